"""Problem files: every bad value is rejected with a ProblemError naming the file and the key,
and ``pdw-simulate`` turns such errors into one line on stderr and exit code 2."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from pdw_casadi.cli import simulate_main
from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.model.problem import ProblemError, load_overrides, load_problem

BUNDLED = (bundled_dir("problems") / "humanlike_6link.toml").read_text()


def _edit(text: str, key: str, new_line: str | None) -> str:
    """Replace the line that assigns ``key`` (first match) by ``new_line`` (None: delete)."""
    pattern = re.compile(rf"^{re.escape(key)}\s*=.*$", re.M)
    assert pattern.search(text), key
    return pattern.sub("" if new_line is None else new_line, text, count=1)


def _insert_after(text: str, header: str, line: str) -> str:
    assert header in text
    return text.replace(header, header + "\n" + line, 1)


BAD_FILES = {
    # case: (edited text, key the message must name)
    "unknown key": (_insert_after(BUNDLED, "[anthropometry]", "l_x = 0.1"), "anthropometry.l_x"),
    "unknown section": (BUNDLED + "\n[extras]\na = 1\n", "extras"),
    "missing key": (_edit(BUNDLED, "m_h", None), "anthropometry.m_h"),
    "missing state key": (_edit(BUNDLED, "dq3", None), "initial_state.dq3"),
    "extra state key": (_insert_after(BUNDLED, "[initial_state]", "dq4 = 0.1"),
                        "initial_state.dq4"),
    "nan": (_edit(BUNDLED, "J_t", "J_t = nan"), "anthropometry.J_t"),
    "inf": (_edit(BUNDLED, "k_knee", "k_knee = inf"), "compliance.k_knee"),
    "nan state": (_edit(BUNDLED, "dq1", "dq1 = nan"), "initial_state.dq1"),
    "zero mass": (_edit(BUNDLED, "m_t", "m_t = 0.0"), "anthropometry.m_t"),
    "negative mass": (_edit(BUNDLED, "m_h", "m_h = -35.88"), "anthropometry.m_h"),
    "negative length": (_edit(BUNDLED, "l_t", "l_t = -0.379"), "anthropometry.l_t"),
    "zero inertia": (_edit(BUNDLED, "J_s", "J_s = 0"), "anthropometry.J_s"),
    "string value": (_edit(BUNDLED, "l_s", 'l_s = "long"'), "anthropometry.l_s"),
    "negative damping": (_edit(BUNDLED, "c_ankle", "c_ankle = -0.1"), "compliance.c_ankle"),
    "open foot": (_edit(BUNDLED, "l_fh", "l_fh = 0.05"), "anthropometry.l_fh"),
}


@pytest.fixture(params=sorted(BAD_FILES))
def bad_problem(request, tmp_path):
    text, key = BAD_FILES[request.param]
    path = tmp_path / "bad_problem.toml"
    path.write_text(text)
    return path, key


def test_bundled_problem_is_the_paper_walker():
    pb = load_problem("humanlike_6link")
    assert pb.slope == pytest.approx(0.1484)
    assert pb.state_names == ["q1", "q2", "q3", "qf2", "dq1", "dq2", "dq3"]
    assert pb.parameter_vector().size == len(pb.compliance) + 1
    assert pb.anthropometry["l_ft"] + pb.anthropometry["l_fh"] == pytest.approx(
        pb.anthropometry["l_f"])


def test_bad_problem_file_names_file_and_key(bad_problem):
    path, key = bad_problem
    with pytest.raises(ProblemError) as info:
        load_problem(path)
    msg = str(info.value)
    assert str(path) in msg and key in msg, msg


def test_not_toml_and_missing_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[walker\nfamily = ")
    with pytest.raises(ProblemError, match="not valid TOML") as info:
        load_problem(path)
    assert str(path) in str(info.value)
    with pytest.raises(ProblemError, match="no_such_problem"):
        load_problem("no_such_problem")


def test_wrong_length_state_vector():
    pb = load_problem("humanlike_6link")
    with pytest.raises(ProblemError, match="6 values, expected 7"):
        pb.with_state(np.zeros(6))
    with pytest.raises(ProblemError, match="q9"):
        pb.with_state({"q9": 0.1})


def test_override_files(tmp_path):
    good = tmp_path / "state.json"
    good.write_text(json.dumps({"q1": 0.25}))
    assert load_overrides(good, "state") == {"q1": 0.25}
    toml = tmp_path / "comp.toml"
    toml.write_text("k_knee = 120.0\n")
    assert load_overrides(toml, "compliance") == {"k_knee": 120.0}
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ProblemError, match="cannot parse") as info:
        load_overrides(bad, "state")
    assert str(bad) in str(info.value)
    nan = tmp_path / "nan.toml"
    nan.write_text("q1 = nan\n")
    with pytest.raises(ProblemError, match="q1"):
        load_overrides(nan, "state")


# -- the CLI -----------------------------------------------------------------------------------
def _run_cli(argv, capsys) -> tuple[int, str]:
    with pytest.raises(SystemExit) as info:
        simulate_main(argv)
    err = capsys.readouterr().err
    return info.value.code, err


def _assert_one_line_error(code, err, *needles):
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def test_cli_bad_problem_file_exits_2(bad_problem, tmp_path, capsys):
    path, key = bad_problem
    code, err = _run_cli(["--problem", str(path), "--steps", "1", "--out",
                          str(tmp_path / "out")], capsys)
    _assert_one_line_error(code, err, str(path), key)


def test_cli_bad_overrides_exit_2(tmp_path, capsys):
    out = str(tmp_path / "out")
    bad_json = tmp_path / "state.json"
    bad_json.write_text("{oops")
    code, err = _run_cli(["--state", str(bad_json), "--out", out], capsys)
    _assert_one_line_error(code, err, str(bad_json))

    unknown = tmp_path / "state2.json"
    unknown.write_text(json.dumps({"q9": 1.0}))
    code, err = _run_cli(["--state", str(unknown), "--out", out], capsys)
    _assert_one_line_error(code, err, str(unknown), "q9")

    negative = tmp_path / "comp.toml"
    negative.write_text("c_ankle = -1.0\n")
    code, err = _run_cli(["--compliance", str(negative), "--out", out], capsys)
    _assert_one_line_error(code, err, str(negative), "compliance.c_ankle")

    missing = tmp_path / "nope.json"
    code, err = _run_cli(["--compliance", str(missing), "--out", out], capsys)
    _assert_one_line_error(code, err, str(missing))

    code, err = _run_cli(["--problem", "no_such_problem", "--out", out], capsys)
    _assert_one_line_error(code, err, "no_such_problem")


def test_cli_unwritable_output_exits_2(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    code, err = _run_cli(["--out", str(blocker / "sub")], capsys)
    _assert_one_line_error(code, err, str(blocker))
