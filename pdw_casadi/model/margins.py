"""Validity margins: what a walker's gait pattern needs, declared once and evaluated once.

A *margin* is a named quantity of the walker that must stay above a requirement for the
assumed gait pattern to hold: a contact normal force, a centre-of-pressure distance from the
foot's ends, the swing foot's clearance, an impulse at an impact. The walker declares each
as a :class:`Margin` (its kind, the ``[validity]`` key of its required minimum, its unit and
from which fraction of its phase it counts); :class:`~pdw_casadi.model.hybrid.HybridSystem`
collects them, and the simulator (the orbit's smallest values), the shooting NLP (its
constraints) and the validity check of fixed points all read them from there.

A walker that declares nothing gets its margins from its output names
(:func:`output_margin`, :func:`check_margin`): ``N_*`` normal forces, ``copmargin_*``
centre-of-pressure margins, ``arcmargin_*`` a rolling foot's contact inside its arc,
``clearance_*`` clearances (after 20 % of the phase: a swing
foot that just lifted off starts on the ground), ``impulse*`` impact checks. That naming
rule lives here only.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum

import casadi as ca
import numpy as np


class MarginKind(StrEnum):
    """What a margin measures."""

    NORMAL_FORCE = "normal_force"  # N
    COP = "cop"  # m, centre of pressure inside the foot
    CLEARANCE = "clearance"  # m, swing foot above the ground
    IMPULSE = "impulse"  # N s (or m for an impulse's centre of pressure), at an impact
    ARC = "arc"  # rad, a rolling foot's contact inside its arc's span
    GUARD_AHEAD = "guard_ahead"  # the guard's unit: a phase's guard not yet crossed at its start


@dataclass(frozen=True)
class Margin:
    """A validity margin of the walker.

    ``requirement``: the ``[validity]`` key of the problem file holding its minimum (None:
    no configurable minimum, the margin must be > 0); ``unit``: its unit; ``active_after``:
    fraction of its phase after which it counts (0: from the phase's start); ``nlp_slack``:
    how far beyond the minimum an NLP keeps the margin (in ``unit``), so that a binding
    margin still passes the simulator's check: the NLP samples the margin on its own RK4
    grid, the simulator on a different one, and IPOPT's answer is feasible to about 1e-8.
    """

    kind: MarginKind
    requirement: str | None
    unit: str
    active_after: float = 0.0
    nlp_slack: float = 1e-6

    def minimum(self, validity: Mapping[str, float]) -> float:
        """The required minimum (in ``unit``) under the problem's ``[validity]`` table."""
        return float(validity.get(self.requirement, 0.0)) if self.requirement else 0.0

    def violation(self, key: str, value: float, validity: Mapping[str, float]) -> str | None:
        """Why ``value`` breaks this margin (a message naming ``key``), or None."""
        if self.kind == MarginKind.GUARD_AHEAD:
            return (f"{key} = {value:.3g} < 0: the guard is already crossed when its phase "
                    "begins (the phase would end at once)") if value < -GUARD_ROUNDOFF \
                else None
        if self.requirement is None:
            return f"{key} = {value:.3g} <= 0" if value <= 0 else None
        need = self.minimum(validity)
        if value - need < 0:
            return f"{key} = {value:.3g} {self.unit} < {need} {self.unit}"
        return None

    def counted(self, t, t0: float, duration: float) -> np.ndarray:
        """Which sample times ``t`` (s) of a phase starting at ``t0`` lasting ``duration``
        (s) count toward the margin (boolean mask)."""
        t = np.asarray(t)
        if self.active_after <= 0:
            return np.ones(t.shape, bool)
        return t >= t0 + self.active_after * duration

    def demand(self, elapsed, duration, need):
        """The NLP's demand (CasADi) at time ``elapsed`` into a phase lasting ``duration``:
        ``need`` from ``active_after`` on, ramped up from 0 over the last tenth before it, so
        that the constraint stays continuous in the segment durations."""
        if self.active_after <= 0:
            return need
        frac = elapsed / (self.active_after * duration)
        return need * ca.fmax(0, ca.fmin(1, 10 * frac - 9))


NORMAL_FORCE = Margin(MarginKind.NORMAL_FORCE, "min_normal_force", "N")
#: lengths held 0.01 mm beyond their minimum by an NLP: between two checked samples d apart
#: a smooth margin can dip below both by up to d^2/8 |a| (d: two NLP RK4 steps, up to 2.5
#: simulator steps: 1.25 ms at the bundled 0.5 ms; a centre of pressure accelerating at
#: 20 m/s^2 then dips 4 micrometres, at 50 m/s^2 10)
COP = Margin(MarginKind.COP, "min_cop_margin", "m", nlp_slack=1e-5)
CLEARANCE = Margin(MarginKind.CLEARANCE, "min_clearance", "m", active_after=0.2,
                   nlp_slack=1e-5)
IMPULSE = Margin(MarginKind.IMPULSE, None, "N s")
#: where an impulse acts on a foot, as a distance from the foot's end (must be > 0)
IMPULSE_COP = Margin(MarginKind.IMPULSE, None, "m")
#: a rolling foot's contact angle short of its arc's span (must be > 0)
ARC_SPAN = Margin(MarginKind.ARC, None, "rad")

#: a phase's guard on its side before the crossing when the phase begins (must be > 0): a
#: contact whose normal force is already negative right after an impact would open at once,
#: so the phase it closes has no duration (the trailing toe pulling the ground at foot strike)
GUARD_AHEAD = Margin(MarginKind.GUARD_AHEAD, None, "")
#: a guard that is zero at its phase's start by construction (a straight knee's knee-strike
#: guard right after heel strike) evaluates to rounding noise there: the phase still runs,
#: since the simulator fires a guard only when it crosses from its near side
GUARD_ROUNDOFF = 1e-9

#: the default naming rule: output-name prefix -> margin (phase outputs)
OUTPUT_PREFIXES = (("N_", NORMAL_FORCE), ("copmargin_", COP), ("clearance_", CLEARANCE),
                   ("arcmargin_", ARC_SPAN))
#: transition checks whose name starts so are validity margins (others, such as a foot's
#: rise speed after an impact, are sign conditions of the impact only)
CHECK_PREFIXES = (("impulse", IMPULSE),)


def output_margin(name: str) -> Margin | None:
    """The margin a phase output named ``name`` carries under the naming rule, or None."""
    return next((m for prefix, m in OUTPUT_PREFIXES if name.startswith(prefix)), None)


def check_margin(name: str) -> Margin | None:
    """The margin an impact check named ``name`` carries under the naming rule, or None."""
    return next((m for prefix, m in CHECK_PREFIXES if name.startswith(prefix)), None)


def ahead_name(event: str) -> str:
    """The check name of the guard ``event``'s :data:`GUARD_AHEAD` margin at a transition."""
    return f"{event}_ahead"


def phase_key(phase: str, output: str) -> str:
    """The key of a phase output's margin in a step's ``margins`` table (its minimum)."""
    return f"{phase}:min_{output}"


def check_key(transition: str, check: str) -> str:
    """The key of an impact check's margin in a step's ``margins`` table."""
    return f"{transition}:{check}"


def leg_key(side: str, key: str) -> str:
    """The key of one step's margin ``key`` in a stride's table: the step's stance leg
    (``left`` or ``right``) first, ``left.II:min_N_foot1`` (step keys hold no dot)."""
    return f"{side}.{key}"


def spec_of(key: str, specs: Mapping[str, Margin]) -> Margin | None:
    """The margin spec of a margins-table key: a step's key, or a stride's (:func:`leg_key`),
    whose spec is that of the step's key; None for a key that is no validity margin."""
    if key in specs:
        return specs[key]
    _, dot, step_key = key.partition(".")
    return specs.get(step_key) if dot else None


def slacks(margins: Mapping[str, float], specs: Mapping[str, Margin],
           validity: Mapping[str, float]) -> dict[str, float]:
    """Each margin of ``margins`` with a spec in ``specs`` (step or stride keys), minus its
    required minimum."""
    return {k: float(v) - m.minimum(validity) for k, v in margins.items()
            if (m := spec_of(k, specs)) is not None}


def first_violation(margins: Mapping[str, float], specs: Mapping[str, Margin],
                    validity: Mapping[str, float]) -> str | None:
    """The first margin of ``margins`` below its requirement (a message), or None."""
    for k, v in margins.items():
        if (m := spec_of(k, specs)) is not None and (why := m.violation(k, float(v), validity)):
            return why
    return None
