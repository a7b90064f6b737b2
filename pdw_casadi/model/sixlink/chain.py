"""The 6-link walker's leg chain: shanks, thighs and the hip mass, hung from the stance ankle.

Absolute angles from the vertical with link direction d(q) = (sin q, -cos q)
(docs/model.md): q1 stance shank, q2 stance thigh, q3 swing thigh, q4 swing shank. The chain
runs from the stance ankle up through the stance knee to the hip and down the swing leg to
the swing ankle, where the feet attach (:mod:`pdw_casadi.model.feet`). Its elements are the
ankle springs-dampers between each foot and its shank (rest angle: foot perpendicular to
the shank, plus an extension's ``ankle_rest``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

from pdw_casadi.model.mechanics.planar import Body, direction
from pdw_casadi.model.mechanics.torques import JointTorque, spring_damper

#: the anthropometry of the chain and its feet (the paper's Table 1 keys), per leg but m_h
ANTHROPOMETRY_KEYS = ("l_s", "l_t", "l_f", "l_sc", "l_tc", "l_fc", "l_ft", "l_fh",
                      "m_h", "m_t", "m_s", "m_f", "J_t", "J_s", "J_f")


@dataclass
class Chain:
    """The chain's joint points (m, SX) and bodies (shank 1, thigh 1, thigh 2, shank 2, hip:
    the first bodies of eq. (1))."""

    knee1: ca.SX
    hip: ca.SX
    knee2: ca.SX
    ankle2: ca.SX
    bodies: list[Body]


def leg_chain(q1, q2, q3, q4, ankle1, a1, a2, m_h) -> Chain:
    """The chain from the stance ankle ``ankle1`` (m) with leg 1's and leg 2's anthropometry
    ``a1``, ``a2`` and the hip mass ``m_h`` (kg; numbers or SX)."""
    knee1 = ankle1 - a1["l_s"] * direction(q1)
    hip = knee1 - a1["l_t"] * direction(q2)
    knee2 = hip + a2["l_t"] * direction(q3)
    ankle2 = knee2 + a2["l_s"] * direction(q4)
    bodies = [
        Body("shank1", a1["m_s"], a1["J_s"], ankle1 - a1["l_sc"] * direction(q1), q1),
        Body("thigh1", a1["m_t"], a1["J_t"], knee1 - a1["l_tc"] * direction(q2), q2),
        Body("thigh2", a2["m_t"], a2["J_t"], knee2 - a2["l_tc"] * direction(q3), q3),
        Body("shank2", a2["m_s"], a2["J_s"], ankle2 - a2["l_sc"] * direction(q4), q4),
        Body("hip", m_h, 0.0, hip),
    ]
    return Chain(knee1, hip, knee2, ankle2, bodies)


def ankle_elements(qf1, q1, qf2, q4, c1, c2) -> list[JointTorque]:
    """The always-on ankle springs-dampers (``k_ankle`` N m/rad, ``c_ankle`` N m s/rad) of
    each leg, rest angle pi/2 + ``ankle_rest`` (rad, 0 if the walker has none) between the
    foot (angle ``qf``) and its shank."""
    return [
        JointTorque("ankle1", qf1, q1, spring_damper(
            c1["k_ankle"], math.pi / 2 + c1.get("ankle_rest", 0.0), c1["c_ankle"])),
        JointTorque("ankle2", qf2, q4, spring_damper(
            c2["k_ankle"], math.pi / 2 + c2.get("ankle_rest", 0.0), c2["c_ankle"])),
    ]
