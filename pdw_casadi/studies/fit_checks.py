"""The checks of a fit's request that the fit and gait layers own, made before any output or
solve: an atlas file that reads as a gait atlas of the walker (:func:`check_atlas_file`) and
a walker whose stride a per-leg fit can build (:func:`check_stride_walker`).

Each raises :class:`~pdw_casadi.engine.errors.UsageError` with a one-line message that names
the flag; a command (``pdw-fit``) calls them while it validates its arguments, the fit
workflow (:mod:`pdw_casadi.studies.fit_run`) runs after them.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pdw_casadi.engine.errors import ProblemError, UsageError, one_line
from pdw_casadi.fit.starts import AtlasEntry
from pdw_casadi.gait.stride import stride_map
from pdw_casadi.model.problem import Problem


def check_atlas_file(problem: Problem, path: Path, same_parameters: bool = True) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.UsageError` unless the readable file
    ``path`` reads as a gait atlas (of ``problem``'s parameters and section state with
    ``same_parameters``): finite states (rad, rad/s), parameters (SI units) and curves
    (deg). A malformed file fails before anything is written, not after the first solves."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
        entries = [AtlasEntry.from_dict(d) for d in data["entries"]]
        names = list(data["parameter_names"])
        for e in entries:
            arrays = (e.state, e.parameters, e.curves.to_numpy(float))
            if not all(np.all(np.isfinite(a)) for a in arrays) or e.parameters.size != len(names):
                raise ValueError(f"entry {e.label!r} has non-finite or missing values")
    except (ValueError, KeyError, TypeError, AttributeError, UnicodeDecodeError) as exc:
        reason = f"no key {exc}" if isinstance(exc, KeyError) else one_line(exc)
        raise UsageError(f"--atlas {path}: not a gait atlas ({reason})") from None
    if same_parameters and names != list(problem.parameter_names):
        raise UsageError(f"--atlas {path}: an atlas of a walker with the parameters "
                         f"{', '.join(map(str, names))}, not {problem.name}'s")
    if same_parameters and any(e.state.size != len(problem.state_names) for e in entries):
        raise UsageError(f"--atlas {path}: its states do not have {problem.name}'s "
                         f"{len(problem.state_names)} values")


def check_stride_walker(problem: Problem) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.UsageError` unless the stride map (two
    steps, the parameters following the physical legs) of ``problem`` can be built: the
    walker a per-leg fit solves on."""
    try:
        stride_map(problem)
    except ProblemError as exc:
        raise UsageError(str(exc)) from None
