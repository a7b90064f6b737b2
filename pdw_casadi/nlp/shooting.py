"""Multiple-shooting transcription of one periodic walking step (for IPOPT).

The step is cut into *segments* of constant phase and mode, in the order a simulation of the
starting gait visits them (:class:`~pdw_casadi.gait.simulate.Plan`): phase I, phase II split at
the knee events (swing-knee flexion/extension switch, swing-knee engagement at theta_eq,
stance-knee disengagement at theta_dis), phase III. Each segment k has an unknown duration
T_k and N_k shooting intervals of M_k fixed RK4 steps (the simulator's integrator, so the
NLP's discrete map is the simulator's up to the step size); the step size h_k = T_k/(N_k M_k)
is bounded above, which keeps the stiff swing-ankle damping inside RK4's stability region.

Unknowns: the section state xs, the parameters p (compliance, slope), the durations T and
the full states at every shooting node. Constraints (all exact, no smoothing):

- start on the section: X_0,0 = section_to_full(xs, p);
- continuity inside segments, the ending event g = 0 at each segment end, identity across
  mode switches, the impact maps across transitions;
- periodicity with the leg swap: full_to_section(foot-strike impact(X_end)) = xs;
- the sign of every enabled event (guards, switches, failures) at the sampled RK4 states
  inside each segment: no event is crossed early (sampled: grazing between samples is caught
  by the re-simulation check of :mod:`pdw_casadi.fit`);
- validity margins at the samples, as the walker declares them (:mod:`pdw_casadi.model.margins`):
  contact normal forces >= min_normal_force, centre-of-pressure margins >= min_cop_margin,
  swing clearance >= min_clearance after 20 % of the phase (ramped from 0 at toe-off);
  impact checks (impulses, post-impact velocities) > 0 and guard requirements > 0.

Knee-spring engagement happens at its equilibrium angle by construction (the segment ends on
the event theta = theta_eq), so engagement stores no energy (passivity).

**Strides** (``step_perms``): a walker whose legs differ repeats every two steps. With one
parameter permutation per step the NLP transcribes that many steps in a row: the
parameter vector is then theta (each physical leg's values, :mod:`pdw_casadi.gait.stride`), step
i's segments use p_i = theta[perm_i], and step i + 1 starts from its own section state
xs_(i+1) (an unknown, appended to ``w``): full_to_section(foot-strike impact(X_end of step
i), p_i) = xs_(i+1) and X_start of step i + 1 = section_to_full(xs_(i+1), p_(i+1)), the
composition of the two-step :class:`~pdw_casadi.gait.poincare.PoincareMap`; periodicity
closes the last step on xs. :meth:`ShootingNLP.stride` builds it for a problem's per-leg walker.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Segment, Simulator
from pdw_casadi.model.hybrid import GUARD, SWITCH, HybridSystem
from pdw_casadi.model.margins import GUARD_AHEAD, GUARD_ROUNDOFF
from pdw_casadi.nlp.interval import compiled_interval, interval_output_names

H_MAX_FACTOR = 1.25  # largest RK4 step in the NLP, in units of the simulator's step size
#: the NLP's own slope bounds (rad) when a caller gives none (the fit has its own:
#: FitOptions.slope_bounds)
SLOPE_BOUNDS = (0.02, 0.30)
N_SUB = 10  # RK4 steps per shooting interval (one compiled function per phase)


@dataclass
class SegmentSpec:
    """One segment of the step: ``phase``, ``mode`` vector, ending ``event`` (index into the
    phase's events), ``transition`` taken after it (None: a mode switch), intervals ``n_int``,
    RK4 steps per interval ``n_sub``, starting duration ``duration0`` (s)."""

    phase: str
    mode: tuple[float, ...]
    event: int
    transition: str | None
    n_int: int
    n_sub: int
    duration0: float
    signs: dict[int, float] = field(default_factory=dict)  # event index -> required sign
    gaps: dict[int, float] = field(default_factory=dict)  # event index -> required |g| margin
    start: dict[int, int] = field(default_factory=dict)  # event index -> first sample checked
    cross_sign: float = 0.0  # direction of the ending event's crossing in the starting gait
    #: event index -> required sign at the segment's first state (mode indicators: the
    #: simulator reads them from the state when a phase begins)
    first_signs: dict[int, float] = field(default_factory=dict)
    #: event indices of the directional guards held on their near side at the segment's first
    #: state: at a phase start every guard the simulator checks there (``guards_ahead`` of the
    #: transition that begins the phase), after a mode switch the segment's ending guard
    ahead: tuple[int, ...] = ()
    cross_rate0: float = 0.0  # its rate dg/dt there
    step: int = 0  # the step (of a stride) the segment belongs to


def shooting_intervals(duration: float, n_sub: int, h: float, headroom_s: float = 0.0) -> int:
    """The shooting intervals of a segment lasting ``duration`` (s) with ``n_sub`` RK4 steps
    of about ``h`` (s) each: enough for it and ``headroom_s`` more, plus one interval of
    headroom (a segment's duration is bounded by n_int n_sub h_max, the RK4 step bound, and
    short segments, phase I lasts ~4 ms, must be free to grow)."""
    return int(math.ceil((duration + headroom_s) / (n_sub * h))) + 1


def segments_from_plan(hs: HybridSystem, plan, h: float, n_sub: int = N_SUB,
                       headroom_s: float = 0.0) -> list[SegmentSpec]:
    """Segment layout of one step from a simulator plan
    (see :class:`~pdw_casadi.gait.simulate.Plan`).

    ``headroom_s`` (s): every segment gets intervals enough to grow by this much beyond its
    starting duration (besides one interval of headroom): a segment's duration is bounded
    by n_int n_sub h_max, so without it a 7 ms segment can never last 20 ms."""
    specs: list[SegmentSpec] = []
    for i, item in enumerate(plan.items):
        if not isinstance(item, Segment):
            continue
        tr = plan.transition_after(i)
        ev = hs.event_list[item.phase][item.event]
        if ev.kind not in (GUARD, SWITCH):
            raise ValueError(f"plan segment ends on failure event {ev.name!r}")
        dur = item.n * item.h + item.tau
        n_int = shooting_intervals(dur, n_sub, h, headroom_s)
        specs.append(SegmentSpec(item.phase, tuple(item.mode), item.event, tr, n_int, n_sub,
                                 dur))
    return specs


def prescribed_segments(hs: HybridSystem, segments, nodes, n_steps: int = 1
                        ) -> list[SegmentSpec]:
    """Fresh copies of a prescribed segment layout for :class:`ShootingNLP` (their event
    signs are the NLP's to derive from the guess), checked against the walker ``hs``: every
    phase and ending event known, a guard or a switch; a transition after a guard and none
    after a switch; ``nodes`` one nx x (n_int + 1) array per segment; every step present."""
    specs = []
    if len(nodes) != len(segments):
        raise ValueError(f"{len(nodes)} node arrays for {len(segments)} segments")
    for k, (s, X) in enumerate(zip(segments, nodes, strict=True)):
        if s.phase not in hs.event_list:
            raise ValueError(f"segment {k}: no phase {s.phase!r} in this walker")
        events = hs.event_list[s.phase]
        if not 0 <= s.event < len(events) or events[s.event].kind not in (GUARD, SWITCH):
            raise ValueError(f"segment {k}: its ending event must be a guard or a switch of "
                             f"phase {s.phase}")
        if (events[s.event].kind == GUARD) != (s.transition is not None):
            raise ValueError(f"segment {k}: a guard ({events[s.event].name}) ends in a "
                             f"transition, a switch in none")
        if len(s.mode) != len(hs.mode_keys):
            raise ValueError(f"segment {k}: {len(s.mode)} mode values for "
                             f"{len(hs.mode_keys)} mode keys")
        if np.shape(X) != (hs.nx, s.n_int + 1):
            raise ValueError(f"segment {k}: nodes of shape {np.shape(X)}, expected "
                             f"{(hs.nx, s.n_int + 1)}")
        specs.append(SegmentSpec(s.phase, tuple(s.mode), s.event, s.transition, s.n_int,
                                 s.n_sub, s.duration0, step=s.step))
    if [s.step for s in specs] != sorted(s.step for s in specs) or \
            sorted({s.step for s in specs}) != list(range(n_steps)):
        raise ValueError(f"the segments must cover steps 0..{n_steps - 1} in order")
    by_name = {tr.name: tr for tr in hs.transitions.values()}
    for k, (s, nxt) in enumerate(zip(specs, [*specs[1:], None], strict=True)):
        tr = by_name.get(s.transition) if s.transition is not None else None
        if s.transition is not None and (tr is None or tr.source != s.phase):
            raise ValueError(f"segment {k}: no transition {s.transition!r} leaves phase "
                             f"{s.phase}")
        ends_step = tr is not None and tr.ends_step
        if nxt is None:
            if not ends_step:
                raise ValueError(f"the last segment must end the step (on "
                                 f"{[t.name for t in by_name.values() if t.ends_step]})")
            continue
        want = tr.target if tr is not None else s.phase
        if nxt.phase != want or nxt.step != s.step + (1 if ends_step else 0):
            raise ValueError(f"segment {k + 1}: phase {nxt.phase} (step {nxt.step}) cannot "
                             f"follow {s.phase} ending on "
                             f"{hs.event_list[s.phase][s.event].name} (expected {want})")
    return specs


class ShootingNLP:
    """The multiple-shooting NLP of one step of ``problem``'s walker (CasADi MX graph).

    ``free`` selects which parameters are unknowns (names of the problem's parameter
    vector); the others are fixed at ``p0``. ``objective(self) -> MX`` may be set by the
    caller (the curve fit); by default the NLP is a pure feasibility problem.

    ``step_perms`` (strides, see the module docstring): one index array per step, step i
    using ``p[perm_i]``; None: one step with ``p``. ``param_names``: the names of ``p0``
    (default the problem's parameter vector).
    """

    def __init__(self, problem, x0, p0, free: tuple[str, ...] = (), n_sub: int = N_SUB,
                 sample_stride: int = 1, hs: HybridSystem | None = None,
                 transversality: float = 0.5, headroom_s: float = 0.0,
                 step_perms=None, param_names=None,
                 segments: list[SegmentSpec] | None = None, nodes=None):
        """``segments`` with ``nodes``: a prescribed gait pattern instead of a simulated one,
        for a gait the simulator has not found yet (a guess from human curves): the
        segments' layout (phase, mode, ending event, transition, intervals, starting
        duration, step) and the starting guess at their shooting nodes, one nx x (n_int + 1)
        array of full states per segment (SI); ``x0`` is then the guess's section state, and
        ``n_sub`` and ``headroom_s`` are the segments' own (their ``n_sub``, ``n_int``).
        Otherwise the layout and the guess are those of a simulation from ``x0``."""
        self.problem = problem
        self.sim = Simulator(problem, hs)
        self.hs = hs = self.sim.hs
        self.model = hs.model
        self.h = self.sim.h
        self.h_max = H_MAX_FACTOR * self.h
        self.stride = sample_stride
        self.transversality = transversality
        self._gdot_cache: dict[str, ca.Function] = {}
        self.p0 = np.asarray(p0, float).ravel()
        #: per step, the indices of theta forming its parameter vector (None: p itself)
        self.step_perms = [None] if step_perms is None else [np.asarray(i, int)
                                                              for i in step_perms]
        self.n_steps = len(self.step_perms)
        self.p0_steps = [self.p0 if i is None else self.p0[i] for i in self.step_perms]
        x0 = np.asarray(x0, float).ravel()
        if (segments is None) != (nodes is None):
            raise ValueError("a prescribed gait pattern needs both its segments and its nodes")
        if segments is not None:
            self.specs = prescribed_segments(hs, segments, nodes, self.n_steps)
        else:
            run = self.sim.run(x0, self.p0, steps=self.n_steps, record=False,
                               p_steps=self.p0_steps)
            if run.failure is not None or run.completed_steps < self.n_steps:
                raise ValueError(f"the starting gait fails: {run.failure}")
            self.specs = []
            for i in range(self.n_steps):
                for spec in segments_from_plan(hs, run.steps[i].plan, self.h, n_sub,
                                               headroom_s):
                    spec.step = i
                    self.specs.append(spec)
        self.param_names = list(problem.parameter_names if param_names is None
                                else param_names)
        if len(self.param_names) != self.p0.size:
            raise ValueError(f"p0 has {self.p0.size} values for {len(self.param_names)} "
                             f"parameter names")
        self.free = [n for n in self.param_names if n in free]
        self._build()
        self.w0 = self._initial_guess(x0, nodes)
        self._signs_from_guess()
        self._build_constraints()

    @classmethod
    def stride(cls, problem, x0, theta0=None, free: tuple[str, ...] = (), **kw):
        """The two-step (stride) NLP of ``problem``'s per-leg walker
        (:func:`~pdw_casadi.model.system.per_leg_system`): parameters theta in the order of
        :func:`~pdw_casadi.model.system.physical_parameter_names` (``free`` names from there, e.g.
        ``right.k_ankle``), step 1 with the left leg in stance, step 2 with the right, from
        section state ``x0`` (SI units)."""
        smap = PoincareMap(problem, steps=2)
        if not smap.per_leg:
            raise ValueError(f"{problem.family}: no per-leg walker for a stride NLP")
        theta0 = smap.default_parameters() if theta0 is None else theta0
        nlp = cls(problem, x0, theta0, free=free, hs=smap.hs,
                  step_perms=list(smap.perms),
                  param_names=smap.parameter_names, **kw)
        nlp.stride_map = smap
        return nlp

    # -- variables -------------------------------------------------------------------------
    def _build(self):
        nx = self.hs.nx
        ns = len(self.model.state_names)
        self.xs = ca.MX.sym("xs", ns)
        self.pf = ca.MX.sym("p_free", len(self.free))
        # free parameters are unknowns in units of their starting magnitude (k_knee ~ 100,
        # theta_eq ~ 0.02): IPOPT's quasi-Newton model is far better conditioned so
        self.p_scale = np.array([max(abs(self.p0[self.param_names.index(n)]), 1e-2)
                                 for n in self.free])
        parts = []
        for name, v in zip(self.param_names, self.p0, strict=True):
            if name in self.free:
                j = self.free.index(name)
                parts.append(self.p_scale[j] * self.pf[j])
            else:
                parts.append(ca.MX(v))
        self.p = ca.vertcat(*parts)
        # each step's parameter vector; the symmetric step uses p itself (same graph)
        self.p_steps = [self.p if i is None else self.p[list(i)] for i in self.step_perms]
        self.p_seg = [self.p_steps[s.step] for s in self.specs]
        self.T = ca.MX.sym("T", len(self.specs))
        self.X = [ca.MX.sym(f"X{k}", nx, s.n_int + 1) for k, s in enumerate(self.specs)]
        # the section states at which steps 2.. start (none for one step)
        self.xs_steps = [self.xs, *[ca.MX.sym(f"xs{i}", ns) for i in range(1, self.n_steps)]]
        self.w = ca.vertcat(self.xs, self.pf, self.T, *[ca.vec(X) for X in self.X],
                            *self.xs_steps[1:])
        # the RK4 states and outputs inside every interval, in time order
        self.samples: list[ca.MX] = []  # nx x (N M) per segment
        self.Y: list[ca.MX] = []  # ny x (N M): phase outputs, then event functions
        self.sample_t: list[ca.MX] = []  # time of each sample from the step start (s)
        self.h_k: list[ca.MX] = []
        t0 = ca.MX(0)
        self.t_start: list[ca.MX] = []
        for k, s in enumerate(self.specs):
            hk = self.T[k] / (s.n_int * s.n_sub)
            self.h_k.append(hk)
            self.t_start.append(t0)
            F = self._interval(s.phase, s.n_sub).map(s.n_int)
            Xall, Yall = F(self.X[k][:, :-1], self.p_seg[k], ca.DM(s.mode), hk)
            self.samples.append(Xall)
            self.Y.append(Yall)
            idx = np.arange(1, s.n_int * s.n_sub + 1)
            self.sample_t.append(t0 + hk * ca.DM(idx).T)
            t0 = t0 + self.T[k]
        self.step_time = t0  # of the whole NLP (a stride: both steps), s
        #: per step: its time (s) and its length (m, the walker's step_length just before
        #: the step's foot strike, as the simulator reports it)
        self.step_times, self.step_lengths = [], []
        for i in range(self.n_steps):
            ks = [k for k, s in enumerate(self.specs) if s.step == i]
            self.step_times.append(ca.sum1(self.T[ks[0]: ks[-1] + 1]))
            self.step_lengths.append(self.hs.step_length.fun(self.X[ks[-1]][:, -1],
                                                             self.p_steps[i]))

    def _interval(self, phase: str, n_sub: int):
        """M RK4 steps: (x, p, m, h) -> (states, outputs+events) at the M sample instants."""
        return compiled_interval(self.hs, phase, n_sub)

    def output_names(self, phase: str) -> list[str]:
        """Rows of the segment outputs ``Y``: phase outputs, then ``event:<name>``."""
        return interval_output_names(self.hs, phase)

    def output(self, k: int, name: str) -> ca.MX:
        """Output ``name`` of segment k at its RK4 samples (1 x N M)."""
        return self.Y[k][self.output_names(self.specs[k].phase).index(name), :]

    # -- initial guess -----------------------------------------------------------------------
    def _initial_guess(self, x0, nodes=None) -> np.ndarray:
        """Nodes from a forward pass of the NLP's own integrator over the plan's durations
        (``nodes``: the prescribed ones; the later steps' section states from the impacts
        at their ends either way)."""
        hs, model = self.hs, self.model
        x = model.section_to_full(x0, self.p0_steps[0]).full().ravel()
        Xs, xs_next = [], []
        for k, s in enumerate(self.specs):
            p = self.p0_steps[s.step]
            if nodes is not None:
                Xs.append(np.asarray(nodes[k], float))
                x = Xs[-1][:, -1]
            else:
                h = s.duration0 / (s.n_int * s.n_sub)
                F = self._interval(s.phase, s.n_sub)
                cols = [x]
                for _ in range(s.n_int):
                    x = F(x, p, s.mode, h)[0].full()[:, -1]
                    cols.append(x)
                Xs.append(np.column_stack(cols))
            if s.transition is not None:
                x = hs.impact_at(s.transition, x, p).x_plus
            if k + 1 < len(self.specs) and self.specs[k + 1].step != s.step:
                xs_next.append(model.full_to_section(x).full().ravel())
                x = model.section_to_full(xs_next[-1],
                                          self.p0_steps[self.specs[k + 1].step]).full().ravel()
        pf = [self.p0[self.param_names.index(n)] / sc for n, sc in zip(self.free, self.p_scale,
                                                                          strict=True)]
        T = [s.duration0 for s in self.specs]
        return np.concatenate([x0, pf, T, *[X.ravel(order="F") for X in Xs], *xs_next])

    def _signs_from_guess(self):
        """Required sign (and margin) of every enabled event inside each segment, from the guess.

        An event that changes sign inside a segment of the guess without firing (a
        one-directional event crossed the other way) gets no sign constraint. Events other
        than the segment's own must also keep a margin from zero (1e-3 of their range in the
        segment, at most half their smallest value there): a sampled sign constraint alone
        lets a solution graze an event between samples, which the simulator would fire. An
        event that is zero at the segment start (it just fired) only keeps its sign.
        """
        hs = self.hs
        n = len(self.specs)
        fun = ca.Function("guess", [self.w], [*self.Y, *[X[:, -1] for X in self.X],
                                              *[X[:, 0] for X in self.X]])
        vals = fun.call([self.w0])
        for k, (s, Y, xe, xb) in enumerate(zip(self.specs, vals[:n], vals[n:2 * n],
                                               vals[2 * n:], strict=True)):
            names = self.output_names(s.phase)
            g = Y.full()[len(names) - len(hs.event_list[s.phase]):, :]
            mode = dict(zip(hs.mode_keys, s.mode, strict=True))
            rate = float(self._gdot(s.phase)(xe, self.p0_steps[s.step], s.mode)[s.event])
            s.cross_sign, s.cross_rate0 = float(np.sign(rate)), rate
            g_first = hs.events[s.phase].np(xb.full().ravel(), self.p0_steps[s.step],
                                            s.mode).ravel()
            # the guards at the segment's first state, unless zero there by construction
            # (see GUARD_ROUNDOFF): a phase's first segment may end on a mode switch, and the
            # simulator checks all the phase's guards where the phase begins
            begun_by = self.specs[k - 1].transition if k else self.specs[-1].transition
            if begun_by is not None:
                held = [i for i, ev, _ in hs.guards_ahead[begun_by] if ev.enabled(mode)]
            else:
                held = [s.event] if hs.event_list[s.phase][s.event].directional_guard else []
            s.ahead = tuple(i for i in held if abs(g_first[i]) > GUARD_ROUNDOFF)
            for i, ev in enumerate(hs.event_list[s.phase]):
                if not ev.enabled(mode):
                    continue
                if i == s.event and ev.directional_guard:
                    # the segment ends at this guard's first crossing: before it, the guard
                    # is on its near side whatever the guess does (a guess that grazes it
                    # would otherwise let the answer cross it early, unseen)
                    s.signs[i] = float(-ev.direction)
                    continue
                gi = g[i, :-1] if i == s.event else g[i]
                if not gi.size or not (np.all(gi > 0) or np.all(gi < 0)):
                    continue
                s.signs[i] = float(np.sign(gi[0]))
                if ev.arm_above > 0:
                    # like the simulator: an armed event counts once g has left the surface
                    # (a toe that just lifted off starts at height 0)
                    s.start[i] = int(np.argmax(np.abs(gi) > 10 * ev.arm_above))
                a = np.abs(gi)
                gap = min(1e-3 * a.max(), 0.5 * a.min())
                if i != s.event and a[0] > 10 * gap:
                    s.gaps[i] = gap
                if ev.indicator:
                    # the flag's sign at the segment's first state, unless the event fired
                    # there (then ~0: its flag comes from the crossing direction)
                    if np.sign(g_first[i]) == s.signs[i] and abs(g_first[i]) > 1e-3 * a.max():
                        s.first_signs[i] = s.signs[i]

    # -- constraints -------------------------------------------------------------------------
    def _build_constraints(self):
        hs, model = self.hs, self.model
        v = self.problem.validity
        g, lb, ub, names = [], [], [], []

        def add(expr, lo, hi, name):
            expr = ca.vec(expr)
            g.append(expr)
            lb.append(np.full(expr.shape[0], lo))
            ub.append(np.full(expr.shape[0], hi))
            names.extend([name] * expr.shape[0])

        add(self.X[0][:, 0] - model.section_to_full(self.xs, self.p_seg[0]), 0, 0, "section")
        phase_start: dict[tuple, ca.MX] = {}
        phase_len: dict[tuple, ca.MX] = {}
        for k, s in enumerate(self.specs):
            key = (s.step, s.phase)
            phase_start.setdefault(key, self.t_start[k])
            phase_len[key] = phase_len.get(key, 0) + self.T[k]
        for k, s in enumerate(self.specs):
            X, S, Y, p = self.X[k], self.samples[k], self.Y[k], self.p_seg[k]
            M = s.n_sub
            add(X[:, 1:] - S[:, M - 1::M], 0, 0, f"continuity[{k}]")
            onames = self.output_names(s.phase)
            evs = hs.event_list[s.phase]
            e0 = len(onames) - len(evs)
            add(Y[e0 + s.event, -1], 0, 0, f"guard[{k}]:{evs[s.event].name}")
            # transversality: the ending event is crossed at a rate of at least half the
            # starting gait's; a grazing crossing makes the step map hypersensitive (the
            # saltation term divides by this rate) and the event order fragile
            mv = ca.DM(s.mode)
            if self.transversality > 0:
                rate = self._gdot(s.phase)(X[:, -1], p, mv)[s.event]
                add(s.cross_sign * rate, self.transversality * abs(s.cross_rate0), ca.inf,
                    f"transversality[{k}]:{evs[s.event].name}")
            cols = list(range(self.stride - 1, Y.shape[1], self.stride))
            if cols[-1] != Y.shape[1] - 1:
                cols.append(Y.shape[1] - 1)
            inner = cols[:-1]
            for i, sign in s.signs.items():
                at = inner if i == s.event else cols
                at = [c for c in at if c >= s.start.get(i, 0)]
                if at:
                    add(sign * Y[e0 + i, at], s.gaps.get(i, 0.0), ca.inf,
                        f"sign[{k}]:{evs[i].name}")
            y0 = hs.outputs[s.phase](X[:, 0], p, mv)  # the outputs at the segment's start
            # the events there, where a row needs them
            g0 = hs.events[s.phase](X[:, 0], p, mv) if s.ahead or s.first_signs else None
            for i in s.ahead:
                # ... and at the segment's first state (right after an impact: a contact
                # whose force the impact left negative would open at once)
                add(-evs[i].direction * g0[i], GUARD_AHEAD.nlp_slack, ca.inf,
                    f"ahead[{k}]:{evs[i].name}")
            for i, sign in s.first_signs.items():
                # a mode flag read from the state at a phase start: the segment's mode holds
                # from its first state on (a knee rate that the impact reversed would switch
                # the damping within the first RK4 steps, before the first checked sample)
                add(sign * g0[i], 0, ca.inf, f"first_sign[{k}]:{evs[i].name}")
            mv = ca.DM(s.mode)
            if evs[s.event].require is not None:
                add(hs.require[s.phase](X[:, -1], p, mv)[s.event], 0, ca.inf,
                    f"require[{k}]:{evs[s.event].require_reason}")
            # validity margins at the samples and at the segment's start node (right after an
            # impact the contact forces jump)
            ts = self.sample_t[k]
            for j, name, spec in hs.phase_margins[s.phase]:
                need = spec.minimum(v) + spec.nlp_slack
                if spec.active_after <= 0:
                    add(ca.horzcat(y0[j], Y[j, cols]), need, ca.inf, f"margin[{k}]:{name}")
                    continue
                # a margin that counts late in its phase (a swing foot's clearance) is not
                # demanded at the start node: the foot leaves the ground there (height 0 by
                # the previous phase's contact), and a pinned row only degrades the KKT
                key = (s.step, s.phase)
                demand = spec.demand(ts[cols] - phase_start[key], phase_len[key], need)
                add(Y[j, cols] - demand, 0, ca.inf, f"margin[{k}]:{name}")
            xe = X[:, -1]
            if s.transition is not None:
                imp = hs.impact_expr(s.transition, xe, p)
                x_plus, chk = imp.x_plus, imp.checks
                if chk.shape[0]:
                    add(chk, 1e-9, ca.inf, f"impact_check[{s.transition}]")
                if k + 1 == len(self.specs):
                    add(model.full_to_section(x_plus) - self.xs, 0, 0, "periodicity")
                elif self.specs[k + 1].step == s.step:
                    add(self.X[k + 1][:, 0] - x_plus, 0, 0, f"impact[{s.transition}]")
                else:  # the next step starts on its own section state (leg roles swapped)
                    i = self.specs[k + 1].step
                    add(model.full_to_section(x_plus) - self.xs_steps[i], 0, 0,
                        f"step_link[{i}]")
                    add(self.X[k + 1][:, 0] - model.section_to_full(self.xs_steps[i],
                                                                    self.p_seg[k + 1]),
                        0, 0, f"section[{i}]")
            else:
                add(self.X[k + 1][:, 0] - xe, 0, 0, f"switch[{k}]")
        self.g = ca.vertcat(*g)
        self.lbg = np.concatenate(lb)
        self.ubg = np.concatenate(ub)
        self.g_names = names

    def _gdot(self, phase: str) -> ca.Function:
        """Rates of change of the phase's event functions along the flow, dg/dt (built once
        per phase)."""
        if phase not in self._gdot_cache:
            hs = self.hs
            x, p, m = hs.x_sym, self.model.p, self.model.m
            g = hs.events[phase].fun(x, p, m)
            f = hs.rhs[phase](x, p, m)
            self._gdot_cache[phase] = ca.Function(f"gdot_{phase}", [x, p, m],
                                                  [ca.mtimes(ca.jacobian(g, x), f)])
        return self._gdot_cache[phase]

    def violations(self, w) -> list[tuple[str, float]]:
        """Constraint violations at ``w``, largest first (name, amount)."""
        gv = ca.Function("g", [self.w], [self.g])(w).full().ravel()
        viol = np.maximum(self.lbg - gv, 0) + np.maximum(gv - self.ubg, 0)
        order = np.argsort(-viol)
        return [(self.g_names[i], float(viol[i])) for i in order if viol[i] > 0]

    # -- bounds ------------------------------------------------------------------------------
    def bounds(self, slope_bounds=SLOPE_BOUNDS, t_min: float = 1e-3):
        """Lower and upper bounds of the unknowns (compliance from the problem file).

        ``t_min`` (s): shortest segment. The event order is part of the assumed gait
        pattern; a segment shrinking to nothing would let two events coincide, where the
        simulator's order (and the gait) is no longer the NLP's.
        """
        n = self.w.shape[0]
        lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
        ns = self.xs.shape[0]
        cb = self.problem.compliance_bounds
        for j, name in enumerate(self.free):
            # a stride's per-leg names (right.k_ankle) take the problem's bounds of k_ankle
            key = name.rsplit(".", 1)[-1]
            b = slope_bounds if name == "slope" else cb.get(key, (-np.inf, np.inf))
            lo[ns + j], hi[ns + j] = np.asarray(b, float) / self.p_scale[j]
        o = ns + len(self.free)
        for k, s in enumerate(self.specs):
            lo[o + k] = t_min
            hi[o + k] = s.n_int * s.n_sub * self.h_max
        return lo, hi

    def unpack(self, w) -> dict:
        """The section state, full parameter vector and durations of a solution vector
        (strides: ``xs_steps``, the section state at the start of every step)."""
        w = np.asarray(w, float).ravel()
        ns = self.xs.shape[0]
        nf = len(self.free)
        p = self.p0.copy()
        for j, name in enumerate(self.free):
            p[self.param_names.index(name)] = w[ns + j] * self.p_scale[j]
        n_extra = ns * (self.n_steps - 1)
        extra = w[w.size - n_extra:] if n_extra else np.zeros(0)
        return {"xs": w[:ns], "p": p, "T": w[ns + nf: ns + nf + len(self.specs)],
                "xs_steps": [w[:ns], *extra.reshape(-1, ns)]}
