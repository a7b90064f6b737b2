"""One evaluator of validity margins: a walker output ``clearance_<anything>`` is measured by
the simulator, checked by the fixed points' validity and constrained in the shooting NLP
alike (:mod:`pdw_casadi.model.margins`)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from pdw_casadi.gait.fixed_point import find_fixed_point, validity_failure, validity_slacks
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.hybrid import HybridSystem
from pdw_casadi.model.margins import CLEARANCE, IMPULSE, NORMAL_FORCE, Margin, MarginKind
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.walkers import get_family
from pdw_casadi.nlp.shooting import ShootingNLP

DEG = np.pi / 180
NAME = "clearance_hip_over_half_leg"  # a name no walker uses: only the prefix counts


@pytest.fixture(scope="module")
def walker():
    """The compass gait with one extra swing-phase output: the hip's height above half the
    leg length (m), which is not a margin of the shipped walker."""
    problem = load_problem("compass_gait")
    model = get_family("compass_gait").build(problem)
    leg = problem.anthropometry["a"] + problem.anthropometry["b"]
    phase = model.phases[0]
    phase.outputs = {**phase.outputs, NAME: model.common_outputs["hip_height_m"] - 0.5 * leg}
    hs = HybridSystem(model)
    fp = find_fixed_point(problem, p=np.array([3 * DEG]))
    assert fp.converged
    return problem, hs, fp


def _sim_margin(problem, hs, fp):
    sim = Simulator(problem, hs)
    res = sim.run(fp.state, fp.parameters, steps=1, record=True)
    return res, res.steps[0].margins


def test_the_naming_rule_gives_a_clearance_margin(walker):
    problem, hs, _ = walker
    key = f"swing:min_{NAME}"
    assert hs.margin_specs[key] == CLEARANCE
    assert hs.margin_specs["swing:min_N_foot1"] == NORMAL_FORCE
    assert hs.margin_specs["heel_strike:impulse_foot2"] == IMPULSE
    assert "heel_strike:foot1_rise_speed" not in hs.margin_specs  # a sign condition only


def test_simulator_measures_it_after_a_fifth_of_the_phase(walker):
    problem, hs, fp = walker
    res, margins = _sim_margin(problem, hs, fp)
    tr = res.trajectory
    leg = problem.anthropometry["a"] + problem.anthropometry["b"]
    late = tr["t"] >= 0.2 * res.steps[0].step_time
    # the hip is highest at mid-stance and lowest at the step's ends: the margin is the
    # height over half the leg at the last counted sample
    expected = float((tr["hip_height_m"][late] - 0.5 * leg).min())
    assert margins[f"swing:min_{NAME}"] == pytest.approx(expected, abs=1e-12)
    assert 0.3 * leg < expected < 0.5 * leg  # the legs are ~20 deg apart at heel strike


def test_validity_and_nlp_agree_on_the_margin(walker, monkeypatch):
    monkeypatch.setenv("PDW_NO_COMPILE", "1")  # this model's functions are built once here
    problem, hs, fp = walker
    _, margins = _sim_margin(problem, hs, fp)
    m = margins[f"swing:min_{NAME}"]
    key = f"swing:min_{NAME}"
    for need, broken in ((m - 0.01, False), (m + 0.01, True)):
        pb = problem.replace(validity={**problem.validity, "min_clearance": need})
        assert validity_slacks(margins, pb, hs)[key] == pytest.approx(m - need)
        why = validity_failure(margins, pb, hs)
        assert (why is not None and why.startswith(key)) is broken
        nlp = ShootingNLP(pb, fp.state, fp.parameters, hs=hs)
        rows = [i for i, n in enumerate(nlp.g_names) if n.endswith(f":{NAME}")]
        assert rows and all(nlp.lbg[i] == 0 and nlp.ubg[i] == np.inf for i in rows)
        g = ca.Function("g", [nlp.w], [nlp.g])(nlp.w0).full().ravel()[rows]
        # the NLP's guess is the simulated gait: its smallest demanded row is the margin less
        # the requirement (to the NLP's slightly different RK4 grid)
        assert g.min() == pytest.approx(m - need - CLEARANCE.nlp_slack, abs=2e-4)
        assert bool(g.min() < 0) == broken


def test_declared_margins_override_the_naming_rule(walker):
    problem, _, _ = walker
    model = get_family("compass_gait").build(problem)
    phase = model.phases[0]
    spec = Margin(MarginKind.CLEARANCE, "min_clearance", "m", active_after=0.5)
    phase.margins = {"N_foot1": spec}  # only this one, with its own rule
    hs = HybridSystem(model)
    assert hs.margin_specs == {"swing:min_N_foot1": spec, "heel_strike:impulse_foot2": IMPULSE}
    phase.margins = {"no_such_output": spec}
    with pytest.raises(ValueError, match="no_such_output"):
        HybridSystem(model)
