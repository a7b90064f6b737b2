"""The foot interface (pdw_casadi/model/feet): a foot is a part of the 6-link walker.

New feet defined here, in the test file, with no edit to the package:

- the ball foot: the flat foot whose sole ends at the ball of the foot (the toe contact a
  fraction ``ball`` of the ankle-to-toe length in front of the ankle; the foot's body
  unchanged). At ``ball = 1`` its walker must equal the paper walker exactly; at 0.8 its
  contacts move.
- the fixed-radius rolling foot: the rolling arcs with radii fixed in the foot (no
  compliance keys), simulated and taken to its fixed point like any bundled walker. (The
  shipped flat-foot gaits sit where a few millimetres of heel or a shifted foot mass leave
  Newton's basin: a 2 mm heel pad gives |P(x) - x| = 0.14 from the paper's gait; a 45 mm
  toe arc stays in the rolling-foot gait's.)
"""

from __future__ import annotations

import tomllib

import casadi as ca
import numpy as np
import pytest
from conftest import model_functions

from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.feet.arc import ArcFoot, ArcFootLeg
from pdw_casadi.model.feet.flat import FlatFoot, FlatFootLeg
from pdw_casadi.model.problem import load_problem, problem_from_dict
from pdw_casadi.model.walkers import FAMILIES, get_family
from pdw_casadi.model.walkers import humanlike_6link_ankle as ankle
from pdw_casadi.model.walkers.humanlike_6link import build, build_per_leg, register_six_link

BALL = 0.8
#: m, the fixed-radius rolling foot's toe arc (the shipped problem's is 50 mm) and heel arc
#: (the shipped problem's)
FIXED_R_TOE = 0.045
FIXED_R_HEEL = 0.003931641474688356


class BallFootLeg(FlatFootLeg):
    """The flat foot whose sole (and toe contact) ends ``ball`` l_ft in front of the ankle:
    the sole's geometry (l_ft, l_f) shortened, the body (m_f, J_f, l_fc) unchanged."""

    ball = 1.0

    def __init__(self, leg, angle, a, c, ground, *, root=None, ankle=None):
        short = {**a, "l_ft": self.ball * a["l_ft"], "l_f": self.ball * a["l_ft"] + a["l_fh"]}
        super().__init__(leg, angle, short, c, ground, root=root, ankle=ankle)


class BallFoot(FlatFoot):
    """The ball foot (module doc) with its ``ball`` fraction."""

    def __init__(self, ball: float):
        self.name = f"ball{ball:g}"
        self.leg_class = type(f"BallFootLeg{ball:g}", (BallFootLeg,), {"ball": ball})


FAMILY = "test_ball_foot_6link"
if FAMILY not in FAMILIES:  # registered once per session
    register_six_link(FAMILY, "The 6-link walker with ball feet (a test's foot).",
                      foot=BallFoot(BALL))


def _problem(family):
    """The bundled paper problem (Table 1 body, Table 3 compliance) as a ``family`` walker."""
    raw = tomllib.loads((bundled_dir("problems") / "humanlike_6link.toml").read_text())
    raw["walker"] = {**raw["walker"], "family": family}
    return problem_from_dict(raw, name=family)


def _same_model(a, b, p, rng, trials=5):
    """The two models agree at random states (1e-12 relative): same structure and values."""
    assert [ph.name for ph in a.phases] == [ph.name for ph in b.phases]
    assert [tr.name for tr in a.transitions] == [tr.name for tr in b.transitions]
    for ph_a, ph_b in zip(a.phases, b.phases, strict=True):
        assert list(ph_a.outputs) == list(ph_b.outputs)
        assert [e.name for e in ph_a.events] == [e.name for e in ph_b.events]
    fa, fb = model_functions(a), model_functions(b)
    for _ in range(trials):
        q = rng.uniform(-0.6, 0.6, 8) + np.array([0, 0, 0, 0, 1.4, 1.4, 0, 0])
        qd = rng.uniform(-2, 2, 8)
        m = rng.integers(0, 2, a.m.shape[0]).astype(float)
        for u, v in zip(fa(q, qd, p, m), fb(q, qd, p, m), strict=True):
            u, v = u.full(), v.full()
            if v.size == 0:  # a transition without an impact
                assert u.size == 0
                continue
            assert np.allclose(u, v, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(v).max()))


def test_a_foot_equal_to_the_flat_foot_builds_the_paper_walker():
    """The ball foot at ball = 1 (defined in this file) gives the paper walker: every
    phase's dynamics, multipliers, events and outputs and every impact agree with the
    flat-foot walker's at random states, for the baked walker and the per-leg one."""
    rng = np.random.default_rng(3)
    pb = load_problem("humanlike_6link")
    unit = BallFoot(1.0)
    _same_model(build(pb, foot=unit), build(pb), pb.parameter_vector(), rng)
    flat_pl = build_per_leg("flat_per_leg", pb.g)
    ball_pl = build_per_leg("ball_per_leg", pb.g, foot=unit)
    a = dict(pb.anthropometry)
    p = [*pb.compliance.values(), *pb.compliance.values(),
         *(a[k.split("@")[0]] for k in flat_pl.parameter_names if k.endswith("@1")
           and k.split("@")[0] in a),
         *(a[k.split("@")[0]] for k in flat_pl.parameter_names if k.endswith("@2")
           and k.split("@")[0] in a), a["m_h"], pb.slope]
    assert len(p) == flat_pl.p.shape[0]
    _same_model(ball_pl, flat_pl, p, rng)


