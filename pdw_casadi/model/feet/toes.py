"""The toe foot: a rear foot and toes hinged at the metatarsophalangeal (MTP) joint.

Geometry (docs/model.md, "Toe foot"): the rear foot runs from the heel point ``l_fh``
behind the ankle to the MTP joint ``l_ft - l_toe`` in front of it, along d(qf) (qf: the
rear foot's absolute angle; the ankle joint acts on it); the toes run from the MTP joint
``l_toe`` to the toe tip along d(qtoe) (qtoe: the toes' absolute angle, the foot's extra
coordinate, ``qtoe1``, ``qtoe2``). The MTP angle phi = qtoe - qf is positive in
dorsiflexion (heel up, toes flat). Flat on the ground, rear foot and toes lie on one line
from heel to tip: the foot of Table 1 (``l_f``, ``l_ft``, ``l_fh``). Bodies: the toes
(``m_toe``, ``J_toe`` about their centre of mass, ``l_toec`` from the MTP joint) and the
rear foot, the rest of Table 1's foot (``m_f``, ``J_f``, ``l_fc``) so that the two bodies
in line are that foot exactly.

Joint elements: a torsional spring-damper at the MTP joint, tau = -k_mtp (phi - mtp_rest)
- c_mtp dphi on the toes (the opposite on the rear foot); a stop at phi = 0 (the toes in
line with the rear foot cannot plantarflex further). On the ground the stop is implied by
the flat contact; in swing the toes leave the ground dorsiflexed and come back to the stop
(an inelastic impact, ``toes_stop``, into phase ``II_stop``), which holds them in line until
the foot lands flat (the stop's torque must stay positive: failure ``stop2_release``).

Contacts (rows; the first two multipliers are the contact force at the toe tip):

- flat (phases I, II): tip (x, y), the toes flat (l_toe cos qtoe), the rear foot flat
  (l_r cos qf, l_r = l_f - l_toe): normal force, the whole foot's centre of pressure, the
  rear foot's ground moment about the MTP joint (``heelload``, N m: the heel-off guard
  ``heel_off`` in single support, a failure in double support) and the toes' ground moment
  about it (``toesload``: the toes lifting off, a failure);
- toes flat (``pivot("toe")``; the trailing foot in phase I, the stance foot after heel off,
  ``II_mtp``, and in phase III): tip (x, y) and the toes flat, the rear foot rotating about
  the MTP joint: the toes' centre of pressure from the MTP joint and its margin
  (``copmargin_toes*``), the failure of it reaching the MTP joint and of the heel coming
  back down (phi back to 0); its reaching the toe tip is the guard ``toes2_cop_at_tip`` of
  the trailing foot in phase I (the toes roll onto the tip, smoothly: the toes' couple is
  zero there) and a failure elsewhere (the walker has no phase for the stance toes on their
  tip before the other heel strikes);
- toe tip (``pivot("tip")``; the trailing foot in phase ``I_tip``, push-off about the tip):
  two rows, the toes rotating about the tip (their coming back flat is a failure), left at
  toe off (``toe_off_tip``, the tip's normal force reaching zero) into phase II;
- heel point (phase III): as the flat foot's.

``TOES_LOCKED`` is the same foot with the MTP joint locked (qtoe = qf, no extra coordinate
and no MTP element): two bodies rigidly in line, the flat foot of Table 1.

Segment parameters of the shipped problem: the toes body of OpenSim's gait2392 model
relative to its whole foot (talus + calcaneus + toes), scaled to Table 1's foot
(problems/humanlike_toes.toml).
"""

from __future__ import annotations

import casadi as ca

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.feet.base import FlatReading, Ground, Hold, Pivot, Stage
from pdw_casadi.model.feet.flat import FlatFoot, FlatFootLeg
from pdw_casadi.model.hybrid import FAILURE, GUARD, Event
from pdw_casadi.model.margins import IMPULSE, IMPULSE_COP
from pdw_casadi.model.mechanics.planar import Body, cross2, direction
from pdw_casadi.model.mechanics.torques import JointTorque, spring_damper

