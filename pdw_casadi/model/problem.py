"""Problem files: what a walker is, as numbers only.

A problem file (TOML) names a walker ``family`` (the module in :mod:`pdw_casadi.model.walkers` that
knows its chain, phases and impacts) and gives its anthropometry, compliance, slope, initial
section state and numerical settings. Loading validates every key and value and raises
:class:`ProblemError` naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.engine.resources import bundled_names, resolve
from pdw_casadi.model.walkers import FAMILIES, get_family

#: the walker a command or study uses when none is named: the bundled problem of the paper's
#: 6-link walker (Tables 1-3)
DEFAULT_PROBLEM = "humanlike_6link"
#: numerical settings with their defaults (s, s)
NUMERICS_DEFAULTS = {"step_size": 5e-4, "max_phase_time": 2.0}
#: accepted ranges of the numerical settings (s): below the smallest step size a phase
#: needs millions of RK4 steps (and as many recorded samples); above the largest the fixed
#: RK4 step is too coarse for the walkers' contact and knee-spring dynamics (the event
#: location and the energy balance break down); a phase longer than the largest
#: max_phase_time is not a step
NUMERICS_RANGES = {"step_size": (1e-5, 1e-2), "max_phase_time": (1e-2, 10.0)}
#: validity margins with their defaults (N, m, m)
VALIDITY_DEFAULTS = {"min_normal_force": 0.0, "min_clearance": 0.0, "min_cop_margin": 0.0}

_SECTIONS = (
    "walker", "environment", "anthropometry", "compliance", "compliance_bounds",
    "initial_state", "numerics", "validity",
)


def _frozen(d: Mapping) -> Mapping:
    return MappingProxyType(dict(d))


@dataclass(frozen=True)
class Problem:
    """A validated walker problem. Angles in rad, lengths in m, masses in kg, time in s."""

    name: str
    family: str
    title: str
    g: float
    slope: float
    anthropometry: Mapping[str, float]
    compliance: Mapping[str, float]
    compliance_bounds: Mapping[str, tuple[float, float]]
    initial_state: Mapping[str, float]
    numerics: Mapping[str, float] = field(default_factory=lambda: _frozen(NUMERICS_DEFAULTS))
    validity: Mapping[str, float] = field(default_factory=lambda: _frozen(VALIDITY_DEFAULTS))
    source: Path | None = None
    #: per-leg overrides {"left"|"right": {"compliance": {...}, "anthropometry": {...}}}
    #: (``[compliance.left]``, ``[anthropometry.right]``, ... in the file); empty: both legs
    #: use ``compliance`` and ``anthropometry`` (a symmetric walker). See pdw_casadi.gait.stride.
    legs: Mapping[str, Mapping[str, Mapping[str, float]]] = field(
        default_factory=lambda: _frozen({}))

    @property
    def asymmetric(self) -> bool:
        """True when the two physical legs have different parameters."""
        return any(self.leg_values(side) != self.leg_values(LEG_SIDES[0]) for side in LEG_SIDES)

    def leg_values(self, side: str) -> tuple[dict[str, float], dict[str, float]]:
        """(compliance, anthropometry) of the physical leg ``side`` ("left" or "right"):
        the shared values with that leg's overrides."""
        over = self.legs.get(side, {})
        return ({**self.compliance, **over.get("compliance", {})},
                {**self.anthropometry, **over.get("anthropometry", {})})

    @property
    def state_names(self) -> list[str]:
        return list(self.initial_state)

    @property
    def compliance_names(self) -> list[str]:
        return list(self.compliance)

    def state_vector(self) -> np.ndarray:
        """The initial section state in file order."""
        return np.array(list(self.initial_state.values()), dtype=float)

    def compliance_vector(self) -> np.ndarray:
        return np.array(list(self.compliance.values()), dtype=float)

    def parameter_vector(self) -> np.ndarray:
        """Parameters p fed to the CasADi functions: compliance in file order, then slope."""
        return np.append(self.compliance_vector(), self.slope)

    @property
    def parameter_names(self) -> list[str]:
        return [*self.compliance, "slope"]

    def split_parameters(self, p) -> tuple[dict[str, float], float]:
        """A parameter vector (see parameter_vector) as (compliance by name, slope in rad)."""
        p = np.asarray(p, dtype=float).ravel()
        if p.size != len(self.compliance) + 1:
            raise ProblemError(f"{self.name}: parameter vector has {p.size} values, "
                               f"expected {len(self.compliance) + 1}")
        named = dict(zip(self.parameter_names, map(float, p), strict=True))
        slope = named.pop("slope")
        return named, slope

    def with_parameters(self, p) -> Problem:
        """A copy with compliance and slope taken from a parameter vector (see parameter_vector)."""
        comp, slope = self.split_parameters(p)
        return self.replace(compliance=comp, slope=slope)

    def with_state(self, x) -> Problem:
        """A copy whose initial section state is ``x`` (array in state order, or a mapping)."""
        if isinstance(x, Mapping):
            merged = {**self.initial_state, **{k: float(v) for k, v in x.items()}}
            unknown = set(x) - set(self.initial_state)
            if unknown:
                raise ProblemError(f"{self.name}: unknown state key(s) {sorted(unknown)}")
            return self.replace(initial_state=merged)
        x = np.asarray(x, dtype=float).ravel()
        if x.size != len(self.initial_state):
            raise ProblemError(f"{self.name}: state has {x.size} values, expected "
                               f"{len(self.initial_state)} ({', '.join(self.initial_state)})")
        return self.replace(initial_state=dict(zip(self.initial_state, x, strict=True)))

    def replace(self, **changes) -> Problem:
        """A validated copy with some fields changed (compliance may be given partially)."""
        if "compliance" in changes:
            unknown = set(changes["compliance"]) - set(self.compliance)
            if unknown:
                known = (f"known: {', '.join(self.compliance)}" if self.compliance
                         else f"the {self.family} walker has no compliance values")
                raise ProblemError(f"{self.name}: unknown compliance key(s) {sorted(unknown)}; "
                                   f"{known}")
            changes["compliance"] = {**self.compliance, **changes["compliance"]}
        for key in ("anthropometry", "compliance", "initial_state", "numerics", "validity",
                    "compliance_bounds"):
            if key in changes:
                changes[key] = _frozen(changes[key])
        if "legs" in changes:
            changes["legs"] = _freeze_legs(changes["legs"])
        new = dataclasses.replace(self, **changes)
        _check_values(new, self.source or Path(self.name))
        return new

    def in_family(self, family: str, extra: Mapping[str, float],
                  bounds: Mapping[str, tuple[float, float]] | None = None) -> Problem:
        """This walker as one of ``family``, whose compliance keys are this walker's and
        more (an extension: humanlike_6link -> humanlike_6link_ankle): the same body,
        compliance, per-leg values and section state, the extra keys at ``extra`` on both
        legs (SI units), their bounds ``bounds`` (default: those of the family's bundled
        problem file). Extra elements that are off (zero stiffness and damping) leave the
        gait as it was; a caller that relies on that checks it by re-simulation."""
        fam = get_family(family)
        keys = tuple(fam.compliance_keys)
        lost = [k for k in self.compliance if k not in keys]
        if lost or tuple(self.state_names) != tuple(fam.state_keys) or \
                set(self.anthropometry) != set(fam.anthropometry_keys):
            raise ProblemError(f"{self.name}: the {family} walker does not extend the "
                               f"{self.family} walker (compliance {', '.join(keys)})")
        new = [k for k in keys if k not in self.compliance]
        wrong = sorted(set(extra) ^ set(new))
        if wrong:
            raise ProblemError(f"{self.name} as a {family} walker needs values of exactly "
                               f"its extra compliance keys {', '.join(new) or '(none)'}; "
                               f"got {', '.join(extra) or 'none'}")
        if bounds is None:
            ref = load_problem(family).compliance_bounds
            bounds = {k: ref[k] for k in new if k in ref}
        comp = {k: float(self.compliance[k] if k in self.compliance else extra[k])
                for k in keys}
        out = dataclasses.replace(
            self, family=family, compliance=_frozen(comp),
            compliance_bounds=_frozen({**self.compliance_bounds,
                                       **{k: tuple(v) for k, v in bounds.items()}}))
        _check_values(out, self.source or Path(self.name))
        return out

    def __getstate__(self) -> dict:
        # mapping proxies do not pickle; worker processes get plain dicts, re-frozen on arrival
        state = {f.name: (dict(v) if isinstance(v, Mapping) else v)
                 for f in dataclasses.fields(self) for v in (getattr(self, f.name),)}
        state["legs"] = _thaw_legs(self.legs)
        return state

    def __setstate__(self, state: dict) -> None:
        for k, v in state.items():
            if k == "legs":
                v = _freeze_legs(v)
            object.__setattr__(self, k, _frozen(v) if isinstance(v, dict) else v)

    def content_key(self) -> str:
        """A string equal for problems of equal content (per-process caches key by it)."""
        return json.dumps(self.to_dict(), sort_keys=True, default=str)

    def to_dict(self) -> dict:
        return {
            "name": self.name, "family": self.family, "title": self.title, "g": self.g,
            "slope": self.slope, "anthropometry": dict(self.anthropometry),
            "compliance": dict(self.compliance),
            "compliance_bounds": {k: list(v) for k, v in self.compliance_bounds.items()},
            "initial_state": dict(self.initial_state), "numerics": dict(self.numerics),
            "validity": dict(self.validity), "legs": _thaw_legs(self.legs),
        }


