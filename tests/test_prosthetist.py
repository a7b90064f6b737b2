"""The prosthetist's study (pdw_casadi.studies.prosthetist): the sound side fitted, the
prosthetic leg designed at each level of one mass homotopy, each level's gait re-solved."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pdw_casadi.model.gait_data import load_side_curves
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.system import physical_parameter_vector
from pdw_casadi.report.prosthetist import plot_prosthetist_study
from pdw_casadi.studies.prosthetist import (
    StudyOptions,
    prosthetist_study,
    study_design_options,
)


@pytest.mark.slow  # a fit, a per-leg walker's functions and two design solves (45 s warm)
def test_the_study_designs_each_level_and_rereads_its_gait(tmp_path):
    """Two tiny levels (0.1 and 0.2 % lighter, 15 iterations a solve): the homotopy lands on
    both; the fitted walker's row is a symmetric gait (both legs' R^2 equal, no asymmetry);
    every level's re-solved stride is stable, valid and symmetric within the verdict's 1 %,
    and its walker's prosthetic shank is lighter by exactly that level."""
    sides = load_side_curves("data/corpus/WBDS09_sides.csv")
    levels = (0.001, 0.002)
    study = prosthetist_study(
        load_problem("humanlike_6link"), sides,
        StudyOptions(levels=levels, design=dataclasses.replace(study_design_options(),
                                                               max_iter=15)),
        log=lambda m: None)
    t = study.table
    assert list(t["lighter_pct"]) == [0.0, 0.1, 0.2]
    assert t["converged"].all() and t["valid"].all()
    base = t.iloc[0]
    assert abs(base["step_length_asymmetry_pct"]) < 1e-6
    assert base["r2_knee_left"] == pytest.approx(base["r2_knee_right"], abs=1e-9)
    assert (t["step_radius"] <= 0.9).all()
    assert (t[["step_length_asymmetry_pct", "step_time_asymmetry_pct"]].abs() < 1.0).all(axis=None)
    for level in levels:
        walker, x = study.design.design_at(level)
        right, left = walker.leg_values("right")[1], walker.leg_values("left")[1]
        assert right["m_s"] == pytest.approx((1 - level) * left["m_s"], rel=1e-12)
        assert np.all(np.isfinite(x))
    # the last level's walker is the design's answer: the same values, the same gait
    last, x = study.design.design_at(levels[-1])
    np.testing.assert_array_equal(physical_parameter_vector(last),
                                  physical_parameter_vector(study.design.problem))
    np.testing.assert_array_equal(x, study.design.problem.state_vector())
    fig = plot_prosthetist_study(t, path=tmp_path / "study.png")
    assert len(fig.axes) == 2 and (tmp_path / "study.png").stat().st_size > 0
