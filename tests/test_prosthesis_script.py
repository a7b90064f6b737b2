"""Usage errors of pdw-design: bad input is refused before any solve."""

from __future__ import annotations

import re

import pytest


@pytest.fixture(scope="module")
def script():
    from pdw_casadi.cli import design

    return design


@pytest.mark.parametrize("argv, msg", [
    (["--free", "k_ankel"], "--free: k_ankel"),
    (["--extension", "ankle_rest=0"], "--extension needs --family"),
    (["--family", "humanlike_6link_ankle", "--extension", "ankle_rest=0"],
     "exactly its extra compliance keys"),
    (["--family", "humanlike_6link_ankle", "--extension", "ankle_rest=flat"],
     "KEY=VALUE with a number"),
    (["--family", "compass_gait"], "does not extend"),
    (["--method", "continuation", "--free", "k_ankle"], "options of --method nlp only"),
    (["--mass-distribution", "l_sc", "--mass-bounds", "l_sc=2:1"], "0 < LO < HI"),
    (["--symmetry-tol", "1.5"], r"\[0, 1\)"),
    (["--free-sound", "k_ankle,kneee"], "--free-sound: kneee"),
    (["--method", "continuation", "--free-sound", "k_knee"], "options of --method nlp only"),
])
def test_bad_options_are_usage_errors(script, capsys, argv, msg):
    with pytest.raises(SystemExit) as exc:
        script.design_main(argv)
    assert exc.value.code == 2
    assert re.search(msg, capsys.readouterr().err)
