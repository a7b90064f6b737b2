"""The stride (two-step) multiple-shooting NLP of a per-leg walker and its stability row:
at equal legs it is the one-step NLP twice; its stability row is the stride map's Jacobian
with an exact gradient."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from pdw_casadi.fit import StabilityRow
from pdw_casadi.gait.stride import find_stride_fixed_point, stride_map
from pdw_casadi.nlp.shooting import ShootingNLP
from pdw_casadi.studies.prosthesis import DesignNLPOptions, atlas_problem, prosthetic_problem

#: the design's verdict on the stride's spectral radius (0.81 = 0.9 per step)
STRIDE_RADIUS = DesignNLPOptions.max_stride_radius


@pytest.fixture(scope="module")
def base():
    return atlas_problem()


def test_stride_nlp_at_equal_legs_is_the_one_step_nlp_twice(base):
    """Every constraint of the stride NLP at a point made of a (perturbed) one-step NLP point
    repeated twice equals the one-step NLP's row there: step 1's rows, step 2's rows, the
    link between the steps equal to the one-step periodicity row, to 1e-10. The stride runs
    on the per-leg walker (other compiled functions), so this checks the per-leg parameters,
    the role permutation and the node layout."""
    one = ShootingNLP(base, base.state_vector(), base.parameter_vector())
    smap = stride_map(base)
    stride = ShootingNLP.stride(base, base.state_vector(), smap.default_parameters())
    n1 = len(one.specs)
    assert [(s.phase, s.event, s.n_int, s.step) for s in stride.specs] == [
        (s.phase, s.event, s.n_int, i) for i in (0, 1) for s in one.specs]
    rng = np.random.default_rng(5)
    w1 = one.w0 * (1 + 1e-4 * rng.standard_normal(one.w0.size))
    ns = one.xs.shape[0]
    xs, T, X = w1[:ns], w1[ns: ns + n1], w1[ns + n1:]
    w2 = np.r_[xs, T, T, X, X, xs]
    g1 = ca.Function("g1", [one.w], [one.g])(w1).full().ravel()
    g2 = ca.Function("g2", [stride.w], [stride.g])(w2).full().ravel()
    names1, names2 = np.array(one.g_names), np.array(stride.g_names)
    # the one-step rows in order, with its periodicity row standing for the step link
    assert names1[0] == "section" and names1[-len(base.initial_state):][0] == "periodicity"
    half = np.flatnonzero(names2 == "step_link[1]")
    sec2 = np.flatnonzero(names2 == "section[1]")
    assert half.size == ns and sec2.size == one.hs.nx
    step1 = g2[: half[0]]
    step2 = g2[sec2[-1] + 1:]
    per = np.flatnonzero(names1 == "periodicity")
    assert np.abs(step1 - g1[: per[0]]).max() < 1e-10
    assert np.abs(g2[half] - g1[per]).max() < 1e-10
    assert np.abs(g2[sec2] - g1[: sec2.size]).max() < 1e-10  # step 2 starts on its section
    assert np.abs(step2 - g1[sec2.size:]).max() < 1e-10
    assert np.abs(g1[per]).max() > 1e-6  # the comparison is of non-trivial residuals
    # the same bounds (the event margins come from each step's own starting guess)
    np.testing.assert_allclose(stride.lbg, np.r_[one.lbg[: per[0]], np.zeros(ns),
                                                 np.zeros(sec2.size), one.lbg[sec2.size:]],
                               rtol=1e-6, atol=1e-12)


@pytest.fixture(scope="module")
def asymmetric(base):
    """A walker whose right shank and foot are 0.01 % lighter, its stride fixed point and
    the stride NLP there (two compliance values free)."""
    pb = prosthetic_problem(base, 1e-4)
    smap = stride_map(pb)
    fp = find_stride_fixed_point(pb, x0=find_stride_fixed_point(base).state, tol=1e-10,
                                 smap=smap, fallback=False)
    assert fp.converged
    nlp = ShootingNLP.stride(pb, fp.state, fp.parameters,
                             free=("right.k_ankle", "right.c_knee_ext"))
    return pb, smap, fp, nlp


@pytest.mark.slow  # a further per-leg walker (0.01 % lighter leg) to compile
def test_stride_stability_row_is_the_stride_map_jacobian(asymmetric):
    """At the stride NLP's starting gait (the simulator's fixed point, feasible to 1e-6),
    the row's chain over both steps is the stride map's exact-AD Jacobian dS/dx
    (stride_map(...).evaluate) to 1e-5 relative, and its value is rho_32 of those eigenvalues."""
    from pdw_casadi.fit import RADIUS_NORM

    pb, smap, fp, nlp = asymmetric
    bad = [(n, v) for n, v in nlp.violations(nlp.w0) if v > 1e-6]
    assert not bad, bad[:5]
    row = StabilityRow(nlp)
    J = row.poincare_jacobian(nlp.w0)
    ref = smap.evaluate(fp.state, fp.parameters).dx
    assert np.abs(J - ref).max() < 1e-5 * np.abs(ref).max()
    lam = np.linalg.eigvals(ref)
    bound = float(np.sum(np.abs(lam) ** RADIUS_NORM) ** (1 / RADIUS_NORM))
    assert abs(row.value(nlp.w0) - bound) < 1e-4


@pytest.mark.slow  # a further per-leg walker (0.01 % lighter leg) to compile
def test_stride_stability_row_gradient_matches_finite_differences(asymmetric):
    """Off the orbit, the row's reverse-mode gradient over both steps (nodes, durations,
    both section states, the free parameters through both steps' role vectors) matches
    Richardson central differences of the row itself, block by block, to 1e-6 (relative,
    or absolute below 1)."""
    *_, nlp = asymmetric
    row = StabilityRow(nlp)
    rng = np.random.default_rng(7)
    w = nlp.w0 * (1 + 1e-6 * rng.standard_normal(nlp.w0.size))
    g = row.gradient(w)
    ns, nf = nlp.xs.shape[0], len(nlp.free)
    o_T, o_X = ns + nf, row.o_X[0]
    blocks = {"xs": slice(0, ns), "free": slice(ns, o_T), "T": slice(o_T, o_X),
              "nodes": slice(o_X, row.o_xs[1]), "xs2": slice(row.o_xs[1], row.n)}

    def central(v, eps):
        return (row.value(w + eps * v) - row.value(w - eps * v)) / (2 * eps)

    for name, sl in blocks.items():
        v = np.zeros(w.size)
        v[sl] = rng.standard_normal(sl.stop - sl.start)
        v /= np.linalg.norm(v)
        # the stride's two leading eigenvalues nearly coincide (a 0.01 % asymmetry splits a
        # double one), so the row curves sharply in the durations: smaller steps there
        eps = 1e-7 if name == "T" else 1e-6
        fd = (4 * central(v, eps) - central(v, 2 * eps)) / 3
        assert abs(g @ v - fd) < 1e-6 * max(abs(fd), 1.0), (name, g @ v, fd)


def _design_checks(base, res, lighter):
    """The designed gait re-simulated on the stride map: stable (stride radius <= 0.81),
    valid, both asymmetries below 1 %, the right leg lighter by ``lighter``."""
    from pdw_casadi.studies.prosthesis import lighter_mass

    fp, rep = res.fixed_point, res.report
    assert res.reached and fp.converged and fp.valid
    assert fp.spectral_radius <= STRIDE_RADIUS
    assert abs(rep["step_length_asymmetry_pct"]) < 1.0
    assert abs(rep["step_time_asymmetry_pct"]) < 1.0
    assert abs(lighter_mass(res.problem) - (1 - lighter)) < 1e-12


@pytest.mark.slow  # 80 s; notebook 05 runs the same case in the default suite
def test_design_nlp_makes_a_slightly_lighter_leg_symmetric_and_stable(base):
    """0.3 % lighter right shank and foot, one NLP solve: at the sound leg's compliance that
    walker's stride radius is above 0.81 (these gaits are that sensitive to the shank mass);
    the designed compliance brings it to <= 0.81 with equal steps (re-simulated), and the
    NLP's own stability bound rho_32 bounds the simulator's radius from above, within the
    bound's own slack (n^(1/32), n = 7 eigenvalues)."""
    from pdw_casadi.studies.prosthesis import DesignNLPOptions, design_prosthesis_nlp

    lighter = 0.003
    x = find_stride_fixed_point(base).state
    plain = prosthetic_problem(base, lighter)
    fp_plain = find_stride_fixed_point(plain, x0=x, fallback=False)
    assert fp_plain.converged and fp_plain.spectral_radius > STRIDE_RADIUS
    res = design_prosthesis_nlp(base, x0=x, lighter=lighter,
                                options=DesignNLPOptions(first_step=lighter), log=None)
    _design_checks(base, res, lighter)
    assert len(res.solves) == 1
    rho, bound = res.fixed_point.spectral_radius, res.solves[0].nlp_radius
    assert rho <= bound + 1e-6 and bound <= rho * 7 ** (1 / 32) + 1e-6


