"""The bundled gait atlas: every entry is a stable, valid fixed point of its walker, and the
fit picks its starts from it by R^2 on the user's curves."""

from __future__ import annotations

import numpy as np

from pdw_casadi.curves import fit_scores
from pdw_casadi.fit import FitOptions
from pdw_casadi.fit.starts import load_atlas, select_starts
from pdw_casadi.fixed_point import find_fixed_point
from pdw_casadi.gait_data import load_gait_curves


def test_every_atlas_entry_is_a_stable_valid_fixed_point(problem):
    entries = load_atlas(problem)
    assert entries, "the 6-link walker ships an atlas"
    for e in entries:
        fp = find_fixed_point(problem, e.state, e.parameters, fallback=False)
        assert fp.converged, e.label
        assert np.abs(fp.state - e.state).max() < 1e-8, e.label
        assert fp.stable and fp.valid and fp.spectral_radius <= 0.9, e.label
        assert abs(fp.spectral_radius - e.spectral_radius) < 1e-8, e.label


def test_starts_are_the_atlas_entries_with_the_best_r2(problem):
    human = load_gait_curves("female_fast.csv")
    entries = load_atlas(problem)
    starts = select_starts(problem, human, FitOptions(multistart=len(entries) + 1))
    scores = [np.mean([fit_scores(e.curves, human.resample(101))[k]
                       for k in ("r2_knee", "r2_hip")]) for e in entries]
    assert starts[0].label == "problem"
    assert [s.score for s in starts[1:]] == sorted(scores, reverse=True)
    assert [s.label for s in select_starts(problem, human, FitOptions())] == ["problem"]


def test_multistart_gives_identical_results_in_process_and_in_a_pool(problem, tmp_path):
    """Two starts (the problem's own and an atlas entry at c_ankle -1 %, c_knee_flex -1 %),
    fitted in this process and on a 2-process pool: the same answers, bit for bit."""
    from pdw_casadi.curves import gait_cycle
    from pdw_casadi.fit import fit_gait
    from pdw_casadi.fit.starts import AtlasEntry, save_atlas
    from pdw_casadi.simulate import Simulator

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
