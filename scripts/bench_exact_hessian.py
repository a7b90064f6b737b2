"""Experiment (docs/results/fit.md, "An exact Hessian without the stability row's
curvature"): `pdw-fit` with IPOPT given the exact Hessian of the Lagrangian of the shooting,
curve and knee-floor rows, the stability row's curvature left out (its Hessian needs third
derivatives of the dynamics).

The Hessian comes from a twin of each step NLP whose intervals are CasADi's symbolic
functions instead of the compiled ones (CasADi differentiates them twice), evaluated in
CasADi's virtual machine: seconds per iteration, so the experiment counts iterations, not
time. Usage: the arguments of `pdw-fit`, e.g.

    python scripts/bench_exact_hessian.py --gait female_fast.csv --out /tmp/exact
"""

from __future__ import annotations

import dataclasses
import sys
import time

import casadi as ca

from pdw_casadi.cli.scripts import fit
from pdw_casadi.fit import core, driver
from pdw_casadi.nlp.interval import _symbolic_once
from pdw_casadi.nlp.shooting import ShootingNLP

_INIT, _SOLVE, _NLP, _NLPSOL = (driver.FitSolver.__init__, driver.FitSolver.solve,
                                core.StepFit.nlp, driver.ca.nlpsol)
_CURRENT: list = [None]  # the Hessian of the solver being solved


class SymbolicShootingNLP(ShootingNLP):
    """The same NLP with symbolic intervals (twice differentiable by CasADi)."""

    def _interval(self, phase, n_sub):
        return _symbolic_once(self.hs, phase, n_sub)[0]


def step_nlp(self, x, p):
    nlp = _NLP(self, x, p)
    opts = self.opts
    headroom = max(opts.segment_headroom_s,
                   opts.timing_headroom_s if opts.timing_weight > 0 else 0.0)
    nlp.twin = SymbolicShootingNLP(self.problem, x, p, free=self.free,
                                   sample_stride=opts.sample_stride, hs=self.sim.hs,
                                   headroom_s=headroom)
    return nlp


def init(self, nlp, human, opts, *args, **kw):
    _INIT(self, nlp, human, opts, *args, **kw)
    t0 = time.perf_counter()
    # the twin's rows are this solver's rows without the stability row (always the last)
    twin = object.__new__(driver.FitSolver)
    _INIT(twin, nlp.twin, human,
          dataclasses.replace(opts, stability_constraint=False, jacobian="casadi"),
          knee_floor=kw.get("knee_floor"))
    x, p = ca.MX.sym("x", self.x.shape[0]), ca.MX.sym("p", self.p.size)
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", self.lbg.size)
    f, g = twin.nlp_fun(x, p)
    lagrangian = lam_f * f + ca.dot(lam_g[: twin.lbg.size], g)
    hess = ca.triu(ca.hessian(lagrangian, x)[0])
    self.exact_hessian = ca.Function("exact_hess_lag", [x, p, lam_f, lam_g], [hess],
                                     ["x", "p", "lam_f", "lam_g"], ["hess_lag"])
    print(f"exact Hessian built in {time.perf_counter() - t0:.1f} s, {hess.nnz()} entries",
          flush=True)


def solve(self, *args, **kw):
    _CURRENT[0] = self.exact_hessian
    try:
        return _SOLVE(self, *args, **kw)
    finally:
        _CURRENT[0] = None


def nlpsol(name, plugin, nlp, opts):
    if _CURRENT[0] is not None:
        opts = {**opts, "hess_lag": _CURRENT[0],
                "ipopt": {**opts["ipopt"], "hessian_approximation": "exact"}}
    return _NLPSOL(name, plugin, nlp, opts)


if __name__ == "__main__":
    driver.FitSolver.__init__, driver.FitSolver.solve = init, solve
    core.StepFit.nlp, driver.ca.nlpsol = step_nlp, nlpsol
    sys.argv = ["pdw-fit", *sys.argv[1:]]
    fit()
