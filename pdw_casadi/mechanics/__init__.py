"""Generic planar multibody mechanics (CasADi SX): chains, contact sets, torque elements."""

from .planar import Body, ContactSet, PlanarSystem, direction
from .torques import JointTorque

__all__ = ["Body", "ContactSet", "JointTorque", "PlanarSystem", "direction"]
