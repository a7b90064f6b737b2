"""The paper's flat foot: one rigid link from heel to toe, pivoting on its toe and heel points.

The foot of leg i is a rigid body at absolute angle qf (mass ``m_f``, inertia ``J_f`` about
its centre of mass, ``l_fc`` from the ankle towards the toe); its sole runs from the heel
point ``l_fh`` behind the ankle to the toe point ``l_ft`` in front of it (``l_ft + l_fh =
l_f``). Flat on the ground it is held by three rows: its toe point (x, y) and the couple row
l_f cos(qf); it pivots on its toe or heel point (two rows each). The stance foot is the
chain's ground anchor: its toe point is the generalised coordinates (x_t1, y_t1).
"""

from __future__ import annotations

import casadi as ca

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.feet.base import FlatReading, Foot, FootLeg, Ground, Pivot
from pdw_casadi.model.hybrid import FAILURE, Event
from pdw_casadi.model.margins import IMPULSE, IMPULSE_COP
from pdw_casadi.model.mechanics.planar import Body, direction

#: the 6-link walker's phases with flat feet (docs/model.md)
#: the single-support phase (the stance foot flat, the other leg swinging); the feet built
#: on the flat foot (rocker, arc, toes) keep its name
SINGLE_SUPPORT = "II"
PHASE_DESCRIPTIONS = {"I": "leading foot flat + trailing toe pivot",
                      "II": "single stance on the flat foot, swing",
                      "III": "trailing toe + leading heel pivots"}
#: what touches the ground in each phase, (leg 1, leg 2): see pdw_casadi.gait.timing
PHASE_CONTACTS = {"I": ("flat", "toe"), "II": ("flat", None), "III": ("toe", "heel")}
#: instants of the paper's Fig. 4: a (foot strike), b (toe-off), c (heel strike)
INSTANT_LABELS = {"foot_strike": "a", "toe_off": "b", "heel_strike": "c"}


class FlatFootLeg(FootLeg):
    """The flat foot on one leg (module doc)."""

    def __init__(self, leg, angle, a, c, ground: Ground, *, root=None, ankle=None):
        self.leg, self.angle, self.a, self.c, self.ground = leg, angle, a, c, ground
        if root is not None:  # the stance foot: the chain hangs from its toe point
            toe = root
            ankle = toe - a["l_ft"] * direction(angle)
        else:
            toe = ankle + a["l_ft"] * direction(angle)
        heel = ankle - a["l_fh"] * direction(angle)
        self.ankle, self.toe, self.heel = ankle, toe, heel
        self.bodies = [Body(f"foot{leg}", a["m_f"], a["J_f"],
                            ankle + a["l_fc"] * direction(angle), angle)]
        ends = [(f"toe{leg}", toe), (f"heel{leg}", heel)]
        self.points = dict(ends if leg == 1 else ends[::-1])
        names = list(self.points)
        self.links = [(names[0], names[1])]

    def flat_rows(self):
        i = self.leg
        return (ca.vertcat(self.toe, self.a["l_f"] * ca.cos(self.angle)),
                (f"toe{i}_x", f"toe{i}_y", f"flat{i}"))

    def flat_reading(self, lam, single_support):
        """Normal force (N), centre of pressure (m from the toe) and its margin (m; the
        couple row l_f cos(qf) gives a torque -l_f sin(qf) lambda on the foot, so the centre
        of pressure lies s = -tau/N behind the toe and s N, (l_f - s) N are the smooth
        event functions, positive while N > 0 and the centre of pressure is on the sole)."""
        i, lf, n = self.leg, self.a["l_f"], self.ground.n
        force = ca.vertcat(lam[0], lam[1])
        normal = ca.dot(force, n)
        tau = -lf * ca.sin(self.angle) * lam[2]
        cop = -tau / normal
        tag = f"foot{i}"
        outs = {f"N_{tag}": normal, f"cop_{tag}_from_toe": cop,
                f"copmargin_{tag}": ca.fmin(cop, lf - cop),
                f"F_{tag}_x": lam[0], f"F_{tag}_y": lam[1]}
        events = [
            Event(f"foot{i}_lift", normal, -1, FAILURE, "stance foot normal force reaches zero"),
            Event(f"cop{i}_at_toe", -tau, -1, FAILURE, "centre of pressure reaches the stance toe"),
            Event(f"cop{i}_at_heel", lf * normal + tau, -1, FAILURE,
                  "centre of pressure reaches the stance heel"),
        ]
        return FlatReading(outs, events)

    def flat_impulse_checks(self, impulse):
        i, lf, n = self.leg, self.a["l_f"], self.ground.n
        normal = ca.dot(impulse[0:2], n)
        tau = -lf * ca.sin(self.angle) * impulse[2]
        checks = {f"impulse_foot{i}": normal, f"impulse_cop{i}_from_toe": -tau / normal,
                  f"impulse_cop{i}_from_heel": lf + tau / normal}
        return checks, {f"impulse_foot{i}": IMPULSE, f"impulse_cop{i}_from_toe": IMPULSE_COP,
                        f"impulse_cop{i}_from_heel": IMPULSE_COP}

    def flat_guard(self):
        return self.angle - (ca.pi / 2 - self.ground.gamma)

    def end_point(self, end):
        return {"toe": self.toe, "heel": self.heel}[end]

    def pivot(self, end, arm_first=False):
        tag = f"{end}{self.leg}"
        return Pivot(tag, self.end_point(end), (f"{tag}_x", f"{tag}_y"))

    def lowest(self, end):
        return self.ground.height(self.end_point(end))

    def resting_shank_cosine(self, knee_height, angle, shank_length):
        # toe height = 0: l_s cos(q + gamma) = knee.n + l_ft d(qf).n, d(a).n = -cos(a + gamma)
        return (knee_height - self.a["l_ft"] * ca.cos(angle + self.ground.gamma)) / shank_length


class FlatFoot(Foot):
    """The paper's flat foot (module doc)."""

    name = "flat"
    phase_descriptions = PHASE_DESCRIPTIONS
    phase_contacts = PHASE_CONTACTS
    instant_labels = INSTANT_LABELS
    leg_class = FlatFootLeg

    def check_anthropometry(self, a, where):
        """Foot geometry must close: heel-to-ankle + ankle-to-toe = foot length."""
        if abs(a["l_ft"] + a["l_fh"] - a["l_f"]) > 1e-9:
            raise ProblemError(f"{where}: 'anthropometry.l_ft' + 'anthropometry.l_fh' must "
                               f"equal 'anthropometry.l_f' ({a['l_ft']} + {a['l_fh']} != "
                               f"{a['l_f']})")

    def attach(self, leg, angle, a, c, ground, *, root=None, ankle=None):
        return self.leg_class(leg, angle, a, c, ground, root=root, ankle=ankle)


#: the flat foot of the paper's walker
FLAT = FlatFoot()