@pytest.mark.slow  # one NLP solve with 16 compliance values free
def test_design_nlp_with_the_sound_leg_adapting(base):
    """0.3 % lighter right shank and foot, one NLP solve with the sound (left) leg's eight
    compliance values free as well: the re-simulated gait is stable, valid and symmetric,
    and the walker written carries the left leg's adapted values, which the result
    reports (they moved: the sound leg took part in the design)."""
    from pdw_casadi.studies.prosthesis import NLP_FREE, DesignNLPOptions, design_prosthesis_nlp

    lighter = 0.003
    x = find_stride_fixed_point(base).state
    res = design_prosthesis_nlp(base, x0=x, lighter=lighter, log=None,
                                options=DesignNLPOptions(first_step=lighter,
                                                         free_sound=NLP_FREE))
    _design_checks(base, res, lighter)
    left, _ = res.problem.leg_values("left")
    assert set(res.sound_compliance) == set(NLP_FREE)
    assert all(left[k] == v for k, v in res.sound_compliance.items())
    moved = max(abs(left[k] - base.compliance[k]) / max(abs(base.compliance[k]), 1e-2)
                for k in NLP_FREE)
    assert moved > 1e-6


@pytest.mark.slow  # two NLP solves of at most 20 iterations
def test_design_nlp_accepts_only_verified_answers(base):
    """With ``accept_verified`` a homotopy step is taken exactly when its answer
    re-simulates as stable (stride radius <= 0.81), valid and symmetric (below 1 %),
    whether IPOPT converged or stopped at its iteration limit (20 iterations: fewer than the
    0.3 % step needs to converge); without it, a stopped solve is never taken."""
    from pdw_casadi.studies.prosthesis import DesignNLPOptions, design_prosthesis_nlp

    lighter = 0.003
    x = find_stride_fixed_point(base).state
    for accept in (True, False):
        res = design_prosthesis_nlp(base, x0=x, lighter=lighter, log=None,
                                    options=DesignNLPOptions(
                                        first_step=lighter, max_iter=20, max_solves=1,
                                        accept_verified=accept))
        (sv,) = res.solves
        assert sv.status == "Maximum_Iterations_Exceeded"
        verified = (bool(sv.valid) and sv.stride_radius <= STRIDE_RADIUS
                    and abs(sv.step_length_asymmetry_pct) < 1.0
                    and abs(sv.step_time_asymmetry_pct) < 1.0)
        assert sv.accepted == (verified and accept)
        assert res.reached == sv.accepted
        if sv.accepted:
            _design_checks(base, res, lighter)


