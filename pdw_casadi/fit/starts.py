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
from pdw_casadi.fit.driver import WarmStart
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.gait.curves import cycle_curves, fit_scores
from pdw_casadi.gait.fixed_point import own_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.gait_data import CYCLE_POINTS


@dataclass
class Start:
    """A starting gait: section state, parameters, where it came from, its mean R^2 on the
    user's curves before fitting and its spectral radius (NaN when not known)."""

    label: str
    state: np.ndarray
    parameters: np.ndarray
    score: float = float("nan")
    spectral_radius: float = float("nan")
    #: a stored solution of the NLP built at this gait (None: none; a fit then starts cold)
    warm: WarmStart | None = None


@dataclass
class AtlasEntry:
    """A stable, valid fixed point: state, parameters (problem order), spectral radius,
    its 101-point gait-cycle curves (cycle_pct, knee_deg, hip_deg, thigh_deg)."""

    label: str
    state: np.ndarray
    parameters: np.ndarray
    spectral_radius: float
    curves: pd.DataFrame
    #: the solution and multipliers of the fit's NLP built at this gait
    #: (:meth:`~pdw_casadi.fit.driver.FitSolver.warm_start_of`), stored beside the atlas
    #: file (``<atlas>.warm.npz``) under ``warm_key``; None: none
    warm: WarmStart | None = None
    #: the FitOptions fields that shape that NLP (:func:`warm_key`) when it was solved
    warm_key: str = ""

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


def warm_key(opts: FitOptions) -> str:
    """The settings a stored warm start is valid for: those that shape the fit's NLP."""
    return (f"stride{opts.sample_stride}-{opts.stability_bound}{opts.stability_power}-"
            f"headroom{opts.segment_headroom_s:g}-slope{int(opts.free_slope)}")


def warm_path(atlas: Path) -> Path:
    """The file of an atlas's warm starts, beside it."""
    return atlas.with_suffix(".warm.npz")


def _load_warm(p: Path, entries: list[AtlasEntry]) -> None:
    wp = warm_path(p)
    if not wp.is_file():
        return
    with np.load(wp, allow_pickle=False) as z:
        for e in entries:
            if f"{e.label}/w" not in z:
                continue
            row = z[f"{e.label}/lam_row"]
            e.warm = WarmStart(z[f"{e.label}/w"], z[f"{e.label}/lam_w"],
                               z[f"{e.label}/lam_shooting"],
                               None if row.size == 0 else float(row[0]))
            e.warm_key = str(z[f"{e.label}/key"])


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
    entries = [AtlasEntry.from_dict(d) for d in data["entries"]]
    _load_warm(p, entries)
    return entries


def save_atlas(problem, entries: list[AtlasEntry], path: str | Path,
               warm_file: str | Path | None = None) -> Path:
    """Write the atlas ``entries`` to ``path`` (JSON) and their warm starts to
    ``warm_file`` (default: :func:`warm_path` of ``path``)."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps({"problem": problem.name,
                             "parameter_names": list(problem.parameter_names),
                             "state_names": list(problem.state_names),
                             "entries": [e.to_dict() for e in entries]}, indent=1))
    arrays = {}
    for e in entries:
        if e.warm is None:
            continue
        arrays.update({f"{e.label}/w": e.warm.w, f"{e.label}/lam_w": e.warm.lam_w,
                       f"{e.label}/lam_shooting": e.warm.lam_shooting,
                       f"{e.label}/lam_row": np.array([] if e.warm.lam_row is None
                                                      else [e.warm.lam_row]),
                       f"{e.label}/key": np.array(e.warm_key)})
    with open(Path(warm_file) if warm_file else warm_path(p), "wb") as f:
        np.savez_compressed(f, **arrays)
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
    h = human.resample(CYCLE_POINTS)

    def score(curves: pd.DataFrame) -> float:
        s = fit_scores(curves, h)
        return float(np.mean([s[f"r2_{t}"] for t in opts.targets()]))

    key = warm_key(opts)
    starts = [Start(f"atlas:{e.label}", e.state, e.parameters, score(e.curves),
                    e.spectral_radius, e.warm if e.warm_key == key else None)
              for e in entries]
    gait = own_gait(problem)
    if gait is not None:
        own.score, own.spectral_radius = score(gait[0]), gait[1]
        starts.append(own)
    return rank_starts(starts, opts.start_r2_tolerance)[: opts.multistart]
