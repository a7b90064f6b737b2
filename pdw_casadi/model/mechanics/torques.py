"""Joint torque elements: pluggable laws acting +tau on one link and -tau on another.

Each law maps (relative angle, rate, parameters, mode weights) to a torque and a damping
power, as SX. Mode weights are 0/1 inputs that switch a law's branch (spring engaged or not,
flexion or extension damping) without rebuilding the CasADi graph.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import casadi as ca


@dataclass(frozen=True)
class JointTorque:
    """A torque element between two links.

    ``law(theta, theta_dot) -> (tau, spring_energy, damping_power)`` with tau in N m, energy in
    J and dissipated power (>= 0) in W; theta = plus_angle - minus_angle (rad).
    """

    name: str
    plus_angle: ca.SX
    minus_angle: ca.SX | None
    law: Callable


def spring_damper(stiffness, rest, damping):
    """Linear torsional spring-damper: tau = -k (theta - rest) - c theta_dot."""

    def law(theta, theta_dot):
        tau = -stiffness * (theta - rest) - damping * theta_dot
        return tau, 0.5 * stiffness * (theta - rest) ** 2, damping * theta_dot**2

    return law


def engageable_spring_damper(engaged, stiffness, rest, damping):
    """Spring that acts only while ``engaged`` (0/1 input) plus a damper whose coefficient
    ``damping`` is itself chosen by mode weights (e.g. flexion vs extension)."""

    def law(theta, theta_dot):
        spring = engaged * stiffness
        tau = -spring * (theta - rest) - damping * theta_dot
        return tau, 0.5 * spring * (theta - rest) ** 2, damping * theta_dot**2

    return law


def relative_angle(plus_angle, minus_angle):
    return plus_angle - (0 if minus_angle is None else minus_angle)


def total_torque(system, elements, qd):
    """Generalized torque, spring energy (J) and damping power (W) of a list of elements."""
    F = ca.SX.zeros(system.q.shape[0], 1)
    energy = 0
    power = 0
    for el in elements:
        theta = relative_angle(el.plus_angle, el.minus_angle)
        theta_dot = ca.jtimes(theta, system.q, qd)
        tau, e, pw = el.law(theta, theta_dot)
        F += system.generalized_torque(tau, el.plus_angle, el.minus_angle)
        energy += e
        power += pw
    return F, energy, power