@pytest.mark.slow  # two NLP solves of 20 iterations
def test_a_design_solve_stopped_short_answers_with_its_best_feasible_iterate(base):
    """The fit's walk in the design (DesignNLPOptions.keep_best_feasible): a solve stopped
    at its iteration limit answers with its lowest-objective iterate that holds every row
    and bound (within IPOPT's tolerance), not with its last iterate; without it, with the
    last iterate."""
    from pdw_casadi.model.system import physical_parameter_names, physical_parameter_vector
    from pdw_casadi.nlp.driver import IPOPT_TOL
    from pdw_casadi.studies.prosthesis import LIGHTER_KEYS, NLP_FREE, ProsthesisDesignSolver

    x = find_stride_fixed_point(base).state
    target = prosthetic_problem(base, 0.003)
    names = list(physical_parameter_names(base))
    theta = physical_parameter_vector(base)
    keys = [f"right.{k}" for k in NLP_FREE]
    body = [f"right.{k}" for k in LIGHTER_KEYS]
    nlp = ShootingNLP.stride(target, x, theta, free=(*keys, *body), sample_stride=2)
    theta_t = physical_parameter_vector(target)
    pinned = {k: float(theta_t[names.index(k)]) for k in body}
    sound = {k: float(theta[names.index(k.replace("right.", "left."))]) for k in keys}
    answers = {}
    for keep in (True, False):
        opts = DesignNLPOptions(max_iter=20, keep_best_feasible=keep, stall=None)
        solver = ProsthesisDesignSolver(nlp, keys, sound, opts, pinned, log=None)
        out = solver.solve(nlp.w0)
        assert out["status"] == "Maximum_Iterations_Exceeded"
        w, g = out["w"], out["g"]
        worst = max(np.max(np.r_[solver.lbg - g, g - solver.ubg, 0.0]),
                    np.max(np.r_[solver.lbx - w, w - solver.ubx, 0.0]))
        answers[keep] = (out, worst)
    out, worst = answers[True]
    assert out["fallback_iteration"] is not None and worst <= IPOPT_TOL
    assert answers[False][0]["fallback_iteration"] is None


