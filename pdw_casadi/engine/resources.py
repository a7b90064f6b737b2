"""Locate files bundled with the package (problem files, human gait curves).

In a wheel they live inside the package (``pdw_casadi/problems``, ``pdw_casadi/data``); in an
editable install or a source checkout they are the top-level ``problems/`` and ``data/``.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parents[1]  # pdw_casadi/


def bundled_dir(kind: str) -> Path:
    """Directory of bundled files of one kind: ``"problems"`` or ``"data"``."""
    if kind not in ("problems", "data"):
        raise ValueError(f"unknown bundled kind {kind!r}")
    inside = Path(str(resources.files("pdw_casadi"))) / kind
    if inside.is_dir():
        return inside
    return _PACKAGE_DIR.parent / kind


def bundled_names(kind: str, suffix: str) -> list[str]:
    """Names (without suffix) of the bundled files of one kind."""
    return sorted(p.name[: -len(suffix)] for p in bundled_dir(kind).glob(f"*{suffix}"))


def resolve(name_or_path: str | Path, kind: str, suffix: str) -> Path:
    """A path as given if it exists or contains a directory part, else a bundled file.

    ``"female_fast.csv"`` and ``"female_fast"`` both resolve to the bundled curve file;
    ``"./my.csv"`` or an existing path is returned unchanged.
    """
    p = Path(name_or_path)
    if p.exists() or len(p.parts) > 1:
        return p
    name = p.name if p.name.endswith(suffix) else p.name + suffix
    return bundled_dir(kind) / name
