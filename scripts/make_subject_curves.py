"""Build one curve file per subject from the per-side WBDS excerpts in ``data/raw``.

Same method as the bundled ``female_fast.csv`` (data/README.md): per subject, hip, knee and
pelvis are the means of the right and left curves (each normalised to its own heel strikes),
thigh = mean(right hip - right pelvis, left hip - left pelvis). The SD columns are the
between-side SD of that one subject (sample SD, n - 1 = 1), so the files keep the schema.

``--sides`` writes the per-side files instead (pdw_casadi.model.gait_data, "per-side files"): per
side its own hip, knee and pelvis curve and thigh = hip - pelvis of that side, each over
that side's gait cycle; no SD columns (one curve per side and subject: the excerpts give no
stride-to-stride spread).

    python scripts/make_subject_curves.py          # writes data/subjects/WBDSxx_fast.csv
    python scripts/make_subject_curves.py --sides  # writes data/subjects/WBDSxx_fast_sides.csv
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]


SIGNALS = {"hip": ("RHipAngleZ", "LHipAngleZ"), "knee": ("RKneeAngleZ", "LKneeAngleZ"),
           "pelvis": ("RPelvisAngleZ", "LPelvisAngleZ")}
"""Curve -> (right, left) signal of the WBDS excerpt (sagittal component)."""


def _per_side(t: pd.DataFrame) -> dict:
    """Curve -> (n, 2) array, columns right and left (deg); thigh = hip - pelvis per side."""
    per_side = {k: np.column_stack([t[c].to_numpy(float) for c in cols])
                for k, cols in SIGNALS.items()}
    per_side["thigh"] = per_side["hip"] - per_side["pelvis"]
    return per_side


def subject_curves(raw: Path) -> pd.DataFrame:
    """The curve table of one subject's excerpt (deg)."""
    t = pd.read_csv(raw, sep="\t")
    out = {"cycle_pct": t["Time"].to_numpy(float)}
    per_side = _per_side(t)
    for name in ("hip", "knee", "pelvis", "thigh"):
        v = per_side[name]
        out[f"{name}_mean_deg"] = v.mean(axis=1)
        out[f"{name}_sd_deg"] = v.std(axis=1, ddof=1)
    return pd.DataFrame(out).round(4)


def subject_side_curves(raw: Path) -> pd.DataFrame:
    """The per-side curve table of one subject's excerpt (deg): ``<curve>_<side>_mean_deg``."""
    t = pd.read_csv(raw, sep="\t")
    out = {"cycle_pct": t["Time"].to_numpy(float)}
    per_side = _per_side(t)
    for name in ("hip", "knee", "pelvis", "thigh"):
        for j, side in ((1, "left"), (0, "right")):
            out[f"{name}_{side}_mean_deg"] = per_side[name][:, j]
    return pd.DataFrame(out).round(4)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sides", action="store_true",
                        help="write the per-side files WBDSxx_fast_sides.csv")
    args = parser.parse_args(argv)
    dest = ROOT / "data" / "subjects"
    dest.mkdir(exist_ok=True)
    for raw in sorted((ROOT / "data" / "raw").glob("WBDS*walkOFang_sagittal.tsv")):
        if args.sides:
            name = raw.name[:6] + "_fast_sides.csv"
            subject_side_curves(raw).to_csv(dest / name, index=False)
        else:
            name = raw.name[:6] + "_fast.csv"
            subject_curves(raw).to_csv(dest / name, index=False)
        print(f"wrote data/subjects/{name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
