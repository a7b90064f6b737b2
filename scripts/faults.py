"""Run a corpus of faults through every command and check that each is handled cleanly.

Faults a user meets beside bad input (that is ``scripts/bad_inputs.py``): Ctrl-C and
SIGTERM at each stage of each command, a full disk (a file-size limit,
``resource.RLIMIT_FSIZE``), a damaged or unusable compile cache, two runs into one output,
and degenerate or malformed inputs. Every case runs the command as a process of its own
(``python -m pdw_casadi.cli COMMAND ...``) in a scratch directory whose output folder holds
the files "of an earlier run". A case is *handled cleanly* when it ends as the contract says:

- a signal: exit code 130 (SIGINT) or 143 (SIGTERM) within ``--within`` seconds (default
  5), the last stderr line ``interrupted: ...``, no traceback, the earlier run's files
  unchanged and no partial file of this run left behind (except ``sweep.partial.csv``);
- a file-size limit: exit code 1 with ``error: could not write FILE: ...`` naming a file of
  the output, the earlier run's files unchanged, no partial file left;
- a damaged cache: the command succeeds (exit 0) with one warning line per damaged library,
  and the next run loads the healed cache without a warning; an unusable cache path: exit 0
  with one warning;
- two runs into one output: each ends with exit 0, or exit 2 refused (``another run``), and
  the output holds one whole result;
- degenerate input: exit 2 with one ``error:`` line and the output unchanged (or the
  expected result: a title with quotes written as valid TOML).

    python scripts/faults.py              # all cases: prints "N of M handled cleanly"
    python scripts/faults.py -k signal    # cases whose id contains "signal"
    python scripts/faults.py --list       # the case ids

Exit code 0 when every case is clean, else 1. The compile cache used is a copy made from
``$PDW_CACHE`` (never damaged in place).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EARLIER = {"summary.json": '{"earlier": true}\n', "trajectory.csv": "t,q\n0,1\n",
           "sweep.csv": "slope\n0.05\n", "curves.csv": "x\n1\n", "ipopt.log": "earlier log\n",
           "events.json": "{}\n", "table.md": "earlier\n"}
#: files a run may leave beside the earlier ones (an interrupted sweep's rows)
ALLOWED_NEW = {"sweep.partial.csv"}


@dataclass
class Case:
    id: str
    command: str
    args: list[str]
    kind: str  # signal | fsize | cache | unusable | concurrent | degenerate | toml
    signum: int | None = None
    trigger: str | float | None = None  # a text on stderr/stdout, or seconds after start
    fsize: int | None = None
    damage: str | None = None
    timeout: float = 600.0
    out: str = "dir"  # "dir": --out DIR (prepared), "file": --out FILE (prepared), "none"
    check: Callable | None = None  # extra check(out_path, proc) -> reason or ""
    env: dict = field(default_factory=dict)


@dataclass
class Outcome:
    case: Case
    code: int | None
    stderr: str
    why: str
    seconds: float

    @property
    def clean(self) -> bool:
        return not self.why


# -- helpers ---------------------------------------------------------------------------------
def snapshot(path: Path) -> dict[str, str]:
    """Name -> SHA-256 of every file under ``path`` (a file: itself)."""
    if path.is_file():
        return {path.name: hashlib.sha256(path.read_bytes()).hexdigest()}
    if not path.exists():
        return {}
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(path.rglob("*")) if p.is_file()}


def leftovers(folder: Path) -> list[str]:
    """Partial files or folders of a run left in ``folder``."""
    if not folder.is_dir():
        return []
    return [p.name for p in folder.iterdir() if p.name not in ALLOWED_NEW and (
            p.name.startswith(".pdw-partial-") or ".partial" in p.suffixes
            or p.name.startswith(".pdw-write-test-"))]


def prepare(case: Case, work: Path) -> Path | None:
    """The case's output (with an earlier run's files), or None."""
    if case.out == "dir":
        out = work / "out"
        out.mkdir()
        for name, text in EARLIER.items():
            (out / name).write_text(text)
        return out
    if case.out == "file":
        out = work / "out" / ("p.json" if case.command == "atlas" else "p.toml")
        out.parent.mkdir()
        out.write_text('# earlier\n[walker]\nfamily = "compass_gait"\n')
        return out
    return None


class Proc:
    """A command process whose stdout and stderr lines are collected as they come."""

    def __init__(self, argv: list[str], env: dict, cwd: Path, fsize: int | None = None):
        def limit():
            if fsize is not None:
                resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))

        self.p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True, env=env, cwd=cwd, preexec_fn=limit)
        self.out: list[str] = []
        self.err: list[str] = []
        self.seen = threading.Event()
        self.marker: str | None = None
        self.threads = [threading.Thread(target=self._read, args=(s, b), daemon=True)
                        for s, b in ((self.p.stdout, self.out), (self.p.stderr, self.err))]
        for t in self.threads:
            t.start()

    def _read(self, stream, buf):
        for line in stream:
            buf.append(line)
            if self.marker and self.marker in line:
                self.seen.set()

    def wait(self, timeout: float) -> int | None:
        try:
            code = self.p.wait(timeout)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()
            return None
        for t in self.threads:
            t.join(5)
        return code

    @property
    def stderr(self) -> str:
        return "".join(self.err)


def command_argv(case: Case, out: Path | None) -> list[str]:
    argv = [sys.executable, "-m", "pdw_casadi.cli", case.command, *case.args]
    if out is not None:
        argv += ["--out", str(out)]
    return argv


def base_env(cache: Path) -> dict:
    env = {**os.environ, "PDW_CACHE": str(cache), "PYTHONUNBUFFERED": "1",
           "MPLBACKEND": "Agg"}
    env.pop("PDW_DEBUG", None)
    return env


def lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.strip()
            and not ln.lstrip().startswith(("pdw-simulate:", "pdw-sweep:"))  # progress bars
            and "\r" not in ln]


def common_faults(stderr: str) -> str:
    if "Traceback" in stderr:
        return "traceback"
    if "internal error" in stderr:
        return "internal error"
    return ""


def output_whole(out: Path | None, before: dict) -> str:
    if out is None:
        return ""
    after = snapshot(out)
    changed = [k for k in before if after.get(k) != before[k]]
    new = [k for k in after if k not in before and k not in ALLOWED_NEW]
    left = leftovers(out if out.is_dir() else out.parent)
    if changed:
        return f"earlier files changed: {changed}"
    if new:
        return f"new files beside the earlier ones: {new}"
    if left:
        return f"partial files left: {left}"
    return ""


# -- running a case ----------------------------------------------------------------------------
def run_case(case: Case, base: Path, i: int, cache: Path, within: float) -> Outcome:
    work = base / f"case{i:03d}"
    work.mkdir()
    out = prepare(case, work)
    before = snapshot(out) if out is not None else {}
    env = {**base_env(cache), **case.env}
    t0 = time.perf_counter()
    if case.kind == "concurrent":
        return _concurrent(case, work, out, env, t0)
    if case.kind == "cache":
        return _cache(case, work, out, env, t0)
    proc = Proc(command_argv(case, out), env, work, case.fsize)
    why = ""
    if case.kind == "signal":
        if isinstance(case.trigger, str):
            proc.marker = case.trigger
            if any(case.trigger in ln for ln in proc.err + proc.out):
                proc.seen.set()
            while not proc.seen.wait(0.2):
                if proc.p.poll() is not None or time.perf_counter() - t0 > case.timeout:
                    break
        else:
            time.sleep(float(case.trigger))
        if proc.p.poll() is not None:
            code = proc.wait(10)
            return Outcome(case, code, proc.stderr, f"ended (exit {code}) before the signal",
                           time.perf_counter() - t0)
        ts = time.perf_counter()
        proc.p.send_signal(case.signum)
        code = proc.wait(max(within, 1.0) * 6)
        took = time.perf_counter() - ts
        want = 130 if case.signum == signal.SIGINT else 143
        last = lines(proc.stderr)[-1:] or [""]
        why = (common_faults(proc.stderr)
               or (f"exit {code}, expected {want}" if code != want else "")
               or (f"ended {took:.1f} s after the signal (> {within:g} s)"
                   if took > within else "")
               or ("" if last[0].startswith("interrupted:") else
                   f"last line not 'interrupted:': {last[0][:80]!r}")
               or output_whole(out, before))
        return Outcome(case, code, proc.stderr, why, time.perf_counter() - t0)
    code = proc.wait(case.timeout)
    err = lines(proc.stderr)
    why = common_faults(proc.stderr)
    if not why and case.kind == "fsize":
        if code != 1:
            why = f"exit {code}, expected 1"
        elif not err or not err[-1].startswith("error: could not write "):
            why = f"last line not 'error: could not write': {(err or [''])[-1][:80]!r}"
        elif out is not None and str(out) not in err[-1]:
            why = "the message does not name the output"
        else:
            why = output_whole(out, before)
    elif not why and case.kind == "degenerate":
        if code != 2:
            why = f"exit {code}, expected 2"
        elif len(err) != 1 or not err[0].startswith("error:"):
            why = f"{len(err)} stderr lines, expected one 'error:' line"
        else:
            why = output_whole(out, before)
    elif not why and case.kind == "unusable":
        warn = [ln for ln in err if ln.startswith("warning:")]
        if code != 0:
            why = f"exit {code}, expected 0"
        elif len(warn) != 1:
            why = f"{len(warn)} warning lines, expected 1"
    if not why and case.check is not None:
        why = case.check(out, proc, code)
    return Outcome(case, code, proc.stderr, why, time.perf_counter() - t0)


def _concurrent(case: Case, work: Path, out: Path, env: dict, t0: float) -> Outcome:
    """Two runs of the case at once into one output."""
    procs = [Proc(command_argv(case, out), env, work)]
    time.sleep(float(case.trigger or 0.0))
    procs.append(Proc(command_argv(case, out), env, work))
    codes = [p.wait(case.timeout) for p in procs]
    errs = "".join(p.stderr for p in procs)
    why = common_faults(errs)
    for p, c in zip(procs, codes, strict=True):
        err = lines(p.stderr)
        if c == 2:
            if not (len(err) == 1 and "another run" in err[0]):
                why = why or f"exit 2 but not a refusal: {err[-1:]}"
        elif c != 0:
            why = why or f"exit {c}"
    if 0 not in codes:
        why = why or "neither run completed"
    if not why and case.check is not None:
        why = case.check(out, procs[0], codes[0])
    if not why:
        left = leftovers(out if out.is_dir() else out.parent)
        why = f"partial files left: {left}" if left else ""
    return Outcome(case, codes[0], errs, why, time.perf_counter() - t0)


def _damage(so: Path, how: str, foreign: Path) -> None:
    data = so.read_bytes()
    record = so.with_suffix(".sum")
    if how == "truncated":
        so.write_bytes(data[: len(data) // 2])
    elif how == "truncated-tail":
        so.write_bytes(data[:-64])
    elif how == "empty":
        so.write_bytes(b"")
    elif how == "garbage":
        so.write_bytes(os.urandom(len(data)))
    elif how == "foreign":
        shutil.copyfile(foreign, so)
    elif how == "flipped":  # one byte changed: same size
        b = bytearray(data)
        b[len(b) // 2] ^= 0xFF
        so.write_bytes(bytes(b))
    elif how in ("truncated-norecord", "foreign-norecord", "empty-norecord"):
        _damage(so, how.split("-")[0], foreign)
        record.unlink(missing_ok=True)
        return
    elif how == "record-garbage":
        record.write_text("not a record")
        return
    elif how == "record-missing":  # an older cache without records: probed, kept
        record.unlink(missing_ok=True)
        return


def _cache(case: Case, work: Path, out: Path, env: dict, t0: float) -> Outcome:
    """Build the case's libraries into a fresh cache, damage them, run twice."""
    cache = work / "cache"
    env = {**env, "PDW_CACHE": str(cache)}
    first = Proc(command_argv(case, work / "warm"), env, work)
    if first.wait(case.timeout) != 0:
        return Outcome(case, None, first.stderr, "building the cache failed",
                       time.perf_counter() - t0)
    libs = sorted(cache.glob("*.so"))
    if not libs:
        return Outcome(case, None, "", "no library was cached", time.perf_counter() - t0)
    foreign = work / "foreign.so"
    shutil.copyfile(libs[-1], foreign)
    for so in libs[:-1] if case.damage and case.damage.startswith("foreign") else libs:
        _damage(so, case.damage, foreign if so != libs[-1] else libs[0])
    damaged = len(libs) - (1 if case.damage and case.damage.startswith("foreign") else 0)
    second = Proc(command_argv(case, out), env, work)
    code = second.wait(case.timeout)
    err = lines(second.stderr)
    warn = [ln for ln in err if ln.startswith("warning:")]
    why = common_faults(second.stderr)
    expect_warn = 0 if case.damage == "record-missing" else damaged
    if not why and code != 0:
        why = f"exit {code} with a damaged cache: {err[-1:]}"
    elif not why and len(warn) != expect_warn:
        why = f"{len(warn)} warning lines for {expect_warn} damaged libraries"
    if not why:
        third = Proc(command_argv(case, work / "again"), env, work)
        c3 = third.wait(case.timeout)
        if c3 != 0 or any(ln.startswith("warning:") for ln in lines(third.stderr)):
            why = f"the healed cache is not used cleanly (exit {c3}): {lines(third.stderr)[-1:]}"
    return Outcome(case, code, second.stderr, why, time.perf_counter() - t0)