#: the physical legs; a stride starts with "left" as the stance (leading) leg
LEG_SIDES = ("left", "right")


def _freeze_legs(legs) -> Mapping:
    return _frozen({side: _frozen({k: _frozen(v) for k, v in d.items()})
                    for side, d in dict(legs).items()})


def _thaw_legs(legs) -> dict:
    return {side: {k: dict(v) for k, v in d.items()} for side, d in legs.items()}


def _show(v) -> str:
    """A value for a message: numbers as plain Python numbers (no numpy reprs), JSON's
    null as null."""
    if isinstance(v, np.generic):
        v = v.item()
    if v is None:
        return "null"
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _num(where: str, key: str, v) -> float:
    if isinstance(v, np.generic) and not isinstance(v, np.bool_):
        v = v.item()
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise ProblemError(f"{where}: '{key}' must be a number, got {_show(v)}")
    v = float(v)
    if not math.isfinite(v):
        raise ProblemError(f"{where}: '{key}' must be finite, got {v}")
    return v


def check_bounds(problem: Problem, values: Mapping[str, float], where) -> None:
    """Raise :class:`ProblemError` when a compliance value lies outside the problem's
    ``compliance_bounds`` (or is negative where the walker needs it >= 0).

    The problem file's own values are checked when it is loaded; this applies the same
    limits to overrides (``--compliance``, ``--from-fit``) and to sweep grids. A physical
    leg's value (``right.k_ankle``, a stride parameter) has the key's bounds; a leg's body
    value (``right.m_s``) must be positive.
    """
    fam = get_family(problem.family)
    for name, v in values.items():
        side, dot, k = name.partition(".")
        if not (dot and side in LEG_SIDES):
            k = name
        elif k in fam.anthropometry_keys:  # one physical leg's body value (stride)
            if not v > 0:
                raise ProblemError(f"{where}: '{name}' = {v:g} must be > 0")
            continue
        if k == "slope":
            if not abs(v) < math.pi / 4:
                raise ProblemError(f"{where}: slope = {v:g} rad must be below pi/4 rad")
            continue
        if k in fam.nonnegative_compliance and v < 0:
            raise ProblemError(f"{where}: '{name}' = {v:g} must be >= 0")
        if k in problem.compliance_bounds:
            lo, hi = problem.compliance_bounds[k]
            if not lo <= v <= hi:
                src = problem.source or problem.name
                raise ProblemError(f"{where}: '{name}' = {v:g} lies outside its bounds "
                                   f"[{lo:g}, {hi:g}] (compliance_bounds of {src})")


