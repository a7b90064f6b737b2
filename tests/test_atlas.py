"""The bundled gait atlas: every entry is a stable, valid fixed point of its walker, and the
fit picks its starts from it by R^2 on the user's curves, the most stable of the near-best
first."""

from __future__ import annotations

import numpy as np
import pytest

from pdw_casadi.fit import FitOptions
from pdw_casadi.fit.starts import Start, load_atlas, rank_starts, select_starts
from pdw_casadi.gait.curves import fit_scores
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.gait_data import load_gait_curves


def test_every_atlas_entry_is_a_stable_valid_fixed_point(problem):
    entries = load_atlas(problem)
    assert entries, "the 6-link walker ships an atlas"
    for e in entries:
        fp = find_fixed_point(problem, e.state, e.parameters, fallback=False)
        assert fp.converged, e.label
        assert np.abs(fp.state - e.state).max() < 1e-8, e.label
        # within the fit's NLP bound (0.9), not only its verdict
        assert fp.stable and fp.valid and fp.spectral_radius <= FitOptions().radius_bound(), \
            e.label
        assert abs(fp.spectral_radius - e.spectral_radius) < 1e-8, e.label


def test_starts_are_ranked_by_r2_on_the_users_curves_then_by_stability(problem):
    human = load_gait_curves("female_fast.csv")
    entries = load_atlas(problem)
    opts = FitOptions(multistart=len(entries) + 1)
    starts = select_starts(problem, human, opts)
    assert sorted(s.label for s in starts) == sorted(
        ["problem"] + [f"atlas:{e.label}" for e in entries])
    h = human.resample(101)
    for e in entries:
        st = next(s for s in starts if s.label == f"atlas:{e.label}")
        r2 = fit_scores(e.curves, h)
        assert st.score == np.mean([r2["r2_knee"], r2["r2_hip"]])
        assert st.spectral_radius == e.spectral_radius
    # the first start fits within the tolerance of the best and is the most stable of those
    best = max(s.score for s in starts)
    near = [s for s in starts if s.score >= best - opts.start_r2_tolerance]
    assert starts[0].spectral_radius == min(s.spectral_radius for s in near)
    assert starts == rank_starts(starts[::-1], opts.start_r2_tolerance)
    assert [s.label for s in select_starts(problem, human, FitOptions())] == [starts[0].label]
    assert [s.label for s in select_starts(problem, human, FitOptions(atlas=""))] == ["problem"]


def test_rank_starts_is_by_score_alone_at_zero_tolerance_and_by_stability_alone_at_any():
    z = np.zeros(1)
    starts = [Start(f"s{i}", z, z, score, rho) for i, (score, rho) in
              enumerate([(0.80, 0.70), (0.85, 0.88), (0.845, 0.83), (0.70, 0.60)])]
    assert [s.label for s in rank_starts(starts, 0.0)] == ["s1", "s2", "s0", "s3"]
    assert [s.label for s in rank_starts(starts, 1.0)] == ["s3", "s0", "s2", "s1"]
    assert [s.label for s in rank_starts(starts, 0.01)] == ["s2", "s1", "s0", "s3"]


@pytest.mark.slow  # four fits, two of them in fresh pool processes
def test_multistart_gives_identical_results_in_process_and_in_a_pool(problem, tmp_path):
    """Two starts (the problem's own and an atlas entry at c_ankle -1 %, c_knee_flex -1 %),
    fitted in this process and on a 2-process pool: the same answers, bit for bit."""
    from pdw_casadi.fit import fit_gait
    from pdw_casadi.fit.starts import AtlasEntry, save_atlas
    from pdw_casadi.gait.curves import gait_cycle
    from pdw_casadi.gait.simulate import Simulator

    names = list(problem.parameter_names)
    sim = Simulator(problem)
    entries = []
    for f in (1.0, 0.99):
        p = problem.parameter_vector()
        for n in ("c_ankle", "c_knee_flex"):
            p[names.index(n)] *= f
        fp = find_fixed_point(problem, problem.state_vector(), p)
        one = sim.run(fp.state, fp.parameters, steps=1, record=True)
        entries.append(AtlasEntry(f"f{f}", fp.state, fp.parameters, fp.spectral_radius,
                                  gait_cycle(one.trajectory, "III")))
    atlas = save_atlas(problem, entries, tmp_path / "atlas.json")
    human = load_gait_curves("female_fast.csv")
    # all compliance free is what lets atlas entries start a fit; the stability row is off
    # and the iterations few, to keep this a test of the dispatch, not of the optimiser
    opts = FitOptions(atlas=str(atlas), multistart=2, stability_constraint=False,
                      max_iter=15, rounds=1, verbose=False)
    serial = fit_gait(problem, human, opts, log=lambda m: None)
    pooled = fit_gait(problem, human, opts, log=lambda m: None, workers=2)
    assert len(serial.solves) == len(pooled.solves) == 2
    for a, b in zip(serial.solves, pooled.solves, strict=True):
        assert (a.start, a.status, a.iterations) == (b.start, b.status, b.iterations)
        assert a.objective == b.objective  # bit for bit
    assert len(serial.candidates) == len(pooled.candidates)
    for a, b in zip(serial.candidates, pooled.candidates, strict=True):
        assert np.array_equal(a.parameters, b.parameters)
