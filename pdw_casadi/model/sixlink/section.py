"""The 6-link walker's Poincare section: just after foot strike, legs swapped.

The section state is (q1, q2, q3, qf2, dq1, dq2, dq3) (docs/model.md): the stance foot
flat with its toe at the origin (qf1 = pi/2 - gamma, x_t1 = y_t1 = 0), the trailing foot at
rest on its toe contact. The trailing shank angle q4 follows from the trailing foot resting
on the ground (the foot's :meth:`~pdw_casadi.model.feet.base.FootLeg.resting_shank_cosine`,
the root nearer to q3), and (dq4, dqf2) from its toe contact being at rest.
"""

from __future__ import annotations

import casadi as ca

from pdw_casadi.model.feet.base import FootLeg, Ground

STATE_KEYS = ("q1", "q2", "q3", "qf2", "dq1", "dq2", "dq3")
#: the swap of legs at the Poincare section: new coordinate i is old coordinate SWAP[i]
SWAP = (3, 2, 1, 0, 5, 4)


def section_maps(q, knee2, trailing: FootLeg, shank_length, ground: Ground, p
                 ) -> tuple[ca.Function, ca.Function]:
    """``section_to_full(xs, p) -> x`` and ``full_to_section(x) -> xs`` for the chain
    coordinates ``q`` = [q1, q2, q3, q4, qf1, qf2, x_t1, y_t1] (x = [q; qd; W], W = 0 at
    the section); ``knee2``: the swing knee (m, SX in q); ``trailing``: leg 2's foot;
    ``shank_length``: leg 2's shank (m)."""
    gamma = ground.gamma
    q1, q2, q3, qf1, xt, yt = q[0], q[1], q[2], q[4], q[6], q[7]
    xs = ca.SX.sym("xs", len(STATE_KEYS))
    s_q1, s_q2, s_q3, s_qf2, s_d1, s_d2, s_d3 = (xs[i] for i in range(7))
    s_qf1 = ca.pi / 2 - gamma
    knee2_s = ca.substitute(knee2, ca.vertcat(q1, q2, q3, qf1, xt, yt),
                            ca.vertcat(s_q1, s_q2, s_q3, s_qf1, 0, 0))
    rhs_c = trailing.resting_shank_cosine(ground.height(knee2_s), s_qf2, shank_length)
    root = ca.acos(ca.fmin(ca.fmax(rhs_c, -1), 1))
    r_plus, r_minus = -gamma + root, -gamma - root
    s_q4 = ca.if_else(ca.fabs(r_plus - s_q3) < ca.fabs(r_minus - s_q3), r_plus, r_minus)
    q_s = ca.vertcat(s_q1, s_q2, s_q3, s_q4, s_qf1, s_qf2, 0, 0)
    # trailing toe contact at rest (a rolling arc rolls, not slips): solve for (dq4, dqf2)
    v_toe2 = ca.jacobian(trailing.pivot("toe").rows, q)
    Jt = ca.substitute(v_toe2, q, q_s)
    A = ca.horzcat(Jt[:, 3], Jt[:, 5])
    b = -(Jt[:, 0] * s_d1 + Jt[:, 1] * s_d2 + Jt[:, 2] * s_d3)
    sol = ca.solve(A, b)
    qd_s = ca.vertcat(s_d1, s_d2, s_d3, sol[0], 0, sol[1], 0, 0)
    section_to_full = ca.Function("section_to_full", [xs, p], [ca.vertcat(q_s, qd_s, 0)],
                                  ["xs", "p"], ["x"])
    xf = ca.SX.sym("x", 17)
    full_to_section = ca.Function(
        "full_to_section", [xf], [ca.vertcat(xf[0], xf[1], xf[2], xf[5], xf[8], xf[9], xf[10])],
        ["x"], ["xs"])
    return section_to_full, full_to_section
