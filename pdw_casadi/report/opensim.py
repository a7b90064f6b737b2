"""Gaits as OpenSim files: a planar model (``.osim``), its motion (``.mot``), the ground
reaction forces (``.sto``) and an ``ExternalLoads`` XML that applies them.

The model (docs/opensim.md):

- OpenSim's ground frame is the toolkit's world frame: x downhill-horizontal, y up, z out of
  the plane (to the walker's right), gravity (0, -g, 0); the slope is the orientation of the
  ground's ``slope`` frame (rotated -slope about z, its x axis along the walking surface).
- The root is the ``pelvis``, a body at the hip carrying the lumped upper body ``m_h`` (a
  point mass: no inertia), jointed to ground by a planar joint (``pelvis_tilt``,
  ``pelvis_tx``, ``pelvis_ty``); the motion holds ``pelvis_tilt`` at 0, so each hip angle is
  the thigh's angle from the vertical. Each side has ``thigh_l``, ``shank_l`` and (6-link
  walker) ``foot_l`` bodies (compass gait: one ``leg_l``) on pin joints ``hip_l``, ``knee_l``,
  ``ankle_l`` with the coordinates ``hip_flexion_l`` (thigh ahead > 0), ``knee_angle_l``
  (shank relative to thigh, flexion < 0, as in OpenSim's gait models) and ``ankle_angle_l``
  (foot relative to the perpendicular of the shank, dorsiflexion > 0). Every body frame has
  its origin at its proximal joint and its -y axis along the link (the foot: x from heel to
  toe), so its z rotation is the toolkit's absolute angle (the foot's minus pi/2).
- Legs are roles in the toolkit (leg 1 in stance at the start of a step); the export follows
  physical legs: leg 1 of the first step is the left leg, as in the stride map
  (:mod:`pdw_casadi.gait.stride`), so the left leg is leg 1 in even steps and leg 2 in odd ones.
  Per-leg parameters (``[anthropometry.right]``) give each side its own bodies.
- The toolkit puts the stance toe back at the origin after every step; the export adds the
  distance walked, so that the motion continues down the slope.

The ground reaction forces are the contact multipliers of the toolkit's phases (N): a point
contact's force acts at the point, a flat foot's couple moves its centre of pressure along
the sole. In a planar model every contact wrench is a force through a point of the ground
line, so the free moments are zero up to rounding (they are written as computed). Impacts
are instantaneous impulses (N s), which a force table cannot hold: at an impact time the
table keeps the forces after it. Times are strictly increasing (OpenSim splines the
columns): of two samples at one time (an event), the later one is kept, whose coordinates
are the same (positions are continuous at impacts).
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import escape

import casadi as ca
import numpy as np
from matplotlib.figure import Figure

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.stride import stride_map
from pdw_casadi.model.hybrid import HybridSystem

__all__ = ["OpenSimExport", "WalkerSkeleton", "export_gait", "export_opensim", "fitted_problem",
           "plot_opensim_frames", "read_back", "read_storage", "skeleton"]

SIDES = ("l", "r")
#: the physical side of leg 1 (the stance leg at the section) in step k: left in even steps
ROLE_SIDES = {0: ("l", "r"), 1: ("r", "l")}
MOTION_HEADER_NOTE = ("Units are S.I. units (second, meters, Newtons, ...)\n"
                      "If the header above contains a line with 'inDegrees', this indicates "
                      "whether rotational values are in degrees (yes) or radians (no).\n")


def _d(a):
    """Unit vector (sin a, -cos a) of a link at absolute angle a (rad), see docs/model.md."""
    return ca.vertcat(ca.sin(a), -ca.cos(a))


@dataclass(frozen=True)
class Segment:
    """One body of a leg below the hip: its OpenSim names, the toolkit coordinates of its
    absolute angle in leg 1 and leg 2, and its geometry (m, kg, kg m^2) in its own frame."""

    body: str
    joint: str
    coordinate: str
    angles: tuple[str, str]
    length: float  # m, proximal joint to the next joint (foot: ankle to toe)
    mass: float
    inertia: float
    com: tuple[float, float]  # m, in the body frame
    #: rad, body frame angle minus the toolkit angle (the foot's x axis points heel -> toe)
    frame_offset: float = 0.0
    #: markers (name without side, position in the body frame, m)
    markers: tuple[tuple[str, tuple[float, float]], ...] = ()


@dataclass(frozen=True)
class WalkerSkeleton:
    """The OpenSim view of one walker: the pelvis mass, each side's segments (hip down),
    the body that touches the ground, and the toolkit point -> marker names."""

    family: str
    m_h: float
    legs: dict[str, tuple[Segment, ...]]
    contact_body: str  # without side
    slope: float
    g: float

    def coordinate_names(self) -> list[str]:
        names = ["pelvis_tilt", "pelvis_tx", "pelvis_ty"]
        for s in SIDES:
            names += [f"{seg.coordinate}_{s}" for seg in self.legs[s]]
        return names

    def rotational(self) -> list[bool]:
        return [n not in ("pelvis_tx", "pelvis_ty") for n in self.coordinate_names()]


def _six_link_leg(a: dict) -> tuple[Segment, ...]:
    thigh, shank, foot = (("q2", "q3"), ("q1", "q4"), ("qf1", "qf2"))
    return (
        Segment("thigh", "hip", "hip_flexion", thigh, a["l_t"], a["m_t"], a["J_t"],
                (0.0, -(a["l_t"] - a["l_tc"])), markers=(("knee", (0.0, -a["l_t"])),)),
        Segment("shank", "knee", "knee_angle", shank, a["l_s"], a["m_s"], a["J_s"],
                (0.0, -(a["l_s"] - a["l_sc"])), markers=(("ankle", (0.0, -a["l_s"])),)),
        Segment("foot", "ankle", "ankle_angle", foot, a["l_ft"], a["m_f"], a["J_f"],
                (a["l_fc"], 0.0), frame_offset=-math.pi / 2,
                markers=(("heel", (-a["l_fh"], 0.0)), ("toe", (a["l_ft"], 0.0)))),
    )


def _kneed_leg(a: dict) -> tuple[Segment, ...]:
    l_t, l_s = a["a2"] + a["b2"], a["a1"] + a["b1"]
    return (
        Segment("thigh", "hip", "hip_flexion", ("q2", "q3"), l_t, a["m_t"], a["J_t"],
                (0.0, -a["b2"]), markers=(("knee", (0.0, -l_t)),)),
        Segment("shank", "knee", "knee_angle", ("q1", "q4"), l_s, a["m_s"], a["J_s"],
                (0.0, -a["b1"]), markers=(("foot", (0.0, -l_s)),)),
    )


def _compass_leg(a: dict) -> tuple[Segment, ...]:
    leg = a["a"] + a["b"]
    return (Segment("leg", "hip", "hip_flexion", ("q_st", "q_sw"), leg, a["m"], 0.0,
                    (0.0, -a["b"]), markers=(("foot", (0.0, -leg)),)),)


#: the toolkit's coordinate names -> (the segments of one leg from its anthropometry, the
#: body that touches the ground)
_FAMILIES = {
    ("q1", "q2", "q3", "q4", "qf1", "qf2", "x_t1", "y_t1"): (_six_link_leg, "foot"),
    ("q1", "q2", "q3", "q4", "x_foot", "y_foot"): (_kneed_leg, "shank"),
    ("q_st", "q_sw", "x_foot", "y_foot"): (_compass_leg, "leg"),
}


def skeleton(problem, hs: HybridSystem, slope: float | None = None) -> WalkerSkeleton:
    """The OpenSim skeleton of ``problem``'s walker (per-leg anthropometry included) on a
    slope of ``slope`` rad (default: the problem's)."""
    key = tuple(hs.model.q_names)
    if key not in _FAMILIES:
        raise ProblemError(f"{problem.name} ({problem.family}): no OpenSim export for a "
                           f"walker with coordinates {', '.join(key)}")
    build, contact = _FAMILIES[key]
    sides = {"l": "left", "r": "right"}
    legs = {s: build(problem.leg_values(sides[s])[1]) for s in SIDES}
    m_h = problem.anthropometry["m_h"]
    return WalkerSkeleton(problem.family, m_h, legs, contact,
                          problem.slope if slope is None else float(slope), problem.g)


# --------------------------------------------------------------------------------------
# the model (OpenSim 4 XML, written as text: the export needs no OpenSim installation)
# --------------------------------------------------------------------------------------
def _v(*xs: float) -> str:
    return " ".join(_fmt(x) for x in xs)


def _offset_frame(name: str, parent: str, translation=(0.0, 0.0, 0.0), rz: float = 0.0,
                  geometry: str = "") -> str:
    geo = f"<attached_geometry>{geometry}</attached_geometry>" if geometry else ""
    return (f'<PhysicalOffsetFrame name="{name}">{geo}<socket_parent>{parent}</socket_parent>'
            f"<translation>{_v(*translation)}</translation>"
            f"<orientation>{_v(0, 0, rz)}</orientation></PhysicalOffsetFrame>")


def _coordinate(name: str, rotational: bool) -> str:
    lim = math.pi if rotational else 1000.0
    return (f'<Coordinate name="{name}"><default_value>0</default_value>'
            f"<range>{_v(-lim, lim)}</range><clamped>false</clamped>"
            f"<locked>false</locked></Coordinate>")


def _joint(kind: str, name: str, parent: str, child: str, parent_at: tuple[float, float],
           coords: list[tuple[str, bool]]) -> str:
    """A joint with its own offset frames: on the parent at ``parent_at`` (m, parent
    frame), on the child at its origin; both unrotated."""
    pf, cf = f"{parent.rsplit('/', 1)[-1]}_offset", f"{child.rsplit('/', 1)[-1]}_offset"
    return (f'<{kind} name="{name}"><socket_parent_frame>{pf}</socket_parent_frame>'
            f"<socket_child_frame>{cf}</socket_child_frame><coordinates>"
            + "".join(_coordinate(n, r) for n, r in coords)
            + "</coordinates><frames>"
            + _offset_frame(pf, parent, (*parent_at, 0.0)) + _offset_frame(cf, child)
            + f"</frames></{kind}>")


def _body(name: str, mass: float, com: tuple[float, float], inertia: tuple[float, float,
          float], components: str = "", geometry: str = "") -> str:
    comp = f"<components>{components}</components>" if components else ""
    geo = f"<attached_geometry>{geometry}</attached_geometry>" if geometry else ""
    return (f'<Body name="{name}">{comp}{geo}<mass>{_fmt(mass)}</mass>'
            f"<mass_center>{_v(*com, 0)}</mass_center>"
            f"<inertia>{_v(*inertia, 0, 0, 0)}</inertia></Body>")


def model_xml(sk: WalkerSkeleton, name: str, credits: str = "") -> str:
    """The ``.osim`` document of a skeleton: bodies (kg, m, kg m^2), joints, coordinates,
    markers at the toolkit's points, the slope frame and display geometry."""
    bodies = [_body("pelvis", sk.m_h, (0.0, 0.0), (0.0, 0.0, 0.0),
                    geometry='<Sphere name="pelvis_geometry"><radius>0.06</radius></Sphere>')]
    joints = [_joint("PlanarJoint", "ground_pelvis", "/ground", "/bodyset/pelvis",
                     (0.0, 0.0), [("pelvis_tilt", True), ("pelvis_tx", False),
                                  ("pelvis_ty", False)])]
    markers = [("hip", "pelvis", (0.0, 0.0))]
    for s in SIDES:
        parent, parent_end = "/bodyset/pelvis", (0.0, 0.0)
        for seg in sk.legs[s]:
            J = seg.inertia
            foot = bool(seg.frame_offset)
            # planar: only Izz enters the dynamics; Ixx, Iyy of a slender link (thigh,
            # shank along y, foot along x) keep the tensor physical (triangle inequality)
            inertia = (0.0, J, J) if foot else (J, 0.0, J)
            half = 0.5 * seg.length
            cyl = (f'<Cylinder name="{seg.body}_{s}_geometry"><radius>0.015</radius>'
                   f"<half_height>{_fmt(half)}</half_height></Cylinder>")
            # a cylinder's axis is its frame's y axis: along the link (the foot: along x)
            frame = _offset_frame(f"{seg.body}_{s}_display", "..",
                                  (half, 0.0, 0.0) if foot else (0.0, -half, 0.0),
                                  math.pi / 2 if foot else 0.0, cyl)
            body = f"/bodyset/{seg.body}_{s}"
            bodies.append(_body(f"{seg.body}_{s}", seg.mass, seg.com, inertia, frame))
            joints.append(_joint("PinJoint", f"{seg.joint}_{s}", parent, body, parent_end,
                                 [(f"{seg.coordinate}_{s}", True)]))
            markers += [(f"{m}_{s}", f"{seg.body}_{s}", at) for m, at in seg.markers]
            parent, parent_end = body, (0.0, -seg.length)
    slope_geo = ('<Brick name="slope_geometry"><half_lengths>3 0.002 0.3</half_lengths>'
                 "</Brick>")
    mk = "".join(f'<Marker name="{n}"><socket_parent_frame>/bodyset/{b}'
                 f"</socket_parent_frame><location>{_v(*at, 0)}</location><fixed>true</fixed>"
                 f"</Marker>" for n, b, at in markers)
    body_xml = "\n".join(bodies)
    joint_xml = "\n".join(joints)
    return f"""<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000">
<Model name="{escape(name)}">
<credits>{escape(credits)}</credits>
<Ground name="ground"><components>{_offset_frame("slope", "..", rz=-sk.slope,
                                                  geometry=slope_geo)}</components></Ground>
<gravity>{_v(0, -sk.g, 0)}</gravity>
<length_units>meters</length_units>
<force_units>N</force_units>
<BodySet name="bodyset"><objects>
{body_xml}
</objects><groups /></BodySet>
<JointSet name="jointset"><objects>
{joint_xml}
</objects><groups /></JointSet>
<MarkerSet name="markerset"><objects>{mk}</objects><groups /></MarkerSet>
</Model>
</OpenSimDocument>
"""


# --------------------------------------------------------------------------------------
# coordinates, forces and torques of the toolkit's samples
# --------------------------------------------------------------------------------------
class _Maps:
    """CasADi maps from the toolkit state to the OpenSim coordinates of a skeleton, for
    leg 1 on side ``ROLE_SIDES[parity][0]``. Every function takes many samples at once
    (states as columns)."""

    def __init__(self, sk: WalkerSkeleton, hs: HybridSystem, parity: int):
        model = hs.model
        q, qd, p, m = model.system.q, model.system.qd, model.p, model.m
        names = list(model.q_names)
        iq = {n: i for i, n in enumerate(names)}
        side_of_role = ROLE_SIDES[parity]
        coords = sk.coordinate_names()
        nq, nu = hs.nq, len(coords)
        x, subs = hs.x_sym, hs.subs_x
        # u(q): the pelvis at the hip (tilt 0), each joint angle the difference of its
        # bodies' frame angles
        u = [None] * nu
        hip = model.points["hip"]
        u[0], u[1], u[2] = ca.SX(0), hip[0], hip[1]
        for role, s in enumerate(side_of_role):
            prev = ca.SX(0)  # the pelvis frame's angle (the motion holds it at 0)
            for seg in sk.legs[s]:
                ang = q[iq[seg.angles[role]]] + seg.frame_offset
                u[coords.index(f"{seg.coordinate}_{s}")] = ang - prev
                prev = ang
        u = ca.vertcat(*u)
        A = ca.jacobian(u, q)
        ud = ca.mtimes(A, qd)
        qdd = ca.SX.sym("qdd", nq)
        udd = ca.mtimes(A, qdd) + ca.jtimes(ud, q, qd)
        self.u = ca.Function("u", [x, p, qdd], [subs(u), subs(ud), subs(udd)])
        # q(u): the toolkit coordinates from OpenSim's (pelvis_tilt free; the stance
        # contact point reached down leg 1), for the generalized forces tau_u = (dq/du)^T tau_q
        uu = ca.SX.sym("u", nu)
        qu = [None] * nq
        stance = ca.vertcat(uu[1], uu[2])
        for role, s in enumerate(side_of_role):
            ang = uu[0]
            for seg in sk.legs[s]:
                ang = ang + uu[coords.index(f"{seg.coordinate}_{s}")]
                qu[iq[seg.angles[role]]] = ang - seg.frame_offset
                if role == 0:
                    stance = stance + seg.length * _d(ang - seg.frame_offset)
        qu[nq - 2], qu[nq - 1] = stance[0], stance[1]
        dq_du = ca.Function("dq_du", [uu], [ca.jacobian(ca.vertcat(*qu), uu)])
        J = dq_du(u)  # at the sample's coordinates (invariant to the pelvis translation)
        # per phase: the joint torques (springs, dampers, extension elements and the
        # multipliers of internal rows such as the kneed walker's knee locks) in OpenSim's
        # coordinates, and each contact row's load: a point row's force component (N) or
        # a flat-foot row's couple on its foot (N m; the row depends on the foot angle only)
        F_joint = model.F_q - model.system.F_gravity - model.system.F_velocity
        pnames = list(model.parameter_names)
        slope = p[pnames.index("slope")]
        t_slope = ca.vertcat(ca.cos(slope), -ca.sin(slope))
        self.tau, self.contact, self.where = {}, {}, {}
        for ph in model.phases:
            E = ca.jacobian(ph.contact.rows, q)
            tau = F_joint
            loads = []
            # where each point contact's force acts (m, toolkit frame): the point of its
            # rows; a rolling arc's rows are its rolling point C - r n + r qf t, whose
            # material contact point is C - r n (pdw_casadi.model.mechanics.rolling)
            where = []
            for lab in ph.contact.labels:
                mpt = _POINT_ROW.match(lab)
                if mpt and mpt.group(3) == "x":
                    pair = ph.contact.rows[[ph.contact.labels.index(lab),
                                            ph.contact.labels.index(lab[:-1] + "y")]]
                    kind, role = mpt.group(1), mpt.group(2)
                    r_name = next((n for n in (f"r_{kind}@{role}", f"r_{kind}")
                                   if n in pnames), None)
                    if r_name is not None and ca.depends_on(pair, p[pnames.index(r_name)]):
                        pair = pair - (p[pnames.index(r_name)] * q[iq[f"qf{role}"]]
                                       * t_slope)
                    where.append(pair)
            self.where[ph.name] = ca.Function(f"where_{ph.name}", [x, p],
                                              [subs(ca.horzcat(*where)) if where
                                               else ca.SX(2, 0)])
            for i, lab in enumerate(ph.contact.labels):
                if lab.startswith("knee"):
                    tau = tau + E[i, :].T * ph.lam[i]
                    loads.append(ca.SX(0))
                elif _FLAT_ROW.match(lab):
                    qf = iq[f"qf{_FLAT_ROW.match(lab).group(1)}"]
                    loads.append(E[i, qf] * ph.lam[i])
                elif _POINT_ROW.match(lab):
                    loads.append(ph.lam[i])
                else:
                    raise ProblemError(f"contact row {lab!r} of phase {ph.name}: no OpenSim "
                                       f"export for it")
            self.tau[ph.name] = ca.Function(f"tau_{ph.name}", [x, p, m],
                                            [subs(ca.mtimes(J.T, tau))])
            self.contact[ph.name] = ca.Function(f"loads_{ph.name}", [x, p, m],
                                                [subs(ca.vertcat(*loads))])


_POINT_ROW = re.compile(r"^(toe|heel|foot)(\d)_([xy])$")
_FLAT_ROW = re.compile(r"^flat(\d)$")


@dataclass
class Samples:
    """The exported samples (one per distinct time): OpenSim coordinates (rad, m), their
    rates and accelerations, the toolkit's points in the world frame (m), the ground
    reaction force, centre of pressure and free moment of each side's contact body (N, m,
    N m, ground frame) and the joint torques of the toolkit in OpenSim's coordinates (N m;
    N for the pelvis translations)."""

    time: np.ndarray
    coordinates: list[str]
    rotational: list[bool]
    u: np.ndarray
    ud: np.ndarray
    udd: np.ndarray
    points: dict[str, np.ndarray]
    force: dict[str, np.ndarray]
    cop: dict[str, np.ndarray]
    free_moment: dict[str, np.ndarray]
    tau: np.ndarray
    phase: list[str] = field(default_factory=list)


def _kept_rows(t: np.ndarray) -> np.ndarray:
    """Indices of the rows kept: of several rows at one time (an event), the last."""
    t = np.asarray(t, float)
    keep = np.ones(len(t), bool)
    keep[:-1] = t[1:] > t[:-1]
    return np.flatnonzero(keep)


def _cross(a, b):
    """z of a x b for rows of planar vectors."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def sample(problem, result, hs: HybridSystem, p_steps, sk: WalkerSkeleton | None = None
           ) -> Samples:
    """Evaluate the export's quantities at every kept sample of a simulation ``result``
    (:class:`~pdw_casadi.gait.simulate.SimulationResult` with ``record=True``) of ``hs`` with the
    parameter vectors ``p_steps`` used in turn (one for a symmetric walker)."""
    traj = result.trajectory
    if traj is None or traj.empty or result.sample_modes is None:
        raise ProblemError("the OpenSim export needs a recorded simulation (record=True) "
                           "with at least one sample")
    ps = [np.asarray(v, float).ravel() for v in p_steps]
    sk = sk or skeleton(problem, hs, _slope(hs, ps[0]))
    maps = [_Maps(sk, hs, 0), _Maps(sk, hs, 1)]
    names = list(hs.model.q_names)
    nq = hs.nq
    X = np.hstack([traj[names].to_numpy(float), traj[["d" + n for n in names]].to_numpy(float),
                   traj[["damping_work_J"]].to_numpy(float)])
    steps = traj["step"].to_numpy(int)
    phases = traj["phase"].to_numpy(str)
    modes = np.asarray(result.sample_modes, float)
    point_names = hs.point_names
    npt = len(point_names)

    def points(xs, k):  # (samples, points, 2), m, in the toolkit's frame of step k
        P = np.asarray(hs.points(xs.T, ps[k % len(ps)]))
        return P.reshape(2, len(xs), npt).transpose(1, 2, 0)

    # the distance walked: the hip is continuous across a step's end, so each step's
    # offset is the previous one plus the hip's jump in the toolkit's (re-centred) frame
    hip_i = point_names.index("hip")
    offsets = {int(steps[0]): np.zeros(2)}
    for i in np.flatnonzero(steps[1:] != steps[:-1]) + 1:
        jump = points(X[i - 1:i], steps[i - 1])[0, hip_i] - points(X[i:i + 1], steps[i])[0, hip_i]
        offsets[int(steps[i])] = offsets[int(steps[i - 1])] + jump
    keep = _kept_rows(traj["t"].to_numpy(float))
    coords = sk.coordinate_names()
    n = len(keep)
    U, UD, UDD, TAU = (np.zeros((n, len(coords))) for _ in range(4))
    P = np.zeros((n, npt, 2))
    force = {s: np.zeros((n, 2)) for s in SIDES}
    cop = {s: np.zeros((n, 2)) for s in SIDES}
    free = {s: np.zeros(n) for s in SIDES}
    tangent = np.array([math.cos(sk.slope), -math.sin(sk.slope)])
    # runs of kept samples with one step, phase and mode: one call per run and function
    key = [(int(steps[i]), phases[i], tuple(modes[i])) for i in keep]
    starts = [0] + [j for j in range(1, n) if key[j] != key[j - 1]] + [n]
    for a, b in zip(starts[:-1], starts[1:], strict=True):
        k, ph, _ = key[a]
        rows, p, mv = keep[a:b], ps[k % len(ps)], modes[keep[a]]
        mp, side = maps[k % 2], ROLE_SIDES[k % 2]
        Xg = X[rows].T
        qdd = np.asarray(hs.rhs[ph](Xg, p, mv))[nq:2 * nq]
        u, ud, udd = (np.asarray(v).T for v in mp.u(Xg, p, qdd))
        u[:, 1:3] += offsets[k]
        U[a:b], UD[a:b], UDD[a:b] = u, ud, udd
        TAU[a:b] = np.asarray(mp.tau[ph](Xg, p, mv)).T
        Pg = points(X[rows], k) + offsets[k]
        P[a:b] = Pg
        loads = np.asarray(mp.contact[ph](Xg, p, mv))
        labels = hs.phases[ph].contact.labels
        pairs = [lab[:-2] for lab in labels if _POINT_ROW.match(lab) and lab.endswith("_x")]
        where = np.asarray(mp.where[ph](Xg, p)).reshape(2, b - a, len(pairs)) \
            .transpose(1, 2, 0) + offsets[k]
        wrench = {s: [np.zeros((b - a, 2)), np.zeros(b - a), {}] for s in SIDES}
        for r, lab in enumerate(labels):
            mpt, mfl = _POINT_ROW.match(lab), _FLAT_ROW.match(lab)
            if mpt:
                s = side[int(mpt.group(2)) - 1]
                point = f"{mpt.group(1)}{mpt.group(2)}"
                at = where[:, pairs.index(point)]
                f = np.zeros((b - a, 2))
                f[:, "xy".index(mpt.group(3))] = loads[r]
                wrench[s][0] += f
                wrench[s][1] += _cross(at, f)
                wrench[s][2][point] = at
            elif mfl:
                wrench[side[int(mfl.group(1)) - 1]][1] += loads[r]
        for s in SIDES:
            F, M0, at = wrench[s]
            at = list(at.values())
            force[s][a:b] = F
            if not at:
                continue
            N = F @ np.array([-tangent[1], tangent[0]])  # t x F: the normal force
            if len(at) == 1 and np.allclose(M0, _cross(at[0], F), rtol=1e-12, atol=1e-12):
                C = at[0]  # one point contact, no couple: the force acts there
            else:
                # the point of the ground line (through the origin along t) about which
                # the force has the contact's moment: (c t) x F = c N = M0
                safe = np.where(np.abs(N) > 1e-12, N, 1.0)
                C = np.where((np.abs(N) > 1e-12)[:, None], (M0 / safe)[:, None] * tangent,
                             at[0])
            cop[s][a:b] = C
            free[s][a:b] = M0 - _cross(C, F)
    pts = {}
    for c, pn in enumerate(point_names):
        role = re.fullmatch(r"(\w+?)(\d)", pn)
        if role is None:
            pts[pn] = P[:, c]
            continue
        for parity in (0, 1):
            sel = steps[keep] % 2 == parity
            name = f"{role.group(1)}_{ROLE_SIDES[parity][int(role.group(2)) - 1]}"
            pts.setdefault(name, np.zeros((n, 2)))[sel] = P[sel, c]
    return Samples(traj["t"].to_numpy(float)[keep], coords, sk.rotational(), U, UD, UDD,
                   pts, force, cop, free, TAU, list(phases[keep]))


# --------------------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------------------
def _slope(hs: HybridSystem, p) -> float:
    """The slope (rad) in a parameter vector of ``hs``."""
    return float(np.asarray(p, float).ravel()[list(hs.model.parameter_names).index("slope")])


def _fmt(v: float) -> str:
    """A number as the shortest text that reads back as the same double (positions and
    forces round-trip exactly through the files)."""
    return repr(float(v)) if math.isfinite(v) else "nan"


def write_storage(path: Path, name: str, columns: list[str], time: np.ndarray,
                  data: np.ndarray, in_degrees: bool) -> Path:
    """An OpenSim storage file (``.mot``/``.sto``, version 1 header with nRows, nColumns
    and inDegrees) of ``data`` (rows x columns) against ``time`` (s)."""
    rows = ["\t".join([_fmt(t), *map(_fmt, r)]) for t, r in zip(time, data, strict=True)]
    head = (f"{name}\nversion=1\nnRows={len(rows)}\nnColumns={len(columns) + 1}\n"
            f"inDegrees={'yes' if in_degrees else 'no'}\n\n{MOTION_HEADER_NOTE}\nendheader\n")
    path.write_text(head + "\t".join(["time", *columns]) + "\n" + "\n".join(rows) + "\n")
    return path


def read_storage(path: Path) -> tuple[dict[str, str], list[str], np.ndarray]:
    """(header fields, column names, data with time first) of a storage file written by
    :func:`write_storage` (plain reader for checks; OpenSim reads them with ``Storage``)."""
    lines = Path(path).read_text().splitlines()
    end = lines.index("endheader")
    header = dict(line.split("=", 1) for line in lines[:end] if "=" in line)
    cols = lines[end + 1].split("\t")
    data = np.array([[float(v) for v in line.split("\t")] for line in lines[end + 2:] if line])
    return header, cols, data


def force_columns(side: str) -> list[str]:
    """The columns of one side's ground reaction in the force table."""
    return ([f"ground_force_{side}_v{a}" for a in "xyz"]
            + [f"ground_force_{side}_p{a}" for a in "xyz"]
            + [f"ground_torque_{side}_{a}" for a in "xyz"])


def write_external_loads(path: Path, forces_file: str, sk: WalkerSkeleton) -> Path:
    """The ``ExternalLoads`` XML applying each side's ground reaction (force, point and
    free moment expressed in ground) to its contact body."""
    items = []
    for s in SIDES:
        items.append(f"""\t\t\t<ExternalForce name="ground_reaction_{s}">
\t\t\t\t<isDisabled>false</isDisabled>
\t\t\t\t<applied_to_body>{sk.contact_body}_{s}</applied_to_body>
\t\t\t\t<force_expressed_in_body>ground</force_expressed_in_body>
\t\t\t\t<point_expressed_in_body>ground</point_expressed_in_body>
\t\t\t\t<force_identifier>ground_force_{s}_v</force_identifier>
\t\t\t\t<point_identifier>ground_force_{s}_p</point_identifier>
\t\t\t\t<torque_identifier>ground_torque_{s}_</torque_identifier>
\t\t\t\t<data_source_name>{escape(forces_file)}</data_source_name>
\t\t\t</ExternalForce>""")
    body = "\n".join(items)
    path.write_text(f"""<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000">
\t<ExternalLoads name="ground_reactions">
\t\t<objects>
{body}
\t\t</objects>
\t\t<groups />
\t\t<datafile>{escape(forces_file)}</datafile>
\t</ExternalLoads>
</OpenSimDocument>
""")
    return path


def write_id_setup(path: Path, name: str, t0: float, t1: float) -> Path:
    """A setup file of OpenSim's ``InverseDynamicsTool`` for the exported files (beside it,
    by relative name): ``opensim-cmd run-tool <name>_id_setup.xml`` writes the generalized
    forces to ``inverse_dynamics/<name>_id.sto`` (columns as in the joint-torque file).
    The coordinates are not filtered (cut-off -1): the motion is a simulation, not noisy
    data."""
    path.write_text(f"""<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000">
\t<InverseDynamicsTool name="{escape(name)}_id">
\t\t<results_directory>inverse_dynamics</results_directory>
\t\t<model_file>{escape(name)}.osim</model_file>
\t\t<time_range>{_v(t0, t1)}</time_range>
\t\t<forces_to_exclude />
\t\t<external_loads_file>{escape(name)}_external_loads.xml</external_loads_file>
\t\t<coordinates_file>{escape(name)}.mot</coordinates_file>
\t\t<lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
\t\t<output_gen_force_file>{escape(name)}_id.sto</output_gen_force_file>
\t</InverseDynamicsTool>
</OpenSimDocument>
""")
    return path


@dataclass
class OpenSimExport:
    """The files of one export (paths) and the samples written to them."""

    model: Path
    motion: Path
    forces: Path
    external_loads: Path
    torques: Path
    id_setup: Path
    samples: Samples

    def to_dict(self) -> dict:
        return {"model": str(self.model), "motion": str(self.motion),
                "forces": str(self.forces), "external_loads": str(self.external_loads),
                "torques": str(self.torques), "id_setup": str(self.id_setup)}


def export_opensim(problem, result, out_dir, hs: HybridSystem, p_steps,
                   name: str | None = None) -> OpenSimExport:
    """Write the OpenSim files of a recorded simulation ``result`` of ``problem`` into
    ``out_dir`` (created if missing) and return their paths.

    ``hs``: the simulator's hybrid system; ``p_steps``: the parameter vectors of the steps
    in turn (``[problem.parameter_vector()]`` for a symmetric walker; a per-leg walker's
    from :func:`pdw_casadi.gait.stride.stride_simulator`). Files (``name`` defaults to the
    problem's): ``<name>.osim`` (model), ``<name>.mot`` (coordinates, degrees and m),
    ``<name>_grf.sto`` (per side: force N, centre of pressure m, free moment N m, in
    ground), ``<name>_external_loads.xml``, ``<name>_joint_torques.sto`` (the toolkit's
    joint torques by coordinate, N m: the reference for OpenSim's inverse dynamics) and
    ``<name>_id_setup.xml`` (OpenSim's inverse-dynamics tool on these files).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    name = name or problem.name
    # the slope the gait walked on: the parameters' (a fit may have moved it)
    sk = skeleton(problem, hs, _slope(hs, p_steps[0]))
    smp = sample(problem, result, hs, p_steps, sk)
    osim_path = out / f"{name}.osim"
    osim_path.write_text(model_xml(sk, name, credits=(
        f"pdw-casadi export of {problem.name} ({problem.family}), slope {problem.slope!r} rad; "
        f"{len(set(result.trajectory['step']))} steps")))
    deg = np.where(smp.rotational, 180 / math.pi, 1.0)
    motion = write_storage(out / f"{name}.mot", "Coordinates", smp.coordinates, smp.time,
                           smp.u * deg, in_degrees=True)
    cols, data = [], []
    for s in SIDES:
        cols += force_columns(s)
        z = np.zeros(len(smp.time))
        data += [smp.force[s][:, 0], smp.force[s][:, 1], z, smp.cop[s][:, 0],
                 smp.cop[s][:, 1], z, z, z, smp.free_moment[s]]
    forces = write_storage(out / f"{name}_grf.sto", "ground_reactions", cols, smp.time,
                           np.column_stack(data), in_degrees=False)
    loads = write_external_loads(out / f"{name}_external_loads.xml", forces.name, sk)
    torques = write_storage(out / f"{name}_joint_torques.sto", "joint_torques",
                            [f"{c}_{'moment' if r else 'force'}" for c, r in
                             zip(smp.coordinates, smp.rotational, strict=True)],
                            smp.time, smp.tau, in_degrees=False)
    setup = write_id_setup(out / f"{name}_id_setup.xml", name, smp.time[0], smp.time[-1])
    return OpenSimExport(osim_path, motion, forces, loads, torques, setup, smp)


def export_gait(problem, state, out_dir, parameters=None, steps: int = 2,
                name: str | None = None) -> OpenSimExport:
    """Simulate ``steps`` steps of ``problem`` from section state ``state`` (rad, rad/s;
    ``parameters``: the parameter vector, default the problem's) and export them
    (:func:`export_opensim`). A walker whose legs differ runs on the stride map's
    per-leg walker (``parameters``: its physical parameters)."""
    if problem.asymmetric:
        smap = stride_map(problem)
        theta = smap.default_parameters() if parameters is None else parameters
        sim, p_steps = Simulator(smap.problem, smap.hs), list(smap.step_parameters(theta))
    else:
        sim = Simulator(problem)
        p_steps = [problem.parameter_vector() if parameters is None else parameters]
    result = sim.run(np.asarray(state, float), p_steps[0], steps=steps, record=True,
                     p_steps=p_steps)
    if result.failure is not None:
        raise ProblemError(f"{problem.name}: the simulation for the export failed in step "
                           f"{result.failure.step}: {result.failure.reason}")
    return export_opensim(problem, result, out_dir, sim.hs, p_steps, name=name)


def read_back(export: OpenSimExport, id_rows=None, python: str | None = None,
              timeout: float = 600.0, tool: bool = False) -> dict:
    """OpenSim's view of an export: marker positions at every frame of the motion, the
    force table as OpenSim reads it and OpenSim's inverse dynamics (with the exported
    external loads) at the samples ``id_rows`` (indices into ``export.samples``; default
    all); with ``tool``, also the results of OpenSim's inverse-dynamics tool run from the
    export's setup file (``tool_time``, ``tool_columns``, ``tool_data``). Needs the
    ``opensim`` package; runs :mod:`pdw_casadi.report.opensim_check` in a child process
    (``python``: its interpreter, default this one), because OpenSim and CasADi cannot
    share a process (module docstring there). Returns its arrays by name.
    """
    smp = export.samples
    rows = np.arange(len(smp.time)) if id_rows is None else np.asarray(id_rows, int)
    with tempfile.TemporaryDirectory() as tmp:
        req, res = Path(tmp) / "request.npz", Path(tmp) / "result.npz"
        np.savez(req, forces_path=str(export.forces), id_time=smp.time[rows],
                 coordinates=np.array(smp.coordinates), id_speed=smp.ud[rows],
                 id_acceleration=smp.udd[rows],
                 id_setup=str(export.id_setup) if tool else "")
        script = Path(__file__).with_name("opensim_check.py")
        done = subprocess.run([python or sys.executable, str(script), str(export.model),
                               str(export.motion), str(export.external_loads), str(req),
                               str(res)], capture_output=True, text=True, timeout=timeout)
        if done.returncode != 0:
            raise RuntimeError(f"OpenSim could not read the export back (exit code "
                               f"{done.returncode}): {done.stderr.strip()[-2000:]}")
        with np.load(res, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}


def plot_opensim_frames(back: dict, path=None, n: int = 4, axis_length: float = 0.08,
                        title: str = "the walker as OpenSim sees it"):
    """A picture of the model from OpenSim's own numbers (:func:`read_back`): at ``n``
    frames spread over the motion, each body frame's origin and its x (red) and y (green)
    axes (``axis_length`` m), the links between the markers and the walking surface.
    Saved to ``path`` when given; returns the figure."""
    frames, markers = back["body_frames"], back["marker_positions"]
    names = [str(m) for m in back["marker_names"]]
    chain = {s: [m for m in ("hip", f"knee_{s}", f"ankle_{s}", f"foot_{s}") if m in names]
             for s in SIDES}
    feet = {s: [m for m in (f"heel_{s}", f"ankle_{s}", f"toe_{s}", f"heel_{s}")
                if m in names] for s in SIDES}
    picks = np.linspace(0, len(frames) - 1, n).round().astype(int)
    # a Figure without pyplot: no backend is chosen or switched (as pdw_casadi.report.plots)
    fig = Figure(figsize=(10, 4.2), layout="constrained")
    ax = fig.add_subplot()
    colours = {"l": "tab:blue", "r": "tab:orange"}
    for k, i in enumerate(picks):
        alpha = 0.35 + 0.65 * k / max(n - 1, 1)
        for s in SIDES:
            for line in (chain[s], feet[s]):
                if len(line) > 1:
                    xy = markers[i, [names.index(m) for m in line], :2]
                    ax.plot(xy[:, 0], xy[:, 1], color=colours[s], alpha=alpha, lw=2,
                            label=f"leg {s}" if k == len(picks) - 1 and line is chain[s]
                            else None)
        o = frames[i, :, 0, :2]
        ax.quiver(o[:, 0], o[:, 1], frames[i, :, 1, 0], frames[i, :, 1, 1], color="red",
                  angles="xy", scale_units="xy", scale=1 / axis_length, width=0.003)
        ax.quiver(o[:, 0], o[:, 1], frames[i, :, 2, 0], frames[i, :, 2, 1], color="green",
                  angles="xy", scale_units="xy", scale=1 / axis_length, width=0.003)
        ax.plot(o[:, 0], o[:, 1], "k.", ms=4)
    xs = markers[:, :, 0]
    x0, x1 = float(xs.min()) - 0.1, float(xs.max()) + 0.1
    gamma = float(back.get("slope", 0.0))
    ax.plot([x0, x1], [-x0 * math.tan(gamma), -x1 * math.tan(gamma)], color="0.4", lw=1,
            label="ground")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, ground frame)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{title}: body frames (x red, y green) at {n} instants")
    ax.legend(loc="upper right", fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def fitted_problem(problem, summary: dict):
    """``problem`` with the compliance, slope and section state of a fit's summary
    (``pdw-fit``'s summary.json as a dict: a one-step fit's ``compliance``, or a per-leg
    fit's ``legs.<side>.compliance``; ``slope`` in rad; ``fixed_point`` in rad, rad/s)."""
    if "legs" in summary and "compliance" not in summary:
        legs = {side: {**problem.legs.get(side, {}), "compliance": dict(v["compliance"])}
                for side, v in summary["legs"].items()}
        new = problem.replace(legs=legs, slope=float(summary["slope"]))
    else:
        new = problem.replace(compliance=dict(summary["compliance"]),
                              slope=float(summary["slope"]))
    return new.with_state(dict(summary["fixed_point"]))