# -- the corpus ------------------------------------------------------------------------------
def make_files(base: Path) -> dict[str, str]:
    """The degenerate inputs the cases refer to, by key."""
    import numpy as np

    f: dict[str, str] = {}
    pct = np.linspace(0, 100, 51)
    knee = 30 + 30 * np.sin(2 * np.pi * pct / 100)
    hip = 10 + 20 * np.cos(2 * np.pi * pct / 100)

    def csv(key: str, cols: dict) -> None:
        path = base / "files" / f"{key}.csv"
        path.parent.mkdir(parents=True, exist_ok=True)
        names = ["cycle_pct", *cols]
        rows = [",".join(names)] + [",".join(repr(float(v)) for v in vals)
                                    for vals in zip(pct, *cols.values(), strict=True)]
        path.write_text("\n".join(rows) + "\n")
        f[key] = str(path)

    csv("knee_constant", {"knee_mean_deg": np.full_like(pct, 20.0), "hip_mean_deg": hip})
    csv("hip_constant", {"knee_mean_deg": knee, "hip_mean_deg": np.full_like(pct, -5.0)})
    csv("knee_flat", {"knee_mean_deg": 40 + 0.5 * np.sin(pct), "hip_mean_deg": hip})
    csv("knee_huge", {"knee_mean_deg": knee * 1e6, "hip_mean_deg": hip})
    csv("hip_absurd", {"knee_mean_deg": knee, "hip_mean_deg": hip + 1e300})
    csv("sd_huge", {"knee_mean_deg": knee, "hip_mean_deg": hip,
                    "knee_sd_deg": np.full_like(pct, 1e9)})
    csv("side_constant", {"knee_left_mean_deg": knee, "hip_left_mean_deg": hip,
                          "knee_right_mean_deg": np.full_like(pct, 15.0),
                          "hip_right_mean_deg": hip})
    csv("side_huge", {"knee_left_mean_deg": knee, "hip_left_mean_deg": hip * 1e5,
                      "knee_right_mean_deg": knee, "hip_right_mean_deg": hip})
    atlas = base / "files"
    (atlas / "atlas_notjson.json").write_text("{not json")
    (atlas / "atlas_nokeys.json").write_text('{"x": 1}')
    (atlas / "atlas_list.json").write_text("[1, 2]")
    (atlas / "atlas_binary.json").write_bytes(b"\xff\xfe\x00garbage")
    good = ROOT / "data" / "atlas" / "humanlike_6link.json"
    text = good.read_text()
    (atlas / "atlas_other.json").write_text(text.replace('"k_knee"', '"k_other"', 1))
    import json

    data = json.loads(text)
    data["entries"][0]["state"] = data["entries"][0]["state"][:-1]
    (atlas / "atlas_short.json").write_text(json.dumps(data))
    data = json.loads(text)
    data["entries"][0]["parameters"][0] = None
    (atlas / "atlas_null.json").write_text(json.dumps(data))
    for k in ("notjson", "nokeys", "list", "binary", "other", "short", "null"):
        f[f"atlas_{k}"] = str(atlas / f"atlas_{k}.json")
    hl = (ROOT / "problems" / "humanlike_6link.toml").read_text()
    title = next(ln for ln in hl.splitlines() if ln.startswith("title"))
    quoted = hl.replace(title, 'title = "a \\"quoted\\" title with a back\\\\slash"', 1)
    (base / "files" / "quoted.toml").write_text(quoted)
    f["quoted"] = str(base / "files" / "quoted.toml")
    f["file"] = str(base / "files" / "quoted.toml")
    return f


