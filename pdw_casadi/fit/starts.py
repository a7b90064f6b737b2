"""Where fits start: stable interior gaits shipped with the package (the gait atlas).

The paper's Table 3 gait sits within 0.01 % of a fold in k_knee, and random perturbations
of its compliance have no fixed point; an NLP started there must first leave the fold.
The atlas (``data/atlas/<problem>.json``, rebuilt by ``pdw-atlas``)
holds stable, valid fixed points of a walker, each with its gait-cycle curves and spectral
radius: gaits fitted to the walker's own curves and to the bundled cohort's curves, each at
two stability levels. A fit starts from the gaits, among the atlas entries and the problem's
own gait, whose curves already fit the user's best (mean R^2 of the targets), and of those
within ``FitOptions.start_r2_tolerance`` of the best, from the one deepest inside the stable
region (smallest spectral radius): the same curves from further away from the fold.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.gait.curves import cycle_curves, fit_scores
from pdw_casadi.gait.fixed_point import own_fixed_point
from pdw_casadi.gait.simulate import Simulator


@dataclass
class Start:
    """A starting gait: section state, parameters, where it came from, its mean R^2 on the
    user's curves before fitting and its spectral radius (NaN when not known)."""

    label: str
    state: np.ndarray
    parameters: np.ndarray
    score: float = float("nan")
    spectral_radius: float = float("nan")


@dataclass
class AtlasEntry:
    """A stable, valid fixed point: state, parameters (problem order), spectral radius,
    its 101-point gait-cycle curves (cycle_pct, knee_deg, hip_deg, thigh_deg)."""

    label: str
    state: np.ndarray
    parameters: np.ndarray
    spectral_radius: float
    curves: pd.DataFrame

    def to_dict(self) -> dict:
        return {"label": self.label, "state": self.state.tolist(),
                "parameters": self.parameters.tolist(),
                "spectral_radius": self.spectral_radius,
                "curves": {k: v.tolist() for k, v in self.curves.items()}}

    @classmethod
    def from_dict(cls, d: dict) -> AtlasEntry:
        return cls(d["label"], np.asarray(d["state"], float),
                   np.asarray(d["parameters"], float), float(d["spectral_radius"]),
                   pd.DataFrame(d["curves"]))


def atlas_path(problem_name: str) -> Path:
    """The bundled atlas file of a problem (it may not exist)."""
    return bundled_dir("data") / "atlas" / f"{problem_name}.json"


def load_atlas(problem, path: str | Path | None = None) -> list[AtlasEntry]:
    """The atlas entries of ``problem`` (empty when there is no atlas for it). Entries whose
    parameter names differ from the problem's are an error: the atlas is of another walker."""
    p = Path(path) if path else atlas_path(problem.name)
    if not p.is_file():
        return []
    data = json.loads(p.read_text())
    if list(data["parameter_names"]) != list(problem.parameter_names):
        raise ValueError(f"{p}: the atlas is for parameters {data['parameter_names']}, "
                         f"not {list(problem.parameter_names)}")
    return [AtlasEntry.from_dict(d) for d in data["entries"]]


def save_atlas(problem, entries: list[AtlasEntry], path: str | Path) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps({"problem": problem.name,
                             "parameter_names": list(problem.parameter_names),
                             "state_names": list(problem.state_names),
                             "entries": [e.to_dict() for e in entries]}, indent=1))
    return p


_OWN_GAIT: dict[str, tuple[pd.DataFrame, float] | None] = {}


def own_gait(problem) -> tuple[pd.DataFrame, float] | None:
    """The 101-point knee/hip/thigh curves (deg) and the spectral radius of the problem's own
    fixed point, or None when its own parameters have no gait (once per process for a
    problem of the same content: the start ranking and the knee floor both need it)."""
    key = problem.content_key()
    if key not in _OWN_GAIT:
        fp = own_fixed_point(problem)
        curves = cycle_curves(Simulator(problem), fp.state, fp.parameters) \
            if fp.converged else None
        if len(_OWN_GAIT) >= 8:
            _OWN_GAIT.pop(next(iter(_OWN_GAIT)))
        _OWN_GAIT[key] = None if curves is None else (curves, fp.spectral_radius)
    gait = _OWN_GAIT[key]
    return None if gait is None else (gait[0].copy(), gait[1])


def rank_starts(starts: list[Start], r2_tolerance: float) -> list[Start]:
    """``starts`` in the order a fit tries them: repeatedly, of the remaining starts whose
    score is within ``r2_tolerance`` of the best remaining score, the one with the smallest
    spectral radius (ties: the earlier in ``starts``)."""
    left, order = list(starts), []
    while left:
        top = max(st.score for st in left)
        near = [st for st in left if st.score >= top - r2_tolerance]
        pick = min(near, key=lambda st: st.spectral_radius)
        order.append(pick)
        left.remove(pick)
    return order


def select_starts(problem, human, opts: FitOptions) -> list[Start]:
    """The fit's ``multistart`` starts, of the problem's own gait and the atlas entries that
    agree with the problem in the parameters the fit holds fixed, in :func:`rank_starts`
    order of their mean R^2 of the targets on ``human``. ``atlas=""``: the problem's own
    start only."""
    own = Start("problem", problem.state_vector(), problem.parameter_vector())
    if opts.atlas == "":
        return [own]
    entries = load_atlas(problem, opts.atlas)
    # an entry can start the fit only if it agrees with the problem in every parameter the
    # fit holds fixed (a subset of the compliance, the slope unless it is free)
    free = set(opts.free or problem.compliance_names) | ({"slope"} if opts.free_slope else set())
    p0 = problem.parameter_vector()
    held = [i for i, n in enumerate(problem.parameter_names) if n not in free]
    entries = [e for e in entries if np.all(np.abs(e.parameters[held] - p0[held]) <= 1e-12 *
                                            np.maximum(1.0, np.abs(p0[held])))]
    if not entries:
        return [own]
    h = human.resample(101)

    def score(curves: pd.DataFrame) -> float:
        s = fit_scores(curves, h)
        return float(np.mean([s[f"r2_{t}"] for t in opts.targets()]))

    starts = [Start(f"atlas:{e.label}", e.state, e.parameters, score(e.curves),
                    e.spectral_radius) for e in entries]
    gait = own_gait(problem)
    if gait is not None:
        own.score, own.spectral_radius = score(gait[0]), gait[1]
        starts.append(own)
    return rank_starts(starts, opts.start_r2_tolerance)[: opts.multistart]
