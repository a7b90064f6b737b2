"""Human gait target curves: load and validate a CSV of joint angles over one gait cycle.

A gait-curve file is a CSV with one row per sample of the gait cycle and these columns
(all angles in **degrees**, sagittal plane):

Required:

- ``cycle_pct``: time in % of the gait cycle, strictly increasing from 0 to 100
  (0 = heel strike of the reference leg, 100 = its next heel strike).
- ``hip_mean_deg``: hip joint angle (thigh relative to pelvis), flexion positive.
- ``knee_mean_deg``: knee flexion, 0 = straight, flexion positive.

Optional (validated when present):

- ``thigh_mean_deg``: thigh angle from the gravity vertical, positive with the knee ahead
  of the hip (same sign as hip flexion).
- ``pelvis_mean_deg``: pelvic tilt relative to the laboratory, anterior tilt positive.
- ``hip_sd_deg``, ``knee_sd_deg``, ``thigh_sd_deg``, ``pelvis_sd_deg``: standard deviations
  of the corresponding curves (>= 0).

Other columns are kept unchanged and are not validated. The bundled file ``female_fast.csv``
(see ``data/README.md``) is found by bare name: ``load_gait_curves("female_fast")``.

**Per-side files** (a walker whose legs differ is fitted leg by leg): the same columns once
per side, the side after the curve name, ``<curve>_<side>_mean_deg`` and
``<curve>_<side>_sd_deg`` with curve in hip, knee, thigh, pelvis and side in left, right
(e.g. ``knee_left_mean_deg``, ``hip_right_sd_deg``), and one ``cycle_pct``: each side's
curves over its own gait cycle (0 = that side's heel strike). Required: ``cycle_pct`` and
hip and knee means of both sides; an optional column must be given for both sides or for
none. One-curve columns (``knee_mean_deg``) and per-side ones may not be mixed.
:func:`load_side_curves` reads such a file (or two standard files, one per side) into
:class:`SideCurves`; :func:`load_gait_file` reads either kind.
"""

from __future__ import annotations

import csv
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd

from pdw_casadi.engine import resources
from pdw_casadi.engine.errors import GaitDataError

__all__ = [
    "ANGLE_COLUMNS",
    "CYCLE_POINTS",
    "MIN_ROWS",
    "OPTIONAL_COLUMNS",
    "REQUIRED_COLUMNS",
    "SD_COLUMNS",
    "SIDES",
    "GaitCurves",
    "GaitDataError",
    "SideCurves",
    "bundled_gait_files",
    "is_per_side",
    "load_gait_curves",
    "load_gait_file",
    "load_side_curves",
    "side_column",
    "split_sides",
]

REQUIRED_COLUMNS: tuple[str, ...] = ("cycle_pct", "hip_mean_deg", "knee_mean_deg")
"""Columns every gait-curve file must have."""

OPTIONAL_COLUMNS: tuple[str, ...] = (
    "hip_sd_deg",
    "knee_sd_deg",
    "thigh_mean_deg",
    "thigh_sd_deg",
    "pelvis_mean_deg",
    "pelvis_sd_deg",
)
"""Columns that are validated (numeric, finite) when present."""

SD_COLUMNS: tuple[str, ...] = tuple(c for c in OPTIONAL_COLUMNS if c.endswith("_sd_deg"))
"""Standard-deviation columns: must also be non-negative."""

ANGLE_COLUMNS: tuple[str, ...] = ("knee_mean_deg", "hip_mean_deg", "thigh_mean_deg")
"""Mean-angle columns checked by the radians heuristic (the pelvis is not: see below)."""

#: samples of one gait cycle, 0..100 % at every 1 % like the human data: the grid the
#: curves are resampled to, fitted and reported on
CYCLE_POINTS = 101

MIN_ROWS = 11
"""Fewest samples accepted over the cycle (a sample at least every 10 % on average)."""

CYCLE_TOL = 1e-6
"""Tolerance (in %) on the first ``cycle_pct`` being 0 and the last being 100."""

RADIANS_MAX_RANGE_DEG = 5.0
"""A mean-angle curve whose range over the cycle is below this (deg) may be in radians."""

RADIANS_MAX_ABS = 3.2
"""... and whose largest magnitude is below this (just above pi) then looks like radians."""

