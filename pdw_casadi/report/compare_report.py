"""The report of ``pdw-compare``: ``study.csv``, ``study.md`` and the table it prints.

The comparison is :func:`pdw_casadi.studies.compare_run.run_compare`; this module renders
its rows (:func:`~pdw_casadi.studies.compare_run.compare_row`: column names with their
units). Nothing here solves.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

#: the table's column that ``study.csv`` keeps and ``study.md`` and the printed table leave out
COMPLIANCE = "compliance"


def compare_table(rows: list[dict]) -> pd.DataFrame:
    """The rows as a table, one per fit."""
    return pd.DataFrame(rows)


def markdown_table(frame: pd.DataFrame) -> str:
    """``frame`` as a Markdown table (floats with three decimals)."""
    def cell(v):
        return f"{v:.3f}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(frame.columns) + " |", "|---" * len(frame.columns) + "|"]
    lines += ["| " + " | ".join(cell(v) for v in r) + " |" for r in frame.itertuples(index=False)]
    return "\n".join(lines) + "\n"


def _shown(table: pd.DataFrame) -> pd.DataFrame:
    return table[[c for c in table.columns if c != COMPLIANCE]]


def write_compare_report(table: pd.DataFrame, out: Path) -> tuple[Path, Path]:
    """Write ``study.csv`` (every column) and ``study.md`` (without the compliance) into
    ``out``; returns their paths."""
    out = Path(out)
    csv, md = out / "study.csv", out / "study.md"
    table.to_csv(csv, index=False)
    md.write_text(markdown_table(_shown(table)))
    return csv, md


def compare_text(table: pd.DataFrame) -> str:
    """The table as the command prints it (without the compliance)."""
    return _shown(table).to_string(index=False)
