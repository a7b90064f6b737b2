"""Build one curve file per subject from the per-side WBDS excerpts in ``data/raw``.

Same method as the bundled ``female_fast.csv`` (data/README.md): per subject, hip, knee and
pelvis are the means of the right and left curves (each normalised to its own heel strikes),
thigh = mean(right hip - right pelvis, left hip - left pelvis). The SD columns are the
between-side SD of that one subject (sample SD, n - 1 = 1), so the files keep the schema.

    python scripts/make_subject_curves.py        # writes data/subjects/WBDSxx_fast.csv
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]


def subject_curves(raw: Path) -> pd.DataFrame:
    """The curve table of one subject's excerpt (deg)."""
    t = pd.read_csv(raw, sep="\t")
    sides = {"hip": ("RHipAngleZ", "LHipAngleZ"), "knee": ("RKneeAngleZ", "LKneeAngleZ"),
             "pelvis": ("RPelvisAngleZ", "LPelvisAngleZ")}
    out = {"cycle_pct": t["Time"].to_numpy(float)}
    per_side = {k: np.column_stack([t[c].to_numpy(float) for c in cols])
                for k, cols in sides.items()}
    per_side["thigh"] = per_side["hip"] - per_side["pelvis"]
    for name in ("hip", "knee", "pelvis", "thigh"):
        v = per_side[name]
        out[f"{name}_mean_deg"] = v.mean(axis=1)
        out[f"{name}_sd_deg"] = v.std(axis=1, ddof=1)
    return pd.DataFrame(out).round(4)


def main() -> int:
    dest = ROOT / "data" / "subjects"
    dest.mkdir(exist_ok=True)
    for raw in sorted((ROOT / "data" / "raw").glob("WBDS*walkOFang_sagittal.tsv")):
        name = raw.name[:6] + "_fast.csv"
        subject_curves(raw).to_csv(dest / name, index=False)
        print(f"wrote data/subjects/{name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
