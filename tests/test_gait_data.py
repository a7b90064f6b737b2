"""Human gait-curve files: the bundled WBDS curves load by bare name, and each kind of bad
file is rejected with a GaitDataError that says what is wrong."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdw_casadi.cli import _errors
from pdw_casadi.gait_data import GaitDataError, bundled_gait_files, load_gait_curves
from pdw_casadi.resources import bundled_dir


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
