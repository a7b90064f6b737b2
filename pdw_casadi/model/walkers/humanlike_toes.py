"""The ankle-extended 6-link walker with toe feet: rear foot and toes hinged at the MTP joint.

The walker of :mod:`pdw_casadi.model.walkers.humanlike_6link_ankle` (same chain, passive ankle
elements, knee rule, section state) with the toe foot of :mod:`pdw_casadi.model.feet.toes`
on both legs (8 bodies; extra coordinates ``qtoe1``, ``qtoe2``; compliance keys ``k_mtp``,
``c_mtp``, ``mtp_rest`` after the ankle walker's; anthropometry keys ``l_toe``, ``l_toec``,
``m_toe``, ``J_toe`` after Table 1's). The phases follow the contacts: I (leading foot flat,
trailing toes flat, its heel up), II (single stance on the flat foot, the swing toes
springing back), ``II_stop`` (the swing toes on their stop), ``II_mtp`` (heel off: the
stance foot on its toes, the rear foot rotating about the MTP joint), III (trailing toes
flat, leading heel); a gait whose stance heel stays down until the other heel strikes walks
I, II, II_stop, III. Everything stays passive: the MTP spring-damper and the stop's
inelastic impact close the energy books.
"""

from __future__ import annotations

from pdw_casadi.model.feet.toes import TOES

from . import humanlike_6link as base
from . import humanlike_6link_ankle as ankle

__all__ = ["COMPLIANCE_KEYS", "build"]
COMPLIANCE_KEYS = base.compliance_keys(ankle.EXTENSION, TOES)

build = base.register_six_link(
    "humanlike_toes",
    "The humanlike 6-link walker with passive ankle extensions and toe feet (rear foot and "
    "toes hinged at a spring-damped MTP joint; heel off in single support).",
    foot=TOES, ext=ankle.EXTENSION, nonnegative_compliance=ankle.EXTRA_NONNEGATIVE)
