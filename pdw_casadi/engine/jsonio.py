"""JSON output of the toolkit's summaries: numpy scalars and arrays, tuples, paths and
non-finite floats (written as ``null``) handled, strict JSON out."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np


def jsonable(obj):
    """``obj`` with numpy types, tuples, paths and non-finite floats made JSON-safe."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.bool_ | bool):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating | float):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "to_dict"):
        return jsonable(obj.to_dict())
    return obj


def write_json(path: Path | str, data) -> Path:
    """Write ``data`` as indented JSON (strict: NaN and inf become null)."""
    path = Path(path)
    path.write_text(json.dumps(jsonable(data), indent=2, allow_nan=False) + "\n")
    return path
