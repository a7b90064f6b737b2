"""``pdw-simulate``: the files it writes and what summary.json says about the Table-2 step."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from pdw_casadi.cli import COMMANDS, main, simulate_main
from pdw_casadi.engine.jsonio import write_json

OUTPUTS = ("trajectory.csv", "events.csv", "summary.json", "angles.png", "stick.png")
SUMMARY_KEYS = {"phases", "step_time_s", "step_length_m", "speed_m_s", "poincare_states",
                "residual", "energy_balance_J", "failure", "steps", "margins", "problem",
                "compliance", "slope"}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    assert simulate_main(["--problem", "humanlike_6link", "--steps", "1", "--out", str(out)]) == 0
    return out


def test_simulate_writes_all_outputs(run_dir):
    for name in OUTPUTS:
        assert (run_dir / name).stat().st_size > 0, name
    for png in ("angles.png", "stick.png"):
        assert (run_dir / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    traj = pd.read_csv(run_dir / "trajectory.csv")
    assert {"t_s", "phase", "q1_rad", "dq1_rad_s", "x_t1_m", "dx_t1_m_s", "knee1_deg",
            "hip2_deg", "kinetic_J", "N_foot1_N", "cop_foot1_from_toe_m",
            "clearance_toe2_m"} <= set(traj)
    assert np.all(np.diff(traj["t_s"]) >= 0)
    events = pd.read_csv(run_dir / "events.csv")
    guards = events[events["kind"] == "guard"]["event"].tolist()
    assert guards == ["toe_off", "heel_strike", "foot_strike"]


def test_summary_describes_the_step(run_dir):
    s = json.loads((run_dir / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(s)
    assert s["failure"] is None and s["slope"] == pytest.approx(0.1484)
    assert [p["name"] for p in s["phases"][0]] == ["I", "II", "III"]
    assert s["step_time_s"] == pytest.approx(sum(p["duration_s"] for p in s["phases"][0]))
    assert 0.5 < s["step_time_s"] < 0.9 and 0.4 < s["step_length_m"] < 0.8  # s, m
    assert s["speed_m_s"] == pytest.approx(s["step_length_m"] / s["step_time_s"])
    states = s["poincare_states"]
    assert len(states) == 2 and list(states[0]) == ["q1", "q2", "q3", "qf2", "dq1", "dq2", "dq3"]
    diff = np.array(list(states[1].values())) - np.array(list(states[0].values()))
    assert s["residual"] == pytest.approx(np.linalg.norm(diff)) and s["residual"] < 0.05
    assert max(abs(e) for e in s["energy_balance_J"]) < 1e-6
    assert s["steps"][0]["step_length_m"] == pytest.approx(s["step_length_m"])
    assert all(v > 0 for k, v in s["margins"].items() if k.startswith(("heel_strike:",
                                                                        "foot_strike:")))
    assert s["compliance"]["k_knee"] == pytest.approx(116.2)


def test_summary_round_trips_as_state_and_compliance_file(run_dir, tmp_path):
    """A summary.json is accepted by --state and --compliance (same gait again)."""
    summary = run_dir / "summary.json"
    out = tmp_path / "again"
    assert simulate_main(["--state", str(summary), "--compliance", str(summary),
                          "--steps", "1", "--out", str(out)]) == 0
    a = json.loads(summary.read_text())
    b = json.loads((out / "summary.json").read_text())
    assert b["residual"] == pytest.approx(a["residual"], abs=1e-12)


def test_a_fall_is_reported_not_raised(tmp_path, capsys):
    state = tmp_path / "state.json"
    state.write_text(json.dumps({"dq1": 0.0}))  # no forward speed: the walker tips back
    out = tmp_path / "fall"
    assert simulate_main(["--state", str(state), "--steps", "2", "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["failure"]["reason"] and s["failure"]["step"] == 0
    assert s["residual"] is None and s["step_time_s"] is None
    assert "warning:" in capsys.readouterr().err
    for name in OUTPUTS:
        assert (out / name).exists(), name


def test_bad_arguments_exit_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        simulate_main(["--steps", "0", "--out", str(tmp_path)])
    assert info.value.code == 2
    with pytest.raises(SystemExit) as info:
        main(["no-such-command"])
    assert info.value.code == 2
    assert "simulate" in COMMANDS


def test_write_json_handles_numpy_and_non_finite(tmp_path):
    path = write_json(tmp_path / "x.json", {
        "a": np.float64(1.5), "b": np.arange(3), "c": (np.int32(2), math.nan),
        "d": np.bool_(True), "e": float("inf"), "f": tmp_path})
    data = json.loads(path.read_text())
    assert data == {"a": 1.5, "b": [0, 1, 2], "c": [2, None], "d": True, "e": None,
                    "f": str(tmp_path)}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_command_tells_its_version(command, capsys):
    import tomllib
    from pathlib import Path

    pyproject = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml")
                              .read_text())
    with pytest.raises(SystemExit) as exc:
        COMMANDS[command](["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.split()[-1] == pyproject["project"]["version"]
