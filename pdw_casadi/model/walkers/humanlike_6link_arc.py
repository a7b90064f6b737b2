"""The ankle-extended 6-link walker with rolling feet: toe and heel arcs (a rollover shape).

The walker of :mod:`pdw_casadi.model.walkers.humanlike_6link_ankle` (same chain, passive ankle
elements, knee rule, phases and section) with the rolling foot of
:mod:`pdw_casadi.model.feet.arc` on both legs (compliance keys ``r_toe``, ``r_heel``, m):
wherever the walker pivots on a toe or heel point the foot instead rolls without slip on
an arc. ``r_toe = r_heel = 0`` is the ankle walker.
"""

from __future__ import annotations

from pdw_casadi.model.feet.arc import ARC, ARC_SPAN

from . import humanlike_6link as base
from . import humanlike_6link_ankle as ankle

__all__ = ["ARC_SPAN", "COMPLIANCE_KEYS", "build"]
COMPLIANCE_KEYS = base.compliance_keys(ankle.EXTENSION, ARC)

build = base.register_six_link(
    "humanlike_6link_arc",
    "The humanlike 6-link walker with passive ankle extensions and rolling feet (toe and "
    "heel arcs, a rollover shape).",
    foot=ARC, ext=ankle.EXTENSION, nonnegative_compliance=ankle.EXTRA_NONNEGATIVE)
