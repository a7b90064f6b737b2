"""Generic planar multibody mechanics (CasADi SX): chains, contact sets, torque elements."""

from pdw_casadi.model.mechanics.planar import Body, ContactSet, PlanarSystem, direction
from pdw_casadi.model.mechanics.torques import JointTorque

__all__ = ["Body", "ContactSet", "JointTorque", "PlanarSystem", "direction"]