def test_sound_problem_undoes_prosthetic_problem(base):
    """A prosthetic walker's sound problem is the symmetric walker it was made from (every
    body and compliance value of both legs) with the mass reduction it carries; a walker
    whose masses were not scaled by one factor is refused."""
    from pdw_casadi.gait.stride import physical_parameter_vector
    from pdw_casadi.model.problem import ProblemError
    from pdw_casadi.studies.prosthesis import sound_problem

    pb = prosthetic_problem(base, 0.04)
    sound, lighter = sound_problem(pb)
    assert not sound.asymmetric and abs(lighter - 0.04) < 1e-12
    np.testing.assert_array_equal(physical_parameter_vector(sound),
                                  physical_parameter_vector(base))
    legs = {"right": {"anthropometry": {**pb.legs["right"]["anthropometry"], "m_f": 0.6}}}
    with pytest.raises(ProblemError, match="not a prosthetic_problem walker"):
        sound_problem(pb.replace(legs=legs))
    # a design whose sound (left) leg adapted its compliance (DesignNLPOptions.free_sound):
    # the symmetric walker carries the left leg's values on both legs
    adapted = {**pb.legs, "left": {"compliance": {"k_knee": 1.1 * base.compliance["k_knee"]}}}
    sound, lighter = sound_problem(pb.replace(legs=adapted))
    assert not sound.asymmetric and abs(lighter - 0.04) < 1e-12
    assert sound.compliance["k_knee"] == 1.1 * base.compliance["k_knee"]
    assert {k: v for k, v in sound.compliance.items() if k != "k_knee"} == {
        k: v for k, v in base.compliance.items() if k != "k_knee"}


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured: the NLP keeps the start gait's event "
                   "order, and its swing-knee engagement and stance-knee disengagement meet "
                   "near 5 % lighter (5.5 % compliance only, 6 % with the mass distribution "
                   "free, 8.5 % with the slope free too: 100 iterations, locally "
                   "infeasible); the design does not reach 10 %")
def test_design_nlp_ten_percent_lighter(base):
    """10 % lighter by the mass homotopy: stable, valid and symmetric on re-simulation."""
    from pdw_casadi.studies.prosthesis import design_prosthesis_nlp

    res = design_prosthesis_nlp(base, lighter=0.1, log=None)
    _design_checks(base, res, 0.1)


def test_a_steps_last_impact_enters_a_phase_of_the_next_step(base):
    """Per-leg walker, legs made to differ (right ankle 2 % stiffer): the phase that a step's
    last impact enters belongs to the next step, whose parameters are the other leg's. The
    stride map checks that phase's guard (the trailing toe force, N) with those, and the
    stride NLP's row at the next step's first state gives the same value; the current
    step's parameters would give another force."""
    smap = stride_map(base)
    theta = np.array(smap.default_parameters(), float)
    theta[smap.parameter_names.index("right.k_ankle")] *= 1.02
    ps = smap.step_parameters(theta)
    hs = smap.hs
    x0 = base.state_vector()
    run = smap.sim.run(x0, None, steps=1, record=False, margins=True, p_steps=list(ps))
    ix = [e.name for e in hs.event_list["I"]].index("toe_off")
    mv = np.array(hs.mode_vector(run.final_mode))
    force = {k: float(hs.events["I"].np(run.final_state, ps[k], mv).ravel()[ix]) for k in (0, 1)}
    margin = run.steps[0].margins["foot_strike:toe_off_ahead"]
    assert margin == pytest.approx(force[1], rel=1e-12)
    assert abs(force[0] - force[1]) > 1e-3 * abs(force[1])  # the legs' values matter here
    # the stride map's own labels: step 0 (left stance) ends with the right foot's strike
    res = smap.evaluate(x0, theta, jacobian=False, margins=True)
    assert res.steps[0].sim.steps[0].margins["foot_strike:toe_off_ahead"] == \
        pytest.approx(force[1], rel=1e-12)
    nlp = ShootingNLP.stride(base, x0, theta)
    g = ca.Function("g", [nlp.w], [nlp.g])(nlp.w0).full().ravel()
    k = next(i for i, sp in enumerate(nlp.specs) if sp.step == 1)
    row = nlp.g_names.index(f"ahead[{k}]:toe_off")
    # the NLP's node is the section state rebuilt with step 1's parameters (2e-9 off)
    assert g[row] == pytest.approx(force[1], rel=1e-6)


