"""Where fits start: stable interior gaits shipped with the package (the gait atlas).

The paper's Table 3 gait sits within 0.01 % of a fold in k_knee, and random perturbations
of its compliance have no fixed point; an NLP started there must first leave the fold.
The atlas (``data/atlas/<problem>.json``, rebuilt by ``python -m pdw_casadi.fit.atlas``)
holds stable, valid fixed points of a walker across compliance and slope, each with its
gait-cycle curves. A fit starts from the problem's own gait and, with ``multistart`` N > 1,
from the N - 1 entries whose curves already have the best mean R^2 on the user's curves.
Measured on the five bench files: from the problem's own (Table-3) gait four of five
converge in 10 to 17 s; from an atlas entry the same four or three, in 15 to 35 s, and which
file fails depends on the entry (the entries' compliance is not unique along a flat
direction of the curves), so the problem's own start comes first.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..curves import fit_scores
from ..resources import bundled_dir
from .options import FitOptions


@dataclass
class Start:
    """A starting gait: section state, parameters, where it came from, its R^2 on the
    user's curves before fitting (NaN when not known)."""

    label: str
    state: np.ndarray
    parameters: np.ndarray
    score: float = float("nan")


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


def select_starts(problem, human, opts: FitOptions) -> list[Start]:
    """The fit's ``multistart`` starts: the problem's own state and parameters, then the
    atlas entries with the best mean R^2 of the targets on ``human`` (only entries that
    agree with the problem in the parameters the fit holds fixed). ``atlas=""``: the
    problem's own start only."""
    own = Start("problem", problem.state_vector(), problem.parameter_vector())
    if opts.atlas == "" or opts.multistart < 2:
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
    scored = []
    for e in entries:
        s = fit_scores(e.curves, h)
        scored.append((float(np.mean([s[f"r2_{t}"] for t in opts.targets()])), e))
    scored.sort(key=lambda t: -t[0])
    return [own] + [Start(f"atlas:{e.label}", e.state, e.parameters, score)
                    for score, e in scored[: opts.multistart - 1]]
