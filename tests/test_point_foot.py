"""Point-foot walkers (compass gait, kneed walker): one step reproduces the published gaits."""

from __future__ import annotations

import numpy as np
import pytest

from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.walkers import get_family

# (problem, step period s, phase durations s) of the published period-one gaits
PUBLISHED = {
    # Goswami, Thuilot & Espiau (1996): a = b = 0.5 m, m = 5 kg, m_H = 10 kg, slope 3 deg
    "compass_gait": (0.7343464, None),
    # McGeer (1990) / Hsu Chen (2007): knee strike 0.363552 s, heel strike 0.545846 s
    "kneed_walker": (0.545846, (0.363552, 0.545846 - 0.363552)),
}


def _one_step(name, state=None, steps=1):
    pb = load_problem(name)
    x0 = pb.state_vector() if state is None else np.asarray(state, dtype=float)
    res = Simulator(pb).run(x0, pb.parameter_vector(), steps=steps)
    return pb, x0, res


@pytest.mark.parametrize("name", list(PUBLISHED))
def test_one_step_returns_to_published_state(name):
    period, phases = PUBLISHED[name]
    pb, x0, res = _one_step(name)
    assert res.failure is None, res.failure
    step = res.steps[0]
    np.testing.assert_allclose(step.x_section_end, x0, rtol=0, atol=1e-6)
    assert step.step_time == pytest.approx(period, abs=1e-6)
    if phases is not None:
        assert [n for n, _ in step.phases] == ["unlocked", "locked"]
        np.testing.assert_allclose([d for _, d in step.phases], phases, atol=1e-6)
    # no springs, no dampers: the energy lost is exactly the impact losses
    assert abs(step.energy_residual_J) < 1e-8
    assert step.impact_loss_J > 0
    assert all(v > 0 for v in step.margins.values()), step.margins


def test_compass_gait_published_geometry():
    pb, x0, res = _one_step("compass_gait")
    q_st, q_sw, dq_st, dq_sw = x0
    # legs symmetric about the slope normal, both rotating clockwise (walking along +x)
    assert (q_st + q_sw) / 2 == pytest.approx(-pb.slope, abs=1e-12)
    assert (q_st - q_sw) / 2 == pytest.approx(0.2710287, abs=1e-7)
    assert dq_st < 0 and dq_sw < 0
    step = res.steps[0]
    assert step.step_length == pytest.approx(2 * np.sin(0.2710287), abs=1e-6)
    # the rigid swing leg scuffs at mid-stance; that is ignored as in the literature
    traj = res.trajectory
    assert traj["foot2_height_m"].min() < 0
    assert traj["knee1_deg"].abs().max() == 0


def test_compass_gait_tolerates_section_state_off_the_ground():
    """Newton iterates / finite differences move the swing foot slightly off the ground."""
    pb = load_problem("compass_gait")
    for dq in (-1e-4, 1e-6, 1e-4):
        x0 = pb.state_vector() + np.array([0.0, dq, 0.0, 0.0])
        _, _, res = _one_step("compass_gait", x0)
        assert res.failure is None
        assert res.steps[0].step_time == pytest.approx(0.7343464, abs=1e-3)


def test_kneed_walker_gait_details():
    pb, x0, res = _one_step("kneed_walker", steps=3)
    assert res.failure is None and res.completed_steps == 3
    assert x0[0] - x0[1] == pytest.approx(0.4792840, abs=1e-7)
    assert x0[3] == x0[4]  # knees straight and locked at the section
    traj = res.trajectory
    # the swing knee flexes in the unlocked phase and is straight in the locked phase
    unl = traj[traj["phase"] == "unlocked"]
    lck = traj[traj["phase"] == "locked"]
    assert unl["knee2_deg"].max() > 20
    assert lck["knee2_deg"].abs().max() < 1e-9
    assert traj["knee1_deg"].abs().max() < 1e-9
    assert (traj["hip1_deg"] - traj["thigh1_deg"]).to_numpy() == pytest.approx(
        np.degrees(pb.slope))
    for col in ("kinetic_J", "potential_J", "spring_J", "hip_height_m", "knee2_deg"):
        assert col in traj


def test_comparison_walker_fixed_point():
    """The kneed walker with the 6-link anthropometry: the bundled state is a fixed point."""
    pb, x0, res = _one_step("comparison_kneed_6link")
    assert res.failure is None
    np.testing.assert_allclose(res.steps[0].x_section_end, x0, rtol=0, atol=1e-9)
    assert pb.anthropometry["a1"] + pb.anthropometry["b1"] == pytest.approx(0.388)
    assert pb.anthropometry["a2"] + pb.anthropometry["b2"] == pytest.approx(0.379)


@pytest.mark.parametrize("family", ["compass_gait", "kneed_walker"])
def test_family_objects(family):
    fam = get_family(family)
    assert fam.name == family and fam.compliance_keys == ()
    pb = load_problem(family)
    assert list(pb.initial_state) == list(fam.state_keys)
    assert list(pb.parameter_vector()) == [pb.slope]
    model = fam.build(pb)
    assert model.parameter_names == ("slope",)
    assert len(model.q_names) == model.system.q.shape[0]
    for a, b in model.links:
        assert a in model.points and b in model.points


def test_negative_inertia_rejected():
    from pdw_casadi.model.problem import ProblemError

    pb = load_problem("kneed_walker")
    with pytest.raises(ProblemError, match="J_s"):
        pb.replace(anthropometry={**pb.anthropometry, "J_s": -1.0})
