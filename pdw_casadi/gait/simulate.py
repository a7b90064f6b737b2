"""Event-driven simulation of a hybrid walker through any number of steps.

Each phase is integrated with fixed RK4 steps of ``numerics.step_size`` (s), evaluated in
chunks by one CasADi call. When an enabled event function changes sign within a step, the
event time is found by safeguarded Newton on the partial RK4 step (to 1e-13 s), the walker
switches mode or phase there, and integration restarts from the event state. The exact
sequence of full and partial steps is kept as a *plan* so that the Poincare map can replay
the identical discrete map with exact derivatives (:mod:`pdw_casadi.gait.poincare`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pandas as pd

from pdw_casadi.model.hybrid import FAILURE, GUARD, HybridSystem
from pdw_casadi.model.margins import check_key, phase_key
from pdw_casadi.model.problem import Problem, load_problem
from pdw_casadi.model.system import hybrid_system

TAU_TOL = 1e-13  # s, event-time tolerance of the Newton location
#: a state beyond these is a numerical blow-up, not a walker: |coordinate| (rad or m) and
#: |velocity| (rad/s or m/s). A falling walker stays far below (its fall event ends it).
Q_LIMIT, QD_LIMIT = 100.0, 1000.0
#: a step whose energy balance is off by more than ENERGY_TOL_J + ENERGY_RTOL * |E| (J)
#: was not integrated faithfully (normal runs: ~1e-6 J); see :func:`energy_tolerance`
ENERGY_TOL_J, ENERGY_RTOL = 0.05, 1e-3
DIVERGENCE = "numerical_divergence"


def energy_tolerance(*energies: float) -> float:
    """The largest energy-balance residual (J) accepted for a step with these energies."""
    return ENERGY_TOL_J + ENERGY_RTOL * max((abs(e) for e in energies), default=0.0)


@dataclass
class Failure:
    """Why a simulation stopped before completing its steps (a typed result, not a crash).

    ``reason``: e.g. ``fall``, ``toe_scuff``, ``foot1_lift`` (contact force of the wrong
    sign), ``cop1_at_heel`` (centre of pressure outside the foot), ``heel_strike:impulse_toe1``
    (impulse of the wrong sign), ``guard_not_reached``; ``step`` (0-based), ``time`` (s).
    ``numerical_divergence`` is not physical: the states became non-finite or absurd or the
    energy balance broke (the step size is too large for the walker's stiffest mode);
    ``sample_limit``: the recorded trajectory reached ``max_samples``.
    """

    reason: str
    step: int
    time: float
    phase: str
    detail: str = ""

    def to_dict(self) -> dict:
        return {"reason": self.reason, "step": self.step, "time_s": self.time,
                "phase": self.phase, "detail": self.detail}


@dataclass
class Segment:
    """A run of RK4 steps at constant phase and mode: ``n`` full steps of size ``h`` then a
    partial step ``tau`` ending on event ``event`` (index into the phase's events; -1: none)."""

    phase: str
    mode: tuple[float, ...]
    n: int
    h: float
    tau: float
    event: int
    sign: int = 0


@dataclass(frozen=True)
class TransitionItem:
    """A transition taken in a step's plan (its name: a
    :class:`~pdw_casadi.model.hybrid.Transition`'s) and the mode vector the phase it enters
    begins with (None: not recorded)."""

    name: str
    mode_after: tuple[float, ...] | None = None


@dataclass
class Plan:
    """The discrete map of one step: segments and transitions, in order."""

    items: list[Segment | TransitionItem] = field(default_factory=list)

    def transition_after(self, i: int) -> str | None:
        """The name of the transition right after item ``i``, or None (a mode switch)."""
        nxt = self.items[i + 1] if i + 1 < len(self.items) else None
        return nxt.name if isinstance(nxt, TransitionItem) else None


@dataclass
class StepRecord:
    """One walking step (section to section)."""

    index: int
    t_start: float
    phases: list[tuple[str, float]]
    x_section_start: np.ndarray
    x_section_end: np.ndarray | None = None
    step_length: float = float("nan")
    dissipated_damping_J: float = 0.0
    impact_loss_J: float = 0.0
    spring_loss_J: float = 0.0
    energy_start_J: float = float("nan")
    energy_end_J: float = float("nan")
    margins: dict = field(default_factory=dict)
    plan: Plan = field(default_factory=Plan)

    @property
    def step_time(self) -> float:
        return float(sum(d for _, d in self.phases))

    @property
    def energy_residual_J(self) -> float:
        """(E_start - E_end) - (damping work + impact losses + disengagement losses), J."""
        lost = self.dissipated_damping_J + self.impact_loss_J + self.spring_loss_J
        return (self.energy_start_J - self.energy_end_J) - lost

    def to_dict(self) -> dict:
        return {
            "index": self.index, "t_start_s": self.t_start,
            "phases": [{"name": n, "duration_s": d} for n, d in self.phases],
            "step_time_s": self.step_time, "step_length_m": self.step_length,
            "damping_work_J": self.dissipated_damping_J, "impact_loss_J": self.impact_loss_J,
            "spring_disengagement_loss_J": self.spring_loss_J,
            "energy_residual_J": self.energy_residual_J,
        }


EVENT_COLUMNS = ["step", "phase", "event", "t", "kind"]


@dataclass
class SimulationResult:
    """Trajectory (DataFrame), events table, per-step records and the failure, if any."""

    trajectory: pd.DataFrame | None
    # the events table, kept as rows until first read: building a DataFrame costs about
    # as much as simulating a tenth of a step, and Newton / sweeps never read it
    _events: pd.DataFrame | list
    steps: list[StepRecord]
    failure: Failure | None
    state_names: tuple[str, ...]
    final_state: np.ndarray
    final_mode: dict
    #: the mode vector (0/1, order of ``HybridSystem.mode_keys``) of every trajectory row,
    #: rows aligned with ``trajectory``: the joint torques and contact forces of a sample
    #: depend on it (knee springs engaged or not), the exports re-evaluate them
    sample_modes: np.ndarray | None = None

    @property
    def events(self) -> pd.DataFrame:
        """One row per guard, mode switch and failure: step, phase, event, t (s), kind."""
        if not isinstance(self._events, pd.DataFrame):
            self._events = pd.DataFrame(self._events, columns=EVENT_COLUMNS)
        return self._events

    @property
    def completed_steps(self) -> int:
        return sum(1 for s in self.steps if s.x_section_end is not None)

    @property
    def poincare_states(self) -> np.ndarray:
        """Section states at the start of every completed step and after the last (rows)."""
        rows = [self.steps[0].x_section_start] if self.steps else []
        rows += [s.x_section_end for s in self.steps if s.x_section_end is not None]
        return np.array(rows)

    def to_frame(self) -> pd.DataFrame:
        return self.trajectory if self.trajectory is not None else pd.DataFrame()


class TraceChunk(NamedTuple):
    """A run of recorded samples of one phase in one mode: the states as columns."""

    phase: str
    mode_vector: list
    times_s: np.ndarray
    states: np.ndarray  # full states x = [q; qd; W], one column per sample
    step: int


@dataclass
class PhaseEnd:
    """How a phase ended: the state and mode there, its duration (s), the event that ended it
    (None when none did), a failure reason (None for a guard reached) and, for a numerical
    blow-up, what diverged (``failure`` is then :data:`DIVERGENCE`)."""

    x: np.ndarray
    mode: dict
    duration_s: float
    event: object | None
    failure: str | None = None
    divergence: str | None = None


@dataclass
class _PhaseRun:
    """What the phases of one step accumulate, passed from phase to phase (never kept on the
    :class:`Simulator`, so that its calls share no state): the step's index, the energy lost
    where a knee spring disengages (J) and the mode switches seen, (phase, event, t in s)."""

    step: int
    spring_loss: float = 0.0
    switches: list[tuple[str, str, float]] = field(default_factory=list)


@dataclass
class _Step:
    """One step in progress (never kept on the :class:`Simulator`): its record, what its
    phases accumulate, its parameters ``p``, those of the phase its last impact enters
    (``p_next``: the next step's), the damping work at its start (J) and the validity
    margins seen so far (margins-table key -> value)."""

    record: StepRecord
    run: _PhaseRun
    p: np.ndarray
    p_next: np.ndarray
    w0: float = 0.0
    margins: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class _PhaseEvents:
    """The event table of a phase as arrays: arming thresholds, the armed events' indices,
    crossing directions."""

    arm: np.ndarray
    arm_idx: np.ndarray
    direction: np.ndarray

    @classmethod
    def of(cls, evs) -> _PhaseEvents:
        arm = np.array([e.arm_above for e in evs])
        return cls(arm, np.flatnonzero(arm > 0), np.array([e.direction for e in evs]))

    def crossings(self, Gp, G, enabled, armed):
        """Mask (events x steps) of enabled events crossing zero in their direction between
        the columns of Gp (values before each step) and G (after)."""
        a = Gp
        if self.arm_idx.size:
            a = Gp.copy()
            for i in self.arm_idx:
                # an armed event counts only once g has exceeded arm_above in this phase
                seen = np.maximum.accumulate(Gp[i] > self.arm[i]) | armed[i]
                a[i] = np.where(seen, Gp[i], -np.inf if self.direction[i] <= 0 else np.inf)
        down = (a > 0) & (G <= 0)
        up = (a < 0) & (G >= 0)
        d = self.direction[:, None]
        mask = np.where(d < 0, down, np.where(d > 0, up, down | up))
        return mask & enabled[:, None]


class Simulator:
    """Event-driven simulation of one walker; keeps CasADi functions, reused across calls."""

    def __init__(self, problem, hs: HybridSystem | None = None):
        self.problem = problem
        self.hs = hs or hybrid_system(problem)
        self.h = float(problem.numerics["step_size"])
        self.t_max = float(problem.numerics["max_phase_time"])

    # -- one phase -------------------------------------------------------------------------
    def _locate(self, phase, x, p, mv, idx, h, g_lo, g_hi):
        """Smallest tau in (0, h] at which event ``idx`` crosses zero (safeguarded Newton).

        Newton on g(step(x, tau)) with a bracket kept by sign; stops on a tau update below
        :data:`TAU_TOL` after g has changed sign across the bracket (so the root is inside).
        ``g_lo``, ``g_hi``: the event's values at x and one full step later (from the chunk;
        they only seed the first secant guess).
        """
        loc = self.hs.locate[phase].np
        lo, hi = 0.0, h
        tau = h * g_lo / (g_lo - g_hi) if g_lo != g_hi else 0.5 * h
        tau = min(max(tau, 0.0), h)
        for _ in range(100):
            g, dg, _ = loc(x, tau, p, mv)
            g, dg = float(g[idx, 0]), float(dg[idx, 0])
            if g == 0.0:
                return tau
            if (g > 0) == (g_lo > 0):
                lo = tau
            else:
                hi = tau
            new = tau - g / dg if dg != 0 else 0.5 * (lo + hi)
            if not lo <= new <= hi:
                new = 0.5 * (lo + hi)
            if abs(new - tau) < TAU_TOL or hi - lo < TAU_TOL:
                return new
            tau = new
        return tau

    def run_phase(self, phase, x, p, mode, t0, rec, plan,
                  run: _PhaseRun | None = None) -> PhaseEnd:
        """Integrate one phase from x until its guard (:class:`PhaseEnd`).

        ``run``: the step's accumulator (mode switches, disengagement losses); default: a
        fresh one for step 0."""
        run = run if run is not None else _PhaseRun(0)
        hs, h = self.hs, self.h
        evs = hs.event_list[phase]
        mode = hs.refresh_indicators(phase, x, p, mode)
        mv = hs.mode_vector(mode)
        mva = np.array(mv)  # for the compiled calls (a list costs a conversion per call)
        x = np.asarray(x, float).ravel()
        if rec is not None:
            rec.append(TraceChunk(phase, mv, np.array([t0]), x.reshape(-1, 1), run.step))
        enabled = np.array([e.enabled(mode) for e in evs])
        events, step = hs.events[phase].np, hs.step[phase].np
        g_prev = events(x, p, mva).ravel()
        table = _PhaseEvents.of(evs)
        arm = table.arm
        armed = g_prev > arm
        t = 0.0
        n_full = 0
        K = hs.chunk_size
        nq2 = 2 * hs.nq
        chunk = hs.chunk[phase].np
        en = np.flatnonzero(enabled)
        while True:
            X, G = chunk(x, h, p, mva)
            # most chunks cross nothing: if no enabled event's sign (-1, 0, +1) ever differs
            # from its value before the chunk, no crossing is possible (arming only removes
            # crossings); only otherwise build the exact directional, armed test
            Ge = G[en]
            if (np.sign(Ge) == np.sign(g_prev[en])[:, None]).all():
                cols = ()
            else:
                Gp = np.column_stack([g_prev, G[:, :-1]])
                mask = table.crossings(Gp, G, enabled, armed)
                cols = np.flatnonzero(mask.any(axis=0))
            if len(cols) == 0:
                if rec is not None:
                    rec.append(TraceChunk(phase, mv, t0 + t + h * np.arange(1, K + 1), X, run.step))
                x, g_prev = X[:, -1], G[:, -1]
                armed |= (G > arm[:, None]).any(axis=1)
                t += K * h
                n_full += K
                if t > self.t_max:
                    # a blown-up state (NaN compares False) crosses no event: not a walker
                    if not np.abs(x[:nq2]).max() <= Q_LIMIT \
                            and _diverged_column(x[:, None], hs.nq, 0) is not None:
                        return PhaseEnd(x, mode, t, None, DIVERGENCE, _divergence_detail(x, hs))
                    return PhaseEnd(x, mode, t, None, "guard_not_reached")
                continue
            hit_k = int(cols[0])
            hits = np.flatnonzero(mask[:, hit_k])
            x_before = X[:, hit_k - 1] if hit_k > 0 else x
            if rec is not None and hit_k > 0:
                rec.append(TraceChunk(phase, mv, t0 + t + h * np.arange(1, hit_k + 1),
                                      X[:, :hit_k], run.step))
            t += hit_k * h
            n_full += hit_k
            taus = [(self._locate(phase, x_before, p, mva, i, h, float(Gp[i, hit_k]),
                                  float(G[i, hit_k])), int(i)) for i in hits]
            tau, idx = min(taus)
            x_e = step(x_before, tau, p, mva).ravel()
            t += tau
            g_e = events(x_e, p, mva).ravel()
            ev = evs[idx]
            sign = 1 if Gp[idx, hit_k] < 0 else -1  # crossing direction
            if rec is not None:
                rec.append(TraceChunk(phase, mv, np.array([t0 + t]), x_e[:, None], run.step))
            plan.items.append(Segment(phase, tuple(mv), n_full, h, tau, int(idx), sign))
            n_full = 0
            if not np.abs(x_e[:nq2]).max() <= Q_LIMIT \
                    and _diverged_column(x_e[:, None], hs.nq, 0) is not None:
                return PhaseEnd(x_e, mode, t, None, DIVERGENCE, _divergence_detail(x_e, hs))
            if ev.kind == FAILURE:
                return PhaseEnd(x_e, mode, t, ev, ev.name)
            if ev.kind == GUARD:
                if ev.require is not None:
                    req = float(hs.require[phase].np(x_e, p, mva)[idx, 0])
                    if req <= 0:
                        return PhaseEnd(x_e, mode, t, ev, ev.require_reason or f"{ev.name}_invalid")
                return PhaseEnd(x_e, mode, t, ev)
            # SWITCH: new mode, continue the phase from the event state
            mode = hs.mode_after_switch(phase, idx, sign, x_e, p, mode)
            new_mv = hs.mode_vector(mode)
            run.spring_loss += self._spring(x_e, p, mv) - self._spring(x_e, p, new_mv)
            run.switches.append((phase, ev.name, t0 + t))
            mv, mva = new_mv, np.array(new_mv)
            enabled = np.array([e.enabled(mode) for e in evs])
            en = np.flatnonzero(enabled)
            armed |= (Gp[:, : hit_k + 1] > arm[:, None]).any(axis=1)
            g_prev = g_e
            g_prev[idx] = 0.0  # the event just handled must not be found again
            x = x_e

    def _guards_ahead(self, tr, x, p, mode, margins) -> None:
        """The margins of the guards of the phase that ``tr`` enters at its first state ``x``
        (mode ``mode``): how far each enabled one is from its crossing (> 0: not crossed)."""
        ahead = self.hs.guards_ahead[tr.name]
        if not ahead:
            return
        g = self.hs.events[tr.target].np(x, p, np.array(self.hs.mode_vector(mode))).ravel()
        for i, ev, key in ahead:
            if ev.enabled(mode):
                margins[key] = float(-ev.direction * g[i])

    def _spring(self, x, p, mv) -> float:
        return self.hs.energy_at(x, p, mv).spring

    def _energy(self, x, p, mv) -> float:
        return float(np.sum(self.hs.energy.np(x, p, mv)))

    # -- whole steps -----------------------------------------------------------------------
    def run(self, x_section, p, steps: int = 1, record: bool = True,
            mode: dict | None = None, progress=None, margins: bool = False,
            max_samples: int | None = None, p_steps=None,
            p_after=None) -> SimulationResult:
        """Simulate ``steps`` steps from section state ``x_section`` with parameters ``p``.

        ``record``: build the trajectory DataFrame (and the steps' validity margins);
        ``margins``: only the margins (``StepRecord.margins``), without the DataFrame.
        ``max_samples``: stop (failure ``sample_limit``) after the step in which the recorded
        trajectory exceeds this many samples (bounds the memory of long runs).
        A numerical blow-up ends the run with failure ``numerical_divergence``
        (:class:`Failure`), never with a physical failure reason.
        ``p_steps``: a list of parameter vectors used in turn, step k with
        ``p_steps[k % len(p_steps)]`` (a walker whose legs differ: pdw_casadi.gait.stride);
        ``p`` is then ignored. ``p_after``: the parameters of the step that would follow the
        last one (default: the next in turn); the phase a step's last impact enters belongs
        to the next step, so its guards are checked with that step's parameters.
        """
        hs = self.hs
        model = hs.model
        ps = [np.asarray(v, dtype=float).ravel() for v in (p_steps or [p])]
        xs = np.asarray(x_section, dtype=float).ravel()
        x = hs.section_to_full.np(xs, ps[0]).ravel()
        mode = dict(mode or model.initial_mode)
        t = 0.0
        rec = [] if record or margins else None
        event_rows: list[dict] = []
        records: list[StepRecord] = []
        failure = None
        n_samples = n_counted = 0  # recorded samples (for max_samples), entries counted
        for k in range(steps):
            if not np.all(np.isfinite(x)):
                failure = Failure("non_finite_state", k, t, hs.phase_names[0])
                break
            p_next = ps[(k + 1) % len(ps)] if p_after is None or k + 1 < steps \
                else np.asarray(p_after, dtype=float).ravel()
            st = _Step(StepRecord(k, t, [], xs.copy()), _PhaseRun(k), ps[k % len(ps)], p_next)
            records.append(st.record)
            x, mode, t, phase, failure = self._step(st, x, mode, t, rec, event_rows)
            if failure is None:
                failure = self._unbalanced(st.record, t, phase, event_rows)
            if failure is not None:
                break
            xs = st.record.x_section_end
            if progress is not None:
                progress(k + 1)
            if max_samples is not None and rec is not None:
                n_samples += sum(e.states.shape[1] for e in rec[n_counted:])
                n_counted = len(rec)
            if max_samples is not None and rec is not None and k + 1 < steps \
                    and n_samples > max_samples:
                failure = Failure("sample_limit", k, t, phase,
                                  f"the recorded trajectory exceeds {max_samples} samples "
                                  f"after {k + 1} steps; ask for fewer steps")
                event_rows.append({"step": k, "phase": phase, "event": "sample_limit",
                                   "t": t, "kind": "failure"})
                break
        traj = self._trajectory(rec, records, ps) if record else None
        modes = None
        if record and rec:
            modes = np.vstack([np.tile(np.asarray(c.mode_vector, float).reshape(1, hs.nm),
                                       (len(c.times_s), 1)) for c in rec])
        return SimulationResult(traj, event_rows, records, failure, model.state_names, x, mode,
                                sample_modes=modes)

    def _step(self, st: _Step, x, mode, t, rec, event_rows):
        """Step ``st`` from the full state ``x`` at the section (mode ``mode``, time ``t`` in
        s): its phases, each ended by a guard and its transition, until the impact that ends
        the step; fills ``st.record`` (phases, energy balance in J, margins, the section
        state after it). Returns (x, mode, t, phase, failure): after that impact, in the
        phase it enters (failure None), or where the step failed (the state there)."""
        hs = self.hs
        sr, run, p = st.record, st.run, st.p
        phase = hs.phase_names[0]
        mode = hs.refresh_indicators(phase, x, p, mode)
        sr.energy_start_J = self._energy(x, p, hs.mode_vector(mode))
        st.w0 = x[-1]
        while True:
            n_rec = len(rec) if rec is not None else 0
            end = self.run_phase(phase, x, p, mode, t, rec, sr.plan, run)
            mode, dt = end.mode, end.duration_s
            for ph, name, te in run.switches:
                event_rows.append({"step": sr.index, "phase": ph, "event": name, "t": te,
                                   "kind": "switch"})
            run.switches.clear()
            self._phase_margins(phase, rec, n_rec, p, st.margins, t, dt)
            t += dt
            sr.phases.append((phase, dt))
            failure = self._phase_failure(st, end, t, phase, event_rows)
            if failure is not None:
                return end.x, mode, t, phase, failure
            event_rows.append({"step": sr.index, "phase": phase, "event": end.event.name,
                               "t": t, "kind": "guard"})
            tr = hs.transitions[(phase, end.event.name)]
            x_plus, new_mode, failure = self._transition(st, tr, end.x, mode, t, phase)
            if failure is not None:
                return end.x, mode, t, phase, failure
            mode, x, phase = new_mode, x_plus, tr.target
            if tr.ends_step:
                return x, mode, t, phase, None

    def _phase_failure(self, st: _Step, end: PhaseEnd, t, phase, event_rows
                       ) -> Failure | None:
        """The failure phase ``phase`` ended in at time ``t`` (s), added to ``event_rows``;
        None when it reached a guard."""
        fail, ev, divergence = end.failure, end.event, end.divergence
        if fail is not None and ev is not None and ev.kind == FAILURE:
            # a physical failure only counts if the energy balance still holds
            drift = self._drift(st.record, st.run, end.x, st.p, end.mode, st.w0)
            if drift is not None:
                divergence = (f"the energy balance is off by {drift:.3g} J when "
                              f"'{fail}' was reached; {_ADVICE}")
                fail = DIVERGENCE
        if divergence is None and fail is None:
            return None
        detail = divergence if divergence is not None else (ev.description if ev else "")
        event_rows.append({"step": st.record.index, "phase": phase, "event": fail, "t": t,
                           "kind": "failure"})
        return Failure(fail, st.record.index, t, phase, detail)

    def _transition(self, st: _Step, tr, x_end, mode, t, phase):
        """Transition ``tr`` at the guard that ended ``phase`` (state ``x_end``, mode
        ``mode``, time ``t`` in s): its impact (the kinetic energy it takes, J; its checks,
        margins of the step), the mode after it, the margins of the guards ahead in the phase
        it enters; the impact that ends the step closes the step's record. Returns (x, mode,
        failure): the state and mode that phase begins with, or a failure (checks of the
        wrong sign, a mode rule broken) with the state and mode before."""
        hs, sr, p = self.hs, st.record, st.p
        mv = hs.mode_vector(mode)
        if tr.ends_step:
            sr.step_length = float(hs.step_length.np(x_end, p)[0, 0])
        imp = hs.impact_at(tr.name, x_end, p)
        x_plus, chk = imp.x_plus, imp.checks
        at = len(sr.plan.items)
        sr.plan.items.append(TransitionItem(tr.name))
        ke = hs.energy_at(x_end, p, mv)
        ke_post = hs.energy_at(imp.x_post, p, mv).kinetic
        sr.impact_loss_J += ke.kinetic - ke_post
        for name, v in zip(hs.check_names[tr.name], chk, strict=True):
            st.margins[check_key(tr.name, name)] = float(v)
        bad = [n for n, v in zip(hs.check_names[tr.name], chk, strict=True) if v <= 0]
        if bad:
            return x_end, mode, Failure(f"{tr.name}:{bad[0]}", sr.index, t, phase,
                                        "impulse or post-impact velocity of the wrong sign")
        # the phase entered belongs to the next step when the impact ends this one
        # (a per-leg walker: the legs' parameters swap roles there)
        p_enter = st.p_next if tr.ends_step else p
        new_mode = hs.mode_after_transition(tr, x_plus, p_enter, mode)
        if isinstance(new_mode, str):
            return x_end, mode, Failure(new_mode, sr.index, t, phase,
                                        "mode rule broken at " + tr.name)
        sr.plan.items[at] = TransitionItem(tr.name, tuple(hs.mode_vector(new_mode)))
        self._guards_ahead(tr, x_plus, p_enter, new_mode, st.margins)
        st.run.spring_loss += ke.spring - self._spring(x_plus, p, hs.mode_vector(new_mode))
        if tr.ends_step:
            sr.dissipated_damping_J = x_end[-1] - st.w0
            sr.spring_loss_J = st.run.spring_loss
            sr.energy_end_J = ke_post + ke.potential + self._spring(
                x_plus, p, hs.mode_vector(new_mode))
            sr.x_section_end = hs.full_to_section.np(x_plus).ravel()
            sr.margins = st.margins
        return x_plus, new_mode, None

    def _unbalanced(self, sr: StepRecord, t, phase, event_rows) -> Failure | None:
        """A numerical divergence when the completed step's energy balance is off by more
        than :func:`energy_tolerance` (J; the step's section state is then dropped), added
        to ``event_rows``; else None."""
        residual = sr.energy_residual_J
        if abs(residual) <= energy_tolerance(sr.energy_start_J, sr.energy_end_J):
            return None
        sr.x_section_end = None
        event_rows.append({"step": sr.index, "phase": phase, "event": DIVERGENCE, "t": t,
                           "kind": "failure"})
        return Failure(DIVERGENCE, sr.index, t, phase,
                       f"the energy balance of the step is off by {residual:.3g} J; {_ADVICE}")

    def _drift(self, sr, run: _PhaseRun, x, p, mode, w0) -> float | None:
        """The energy-balance residual (J) of the step so far at state ``x`` when it exceeds
        :func:`energy_tolerance`, else None."""
        e_now = self._energy(x, p, self.hs.mode_vector(mode))
        lost = (x[-1] - w0) + sr.impact_loss_J + run.spring_loss
        drift = (sr.energy_start_J - e_now) - lost
        if abs(drift) <= energy_tolerance(sr.energy_start_J, e_now):
            return None
        return float(drift)

    def _phase_margins(self, phase, rec, n_rec, p, margins, t0, dt):
        """Smallest value of each validity margin of a phase (contact forces in N, CoP
        margins and clearances in m), over the samples its
        :class:`~pdw_casadi.model.margins.Margin` counts."""
        if rec is None:
            return
        specs = self.hs.phase_margins[phase]
        entries = rec[n_rec:]
        i = 0
        while i < len(entries):
            # one call for each run of entries in the same mode (not one per chunk)
            ph, mv = entries[i].phase, entries[i].mode_vector
            j = i + 1
            while j < len(entries) and entries[j].phase == ph and entries[j].mode_vector == mv:
                j += 1
            ts = np.concatenate([e.times_s for e in entries[i:j]])
            X = np.hstack([e.states for e in entries[i:j]])
            i = j
            out = self.hs.outputs[ph](X, p, mv).full()
            for row, name, spec in specs:
                vals = out[row][spec.counted(ts, t0, dt)]
                if vals.size:
                    key = phase_key(phase, name)
                    margins[key] = float(min(vals.min(), margins.get(key, math.inf)))

    def _trajectory(self, rec, records, ps) -> pd.DataFrame:
        """The recorded chunks as one table (one row per RK4 sample; a phase's outputs are
        NaN in the rows of phases without them). Built column by column: a DataFrame per
        chunk cost more than the simulation."""
        hs = self.hs
        q_names = _q_names(hs)
        groups: list[list] = []  # consecutive chunks of one phase, step and mode
        for ph, mv, ts, X, k in rec:  # TraceChunk fields
            mode = tuple(np.ravel(mv))
            if groups and groups[-1][0] == (ph, k, mode):
                groups[-1][1].append(ts)
                groups[-1][2].append(X)
            else:
                groups.append([(ph, k, mode), [ts], [X], mv])
        if not groups:
            return pd.DataFrame()
        cols: dict[str, list] = {}
        sizes = []
        for (ph, k, _), tss, Xs, mv in groups:
            ts, X = np.concatenate(tss), np.hstack(Xs)
            n = ts.size
            out = hs.outputs[ph](X, ps[k % len(ps)], mv).full()
            data = {"t": ts, "step": np.full(n, k), "phase": np.full(n, ph, dtype=object)}
            for j, name in enumerate(q_names):
                data[name] = X[j]
                data["d" + name] = X[hs.nq + j]
            data["damping_work_J"] = X[-1]
            for j, name in enumerate(hs.output_names[ph]):
                data[name] = out[j]
            for name in data:
                if name not in cols:  # a column first seen here: NaN in the rows before
                    cols[name] = [np.full(m, np.nan) for m in sizes]
            for name, parts in cols.items():
                parts.append(data[name] if name in data else np.full(n, np.nan))
            sizes.append(n)
        return pd.DataFrame({name: np.concatenate(parts) for name, parts in cols.items()})


_ADVICE = ("a numerical blow-up, not a physical failure: the step size "
           "(numerics.step_size) is too large for the walker's stiffest mode (compliance "
           "values) - reduce it or use less extreme compliance")


def _diverged_column(X, nq: int, last: int) -> int | None:
    """First column <= ``last`` of the states X (columns) that is non-finite or absurd
    (|q| > Q_LIMIT, |qd| > QD_LIMIT), else None."""
    Y = X[: 2 * nq, : last + 1]
    ok = np.isfinite(Y).all(axis=0)
    ok &= (np.abs(Y[:nq]) <= Q_LIMIT).all(axis=0)
    ok &= (np.abs(Y[nq: 2 * nq]) <= QD_LIMIT).all(axis=0)
    if ok.all():
        return None
    return int(np.flatnonzero(~ok)[0])


def _divergence_detail(x, hs) -> str:
    names = _q_names(hs)
    q, qd = x[: hs.nq], x[hs.nq: 2 * hs.nq]
    if not np.isfinite(x).all():
        what = "the state became non-finite"
    else:
        i, j = int(np.argmax(np.abs(q))), int(np.argmax(np.abs(qd)))
        what = (f"absurd state ({names[i]} = {q[i]:.3g}, d{names[j]} = {qd[j]:.3g}; limits "
                f"|q| <= {Q_LIMIT:g}, |dq| <= {QD_LIMIT:g})")
    return f"{what}; {_ADVICE}"


def _q_names(hs) -> list[str]:
    names = hs.model.q_names
    return list(names) if names else [f"q{i}" for i in range(hs.nq)]


def simulate(problem, steps: int = 1, state=None, parameters=None, record: bool = True,
             progress=None) -> SimulationResult:
    """Simulate ``steps`` steps of ``problem``'s walker from its initial section state.

    Args:
        problem: a :class:`~pdw_casadi.model.problem.Problem` (or a bundled name / path).
        steps: number of steps (section to section).
        state: section state (rad, rad/s) in the problem's state order; default: the problem's.
        parameters: compliance + slope vector; default: the problem's.
        record: keep the full trajectory DataFrame (off for speed in Newton / sweeps).
    """
    if not isinstance(problem, Problem):
        problem = load_problem(problem)
    sim = Simulator(problem)
    x0 = problem.state_vector() if state is None else state
    p = problem.parameter_vector() if parameters is None else parameters
    return sim.run(x0, p, steps=steps, record=record, progress=progress)