def _section(raw: Mapping, where: str, name: str, required: list[str],
             optional: Mapping[str, float] | None = None) -> dict[str, float]:
    sec = raw.get(name, {} if optional is not None and not required else None)
    if sec is None:
        raise ProblemError(f"{where}: missing section [{name}]")
    if not isinstance(sec, Mapping):
        raise ProblemError(f"{where}: [{name}] must be a table")
    allowed = list(required) + list(optional or {})
    unknown = [k for k in sec if k not in allowed]
    if unknown:
        raise ProblemError(f"{where}: unknown key(s) {', '.join(f'{name}.{k}' for k in unknown)}"
                           f"; allowed: {', '.join(allowed)}")
    missing = [k for k in required if k not in sec]
    if missing:
        raise ProblemError(f"{where}: missing key(s) {', '.join(f'{name}.{k}' for k in missing)}")
    out = {k: _num(where, f"{name}.{k}", sec[k]) for k in required}
    for k, default in (optional or {}).items():
        out[k] = _num(where, f"{name}.{k}", sec.get(k, default))
    return out


def _check_values(pb: Problem, where) -> None:
    fam = get_family(pb.family)
    for k, v in pb.anthropometry.items():
        if k in fam.positive_keys and not v > 0:
            raise ProblemError(f"{where}: 'anthropometry.{k}' must be positive, got {v}")
    for k, v in pb.numerics.items():
        if not v > 0:
            raise ProblemError(f"{where}: 'numerics.{k}' must be positive, got {v}")
        lo, hi = NUMERICS_RANGES.get(k, (0.0, math.inf))
        if not lo <= v <= hi:
            raise ProblemError(f"{where}: 'numerics.{k}' must lie in [{lo:g}, {hi:g}] s, "
                               f"got {v:g}")
    if not pb.g > 0:
        raise ProblemError(f"{where}: 'environment.g' must be positive, got {pb.g}")
    if not abs(pb.slope) < math.pi / 4:
        raise ProblemError(f"{where}: 'environment.slope' must be below pi/4 rad, got {pb.slope}")
    for k, v in pb.compliance.items():
        if not math.isfinite(v):
            raise ProblemError(f"{where}: 'compliance.{k}' must be finite")
        if k in fam.nonnegative_compliance and v < 0:
            raise ProblemError(f"{where}: 'compliance.{k}' must be >= 0, got {v}")
    for k, (lo, hi) in pb.compliance_bounds.items():
        if not lo <= hi:
            raise ProblemError(f"{where}: 'compliance_bounds.{k}' = [{lo:g}, {hi:g}] is "
                               f"reversed (lower > upper)")
    for k, v in pb.initial_state.items():
        if not math.isfinite(v):
            raise ProblemError(f"{where}: 'initial_state.{k}' must be finite")
    fam.check_anthropometry(pb.anthropometry, where)
    for side in pb.legs:
        comp, anthro = pb.leg_values(side)
        for k, v in anthro.items():
            if k in fam.positive_keys and not v > 0:
                raise ProblemError(f"{where}: 'anthropometry.{side}.{k}' must be positive, "
                                   f"got {v}")
        for k, v in comp.items():
            if k in fam.nonnegative_compliance and v < 0:
                raise ProblemError(f"{where}: 'compliance.{side}.{k}' must be >= 0, got {v}")
            lo, hi = pb.compliance_bounds.get(k, (-math.inf, math.inf))
            if not lo <= v <= hi:
                raise ProblemError(f"{where}: 'compliance.{side}.{k}' = {v:g} lies outside "
                                   f"its bounds [{lo:g}, {hi:g}]")
        fam.check_anthropometry(anthro, f"{where} ({side} leg)")


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string (quotes, backslashes and control characters
    escaped)."""
    out = []
    for ch in str(text):
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def problem_toml(problem: Problem, header: str = "") -> str:
    """A problem as TOML text (the layout :func:`load_problem` reads), after ``header``:
    comment lines (a line not starting with ``#`` is made one)."""
    def table(name, values, units=None):
        lines = [f"[{name}]"]
        for k, v in values.items():
            if isinstance(v, tuple | list):
                lines.append(f"{k} = [{float(v[0])!r}, {float(v[1])!r}]")
            else:
                lines.append(f"{k} = {float(v)!r}")
        return "\n".join(lines) + "\n"

    # a header line that is not a comment would make the file unreadable, and so would a
    # control character in a comment (TOML forbids them)
    lines = [re.sub(r"[\x00-\x08\x0b-\x1f\x7f]", "", line) for line in header.split("\n")]
    head = "\n".join(line if line.lstrip().startswith("#") or not line.strip() else f"# {line}"
                     for line in lines)
    if head and not head.endswith("\n"):
        head += "\n"
    parts = [head] if head else []
    parts.append(f"[walker]\nfamily = {toml_string(problem.family)}\n"
                 f"title = {toml_string(problem.title)}\n")
    parts.append(table("environment", {"g": problem.g, "slope": problem.slope}))
    parts.append(table("anthropometry", problem.anthropometry))
    for side, d in problem.legs.items():
        if d.get("anthropometry"):
            parts.append(table(f"anthropometry.{side}", d["anthropometry"]))
    parts.append(table("compliance", problem.compliance))
    for side, d in problem.legs.items():
        if d.get("compliance"):
            parts.append(table(f"compliance.{side}", d["compliance"]))
    if problem.compliance_bounds:
        parts.append(table("compliance_bounds", problem.compliance_bounds))
    parts.append(table("initial_state", problem.initial_state))
    parts.append(table("numerics", problem.numerics))
    parts.append(table("validity", problem.validity))
    return "\n".join(parts)


def load_problem(name_or_path: str | Path) -> Problem:
    """Load and validate a problem: a bundled name (``"humanlike_6link"``) or a TOML path."""
    path = resolve(name_or_path, "problems", ".toml")
    if path.is_dir():
        raise ProblemError(f"problem {str(name_or_path)!r} is a directory, not a problem file")
    if not path.is_file():
        known = ", ".join(bundled_names("problems", ".toml"))
        raise ProblemError(f"problem {str(name_or_path)!r} not found: not a file and not a "
                           f"bundled problem ({known})")
    where = str(path)
    try:
        raw = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ProblemError(f"{where}: not valid TOML: {exc}") from None
    return problem_from_dict(raw, name=path.stem, source=path)


def problem_from_dict(raw: Mapping, name: str = "problem", source: Path | None = None) -> Problem:
    """Validate a parsed problem (same layout as the TOML file)."""
    where = str(source or name)
    unknown = [k for k in raw if k not in _SECTIONS]
    if unknown:
        raise ProblemError(f"{where}: unknown section(s) {', '.join(unknown)}; "
                           f"allowed: {', '.join(_SECTIONS)}")
    walker = raw.get("walker")
    if not isinstance(walker, Mapping) or "family" not in walker:
        raise ProblemError(f"{where}: missing key 'walker.family' (one of {', '.join(FAMILIES)})")
    extra = set(walker) - {"family", "title"}
    if extra:
        raise ProblemError(f"{where}: unknown key(s) {sorted('walker.' + k for k in extra)}")
    family = walker["family"]
    if family not in FAMILIES:
        raise ProblemError(f"{where}: 'walker.family' = {family!r} is not one of "
                           f"{', '.join(FAMILIES)}")
    fam = get_family(family)
    env = _section(raw, where, "environment", ["g", "slope"])
    raw, legs = _split_legs(raw, where, fam)
    anthro = _section(raw, where, "anthropometry", list(fam.anthropometry_keys))
    comp = _section(raw, where, "compliance", list(fam.compliance_keys)) \
        if fam.compliance_keys else _section(raw, where, "compliance", [], {})
    state = _section(raw, where, "initial_state", list(fam.state_keys))
    numerics = _section(raw, where, "numerics", [], NUMERICS_DEFAULTS)
    validity = _section(raw, where, "validity", [], VALIDITY_DEFAULTS)
    bounds_raw = raw.get("compliance_bounds", {})
    if not isinstance(bounds_raw, Mapping):
        raise ProblemError(f"{where}: [compliance_bounds] must be a table of "
                           f"name = [lower, upper], got {_show(bounds_raw)}")
    bounds: dict[str, tuple[float, float]] = {}
    for k, v in bounds_raw.items():
        if k not in comp:
            raise ProblemError(f"{where}: unknown key 'compliance_bounds.{k}'")
        if not (isinstance(v, list) and len(v) == 2):
            raise ProblemError(f"{where}: 'compliance_bounds.{k}' must be [lower, upper]")
        lo, hi = (_num(where, f"compliance_bounds.{k}", x) for x in v)
        if not lo <= hi:
            raise ProblemError(f"{where}: 'compliance_bounds.{k}' = [{lo:g}, {hi:g}] is "
                               f"reversed (lower > upper)")
        if not lo <= comp[k] <= hi:
            raise ProblemError(f"{where}: 'compliance.{k}' = {comp[k]} lies outside its bounds "
                               f"[{lo}, {hi}]")
        bounds[k] = (lo, hi)
    pb = Problem(
        name=name, family=family, title=str(walker.get("title", name)), g=env["g"],
        slope=env["slope"], anthropometry=_frozen(anthro), compliance=_frozen(comp),
        compliance_bounds=_frozen(bounds), initial_state=_frozen(state),
        numerics=_frozen(numerics), validity=_frozen(validity), source=source,
        legs=_freeze_legs(legs),
    )
    _check_values(pb, where)
    return pb


def _split_legs(raw: Mapping, where: str, fam) -> tuple[dict, dict]:
    """Take the per-leg subtables ([compliance.left], [anthropometry.right], ...) out of
    ``raw``; returns (raw without them, {side: {section: {key: value}}})."""
    raw = dict(raw)
    legs: dict[str, dict[str, dict[str, float]]] = {}
    family = raw["walker"]["family"]
    for section in ("compliance", "anthropometry"):
        sec = raw.get(section)
        if not isinstance(sec, Mapping):
            continue
        sides = [k for k in sec if k in LEG_SIDES]
        if not sides:
            continue
        per_leg = (fam.leg_keys or {}).get(section)
        if per_leg is None:
            raise ProblemError(f"{where}: the {family} walker has no per-leg {section} "
                               f"([{section}.{sides[0]}])")
        sec = dict(sec)
        for side in sides:
            sub = sec.pop(side)
            if not isinstance(sub, Mapping):
                raise ProblemError(f"{where}: [{section}.{side}] must be a table")
            unknown = [k for k in sub if k not in per_leg]
            if unknown:
                raise ProblemError(f"{where}: unknown per-leg key(s) "
                                   f"{', '.join(f'{section}.{side}.{k}' for k in unknown)}; "
                                   f"allowed: {', '.join(per_leg)}")
            legs.setdefault(side, {})[section] = {
                k: _num(where, f"{section}.{side}.{k}", v) for k, v in sub.items()}
        raw[section] = sec
    return raw, legs


def load_overrides(path: str | Path, what: str) -> dict[str, float]:
    """Read a JSON or TOML file of ``{name: value}`` overrides (state or compliance).

    A file may also be a ``summary.json`` written by this toolkit: its ``fixed_point`` (for
    ``what="state"``) or ``compliance`` table is used.
    """

    p = Path(path)
    if p.is_dir():
        raise ProblemError(f"{p}: is a directory, not a {what} file")
    if not p.is_file():
        raise ProblemError(f"{p}: {what} file not found" if not p.exists()
                           else f"{p}: not a regular file")
    raw = read_table(p, what)
    key = {"state": ("fixed_point", "initial_state"), "compliance": ("compliance",)}[what]
    for k in key:
        if isinstance(raw, Mapping) and isinstance(raw.get(k), Mapping):
            raw = raw[k]
            break
    if not isinstance(raw, Mapping) or not raw:
        raise ProblemError(f"{p}: expected a table of {what} values, got "
                           f"{'an empty table' if isinstance(raw, Mapping) else _show(raw)}")
    return {k: _num(str(p), k, v) for k, v in raw.items()}


def read_table(path: Path, what: str):
    """Parse a JSON or TOML file: by suffix (``.json`` / ``.toml``, any case), else JSON when
    the text parses as JSON, else TOML. Raises :class:`ProblemError` naming the file."""
    p = Path(path)
    try:
        text = p.read_text()
    except UnicodeDecodeError:
        raise ProblemError(f"{p}: cannot parse {what} file: not UTF-8 text") from None
    suffix = p.suffix.lower()
    try:
        if suffix == ".json":
            return json.loads(text)
        if suffix == ".toml":
            return tomllib.loads(text)
        try:
            return json.loads(text)
        except ValueError:
            return tomllib.loads(text)
    except (ValueError, tomllib.TOMLDecodeError) as exc:
        kind = {".json": "JSON", ".toml": "TOML"}.get(suffix, "JSON or TOML")
        raise ProblemError(f"{p}: cannot parse {what} file as {kind}: {exc}") from None
