"""Plain numpy/scipy reference implementation of one step of the humanlike 6-link walker.

Independent of the CasADi package (no casadi import): it serves as the baseline of the speed
benchmark and as a cross-check of ``pdw_casadi``. Conventions follow ``docs/model.md`` exactly:

* q = [q1, q2, q3, q4, qf1, qf2, x_t1, y_t1], absolute angles from the vertical, and
  d(a) = (sin a, -cos a) the proximal-to-distal unit vector of a link.
* Chain: toe1 = (x_t1, y_t1); ankle1 = toe1 - l_ft d(qf1); knee1 = ankle1 - l_s d(q1);
  hip = knee1 - l_t d(q2); knee2 = hip + l_t d(q3); ankle2 = knee2 + l_s d(q4);
  toe2 = ankle2 + l_ft d(qf2); heel_i = ankle_i - l_fh d(qf_i).
* Every point P of the walker is toe1 + sum_j c_j d(q_j) with constant coefficients c, so
  T = dr/dq, M_q = T^T M T and F_q = T^T (F - M Tdot qd) (eqs. 8, 9) reduce to exact closed
  forms: M_q[i, j] = A_ij cos(q_i - q_j) (+ J_i on the diagonal), with A = sum_b m_b c_b c_b^T.
* Constrained dynamics: eq. (12), solved with np.linalg.solve on the KKT system.
* A step: phase I (foot 1 flat, toe 2 pivot) -> toe-off -> phase II (swing) -> heel strike
  (impact) -> phase III (toe 1 and heel 2 pivots) -> foot strike (impact) -> leg swap.
* Knee springs, damping switches and phase guards are terminal events of ``solve_ivp``
  (RK45, rtol 1e-9, atol 1e-11); integration restarts at every event, so no discontinuity of
  the vector field (or of its derivative) is ever integrated across.

Run ``python scripts/numpy_walker.py`` to walk one step from the paper's Table 2 state.
"""

from __future__ import annotations

import sys
import time
import tomllib
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

RTOL = 1e-9
ATOL = 1e-11

# angle indices in q
Q1, Q2, Q3, Q4, QF1, QF2, XT, YT = range(8)
NQ = 8


class StepFailure(RuntimeError):
    """The step does not follow the intended gait pattern (a guard not reached, scuffing...)."""


# --------------------------------------------------------------------------------------------
# parameters
# --------------------------------------------------------------------------------------------
def load_params(path=None) -> dict:
    """Flat parameter dict from the problem TOML (default: the bundled humanlike_6link.toml)."""
    if path is None:
        path = Path(__file__).resolve().parents[1] / "problems" / "humanlike_6link.toml"
    with open(path, "rb") as fh:
        raw = tomllib.load(fh)
    p: dict = {}
    for sec in ("environment", "anthropometry", "compliance", "numerics"):
        p.update(raw.get(sec, {}))
    ini = raw.get("initial_state", {})
    p["x0"] = np.array([ini[k] for k in ("q1", "q2", "q3", "qf2", "dq1", "dq2", "dq3")],
                       dtype=float) if ini else None
    p.setdefault("max_phase_time", 2.0)
    return p