#: rad, the MTP angle must have exceeded this in a phase that starts with the foot flat
#: before its coming back to 0 (the heel down again) counts
HEEL_DOWN_ARM = 1e-6
#: m, how far below the ground the swing toe tip may go after toe off before that counts
#: (it leaves the ground at height 0)
TIP_DEPTH = 1e-6
TOE_KEYS = ("l_toe", "l_toec", "m_toe", "J_toe")
TOE_COMPLIANCE = ("k_mtp", "c_mtp", "mtp_rest")
#: the phases of single stance on the flat foot (the swing toes free or on their stop)
SINGLE_SUPPORT_PHASES = ("II", "II_stop")
PHASE_DESCRIPTIONS = {"I": "leading foot flat + trailing toes flat (heel up)",
                      "I_tip": "leading foot flat + trailing toe-tip pivot",
                      "I_stop": "leading foot flat + trailing toe-tip pivot, toes on their "
                                "stop (a rigid foot)",
                      "II": "single stance on the flat foot, swing toes free",
                      "II_stop": "single stance on the flat foot, swing toes on their stop",
                      "II_mtp": "single stance on the toes (heel off), swing",
                      "III": "trailing toes flat + leading heel pivot"}
PHASE_CONTACTS = {"I": ("flat", "toe"), "I_tip": ("flat", "toe"), "I_stop": ("flat", "toe"),
                  "II": ("flat", None),
                  "II_stop": ("flat", None), "II_mtp": ("toe", None), "III": ("toe", "heel")}
INSTANT_LABELS = {"foot_strike": "a", "toe_off": "b", "toe_off_tip": "b", "toe_off_stop": "b",
                  "heel_strike": "c",
                  "heel_strike_mtp": "c", "heel_off": "heel off", "toes_stop": "toes stop"}


def rear_body(a) -> tuple:
    """(mass kg, centre of mass m from the ankle towards the toe, inertia kg m^2 about it) of
    the rear foot: Table 1's foot (``m_f``, ``l_fc``, ``J_f``) less the toes in line."""
    m_r = a["m_f"] - a["m_toe"]
    toes_c = a["l_ft"] - a["l_toe"] + a["l_toec"]
    c_r = (a["m_f"] * a["l_fc"] - a["m_toe"] * toes_c) / m_r
    j_r = (a["J_f"] - a["J_toe"] - a["m_toe"] * (toes_c - a["l_fc"]) ** 2
           - m_r * (c_r - a["l_fc"]) ** 2)
    return m_r, c_r, j_r


