"""Build the fit's robustness corpus (``data/corpus``) from the bundled WBDS data only.

Per subject of ``data/raw`` (four young women, overground, fast; data/README.md):

- ``<S>_mean.csv``: the subject's curves, mean of both sides (= ``data/subjects/<S>_fast.csv``);
- ``<S>_left.csv``, ``<S>_right.csv``: each side alone, as a one-curve file (no SD columns);
- six deformations of the subject's mean, each by one between-subject SD measured on the
  four subjects themselves (printed, and written to ``data/corpus/spread.json``):
  ``<S>_knee+.csv`` / ``<S>_knee-.csv`` the knee scaled about its cycle mean so that its
  range grows / shrinks by one SD of the subjects' knee ranges;
  ``<S>_hip+.csv`` / ``<S>_hip-.csv`` the hip and the pelvis offset by one SD of the
  subjects' cycle-mean hip angles (subjects differ in the hip mostly by pelvic tilt: the
  thigh column is kept);
  ``<S>_late.csv`` / ``<S>_early.csv`` every curve shifted later / earlier in the cycle by one
  SD of the subjects' timing (of four landmarks: the knee's loading and swing peaks, the
  hip's peak extension and late-swing maximum);
- ``<S>_sides.csv``: the per-side file (= ``data/subjects/<S>_fast_sides.csv``), for the
  per-leg fit.

    python scripts/make_corpus.py            # writes data/corpus/*.csv and spread.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_subject_curves import subject_curves, subject_side_curves  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CURVES = ("hip", "knee", "pelvis", "thigh")


def shift_periodic(c: pd.DataFrame, delta_pct: float) -> pd.DataFrame:
    """Every column of ``c`` delayed by ``delta_pct`` % of the cycle (periodic linear
    interpolation on the 0..100 % grid: new(t) = old(t - delta))."""
    t = c["cycle_pct"].to_numpy(float)
    out = {"cycle_pct": t}
    base = t[:-1]  # 0..99: the 100 % sample repeats 0 % of a periodic curve
    for col in c.columns:
        if col == "cycle_pct":
            continue
        v = c[col].to_numpy(float)[:-1]
        out[col] = np.interp((t - delta_pct) % 100.0, base, v, period=100.0)
    return pd.DataFrame(out)


def landmarks(c: pd.DataFrame) -> list[float]:
    """Times (% of the cycle) of four landmarks of one subject's curves: the knee's
    loading-response peak (0-30 %) and swing peak, the hip's peak extension and its late-swing
    maximum (50-100 %)."""
    t = c["cycle_pct"].to_numpy(float)
    k, h = c["knee_mean_deg"].to_numpy(float), c["hip_mean_deg"].to_numpy(float)
    early, late = t <= 30, t >= 50
    return [float(t[early][np.argmax(k[early])]), float(t[np.argmax(k)]),
            float(t[np.argmin(h)]), float(t[late][np.argmax(h[late])])]


def spread(means: dict[str, pd.DataFrame]) -> dict:
    """Between-subject SDs (sample, n - 1) of the knee range (deg), the cycle-mean hip
    angle (deg) and the timing (%: root mean square over the four :func:`landmarks` of the
    SD of their times), measured on the subjects' mean curves."""
    knee_range = [float(np.ptp(c["knee_mean_deg"])) for c in means.values()]
    hip_mean = [float(np.mean(c["hip_mean_deg"])) for c in means.values()]
    times = np.array([landmarks(c) for c in means.values()])  # subject x landmark
    timing = float(np.sqrt(np.mean(np.var(times, axis=0, ddof=1))))
    return {"subjects": list(means), "knee_range_deg": knee_range,
            "knee_range_sd_deg": float(np.std(knee_range, ddof=1)),
            "hip_mean_deg": hip_mean, "hip_offset_sd_deg": float(np.std(hip_mean, ddof=1)),
            "landmark_times_pct": times.tolist(), "timing_sd_pct": timing}


def deformations(c: pd.DataFrame, sd: dict) -> dict[str, pd.DataFrame]:
    """The six one-SD deformations of one subject's mean curves (see the module docstring)."""
    out = {}
    k = c["knee_mean_deg"].to_numpy(float)
    rng = float(np.ptp(k))
    for sign, tag in ((1, "knee+"), (-1, "knee-")):
        f = (rng + sign * sd["knee_range_sd_deg"]) / rng
        d = c.copy()
        d["knee_mean_deg"] = k.mean() + f * (k - k.mean())
        if "knee_sd_deg" in d:
            d["knee_sd_deg"] = f * d["knee_sd_deg"]
        out[tag] = d
    for sign, tag in ((1, "hip+"), (-1, "hip-")):
        d = c.copy()
        d["hip_mean_deg"] = d["hip_mean_deg"] + sign * sd["hip_offset_sd_deg"]
        d["pelvis_mean_deg"] = d["pelvis_mean_deg"] + sign * sd["hip_offset_sd_deg"]
        out[tag] = d
    for sign, tag in ((1, "late"), (-1, "early")):
        out[tag] = shift_periodic(c, sign * sd["timing_sd_pct"])
    return out


def one_side(sides: pd.DataFrame, side: str) -> pd.DataFrame:
    """One side of a per-side table as a one-curve table (``<curve>_mean_deg``)."""
    out = {"cycle_pct": sides["cycle_pct"]}
    for name in CURVES:
        out[f"{name}_mean_deg"] = sides[f"{name}_{side}_mean_deg"]
    return pd.DataFrame(out)


def build(dest: Path) -> list[Path]:
    """Write the corpus into ``dest``; the written files, in order."""
    dest.mkdir(parents=True, exist_ok=True)
    raws = sorted((ROOT / "data" / "raw").glob("WBDS*walkOFang_sagittal.tsv"))
    means = {r.name[:6]: subject_curves(r) for r in raws}
    sd = spread(means)
    (dest / "spread.json").write_text(json.dumps(sd, indent=1) + "\n")
    written = []

    def write(frame: pd.DataFrame, name: str):
        p = dest / name
        frame.round(4).to_csv(p, index=False)
        written.append(p)

    for raw in raws:
        s = raw.name[:6]
        write(means[s], f"{s}_mean.csv")
        sides = subject_side_curves(raw)
        for side in ("left", "right"):
            write(one_side(sides, side), f"{s}_{side}.csv")
        for tag, frame in deformations(means[s], sd).items():
            write(frame, f"{s}_{tag}.csv")
        write(sides, f"{s}_sides.csv")
    return written


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "data" / "corpus")
    args = ap.parse_args(argv)
    files = build(args.out)
    sd = json.loads((args.out / "spread.json").read_text())
    print(f"between-subject SDs: knee range {sd['knee_range_sd_deg']:.2f} deg, hip offset "
          f"{sd['hip_offset_sd_deg']:.2f} deg, timing {sd['timing_sd_pct']:.2f} %")
    print(f"wrote {len(files)} curve files to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