# --------------------------------------------------------------------------------------------
# the model: constant coefficient vectors and closed-form dynamics
# --------------------------------------------------------------------------------------------
class Model:
    """Kinematics, M_q, F_q and constraint rows of the walker for one parameter set."""

    def __init__(self, p: dict):
        self.p = p
        g, gam = p["g"], p["slope"]
        l_s, l_t, l_sc, l_tc = p["l_s"], p["l_t"], p["l_sc"], p["l_tc"]
        l_ft, l_fh, l_fc = p["l_ft"], p["l_fh"], p["l_fc"]
        self.g, self.gamma = g, gam
        self.n = np.array([np.sin(gam), np.cos(gam)])      # outward ground normal
        self.tang = np.array([np.cos(gam), -np.sin(gam)])   # downhill along the slope

        def vec(**kw):
            c = np.zeros(6)
            for k, v in kw.items():
                c[{"q1": 0, "q2": 1, "q3": 2, "q4": 3, "qf1": 4, "qf2": 5}[k]] = v
            return c

        # points (coefficients of d(q_j), relative to toe1)
        self.c_toe1 = vec()
        self.c_ankle1 = vec(qf1=-l_ft)
        self.c_heel1 = vec(qf1=-l_ft - l_fh)
        self.c_knee1 = vec(qf1=-l_ft, q1=-l_s)
        self.c_hip = vec(qf1=-l_ft, q1=-l_s, q2=-l_t)
        self.c_knee2 = vec(qf1=-l_ft, q1=-l_s, q2=-l_t, q3=l_t)
        self.c_ankle2 = vec(qf1=-l_ft, q1=-l_s, q2=-l_t, q3=l_t, q4=l_s)
        self.c_toe2 = vec(qf1=-l_ft, q1=-l_s, q2=-l_t, q3=l_t, q4=l_s, qf2=l_ft)
        self.c_heel2 = vec(qf1=-l_ft, q1=-l_s, q2=-l_t, q3=l_t, q4=l_s, qf2=-l_fh)
        # bodies in the order of eq. (1): shank1, thigh1, thigh2, shank2, hip, foot1, foot2
        m_s, m_t, m_h, m_f = p["m_s"], p["m_t"], p["m_h"], p["m_f"]
        self.bodies = [
            ("shank1", m_s, p["J_s"], 0, vec(qf1=-l_ft, q1=-l_sc)),
            ("thigh1", m_t, p["J_t"], 1, vec(qf1=-l_ft, q1=-l_s, q2=-l_tc)),
            ("thigh2", m_t, p["J_t"], 2, vec(qf1=-l_ft, q1=-l_s, q2=-l_t, q3=l_t - l_tc)),
            ("shank2", m_s, p["J_s"], 3,
             vec(qf1=-l_ft, q1=-l_s, q2=-l_t, q3=l_t, q4=l_s - l_sc)),
            ("hip", m_h, 0.0, None, self.c_hip.copy()),
            ("foot1", m_f, p["J_f"], 4, vec(qf1=-l_ft + l_fc)),
            ("foot2", m_f, p["J_f"], 5,
             vec(qf1=-l_ft, q1=-l_s, q2=-l_t, q3=l_t, q4=l_s, qf2=l_fc)),
        ]
        self.mtot = sum(b[1] for b in self.bodies)
        self.A = sum(m * np.outer(c, c) for _, m, _, _, c in self.bodies)
        self.B = sum(m * c for _, m, _, _, c in self.bodies)
        self.Jdiag = np.zeros(6)
        for _, _, J, idx, _ in self.bodies:
            if idx is not None:
                self.Jdiag[idx] += J
        self.Jmat = np.diag(self.Jdiag)
        self._pts = {"toe2": self.c_toe2, "heel2": self.c_heel2, "heel1": self.c_heel1}
        self.gB = g * self.B
        self.mg = self.mtot * g
        # compliance
        self.k_a, self.c_a = p["k_ankle"], p["c_ankle"]
        self.k_k, self.c_st = p["k_knee"], p["c_knee_stance"]
        self.c_flex, self.c_ext = p["c_knee_flex"], p["c_knee_ext"]
        self.th_eq, self.th_dis = p["theta_eq"], p["theta_dis"]
        self.l_f = p["l_f"]

    # ---- kinematics ------------------------------------------------------------------------
    @staticmethod
    def point(c, q):
        a = q[:6]
        return np.array([q[XT] + c @ np.sin(a), q[YT] - c @ np.cos(a)])

    @staticmethod
    def point_vel(c, q, qd):
        a = q[:6]
        return np.array([qd[XT] + (c * np.cos(a)) @ qd[:6], qd[YT] + (c * np.sin(a)) @ qd[:6]])

    def height(self, c, q):
        return self.point(c, q) @ self.n

    @staticmethod
    def _point_rows(c, s, co, w):
        """Jacobian rows (2x8) of a point and its d(E qd)/dq qd (2,)."""
        E = np.zeros((2, NQ))
        E[0, :6] = c * co
        E[1, :6] = c * s
        E[0, XT] = 1.0
        E[1, YT] = 1.0
        gam = np.array([-(c * s) @ w, (c * co) @ w])
        return E, gam

    def _fill_constraints(self, rows, s, co, w, E, gam):
        """Write the rows' E (m x 8) and d(E qd)/dq qd (m,) into E and gam (pre-zeroed E)."""
        i = 0
        for r in rows:
            if r == "toe1":   # eps = (x_t1, y_t1)
                E[i, XT] = E[i + 1, YT] = 1.0
                gam[i] = gam[i + 1] = 0.0
                i += 2
            elif r == "flat1" or r == "flat2":   # eps = l_f cos(qf)
                j = QF1 if r == "flat1" else QF2
                E[i, j] = -self.l_f * s[j]
                gam[i] = -self.l_f * co[j] * w[j]
                i += 1
            else:   # a point of the chain: toe2, heel2, heel1
                c = self._pts[r]
                cc, cs = c * co, c * s
                E[i, :6] = cc
                E[i + 1, :6] = cs
                E[i, XT] = E[i + 1, YT] = 1.0
                gam[i] = -(cs @ w)
                gam[i + 1] = cc @ w
                i += 2
        return i

    def constraints(self, rows, q, qd, s=None, co=None):
        """Stacked E (m x 8) and d(E qd)/dq qd (m,) of a list of row names."""
        if s is None:
            s, co = np.sin(q[:6]), np.cos(q[:6])
        m = self.n_rows(rows)
        E = np.zeros((m, NQ))
        gam = np.zeros(m)
        self._fill_constraints(rows, s, co, qd[:6] ** 2, E, gam)
        return E, gam

    @staticmethod
    def n_rows(rows):
        return sum(1 if r.startswith("flat") else 2 for r in rows)

    # ---- dynamics ---------------------------------------------------------------------------
    def _fill_mass(self, M, s, co):
        """Write M_q (8x8) into the top-left block of M."""
        M[:6, :6] = self.A * (co[:, None] * co + s[:, None] * s) + self.Jmat
        M[:6, XT] = M[XT, :6] = self.B * co
        M[:6, YT] = M[YT, :6] = self.B * s
        M[XT, XT] = M[YT, YT] = self.mtot
        M[XT, YT] = M[YT, XT] = 0.0

    def mass_matrix(self, s, co):
        M = np.empty((NQ, NQ))
        self._fill_mass(M, s, co)
        return M

    def torques(self, q, qd, knees):
        """Generalized joint torques (8,). knees = (mode1, mode2), mode in
        {'spring', 'flex', 'ext'} ('flex'/'ext': disengaged, damping c_flex/c_ext)."""
        tau = np.zeros(NQ)
        # ankles: phi = qf - q_shank, +tau on the foot, -tau on the shank
        ta1 = -self.k_a * (q[QF1] - q[Q1] - 0.5 * np.pi) - self.c_a * (qd[QF1] - qd[Q1])
        ta2 = -self.k_a * (q[QF2] - q[Q4] - 0.5 * np.pi) - self.c_a * (qd[QF2] - qd[Q4])
        tau[QF1] = ta1
        tau[QF2] = ta2
        # knees: theta = q_thigh - q_shank, +tau on the thigh, -tau on the shank
        tk = [0.0, 0.0]
        for k, (thigh, shank) in enumerate(((Q2, Q1), (Q3, Q4))):
            thd = qd[thigh] - qd[shank]
            mode = knees[k]
            if mode == "spring":
                tk[k] = -self.k_k * (q[thigh] - q[shank] - self.th_eq) - self.c_st * thd
            elif mode == "flex":
                tk[k] = -self.c_flex * thd
            else:
                tk[k] = -self.c_ext * thd
        tau[Q1] = -ta1 - tk[0]
        tau[Q2] = tk[0]
        tau[Q3] = tk[1]
        tau[Q4] = -ta2 - tk[1]
        return tau

    def forces(self, q, qd, s, co, knees):
        """F_q = T^T (F - M Tdot qd) including joint torques."""
        w = qd[:6] ** 2
        F = np.empty(NQ)
        # gravity minus T^T M Tdot qd (closed form: sum_j A_ij sin(q_i - q_j) qd_j^2)
        F[:6] = -self.gB * s - (s * (self.A @ (co * w)) - co * (self.A @ (s * w)))
        F[XT] = (self.B * s) @ w
        F[YT] = -self.mg - (self.B * co) @ w
        F += self.torques(q, qd, knees)
        return F

    def accel(self, q, qd, rows, knees):
        """qdd and lambda from eq. (12)."""
        s, co = np.sin(q[:6]), np.cos(q[:6])
        m = self.n_rows(rows)
        K = np.zeros((NQ + m, NQ + m))
        b = np.empty(NQ + m)
        self._fill_mass(K, s, co)
        b[:NQ] = self.forces(q, qd, s, co, knees)
        E = K[NQ:, :NQ]               # a view: filled in place
        gam = b[NQ:]
        self._fill_constraints(rows, s, co, qd[:6] ** 2, E, gam)
        np.negative(gam, out=gam)
        K[:NQ, NQ:] = -E.T
        sol = np.linalg.solve(K, b)
        return sol[:NQ], sol[NQ:]

    def impact(self, q, qd, rows):
        """M_q (qd+ - qd-) = E^T Lambda, E qd+ = 0. Returns qd+, Lambda."""
        s, co = np.sin(q[:6]), np.cos(q[:6])
        M = self.mass_matrix(s, co)
        E, _ = self.constraints(rows, q, qd, s, co)
        m = E.shape[0]
        K = np.zeros((NQ + m, NQ + m))
        K[:NQ, :NQ] = M
        K[:NQ, NQ:] = -E.T
        K[NQ:, :NQ] = E
        sol = np.linalg.solve(K, np.concatenate([M @ qd, np.zeros(m)]))
        return sol[:NQ], sol[NQ:]

    # ---- energy (for checks) ---------------------------------------------------------------
    def energy(self, q, qd, knees=("spring", "spring")):
        s, co = np.sin(q[:6]), np.cos(q[:6])
        M = self.mass_matrix(s, co)
        ke = 0.5 * qd @ M @ qd
        pe = sum(m * self.g * self.point(c, q)[1] for _, m, _, _, c in self.bodies)
        pe += 0.5 * self.k_a * ((q[QF1] - q[Q1] - 0.5 * np.pi) ** 2
                                + (q[QF2] - q[Q4] - 0.5 * np.pi) ** 2)
        for (thigh, shank), mode in zip(((Q2, Q1), (Q3, Q4)), knees, strict=True):
            if mode == "spring":
                pe += 0.5 * self.k_k * (q[thigh] - q[shank] - self.th_eq) ** 2
        return ke + pe


