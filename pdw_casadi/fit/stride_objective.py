"""The per-leg curve objective on the stride NLP: 1 - R^2 of each leg against its side's curves.

A stride (:meth:`~pdw_casadi.nlp.shooting.ShootingNLP.stride`) is two steps, the left leg in
stance in step 0 (it is leg 1 there, leg 2 in step 1), the right leg in step 1. Each
physical leg's gait cycle runs from its own heel strike to its next one: its heel strikes
in the step before its stance step (at the start of that step's heel-strike phase, where it
is the swing leg), so the left leg's cycle starts in step 1 and wraps through step 0, the
right leg's starts in step 0. With the stride time S and that heel strike at t0 (s from the
stride's start), a sample at t lies at cycle percentage 100 (t - t0) / S after it and
100 (S - t0 + t) / S before it. Point-foot walkers (no heel-strike phase) begin each step
at the stance leg's heel strike: t0 is the start of the leg's stance step.

Each leg's cycle points are interpolated like the one-step fit (:mod:`.objective`), each of
its two steps' samples one part, so that at a symmetric gait and equal sides each leg's
error rows are the one-step NLP's.
"""

from __future__ import annotations

import casadi as ca

from pdw_casadi.engine.errors import CurveError
from pdw_casadi.fit.objective import TARGETS, interpolated_errors
from pdw_casadi.model.gait_data import SIDES


def side_targets(targets) -> tuple[str, ...]:
    """Objective keys of a stride fit: ``left.knee``, ``left.hip``, ``right.knee``, ..."""
    return tuple(f"{side}.{t}" for side in SIDES for t in targets)


def _check(nlp, sides, targets) -> None:
    names = set(nlp.output_names(nlp.specs[0].phase))
    for target in targets:
        if target not in TARGETS:
            raise CurveError(f"unknown fit target {target!r} (one of {', '.join(TARGETS)})")
        stem, column = TARGETS[target]
        for side in SIDES:
            if getattr(sides.side(side), column) is None:
                raise CurveError(f"the gait file has no {side} {column} column (needed for "
                                 f"{target})")
        missing = [f"{stem}{leg}_deg" for leg in (1, 2) if f"{stem}{leg}_deg" not in names]
        if missing:
            raise CurveError(f"walker {nlp.model.name!r} has no {target} outputs "
                             f"({', '.join(missing)}): it cannot be fitted to {target} curves")


def stride_curve_errors(nlp, sides, targets=("knee", "hip")) -> dict:
    """Per leg and target (``left.knee``, ...): (err, SS_tot), the model minus the side's
    human angle (deg) at its 101 cycle points (1 x 101 MX of the stride NLP's unknowns), so
    that sum err^2 / SS_tot is that leg's 1 - R^2 (:func:`pdw_casadi.gait.curves.r_squared`).
    ``sides``: :class:`~pdw_casadi.model.gait_data.SideCurves`."""
    if nlp.n_steps != 2:
        raise ValueError("stride_curve_errors needs a two-step (stride) NLP")
    _check(nlp, sides, targets)
    S = nlp.step_time
    specs = nlp.specs
    hs_phase = nlp.model.heel_strike_phase
    first = [next(k for k, s in enumerate(specs) if s.step == i) for i in (0, 1)]
    out = {}
    for i, side in enumerate(SIDES):  # side i is in stance in step i
        if hs_phase is None:
            k0 = first[i]
        else:  # its heel strike: the heel-strike phase of the other step
            k0 = next(k for k, s in enumerate(specs) if s.step == 1 - i and s.phase == hs_phase)
        t0 = nlp.t_start[k0]
        pct = {0: [], 1: []}
        for k, s in enumerate(specs):
            t = nlp.sample_t[k]
            c = t - t0 if k >= k0 else S - t0 + t
            pct[s.step].append(100 * c / S)
        pct = {j: ca.horzcat(*rows) for j, rows in pct.items()}

        def model(stem, i=i):
            # leg 1 (stance) in its own step, leg 2 (swing) in the other
            return {j: ca.horzcat(*[nlp.output(k, f"{stem}{1 if j == i else 2}_deg")
                                    for k, s in enumerate(specs) if s.step == j])
                    for j in (0, 1)}

        errs = interpolated_errors(nlp, pct, model, sides.side(side), targets)
        out.update({f"{side}.{t}": v for t, v in errs.items()})
    return out
