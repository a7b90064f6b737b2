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


def swap(ne: int = 0) -> tuple[int, ...]:
    """The leg swap of the first six chain coordinates (:data:`SWAP`), the stance anchor
    reset (the caller sets x_t1 = y_t1 = 0) and the feet's ``ne`` extra coordinates per
    leg exchanged: new coordinate i is old coordinate ``swap(ne)[i]`` (indices 6, 7: the
    anchor, kept for the length)."""
    return (*SWAP, 6, 7, *range(8 + ne, 8 + 2 * ne), *range(8, 8 + ne))


def section_maps(q, knee2, trailing: FootLeg, shank_length, ground: Ground, p,
                 leading: FootLeg | None = None) -> tuple[ca.Function, ca.Function]:
    """``section_to_full(xs, p) -> x`` and ``full_to_section(x) -> xs`` for the chain
    coordinates ``q`` = [q1, q2, q3, q4, qf1, qf2, x_t1, y_t1, then the feet's extra
    coordinates, leg 1's and leg 2's] (x = [q; qd; W], W = 0 at the section); ``knee2``:
    the swing knee (m, SX in q); ``trailing``: leg 2's foot; ``shank_length``: leg 2's
    shank (m); ``leading``: leg 1's foot (its extra coordinates' section values; needed
    only when the feet have extra coordinates). The trailing foot's extra coordinates take
    their section values, their rates with (dq4, dqf2) from its toe contact at rest."""
    gamma = ground.gamma
    nq = q.shape[0]
    lead_extra = leading.section_extra() if leading is not None else []
    trail_extra = trailing.section_extra()
    ne = len(trail_extra)
    if len(lead_extra) != ne or nq != 8 + 2 * ne:
        raise ValueError(f"section_maps: {nq} coordinates for feet with {len(lead_extra)} "
                         f"and {ne} extra coordinates")
    q1, q2, q3 = q[0], q[1], q[2]
    xs = ca.SX.sym("xs", len(STATE_KEYS))
    s_q1, s_q2, s_q3, s_qf2, s_d1, s_d2, s_d3 = (xs[i] for i in range(7))
    s_qf1 = ca.pi / 2 - gamma
    # the swing knee hangs from the stance foot: only leg 1's coordinates enter it
    lead_q = ca.vertcat(q1, q2, q3, q[4], q[6], q[7], *[q[8 + j] for j in range(ne)])
    lead_s = ca.vertcat(s_q1, s_q2, s_q3, s_qf1, 0, 0, *lead_extra)
    knee2_s = ca.substitute(knee2, lead_q, lead_s)
    rhs_c = trailing.resting_shank_cosine(ground.height(knee2_s), s_qf2, shank_length)
    root = ca.acos(ca.fmin(ca.fmax(rhs_c, -1), 1))
    r_plus, r_minus = -gamma + root, -gamma - root
    s_q4 = ca.if_else(ca.fabs(r_plus - s_q3) < ca.fabs(r_minus - s_q3), r_plus, r_minus)
    q_s = ca.vertcat(s_q1, s_q2, s_q3, s_q4, s_qf1, s_qf2, 0, 0, *lead_extra, *trail_extra)
    # trailing toe contact at rest (a rolling arc rolls, not slips): solve for (dq4, dqf2)
    # and the trailing foot's extra rates
    v_toe2 = ca.jacobian(trailing.pivot("toe").rows, q)
    Jt = ca.substitute(v_toe2, q, q_s)
    cols = [3, 5, *range(8 + ne, nq)]
    A = ca.horzcat(*[Jt[:, j] for j in cols])
    b = -(Jt[:, 0] * s_d1 + Jt[:, 1] * s_d2 + Jt[:, 2] * s_d3)
    sol = ca.solve(A, b)
    qd_s = ca.vertcat(s_d1, s_d2, s_d3, sol[0], 0, sol[1], 0, 0, ca.SX.zeros(ne, 1),
                      sol[2:])
    section_to_full = ca.Function("section_to_full", [xs, p], [ca.vertcat(q_s, qd_s, 0)],
                                  ["xs", "p"], ["x"])
    xf = ca.SX.sym("x", 2 * nq + 1)
    full_to_section = ca.Function(
        "full_to_section", [xf],
        [ca.vertcat(xf[0], xf[1], xf[2], xf[5], xf[nq], xf[nq + 1], xf[nq + 2])],
        ["x"], ["xs"])
    return section_to_full, full_to_section