PHASE_ROWS = {
    "I": ("toe2", "toe1", "flat1"),
    "II": ("toe1", "flat1"),
    "III": ("toe1", "heel2"),
}
IMPACT_ROWS = {
    "heel_strike": ("toe1", "heel2"),
    "foot_strike": ("toe1", "toe2", "flat2"),
}


# --------------------------------------------------------------------------------------------
# Poincare section
# --------------------------------------------------------------------------------------------
def section_to_full(x7, params, model: Model | None = None):
    """Full (q, qd) at the section from the 7-value state [q1,q2,q3,qf2,dq1,dq2,dq3]."""
    mdl = model if model is not None else Model(params)
    x7 = np.asarray(x7, dtype=float)
    gam = mdl.gamma
    q = np.zeros(NQ)
    q[[Q1, Q2, Q3, QF2]] = x7[:4]
    q[QF1] = 0.5 * np.pi - gam
    # trailing toe on the ground: (knee2 + l_ft d(qf2)) . n - l_s cos(q4 + gamma) = 0
    c_part = mdl.c_toe2.copy()
    c_part[Q4] = 0.0
    h0 = mdl.height(c_part, q)
    ratio = h0 / mdl.p["l_s"]
    if abs(ratio) > 1.0:
        raise StepFailure("section: the trailing toe cannot reach the ground")
    base = np.arccos(ratio)
    roots = np.array([-gam + base, -gam - base])
    q[Q4] = roots[np.argmin(np.abs(roots - q[Q3]))]
    # zero trailing-toe velocity: two linear equations in dq4, dqf2
    qd = np.zeros(NQ)
    qd[[Q1, Q2, Q3]] = x7[4:]
    s, co = np.sin(q[:6]), np.cos(q[:6])
    E, _ = mdl._point_rows(mdl.c_toe2, s, co, np.zeros(6))
    unk = [Q4, QF2]
    known = [i for i in range(NQ) if i not in unk]
    qd[unk] = np.linalg.solve(E[:, unk], -E[:, known] @ qd[known])
    return q, qd


