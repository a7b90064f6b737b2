"""Build a walker's gait atlas: stable, valid interior fixed points to start fits from.

- **Own seeds**: the stable gait (simulator rho <= ``radius``) whose knee and hip curves are
  closest (R^2) to those of the problem's own gait, or to a deformation of them (knee
  amplitude, hip offset: :data:`VARIANTS`), found by the fit itself with those curves as
  the target; a smaller ``radius`` gives a seed further inside the stable region.
- **Cohort seeds** (``--curves``): the fitted gait of each given human curve file (the shipped
  atlas: the bundled cohort mean ``female_fast.csv``), at each ``radius``. A fit of other
  curves of a similar gait then starts inside the stable region, near its answer.
(Natural-parameter continuation from these seeds, one compliance value at a time, finds
no further points for the 6-link walker: Newton does not converge even 2 % away, where the
NLP does; so the entries come from the NLP.)

Entries are stored with their curves, so a fit can rank them on the user's curves.

    pdw-atlas --problem humanlike_6link --curves female_fast.csv
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from pdw_casadi.fit.core import StepFit, fit_gait
from pdw_casadi.fit.driver import WarmStart
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.starts import AtlasEntry, own_gait, warm_key
from pdw_casadi.model.gait_data import GaitCurves

#: deformations of the walker's own curves that the variants are fitted to:
#: (label, knee amplitude factor about its mean, hip offset in deg)
VARIANTS = (("own", 1.0, 0.0), ("knee0.85", 0.85, 0.0), ("knee1.15", 1.15, 0.0),
            ("hip-4", 1.0, -4.0), ("hip+4", 1.0, 4.0))
#: stability levels of the seeds: the fit's accepted spectral radius
#: (FitOptions.max_radius) and one further inside the stable region
RADII = (FitOptions.max_radius, 0.86)


def _target(c: pd.DataFrame, knee: float, hip: float, name: str) -> GaitCurves:
    """The curves ``c`` with the knee amplitude scaled about its mean and the hip offset."""
    kd = c.knee_deg.to_numpy()
    frame = pd.DataFrame({"cycle_pct": c.cycle_pct, "hip_mean_deg": c.hip_deg + hip,
                          "knee_mean_deg": kd.mean() + knee * (kd - kd.mean()),
                          "thigh_mean_deg": c.thigh_deg + hip})
    return GaitCurves(frame, Path(f"<{name}>"), name)


def user_options() -> FitOptions:
    """The options of the fits an atlas serves (``pdw-fit``'s defaults): its warm starts
    are solutions of their NLP."""
    return FitOptions(verbose=False)


def warm_start_at(problem, target: GaitCurves, cand, opts: FitOptions) -> WarmStart | None:
    """The solution and multipliers of ``opts``'s NLP built at the fitted gait ``cand``
    for the curves ``target`` (what a later fit starting at that gait is warm started
    from), or None when that solve does not converge."""
    fit = StepFit(problem, target, opts, 0, "atlas", cand.fixed_point.spectral_radius,
                  log=lambda m: None)
    nlp = fit.nlp(cand.state, cand.parameters)
    solver = fit.solver(nlp)
    out = solver.solve(nlp.w0)
    return solver.warm_start_of(out) if out["success"] else None


def build_atlas(problem, radii=RADII, variants=VARIANTS[:1],
                curves: tuple[GaitCurves, ...] = (), log=print) -> list[AtlasEntry]:
    """The seeds: per target (the walker's own curves and their ``variants``, then each of
    ``curves``) and stability level in ``radii``, the stable gait closest to the target (see
    the module docstring)."""
    gait = own_gait(problem)
    if gait is None:
        raise ValueError(f"{problem.name}: its own parameters have no gait")
    c = gait[0]
    targets = [_target(c, knee, hip, name) for name, knee, hip in variants] + list(curves)
    entries = []
    for target, r in ((t, r) for t in targets for r in radii):
        name = target.name
        opts = FitOptions(max_radius=r, atlas="", verbose=False, knee_floor=None)
        res = fit_gait(problem, target, opts, log=lambda m: None)
        b = res.best
        if b is None:
            log(f"radius {r}: no stable valid gait ({res.notes})")
            continue
        label = f"{problem.name}-{name}-rho{r:.2f}"
        entry = AtlasEntry(label, b.state, b.parameters, b.fixed_point.spectral_radius,
                           b.curves)
        entry.warm, entry.warm_key = warm_start_at(problem, target, b, user_options()), \
            warm_key(user_options())
        entries.append(entry)
        log(f"{label}: rho {b.fixed_point.spectral_radius:.4f}, R^2 to its target knee "
            f"{b.scores['r2_knee']:.4f} hip {b.scores['r2_hip']:.4f}")
    return entries
