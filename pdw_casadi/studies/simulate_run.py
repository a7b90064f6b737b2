"""The simulation workflow: everything ``pdw-simulate`` computes, returned as data for the report.

:func:`run_simulation` simulates steps of a walker from its section state on the map the
command works on (:func:`command_map`: the stride, its parameters alternating with the
stance leg, when the legs differ, else the step map) and returns a :class:`SimulationRun`:
the simulator, the parameters of each step, the recorded result, the walker's faces and the
``summary.json`` content (:func:`simulation_summary`). The report layer
(:mod:`pdw_casadi.report.simulate_report`) only renders it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.stride import period_steps, stride_simulator
from pdw_casadi.gait.timing import simulation_timing, timing_or_none
from pdw_casadi.model.faces import WalkerFaces, walker_faces
from pdw_casadi.model.problem import Problem


@dataclass
class SimulationRun:
    """A simulation and what its report shows (:func:`run_simulation`)."""

    problem: Problem
    #: the simulator (its walker ``sim.hs`` gives the units and the drawings)
    sim: Simulator
    #: the parameters of the first step (compliance and slope in SI units)
    parameters: np.ndarray
    #: the parameters of each step of a stride (None: one set for every step)
    parameter_steps: list[np.ndarray] | None
    #: the recorded simulation (trajectory, events, steps, failure)
    result: Any
    faces: WalkerFaces
    #: the summary.json content (SI units; :func:`simulation_summary`)
    summary: dict

    @property
    def divergence(self) -> str | None:
        """Why the simulation diverged numerically (one line; None: it did not)."""
        return divergence(self.result)


def command_map(problem: Problem, stride: bool = False) -> PoincareMap:
    """The periodic map a command works on: the stride (two steps, the parameters following
    the physical legs) with ``stride`` or when the legs differ, else the step map
    (:class:`~pdw_casadi.gait.poincare.PoincareMap`)."""
    return PoincareMap(problem, steps=2 if stride else period_steps(problem))


def simulation_summary(problem: Problem, result, steps_requested: int | None = None) -> dict:
    """The summary.json content of a simulation (SI units: times in s, lengths in m, speed
    in m/s, energies in J, states in rad and rad/s; timing per step and per cycle of two
    steps: :mod:`pdw_casadi.gait.timing`)."""
    names = list(problem.state_names)
    done = [s for s in result.steps if s.x_section_end is not None]
    first = done[0] if done else None
    poincare = [dict(zip(names, map(float, row), strict=True))
                for row in np.atleast_2d(result.poincare_states) if len(row)]
    residual = None
    if first is not None:
        residual = float(np.linalg.norm(first.x_section_end - first.x_section_start))
    energy = [float(s.energy_residual_J) for s in done]
    margins: dict[str, float] = {}
    for s in result.steps:
        for k, v in s.margins.items():
            margins[k] = min(float(v), margins.get(k, math.inf))
    step_time = first.step_time if first else None
    step_length = first.step_length if first else None
    speed = step_length / step_time if first and step_time else None
    return {
        "problem": {"name": problem.name, "family": problem.family,
                    "source": problem.source, "title": problem.title},
        "slope": problem.slope,
        "compliance": dict(problem.compliance),
        "initial_state": dict(problem.initial_state),
        "steps_requested": steps_requested,
        "completed_steps": len(done),
        "phases": [[{"name": n, "duration_s": d} for n, d in s.phases] for s in result.steps],
        "step_time_s": step_time,
        "step_length_m": step_length,
        "speed_m_s": speed,
        "poincare_states": poincare,
        "residual": residual,
        "energy_balance_J": energy,
        "energy_balance_max_abs_J": max((abs(e) for e in energy), default=None),
        "failure": result.failure.to_dict() if result.failure else None,
        "steps": [s.to_dict() for s in result.steps],
        "margins": margins,
        "timing": timing_or_none(lambda: simulation_timing(problem.family, result)),
    }


def divergence(result) -> str | None:
    """One line on a numerical divergence of ``result`` (step, phase, time in s, detail);
    None when it stopped otherwise or not at all."""
    f = result.failure
    if f is not None and f.reason == "numerical_divergence":
        return (f"numerical divergence in step {f.step}, phase {f.phase}, at t = "
                f"{f.time:.4f} s: {f.detail}")
    return None


def simulation_setup(problem: Problem) -> tuple[Simulator, np.ndarray, list[np.ndarray] | None,
                                                 WalkerFaces]:
    """The simulator of ``problem`` on its command map (legs that differ: the parameters
    alternate with the stance leg), the first step's parameters, each step's (or None)
    and the walker's faces."""
    pmap = command_map(problem)
    sim, p_steps = stride_simulator(pmap) if pmap.steps > 1 else (pmap.sim, None)
    faces = walker_faces(problem, sim.hs)
    p = p_steps[0] if p_steps else problem.parameter_vector()
    return sim, p, p_steps, faces


def run_simulation(problem: Problem, steps: int, *, max_samples: int,
                   setup: tuple | None = None,
                   progress: Callable[[int], None] | None = None) -> SimulationRun:
    """Simulate ``steps`` steps of ``problem`` from its section state, recording the
    trajectory (at most ``max_samples`` samples); ``setup``: the result of
    :func:`simulation_setup` when the caller made it already; ``progress(k)`` is called
    with the number of steps done. A fall or a divergence is a result, not an error."""
    sim, p, p_steps, faces = setup or simulation_setup(problem)
    result = sim.run(problem.state_vector(), p, steps=steps, record=True,
                     progress=progress, max_samples=max_samples, p_steps=p_steps)
    return SimulationRun(problem=problem, sim=sim, parameters=p, parameter_steps=p_steps,
                         result=result, faces=faces,
                         summary=simulation_summary(problem, result, steps))