# --------------------------------------------------------------------------------------------
# one step
# --------------------------------------------------------------------------------------------
def _make_event(fun, direction):
    fun.terminal = True
    fun.direction = direction
    return fun


def simulate_step(x7, params, model: Model | None = None, keep_trajectory=False,
                  diagnostics=True) -> dict:
    """Walk one step from the section state x7; see the module docstring.

    ``model`` (a Model of ``params``) may be passed to skip its construction; ``diagnostics``
    (contact forces along the step, swing clearance) can be switched off for benchmarking.

    Returns a dict with x7_end (after the swap), events [(name, t)], phase_durations,
    q_end / qd_end (post-foot-strike, pre-swap), impulses and some validity diagnostics.
    """
    mdl = model if model is not None else Model(params)
    p = mdl.p
    q, qd = section_to_full(x7, params, mdl)
    y = np.concatenate([q, qd])
    t = 0.0
    events: list[tuple[str, float]] = []
    durations: dict[str, float] = {}
    info: dict = {"min_normal": {}, "knee1_spring_energy_lost": None}
    traj_t, traj_y, traj_ph = [], [], []
    max_T = float(p.get("max_phase_time", 2.0))

    # knee state: 'spring' engaged; 'flex' / 'ext' disengaged with that damping
    def disengaged_mode(thd):
        return "flex" if thd > 0.0 else "ext"

    knee = ["spring", disengaged_mode(qd[Q3] - qd[Q4])]
    knee1_can_disengage = True   # until it has disengaged
    knee2_armed = False          # armed at toe-off, until engaged
    th_eq, th_dis = mdl.th_eq, mdl.th_dis
    n = mdl.n

    for phase in ("I", "II", "III"):
        rows = PHASE_ROWS[phase]
        t_phase0 = t
        if phase == "II":
            knee2_armed = knee[1] != "spring"
        while True:
            kn = tuple(knee)

            def rhs(_t, yy, rows=rows, kn=kn):
                qdd, _ = mdl.accel(yy[:NQ], yy[NQ:], rows, kn)
                return np.concatenate([yy[NQ:], qdd])

            evs, names = [], []
            # phase guard
            if phase == "I":
                def g_toeoff(_t, yy, rows=rows, kn=kn):
                    _, lam = mdl.accel(yy[:NQ], yy[NQ:], rows, kn)
                    return lam[0:2] @ n
                evs.append(_make_event(g_toeoff, -1))
                names.append("toe_off")
            elif phase == "II":
                evs.append(_make_event(lambda _t, yy: mdl.height(mdl.c_heel2, yy[:NQ]), -1))
                names.append("heel_strike")
            else:
                evs.append(_make_event(
                    lambda _t, yy: yy[QF2] - (0.5 * np.pi - mdl.gamma), -1))
                names.append("foot_strike")
            # knee 1 spring disengagement (falls through theta_dis)
            if knee[0] == "spring" and knee1_can_disengage:
                evs.append(_make_event(lambda _t, yy: yy[Q2] - yy[Q1] - th_dis, -1))
                names.append("knee1_disengage")
            # knee 2 spring engagement (crosses theta_eq either way) once armed
            if knee[1] != "spring" and knee2_armed:
                evs.append(_make_event(lambda _t, yy: yy[Q3] - yy[Q4] - th_eq, 0))
                names.append("knee2_engage")
            # damping switches of disengaged knees
            for k, (thigh, shank) in enumerate(((Q2, Q1), (Q3, Q4))):
                if knee[k] == "spring":
                    continue
                def fn(_t, yy, a=thigh, b=shank):
                    return yy[NQ + a] - yy[NQ + b]

                if knee[k] == "flex":
                    evs.append(_make_event(fn, -1))
                    names.append(f"knee{k + 1}_flex_to_ext")
                else:
                    evs.append(_make_event(fn, 1))
                    names.append(f"knee{k + 1}_ext_to_flex")

            sol = solve_ivp(rhs, (t, t_phase0 + max_T), y, method="RK45", rtol=RTOL,
                            atol=ATOL, events=evs)
            if not sol.success:
                raise StepFailure(f"phase {phase}: integration failed: {sol.message}")
            traj_t.append(sol.t)
            traj_y.append(sol.y)
            traj_ph.append((phase, kn, len(sol.t)))
            if sol.status != 1:
                raise StepFailure(f"phase {phase}: guard not reached within {max_T} s")
            fired = [(te[0], i) for i, te in enumerate(sol.t_events) if len(te)]
            t, i_ev = min(fired)
            y = sol.y_events[i_ev][0].copy()
            name = names[i_ev]
            events.append((name, float(t)))
            if name == "knee1_disengage":
                thk = y[Q2] - y[Q1]
                info["knee1_spring_energy_lost"] = 0.5 * mdl.k_k * (thk - th_eq) ** 2
                knee[0] = disengaged_mode(y[NQ + Q2] - y[NQ + Q1])
                knee1_can_disengage = False
            elif name == "knee2_engage":
                knee[1] = "spring"
                knee2_armed = False
            elif name.endswith("flex_to_ext"):
                knee[int(name[4]) - 1] = "ext"
            elif name.endswith("ext_to_flex"):
                knee[int(name[4]) - 1] = "flex"
            else:   # phase guard
                break
        durations[phase] = t - t_phase0

        if phase == "II":
            ahead = (mdl.point(mdl.c_heel2, y[:NQ]) - mdl.point(mdl.c_toe1, y[:NQ])) @ mdl.tang
            if ahead <= 0.0:
                raise StepFailure("phase II: swing heel hits the ground behind the stance toe")
        if diagnostics:
            # contact normal forces over the phase (at the solver's steps)
            sel_ph = [j for j, tp in enumerate(traj_ph) if tp[0] == phase]
            yy_all = np.hstack([traj_y[j] for j in sel_ph])
            kn_all = [traj_ph[j][1] for j in sel_ph for _ in range(traj_ph[j][2])]
            mins = {}
            for j in range(yy_all.shape[1]):
                _, lam = mdl.accel(yy_all[:NQ, j], yy_all[NQ:, j], rows, kn_all[j])
                if phase == "I":
                    forces = {"toe2": lam[0:2] @ n, "foot1": lam[2:4] @ n}
                elif phase == "II":
                    forces = {"foot1": lam[0:2] @ n}
                else:
                    forces = {"toe1": lam[0:2] @ n, "heel2": lam[2:4] @ n}
                for kf, v in forces.items():
                    mins[kf] = min(mins.get(kf, np.inf), float(v))
            info["min_normal"][phase] = mins
            if phase == "II":
                # swing toe clearance after 20 % of the phase
                tt = np.concatenate([traj_t[j] for j in sel_ph])
                sel = np.nonzero(tt >= t_phase0 + 0.2 * durations["II"])[0]
                clear = [mdl.height(mdl.c_toe2, yy_all[:NQ, j]) for j in sel]
                info["min_swing_toe_clearance"] = float(min(clear)) if clear else None

        # impacts
        if phase in ("II", "III"):
            imp = "heel_strike" if phase == "II" else "foot_strike"
            qd_plus, Lam = mdl.impact(y[:NQ], y[NQ:], IMPACT_ROWS[imp])
            info[imp + "_impulse"] = Lam
            y = np.concatenate([y[:NQ], qd_plus])
            if imp == "heel_strike":
                info["heel_strike_toe_impulse_n"] = float(Lam[0:2] @ n)
                info["heel1_rise_velocity"] = float(mdl.point_vel(mdl.c_heel1, y[:NQ],
                                                                  qd_plus) @ n)
            else:
                # foot-strike impulse: force Lam[2:4] at toe2 plus couple Lam[4] on foot 2
                qq = y[:NQ]
                Pn = float(Lam[2:4] @ n)
                couple = float(-mdl.l_f * np.sin(qq[QF2]) * Lam[4])
                toe2 = mdl.point(mdl.c_toe2, qq)
                # equivalent point of application along the sole, measured back from the toe
                info["foot_strike_normal_impulse"] = Pn
                dvec = np.array([np.sin(qq[QF2]), -np.cos(qq[QF2])])
                cross = dvec[0] * Lam[3] - dvec[1] * Lam[2]
                # force Lam[2:4] applied r behind the toe has moment -r (d x P) about the toe
                info["foot_strike_cop_from_toe"] = (-couple / cross) if cross != 0 else np.nan
                info["foot_strike_toe2_pos"] = toe2

    q_end, qd_end = y[:NQ].copy(), y[NQ:].copy()
    perm = [Q4, Q3, Q2, Q1, QF2, QF1]
    x7_end = np.concatenate([q_end[[Q4, Q3, Q2, QF1]], qd_end[[Q4, Q3, Q2]]])
    q_new = np.concatenate([q_end[perm], [0.0, 0.0]])
    qd_new = np.concatenate([qd_end[perm], [0.0, 0.0]])
    info["knee_modes_end"] = tuple(knee)
    out = {
        "x7_end": x7_end,
        "events": events,
        "phase_durations": durations,
        "step_time": float(t),
        "q_end": q_end,
        "qd_end": qd_end,
        "q_new": q_new,
        "qd_new": qd_new,
        "info": info,
    }
    if keep_trajectory:
        out["trajectory"] = (traj_t, traj_y, traj_ph)
    return out


