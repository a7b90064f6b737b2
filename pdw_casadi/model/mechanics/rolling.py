"""A circular arc fixed in a foot that rolls without slip on the sloped ground line.

The arc has radius r and is tangent to the foot's sole line at a point of the sole (the toe
or the heel); its centre is C = point + r u(qf), with u(qf) = (cos qf, sin qf) the sole's
unit normal pointing into the foot (d(qf) = (sin qf, -cos qf) runs from heel to toe along
the sole). On the ground (normal n, downhill t) the arc touches at C - r n when

    C . n - r = 0         (the centre is r above the ground)
    C . t + r qf = const  (no slip: the centre advances r per radian rolled)

A clockwise roll (qf falling) carries the centre downhill, as a wheel rolling forward. Both
rows are holonomic; stacked as the world-frame vector C - r n + r qf t (the arc's *rolling
point*, which equals the sole point when r = 0) their multipliers are the contact force's
x and y components, so its normal force is lambda . n as for a point contact. Rolling
without slip does no work: the rows are ideal holonomic constraints.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca


def sole_normal(qf):
    """Unit normal (cos qf, sin qf) of the sole line at foot angle qf, pointing into the foot."""
    return ca.vertcat(ca.cos(qf), ca.sin(qf))


@dataclass(frozen=True)
class RollingArc:
    """A toe arc (``toe=True``) or heel arc of radius ``r`` (m) tangent to the sole at
    ``point`` (2x1 SX), on a foot at angle ``qf`` (rad), over ground with outward normal
    ``n``, downhill direction ``t`` and slope ``gamma`` (rad). ``span`` (rad): the arc's
    angular extent from its tangent point."""

    point: ca.SX
    qf: ca.SX
    r: ca.SX
    n: ca.SX
    t: ca.SX
    gamma: ca.SX
    span: float
    toe: bool

    @property
    def centre(self):
        """The arc's centre C (m)."""
        return self.point + self.r * sole_normal(self.qf)

    @property
    def rows(self):
        """The rolling rows as the world-frame rolling point C - r n + r qf t (m): its
        projection on n is C . n - r, on t it is C . t + r qf (module docstring)."""
        return self.centre - self.r * self.n + self.r * self.qf * self.t

    @property
    def contact_angle(self):
        """Angle (rad) from the arc's tangent point to the point over the ground, positive
        into the arc: pi/2 - gamma - qf for a toe arc (toe down), qf - (pi/2 - gamma) for a
        heel arc (toe up); 0 with the foot flat."""
        flat = ca.pi / 2 - self.gamma
        return flat - self.qf if self.toe else self.qf - flat

    @property
    def contact_length(self):
        """Arc length (m) from the tangent point to the point over the ground."""
        return self.r * self.contact_angle

    @property
    def lowest_height(self):
        """Height (m) above the ground of the arc's lowest point over its span: C . n - r
        while the contact angle lies in [0, span], else the height of the arc's end (the
        sole point below 0, the far end above the span)."""
        a = self.contact_angle
        return ca.dot(self.centre, self.n) - self.r * ca.cos(a - ca.fmin(ca.fmax(a, 0), self.span))

    @property
    def span_margin(self):
        """span - contact angle (rad): positive while the contact lies on the arc."""
        return self.span - self.contact_angle
