"""Fitting compliance to curves: a synthetic curve file made from a known gait of this model
is fitted back (identifiability), and the CLI rejects bad curve files without writing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdw_casadi.fit import FitOptions, fit_gait, reference_gait
from pdw_casadi.gait.curves import gait_cycle
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import load_problem

ROOT = Path(__file__).resolve().parents[1]


def synthetic_curves(problem, p_true, path, x0=None) -> pd.DataFrame:
    """The 101-point knee/hip/thigh curves of the fixed point at ``p_true``, as a curve file."""
    fp = find_fixed_point(problem, problem.state_vector() if x0 is None else x0, p_true)
    assert fp.converged
    sim = Simulator(problem)
    one = sim.run(fp.state, fp.parameters, steps=1)
    c = gait_cycle(one.trajectory, sim.hs.model.heel_strike_phase)
    frame = pd.DataFrame({"cycle_pct": c.cycle_pct, "hip_mean_deg": c.hip_deg,
                          "knee_mean_deg": c.knee_deg, "thigh_mean_deg": c.thigh_deg})
    frame.to_csv(path, index=False)
    return frame


def _identify(problem, tmp_path, free, factors, x0=None):
    p0 = problem.parameter_vector()
    p_true = p0.copy()
    names = problem.parameter_names
    for name, f in zip(free, factors, strict=True):
        p_true[names.index(name)] *= f
    synthetic_curves(problem, p_true, tmp_path / "synthetic.csv", x0)
    human = load_gait_curves(tmp_path / "synthetic.csv")
    res = fit_gait(problem, human, FitOptions(free=free, stability_constraint=False, verbose=False,
                                              tol=1e-10, max_iter=200), log=lambda m: None)
    cand = res.candidates[0]
    return p_true, cand


# about 35 s warm; test_identifiability_all_compliance recovers these two among all eight
@pytest.mark.slow
def test_identifiability_two_dampers(problem, tmp_path):
    """Ankle damping and knee flexion damping 1 % off Table 3 (a gait exists there; the
    branch through Table 3 folds within 0.01 % in k_knee) are recovered from their curves."""
    free = ("c_ankle", "c_knee_flex")
    p_true, cand = _identify(problem, tmp_path, free, (0.99, 0.99))
    idx = [problem.parameter_names.index(n) for n in free]
    rel = np.abs(cand.parameters[idx] - p_true[idx]) / np.abs(p_true[idx])
    assert rel.max() < 1e-3, rel
    assert cand.scores["r2_knee"] > 0.999 and cand.scores["r2_hip"] > 0.999
    assert cand.resimulation_deviation < FitOptions.resim_tol


def test_identifiability_all_compliance(problem, tmp_path):
    """All eight compliance values of a known stable gait far from Table 3 (the fit to the
    bundled curves, k_ankle +34 %, c_knee_flex -68 %, ...) are recovered from its curves,
    starting from Table 3. (Small perturbations of all eight at once leave the Table-3
    branch, which folds within 0.01 % in k_knee.) The durations move by up to 11 ms from the
    start, so this also checks the re-bracketing rounds: one solve alone stops at
    1 - R^2 ~ 1e-6 with c_knee_flex 2.8e-2 off."""
    free = tuple(problem.compliance_names)
    known = np.array([6.8201829881582645, 1.0904382176454261, 0.022040252673901573,
                      1.1938091942112439, 116.65886038141463, 1.1110965956466214,
                      0.021338565955065524, 0.043544457126624234])
    factors = known / problem.compliance_vector()
    x_known = np.array([0.25354773360462085, 0.2846135797935314, -0.5433239511426173,
                        1.413704047046249, -4.634879860632417, 2.102124587895207,
                        1.5190185407561168])
    p_true, cand = _identify(problem, tmp_path, free, tuple(factors), x_known)
    rel = np.abs(cand.parameters[:-1] - p_true[:-1]) / np.abs(p_true[:-1])
    print(dict(zip(free, rel, strict=True)), cand.scores)
    assert rel.max() < 1e-3, dict(zip(free, rel, strict=True))
    assert cand.scores["r2_knee"] > 0.999 and cand.scores["r2_hip"] > 0.999
    assert cand.resimulation_deviation < FitOptions.resim_tol


def test_fit_bundled_curves_stable_and_the_nlp_bound_implies_the_simulators_radius(problem):
    """The bundled fit with the default options converges (Solve_Succeeded, no stall stop)
    to a stable valid gait; the NLP's default bound ||J^k||_F^(1/k) (k = stability_power)
    of its own step's Jacobian is at most max_radius - margin at the answer, it bounds the
    simulator's exact spectral radius there (the verdict), and the two maps agree (the
    NLP's bound vs the same bound of the simulator's Jacobian to 1e-6)."""
    from pdw_casadi.nlp.stability import power_bound

    opts = FitOptions(verbose=False)  # what `pdw-fit --gait female_fast.csv` runs
    res = fit_gait(problem, load_gait_curves("female_fast.csv"), opts, log=lambda m: None)
    assert [s.status for s in res.solves] == ["Solve_Succeeded"]
    best = res.best
    assert best is not None and best.stable and best.valid
    nlp_bound = res.solves[-1].nlp_radius_bound
    assert nlp_bound <= opts.radius_bound() + opts.tol  # held to IPOPT's tolerance
    sim_rho = best.fixed_point.spectral_radius
    assert sim_rho <= nlp_bound + 1e-6 and sim_rho <= opts.max_radius
    assert opts.stability_bound == "power"
    sim_bound, _ = power_bound(best.fixed_point.jacobian, opts.stability_power)
    assert abs(sim_bound - nlp_bound) < 1e-6
    # no worse than the stall-stopped fit it replaces (0.851 / 0.806 on this file)
    assert best.scores["r2_knee"] >= 0.85 and best.scores["r2_hip"] >= 0.80


@pytest.mark.parametrize("case", ["missing column", "nan", "out of order", "duplicate",
                                  "fraction of the cycle", "too few rows", "radians"])
def test_pdw_fit_rejects_bad_curve_files_and_writes_nothing(case, tmp_path, capsys):
    from test_gait_data import BAD

    from pdw_casadi.cli import fit_main
    from pdw_casadi.engine.resources import bundled_dir

    edit, message = BAD[case]
    bad = tmp_path / "bad.csv"
    edit(pd.read_csv(bundled_dir("data") / "female_fast.csv")).to_csv(bad, index=False)
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        fit_main(["--gait", str(bad), "--out", str(out)])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err
    assert not out.exists()


def test_point_foot_kneed_walker_fits_its_slope(tmp_path):
    """The fit is walker-agnostic: the paper's comparison family (point feet, no heel-strike
    phase) fits its slope to the curves, re-simulated and stable (on 8fc9cab: StopIteration
    in the objective, which looked for phase III)."""
    import json

    from pdw_casadi.cli import fit_main

    out = tmp_path / "fit"
    code = fit_main(["--problem", "kneed_walker", "--free-slope", "--gait", "female_fast.csv",
                     "--out", str(out), "--max-iter", "30", "--quiet"])
    s = json.loads((out / "summary.json").read_text())
    assert code == 0 and s["stable"] and s["valid"]
    assert s["resimulation_deviation"] < FitOptions.resim_tol
    assert s["r2_hip"] > 0.3  # the slope is fitted: the problem file's own gives 0.135


def test_progress_keeps_the_lowest_objective_iterate_that_holds_every_row():
    """The iteration callback's best feasible iterate: the lowest objective among iterates
    whose largest row or bound violation is within the tolerance; an infeasible iterate and
    one whose (capped) stability row is NaN never count, however low their objective."""
    import casadi as ca

    from pdw_casadi.nlp.driver import Progress

    lbg, ubg = np.array([0.0, -np.inf]), np.array([0.0, 0.9])
    lbx, ubx = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    prog = Progress(2, 2, lbg, ubg, lbx, ubx, lambda x: {}, True, None, feasible_tol=1e-6)
    names = ca.nlpsol_out()

    def it(f, g, x):
        d = {"f": f, "g": np.array(g), "x": np.array(x)}
        return prog.eval([d.get(n, np.zeros(0)) for n in names])

    it(2.0, [1e-7, 0.89], [0.1, 0.2])          # feasible
    it(1.0, [1e-3, 0.89], [0.3, 0.4])          # a continuity row off by 1e-3
    it(1.5, [-5e-7, 0.9], [0.5, 0.6])          # feasible, lower
    it(0.5, [0.0, float("nan")], [0.7, 0.8])   # the row above its cap
    it(0.4, [0.0, 0.89], [1.5, 0.0])           # outside a bound
    best = prog.best_feasible
    assert best.iteration == 2 and best.objective == 1.5
    assert np.array_equal(best.x, [0.5, 0.6])


def cold_atlas(problem, tmp_path) -> str:
    """An atlas of one entry without a stored warm start, whose gait lies above the
    eight-step bound (its NLP starts infeasible): the bundled file's fit from it takes 41
    iterations, a trajectory the tests below stop part way."""
    from pdw_casadi.fit.starts import load_atlas, save_atlas

    entry = next(e for e in load_atlas(problem) if e.label == COLD_ENTRY)
    assert entry.warm is None
    return str(save_atlas(problem, [entry], tmp_path / "cold.json"))


#: a bundled atlas entry fitted under the spectral-radius row (rho 0.83, eight-step bound 1.2)
COLD_ENTRY = "humanlike_6link-female_fast-rho0.86"


def test_a_fit_stopped_at_its_iteration_limit_gives_its_best_feasible_iterate(problem,
                                                                             tmp_path):
    """IPOPT stopped one iteration short of convergence on the bundled file (from
    COLD_ENTRY): the fit's answer is the best iterate that held every row to IPOPT's
    tolerance, marked not certified; the simulator finds the same gait there (re-simulation
    within its tolerance, stable, valid) and its re-simulated 1 - R^2 is the NLP objective
    there."""
    human = load_gait_curves("female_fast.csv")
    atlas = cold_atlas(problem, tmp_path)
    full = fit_gait(problem, human, FitOptions(verbose=False, atlas=atlas, rounds=1),
                    log=lambda m: None)
    assert full.solves[0].status == "Solve_Succeeded"
    opts = FitOptions(verbose=False, max_iter=full.solves[0].iterations - 1, atlas=atlas)
    res = fit_gait(problem, human, opts, log=lambda m: None)
    solve = res.solves[-1]
    assert solve.status == "Maximum_Iterations_Exceeded"
    assert solve.fallback_iteration is not None
    best = res.best
    assert best is not None and not best.certified
    assert best.stable and best.valid and best.fixed_point.spectral_radius <= opts.max_radius
    resim = sum(1 - best.scores[f"r2_{t}"] for t in opts.targets())
    assert abs(resim - best.objective) <= opts.consistency_tol * best.objective
    assert any("not certified optimal" in n for n in res.notes)


def _iterates(objectives, infeasibilities):
    from pdw_casadi.nlp.driver import Iterate

    return [Iterate(k, f, inf, {}, float("nan"), 0.0)
            for k, (f, inf) in enumerate(zip(objectives, infeasibilities, strict=True))]


def test_a_stall_is_a_flat_objective_with_an_infeasibility_that_does_not_fall():
    """The stall rule (FitOptions.stall_*): a solve wandering at infeasibility 1e-2..1e-1
    with its objective flat to 1e-4 stalls; one whose infeasibility falls by decades, one
    whose objective still falls, and one already feasible to 1e-7 (converging) do not."""
    from pdw_casadi.nlp.driver import Stall

    rule = Stall(window=10, rtol=1e-3, min_infeasibility=1e-5)
    rng = np.random.default_rng(0)
    flat = 0.19 + 1e-5 * rng.standard_normal(30)
    wander = 10 ** rng.uniform(-2, -1, 30)
    assert rule.stalled(_iterates(flat, wander))
    assert not rule.stalled(_iterates(flat[:10], wander[:10]))  # not a window yet
    falling = np.r_[wander[:20], np.logspace(-3, -4, 10)]
    assert not rule.stalled(_iterates(flat, falling))
    descending = 0.3 - 0.003 * np.arange(30)
    assert not rule.stalled(_iterates(descending, wander))
    converging = np.r_[wander[:20], np.full(10, 1e-7)]
    assert not rule.stalled(_iterates(flat, converging))


def test_a_zigzag_across_the_bound_stalls_and_a_feasible_tail_does_not():
    """The second stall form (FitOptions.stall_plateau_infeasibility): iterates crossing
    the stability bound back and forth (infeasibility 1e-5..8e-2, the infeasible ones a
    little lower in objective, as one corpus file did for 100 iterations) with the best
    nearly feasible objective flat stall, although the objective's spread hides it from
    the first form; the same best objective still falling, a converging tail feasible
    throughout, and the rule switched off do not."""
    from pdw_casadi.nlp.driver import Stall

    rule = Stall(window=10, rtol=1e-3, min_infeasibility=1e-5, plateau_infeasibility=1e-4,
                 wander=1e-3)
    rng = np.random.default_rng(1)
    inf = np.where(np.arange(40) % 3 == 0, 10 ** rng.uniform(-6, -5, 40),
                   10 ** rng.uniform(-3, -1.1, 40))
    f = 0.2033 - 0.05 * inf  # an infeasible iterate looks better, by up to 4e-3
    assert not rule.wandering(_iterates(f, inf))
    assert rule.stalled(_iterates(f, inf))
    falling = f - 2e-3 * np.arange(40) / 40  # the best improves 2.5e-3 of itself per window
    assert not rule.stalled(_iterates(falling, inf))
    tail = np.full(40, 1e-7)
    assert not rule.stalled(_iterates(np.full(40, 0.2033), tail))
    off = Stall(window=10, rtol=1e-3, min_infeasibility=1e-5)
    assert not off.stalled(_iterates(f, inf))
    # feasible for two iterations, then infeasible and still improving: it left the
    # feasible region and has not come back (wandering, the first form's case)
    left = np.r_[np.full(13, 1e-7), 10 ** rng.uniform(-3, -1.5, 8)]
    assert not rule.zigzag(_iterates(1.1264 - 2e-3 * np.arange(21) / 21, left))
    # within the first two windows the start is the only feasible iterate before the
    # window: an excursion that comes back no better is not yet a plateau
    assert not rule.stalled(_iterates(f[:20], inf[:20]))


def test_progress_keeps_nearly_feasible_iterates_with_their_multipliers_and_stops_a_stall():
    """The iteration callback keeps the lowest-objective iterates within near_tol (with
    IPOPT's multipliers, for a warm restart) and asks IPOPT to stop once it stalls."""
    import casadi as ca

    from pdw_casadi.nlp.driver import Progress, Stall

    lbg, ubg = np.array([0.0, -np.inf]), np.array([0.0, 0.9])
    lbx, ubx = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    prog = Progress(2, 2, lbg, ubg, lbx, ubx, lambda x: {}, True, None, near_tol=1e-2,
                    near_keep=2, stall=Stall(window=3, rtol=1e-3, min_infeasibility=1e-5))
    names = ca.nlpsol_out()

    def it(f, g, x):
        d = {"f": f, "g": np.array(g), "x": np.array(x), "lam_g": np.array([1.0, 2.0]),
             "lam_x": np.array([3.0, 4.0])}
        return prog.eval([d.get(n, np.zeros(0)) for n in names])[0]

    assert it(0.30, [5e-2, 0.8], [0.1, 0.1]) == 0     # too infeasible to keep
    assert it(0.20, [5e-3, 0.8], [0.2, 0.2]) == 0
    assert it(0.25, [3e-2, 0.8], [0.3, 0.3]) == 0     # too infeasible to keep
    assert it(0.19, [8e-3, 0.8], [0.4, 0.4]) == 0
    assert it(0.19, [2e-2, 0.8], [0.5, 0.5]) == 0
    assert it(0.19, [4e-2, 0.8], [0.6, 0.6]) == 1     # flat, not falling: stalled
    assert prog.stalled
    assert [k.iteration for k in prog.near] == [3, 1]
    assert np.array_equal(prog.near[0].lam_g, [1.0, 2.0])
    assert np.array_equal(prog.near[0].x, [0.4, 0.4])


def test_the_polish_turns_a_solve_stopped_early_into_a_stable_valid_gait(problem, tmp_path):
    """IPOPT stopped at 7 iterations on the bundled file from COLD_ENTRY, before any iterate
    held every row to its tolerance (iteration 7: infeasibility 7e-4, the next one within
    tolerance; no best feasible iterate): the simulator polishes the
    nearly feasible iterates (Newton on the map at their compliance) into a stable, valid
    gait, the answer, not certified; without the polish the same solve has no gait."""
    human = load_gait_curves("female_fast.csv")
    atlas = cold_atlas(problem, tmp_path)
    opts = FitOptions(verbose=False, max_iter=7, rounds=1, atlas=atlas)
    res = fit_gait(problem, human, opts, log=lambda m: None)
    solve = res.solves[-1]
    assert solve.status == "Maximum_Iterations_Exceeded"
    best = res.best
    assert best is not None and not best.certified
    assert best.polished_from is not None and best.polished_from <= 7
    assert best.stable and best.valid and best.fixed_point.spectral_radius <= opts.max_radius
    # the polished gait is the simulator's own periodic gait: it re-simulates exactly
    assert best.resimulation_deviation < opts.resim_tol
    off = fit_gait(problem, human, FitOptions(verbose=False, max_iter=7, rounds=1,
                                              atlas=atlas, polish_infeasibility=None),
                   log=lambda m: None)
    assert off.best is None


@pytest.mark.slow
def test_a_stalled_solve_restarts_warm_and_converges():
    """WBDS18_late from the problem's own gait (no atlas), with the iterate cap 0.01 above
    the bound and no knee-floor margin (the defaults before this test was written; with
    today's defaults this file converges without stalling): IPOPT leaves its feasible,
    stable iterate and wanders with the stability row at 1.0-1.4 (it used to reach its
    300-iteration limit); the stall rule stops it and the warm restart from its least
    infeasible kept iterate converges (Solve_Succeeded), to a stable valid gait above the
    problem file's own on knee and mean R^2."""
    problem = load_problem("humanlike_6link")
    human = load_gait_curves(str(ROOT / "data" / "corpus" / "WBDS18_late.csv"))
    opts = FitOptions(verbose=False, atlas="", iterate_radius_slack=0.01,
                      knee_floor_margin=0.0)
    res = fit_gait(problem, human, opts, log=lambda m: None)
    assert res.solves[0].status == "User_Requested_Stop"
    assert any("stalled" in n for n in res.notes)
    assert res.solves[-1].status == "Solve_Succeeded"
    best = res.best
    assert best is not None and best.certified and best.stable and best.valid
    ref = reference_gait(problem, human)
    assert best.scores["r2_knee"] >= ref["r2_knee"]
    assert best.scores["r2_knee"] + best.scores["r2_hip"] >= ref["r2_knee"] + ref["r2_hip"]


def test_a_warm_start_from_a_stored_solution_stays_at_it(problem):
    """A solved fit NLP's solution and multipliers, stored (WarmStart) and handed to a new
    solver of the same NLP for the same curves, need at most a few IPOPT iterations and
    give the same objective; a stored solution of another shape is refused."""
    from pdw_casadi.fit.core import StepFit
    from pdw_casadi.fit.driver import WarmStart
    from pdw_casadi.fit.starts import select_starts

    human = load_gait_curves("female_fast.csv")
    opts = FitOptions(verbose=False)
    start = select_starts(problem, human, opts)[0]
    fp = find_fixed_point(problem, start.state, start.parameters, max_iter=30,
                          fallback=False)
    fit = StepFit(problem, human, opts, 0, start.label, fp.spectral_radius)
    nlp = fit.nlp(fp.state, fp.parameters)
    first = fit.solver(nlp)
    cold = first.solve(nlp.w0)
    assert cold["success"] and cold["iterations"] > 10
    warm = first.warm_start_of(cold)
    again = fit.solver(nlp)
    out = again.solve(nlp.w0, warm=again.warm_point(warm))
    assert out["success"] and out["iterations"] <= 3
    assert abs(out["objective"] - cold["objective"]) <= 1e-6 * cold["objective"]
    assert np.max(np.abs(out["w"] - cold["w"])) <= 1e-4
    short = WarmStart(warm.w[:-1], warm.lam_w[:-1], warm.lam_shooting, warm.lam_row)
    assert again.warm_point(short) is None


def test_the_summary_status_is_the_status_of_the_solve_the_gait_came_from():
    """summary.json's solver.status names the solve the reported gait came from: a later
    round at its iteration limit does not relabel an earlier converged answer; with no gait
    it is the last solve's."""
    from types import SimpleNamespace

    from pdw_casadi.fit.result import Solve
    from pdw_casadi.report.fit_report import answer_status

    solves = [Solve(0, 0, "Solve_Succeeded", 20, 5.0, 0.3),
              Solve(0, 1, "Maximum_Iterations_Exceeded", 300, 90.0, 0.3)]
    assert answer_status(SimpleNamespace(solver_status="Solve_Succeeded"), solves) == \
        "Solve_Succeeded"
    assert answer_status(None, solves) == "Maximum_Iterations_Exceeded"
    assert answer_status(None, []) is None


def test_table_md_names_the_solve_and_the_fitted_compliance_with_units(problem, hs):
    """table.md's solve table: IPOPT's status of the solve the gait came from and whether
    the answer is certified optimal (plainly NO when it is not); its compliance table: each
    fitted value beside the problem file's, with its unit (stiffness N m/rad, damping
    N m s/rad, angles rad) and whether the fit varied it."""
    from types import SimpleNamespace

    from pdw_casadi.fit.result import Solve
    from pdw_casadi.model.units import Units
    from pdw_casadi.report.fit_report import compliance_table, solve_table

    solves = [Solve(0, 0, "Solve_Succeeded", 20, 5.0, 0.3),
              Solve(0, 1, "Maximum_Iterations_Exceeded", 300, 90.0, 0.3)]
    good = SimpleNamespace(solver_status="Solve_Succeeded", certified=True, polished_from=None)
    text = solve_table(good, solves)
    assert "| solver status (IPOPT, the solve this gait came from) | Solve_Succeeded |" in text
    assert "| certified optimal | yes |" in text
    assert "| IPOPT iterations (all solves) | 320 |" in text
    short = SimpleNamespace(solver_status="Maximum_Iterations_Exceeded", certified=False,
                            polished_from=None)
    text = solve_table(short, solves)
    assert "| Maximum_Iterations_Exceeded |" in text
    assert "| certified optimal | NO: IPOPT stopped short of convergence" in text
    assert "| certified optimal | - (no gait) |" in solve_table(None, solves)

    fitted = {k: 2.0 * v for k, v in problem.compliance.items()} | {"slope": problem.slope}
    text = compliance_table(fitted, {**problem.compliance, "slope": problem.slope},
                            Units(hs).of, free=set(problem.compliance))
    lines = text.splitlines()
    assert lines[0] == "| parameter | this fit | problem file | unit | free in the fit |"
    rows = {line.split(" | ")[0][2:]: line.split(" | ")[1:] for line in lines[2:]}
    assert list(rows) == [*problem.compliance, "slope"]
    assert rows["k_knee"] == [f"{fitted['k_knee']:.5g}", f"{problem.compliance['k_knee']:.5g}",
                              "N m/rad", "yes |"]
    assert rows["c_ankle"][2] == "N m s/rad" and rows["theta_eq"][2] == "rad"
    assert rows["slope"][2:] == ["rad", "no |"]


def test_the_gait_file_enters_the_fit_nlp_as_its_parameters_not_its_rows(problem):
    """Two gait files (the bundled curves and the same curves 5 deg more flexed at the
    knee, 20 % more hip range) fitted from the same start gait: the rows of their NLPs as
    functions of (unknowns, samples, parameters) are one and the same function, so the
    stored Jacobian of one serves the other; the parameters differ by the curves, and the
    error rows at the start differ by exactly those curve differences (deg)."""
    from pdw_casadi.fit.core import StepFit
    from pdw_casadi.model.gait_data import GaitCurves

    human = load_gait_curves("female_fast.csv")
    df = human.to_frame()
    df["knee_mean_deg"] += 5.0
    hip = df["hip_mean_deg"]
    df["hip_mean_deg"] = hip.mean() + 1.2 * (hip - hip.mean())
    other = GaitCurves(df, human.source, "flexed")
    opts = FitOptions(verbose=False)
    fp = find_fixed_point(problem)
    solvers = []
    for h in (human, other):
        fit = StepFit(problem, h, opts, 0, "test", fp.spectral_radius, floor=0.8)
        nlp = fit.nlp(fp.state, fp.parameters)
        solvers.append((nlp, fit.solver(nlp)))
    (n1, a), (n2, b) = solvers
    ja, jb = (next(k for k in s._keep if hasattr(k, "rows_of_samples")) for s in (a, b))
    assert ja.rows_of_samples.serialize() == jb.rows_of_samples.serialize()
    assert a.p.size == b.p.size == 2 * 101 + 1  # knee, hip, the knee floor's SS_tot
    assert np.max(np.abs(a.p - b.p)) > 1.0
    ea, eb = a.err(n1.w0).full().ravel(), b.err(n2.w0).full().ravel()
    ha = np.r_[human.resample(101).knee_deg, human.resample(101).hip_deg]
    hb = np.r_[other.resample(101).knee_deg, other.resample(101).hip_deg]
    np.testing.assert_allclose(ea - eb, hb - ha, atol=1e-9)



def test_an_unstable_start_is_brought_down_by_relaxed_bounds(problem):
    """The continuation from a start above the stability bound
    (FitOptions.radius_stage_ratio): relaxed bounds loosest first, each a factor ``ratio``
    below the one before and the last a factor ``ratio`` above the fit's bound, the first
    asking at most that factor of the start's row; none for a start within ``ratio`` of the
    bound, or with the continuation off. The paper walker's own gait (rho 1.0068, unstable)
    against bounds of 0.3-0.5 per step."""
    from pdw_casadi.fit.core import StepFit

    human = load_gait_curves("female_fast.csv")
    fp = find_fixed_point(problem)
    for max_radius, ratio in ((0.5, 1.5), (0.3, 2.0), (0.31, 1.2)):
        opts = FitOptions(verbose=False, max_radius=max_radius, radius_stage_ratio=ratio)
        fit = StepFit(problem, human, opts, 0, "problem", fp.spectral_radius)
        nlp = fit.nlp(fp.state, fp.parameters)
        solver = fit.solver(nlp)
        r0, bound = solver.row.value(nlp.w0), opts.radius_bound()
        assert r0 > 1.0  # the row bounds the radius from above: the start is unstable
        stages = solver.relaxed_bounds(nlp.w0)
        assert stages, (max_radius, ratio, r0)
        assert np.allclose(np.array(stages[:-1]) / np.array(stages[1:]), ratio)
        assert stages[-1] == pytest.approx(bound * ratio)
        assert r0 / ratio <= stages[0] < r0
        solver.opts = FitOptions(verbose=False, max_radius=max_radius,
                                 radius_stage_ratio=r0 / bound * 1.01)
        assert solver.relaxed_bounds(nlp.w0) == []
        solver.opts = FitOptions(verbose=False, max_radius=max_radius, radius_stage_ratio=None)
        assert solver.relaxed_bounds(nlp.w0) == []


def test_the_relaxed_solves_run_loosest_first_and_leave_the_fits_bound(problem):
    """relax_stability from the paper walker's unstable gait: one solve per relaxed bound,
    loosest first, each recorded with its bound and at most the iterations it was given;
    the solver's own bound is untouched (each solve's bound is its own copy); a solve that
    keeps no nearly feasible iterate ends the continuation, which returns the last one
    kept. A ratio of 1 or less is refused when the options are made."""
    from pdw_casadi.fit.core import StepFit
    from pdw_casadi.fit.rounds import relax_stability
    from pdw_casadi.nlp.driver import FeasibleIterate

    with pytest.raises(ValueError, match="radius_stage_ratio"):
        FitOptions(radius_stage_ratio=1.0)
    human = load_gait_curves("female_fast.csv")
    fp = find_fixed_point(problem)
    opts = FitOptions(verbose=False, max_radius=0.6, radius_stage_ratio=1.3,
                      radius_stage_iter=2, max_iter=3)
    fit = StepFit(problem, human, opts, 0, "problem", fp.spectral_radius)
    nlp = fit.nlp(fp.state, fp.parameters)
    solver = fit.solver(nlp)
    stages = solver.relaxed_bounds(nlp.w0)
    assert len(stages) >= 2
    solves = []
    point = relax_stability(fit, nlp, solver, solves, log=lambda m: None)
    assert [s.stage_bound for s in solves] == stages[:len(solves)]
    assert all(s.iterations <= 2 for s in solves)
    assert solver.ubg[-1] == opts.radius_bound()
    # measured: the first relaxed solve (two iterations) keeps a nearly feasible iterate,
    # the second none, so the continuation stops there and the fit goes on from the first
    # one's iterate: all of the NLP's unknowns
    assert len(solves) == 2 < len(stages)
    assert isinstance(point, FeasibleIterate) and point.x.size == solver.x.shape[0]
    assert point.infeasibility <= opts.polish_infeasibility and point.iteration <= 2
