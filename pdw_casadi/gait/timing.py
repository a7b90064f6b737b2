"""Gait-phase timing of a walker: stance, swing, double support, cadence and gait events.

The timing follows from the phase durations of the simulator's steps and from which part of
each foot touches the ground in each phase. A walker family declares the latter as
``phase_contacts`` (registry): phase name -> (contact of leg 1, contact of leg 2), each one of
``"flat"`` (the whole sole), ``"heel"``, ``"toe"``, ``"point"`` (a point foot) or None (in
the air). Leg 1 is the stance (leading) leg at the start of a step (docs/model.md); one
physical leg (A) is leg 1 in one step and leg 2 in the next, so two steps make a gait cycle,
which starts at A's heel strike (the instant its contact goes from None to a contact).

Gait events of leg A, in % of the cycle: heel strike (0), foot flat (first "flat" contact;
None for walkers without flat feet), heel off (first "toe" contact after "flat"; None
without flat feet), toe off (end of stance). Double support: every interval in which both
legs touch the ground (at a symmetric gait: loading response, then pre-swing).

Human reference values (:data:`HUMAN_NORMS`) are those of normal adult free walking in
J. Perry and J. M. Burnfield, *Gait Analysis: Normal and Pathological Function*, 2nd ed.,
SLACK, 2010 (ch. 1-2: phases of the gait cycle; ch. 4: stride analysis). A gait-curve file
may carry its own values as constant optional columns (see :func:`human_timing`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from pdw_casadi.engine.errors import TimingError
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.walkers import get_family

#: Perry & Burnfield (2010), normal adult free walking: stance 60 %, swing 40 %, initial and
#: terminal double support 10 % each, heel off (onset of terminal stance) at about 31 %, toe
#: off 60 %; foot flat is taken at the end of loading response (10 %, an upper estimate: the
#: forefoot lands within it); women's free cadence 117 steps/min, speed 1.28 m/s (77 m/min)
HUMAN_NORMS: Mapping[str, float] = {
    "stance_pct": 60.0, "swing_pct": 40.0, "double_support_initial_pct": 10.0,
    "double_support_terminal_pct": 10.0, "double_support_total_pct": 20.0,
    "foot_flat_pct": 10.0, "heel_off_pct": 31.0, "toe_off_pct": 60.0,
    "cadence_steps_min": 117.0, "speed_m_s": 1.28,
}
HUMAN_NORMS_SOURCE = ("Perry & Burnfield, Gait Analysis: Normal and Pathological Function, "
                      "2nd ed. (2010), normal adult free walking")

#: units of the GaitTiming fields
UNITS = {"step_time_s": "s", "cycle_time_s": "s", "step_length_m": "m",
         "stride_length_m": "m", "speed_m_s": "m/s", "cadence_steps_min": "steps/min",
         "stance_pct": "% of cycle", "swing_pct": "% of cycle",
         "double_support_pct": "% of cycle (each period, from heel strike on)",
         "double_support_total_pct": "% of cycle", "single_support_pct": "% of cycle",
         "heel_strike_pct": "% of cycle", "foot_flat_pct": "% of cycle",
         "heel_off_pct": "% of cycle", "toe_off_pct": "% of cycle",
         "stance_s": "s", "swing_s": "s", "double_support_s": "s",
         "phase_durations_s": "s"}


@dataclass(frozen=True)
class GaitTiming:
    """Timing of one gait cycle (two steps) of a walker; fields in the units of :data:`UNITS`.

    ``double_support_pct``: each double-support period in cycle order starting at heel
    strike (a symmetric 6-link gait: loading response, then pre-swing); empty for walkers
    whose feet exchange support instantly (point feet). ``foot_flat_pct`` and
    ``heel_off_pct`` are None for walkers without flat feet.
    """

    step_time_s: float
    cycle_time_s: float
    step_length_m: float
    cadence_steps_min: float
    speed_m_s: float
    stance_pct: float
    swing_pct: float
    double_support_pct: tuple[float, ...]
    heel_strike_pct: float
    foot_flat_pct: float | None
    heel_off_pct: float | None
    toe_off_pct: float
    stance_s: float
    swing_s: float
    double_support_s: tuple[float, ...]
    phase_durations_s: tuple[tuple[str, float], ...] = field(default=())
    #: length of the cycle's other step (m); None: equal to ``step_length_m``
    next_step_length_m: float | None = None

    @property
    def double_support_total_pct(self) -> float:
        return float(sum(self.double_support_pct))

    @property
    def single_support_pct(self) -> float:
        return self.stance_pct - self.double_support_total_pct

    @property
    def stride_length_m(self) -> float:
        other = self.step_length_m if self.next_step_length_m is None else (
            self.next_step_length_m)
        return self.step_length_m + other

    def to_dict(self) -> dict:
        """Plain values plus a ``units`` table (JSON-ready)."""
        d = {k: getattr(self, k) for k in (
            "step_time_s", "cycle_time_s", "step_length_m", "stride_length_m",
            "cadence_steps_min", "speed_m_s", "stance_pct", "swing_pct",
            "single_support_pct", "double_support_total_pct", "heel_strike_pct",
            "foot_flat_pct", "heel_off_pct", "toe_off_pct", "stance_s", "swing_s")}
        d["double_support_pct"] = list(self.double_support_pct)
        d["double_support_s"] = list(self.double_support_s)
        d["phase_durations_s"] = dict(self.phase_durations_s)
        d["units"] = dict(UNITS)
        return d

    def markers(self) -> dict[str, float]:
        """Gait events that exist for this walker: label -> % of the cycle (for plots)."""
        out = {"toe off": self.toe_off_pct}
        if self.foot_flat_pct is not None:
            out = {"foot flat": self.foot_flat_pct, "heel off": self.heel_off_pct, **out}
        return out


def phase_contacts(family: str) -> Mapping[str, tuple[str | None, str | None]]:
    """The walker family's ``phase_contacts`` (see the module docstring)."""
    contacts = get_family(family).phase_contacts
    if not contacts:
        raise TimingError(f"walker family {family!r} declares no phase_contacts")
    return contacts


