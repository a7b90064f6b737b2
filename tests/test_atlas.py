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
    starts = select_starts(problem, human, FitOptions(multistart=len(entries)))
    scores = [np.mean([fit_scores(e.curves, human.resample(101))[k]
                       for k in ("r2_knee", "r2_hip")]) for e in entries]
    assert [s.score for s in starts] == sorted(scores, reverse=True)
    assert select_starts(problem, human, FitOptions(atlas=""))[0].label == "problem"