MIN_RANGE_DEG = 5.0
"""A knee, hip or thigh curve must move through at least this (deg) over the cycle: a flat
curve is not walking, and the fit's R^2 (1 - SSE / variance) is undefined for it."""

MAX_ABS_DEG = 360.0
"""No angle or standard deviation of a gait-curve file may exceed this (deg) in magnitude:
beyond a full turn the numbers are not joint angles (a unit or export fault)."""

_SUFFIX = ".csv"
_KIND = "data"
_READ_ERRORS = (
    OSError,
    UnicodeDecodeError,
    csv.Error,
    pd.errors.ParserError,
    pd.errors.EmptyDataError,
)


FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False, repr=False)
class GaitCurves:
    """Validated human gait curves over one gait cycle (angles in degrees).

    Attributes:
        frame: the validated table, one row per sample, ``cycle_pct`` strictly increasing from
            0 to 100 (%), known columns as float64, extra columns kept as read. Treat as
            read-only; use :meth:`to_frame` for a copy to modify.
        source: the file the curves were read from.
        name: a short label, by default the file name without its suffix (``"female_fast"``).

    Constructing a ``GaitCurves`` directly validates ``frame`` the same way
    :func:`load_gait_curves` does and raises :class:`GaitDataError` on a bad table.
    The array properties return fresh float64 copies.
    """

    frame: pd.DataFrame
    source: Path
    name: str

    def __post_init__(self) -> None:
        source = Path(self.source)
        object.__setattr__(self, "source", source)
        object.__setattr__(self, "frame", _validate(self.frame, source))

    def __repr__(self) -> str:
        return (
            f"GaitCurves(name={self.name!r}, rows={len(self.frame)}, "
            f"columns={list(self.frame.columns)}, source={str(self.source)!r})"
        )

    def __len__(self) -> int:
        """Number of samples over the cycle."""
        return len(self.frame)

    def _column(self, column: str) -> FloatArray:
        return self.frame[column].to_numpy(dtype=np.float64, copy=True)

    def _optional(self, column: str) -> FloatArray | None:
        return self._column(column) if column in self.frame.columns else None

    @property
    def cycle_pct(self) -> FloatArray:
        """Time of each sample, % of the gait cycle (0 .. 100)."""
        return self._column("cycle_pct")

    @property
    def knee_deg(self) -> FloatArray:
        """Mean knee flexion, deg (0 = straight, flexion positive)."""
        return self._column("knee_mean_deg")

    @property
    def hip_deg(self) -> FloatArray:
        """Mean hip joint angle (thigh relative to pelvis), deg, flexion positive."""
        return self._column("hip_mean_deg")

    @property
    def thigh_deg(self) -> FloatArray | None:
        """Mean thigh angle from the gravity vertical, deg (knee ahead positive); None if absent."""
        return self._optional("thigh_mean_deg")

    @property
    def pelvis_deg(self) -> FloatArray | None:
        """Mean pelvic tilt, deg (anterior tilt positive); None if absent."""
        return self._optional("pelvis_mean_deg")

    @property
    def knee_sd_deg(self) -> FloatArray | None:
        """Standard deviation of the knee curve, deg; None if absent."""
        return self._optional("knee_sd_deg")

    @property
    def hip_sd_deg(self) -> FloatArray | None:
        """Standard deviation of the hip curve, deg; None if absent."""
        return self._optional("hip_sd_deg")

    @property
    def thigh_sd_deg(self) -> FloatArray | None:
        """Standard deviation of the thigh curve, deg; None if absent."""
        return self._optional("thigh_sd_deg")

    @property
    def pelvis_sd_deg(self) -> FloatArray | None:
        """Standard deviation of the pelvis curve, deg; None if absent."""
        return self._optional("pelvis_sd_deg")

    def to_frame(self) -> pd.DataFrame:
        """A copy of the validated table (``cycle_pct`` in %, angles in deg)."""
        return self.frame.copy()

    def resample(self, n: int = CYCLE_POINTS) -> GaitCurves:
        """The curves on ``n`` evenly spaced points from 0 to 100 % (linear interpolation).

        Every numeric column is interpolated linearly in ``cycle_pct`` (standard deviations
        too, which is an approximation between samples); non-numeric extra columns are dropped.
        On the file's own grid the values are reproduced exactly.

        Args:
            n: number of samples, at least :data:`MIN_ROWS`.

        Returns:
            A new ``GaitCurves`` with the same ``source`` and ``name``.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < MIN_ROWS:
            raise ValueError(f"resample: n must be an integer >= {MIN_ROWS}, got {n!r}")
        grid = np.linspace(0.0, 100.0, int(n))
        x = self.frame["cycle_pct"].to_numpy(dtype=np.float64)
        columns: dict[str, FloatArray] = {"cycle_pct": grid}
        for column in self.frame.columns:
            if column == "cycle_pct" or not pd.api.types.is_numeric_dtype(self.frame[column]):
                continue
            y = self.frame[column].to_numpy(dtype=np.float64)
            columns[column] = np.interp(grid, x, y)
        return GaitCurves(frame=pd.DataFrame(columns), source=self.source, name=self.name)


def bundled_gait_files() -> list[str]:
    """File names of the gait-curve CSVs bundled with the package, e.g. ``["female_fast.csv"]``.

    Each can be passed to :func:`load_gait_curves` as is or without its ``.csv`` suffix.
    """
    return sorted(p.name for p in resources.bundled_dir(_KIND).glob(f"*{_SUFFIX}") if p.is_file())


def load_gait_curves(source: str | os.PathLike[str]) -> GaitCurves:
    """Read and validate a gait-curve CSV (see the module docstring for the columns).

    Args:
        source: a path to a CSV file, or the bare name of a bundled file (``"female_fast.csv"``
            or ``"female_fast"``). A name without a directory part that is not an existing path
            is looked up among the bundled files (:func:`bundled_gait_files`).

    Returns:
        The validated curves; ``name`` is the file name without its suffix.

    Raises:
        GaitDataError: the file is missing or unreadable, or its content fails a check:
            a required column is missing; a known column holds a NaN, an infinite or a
            non-numeric value; a standard deviation is negative; there are fewer than
            :data:`MIN_ROWS` rows; ``cycle_pct`` is not strictly increasing (duplicate or
            out-of-order rows) or does not run from 0 to 100 (within :data:`CYCLE_TOL`);
            or a knee, hip or thigh curve looks like it is in radians (see :func:`_validate`).
    """
    path = _resolve(source)
    frame = _read_csv(path, bundled=Path(source) != path)
    return GaitCurves(frame=frame, source=path, name=_stem(path))


def _resolve(source: str | os.PathLike[str]) -> Path:
    """The file to read: ``source`` itself if it names a directory part, else via resources.

    ``pathlib`` drops a leading ``./`` (``Path("./x.csv").parts == ("x.csv",)``), so the
    directory part is looked for in the text as given: ``"./x.csv"`` always means that path.
    """
    text = os.fspath(source)
    seps = {os.sep, os.altsep} - {None}
    if any(sep in text for sep in seps):
        return Path(text)
    return resources.resolve(text, _KIND, _SUFFIX)


def _stem(path: Path) -> str:
    return path.name[: -len(_SUFFIX)] if path.name.endswith(_SUFFIX) else path.stem


def _read_csv(path: Path, *, bundled: bool) -> pd.DataFrame:
    """Read ``path`` into a DataFrame, turning every I/O or parse failure into GaitDataError."""
    if not path.exists():
        hint = f" (bundled gait files: {', '.join(bundled_gait_files()) or 'none'})"
        what = "bundled gait curve file" if bundled else "gait curve file"
        raise GaitDataError(f"{what} not found: {path}{hint if bundled else ''}")
    if not path.is_file():
        raise GaitDataError(f"gait curve file {path} is not a regular file")
    # utf-8-sig: tolerate the byte-order mark that spreadsheet programs write.
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            header = next(csv.reader(f), None)
    except _READ_ERRORS as exc:
        raise GaitDataError(f"cannot read gait curve file {path}: {exc}") from exc
    if not header or all(not h.strip() for h in header):
        raise GaitDataError(f"gait curve file {path} is empty (no header line)")
    names = [h.strip() for h in header]
    duplicates = sorted({h for h in names if names.count(h) > 1})
    if duplicates:
        raise GaitDataError(f"gait curve file {path}: duplicate column(s) {duplicates}")
    try:
        frame = pd.read_csv(path, encoding="utf-8-sig")
    except _READ_ERRORS as exc:
        raise GaitDataError(f"cannot read gait curve file {path}: {exc}") from exc
    frame.columns = [str(c).strip() for c in frame.columns]
    return frame


def _validate(frame: pd.DataFrame, source: Path, side: str | None = None) -> pd.DataFrame:
    """Check a gait-curve table and return a clean copy (known columns float64, 0-based index).

    ``side`` ("left"/"right"): the table is one side of a per-side file (:func:`split_sides`),
    and messages name that file's columns (``knee_left_mean_deg``), not the standard ones.

    Radians heuristic: human walking moves the knee through about 60 deg per cycle (fast
    walking: ~0 to ~65 deg) and the hip and thigh through about 40-50 deg. In radians the same
    knee curve spans only ~1.1 and never exceeds pi in magnitude. So a knee, hip or thigh curve
    whose range is below :data:`RADIANS_MAX_RANGE_DEG` (5) *and* whose largest magnitude is below
    :data:`RADIANS_MAX_ABS` (3.2, just above pi) is rejected as "looks like radians": a curve in
    degrees that moves less than 5 deg is not walking either. The pelvis curve is exempt
    because a real pelvic tilt in degrees can be that small and flat.
    """
    where = f"gait curve file {source}"

    def col(c: str) -> str:
        return c if side is None else side_column(c, side)

    if not isinstance(frame, pd.DataFrame):
        raise GaitDataError(f"{where}: expected a pandas DataFrame, got {type(frame).__name__}")
    frame = frame.reset_index(drop=True).copy()

    missing = [c for c in REQUIRED_COLUMNS if c not in frame.columns]
    if missing:
        raise GaitDataError(
            f"{where}: missing required column(s) {[col(c) for c in missing]}; "
            f"required: {[col(c) for c in REQUIRED_COLUMNS]}, "
            f"found: {[col(str(c)) for c in frame.columns]}"
            + (" (this is a per-side file: a per-leg fit reads it, pdw-fit --gait FILE)"
               if side is None and is_per_side(frame.columns) else "")
        )

    known = [c for c in (*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS) if c in frame.columns]
    for column in known:
        frame[column] = _numeric_column(frame[column], col(column), where)
    for column in (c for c in SD_COLUMNS if c in frame.columns):
        negative = np.flatnonzero(frame[column].to_numpy() < 0.0)
        if negative.size:
            i = int(negative[0])
            raise GaitDataError(
                f"{where}: column {col(column)!r} is a standard deviation but has the negative "
                f"value {float(frame[column].iloc[i])!r} at data row {i + 1}"
            )

    if len(frame) < MIN_ROWS:
        raise GaitDataError(
            f"{where}: only {len(frame)} data row(s); at least {MIN_ROWS} samples of the gait "
            f"cycle (column 'cycle_pct', 0..100 %) are needed"
        )

    pct = frame["cycle_pct"].to_numpy()
    step = np.diff(pct)
    if np.any(step <= 0.0):
        i = int(np.flatnonzero(step <= 0.0)[0])
        if step[i] == 0.0:
            problem = f"duplicate value {float(pct[i])!r} at data rows {i + 1} and {i + 2}"
        else:
            problem = (
                f"not increasing: {float(pct[i + 1])!r} at data row {i + 2} follows "
                f"{float(pct[i])!r} at data row {i + 1} (rows out of order?)"
            )
        raise GaitDataError(f"{where}: column 'cycle_pct' must be strictly increasing; {problem}")
    if abs(pct[0]) > CYCLE_TOL:
        raise GaitDataError(
            f"{where}: column 'cycle_pct' must start at 0 (% of the gait cycle), "
            f"got {float(pct[0])!r}"
        )
    if abs(pct[-1] - 100.0) > CYCLE_TOL:
        hint = " (a fraction of the cycle? use percent)" if abs(pct[-1] - 1.0) <= CYCLE_TOL else ""
        raise GaitDataError(
            f"{where}: column 'cycle_pct' must end at 100 (% of the gait cycle), "
            f"got {float(pct[-1])!r}{hint}"
        )

    for column in (c for c in known if c != "cycle_pct"):
        values = frame[column].to_numpy()
        big = np.flatnonzero(np.abs(values) > MAX_ABS_DEG)
        if big.size:
            i = int(big[0])
            raise GaitDataError(
                f"{where}: column {col(column)!r} has the value {float(values[i]):.6g} at data "
                f"row {i + 1}, beyond +-{MAX_ABS_DEG:g} deg: not a joint angle in degrees"
            )
    for column in (c for c in ANGLE_COLUMNS if c in frame.columns):
        values = frame[column].to_numpy()
        span = float(values.max() - values.min())
        peak = float(np.abs(values).max())
        if span < RADIANS_MAX_RANGE_DEG and peak < RADIANS_MAX_ABS:
            raise GaitDataError(
                f"{where}: column {col(column)!r} looks like radians, not degrees: it spans only "
                f"{span:.3g} over the cycle and never exceeds {peak:.3g} in magnitude (a human "
                f"knee moves through ~60 deg per cycle, hip and thigh ~45 deg); "
                f"convert to degrees"
            )
        if span < MIN_RANGE_DEG:
            raise GaitDataError(
                f"{where}: column {col(column)!r} is "
                + ("constant" if span == 0.0 else f"nearly flat (it spans only {span:.3g} deg)")
                + f" over the cycle; a walking knee, hip or thigh moves through tens of "
                f"degrees (at least {MIN_RANGE_DEG:g} deg needed to fit it)"
            )
    return frame


def _numeric_column(values: pd.Series, column: str, where: str) -> pd.Series:
    """``values`` as finite float64, or GaitDataError naming the column and the first bad row."""
    numbers = pd.to_numeric(values, errors="coerce")
    not_numeric = numbers.isna() & values.notna()
    if not_numeric.any():
        i = int(np.flatnonzero(not_numeric.to_numpy())[0])
        raise GaitDataError(
            f"{where}: column {column!r} has the non-numeric value {values.iloc[i]!r} "
            f"at data row {i + 1}"
        )
    numbers = numbers.astype(np.float64)
    if numbers.isna().any():
        i = int(np.flatnonzero(numbers.isna().to_numpy())[0])
        raise GaitDataError(
            f"{where}: column {column!r} has a missing value (NaN or empty cell) "
            f"at data row {i + 1}"
        )
    infinite = ~np.isfinite(numbers.to_numpy())
    if infinite.any():
        i = int(np.flatnonzero(infinite)[0])
        raise GaitDataError(
            f"{where}: column {column!r} has the non-finite value {float(numbers.iloc[i])!r} "
            f"at data row {i + 1}"
        )
    return numbers


# --------------------------------------------------------------------------------------------
# per-side files
# --------------------------------------------------------------------------------------------
SIDES: tuple[str, str] = ("left", "right")
"""The physical legs, in the order of :mod:`pdw_casadi.gait.stride` (step 1: left stance)."""

_CURVE_COLUMNS = tuple(c for c in (*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS) if c != "cycle_pct")
_SIDE_RE = re.compile(r"^(hip|knee|thigh|pelvis)_(left|right)_(mean|sd)_deg$")


def side_column(column: str, side: str) -> str:
    """The per-side name of a standard curve column: ``knee_mean_deg`` -> ``knee_left_mean_deg``
    (``cycle_pct`` is shared by both sides)."""
    if column == "cycle_pct":
        return column
    curve, rest = column.split("_", 1)
    return f"{curve}_{side}_{rest}"


def is_per_side(columns) -> bool:
    """Whether a header holds per-side curve columns (``knee_left_mean_deg``, ...)."""
    return any(_SIDE_RE.match(str(c).strip()) for c in columns)


@dataclass(frozen=True, eq=False, repr=False)
class SideCurves:
    """Human gait curves of each physical leg, each over its own gait cycle (deg).

    Attributes:
        left, right: the validated curves of each side (:class:`GaitCurves`, standard
            column names).
        source: the file (or the left side's file) the curves were read from.
        name: a short label, by default the file name without its suffix.
    """

    left: GaitCurves
    right: GaitCurves
    source: Path
    name: str

    def __repr__(self) -> str:
        return (f"SideCurves(name={self.name!r}, rows={len(self.left)}/{len(self.right)}, "
                f"source={str(self.source)!r})")

    def side(self, side: str) -> GaitCurves:
        """The curves of ``side`` ("left" or "right")."""
        if side not in SIDES:
            raise ValueError(f"side must be one of {SIDES}, got {side!r}")
        return self.left if side == "left" else self.right

    def mean(self, n: int = CYCLE_POINTS) -> GaitCurves:
        """The mean of both sides' curves on ``n`` points (each side on its own cycle), the
        curves a symmetric walker fits: columns present on both sides; the SD columns are
        dropped (a mean of two sides' SDs is not an SD of anything)."""
        a, b = self.left.resample(n).frame, self.right.resample(n).frame
        columns = {"cycle_pct": a["cycle_pct"].to_numpy()}
        for c in _CURVE_COLUMNS:
            if c in a.columns and c in b.columns and not c.endswith("_sd_deg"):
                columns[c] = 0.5 * (a[c].to_numpy() + b[c].to_numpy())
        return GaitCurves(frame=pd.DataFrame(columns), source=self.source,
                          name=f"{self.name} (mean of both sides)")


def split_sides(frame: pd.DataFrame, source: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The two sides of a per-side table as standard tables (``knee_left_mean_deg`` ->
    ``knee_mean_deg``), each validated like a one-curve file (messages name the per-side
    columns). Raises :class:`GaitDataError` on a mixed or one-sided schema."""
    where = f"gait curve file {source}"
    names = [str(c) for c in frame.columns]
    plain = [c for c in names if c in _CURVE_COLUMNS]
    if plain:
        raise GaitDataError(
            f"{where}: mixes one-curve columns {plain} with per-side columns "
            f"(<curve>_left_..., <curve>_right_...); use one schema")
    if "cycle_pct" not in names:
        raise GaitDataError(f"{where}: missing required column(s) ['cycle_pct']")
    for c in _CURVE_COLUMNS:
        have = [s for s in SIDES if side_column(c, s) in names]
        if len(have) == 1:
            other = "right" if have[0] == "left" else "left"
            raise GaitDataError(
                f"{where}: column {side_column(c, have[0])!r} has no {other} counterpart "
                f"{side_column(c, other)!r}; a per-side file gives each curve for both sides")
    out = []
    for s in SIDES:
        cols = {side_column(c, s): c for c in ("cycle_pct", *_CURVE_COLUMNS)
                if side_column(c, s) in names}
        sub = frame[list(cols)].rename(columns=cols)
        out.append(_validate(sub, source, side=s))
    return out[0], out[1]


def load_side_curves(source: str | os.PathLike[str],
                     right: str | os.PathLike[str] | None = None) -> SideCurves:
    """Read per-side human curves: one per-side file (module docstring), or, with ``right``,
    two standard files, ``source`` the left leg's and ``right`` the right leg's.

    Raises:
        GaitDataError: a file is missing, unreadable or fails a check of
            :func:`load_gait_curves`; the per-side file is not per-side, mixes schemas, or
            gives a curve for one side only.
    """
    if right is not None:
        # a per-side file given as one side fails as a one-curve file, saying it is per-side
        left_c, right_c = load_gait_curves(source), load_gait_curves(right)
        return SideCurves(left_c, right_c, left_c.source, left_c.name)
    path = _resolve(source)
    frame = _read_csv(path, bundled=Path(source) != path)
    if not is_per_side(frame.columns):
        raise GaitDataError(f"gait curve file {path}: no per-side columns "
                            f"(<curve>_left_mean_deg, <curve>_right_mean_deg)")
    a, b = split_sides(frame, path)
    name = _stem(path)
    return SideCurves(GaitCurves(frame=a, source=path, name=f"{name}:left"),
                      GaitCurves(frame=b, source=path, name=f"{name}:right"), path, name)


def load_gait_file(source: str | os.PathLike[str]) -> GaitCurves | SideCurves:
    """A gait-curve file of either kind: :class:`SideCurves` when its header has per-side
    columns, else :class:`GaitCurves` (:func:`load_gait_curves`)."""
    path = _resolve(source)
    frame = _read_csv(path, bundled=Path(source) != path)
    if is_per_side(frame.columns):
        return load_side_curves(source)
    return GaitCurves(frame=frame, source=path, name=_stem(path))
