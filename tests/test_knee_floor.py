"""The knee floor of the fit (FitOptions.knee_floor): knee R^2 never below the problem
file's own compliance on the same curves."""

from __future__ import annotations

from pathlib import Path

import pytest

from pdw_casadi.fit import FitOptions, fit_gait
from pdw_casadi.fit.core import knee_floor
from pdw_casadi.fit.result import reference_gait
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import load_problem

CORPUS = Path(__file__).resolve().parents[1] / "data" / "corpus"


def test_floor_values_and_refusals():
    """"reference" is the problem's own compliance's knee R^2 on the curves; a number is
    itself; None, or a fit without a knee target, has no floor; other strings are refused."""
    pb = load_problem("humanlike_6link")
    human = load_gait_curves("female_fast.csv")
    ref = reference_gait(pb, human)["r2_knee"]
    assert knee_floor(pb, human, FitOptions()) == pytest.approx(ref, abs=0.0)
    assert knee_floor(pb, human, FitOptions(knee_floor=0.5)) == 0.5
    assert knee_floor(pb, human, FitOptions(knee_floor=None)) is None
    with pytest.raises(ValueError, match="knee_floor"):
        knee_floor(pb, human, FitOptions(knee_floor="table3"))
    # a walker without compliance fits its slope only: a floor would pin it to its start
    kneed = load_problem("kneed_walker")
    assert knee_floor(kneed, human, FitOptions(free_slope=True)) is None


@pytest.mark.slow  # two fits of about 25 iterations
def test_floor_keeps_the_knee_where_the_sum_trades_it_for_the_hip():
    """On a corpus file whose hip is offset by one SD, the unconstrained sum of 1 - R^2 ends
    with a knee R^2 below the problem file's own; with the floor the re-simulated fit's knee
    is at or above it and its mean still above the reference's mean."""
    pb = load_problem("humanlike_6link")
    human = load_gait_curves(CORPUS / "WBDS09_hip+.csv")
    ref = reference_gait(pb, human)
    free = fit_gait(pb, human, FitOptions(verbose=False, knee_floor=None), log=lambda m: None)
    held = fit_gait(pb, human, FitOptions(verbose=False), log=lambda m: None)
    assert free.best is not None and held.best is not None
    assert free.best.scores["r2_knee"] < ref["r2_knee"]
    assert held.best.scores["r2_knee"] >= ref["r2_knee"] - 1e-6
    mean = (held.best.scores["r2_knee"] + held.best.scores["r2_hip"]) / 2
    assert mean > (ref["r2_knee"] + ref["r2_hip"]) / 2
