"""The foot interface of the 6-link walker: what one foot contributes to the walker.

The 6-link walker (:mod:`pdw_casadi.model.walkers.humanlike_6link`) is its leg chain
(:mod:`pdw_casadi.model.sixlink`: shanks, thighs, hip, ankle and knee elements, the
Poincare section) with a foot attached at each ankle. The walker's phases are named by what
each leg touches (docs/model.md): I (stance foot flat, trailing foot on its toe), II (stance
foot flat, swing), III (trailing toe, leading heel); a foot may add single-support stages
after II (the forefoot rocker's ``II_toe``). A foot is a :class:`Foot` (the family-level
description: its problem-file keys, its phases' faces, how it attaches) whose
:meth:`Foot.attach` gives a :class:`FootLeg` on one leg: its bodies and drawn points, the
rows of its contacts (flat on the ground, pivoting on its toe or heel end), what each contact
reports (forces, centre of pressure, margins) and which events end it, the height of its
ends in swing, the guard of foot flat, its impact checks and its share of the section state.

A new foot is a new module with a :class:`Foot` subclass (or a subclass of an existing
foot) registered as a walker family with
:func:`pdw_casadi.model.walkers.humanlike_6link.register_six_link`; no other module changes.

Conventions: link direction d(a) = (sin a, -cos a); a foot at angle qf runs from heel to toe
along d(qf); the ground has outward normal n and downhill direction t, slope gamma (rad);
forces in N, impulses in N s, lengths in m, angles in rad.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field

import casadi as ca

from pdw_casadi.model.hybrid import Event
from pdw_casadi.model.margins import Margin
from pdw_casadi.model.mechanics.planar import Body


@dataclass(frozen=True)
class Ground:
    """The sloped ground line: outward normal ``n``, downhill direction ``t`` (2x1 SX) and
    slope ``gamma`` (rad, SX)."""

    n: ca.SX
    t: ca.SX
    gamma: ca.SX

    def height(self, point):
        """Height (m) of ``point`` above the ground line (through the origin)."""
        return ca.dot(point, self.n)


@dataclass
class Pivot:
    """A contact of one foot end (toe or heel): holonomic rows whose first two multipliers
    are the contact force's world x, y components (N), so its normal force is lambda . n.
    ``extras``: further outputs of the contact (e.g. the rolling angle); ``events``: failures
    of the contact's own assumption (beyond its normal force reaching zero, which the walker
    adds). A contact with more than two rows (a segment of the foot held flat: the toes)
    reads its further multipliers with ``reading(lam)`` (``lam``: all of its multipliers,
    in the order of ``rows``), which gives its further outputs and events."""

    tag: str
    rows: ca.SX
    labels: tuple[str, ...]
    extras: dict[str, ca.SX] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)
    reading: Callable[[ca.SX], FlatReading] | None = None

    def read(self, lam) -> FlatReading:
        """Outputs and events of the contact from its multipliers (none without
        ``reading``)."""
        return self.reading(lam) if self.reading is not None else FlatReading({}, [])


@dataclass
class Hold:
    """Rows the swing foot closes in single support and holds until it lands flat (a joint
    of the foot reaching its stop: the toes coming back in line with the rear foot).

    ``guard``: the event of phase II at which they close (an impact, transition
    ``transition``, into the single-support phase ``phase``: phase II with the rows held);
    the walker adds the rows to every later contact of the step until foot strike (its
    stages, phase III, the heel-strike impacts) and reads them with ``reading(lam)`` (their
    multipliers: outputs and the events of their release). A heel strike or a stage guard
    reached before they close breaks the gait pattern (a failure). ``description``: the
    held phase for the figures."""

    phase: str
    transition: str
    rows: ca.SX
    labels: tuple[str, ...]
    guard: Event
    reading: Callable[[ca.SX], FlatReading]
    description: str = ""
    #: failures of the free swing in phase II before the rows close
    events: list[Event] = field(default_factory=list)


@dataclass
class FlatReading:
    """What a flat foot on the ground reports in a phase: ``outputs`` (names -> SX; the
    validity margins among them follow the naming rule of :mod:`pdw_casadi.model.margins`)
    and ``events`` (its failures, or guards such as heel off)."""

    outputs: dict[str, ca.SX]
    events: list[Event]


@dataclass
class Stage:
    """A single-support stage a foot adds after the flat stance (phase II): phase ``name``
    with the stance foot on ``pivot``, entered from the previous stage at its guard
    ``entry_guard`` through the smooth transition ``entry`` (no impact) and left at the swing
    heel's strike through the impact transition ``heel_strike`` (a name beginning with
    "heel_strike": extensions act at every heel strike by it); ``events``: its own
    failures (besides the pivot's normal force reaching zero); ``description``: a few words
    for the figures; ``contacts``: what each leg touches (the gait timing).

    A double-support stage after phase I (:meth:`Foot.trailing_stages`) has the trailing
    foot on ``pivot`` (the stance foot flat) and is left at toe off, the pivot's normal
    force reaching zero, through the smooth transition ``toe_off`` (a name beginning with
    "toe_off": extensions act at every toe off by it) into phase II."""

    name: str
    pivot: Pivot
    entry_guard: str
    entry: str
    heel_strike: str = ""
    events: list[Event] = field(default_factory=list)
    description: str = ""
    toe_off: str = ""
    #: a double-support stage entered through the impact that closes the swing foot's
    #: :class:`Hold` (its rows added to the stage's contact), left at toe off into the held
    #: single-support phase
    closes_hold: bool = False


class FootLeg(ABC):
    """One leg's foot, as attached by :meth:`Foot.attach` (subclasses fill in the model).

    ``leg``: 1 (the stance role of the step) or 2 (the swing role); ``angle``: the foot's
    absolute angle (rad, SX; the ankle joint acts between it and the shank; for a foot of
    several segments, the segment the ankle joint belongs to); ``ankle``:
    the ankle point (m); ``bodies``: its rigid bodies (after the leg chain's, in eq. (1)
    order); ``points`` / ``links``: named points and the links between them for drawing,
    listed outward from the ground for leg 1 and from the ankle for leg 2.
    """

    leg: int
    angle: ca.SX
    ankle: ca.SX
    bodies: list[Body]
    points: dict[str, ca.SX]
    links: list[tuple[str, str]]

    @abstractmethod
    def flat_rows(self) -> tuple[ca.SX, tuple[str, ...]]:
        """The rows (and their labels) holding the foot flat on the ground."""

    @abstractmethod
    def flat_reading(self, lam, single_support: bool) -> FlatReading:
        """Outputs and events of the flat contact from its multipliers ``lam`` (rows of
        :meth:`flat_rows`); ``single_support``: the other foot is in the air."""

    @abstractmethod
    def flat_impulse_checks(self, impulse) -> tuple[dict[str, ca.SX], dict[str, Margin]]:
        """Checks (N s, m) and their margins of a flat-foot impact with impulses
        ``impulse`` along :meth:`flat_rows` (the foot strike)."""

    @abstractmethod
    def flat_guard(self):
        """An expression falling through zero as the foot rotates flat onto the ground."""

    @abstractmethod
    def end_point(self, end: str):
        """World position (m) of the foot's ``end`` point ("toe" or "heel"): where the
        sole ends (the heel-strike order, the step length and the drawn foot use it)."""

    @abstractmethod
    def pivot(self, end: str, arm_first: bool = False) -> Pivot:
        """The contact of the foot's ``end`` ("toe" or "heel") pivoting on the ground;
        ``arm_first``: the phase begins with this foot flat (an event of the contact
        leaving flatness must see it leave first)."""

    @abstractmethod
    def lowest(self, end: str):
        """Height (m) above the ground of the lowest point of the foot's ``end`` ("toe",
        "heel") in swing: the clearance and the touch-down guard."""

    @abstractmethod
    def resting_shank_cosine(self, knee_height, angle, shank_length):
        """cos(q_shank + gamma) of this leg's shank when the foot at ``angle`` rests on
        its toe contact with the knee at ``knee_height`` (m) above the ground: the section
        places the trailing leg with it."""

    def section_extra(self) -> list:
        """Values (rad, m; SX in the slope) of the foot's extra coordinates
        (:attr:`Foot.extra_coordinates`) at the Poincare section: leg 1 flat on the ground,
        leg 2 resting on its toe contact (their rates follow from that contact at rest).
        None by default."""
        return []

    def elements(self) -> list:
        """The foot's own joint elements
        (:class:`~pdw_casadi.model.mechanics.torques.JointTorque`, e.g. a spring-damper
        between its segments); none by default."""
        return []

    def swing_hold(self) -> Hold | None:
        """Rows this leg closes and holds in swing (:class:`Hold`; leg 2); None by
        default."""
        return None


class Foot(ABC):
    """A foot design: its problem-file keys, its faces and how it attaches to a leg.

    ``anthropometry_keys``: anthropometry beyond the 6-link walker's own (per leg);
    ``extra_coordinates``: generalised coordinates the foot adds per leg (names without the
    leg index: ``qtoe`` gives ``qtoe1``, ``qtoe2``), appended after the chain's eight, leg
    1's then leg 2's, swapped with the legs at foot strike; :meth:`attach` then gets this
    leg's as ``extra``;
    ``compliance_keys`` / ``nonnegative_compliance``: compliance values it reads (per leg,
    after the walker's and an extension's); ``phase_descriptions``, ``phase_contacts``,
    ``instant_labels``: the faces of its walker's phases and transitions
    (:class:`pdw_casadi.model.walkers.registry.Family`).
    """

    name: str = "foot"
    anthropometry_keys: tuple[str, ...] = ()
    extra_coordinates: tuple[str, ...] = ()
    compliance_keys: tuple[str, ...] = ()
    nonnegative_compliance: tuple[str, ...] = ()
    phase_descriptions: dict[str, str] = {}
    phase_contacts: dict[str, tuple[str | None, str | None]] = {}
    instant_labels: dict[str, str] = {}

    def check_anthropometry(self, a, where) -> None:  # noqa: B027 (an optional hook)
        """Rules of the foot's geometry (raise ProblemError); none by default."""

    @abstractmethod
    def attach(self, leg: int, angle, a, c, ground: Ground, *, root=None,
               ankle=None) -> FootLeg:
        """The foot on leg ``leg`` at absolute angle ``angle`` with the leg's anthropometry
        ``a`` and compliance ``c`` (numbers or SX): the stance leg's foot from its ``root``
        (the chain's ground anchor, the generalised coordinates x_t1, y_t1), the swing
        leg's from its ``ankle``; a foot with :attr:`extra_coordinates` also gets this
        leg's (``extra=``, SX vector)."""

    def stages(self, stance: FootLeg, swing: FootLeg, ground: Ground) -> list[Stage]:
        """Single-support stages after the flat stance (phase II); none by default."""
        return []

    def trailing_stages(self, stance: FootLeg, swing: FootLeg, ground: Ground
                        ) -> list[Stage]:
        """Double-support stages after phase I, the trailing (``swing``) foot's contact
        changing before toe off (:class:`Stage`); none by default."""
        return []
