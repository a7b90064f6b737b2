"""Write the gait atlas's deformed targets: the bundled cohort mean ``female_fast.csv`` with
each of the corpus's six one-SD deformations (knee range +-1 SD, hip offset +-1 SD, timing
+-1 SD; the SDs of ``data/corpus/spread.json``, see ``data/corpus/README.md``), so that the
atlas spans the variety of human curves around the mean, not only the mean itself. No
subject's own curves enter the atlas: the corpus stays the files the atlas is judged on.

    python scripts/make_atlas_targets.py      # rewrites data/atlas/targets/*.csv
    pdw-atlas --radius 0.91 --curves data/female_fast.csv data/atlas/targets/*.csv
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd
from make_corpus import deformations  # scripts/: the corpus's own deformations

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    sd = json.loads((ROOT / "data" / "corpus" / "spread.json").read_text())
    mean = pd.read_csv(ROOT / "data" / "female_fast.csv")
    dest = ROOT / "data" / "atlas" / "targets"
    dest.mkdir(parents=True, exist_ok=True)
    for tag, frame in deformations(mean, sd).items():
        path = dest / f"female_fast_{tag}.csv"
        frame.to_csv(path, index=False, float_format="%.4f")
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