def test_the_foot_decides_the_contacts():
    """At ball = 0.8 the walker's toe contacts sit 0.8 l_ft in front of the ankle (the
    drawn toe point and the stance foot's anchor), and its flat foot's centre of pressure is
    measured on the shorter sole: a different walker from the same chain."""
    pb = _problem(FAMILY)
    model = get_family(FAMILY).build(pb)
    q, a = model.system.q, pb.anthropometry
    f = ca.Function("pts", [q], [model.points["toe1"], model.points["ankle1"],
                                 model.points["toe2"], model.points["ankle2"]])
    qv = [0.2, 0.3, -0.5, -0.4, 1.3, 1.5, 0.1, -0.02]
    toe1, ankle1, toe2, ankle2 = (np.asarray(v).ravel() for v in f(qv))
    assert np.linalg.norm(toe1 - ankle1) == pytest.approx(BALL * a["l_ft"], rel=1e-12)
    assert np.linalg.norm(toe2 - ankle2) == pytest.approx(BALL * a["l_ft"], rel=1e-12)
    assert toe1 == pytest.approx([0.1, -0.02], abs=1e-15)  # the chain's anchor


class FixedArcFootLeg(ArcFootLeg):
    """The rolling foot with its arc radii fixed in the foot (m) instead of read from the
    leg's compliance values."""

    def __init__(self, leg, angle, a, c, ground, *, root=None, ankle=None):
        radii = {"r_toe": FIXED_R_TOE, "r_heel": FIXED_R_HEEL}
        super().__init__(leg, angle, a, {**c, **radii}, ground, root=root, ankle=ankle)


class FixedArcFoot(ArcFoot):
    """The fixed-radius rolling foot: no compliance keys of its own."""

    compliance_keys = ()
    nonnegative_compliance = ()
    leg_class = FixedArcFootLeg


ARC_FAMILY = "test_fixed_arc_6link"
if ARC_FAMILY not in FAMILIES:
    register_six_link(ARC_FAMILY, "The ankle walker with fixed-radius rolling feet (a test's "
                      "foot).", foot=FixedArcFoot(), ext=ankle.EXTENSION,
                      nonnegative_compliance=ankle.EXTRA_NONNEGATIVE)


def _fixed_arc_problem():
    """The shipped rolling-foot problem (its gait, compliance and bounds) as the fixed-arc
    walker: the radii leave the compliance values."""
    raw = tomllib.loads((bundled_dir("problems") / "humanlike_6link_arc.toml").read_text())
    raw["walker"] = {**raw["walker"], "family": ARC_FAMILY}
    for section in ("compliance", "compliance_bounds"):
        raw[section] = {k: v for k, v in raw[section].items() if k not in ("r_toe", "r_heel")}
    return problem_from_dict(raw, name=ARC_FAMILY)


@pytest.mark.slow
def test_simulate_and_fixed_point_of_a_foot_defined_in_a_test():
    """The fixed-radius rolling foot (defined in this file: toe arc 45 mm, the shipped heel
    arc) walks: its fixed point from the shipped rolling-foot gait converges (residual
    < 1e-10), is stable and valid; one simulated step from it returns to it (1e-8) through
    phases I, II, III with its energy books closed (1e-6 J) and impacts losing energy; and
    it is the shipped rolling-foot walker's fixed point at r_toe = 45 mm (state 1e-9,
    eigenvalues 1e-8: the same equations with the radii baked in instead of parameters,
    other rounding). Measured 3.6 min on a loaded 2-core machine with a cold cache
    (compiling the new walker and its sensitivities), 35 s with it warm."""
    pb = _fixed_arc_problem()
    fp = find_fixed_point(pb, tol=1e-11, fallback=False)
    assert fp.converged and fp.residual < 1e-10, (fp.residual, fp.failure)
    assert fp.valid and fp.spectral_radius < 1, (fp.failure, fp.spectral_radius)
    sim = Simulator(pb)
    res = sim.run(fp.state, fp.parameters, steps=1, record=True)
    assert res.failure is None, res.failure
    st = res.steps[0]
    assert [n for n, _ in st.phases] == ["I", "II", "III"]
    assert np.allclose(st.x_section_end, fp.state, rtol=0, atol=1e-8)
    assert abs(st.energy_residual_J) < 1e-6 and st.impact_loss_J > 0
    shipped = load_problem("humanlike_6link_arc")
    ref = find_fixed_point(shipped.replace(compliance={"r_toe": FIXED_R_TOE}), tol=1e-11,
                           fallback=False)
    assert ref.converged
    assert np.allclose(fp.state, ref.state, rtol=0, atol=1e-9)
    ea, eb = (np.sort_complex(np.asarray(r.eigenvalues)) for r in (fp, ref))
    assert np.allclose(ea, eb, rtol=0, atol=1e-8)