def _sweep_whole(num: int):
    def check(out: Path, proc, code) -> str:
        csv = out / "sweep.csv"
        if not csv.exists():
            return "no sweep.csv"
        rows = len(csv.read_text().splitlines()) - 1
        # a continuation adds located points (the start, bifurcations) to the grid's rows
        return "" if rows >= num else f"sweep.csv holds {rows} of {num} rows"
    return check


def _summary_whole(out: Path, proc, code) -> str:
    import json

    try:
        data = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError) as exc:
        return f"summary.json not whole: {exc}"
    return "" if "earlier" not in data else "summary.json still the earlier one"


def _toml_title(out: Path, proc, code) -> str:
    if code != 0:
        return f"exit {code}: {lines(proc.stderr)[-1:]}"
    try:
        data = tomllib.loads(out.read_text())
    except (OSError, ValueError) as exc:
        return f"not valid TOML: {exc}"
    want = 'a "quoted" title with a back\\slash'
    return "" if data["walker"]["title"] == want else f"title {data['walker']['title']!r}"


def make_cases(f: dict[str, str]) -> list[Case]:
    cg = ["--problem", "compass_gait"]
    fit = ["--gait", "female_fast.csv", "--rounds", "1", "--quiet"]
    INT, TERM = signal.SIGINT, signal.SIGTERM
    cases: list[Case] = []
    # -- signals at each stage of each command -------------------------------------------------
    stages = {
        "simulate": (cg + ["--steps", "400"], [("start", 0.3), ("imports", 1.5),
                                               ("stepping", "pdw-simulate:")]),
        "fixed-point": (["--problem", "humanlike_6link"], [
            ("start", 0.3), ("imports", 1.5), ("solving", "solving for a fixed point")]),
        "sweep": (cg + ["--from", "0.03", "--to", "0.06", "--num", "40"],
                  [("start", 0.3), ("imports", 1.5), ("sweeping", "pdw-sweep:")]),
        "fit": (fit + ["--max-iter", "40"], [("start", 0.3), ("imports", 1.5),
                                             ("loading", 6.0), ("ipopt", "start 0")]),
        "scale": (["--mass", "60", "--height", "1.7"], [("start", 0.3), ("imports", 1.5),
                                                        ("continuation", "scaling")]),
        "design": (["--max-solves", "2"], [("start", 0.3), ("imports", 1.5),
                                           ("solving", 45.0)]),
        "atlas": (["--radius", "0.91", "--curves"], [("start", 0.3), ("imports", 1.5),
                                                     ("fitting", 20.0)]),
    }
    for command, (args, points) in stages.items():
        out = "file" if command in ("scale", "design", "atlas") else "dir"
        for stage, trigger in points:
            for name, signum in (("sigint", INT), ("sigterm", TERM)):
                if name == "sigterm" and stage == "imports":
                    continue  # the same code path as at the start
                cases.append(Case(f"signal-{command}-{stage}-{name}", command, args, "signal",
                                  signum=signum, trigger=trigger, out=out))
    # the per-leg fit inside IPOPT
    cases.append(Case("signal-fit-stride-ipopt-sigint", "fit",
                      ["--gait", str(ROOT / "data" / "subjects" / "WBDS09_fast_sides.csv"),
                       "--rounds", "1", "--quiet",
                       "--max-iter", "40"],
                      "signal", signum=INT, trigger=30.0))
    # -- a full disk: file-size limits ------------------------------------------------------------
    for limit in (0, 1000, 20_000, 200_000, 1_000_000):
        cases.append(Case(f"fsize-simulate-{limit}", "simulate", cg + ["--steps", "20"],
                          "fsize", fsize=limit))
    for limit in (0, 5000):
        cases.append(Case(f"fsize-fixed-point-{limit}", "fixed-point", cg, "fsize",
                          fsize=limit))
        cases.append(Case(f"fsize-sweep-{limit}", "sweep",
                          cg + ["--from", "0.04", "--to", "0.05", "--num", "3"], "fsize",
                          fsize=limit))
    cases.append(Case("fsize-scale-100", "scale", ["--mass", "60", "--height", "1.7",
                                                   "--body", "uniform"], "fsize", fsize=100,
                      out="file"))
    cases.append(Case("fsize-fit-2000", "fit", fit + ["--max-iter", "1"], "fsize",
                      fsize=2000))
    # -- a damaged compile cache ------------------------------------------------------------------
    for how in ("truncated", "truncated-tail", "empty", "garbage", "foreign", "flipped",
                "truncated-norecord", "foreign-norecord", "empty-norecord", "record-garbage",
                "record-missing"):
        cases.append(Case(f"cache-{how}", "simulate", cg + ["--steps", "2"], "cache",
                          damage=how))
    for key, path in (("a-file", f["file"]), ("under-a-file", f["file"] + "/cache"),
                      ("dev-null", "/dev/null/cache")):
        cases.append(Case(f"cache-unusable-{key}", "simulate", cg + ["--steps", "2"],
                          "unusable", env={"PDW_CACHE": path}))
    # -- two runs into one output -----------------------------------------------------------------
    cases.append(Case("concurrent-sweep", "sweep",
                      cg + ["--from", "0.04", "--to", "0.06", "--num", "7"], "concurrent",
                      trigger=0.0, check=_sweep_whole(7)))
    cases.append(Case("concurrent-sweep-staggered", "sweep",
                      cg + ["--from", "0.04", "--to", "0.06", "--num", "7"], "concurrent",
                      trigger=4.0, check=_sweep_whole(7)))
    cases.append(Case("concurrent-simulate", "simulate", cg + ["--steps", "30"],
                      "concurrent", trigger=0.0, check=_summary_whole))
    cases.append(Case("concurrent-fixed-point", "fixed-point", cg, "concurrent",
                      trigger=0.0, check=_summary_whole))
    cases.append(Case("concurrent-scale", "scale", ["--mass", "60", "--height", "1.7",
                                                    "--body", "uniform"], "concurrent",
                      trigger=0.0, out="file", check=lambda o, p, c: "" if tomllib.loads(
                          o.read_text()).get("walker") else "no walker table"))
    # -- degenerate and malformed inputs ----------------------------------------------------------
    for key in ("knee_constant", "hip_constant", "knee_flat", "knee_huge", "hip_absurd",
                "sd_huge"):
        cases.append(Case(f"degenerate-fit-{key}", "fit", ["--gait", f[key]], "degenerate"))
    for key in ("side_constant", "side_huge"):
        cases.append(Case(f"degenerate-fit-{key}", "fit", ["--gait", f[key]], "degenerate"))
    cases.append(Case("degenerate-sweep-knee_constant", "sweep",
                      ["--problem", "humanlike_6link", "--from", "0.14", "--to", "0.15",
                       "--gait", f["knee_constant"]], "degenerate"))
    for key in ("notjson", "nokeys", "list", "binary", "other", "short", "null"):
        cases.append(Case(f"degenerate-fit-atlas-{key}", "fit",
                          ["--gait", "female_fast.csv", "--atlas", f[f"atlas_{key}"]],
                          "degenerate"))
    for command in ("simulate", "fixed-point", "sweep", "fit", "scale", "design", "atlas"):
        extra = {"sweep": ["--from", "0.04", "--to", "0.05"], "fit": ["--gait",
                 "female_fast.csv"], "scale": ["--mass", "60", "--height", "1.7"]}
        cases.append(Case(f"degenerate-{command}-out-empty", command,
                          extra.get(command, []) + ["--out", ""], "degenerate", out="none"))
    for key, args in (("lighter-nan", ["--lighter", "nan"]),
                      ("lighter-negative", ["--lighter", "-0.2"]),
                      ("start-missing", ["--start", "no_such_walker.toml"]),
                      ("max-iter-zero", ["--max-iter", "0"]),
                      ("out-under-a-file", ["--out", f["file"] + "/p.toml"])):
        cases.append(Case(f"degenerate-design-{key}", "design", args, "degenerate",
                          out="none"))
    for key, args in (("radius-nan", ["--radius", "nan"]),
                      ("radius-negative", ["--radius", "-0.5"]),
                      ("curves-missing", ["--curves", "no_such.csv"]),
                      ("curves-constant", ["--curves", f["knee_constant"]]),
                      ("out-under-a-file", ["--out", f["file"] + "/a.json"]),
                      ("compass-gait", ["--problem", "compass_gait"])):
        cases.append(Case(f"degenerate-atlas-{key}", "atlas", args, "degenerate",
                          out="none"))
    cases.append(Case("degenerate-scale-compass-gait", "scale",
                      ["--problem", "compass_gait", "--mass", "60", "--height", "1.7"],
                      "degenerate", out="file"))
    cases.append(Case("toml-scale-quoted-title", "scale",
                      ["--problem", f["quoted"], "--mass", "60", "--height", "1.7",
                       "--body", "uniform"], "toml", out="file", check=_toml_title))
    return cases


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-k", default="", help="only cases whose id contains this text")
    ap.add_argument("--list", action="store_true", help="list the case ids and stop")
    ap.add_argument("-v", "--verbose", action="store_true", help="one line per case")
    ap.add_argument("--show", action="store_true", help="the stderr of unclean cases")
    ap.add_argument("--within", type=float, default=5.0,
                    help="seconds a signalled run may take to end (default: %(default)s)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="pdw-faults-") as tmp:
        base = Path(tmp)
        files = make_files(base)
        cases = [c for c in make_cases(files) if args.k in c.id]
        ids = [c.id for c in cases]
        assert len(ids) == len(set(ids)), "duplicate case ids"
        if args.list:
            print("\n".join(ids))
            print(f"{len(ids)} cases")
            return 0
        # a copy of the compile cache: cases damage theirs, never the shared one
        cache = base / "cache"
        src = Path(os.environ.get("PDW_CACHE", Path.home() / ".cache" / "pdw_casadi"))
        if src.is_dir():
            shutil.copytree(src, cache)
        outcomes = []
        for i, case in enumerate(cases):
            o = run_case(case, base, i, cache, args.within)
            outcomes.append(o)
            if args.verbose or not o.clean:
                last = lines(o.stderr)[-1:] or [""]
                print(f"{'ok ' if o.clean else 'BAD'} {case.id:45s} exit {o.code} "
                      f"{o.seconds:6.1f} s  {o.why}  | {last[0][:120]}", flush=True)
                if args.show and not o.clean:
                    print("    " + o.stderr.strip().replace("\n", "\n    "), flush=True)
        n = sum(o.clean for o in outcomes)
        per: dict[str, tuple[int, int]] = {}
        for o in outcomes:
            a, b = per.get(o.case.kind, (0, 0))
            per[o.case.kind] = (a + o.clean, b + 1)
        print("  ".join(f"{k}: {a}/{b}" for k, (a, b) in per.items()))
        print(f"{n} of {len(outcomes)} handled cleanly")
        return 0 if n == len(outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
