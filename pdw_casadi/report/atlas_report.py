"""The report of a rebuilt gait atlas: the atlas file ``pdw-atlas`` writes, its warm starts
beside it and the line it prints.

The atlas is built by :func:`pdw_casadi.studies.atlas_run.run_atlas`; this module writes its
:class:`~pdw_casadi.studies.atlas_run.AtlasRun` in the format its entries own
(:meth:`~pdw_casadi.studies.atlas_run.AtlasRun.save`: JSON, states in rad and rad/s,
parameters in SI units, curves in deg). Nothing here solves.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.atlas_run import AtlasRun


def write_atlas(run: AtlasRun, path: Path, warm: Path) -> tuple[Path, Path]:
    """Write the atlas's entries to ``path`` (JSON) and their warm starts to ``warm``;
    returns both paths."""
    run.save(path, warm)
    return Path(path), Path(warm)


def wrote_line(path: Path) -> str:
    """The line ``pdw-atlas`` ends on."""
    return f"wrote {path}"