class ToeFootLeg(FlatFootLeg):
    """The toe foot on one leg (module doc); ``toes``: the toes' absolute angle (rad, SX;
    None: locked in line with the rear foot)."""

    def __init__(self, leg, angle, a, c, ground: Ground, *, root=None, ankle=None,
                 toes=None):
        self.leg, self.angle, self.a, self.c, self.ground = leg, angle, a, c, ground
        self.locked = toes is None
        self.toes = angle if toes is None else toes
        self.l_am = a["l_ft"] - a["l_toe"]  # ankle to MTP joint
        self.l_r = a["l_f"] - a["l_toe"]  # heel to MTP joint
        if root is not None:  # the stance foot: the chain hangs from its toe tip
            tip = root
            mtp = tip - a["l_toe"] * direction(self.toes)
            ankle = mtp - self.l_am * direction(angle)
        else:
            mtp = ankle + self.l_am * direction(angle)
            tip = mtp + a["l_toe"] * direction(self.toes)
        heel = ankle - a["l_fh"] * direction(angle)
        self.ankle, self.mtp, self.toe, self.heel = ankle, mtp, tip, heel
        m_r, c_r, j_r = rear_body(a)
        self.bodies = [Body(f"rearfoot{leg}", m_r, j_r, ankle + c_r * direction(angle), angle),
                       Body(f"toes{leg}", a["m_toe"], a["J_toe"],
                            mtp + a["l_toec"] * direction(self.toes), self.toes)]
        ends = [(f"toe{leg}", tip), (f"mtp{leg}", mtp), (f"heel{leg}", heel)]
        self.points = dict(ends if leg == 1 else ends[::-1])
        names = list(self.points)
        self.links = [(names[0], names[1]), (names[1], names[2])]

    # -- the MTP joint --------------------------------------------------------------------
    @property
    def mtp_angle(self):
        """phi = qtoe - qf (rad, + dorsiflexion)."""
        return self.toes - self.angle

    def elements(self):
        if self.locked:
            return []
        c = self.c
        return [JointTorque(f"mtp{self.leg}", self.toes, self.angle,
                            spring_damper(c["k_mtp"], c["mtp_rest"], c["c_mtp"]))]

    def section_extra(self):
        # leg 1 flat, leg 2's toes flat on the ground (its heel up)
        return [] if self.locked else [ca.pi / 2 - self.ground.gamma]

    def _toes_moment(self, force, couple):
        """The toes' ground moment about the MTP joint (N m, + pushing the tip up) of the
        force at the tip and the couple multiplier of the toes-flat row."""
        tau_t = -self.a["l_toe"] * ca.sin(self.toes) * couple
        return cross2(self.toe - self.mtp, force) + tau_t

    # -- the foot flat ----------------------------------------------------------------------
    def flat_rows(self):
        if self.locked:
            return super().flat_rows()
        i = self.leg
        return (ca.vertcat(self.toe, self.a["l_toe"] * ca.cos(self.toes),
                           self.l_r * ca.cos(self.angle)),
                (f"toe{i}_x", f"toe{i}_y", f"toes{i}_flat", f"flat{i}"))

    def flat_reading(self, lam, single_support):
        """Normal force (N), the whole foot's centre of pressure (m from the tip) and its
        margin, the rear foot's and the toes' ground moments about the MTP joint (N m; the
        split of the load between the two segments is statically indeterminate, their
        moments are not): the rear foot's reaching zero is heel off (a guard in single
        support), the toes' reaching zero their lifting (a failure)."""
        if self.locked:
            return super().flat_reading(lam, single_support)
        i, lf, n = self.leg, self.a["l_f"], self.ground.n
        force = lam[0:2]
        normal = ca.dot(force, n)
        tau_r = -self.l_r * ca.sin(self.angle) * lam[3]
        toes = self._toes_moment(force, lam[2])
        tau_t = -self.a["l_toe"] * ca.sin(self.toes) * lam[2]
        moment = -(tau_t + tau_r)  # the whole foot's, about the tip (+: behind it)
        cop = moment / normal
        heel_load = -tau_r
        tag = f"foot{i}"
        outs = {f"N_{tag}": normal, f"cop_{tag}_from_toe": cop,
                f"copmargin_{tag}": ca.fmin(cop, lf - cop),
                f"heelload_{tag}": heel_load, f"toesload_{tag}": toes,
                f"F_{tag}_x": lam[0], f"F_{tag}_y": lam[1]}
        heel = (Event("heel_off", heel_load, -1, GUARD, "the rear foot's ground moment about "
                      "the MTP joint reaches zero: the stance heel lifts")
                if single_support else
                Event(f"heel{i}_lift", heel_load, -1, FAILURE, "the stance heel lifts in "
                      "double support"))
        events = [
            Event(f"foot{i}_lift", normal, -1, FAILURE, "stance foot normal force reaches zero"),
            heel,
            Event(f"toes{i}_lift", toes, -1, FAILURE,
                  "the stance toes' ground moment reaches zero: the toes lift"),
            Event(f"cop{i}_at_toe", moment, -1, FAILURE,
                  "centre of pressure reaches the stance toe tip"),
            Event(f"cop{i}_at_heel", lf * normal - moment, -1, FAILURE,
                  "centre of pressure reaches the stance heel"),
        ]
        return FlatReading(outs, events)

    def flat_impulse_checks(self, impulse):
        if self.locked:
            return super().flat_impulse_checks(impulse)
        i, lf, n = self.leg, self.a["l_f"], self.ground.n
        normal = ca.dot(impulse[0:2], n)
        tau_r = -self.l_r * ca.sin(self.angle) * impulse[3]
        tau_t = -self.a["l_toe"] * ca.sin(self.toes) * impulse[2]
        moment = -(tau_t + tau_r)
        checks = {f"impulse_foot{i}": normal, f"impulse_cop{i}_from_toe": moment / normal,
                  f"impulse_cop{i}_from_heel": lf - moment / normal,
                  f"impulse_heel{i}_moment": -tau_r,
                  f"impulse_toes{i}_moment": self._toes_moment(impulse[0:2], impulse[2])}
        return checks, {f"impulse_foot{i}": IMPULSE, f"impulse_cop{i}_from_toe": IMPULSE_COP,
                        f"impulse_cop{i}_from_heel": IMPULSE_COP,
                        f"impulse_heel{i}_moment": IMPULSE,
                        f"impulse_toes{i}_moment": IMPULSE}

    # -- the toes flat, the rear foot about the MTP joint -----------------------------------
    def pivot(self, end, arm_first=False):
        if end in ("tip", "tip_stopped") and not self.locked:
            return self._tip_pivot(stopped=end == "tip_stopped")
        if self.locked or end != "toe":
            return super().pivot(end, arm_first)
        i, lt = self.leg, self.a["l_toe"]
        tag = f"toes{i}"

        def reading(lam):
            normal = ca.dot(lam[0:2], self.ground.n)
            moment = self._toes_moment(lam[0:2], lam[2])
            cop = moment / normal
            return FlatReading(
                {f"cop_{tag}_from_mtp": cop, f"copmargin_{tag}": ca.fmin(cop, lt - cop),
                 f"toesload_{tag}": moment},
                [Event(f"{tag}_cop_at_mtp", moment, -1, FAILURE,
                       "the toes' centre of pressure reaches the MTP joint"),
                 Event(f"{tag}_cop_at_tip", lt * normal - moment, -1, GUARD,
                       "the toes' centre of pressure reaches the toe tip: they roll onto "
                       "it")])

        heel_down = Event(f"heel{i}_down", self.mtp_angle, -1, FAILURE,
                          "the heel comes back down (MTP angle back to 0)",
                          arm_above=HEEL_DOWN_ARM if arm_first else 0.0)
        return Pivot(tag, ca.vertcat(self.toe, lt * ca.cos(self.toes)),
                     (f"{tag}_x", f"{tag}_y", f"{tag}_flat"), events=[heel_down],
                     reading=reading)

    def _tip_pivot(self, stopped: bool) -> Pivot:
        """The toes rolled onto their tip: the tip point (two rows), the toes rotating about
        it; their coming back flat is a failure (the toes' angle from the ground, armed: it
        leaves 0 at rest); the MTP joint reaching its stop is a guard (``stopped``: it is
        there, held by the walker's hold rows)."""
        i = self.leg
        tilt = (ca.pi / 2 - self.ground.gamma) - self.toes  # + : MTP joint above the tip
        tag = f"tip{i}"
        return Pivot(tag, self.toe, (f"{tag}_x", f"{tag}_y"),
                     extras={f"toes{i}_tilt_deg": tilt * 180 / ca.pi},
                     events=[Event(f"toes{i}_down", tilt, -1, FAILURE,
                                   "the toes come back flat onto the ground",
                                   arm_above=HEEL_DOWN_ARM),
                             # the rear foot in line with the toes: the stop closes on
                             # the tip (a rigid foot on its tip, phase I_stop)
                             *([] if stopped else [Event(
                                 f"stop{i}_on_tip", self.mtp_angle, -1, GUARD,
                                 "the MTP joint reaches its stop on the toe tip")])])

    def lowest(self, end):
        if self.locked or end != "toe":
            return super().lowest(end)
        return ca.fmin(self.ground.height(self.toe), self.ground.height(self.mtp))

    def resting_shank_cosine(self, knee_height, angle, shank_length):
        if self.locked:
            return super().resting_shank_cosine(knee_height, angle, shank_length)
        # the MTP joint on the ground (toes flat):
        # l_s cos(q + gamma) = knee.n - l_am cos(qf + gamma)
        return (knee_height - self.l_am * ca.cos(angle + self.ground.gamma)) / shank_length

    # -- swing: the toes back on their stop -------------------------------------------------
    def swing_hold(self):
        if self.locked:
            return None
        i = self.leg

        def reading(lam):
            return FlatReading({f"stop{i}_Nm": lam[0]},
                               [Event(f"stop{i}_release", lam[0], -1, FAILURE,
                                      "the swing toes leave their stop")])

        # the tip leaves the ground at toe off at height 0: going below it (the toes
        # springing back faster than the foot rises) is a contact the swing has no phase for
        into = Event(f"tip{i}_into_ground", self.ground.height(self.toe) + TIP_DEPTH, -1,
                     FAILURE, "the swing toe tip goes into the ground before its toes are back "
                     "on their stop")
        return Hold("II_stop", "toes_stop", self.mtp_angle, (f"stop{i}",),
                    Event("toes_stop", self.mtp_angle, -1, GUARD,
                          "the swing toes come back in line with the rear foot (their stop)"),
                    reading, PHASE_DESCRIPTIONS["II_stop"], events=[into])


