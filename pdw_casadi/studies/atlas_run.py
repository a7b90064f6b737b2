"""The atlas workflow: everything ``pdw-atlas`` computes, returned as data for the report.

:func:`run_atlas` fits stable gaits of a walker at each spectral-radius limit to its own
curves (and their deformations, :func:`atlas_variants`) and to further curve files
(:func:`~pdw_casadi.fit.atlas.build_atlas`) and returns an :class:`AtlasRun`: the entries
of the new atlas, the ones kept from the file it replaces after them. The atlas file of a
walker (:func:`atlas_file`) and the entries kept from it (:func:`kept_entries`) are read
here before any fit. The report layer (:mod:`pdw_casadi.report.atlas_report`) writes it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from pdw_casadi.engine.errors import NoGait
from pdw_casadi.fit.atlas import RADII, VARIANTS, build_atlas
from pdw_casadi.fit.starts import AtlasEntry, atlas_path, load_atlas, save_atlas, warm_path
from pdw_casadi.model.gait_data import GaitCurves
from pdw_casadi.model.problem import Problem

__all__ = ["RADII", "VARIANT_SETS", "AtlasRun", "atlas_file", "atlas_variants", "build_atlas",
           "kept_entries", "run_atlas", "warm_path"]

#: the targets of ``--variants``: the walker's own curves, or also their deformations
VARIANT_SETS = ("own", "all")


@dataclass
class AtlasRun:
    """A rebuilt gait atlas (:func:`run_atlas`)."""

    problem: Problem
    #: the new entries, then those kept from the earlier atlas file (not replaced)
    entries: list[AtlasEntry]

    def save(self, path: Path, warm: Path) -> None:
        """Write the entries to ``path`` (JSON: states in rad and rad/s, parameters in SI
        units, curves in deg) and their warm starts to ``warm``, in the format of
        :func:`~pdw_casadi.fit.starts.save_atlas` (the one the fit reads)."""
        save_atlas(self.problem, self.entries, path, warm)


def atlas_variants(which: str) -> tuple:
    """The curve variants (label, knee amplitude factor, hip offset in deg) of
    ``--variants`` ``which`` (one of :data:`VARIANT_SETS`)."""
    return VARIANTS if which == "all" else VARIANTS[:1]


def atlas_file(problem: Problem, out: Path | None) -> Path:
    """The atlas file written: ``out``, else the bundled atlas of ``problem``."""
    return Path(out) if out else atlas_path(problem.name)


def kept_entries(problem: Problem, path: Path, keep: bool) -> list[AtlasEntry]:
    """With ``keep``, the entries of the atlas file ``path`` (none when it does not exist);
    read before the fits, so a damaged or foreign atlas is refused before any work."""
    return load_atlas(problem, path) if keep and Path(path).is_file() else []


def run_atlas(problem: Problem, radii: Sequence[float], variants: tuple,
              curves: tuple[GaitCurves, ...], kept: Sequence[AtlasEntry] = (),
              log: Callable[[str], None] = print,
              build: Callable[..., list[AtlasEntry]] = build_atlas) -> AtlasRun:
    """Fit the atlas's gaits of ``problem`` for each spectral-radius limit in ``radii``
    (-) and each target (``variants`` of its own curves, then ``curves``); the ``kept``
    entries whose labels the build does not replace go after the new ones. ``build`` is the
    builder (default :func:`~pdw_casadi.fit.atlas.build_atlas`; a caller passes the one it
    holds, so that a test can stand in for the fits). Raises
    :class:`~pdw_casadi.engine.errors.NoGait` when no target gives a stable valid gait."""
    entries = build(problem, tuple(radii), variants, curves, log=log)
    if not entries:
        raise NoGait(f"no stable valid gait of {problem.name} for any target (nothing "
                     f"written)")
    labels = {e.label for e in entries}
    entries += [e for e in kept if e.label not in labels]
    return AtlasRun(problem=problem, entries=entries)