def gait_timing(phases: Sequence[tuple[str, float]], step_length: float,
                contacts: Mapping[str, tuple[str | None, str | None]],
                next_phases: Sequence[tuple[str, float]] | None = None,
                next_step_length: float | None = None) -> GaitTiming:
    """Timing of the gait cycle of the physical leg that is leg 1 in the step ``phases``
    ((phase, duration s) in order, as :attr:`StepRecord.phases`) and leg 2 in
    ``next_phases`` (default: the same step again, a symmetric periodic gait).

    ``step_length`` (m) of the step, ``next_step_length`` (m) of the next (default: the
    same); ``contacts``: the walker's phase_contacts.
    """
    nxt = list(phases if next_phases is None else next_phases)
    for name, _ in [*phases, *nxt]:
        if name not in contacts:
            raise TimingError(f"phase {name!r} has no entry in phase_contacts "
                              f"({', '.join(contacts)})")
    # (duration, contact of leg A, contact of leg B) over the two steps
    segs = [(float(d), contacts[n][0], contacts[n][1]) for n, d in phases]
    segs += [(float(d), contacts[n][1], contacts[n][0]) for n, d in nxt]
    segs = [s for s in segs if s[0] > 0]
    n = len(segs)
    # the cycle starts at A's heel strike: the first segment in contact after one in the air
    start = next((i for i in range(n) if segs[i][1] is not None
                  and segs[i - 1][1] is None), None)
    if start is None:
        raise TimingError("leg A never lands (no swing followed by a contact in the two "
                          "steps)")
    segs = segs[start:] + segs[:start]
    T = sum(s[0] for s in segs)
    t_step = sum(float(d) for _, d in phases)
    t = 0.0
    stance = 0.0
    foot_flat = heel_off = toe_off = None
    ds, ds_now = [], None
    was_flat = False
    for d, a, b in segs:
        if a is not None:
            stance += d
            if a == "flat" and foot_flat is None:
                foot_flat = t
            if a == "toe" and was_flat and heel_off is None:
                heel_off = t
            was_flat = was_flat or a == "flat"
        elif toe_off is None:
            toe_off = t
        if a is not None and b is not None:
            ds_now = (ds_now or 0.0) + d
        elif ds_now is not None:
            ds.append(ds_now)
            ds_now = None
        t += d
    if ds_now is not None:
        ds.append(ds_now)

    def pct(x):
        return None if x is None else 100.0 * x / T

    stride = float(step_length) + float(step_length if next_step_length is None
                                        else next_step_length)
    return GaitTiming(
        step_time_s=t_step, cycle_time_s=T, step_length_m=float(step_length),
        cadence_steps_min=60.0 * 2.0 / T if T > 0 else math.nan,
        speed_m_s=stride / T if T > 0 else math.nan,
        stance_pct=pct(stance), swing_pct=pct(T - stance),
        double_support_pct=tuple(pct(x) for x in ds), heel_strike_pct=0.0,
        foot_flat_pct=pct(foot_flat), heel_off_pct=pct(heel_off),
        toe_off_pct=pct(toe_off if toe_off is not None else T),
        stance_s=stance, swing_s=T - stance, double_support_s=tuple(ds),
        phase_durations_s=tuple((name, float(d)) for name, d in phases),
        next_step_length_m=None if next_step_length is None else float(next_step_length))


def timing_or_none(compute):
    """``compute()`` (a gait timing), or None for a walker that declares no timing."""
    try:
        return compute()
    except TimingError:
        return None


