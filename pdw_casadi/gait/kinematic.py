"""A kinematic guess of one walking step from human gait curves.

For the shooting NLP of a gait the simulator has not found yet (a walker's first gait with a
prescribed gait pattern, :class:`~pdw_casadi.nlp.shooting.ShootingNLP` with ``segments`` and
``nodes``), the walker's full states at the instants of each phase of the pattern, built from
the human curves instead of from a simulation:

- **postures**: at each instant the generalized coordinates whose joint angles (knee and
  thigh of both legs, deg) come closest to the human curves at that leg's point of the gait
  cycle (:func:`~pdw_casadi.gait.curves.cycle_time`, docs/model.md), subject to the phase's
  contacts held where they were when the phase began (a contact set's rows are defined up to
  a constant) and, at a phase's last instant, to its ending guard where that guard is a
  function of the posture alone (a heel reaching the ground; a guard on a contact force is
  left to the NLP). A pull of weight ``pull`` towards the previous instant's posture (its
  coordinates in deg) settles what the curves leave open (the swing foot, the toes) and
  shares a guard's demand among all coordinates (without it the free swing foot alone would
  turn to put its heel down). The first phase's contacts are held where the walker's own
  section state puts them (its initial state: feet on the ground); a later phase begins at
  the posture where the last one ended (a transition keeps the posture);
- **velocities**: central differences of the postures within the phase, projected onto the
  phase's contacts (the least change that keeps every contact at rest); where a phase
  begins at the transition of the one before, the state the transition makes (an impact's
  velocities);
- the damper work W: 0.

In single support, where both legs' knee and thigh are free, the postures reproduce the
curves up to the pull's bias (about ``pull`` times the change between instants) away from a
guard's instant. The guess is not a
motion of the walker: its continuity rows are what the NLP then closes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np

from pdw_casadi.gait.curves import CURVE_TARGETS, cycle_time

#: the largest violation (m, rad) of a posture's contact and guard rows
POSTURE_TOL = 1e-10
#: the curves the postures follow (:data:`~pdw_casadi.gait.curves.CURVE_TARGETS`): knee and
#: thigh, both legs' segment angles whichever the walker's hip convention
GUESS_TARGETS = ("knee", "thigh")


@dataclass(frozen=True)
class GuessPhase:
    """One phase of a prescribed gait pattern: its name, its duration (s), the number of
    instants at which the guess is wanted (both ends included, at least 2), and the name of
    the event that ends it (None: nothing held at its last instant)."""

    phase: str
    duration: float
    n_nodes: int
    guard: str | None = None


class KinematicGuess:
    """The guess's machinery for one walker (its hybrid system ``hs``): per phase, the
    contact rows and their Jacobian, and the small NLP of one posture (built once per phase
    and ending guard, solved at every instant)."""

    def __init__(self, hs, targets: Sequence[str] = GUESS_TARGETS, pull: float = 1e-2):
        self.hs, self.model = hs, hs.model
        unknown = [t for t in targets if t not in CURVE_TARGETS]
        if unknown:
            raise ValueError(f"unknown target {unknown[0]!r} (one of {', '.join(CURVE_TARGETS)})")
        self.targets, self.pull = tuple(targets), float(pull)
        sysm = self.model.system
        self.q, self.p = sysm.q, self.model.p
        self.nq = self.q.shape[0]
        self._solvers: dict = {}
        self._contacts: dict = {}

    def contacts(self, phase: str) -> ca.Function:
        """(q, p) -> (the phase's contact rows (m, rad), their Jacobian in q)."""
        if phase not in self._contacts:
            rows = self.hs.phases[phase].contact.rows
            self._contacts[phase] = ca.Function(f"contacts_{phase}", [self.q, self.p],
                                                [rows, ca.jacobian(rows, self.q)])
        return self._contacts[phase]

    def _angles(self, phase: str) -> tuple[ca.SX, list[str]]:
        """The targets' output expressions (deg) of both legs in q (x with qd = 0, W = 0)."""
        names = self.hs.output_names[phase]
        want = [f"{CURVE_TARGETS[t][0]}{leg}_deg" for t in self.targets for leg in (1, 2)]
        missing = [n for n in want if n not in names]
        if missing:
            raise ValueError(f"walker {self.model.name!r} has no outputs {missing} in phase "
                             f"{phase}")
        outs = {**self.model.common_outputs, **self.hs.phases[phase].outputs}
        sysm = self.model.system
        y = ca.vertcat(*[outs[n] for n in want])
        # the angles of a posture: at rest, whatever the mode
        y = ca.substitute(y, ca.vertcat(sysm.qd, self.model.m),
                          ca.SX.zeros(sysm.qd.shape[0] + self.model.m.shape[0]))
        return y, want

    def _posture_guard(self, phase: str, guard: str | None) -> ca.SX | None:
        """The ending guard's expression in q when it depends on the posture alone."""
        if guard is None:
            return None
        events = {e.name: e for e in self.hs.event_list[phase]}
        if guard not in events:
            raise ValueError(f"phase {phase} has no event {guard!r}")
        expr = events[guard].expr
        rest = ca.vertcat(self.model.system.qd, self.model.m)
        return None if ca.depends_on(expr, rest) else expr

    def solver(self, phase: str, guard: str | None):
        """The posture NLP of ``phase`` (with its ending ``guard`` held when posture-only):
        parameters (targets (deg), previous posture (rad, m), contact rows' values (m,
        rad), p (SI))."""
        key = (phase, guard)
        if key not in self._solvers:
            y, _ = self._angles(phase)
            rows = self.hs.phases[phase].contact.rows
            ystar = ca.SX.sym("ystar", y.shape[0])
            qprev = ca.SX.sym("qprev", self.nq)
            c0 = ca.SX.sym("c0", rows.shape[0])
            f = ca.sumsqr(y - ystar) + self.pull * ca.sumsqr((180 / np.pi) * (self.q - qprev))
            g = [rows - c0]
            gx = self._posture_guard(phase, guard)
            if gx is not None:
                g.append(gx)
            nlp = {"x": self.q, "p": ca.vertcat(ystar, qprev, c0, self.p), "f": f,
                   "g": ca.vertcat(*g)}
            opts = {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes",
                                                   "tol": 1e-12, "max_iter": 200}}
            self._solvers[key] = ca.nlpsol(f"posture_{phase}", "ipopt", nlp, opts)
        return self._solvers[key]

    def posture(self, phase: str, guard: str | None, ystar, q_prev, c0, p) -> np.ndarray:
        """One posture (rad, m): the solve of :meth:`solver` from the previous posture."""
        solver = self.solver(phase, guard)
        sol = solver(x0=q_prev, p=np.r_[ystar, q_prev, c0, p], lbg=0.0, ubg=0.0)
        # IPOPT may stop short of its 1e-12 on the objective's last digits (a search
        # direction too small); the posture counts when it holds its rows
        held = float(np.max(np.abs(sol["g"].full()), initial=0.0)) <= POSTURE_TOL
        if not held:
            raise ValueError(f"no posture of phase {phase} holds its contacts near the "
                             f"previous one ({solver.stats()['return_status']})")
        return sol["x"].full().ravel()

    def velocities(self, phase: str, Q: np.ndarray, t: np.ndarray, p) -> np.ndarray:
        """Central differences (rad/s, m/s) of the postures ``Q`` (nq x n, rad and m) at the
        instants ``t`` (s, increasing), each projected onto the phase's contacts: J qd = 0."""
        V = np.gradient(Q, np.asarray(t, float), axis=1) if Q.shape[1] > 1 else np.zeros_like(Q)
        fun = self.contacts(phase)
        for j in range(Q.shape[1]):
            J = fun(Q[:, j], p)[1].full()
            if J.size:
                V[:, j] -= J.T @ np.linalg.lstsq(J @ J.T, J @ V[:, j], rcond=None)[0]
        return V


