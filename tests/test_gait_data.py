"""Human gait-curve files: the bundled WBDS curves load by bare name, and each kind of bad
file is rejected with a GaitDataError that says what is wrong."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdw_casadi.cli.contract import user_errors as _errors
from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.model.gait_data import GaitDataError, bundled_gait_files, load_gait_curves


@pytest.fixture(scope="module")
def bundled_frame() -> pd.DataFrame:
    return pd.read_csv(bundled_dir("data") / "female_fast.csv")


def _write(frame: pd.DataFrame, tmp_path, name="curves.csv"):
    path = tmp_path / name
    frame.to_csv(path, index=False)
    return path


def test_bundled_file_loads_by_bare_name():
    assert "female_fast.csv" in bundled_gait_files()
    for name in ("female_fast.csv", "female_fast"):
        curves = load_gait_curves(name)
        assert curves.name == "female_fast"
        assert len(curves) == 101
        pct = curves.cycle_pct
        assert pct[0] == 0.0 and pct[-1] == 100.0 and np.all(np.diff(pct) > 0)
        # a human fast-walking knee: nearly straight at heel strike, ~60+ deg in swing
        assert curves.knee_deg[0] < 10.0 and 55.0 < curves.knee_deg.max() < 75.0
        # thigh = hip - pelvic tilt (deg), as documented
        assert np.allclose(curves.thigh_deg, curves.hip_deg - curves.pelvis_deg, atol=3.0)


def test_resample_reproduces_the_grid():
    curves = load_gait_curves("female_fast")
    same = curves.resample(101)
    assert np.allclose(same.knee_deg, curves.knee_deg, atol=1e-12)
    assert len(curves.resample(51)) == 51


def _missing_column(f):
    return f.drop(columns=["knee_mean_deg"])


def _nan(f):
    f.loc[17, "hip_mean_deg"] = np.nan
    return f


def _inf(f):
    f.loc[3, "knee_mean_deg"] = np.inf
    return f


def _non_numeric(f):
    f["knee_mean_deg"] = f["knee_mean_deg"].astype(object)
    f.loc[5, "knee_mean_deg"] = "abc"
    return f


def _out_of_order(f):
    f.loc[[10, 11], "cycle_pct"] = f.loc[[11, 10], "cycle_pct"].to_numpy()
    return f


def _duplicate(f):
    f.loc[20, "cycle_pct"] = f.loc[19, "cycle_pct"]
    return f


def _fraction(f):
    f["cycle_pct"] = f["cycle_pct"] / 100.0
    return f


def _shifted(f):
    f["cycle_pct"] = f["cycle_pct"] + 1.0
    return f


def _too_few_rows(f):
    return f.iloc[np.linspace(0, 100, 10).round().astype(int)]


def _radians(f):
    for c in ("knee_mean_deg", "hip_mean_deg", "thigh_mean_deg"):
        f[c] = np.radians(f[c])
    return f


def _negative_sd(f):
    f.loc[8, "knee_sd_deg"] = -1.0
    return f


BAD = {
    "missing column": (_missing_column, "missing required column"),
    "nan": (_nan, "missing value"),
    "inf": (_inf, "non-finite"),
    "non-numeric": (_non_numeric, "non-numeric"),
    "out of order": (_out_of_order, "not increasing"),
    "duplicate": (_duplicate, "duplicate value"),
    "fraction of the cycle": (_fraction, "must end at 100"),
    "not starting at 0": (_shifted, "must start at 0"),
    "too few rows": (_too_few_rows, "at least 11"),
    "radians": (_radians, "looks like radians"),
    "negative sd": (_negative_sd, "negative"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_gait_files_are_rejected(case, bundled_frame, tmp_path):
    edit, message = BAD[case]
    path = _write(edit(bundled_frame.copy()), tmp_path)
    with pytest.raises(GaitDataError, match=message) as info:
        load_gait_curves(path)
    assert str(path) in str(info.value)


def test_missing_and_empty_files(tmp_path):
    with pytest.raises(GaitDataError, match="not found"):
        load_gait_curves("no_such_curves")
    with pytest.raises(GaitDataError, match="not found"):
        load_gait_curves(tmp_path / "nope.csv")
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(GaitDataError, match="empty"):
        load_gait_curves(empty)


def test_gait_errors_become_a_one_line_cli_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as info, _errors():
        load_gait_curves(tmp_path / "nope.csv")
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


# -- per-side files --------------------------------------------------------------------------
SIDES_FILE = bundled_dir("data") / "subjects" / "WBDS09_fast_sides.csv"


@pytest.fixture(scope="module")
def sides_frame() -> pd.DataFrame:
    return pd.read_csv(SIDES_FILE)


def test_per_side_file_loads_each_side_and_its_mean():
    """The per-side subject file: each side its own curves (the file's columns), and the
    mean of both sides is the subject's one-curve file (data/subjects/WBDS09_fast.csv, made
    from the same excerpt) to its 4-decimal rounding."""
    from pdw_casadi.model.gait_data import SideCurves, load_gait_file, load_side_curves

    sides = load_gait_file(SIDES_FILE)
    assert isinstance(sides, SideCurves) and sides.name == "WBDS09_fast_sides"
    raw = pd.read_csv(SIDES_FILE)
    for side in ("left", "right"):
        c = sides.side(side)
        assert np.array_equal(c.knee_deg, raw[f"knee_{side}_mean_deg"].to_numpy())
        assert np.array_equal(c.thigh_deg, raw[f"thigh_{side}_mean_deg"].to_numpy())
    assert np.abs(sides.left.knee_deg - sides.right.knee_deg).max() > 1.0  # sides differ
    mean = pd.read_csv(bundled_dir("data") / "subjects" / "WBDS09_fast.csv")
    m = sides.mean()
    for joint in ("knee", "hip", "thigh", "pelvis"):
        assert np.abs(getattr(m, f"{joint}_deg") - mean[f"{joint}_mean_deg"]).max() < 1e-4
    assert load_side_curves(SIDES_FILE).left.name == "WBDS09_fast_sides:left"
    assert not isinstance(load_gait_file("female_fast"), SideCurves)


def _side_nan(f):
    f.loc[12, "knee_left_mean_deg"] = np.nan
    return f


def _side_radians(f):
    f["hip_right_mean_deg"] = np.radians(f["hip_right_mean_deg"])
    return f


def _side_negative_sd(f):
    f["knee_right_sd_deg"] = 1.0
    f["knee_left_sd_deg"] = 1.0
    f.loc[4, "knee_right_sd_deg"] = -0.5
    return f


def _side_mixed(f):
    f["knee_mean_deg"] = f["knee_left_mean_deg"]
    return f


def _side_one_sided(f):
    return f.drop(columns=["thigh_right_mean_deg"])


def _side_no_knee_right(f):
    return f.drop(columns=["knee_right_mean_deg", "knee_left_mean_deg"]).assign(
        knee_left_mean_deg=f["knee_left_mean_deg"])


def _side_no_cycle(f):
    return f.drop(columns=["cycle_pct"])


def _side_out_of_order(f):
    f.loc[[10, 11], "cycle_pct"] = f.loc[[11, 10], "cycle_pct"].to_numpy()
    return f


#: bad per-side files and the words the error must contain (it names the per-side column)
BAD_SIDES = {
    "nan": (_side_nan, "'knee_left_mean_deg' has a missing value"),
    "radians": (_side_radians, "'hip_right_mean_deg' looks like radians"),
    "negative sd": (_side_negative_sd, "'knee_right_sd_deg' is a standard deviation"),
    "mixed schema": (_side_mixed, "mixes one-curve columns ['knee_mean_deg']"),
    "one-sided column": (_side_one_sided, "'thigh_left_mean_deg' has no right counterpart"),
    "knee of one side only": (_side_no_knee_right, "'knee_left_mean_deg' has no right"),
    "no cycle_pct": (_side_no_cycle, "missing required column(s) ['cycle_pct']"),
    "out of order": (_side_out_of_order, "not increasing"),
}


@pytest.mark.parametrize("case", sorted(BAD_SIDES))
def test_bad_per_side_files_are_rejected(case, sides_frame, tmp_path):
    from pdw_casadi.model.gait_data import load_gait_file

    edit, message = BAD_SIDES[case]
    path = _write(edit(sides_frame.copy()), tmp_path)
    with pytest.raises(GaitDataError) as info:
        load_gait_file(path)
    assert message in str(info.value) and str(path) in str(info.value)


def test_per_side_loader_refuses_other_files(tmp_path):
    """load_side_curves: a one-curve file alone is not per-side; two files must each be a
    one-curve file (one per side)."""
    from pdw_casadi.model.gait_data import load_side_curves

    with pytest.raises(GaitDataError, match="no per-side columns"):
        load_side_curves("female_fast")
    with pytest.raises(GaitDataError, match="this is a per-side file"):
        load_side_curves("female_fast", SIDES_FILE)
    two = load_side_curves("female_fast", bundled_dir("data") / "subjects" / "WBDS10_fast.csv")
    assert two.left.name == "female_fast" and two.right.name == "WBDS10_fast"


@pytest.mark.parametrize("case", ["mixed schema", "one-sided column", "nan"])
def test_pdw_fit_rejects_bad_per_side_files_and_writes_nothing(case, sides_frame, tmp_path,
                                                               capsys):
    from pdw_casadi.cli import fit_main

    edit, message = BAD_SIDES[case]
    bad = _write(edit(sides_frame.copy()), tmp_path, "bad_sides.csv")
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        fit_main(["--gait", str(bad), "--out", str(out)])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize("argv, message", [
    (["--gait", "female_fast.csv", "--side", "right"], "--side needs per-side curves"),
    (["--gait", str(SIDES_FILE), "--timing"], "--timing is a one-step fit's target"),
    (["--gait", str(SIDES_FILE), "--multistart", "2"], "one-step fit options"),
])
def test_pdw_fit_per_side_option_errors(argv, message, tmp_path, capsys):
    from pdw_casadi.cli import fit_main

    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        fit_main([*argv, "--out", str(out)])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err
    assert not out.exists()


def test_two_standard_files_are_the_per_side_file(tmp_path, sides_frame):
    """--gait L.csv --gait-right R.csv: each side's standard one-curve file (the per-side
    file's columns renamed) gives the same curves as the per-side file, sample for sample."""
    from pdw_casadi.model.gait_data import load_side_curves

    both = load_side_curves(SIDES_FILE)
    files = {}
    for side in ("left", "right"):
        cols = {c: c.replace(f"_{side}_", "_") for c in sides_frame.columns
                if f"_{side}_" in c}
        frame = sides_frame[["cycle_pct", *cols]].rename(columns=cols)
        files[side] = tmp_path / f"{side}.csv"
        frame.to_csv(files[side], index=False)
    two = load_side_curves(files["left"], files["right"])
    for side in ("left", "right"):
        a, b = both.side(side), two.side(side)
        for joint in ("knee", "hip", "thigh"):
            assert np.array_equal(getattr(a, f"{joint}_deg"), getattr(b, f"{joint}_deg"))
    assert np.abs(two.left.knee_deg - two.right.knee_deg).max() > 1.0
