"""The 6-link walker with passive ankle extensions
(pdw_casadi/model/walkers/humanlike_6link_ankle.py): it is the paper's walker when the
extensions are off, it stays passive when they are on (the energy balance of a step closes,
every spring loss accounted for), its impacts are the paper's, and each element acts only
where it is declared to."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.system import hybrid_system

ON = {"c_ankle_load": 0.5, "k_clutch": 5.0, "ankle_rest": 0.05}


@pytest.fixture(scope="module")
def study():
    """The loading-damper study problem: the paper walker's fitted gait, extensions off."""
    return load_problem("humanlike_6link_ankle_load")


@pytest.fixture(scope="module")
def shipped():
    return load_problem("humanlike_6link_ankle")


def _step(pb, steps=1, record=True):
    res = Simulator(pb).run(pb.state_vector(), pb.parameter_vector(), steps=steps,
                            record=record)
    assert res.failure is None, res.failure
    return res


def test_extensions_off_is_the_paper_walker(study):
    """Same compliance, same state: the ankle family with its elements at zero walks the
    paper walker's step (phase durations and end state to 1e-12, damper work to 1e-12
    relative: the two graphs sum the same torques in a different order)."""
    paper = load_problem("humanlike_6link")
    base = {k: study.compliance[k] for k in paper.compliance}
    paper = paper.replace(compliance=base, slope=study.slope).with_state(study.state_vector())
    assert all(study.compliance[k] == 0 for k in ("c_ankle_load", "k_clutch", "ankle_rest"))
    a, b = _step(study, record=False).steps[0], _step(paper, record=False).steps[0]
    assert [n for n, _ in a.phases] == [n for n, _ in b.phases]
    assert np.allclose([d for _, d in a.phases], [d for _, d in b.phases], atol=1e-12)
    assert np.allclose(a.x_section_end, b.x_section_end, atol=1e-12)
    assert a.dissipated_damping_J == pytest.approx(b.dissipated_damping_J, rel=1e-12)


def test_energy_balance_closes_with_every_extension_on(study):
    """E_start - E_end = damper work (incl. the loading damper) + impact losses + spring
    losses (knee disengagement, clutch release); the residual is RK4's error: it falls by
    more than 8x when the step is halved (4th order: 16x)."""
    pb = study.replace(compliance=ON)
    sr = _step(pb, record=False).steps[0]
    fine = _step(pb.replace(numerics={**pb.numerics, "step_size": 2.5e-4}),
                 record=False).steps[0]
    assert abs(sr.energy_residual_J) < 1e-5
    assert abs(fine.energy_residual_J) < abs(sr.energy_residual_J) / 8
    assert sr.dissipated_damping_J > 0 and sr.impact_loss_J > 0


def test_spring_losses_are_the_knee_and_the_clutch_release(study):
    """The spring energy lost in a step is the stance knee's at theta_dis plus the trailing
    clutch's at toe-off, 1/2 k (phi - phi_clutch)^2; engaging the leading clutch at its rest
    angle stores (and loses) nothing."""
    pb = study.replace(compliance=ON)
    res = _step(pb)
    c = pb.compliance
    traj = res.trajectory
    phi_off = math.radians(traj[traj.phase == "I"]["ankle2_deg"].iloc[-1])
    knee = 0.5 * c["k_knee"] * (c["theta_dis"] - c["theta_eq"]) ** 2
    clutch = 0.5 * c["k_clutch"] * (phi_off - c["phi_clutch"]) ** 2
    assert clutch > 1e-3  # the release really loses energy (not vacuous)
    ev = res.events
    assert (ev.event == "clutch1_engage").sum() == 1 and (ev.event == "knee1_disengage").sum() == 1
    assert res.steps[0].spring_loss_J == pytest.approx(knee + clutch, rel=1e-9, abs=1e-12)


def test_loading_damper_acts_from_heel_strike_to_foot_flat_only(study):
    """Phases I and II are unchanged by c_ankle_load; phase III (loading response) lasts
    longer, and the extra damper work is positive."""
    off = _step(study, record=False).steps[0]
    on = _step(study.replace(compliance={"c_ankle_load": 2.0}), record=False).steps[0]
    d_off, d_on = dict(off.phases), dict(on.phases)
    assert d_on["I"] == pytest.approx(d_off["I"], abs=1e-12)
    assert d_on["II"] == pytest.approx(d_off["II"], abs=1e-12)
    assert d_on["III"] > d_off["III"] + 1e-3
    assert on.dissipated_damping_J > off.dissipated_damping_J
    assert abs(on.energy_residual_J) < 1e-6


@pytest.mark.parametrize("name", ["heel_strike", "foot_strike"])
def test_impacts_are_the_paper_walkers(study, hs, impact_states, name):
    """The impact maps do not depend on the ankle elements: same post-impact state and
    impulses as the paper walker's at the Table-2 pre-impact states; kinetic energy lost."""
    hx = hybrid_system(study)
    paper = load_problem("humanlike_6link")
    pa = paper.parameter_vector()
    pb = study.replace(compliance={k: paper.compliance[k] for k in paper.compliance} | ON)
    pe = pb.parameter_vector()
    x = impact_states[name]
    a = [v.full().ravel() for v in hs.impact[name](x, pa)]
    b = [v.full().ravel() for v in hx.impact[name](x, pe)]
    for u, v in zip(a, b, strict=True):
        assert np.allclose(u, v, atol=1e-12)
    assert all(c > 0 for c in b[2])
    mv = hx.mode_vector(hx.model.initial_mode)
    ke = [float(hx.energy(s, pe, mv).full()[0, 0]) for s in (x, b[3])]
    assert ke[1] < ke[0]


def test_mode_rules_of_the_transitions(study):
    """Heel strike starts the loading damper; toe-off releases the trailing clutch; foot
    strike hands the engaged clutch to the trailing leg, arms the leading one and ends the
    loading response; a stance clutch not engaged by foot strike breaks the gait."""
    model = hybrid_system(study).model
    tr = {t.name: t for t in model.transitions}
    m0 = dict(model.initial_mode)
    assert tr["toe_off"].mode_after(m0)["clutch2"] == 0.0
    assert tr["heel_strike"].mode_after(m0)["load2"] == 1.0
    late = {**m0, "eng2": 1.0, "clutch1": 1.0, "armc1": 0.0, "load2": 1.0, "clutch2": 0.0}
    after = tr["foot_strike"].mode_after(late)
    assert {k: after[k] for k in ("clutch1", "clutch2", "armc1", "load2")} == \
        {"clutch1": 0.0, "clutch2": 1.0, "armc1": 1.0, "load2": 0.0}
    assert after == m0  # periodic: back to the section's mode
    assert tr["foot_strike"].mode_after({**late, "clutch1": 0.0}) == "clutch_not_engaged"


def test_shipped_problem_is_a_stable_passive_gait(shipped):
    """The shipped extension's own state is a stable fixed point whose step balances its
    energy and passes every impact check."""
    from pdw_casadi.gait.fixed_point import find_fixed_point

    fp = find_fixed_point(shipped)
    assert fp.converged and fp.valid and fp.spectral_radius <= 0.9
    assert np.abs(fp.state - shipped.state_vector()).max() < 1e-6
    res = Simulator(shipped).run(fp.state, fp.parameters, steps=1, record=False)
    sr = res.steps[0]
    assert abs(sr.energy_residual_J) < 1e-6
    assert all(v > 0 for k, v in sr.margins.items() if k.split(":")[0] in
               ("heel_strike", "foot_strike"))
