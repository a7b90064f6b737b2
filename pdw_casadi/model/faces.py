"""What the walker-agnostic layers (plots, curves, reports, CLI) need to know of a walker.

Phase names, transitions, leg coordinates and joint outputs all come from the walker: the
phases and transitions from its :class:`~pdw_casadi.model.hybrid.WalkerModel`, the rest from its
registered :class:`~pdw_casadi.model.walkers.registry.Family`:

- ``phase_descriptions``: phase name -> a few words (figure captions);
- ``limit_cycle_legs``: the coordinates of one physical leg, per segment, in step 0 (where
  it is leg 1, the stance leg) and in step 1 (leg 2, the swing leg), e.g.
  ``(("q1", "q2"), ("q4", "q3"))`` for (shank, thigh); ``leg_segments`` names the segments;
- ``curve_joints``: the joints with ``<joint>1_deg`` / ``<joint>2_deg`` outputs that mean
  something (a rigid-legged walker has no knee); the gait-curve fit needs knee and hip;
- ``instant_labels``: transition name -> label of the instant in the limit-cycle figure
  (the 6-link walker uses the paper's a/b/c of Fig. 4); default: the transition name;
- ``comparison_problem``: a bundled problem that a fit report compares against;
- ``paper_reported_r2``: R^2 values a publication reports for this walker (fit report).

Nothing here names a particular walker's phases.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import pandas as pd

from pdw_casadi.model.system import hybrid_system
from pdw_casadi.model.walkers import get_family

#: phase shading colours, assigned in the model's phase order
PALETTE = ("#d8e6f3", "#f4f4f4", "#f6e3cf", "#e0f0dc", "#efe0f3", "#f3f0d0")
PALETTE_NAMES = ("blue", "grey", "orange", "green", "violet", "yellow")


@dataclass(frozen=True)
class TransitionFace:
    """A transition as the plots see it: its name, phases, whether it is an impact
    (velocities jump: two marks, before and after) and whether it ends the step."""

    name: str
    source: str
    target: str
    impact: bool
    ends_step: bool


@dataclass(frozen=True)
class WalkerFaces:
    """Names and conventions of one walker for plots, curves and reports (module doc)."""

    family: str
    phases: tuple[str, ...]
    phase_descriptions: Mapping[str, str] = field(default_factory=dict)
    transitions: tuple[TransitionFace, ...] = ()
    legs: tuple[tuple[str, ...], ...] = ()
    leg_segments: tuple[str, ...] = ()
    joints: tuple[str, ...] = ("knee", "hip")
    instant_labels: Mapping[str, str] = field(default_factory=dict)
    heel_strike_phase: str | None = None
    comparison_problem: str | None = None
    paper_reported: Mapping[str, float] | None = None

    def phase_color(self, phase: str) -> str:
        if phase in self.phases:
            return PALETTE[self.phases.index(phase) % len(PALETTE)]
        return "#eeeeee"

    def phase_caption(self) -> str:
        """E.g. ``"phase I (blue, leading foot flat ...), II (grey, ...)"``."""
        parts = []
        for i, ph in enumerate(self.phases):
            desc = self.phase_descriptions.get(ph, "")
            colour = PALETTE_NAMES[i % len(PALETTE_NAMES)]
            parts.append(f"{ph} ({colour}{', ' + desc if desc else ''})")
        return "phases " + ", ".join(parts) if len(parts) > 1 else \
            ("phase " + parts[0] if parts else "")

    def transition_from(self, phase: str, target: str | None = None) -> TransitionFace | None:
        """The transition leaving ``phase`` (into ``target`` when given: a phase may end
        in several, e.g. heel strike or heel off)."""
        return next((t for t in self.transitions if t.source == phase
                     and (target is None or t.target == target)), None)

    def instant_label(self, transition: str) -> str:
        return self.instant_labels.get(transition, transition)

    @property
    def section_transition(self) -> TransitionFace | None:
        return next((t for t in self.transitions if t.ends_step), None)

    @property
    def has_gait_curves(self) -> bool:
        """True when the walker has knee and hip outputs (a gait-curve fit is possible)."""
        return "knee" in self.joints and "hip" in self.joints


def walker_faces(problem, hs=None) -> WalkerFaces:
    """The faces of ``problem``'s walker (its hybrid system is built if not given)."""
    hs = hs or hybrid_system(problem)
    model = hs.model
    fam = get_family(problem.family)
    transitions = tuple(
        TransitionFace(tr.name, tr.source, tr.target, int(tr.impulse.numel()) > 0,
                       bool(tr.ends_step))
        for tr in model.transitions)
    return WalkerFaces(
        family=problem.family,
        phases=tuple(ph.name for ph in model.phases),
        phase_descriptions=dict(fam.phase_descriptions),
        transitions=transitions,
        legs=tuple(tuple(leg) for leg in fam.limit_cycle_legs),
        leg_segments=tuple(fam.leg_segments),
        joints=tuple(fam.curve_joints),
        instant_labels=dict(fam.instant_labels),
        heel_strike_phase=model.heel_strike_phase,
        comparison_problem=fam.comparison_problem,
        paper_reported=fam.paper_reported_r2,
    )


def faces_from_trajectory(trajectory: pd.DataFrame | None) -> WalkerFaces:
    """Faces read off a trajectory alone (phases in order of appearance, joints from the
    columns), for plots called without a walker."""
    phases: list[str] = []
    joints: tuple[str, ...] = ()
    if trajectory is not None and not trajectory.empty:
        for ph in trajectory["phase"].astype(str):
            if ph not in phases:
                phases.append(ph)
        joints = tuple(j for j in ("knee", "hip") if f"{j}1_deg" in trajectory)
    return WalkerFaces(family="", phases=tuple(phases), joints=joints)
