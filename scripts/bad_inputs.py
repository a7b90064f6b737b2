"""Run a corpus of bad inputs through the four commands and check the CLI contract.

Every case runs ``python -m pdw_casadi.cli COMMAND ...`` as a subprocess (with a timeout)
in a scratch directory. A case is *handled cleanly* when either

- exit code 2, stderr exactly one line starting with ``error:``, no traceback, and the
  output directory unchanged (it is prepared holding files "of an earlier run", among them
  a ``sweep.csv``; nothing may be written there or deleted), or a missing output directory
  still missing; or
- exit code 1 with a ``no gait: <reason>`` line and no traceback (the input was valid but
  there is no gait: such cases are marked ``nogait``).

An ``error: internal error`` line is never clean (it is a bug caught by the last resort).

    python scripts/bad_inputs.py            # all cases, prints "N of M handled cleanly"
    python scripts/bad_inputs.py -k sweep   # only cases whose id contains "sweep"
    python scripts/bad_inputs.py --list     # the case ids

Exit code 0 when every case is clean, else 1.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = ("simulate", "fixed-point", "sweep", "fit")
#: arguments every command needs besides the case's own (sweep needs a range, fit a gait)
REQUIRED = {"simulate": [], "fixed-point": [],
            "sweep": ["--from", "0.05", "--to", "0.06", "--num", "3"],
            "fit": ["--gait", "female_fast.csv"]}


@dataclass
class Case:
    id: str
    command: str
    args: list[str]
    expect: str = "usage"  # "usage" (exit 2) or "nogait" (exit 1)
    out: str = "existing"  # "existing": a prepared --out; "missing": a fresh path; "none"
    required: bool = True  # add REQUIRED[command]
    timeout: float = 90.0
    problem: str | None = "compass_gait"  # default --problem, None: not given


@dataclass
class Outcome:
    case: Case
    code: int | None
    stderr: str
    clean: bool
    why: str = ""
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)


# -- scratch files ------------------------------------------------------------------------
def _write(base: Path, name: str, text: str | bytes) -> str:
    path = base / name
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return str(path)


def make_files(base: Path) -> dict[str, str]:
    """The bad (and a few good) input files the cases refer to, by key."""
    cg = (ROOT / "problems" / "compass_gait.toml").read_text()
    hl = (ROOT / "problems" / "humanlike_6link.toml").read_text()
    f: dict[str, str] = {}

    def variant(key, text, old, new):
        assert old in text, (key, old)
        f[key] = _write(base, f"problems/{key}.toml", text.replace(old, new, 1))

    f["dir"] = str(base / "a_directory")
    (base / "a_directory").mkdir(exist_ok=True)
    f["toml_syntax"] = _write(base, "problems/syntax.toml", cg + "\n[[[ not toml\n")
    f["toml_binary"] = _write(base, "problems/binary.toml", b"\xff\xfe\x00\x81 garbage")
    f["toml_empty"] = _write(base, "problems/empty.toml", "")
    variant("no_family", cg, 'family = "compass_gait"\n', "")
    variant("bad_family", cg, 'family = "compass_gait"', 'family = "hexapod"')
    variant("family_number", cg, 'family = "compass_gait"', "family = 3")
    f["bounds_scalar"] = _write(base, "problems/bounds_scalar.toml",
                                "compliance_bounds = 5\n" + cg)
    variant("bounds_reversed", hl, "k_knee = [10.0, 1000.0]", "k_knee = [1000.0, 10.0]")
    variant("bounds_outside", hl, "k_knee = [10.0, 1000.0]", "k_knee = [200.0, 1000.0]")
    variant("bounds_string", hl, "k_knee = [10.0, 1000.0]", 'k_knee = ["a", "b"]')
    variant("bounds_three", hl, "k_knee = [10.0, 1000.0]", "k_knee = [1.0, 2.0, 3.0]")
    variant("bounds_unknown", hl, "k_knee = [10.0, 1000.0]", "k_knee = [10.0, 1000.0]\n"
            "k_hip = [0.0, 1.0]")
    variant("step_tiny", cg, "step_size = 5e-4", "step_size = 1e-9")
    variant("step_huge", cg, "step_size = 5e-4", "step_size = 0.5")
    variant("step_negative", cg, "step_size = 5e-4", "step_size = -5e-4")
    variant("step_string", cg, "step_size = 5e-4", 'step_size = "fast"')
    variant("phase_time_huge", cg, "max_phase_time = 3.0", "max_phase_time = 1e6")
    variant("mass_negative", cg, "m = 5.0 ", "m = -5.0 ")
    variant("mass_zero", cg, "m_h = 10.0", "m_h = 0.0")
    variant("mass_nan", cg, "m_h = 10.0", "m_h = nan")
    variant("mass_inf", cg, "m_h = 10.0", "m_h = inf")
    variant("mass_bool", cg, "m_h = 10.0", "m_h = true")
    variant("slope_steep", cg, "slope = 0.05235987755982988", "slope = 1.0")
    variant("gravity_negative", cg, "g = 9.81", "g = -9.81")
    variant("missing_state", cg, "dq_sw = -0.3773739", "")
    variant("extra_state", cg, "dq_sw = -0.3773739", "dq_sw = -0.3773739\nq_knee = 0.1")
    variant("unknown_section", cg, "[numerics]", "[controller]\ngain = 1\n[numerics]")
    variant("unknown_anthro", cg, "m_h = 10.0", "m_h = 10.0\nm_arm = 2.0")
    variant("foot_open", hl, "l_fh = 0.03 ", "l_fh = 0.05 ")
    variant("hl_no_bounds_stiff", hl, "c_ankle = [0.05, 5.0]\n", "")
    f["hl_asym"] = _write(base, "problems/hl_asym.toml",
                          hl + "\n[compliance.right]\nk_ankle = 5.15\n")
    f["hl_stiff_damper"] = f["hl_no_bounds_stiff"]
    # override files
    f["state_number"] = _write(base, "over/state_number.json", "3.5")
    f["state_string"] = _write(base, "over/state_string.json", '"q_st"')
    f["state_list"] = _write(base, "over/state_list.json", "[0.1, 0.2]")
    f["state_null"] = _write(base, "over/state_null.json", "null")
    f["state_empty"] = _write(base, "over/state_empty.json", "{}")
    f["state_unknown"] = _write(base, "over/state_unknown.json", '{"q_knee": 0.1}')
    f["state_nan"] = _write(base, "over/state_nan.json", '{"q_st": NaN}')
    f["state_inf"] = _write(base, "over/state_inf.json", '{"q_st": Infinity}')
    f["state_text"] = _write(base, "over/state_text.json", '{"q_st": "0.2"}')
    f["state_bool"] = _write(base, "over/state_bool.json", '{"q_st": true}')
    f["state_badjson"] = _write(base, "over/state_bad.json", '{"q_st": 0.2,,}')
    f["state_badtoml"] = _write(base, "over/state_bad.toml", "q_st = = 0.2")
    f["state_binary"] = _write(base, "over/state_binary.json", b"\x00\xff\x81\x82")
    f["state_nested"] = _write(base, "over/state_nested.json", '{"fixed_point": 3}')
    f["state_table"] = _write(base, "over/state_table.json", '{"q_st": {"v": 1}}')
    f["state_falls"] = _write(base, "over/state_falls.json", '{"dq_st": 0.0, "dq_sw": 0.0}')
    f["hl_state_scuffs"] = _write(base, "over/hl_state_scuffs.json", '{"dq1": -3.5}')
    f["comp_unknown"] = _write(base, "over/comp_unknown.json", '{"k_hip": 1.0}')
    f["comp_knee_stiff"] = _write(base, "over/comp_knee.json", '{"k_knee": 1e9}')
    f["comp_ankle_stiff"] = _write(base, "over/comp_ankle.json", '{"c_ankle": 1e6}')
    f["comp_negative"] = _write(base, "over/comp_negative.json", '{"c_ankle": -0.5}')
    f["comp_below"] = _write(base, "over/comp_below.json", '{"k_knee": 1.0}')
    f["comp_nan"] = _write(base, "over/comp_nan.json", '{"k_knee": NaN}')
    f["comp_string"] = _write(base, "over/comp_string.json", '{"k_knee": "stiff"}')
    f["comp_number"] = _write(base, "over/comp_number.json", "116.2")
    f["comp_for_cg"] = _write(base, "over/comp_for_cg.json", '{"k_knee": 100.0}')
    f["comp_toml_bad"] = _write(base, "over/comp.toml", "k_knee = [")
    f["comp_empty_toml"] = _write(base, "over/comp_empty.toml", "")
    # fit summaries (--from-fit)
    f["fit_number"] = _write(base, "fit/number.json", "0.05")
    f["fit_string"] = _write(base, "fit/string.json", '"summary"')
    f["fit_list"] = _write(base, "fit/list.json", "[1, 2]")
    f["fit_null"] = _write(base, "fit/null.json", "null")
    f["fit_missing"] = _write(base, "fit/missing.json", '{"slope": 0.05}')
    f["fit_badjson"] = _write(base, "fit/bad.json", "{slope: 0.05}")
    f["fit_slope_str"] = _write(base, "fit/slope_str.json",
                                '{"compliance": {}, "slope": "steep", "fixed_point": {}}')
    f["fit_slope_steep"] = _write(base, "fit/slope_steep.json",
                                  '{"compliance": {}, "slope": 1.2, "fixed_point": {}}')
    f["fit_slope_nan"] = _write(base, "fit/slope_nan.json",
                                '{"compliance": {}, "slope": NaN, "fixed_point": {}}')
    f["fit_fp_list"] = _write(base, "fit/fp_list.json",
                              '{"compliance": {}, "slope": 0.05, "fixed_point": [1, 2]}')
    f["fit_fp_unknown"] = _write(base, "fit/fp_unknown.json",
                                 '{"compliance": {}, "slope": 0.05, "fixed_point": {"x": 1}}')
    f["fit_fp_text"] = _write(base, "fit/fp_text.json",
                              '{"compliance": {}, "slope": 0.05, "fixed_point": {"q_st": "a"}}')
    f["fit_comp_unknown"] = _write(base, "fit/comp_unknown.json",
                                   '{"compliance": {"k": 1}, "slope": 0.05, "fixed_point": {}}')
    f["fit_binary"] = _write(base, "fit/binary.json", b"\xff\xfe\xfa")
    # gait curves
    good = (ROOT / "data" / "female_fast.csv").read_text().splitlines()
    header = good[0].split(",")
    no_thigh = [i for i, c in enumerate(header) if not c.startswith("thigh")]
    f["gait_no_thigh"] = _write(base, "gait/no_thigh.csv", "\n".join(
        ",".join(row.split(",")[i] for i in no_thigh) for row in good) + "\n")
    f["gait_empty"] = _write(base, "gait/empty.csv", "")
    f["gait_header_only"] = _write(base, "gait/header.csv", good[0] + "\n")
    f["gait_text"] = _write(base, "gait/text.csv", good[0] + "\n" + "\n".join(
        ",".join("x" for _ in header) for _ in range(30)) + "\n")
    f["gait_no_knee"] = _write(base, "gait/no_knee.csv", "\n".join(
        ",".join(v for c, v in zip(header, row.split(","), strict=True)
                 if not c.startswith("knee")) for row in good) + "\n")
    f["gait_binary"] = _write(base, "gait/binary.csv", b"\x00\x01\x02\xff" * 50)
    f["gait_short"] = _write(base, "gait/short.csv", "\n".join(good[:3]) + "\n")
    # per-side gait curves (knee_left_mean_deg, ...)
    f["sides_good"] = str(ROOT / "data" / "subjects" / "WBDS09_fast_sides.csv")
    sides = Path(f["sides_good"]).read_text().splitlines()
    sh = sides[0].split(",")
    f["sides_mixed"] = _write(base, "gait/sides_mixed.csv", "\n".join(
        row + "," + row.split(",")[sh.index("knee_left_mean_deg")] if i else
        row + ",knee_mean_deg" for i, row in enumerate(sides)) + "\n")
    keep = [i for i, c in enumerate(sh) if c != "thigh_right_mean_deg"]
    f["sides_one_sided"] = _write(base, "gait/sides_one_sided.csv", "\n".join(
        ",".join(row.split(",")[i] for i in keep) for row in sides) + "\n")
    f["sides_text"] = _write(base, "gait/sides_text.csv", sides[0] + "\n" + "\n".join(
        ",".join("x" for _ in sh) for _ in range(30)) + "\n")
    f["a_file"] = _write(base, "plain_file.txt", "not a directory\n")
    return f


def make_cases(f: dict[str, str]) -> list[Case]:
    cases: list[Case] = []
    hl = ["--problem", "humanlike_6link"]
    for cmd in COMMANDS:
        c = cmd
        fit = cmd == "fit"
        # problem files
        for key in ("toml_syntax", "toml_binary", "toml_empty", "no_family", "bad_family",
                    "family_number", "bounds_scalar", "bounds_reversed", "bounds_outside",
                    "bounds_string", "bounds_three", "bounds_unknown", "step_tiny",
                    "step_huge", "step_negative", "step_string", "phase_time_huge",
                    "mass_negative", "mass_zero", "mass_nan", "mass_inf", "mass_bool",
                    "slope_steep", "gravity_negative", "missing_state", "extra_state",
                    "unknown_section", "unknown_anthro", "foot_open"):
            cases.append(Case(f"{c}:problem:{key}", c, ["--problem", f[key]], problem=None))
        cases.append(Case(f"{c}:problem:no_such", c, ["--problem", "no_such_walker"],
                          problem=None))
        cases.append(Case(f"{c}:problem:directory", c, ["--problem", f["dir"]],
                          problem=None))
        # override files
        for key in ("state_number", "state_string", "state_list", "state_null",
                    "state_empty", "state_unknown", "state_nan", "state_inf", "state_text",
                    "state_bool", "state_badjson", "state_badtoml", "state_binary",
                    "state_nested", "state_table"):
            if fit and key not in ("state_number", "state_unknown", "state_nan"):
                continue
            cases.append(Case(f"{c}:state:{key}", c, ["--state", f[key]]))
        cases.append(Case(f"{c}:state:missing", c, ["--state", "no/such/state.json"]))
        cases.append(Case(f"{c}:state:directory", c, ["--state", f["dir"]]))
        for key in ("comp_unknown", "comp_knee_stiff", "comp_ankle_stiff", "comp_negative",
                    "comp_below", "comp_nan", "comp_string", "comp_number", "comp_toml_bad",
                    "comp_empty_toml"):
            if fit and key in ("comp_nan", "comp_string", "comp_toml_bad"):
                continue
            cases.append(Case(f"{c}:compliance:{key}", c, [*hl, "--compliance", f[key]],
                              problem=None))
        cases.append(Case(f"{c}:compliance:for_compass_gait", c,
                          ["--problem", "compass_gait", "--compliance", f["comp_for_cg"]],
                          problem=None))
        # output directory
        cases.append(Case(f"{c}:out:is_a_file", c, ["--out", f["a_file"]], out="none"))
        cases.append(Case(f"{c}:out:under_a_file", c, ["--out", f["a_file"] + "/sub"],
                          out="none"))
        cases.append(Case(f"{c}:out:proc", c, ["--out", "/proc/pdw-no-such/out"], out="none"))
        if not fit:
            cases.append(Case(f"{c}:out:missing_value", c, ["--out"], out="none"))
        # argparse
        cases.append(Case(f"{c}:argparse:unknown_option", c, ["--bogus", "1"]))
        cases.append(Case(f"{c}:argparse:positional", c, ["stray"]))
        cases.append(Case(f"{c}:argparse:problem_no_value", c, ["--problem"], problem=None))

    # -- pdw-simulate -------------------------------------------------------------------
    for v in ("0", "-1", "abc", "2.5", "1000000000", "1e3", ""):
        cases.append(Case(f"simulate:steps:{v or 'empty'}", "simulate", ["--steps", v]))
    for flag, vals in (("--snapshots", ("0", "1", "x", "1000")), ("--fps", ("0", "-5", "1e9",
                                                                            "nan"))):
        for v in vals:
            cases.append(Case(f"simulate:{flag[2:]}:{v}", "simulate", [flag, v]))
    cases.append(Case("simulate:animate:proc", "simulate", ["--animate", "/proc/x/walk.gif"]))
    cases.append(Case("simulate:animate:png", "simulate", ["--animate", "walk.png"]))
    cases.append(Case("simulate:animate:directory", "simulate", ["--animate", f["dir"]]))
    cases.append(Case("simulate:animate:under_file", "simulate",
                      ["--animate", f["a_file"] + "/walk.gif"]))
    cases.append(Case("simulate:nogait:stiff_damper", "simulate",
                      ["--problem", f["hl_stiff_damper"], "--compliance",
                       f["comp_ankle_stiff"]], expect="nogait", problem=None))

    # -- pdw-fixed-point ----------------------------------------------------------------
    for v in ("-1", "nan", "inf", "-inf", "0", "abc", "1", "1e-300", "0x10"):
        cases.append(Case(f"fixed-point:tol:{v}", "fixed-point", [f"--tol={v}"]))
    cases.append(Case("fixed-point:nogait:scuffs_at_start", "fixed-point",
                      [*hl, "--state", f["hl_state_scuffs"]], expect="nogait", problem=None))
    cases.append(Case("fixed-point:nogait:falls", "fixed-point", ["--state", f["state_falls"]],
                      expect="nogait"))

    # -- pdw-sweep ------------------------------------------------------------------------
    W = "sweep"

    def sw(cid, args, **kw):
        cases.append(Case(f"sweep:{cid}", W, args, required=False, **kw))

    base = ["--from", "0.05", "--to", "0.06"]
    sw("from:nan", ["--from", "nan", "--to", "0.06"])
    sw("from:-inf", ["--from=-inf", "--to", "0.06"])
    sw("to:inf", ["--from", "0.05", "--to", "inf"])
    sw("from:text", ["--from", "steep", "--to", "0.06"])
    sw("from:missing", ["--to", "0.06"])
    sw("to:missing", ["--from", "0.05"])
    sw("from_equals_to", ["--from", "0.05", "--to", "0.05"])
    for v in ("0", "1", "-3", "1e3", "100001", "x"):
        sw(f"num:{v}", [*base, "--num", v])
    sw("param:k_knee_on_compass", [*base, "--param", "k_knee"])
    sw("param:bogus", [*base, "--param", "bogus"])
    sw("param:negative_damper", [*hl, "--param", "c_ankle", "--from", "-0.5", "--to", "0.8"],
       problem=None)
    sw("param:below_bounds", [*hl, "--param", "k_knee", "--from", "5", "--to", "120"],
       problem=None)
    sw("param:above_bounds", [*hl, "--param", "k_knee", "--from", "100", "--to", "5000"],
       problem=None)
    sw("param:slope_steep", ["--from", "0.05", "--to", "0.9"])
    sw("param:slope_negative_steep", ["--from", "-0.9", "--to", "0.05"])
    sw("mode:bogus", [*base, "--mode", "bogus"])
    sw("predictor:bogus", [*base, "--predictor", "newton"])
    sw("refit:no_gait", [*hl, "--from", "0.1484", "--to", "0.1485", "--num", "2", "--refit"],
       problem=None)
    sw("refit:not_slope", [*hl, "--param", "k_knee", "--from", "100", "--to", "120",
                           "--refit", "--gait", "female_fast.csv"], problem=None)
    sw("gait:missing", [*base, "--gait", "no_such.csv"])
    sw("gait:compass_has_no_knee", [*base, "--gait", "female_fast.csv"])
    sw("gait:empty", [*hl, "--from", "0.148", "--to", "0.149", "--gait", f["gait_empty"]],
       problem=None)
    sw("gait:text", [*hl, "--from", "0.148", "--to", "0.149", "--gait", f["gait_text"]],
       problem=None)
    sw("gait:directory", [*hl, "--from", "0.148", "--to", "0.149", "--gait", f["dir"]],
       problem=None)
    for key in ("fit_number", "fit_string", "fit_list", "fit_null", "fit_missing",
                "fit_badjson", "fit_slope_str", "fit_slope_steep", "fit_slope_nan",
                "fit_fp_list", "fit_fp_unknown", "fit_fp_text", "fit_comp_unknown",
                "fit_binary"):
        sw(f"from_fit:{key}", [*base, "--from-fit", f[key]])
    sw("from_fit:missing_file", [*base, "--from-fit", "no/such/summary.json"])
    sw("from_fit:directory", [*base, "--from-fit", f["dir"]])
    for cid, addr in (("not_a_url", "not a url"), ("refused", "tcp://127.0.0.1:1"),
                      ("no_port", "tcp://127.0.0.1"), ("http", "http://127.0.0.1:8786"),
                      ("no_host", "tcp://:8786"), ("port_range", "tcp://127.0.0.1:99999"),
                      ("port_text", "tcp://127.0.0.1:abc"), ("empty", ""),
                      ("path", "tcp://127.0.0.1:8786/x")):
        sw(f"scheduler:{cid}", [*base, "--scheduler", addr], timeout=60)
    for v in ("0", "-2", "x"):
        sw(f"workers:{v}", [*base, "--workers", v])
    for v in ("-1", "nan", "0"):
        sw(f"tol:{v}", [*base, "--tol", v])
    asym = ["--problem", f["hl_asym"]]
    sw("asym:leg_mass_negative", [*asym, "--param", "right.m_s", "--from", "-1", "--to", "2"],
       problem=None)
    sw("asym:leg_value_above_bounds", [*asym, "--param", "right.k_ankle", "--from", "5",
                                       "--to", "1000"], problem=None)
    sw("asym:unknown_leg_key", [*asym, "--param", "right.m_arm", "--from", "1", "--to", "2"],
       problem=None)
    sw("asym:key_without_leg", [*asym, "--param", "k_ankle", "--from", "5", "--to", "6"],
       problem=None)
    sw("asym:with_gait", [*asym, "--from", "0.148", "--to", "0.149", "--gait",
                          "female_fast.csv"], problem=None)
    sw("nogait:start_fails", [*hl, "--from", "0.148", "--to", "0.149", "--num", "2",
                              "--state", f["hl_state_scuffs"]], expect="nogait", problem=None)

    # -- pdw-fit --------------------------------------------------------------------------
    def ft(cid, args, **kw):
        cases.append(Case(f"fit:{cid}", "fit", args, required=False, **kw))

    g = ["--gait", "female_fast.csv"]
    ft("gait:missing_arg", [*hl])
    ft("gait:no_such_file", [*hl, "--gait", "no_such.csv"])
    ft("gait:directory", [*hl, "--gait", f["dir"]])
    for key in ("gait_empty", "gait_header_only", "gait_text", "gait_no_knee", "gait_binary",
                "gait_short"):
        ft(f"gait:{key}", [*hl, "--gait", f[key]])
    ft("hip_target:thigh_without_column", [*hl, "--gait", f["gait_no_thigh"],
                                           "--hip-target", "thigh"])
    ft("hip_target:bogus", [*hl, *g, "--hip-target", "pelvis"])
    for v in ("1.5", "0", "1", "nan", "-0.5", "x"):
        ft(f"max_radius:{v}", [*hl, *g, "--max-radius", v])
    for flag in ("--multistart", "--max-iter", "--rounds", "--workers"):
        ft(f"{flag[2:]}:0", [*hl, *g, flag, "0"])
        ft(f"{flag[2:]}:text", [*hl, *g, flag, "many"])
    ft("seed:negative", [*hl, *g, "--seed", "-1"])
    for key in ("sides_mixed", "sides_one_sided", "sides_text"):
        ft(f"gait:{key}", [*hl, "--gait", f[key]])
    sg = ["--gait", f["sides_good"]]
    ft("sides:side_without_sides", [*hl, *g, "--side", "right"])
    ft("sides:side_bogus", [*hl, *sg, "--side", "middle"])
    ft("sides:timing", [*hl, *sg, "--timing"])
    ft("sides:multistart", [*hl, *sg, "--multistart", "2"])
    ft("sides:stride_start_bogus", [*hl, *sg, "--stride-start", "nowhere"])
    ft("sides:right_is_per_side", [*hl, *g, "--gait-right", f["sides_good"]])
    ft("sides:right_missing", [*hl, *g, "--gait-right", "no_such.csv"])
    ft("sides:compass_has_no_knee", ["--problem", "compass_gait", *sg])
    ft("problem:compass_has_no_knee", ["--problem", "compass_gait", *g])
    ft("problem:kneed_nothing_to_fit", ["--problem", "kneed_walker", *g])
    for case in cases:
        if case.command == "fit":
            # a fit that got past validation would run for minutes: keep it short; and
            # the compass gait has no knee, so generic fit cases use the 6-link walker
            case.timeout = 50.0
            if case.problem is not None:
                case.problem = "humanlike_6link"
    return cases


# -- running ---------------------------------------------------------------------------------
def snapshot(path: Path) -> dict[str, str] | None:
    if not path.exists():
        return None
    if path.is_file():
        return {"": hashlib.sha1(path.read_bytes()).hexdigest()}
    out = {}
    for p in sorted(path.rglob("*")):
        out[str(p.relative_to(path))] = (hashlib.sha1(p.read_bytes()).hexdigest()
                                         if p.is_file() else "dir")
    return out


def prepare_out(base: Path, case: Case, index: int) -> Path | None:
    if case.out == "none":
        return None
    out = base / "runs" / f"case{index:03d}"
    if case.out == "existing":
        out.mkdir(parents=True)
        (out / "sweep.csv").write_text("slope,converged\n0.05,True\n")
        (out / "summary.json").write_text('{"earlier": "run"}\n')
        (out / "notes.txt").write_text("results of an earlier run\n")
    return out


def run_case(case: Case, base: Path, index: int, python: str) -> Outcome:
    out = prepare_out(base, case, index)
    args = list(case.args)
    if case.problem is not None and "--problem" not in args:
        args = ["--problem", case.problem, *args]
    if case.required:
        args += REQUIRED[case.command]
    if out is not None and "--out" not in args:
        args += ["--out", str(out)]
    before = snapshot(out) if out is not None else None
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.pop("PDW_DEBUG", None)
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([python, "-m", "pdw_casadi.cli", case.command, *args],
                              capture_output=True, text=True, timeout=case.timeout,
                              cwd=base, env=env)
    except subprocess.TimeoutExpired:
        return Outcome(case, None, "", False, f"timed out after {case.timeout:g} s",
                       time.perf_counter() - t0)
    dt = time.perf_counter() - t0
    err = proc.stderr
    lines = [ln for ln in err.splitlines() if ln.strip()]
    code = proc.returncode
    why = ""
    if "Traceback" in err or "Traceback" in proc.stdout:
        why = "traceback"
    elif any("internal error" in ln for ln in lines):
        why = "internal error"
    elif code == 2:
        if len(lines) != 1 or not lines[0].startswith("error:"):
            why = f"{len(lines)} stderr lines"
        elif out is not None and snapshot(out) != before:
            why = "output directory changed"
    elif code == 1:
        if not any(ln.startswith("no gait:") for ln in lines):
            why = "exit 1 without a 'no gait:' reason"
    else:
        why = f"exit code {code}"
    if not why and case.expect == "nogait" and code != 1:
        why = f"expected exit 1 (no gait), got {code}"
    if not why and case.expect == "usage" and code != 2:
        why = f"expected exit 2 (bad input), got {code}"
    return Outcome(case, code, err, not why, why, dt)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-k", default="", help="only cases whose id contains this text")
    ap.add_argument("--list", action="store_true", help="list the case ids and stop")
    ap.add_argument("-v", "--verbose", action="store_true", help="one line per case")
    ap.add_argument("--json", type=Path, help="also write the outcomes to this file")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="pdw-bad-inputs-") as tmp:
        base = Path(tmp)
        files = make_files(base)
        cases = [c for c in make_cases(files) if args.k in c.id]
        ids = [c.id for c in cases]
        assert len(ids) == len(set(ids)), "duplicate case ids"
        if args.list:
            print("\n".join(ids))
            print(f"{len(ids)} cases")
            return 0
        outcomes = []
        for i, case in enumerate(cases):
            o = run_case(case, base, i, sys.executable)
            outcomes.append(o)
            if args.verbose or not o.clean:
                last = o.stderr.strip().splitlines()[-1:] if o.stderr.strip() else [""]
                print(f"{'ok ' if o.clean else 'BAD'} {case.id:55s} exit {o.code} "
                      f"{o.seconds:5.1f} s  {o.why}  | {last[0][:150]}", flush=True)
        n = sum(o.clean for o in outcomes)
        per = {}
        for o in outcomes:
            a, b = per.get(o.case.command, (0, 0))
            per[o.case.command] = (a + o.clean, b + 1)
        print("  ".join(f"{k}: {a}/{b}" for k, (a, b) in per.items()))
        print(f"{n} of {len(outcomes)} handled cleanly")
        if args.json:
            args.json.write_text(json.dumps([{"id": o.case.id, "exit": o.code,
                                              "clean": o.clean, "why": o.why,
                                              "stderr": o.stderr, "seconds": o.seconds}
                                             for o in outcomes], indent=1))
        return 0 if n == len(outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