@pytest.mark.parametrize("name, lighter", [
    # a further per-leg walker to compile: in the slow set
    pytest.param("humanlike_6link_prosthesis30", 0.300, marks=pytest.mark.slow)])
def test_shipped_prosthesis_design_is_stable_valid_and_symmetric(name, lighter):
    """The design shipped in data/designs (the sound leg adapting, pdw-design
    --free-sound ... --accept-verified from the atlas gait; the 30 % one with a 0.9 %
    symmetry tolerance too): the right shank and foot are that much lighter, and the stride map,
    with Newton started 1e-5 away from the file's gait in every component (1e-3 away the
    stride leaves the gait pattern: a fall, or the centre of pressure at the toe), returns
    to that gait: stride radius <= 0.81 (0.9 per step), valid, both asymmetries below 1 %."""
    from pdw_casadi.engine.resources import bundled_dir
    from pdw_casadi.gait.stride import stride_report
    from pdw_casadi.model.problem import load_problem
    from pdw_casadi.studies.prosthesis import lighter_mass

    pb = load_problem(bundled_dir("data") / "designs" / f"{name}.toml")
    assert abs((1 - lighter_mass(pb)) - lighter) < 1e-3
    smap = stride_map(pb)
    x0 = pb.state_vector() + 1e-5
    fp = find_stride_fixed_point(pb, x0=x0, tol=1e-10, smap=smap, fallback=False)
    assert fp.converged and fp.iterations > 0 and fp.valid and \
        fp.spectral_radius <= STRIDE_RADIUS
    assert np.abs(fp.state - pb.state_vector()).max() < 1e-8
    rep = stride_report(smap, fp.state, fp.parameters, curves=False)
    assert abs(rep["step_length_asymmetry_pct"]) < 1.0
    assert abs(rep["step_time_asymmetry_pct"]) < 1.0


def test_a_design_stepping_stone_is_solved_to_its_own_tolerance():
    """DesignNLPOptions.ipopt_options: a homotopy step short of the target (a stepping
    stone) is solved to ``step_tol`` with its rows held to ``step_constr_viol_tol``; the
    target to ``tol``; a cold start near its point only with ``near_start``, a warm one from
    the multipliers' settings; by default every step to ``tol`` from IPOPT's own start."""
    from pdw_casadi.nlp.driver import NEAR_START_IPOPT
    from pdw_casadi.nlp.multipliers import WARM_IPOPT

    plain = DesignNLPOptions()
    for stone in (False, True):
        got = plain.ipopt_options(False, stone)
        assert got["tol"] == plain.tol and "mu_init" not in got
    opts = DesignNLPOptions(near_start=True, step_tol=1e-3)
    stone, target = opts.ipopt_options(False, True), opts.ipopt_options(False, False)
    assert stone["tol"] == 1e-3 and stone["constr_viol_tol"] == opts.step_constr_viol_tol
    assert target["tol"] == opts.tol and "constr_viol_tol" not in target
    assert stone["mu_init"] == NEAR_START_IPOPT["mu_init"] < 0.1  # IPOPT's own is 0.1
    assert opts.ipopt_options(True, False)["mu_init"] == WARM_IPOPT["mu_init"]
    # the user's own IPOPT settings win
    mine = DesignNLPOptions(step_tol=1e-3, ipopt={"tol": 1e-5})
    assert mine.ipopt_options(False, True)["tol"] == 1e-5