# --------------------------------------------------------------------------------------------
def main(argv=None):
    p = load_params(argv[0] if argv else None)
    x0 = p["x0"]
    mdl = Model(p)
    res = simulate_step(x0, p, mdl)       # warm-up (and the reported result)
    n_rep = 5
    t0 = time.perf_counter()
    for _ in range(n_rep):
        simulate_step(x0, p, mdl, diagnostics=False)
    wall = (time.perf_counter() - t0) / n_rep
    t0 = time.perf_counter()
    simulate_step(x0, p)                  # including Model construction and diagnostics
    wall_full = time.perf_counter() - t0
    np.set_printoptions(precision=6, suppress=True, linewidth=110)
    print(f"slope = {p['slope']}, x0 (Table 2) = {x0}")
    print("events:")
    for name, te in res["events"]:
        print(f"  {te:10.6f} s  {name}")
    d = res["phase_durations"]
    print("phase durations [s]: " + ", ".join(f"{k}={v:.6f}" for k, v in d.items())
          + f"  (step {res['step_time']:.6f})")
    print("x7_end =", res["x7_end"])
    r = res["x7_end"] - x0
    print("x7_end - x0 =", r)
    print(f"residual ||x7_end - x0|| = {np.linalg.norm(r):.3e}")
    print("q_end  =", res["q_end"])
    print("qd_end =", res["qd_end"])
    inf = res["info"]
    print("min normal forces [N]:", {k: {kk: round(vv, 3) for kk, vv in v.items()}
                                     for k, v in inf["min_normal"].items()})
    print(f"heel-strike toe normal impulse = {inf['heel_strike_toe_impulse_n']:.4f} N s, "
          f"heel1 rise velocity = {inf['heel1_rise_velocity']:.4f} m/s")
    print(f"foot-strike normal impulse = {inf['foot_strike_normal_impulse']:.4f} N s, "
          f"point of application {inf['foot_strike_cop_from_toe']:.4f} m behind toe2")
    print(f"min swing toe clearance = {inf['min_swing_toe_clearance']:.4f} m; knee1 spring "
          f"energy lost at disengagement = {inf['knee1_spring_energy_lost']}")
    print(f"wall time per step: {wall * 1e3:.1f} ms (mean of {n_rep}, no diagnostics); "
          f"{wall_full * 1e3:.1f} ms with model setup and diagnostics")
    return res


if __name__ == "__main__":
    main(sys.argv[1:])