def kinematic_guess(hs, p, human, phases: Sequence[GuessPhase], q_start,
                    targets: Sequence[str] = GUESS_TARGETS, pull: float = 1e-2,
                    kg: KinematicGuess | None = None) -> list[np.ndarray]:
    """The full states (nx x n_nodes per phase, SI) of one step of the walker ``hs`` with
    parameters ``p`` along the prescribed ``phases`` (module docstring), following the
    human ``human`` (:class:`~pdw_casadi.model.gait_data.GaitCurves`; the targets' columns
    in deg). ``q_start``: a posture whose contacts lie where the step's first phase has them
    (the walker's section state, full: its feet on the ground). The step lasts the phases'
    total; the swing leg's heel strike is the start of the walker's heel-strike phase
    (``model.heel_strike_phase``; None: the step begins at it), which sets each leg's
    point of the cycle. ``pull``: the weight of the pull towards the previous posture
    (its coordinates in deg, positions in m taken as rad), against the targets' squared
    errors in deg^2; ``kg``: the machinery of an earlier guess of the same walker, reused
    (its targets and pull then apply)."""
    kg = kg or KinematicGuess(hs, targets, pull)
    p = np.asarray(p, float).ravel()
    unknown = [ph.phase for ph in phases if ph.phase not in hs.phases]
    if unknown:
        raise ValueError(f"walker {hs.model.name!r} has no phase {unknown[0]!r} (its phases: "
                         f"{', '.join(hs.phase_names)})")
    if any(ph.n_nodes < 2 or ph.duration <= 0 for ph in phases):
        raise ValueError("every phase needs a positive duration and at least 2 instants")
    T = sum(ph.duration for ph in phases)
    starts = np.cumsum([0.0, *[ph.duration for ph in phases]])[:-1]
    hs_phase = hs.model.heel_strike_phase
    k_hs = next((k for k, ph in enumerate(phases) if ph.phase == hs_phase), None)
    if hs_phase is not None and k_hs is None:
        raise ValueError(f"the pattern has no heel-strike phase ({hs_phase})")
    t_hs = None if k_hs is None else float(starts[k_hs])
    cycle = np.asarray(human.cycle_pct, float)
    curves = {}
    for stem in kg.targets:
        column = CURVE_TARGETS[stem][1]
        values = getattr(human, column, None)
        if values is None:
            raise ValueError(f"the gait curves have no {column} (a target of the guess)")
        curves[stem] = np.asarray(values, float)

    def target(t: float, after_hs: bool) -> np.ndarray:
        out = []
        for stem in kg.targets:
            for leg in (1, 2):
                pct = 100 * cycle_time(t, leg, T, t_hs, after_hs) / (2 * T)
                out.append(np.interp(pct % 100.0, cycle, curves[stem], period=100.0))
        return np.asarray(out)

    q = np.asarray(q_start, float).ravel()[: kg.nq]
    postures, times = [], []
    for k, ph in enumerate(phases):
        c0 = kg.contacts(ph.phase)(q, p)[0].full().ravel()
        ts = starts[k] + np.linspace(0.0, ph.duration, ph.n_nodes)
        after = k_hs is not None and k >= k_hs
        # a transition keeps the posture: a later phase begins where the last one ended
        Q = [] if k == 0 else [q]
        for j in range(len(Q), ph.n_nodes):
            guard = ph.guard if j == ph.n_nodes - 1 else None
            q = kg.posture(ph.phase, guard, target(float(ts[j]), after), q, c0, p)
            Q.append(q)
        postures.append(np.column_stack(Q))
        times.append(ts)
    # velocities over each run of entries in one phase together (a phase cut at its mode
    # switches is one motion: its pieces join with one velocity)
    velocities: list[np.ndarray] = []
    k = 0
    while k < len(phases):
        run = [k]
        while run[-1] + 1 < len(phases) and phases[run[-1] + 1].phase == phases[k].phase:
            run.append(run[-1] + 1)
        Q = np.column_stack([postures[run[0]], *[postures[i][:, 1:] for i in run[1:]]])
        ts = np.concatenate([times[run[0]], *[times[i][1:] for i in run[1:]]])
        V = kg.velocities(phases[k].phase, Q, ts, p)
        at = 0
        for i in run:
            n = phases[i].n_nodes
            velocities.append(V[:, at: at + n])
            at += n - 1
        k = run[-1] + 1
    W = [np.zeros((hs.nx - 2 * kg.nq, ph.n_nodes)) for ph in phases]
    nodes = [np.vstack(parts) for parts in zip(postures, velocities, W, strict=True)]
    # where a phase ends on its guard and another begins, the state there is the one the
    # walker's transition makes of the last (an impact's velocities, not differences)
    for k in range(1, len(phases)):
        before = phases[k - 1]
        tr = hs.transitions.get((before.phase, before.guard))
        if before.phase != phases[k].phase and tr is not None and not tr.ends_step:
            x_plus = hs.impact_at(tr.name, nodes[k - 1][:, -1], p).x_plus
            nodes[k][:, 0] = np.asarray(x_plus, float).ravel()
    return nodes


__all__ = ["GUESS_TARGETS", "POSTURE_TOL", "GuessPhase", "KinematicGuess", "kinematic_guess"]
