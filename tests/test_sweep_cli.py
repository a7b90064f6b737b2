"""``pdw-sweep``: the files it writes, --from-fit, --workers, and user errors."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdw_casadi.cli import COMMANDS, sweep_main
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.problem import load_problem

DEG = np.pi / 180
ARGS = ["--problem", "compass_gait", "--param", "slope", "--from", str(3 * DEG),
        "--to", str(6 * DEG), "--num", "7"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    assert sweep_main([*ARGS, "--out", str(out)]) == 0
    return out


def test_sweep_writes_table_events_and_figure(run_dir, capsys):
    table = pd.read_csv(run_dir / "sweep.csv")
    assert len(table) == 7 and table["converged"].all()
    assert {"slope_rad", "q_st_rad", "q_sw_rad", "dq_st_rad_s", "dq_sw_rad_s", "step_time_s",
            "step_length_m",
            "speed_m_s", "spectral_radius", "eig0_re", "eig0_im", "stable", "valid",
            "margin:swing:min_N_foot1_N", "margin:heel_strike:impulse_foot2_N_s"} <= set(table)
    np.testing.assert_allclose(table["slope_rad"], np.linspace(3, 6, 7) * DEG, rtol=0, atol=1e-15)
    np.testing.assert_allclose(table["speed_m_s"], table["step_length_m"] / table["step_time_s"])
    ev = json.loads((run_dir / "events.json").read_text())
    kinds = [e["kind"] for e in ev["events"]]
    assert kinds[0] == "period_doubling"
    pd_slope = ev["events"][0]["value"]
    # the stable rows are exactly those below the period doubling
    np.testing.assert_array_equal(table["stable"], table["slope_rad"] < pd_slope)
    rng = ev["stable_valid_ranges"]
    assert rng[0]["from"] == pytest.approx(3 * DEG) and rng[0]["to"] == pd_slope
    assert (run_dir / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "sweep" in COMMANDS


def test_workers_give_the_same_csv(run_dir, tmp_path):
    assert sweep_main([*ARGS, "--workers", "2", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "sweep.csv").read_text() == (run_dir / "sweep.csv").read_text()


def test_from_fit_starts_at_the_fit(tmp_path):
    pb = load_problem("compass_gait")
    slope = 3.5 * DEG
    fp = find_fixed_point(pb, p=np.array([slope]))
    assert fp.converged
    fit = tmp_path / "summary.json"
    fit.write_text(json.dumps({"compliance": {}, "slope": slope,
                               "fixed_point": fp.state_dict()}))
    out = tmp_path / "out"
    assert sweep_main(["--problem", "compass_gait", "--from", str(3.5 * DEG), "--to",
                       str(4 * DEG), "--num", "3", "--from-fit", str(fit), "--out",
                       str(out)]) == 0
    table = pd.read_csv(out / "sweep.csv")
    first = table.iloc[0]
    assert first["slope_rad"] == slope and first["iterations"] == 0  # already a fixed point
    np.testing.assert_allclose(first[[f"{n}_rad" if n.startswith("q") else f"{n}_rad_s"
                                      for n in pb.state_names]].to_numpy(float), fp.state,
                               atol=1e-12)


@pytest.mark.parametrize("extra, message", [
    (["--param", "k_knee"], "no parameter 'k_knee'"),
    (["--num", "1"], "--num must be >= 2"),
    (["--from-fit", "missing.json"], "missing.json"),
    (["--gait", "female_fast.csv"], "needs knee and hip curves"),
])
def test_user_errors_exit_2(tmp_path, capsys, extra, message):
    with pytest.raises(SystemExit) as exc:
        sweep_main([*ARGS, *extra, "--out", str(tmp_path)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err


def test_rows_found_before_an_interruption_are_on_disk(tmp_path, monkeypatch, capsys):
    """The rows are appended one by one (to sweep.partial.csv until the sweep completes):
    stopping the sweep (Ctrl-C) loses nothing found, and one line says where they are."""
    import pdw_casadi.gait.sweep as sweep_module

    real, calls = sweep_module.point_row, []

    def interrupted_after_three(*args, **kwargs):
        if len(calls) == 3:
            raise KeyboardInterrupt
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(sweep_module, "point_row", interrupted_after_three)
    assert sweep_main([*ARGS, "--out", str(tmp_path)]) == 130
    err = capsys.readouterr().err.strip().splitlines()[-1]
    partial = tmp_path / "sweep.partial.csv"
    assert err.startswith("interrupted: ") and f"3 rows found so far are in {partial}" in err
    assert not (tmp_path / "sweep.csv").exists()
    table = pd.read_csv(partial)
    assert len(table) == 3 and table["converged"].all()
    np.testing.assert_allclose(table["slope_rad"], np.linspace(3, 6, 7)[:3] * DEG, atol=1e-15)


def test_gait_file_adds_r2_of_each_rows_own_gait(tmp_path):
    """With --gait, every row carries R^2 of its own gait cycle: at the paper's slope it is
    the R^2 of the fixed point solved here directly (no sweep code involved)."""
    from pdw_casadi.gait.curves import fit_scores, gait_cycle
    from pdw_casadi.gait.simulate import Simulator
    from pdw_casadi.model.gait_data import load_gait_curves

    sw = tmp_path / "sw"
    assert sweep_main(["--problem", "humanlike_6link", "--from", "0.14839", "--to", "0.1484",
                       "--num", "2", "--gait", "female_fast.csv", "--out", str(sw)]) == 0
    table = pd.read_csv(sw / "sweep.csv").sort_values("slope_rad")
    assert len(table) == 2 and table["converged"].all()
    pb = load_problem("humanlike_6link")
    fp = find_fixed_point(pb)
    sim = Simulator(pb)
    one = sim.run(fp.state, fp.parameters, steps=1, record=True)
    scores = fit_scores(gait_cycle(one.trajectory, sim.hs.model.heel_strike_phase),
                        load_gait_curves("female_fast.csv"))
    at_paper = table[table["slope_rad"] == 0.1484].iloc[0]
    for key in ("r2_knee", "r2_hip", "r2_thigh"):
        assert at_paper[key] == pytest.approx(scores[key], abs=1e-8)
    # a neighbouring slope walks a slightly different gait: close but not the same R^2
    other = table.iloc[0]
    assert 0 < abs(other["r2_knee"] - at_paper["r2_knee"]) < 0.01


def test_refit_needs_a_gait_file(tmp_path, capsys):
    from pdw_casadi.cli import sweep_main

    with pytest.raises(SystemExit) as info:
        sweep_main(["--problem", "humanlike_6link", "--param", "slope", "--from", "0.1484",
                    "--to", "0.1485", "--num", "2", "--refit", "--out", str(tmp_path / "o")])
    assert info.value.code == 2
    assert "--refit needs --gait" in capsys.readouterr().err
