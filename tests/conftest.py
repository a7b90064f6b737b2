"""Shared fixtures: the bundled problem, its hybrid system and one recorded Table-2 step.

The first use of the hybrid system compiles its CasADi functions to C (about 25 s, and as much
again for the Poincare sensitivities; cached in ``$PDW_CACHE`` or ``~/.cache/pdw_casadi``);
every later session reuses the cached libraries.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pandas as pd
import pytest

from pdw_casadi.gait.simulate import simulate
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.system import hybrid_system

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "scripts"


@pytest.fixture(scope="session")
def problem():
    """The bundled humanlike 6-link problem: Table 1 body, Table 3 compliance, slope 0.1484,
    Table 2 section state."""
    return load_problem("humanlike_6link")


@pytest.fixture(scope="session")
def hs(problem):
    return hybrid_system(problem)


@pytest.fixture(scope="session")
def params(problem) -> np.ndarray:
    """Parameter vector p = compliance (Table 3) + slope."""
    return problem.parameter_vector()


@pytest.fixture(scope="session")
def table2_step(problem):
    """One recorded step from the Table 2 state (SimulationResult)."""
    return simulate(problem, steps=1, record=True)


@pytest.fixture(scope="session")
def compass_steps():
    """Three recorded steps of the compass gait from its problem file: (problem, hybrid
    system, parameter vector, SimulationResult)."""
    from pdw_casadi.gait.simulate import Simulator

    pb = load_problem("compass_gait")
    sim = Simulator(pb)
    p = pb.parameter_vector()
    res = sim.run(pb.state_vector(), p, steps=3, record=True)
    assert res.failure is None
    return pb, sim.hs, p, res


@pytest.fixture(scope="session")
def numpy_walker():
    """The independent numpy/scipy implementation ``tests/numpy_walker.py`` (a module)."""
    import numpy_walker  # tests/ is on sys.path under pytest

    return numpy_walker


# -- helpers ---------------------------------------------------------------------------------
def full_states(hs, frame: pd.DataFrame) -> np.ndarray:
    """Full states x = [q; qd; W] (columns) of the trajectory rows in ``frame``."""
    names = list(hs.model.q_names)
    q = frame[names].to_numpy().T
    qd = frame[["d" + n for n in names]].to_numpy().T
    return np.vstack([q, qd, frame["damping_work_J"].to_numpy()[None, :]])


def phase_runs(frame: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """The trajectory split into contiguous runs of one phase, in time order.

    (Runs, not the ``step`` column: the state at a phase's final event belongs to that run.)
    """
    phase = frame["phase"].to_numpy()
    cuts = [0, *(np.flatnonzero(phase[1:] != phase[:-1]) + 1), len(phase)]
    return [(str(phase[a]), frame.iloc[a:b]) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]


@pytest.fixture(scope="session")
def contact_funs(hs):
    """phase -> CasADi function (x, p) -> (constraint rows eps(q), E(q) qd) of its contact set."""
    q, qd = hs.model.system.q, hs.model.system.qd
    x, p = hs.x_sym, hs.model.p
    out = {}
    for name, ph in hs.phases.items():
        rows = ph.contact.rows
        E = ca.jacobian(rows, q)
        out[name] = ca.Function(f"contact_{name}", [x, p],
                                [hs.subs_x(rows), hs.subs_x(ca.mtimes(E, qd))])
    return out


@pytest.fixture(scope="session")
def impact_states(hs, table2_step, params):
    """Pre-impact full states of the Table-2 step: {"heel_strike": x-, "foot_strike": x-}."""
    runs = dict(phase_runs(table2_step.trajectory))
    assert set(runs) == {"I", "II", "III"}
    return {tr.name: full_states(hs, runs[tr.source].iloc[[-1]])[:, 0]
            for tr in hs.model.transitions if tr.name != "toe_off"}


def run(capsys, main, args):
    """(exit code, stdout, stderr) of a command's main, SystemExit included."""
    try:
        code = main(args)
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def model_functions(model, head=None) -> ca.Function:
    """One SX function of (q, qd, p, m) with ``head`` (default: the generalised forces,
    spring energy and step length), every phase's dynamics, multipliers, events and outputs
    and every transition's post-impact velocities, impulses and checks: two models agree
    when these agree."""
    q, qd, p, m = model.system.q, model.system.qd, model.p, model.m
    outs = list(head) if head is not None else [model.F_q, model.spring_energy,
                                                 model.step_length]
    for ph in model.phases:
        outs += [ph.qdd, ph.lam, ca.vertcat(*[e.expr for e in ph.events]),
                 ca.vertcat(*ph.outputs.values())]
    for tr in model.transitions:
        outs += [tr.qd_plus, tr.impulse, ca.vertcat(*tr.checks.values())]
    return ca.Function("all", [q, qd, p, m], outs)