def step_timing(family: str, step, next_step=None) -> GaitTiming:
    """:func:`gait_timing` of a simulated :class:`~pdw_casadi.gait.simulate.StepRecord` (and the
    next one; default: the step itself twice, as at a fixed point)."""
    if next_step is None:
        return gait_timing(step.phases, step.step_length, phase_contacts(family))
    return gait_timing(step.phases, step.step_length, phase_contacts(family),
                       next_step.phases, next_step.step_length)


def simulation_timing(family: str, result) -> dict:
    """Timing of a simulation: ``per_step`` (each completed step as if repeated) and
    ``cycles`` (consecutive pairs of completed steps), as dicts; empty lists without a
    completed step."""
    done = [s for s in result.steps if s.x_section_end is not None]
    per_step = [step_timing(family, s).to_dict() for s in done]
    cycles = [step_timing(family, a, b).to_dict() for a, b in zip(done[::2], done[1::2],
                                                                     strict=False)]
    return {"per_step": per_step, "cycles": cycles}


def fixed_point_timing(problem, state, parameters, sim=None) -> GaitTiming | None:
    """Timing of the periodic gait through section state ``state`` (one step simulated from
    it); None when that step fails."""
    sim = sim or Simulator(problem)
    run = sim.run(state, parameters, steps=1, record=False)
    if run.failure is not None or not run.steps:
        return None
    return step_timing(problem.family, run.steps[0])


#: optional constant columns of a gait-curve file that give the subject's own timing (%)
CURVE_TIMING_COLUMNS = ("stance_pct", "toe_off_pct", "double_support_initial_pct",
                        "double_support_terminal_pct", "foot_flat_pct", "heel_off_pct",
                        "cadence_steps_min", "speed_m_s")


def human_timing(human=None) -> tuple[dict[str, float], str]:
    """Human timing to compare with: the norms of :data:`HUMAN_NORMS`, overridden by the
    gait-curve file's own optional constant columns (``toe_off_pct``, ``stance_pct``, ...,
    :data:`CURVE_TIMING_COLUMNS`, same value in every row). Returns (values, source)."""
    values = dict(HUMAN_NORMS)
    source = HUMAN_NORMS_SOURCE
    frame = getattr(human, "frame", None)
    own = {}
    if frame is not None:
        for col in CURVE_TIMING_COLUMNS:
            if col in frame.columns:
                v = frame[col].dropna()
                if len(v) and float(v.max()) - float(v.min()) < 1e-9:
                    own[col] = float(v.iloc[0])
    if own:
        values.update(own)
        if "toe_off_pct" in own and "stance_pct" not in own:
            values["stance_pct"] = own["toe_off_pct"]
        if "stance_pct" in own and "toe_off_pct" not in own:
            values["toe_off_pct"] = own["stance_pct"]
        values["swing_pct"] = 100.0 - values["stance_pct"]
        name = getattr(human, "source", "the gait file")
        source = f"{name} (columns {', '.join(own)}); the rest: {HUMAN_NORMS_SOURCE}"
    return values, source


#: rows of the timing table: (label, GaitTiming attribute or function, human-norm key)
_ROWS = (
    ("stance (% cycle)", "stance_pct", "stance_pct"),
    ("swing (% cycle)", "swing_pct", "swing_pct"),
    ("double support, loading (% cycle)", lambda t: _ds(t, 0), "double_support_initial_pct"),
    ("double support, pre-swing (% cycle)", lambda t: _ds(t, 1), "double_support_terminal_pct"),
    ("foot flat (% cycle)", "foot_flat_pct", "foot_flat_pct"),
    ("heel off (% cycle)", "heel_off_pct", "heel_off_pct"),
    ("toe off (% cycle)", "toe_off_pct", "toe_off_pct"),
    ("cadence (steps/min)", "cadence_steps_min", "cadence_steps_min"),
    ("speed (m/s)", "speed_m_s", "speed_m_s"),
    ("step length (m)", "step_length_m", None),
)


def _ds(t: GaitTiming, i: int):
    return t.double_support_pct[i] if len(t.double_support_pct) > i else 0.0


def timing_table(columns: Mapping[str, GaitTiming | None], human=None) -> str:
    """A markdown table: one column per gait (label -> timing), then the human values."""
    norms, source = human_timing(human)
    labels = list(columns)
    lines = ["| timing | " + " | ".join(labels) + " | human |",
             "|---" * (len(labels) + 2) + "|"]

    def f(v):
        return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) \
            else f"{v:.3g}" if abs(v) < 10 else f"{v:.1f}"

    for label, attr, key in _ROWS:
        vals = []
        for t in columns.values():
            if t is None:
                vals.append("-")
                continue
            vals.append(f(attr(t) if callable(attr) else getattr(t, attr)))
        lines.append(f"| {label} | " + " | ".join(vals) + f" | {f(norms.get(key))} |")
    return "\n".join(lines) + f"\n\nHuman: {source}.\n"