class ToeFoot(FlatFoot):
    """The toe foot (module doc); ``locked``: the MTP joint locked (the flat foot of Table 1
    as two bodies)."""

    anthropometry_keys = TOE_KEYS
    phase_descriptions = PHASE_DESCRIPTIONS
    phase_contacts = PHASE_CONTACTS
    instant_labels = INSTANT_LABELS

    def __init__(self, locked: bool = False):
        self.locked = locked
        self.name = "toes_locked" if locked else "toes"
        if locked:
            flat = FlatFoot()
            self.phase_descriptions = flat.phase_descriptions
            self.phase_contacts = flat.phase_contacts
            self.instant_labels = flat.instant_labels
        else:
            self.extra_coordinates = ("qtoe",)
            self.compliance_keys = TOE_COMPLIANCE
            self.nonnegative_compliance = ("k_mtp", "c_mtp")

    def check_anthropometry(self, a, where):
        """Table 1's foot closes, the toes are shorter than the ankle-to-toe length with
        their centre of mass on them, and the rear foot left has positive mass and
        inertia."""
        super().check_anthropometry(a, where)
        if not a["l_toe"] < a["l_ft"]:
            raise ProblemError(f"{where}: 'anthropometry.l_toe' must be shorter than "
                               f"'anthropometry.l_ft'")
        if not a["l_toec"] < a["l_toe"]:
            raise ProblemError(f"{where}: 'anthropometry.l_toec' must be shorter than "
                               f"'anthropometry.l_toe'")
        m_r, _, j_r = rear_body(a)
        if not (m_r > 0 and j_r > 0):
            raise ProblemError(f"{where}: the toes ('m_toe', 'J_toe', 'l_toec') leave the "
                               f"rear foot mass {m_r:.4g} kg, inertia {j_r:.4g} kg m^2 (both "
                               f"must be positive)")

    def attach(self, leg, angle, a, c, ground, *, root=None, ankle=None, extra=None):
        toes = None if self.locked else extra[0]
        return ToeFootLeg(leg, angle, a, c, ground, root=root, ankle=ankle, toes=toes)

    def trailing_stages(self, stance, swing, ground):
        """``I_tip``: the trailing toes rolled onto their tip (push-off about the tip,
        module doc), entered where their centre of pressure reaches the tip; none when
        locked."""
        if self.locked:
            return []
        return [Stage("I_tip", swing.pivot("tip"), entry_guard="toes2_cop_at_tip",
                      entry="toes_roll", toe_off="toe_off_tip",
                      description=self.phase_descriptions["I_tip"]),
                Stage("I_stop", swing.pivot("tip_stopped"), entry_guard="stop2_on_tip",
                      entry="toes_stop_tip",
                      toe_off="toe_off_stop", closes_hold=True,
                      description=self.phase_descriptions["I_stop"])]

    def stages(self, stance, swing, ground):
        """``II_mtp``: the stance foot on its toes after heel off, the rear foot rotating
        about the MTP joint (module doc); none when locked."""
        if self.locked:
            return []
        return [Stage("II_mtp", stance.pivot("toe", arm_first=True), entry_guard="heel_off",
                      entry="heel_off", heel_strike="heel_strike_mtp",
                      description=self.phase_descriptions["II_mtp"])]


#: the toe foot of the humanlike_toes walker
TOES = ToeFoot()
#: the toe foot with its MTP joint locked (the flat foot of Table 1 as two bodies)
TOES_LOCKED = ToeFoot(locked=True)
