"""The kinematic guess of a step from human curves (pdw_casadi.gait.kinematic): every
posture holds its phase's contacts, every velocity keeps them at rest, a guard on the posture
alone is met where its phase ends, a phase begins where the last one ended, and in single
support the joint angles are the human curves'."""

from __future__ import annotations

import numpy as np
import pytest

from pdw_casadi.gait.curves import cycle_time
from pdw_casadi.gait.kinematic import GuessPhase, KinematicGuess, kinematic_guess
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.hybrid import GUARD

N_NODES = 15


@pytest.fixture(scope="module")
def guess(problem, hs, params):
    """The guess of the bundled walker's pattern (phase I to toe off, II to heel strike,
    III to foot strike) with human-like durations (s) from the bundled female_fast.csv."""
    human = load_gait_curves("female_fast.csv")
    phases = [GuessPhase("I", 0.06, N_NODES, "toe_off"),
              GuessPhase("II", 0.55, N_NODES, "heel_strike"),
              GuessPhase("III", 0.06, N_NODES, "foot_strike")]
    q0 = hs.section_to_full(problem.state_vector(), params).full().ravel()
    return human, phases, q0, kinematic_guess(hs, params, human, phases, q0)


def test_every_posture_holds_its_phases_contacts_and_every_velocity_keeps_them(
        hs, params, guess):
    """Each phase's contact rows keep their value at the phase's first instant (the first
    phase: the section state's, feet on the ground) at every instant to 1e-9 (m, rad), and
    the velocities lie in the contacts' null space to 1e-9."""
    _, phases, q0, nodes = guess
    kg = KinematicGuess(hs)
    nq = hs.nq
    for k, (ph, X) in enumerate(zip(phases, nodes, strict=True)):
        assert X.shape == (hs.nx, ph.n_nodes)
        fun = kg.contacts(ph.phase)
        c0 = fun(q0[:nq] if k == 0 else X[:nq, 0], params)[0].full().ravel()
        for j in range(ph.n_nodes):
            c, J = (a.full() for a in fun(X[:nq, j], params))
            assert np.max(np.abs(c.ravel() - c0)) < 1e-9, (ph.phase, j)
            assert np.max(np.abs(J @ X[nq:2 * nq, j])) < 1e-9, (ph.phase, j)


def test_a_posture_guard_is_met_where_its_phase_ends_and_phases_join(hs, params, guess):
    """The heel strike and the foot strike (guards on the posture alone) are zero at their
    phase's last instant to 1e-9; toe off (a guard on a contact force) is left to the NLP;
    each phase after the first begins at the last one's final posture."""
    _, phases, _, nodes = guess
    nq = hs.nq
    m = np.array(hs.mode_vector(hs.model.initial_mode))
    for ph, X in zip(phases, nodes, strict=True):
        names = [e.name for e in hs.event_list[ph.phase]]
        i = names.index(ph.guard)
        assert hs.event_list[ph.phase][i].kind == GUARD
        g = float(hs.events[ph.phase](X[:, -1], params, m).full().ravel()[i])
        if ph.guard in ("heel_strike", "foot_strike"):
            assert abs(g) < 1e-9, ph.guard
    for a, b in zip(nodes, nodes[1:], strict=False):
        np.testing.assert_array_equal(b[:nq, 0], a[:nq, -1])


def test_in_single_support_the_joint_angles_are_the_human_curves(hs, params, guess):
    """In phase II (the stance foot flat, both legs' knee and thigh free) the walker's own
    knee and thigh outputs at the instants before the heel strike's equal the human curves
    at each leg's point of the cycle up to the pull's bias: the pull (1e-2) times what an
    angle moves between instants, twice over (an angle is the sum or difference of at most
    two coordinates)."""
    human, phases, _, nodes = guess
    T = sum(ph.duration for ph in phases)
    t_hs = sum(ph.duration for ph in phases[:2])
    t0 = phases[0].duration
    names = hs.output_names["II"]
    m = np.array(hs.mode_vector(hs.model.initial_mode))
    X = nodes[1]
    worst, moved, last = 0.0, 0.0, None
    for j in range(1, N_NODES - 1):
        t = t0 + j * phases[1].duration / (N_NODES - 1)
        out = hs.outputs["II"](X[:, j], params, m).full().ravel()
        wants = []
        for stem, curve in (("knee", human.knee_deg), ("thigh", human.thigh_deg)):
            for leg in (1, 2):
                pct = 100 * cycle_time(t, leg, T, t_hs, False) / (2 * T)
                want = np.interp(pct % 100, human.cycle_pct, curve, period=100)
                worst = max(worst, abs(out[names.index(f"{stem}{leg}_deg")] - want))
                wants.append(want)
        if last is not None:
            moved = max(moved, np.max(np.abs(np.subtract(wants, last))))
        last = wants
    assert worst <= 2 * KinematicGuess(hs).pull * moved
    assert worst < 0.5  # the curves, not merely near them


def test_a_guess_needs_the_curves_and_a_pattern_the_walker_has(hs, params, problem):
    """A pattern with a phase the walker lacks, a phase of one instant, a guard its phase
    lacks, no heel-strike phase, or curves without a target's column is refused with its
    reason."""
    human = load_gait_curves("female_fast.csv")
    q0 = hs.section_to_full(problem.state_vector(), params).full().ravel()
    with pytest.raises(ValueError, match="at least 2 instants"):
        kinematic_guess(hs, params, human, [GuessPhase("II", 0.5, 1)], q0)
    with pytest.raises(ValueError, match="no event 'heel_off'"):
        kinematic_guess(hs, params, human, [GuessPhase("II", 0.5, 5, "heel_off"),
                                            GuessPhase("III", 0.05, 5)], q0)
    with pytest.raises(ValueError, match="no heel-strike phase"):
        kinematic_guess(hs, params, human, [GuessPhase("II", 0.5, 5)], q0)
    with pytest.raises(ValueError, match="no phase 'IV'"):
        kinematic_guess(hs, params, human, [GuessPhase("IV", 0.5, 5)], q0)
    frame = human.to_frame().drop(columns=["thigh_mean_deg", "thigh_sd_deg"], errors="ignore")
    no_thigh = type(human)(frame, human.source, human.name)
    with pytest.raises(ValueError, match="no thigh_deg"):
        kinematic_guess(hs, params, no_thigh, [GuessPhase("II", 0.5, 5),
                                               GuessPhase("III", 0.05, 5)], q0)


def test_a_prescribed_pattern_read_off_the_guess(problem, hs, params):
    """pattern_from_guess cuts the prescribed phases at the switches the guess crosses: the
    phases come in the prescribed order, each ends on its guard with the walker's
    transition, a phase's segments last its duration (to 1e-12 s), each segment's first
    node is the last one's final posture, every mode flag agrees with the sign of its
    event at the segment's first node (where that sign is clear), and the NLP of the
    pattern is built on it (its unknowns at the start are the nodes)."""
    from pdw_casadi.gait.simulate import Simulator
    from pdw_casadi.nlp.pattern import pattern_from_guess
    from pdw_casadi.nlp.shooting import ShootingNLP

    human = load_gait_curves("female_fast.csv")
    phases = [GuessPhase("I", 0.06, 0, "toe_off"), GuessPhase("II", 0.55, 0, "heel_strike"),
              GuessPhase("III", 0.06, 0, "foot_strike")]
    q0 = hs.section_to_full(problem.state_vector(), params).full().ravel()
    h = Simulator(problem, hs).h
    specs, nodes = pattern_from_guess(hs, params, human, phases, q0, h)
    assert [s.phase for s in specs][0] == "I" and specs[-1].phase == "III"
    order = [s.phase for s in specs]
    assert [ph for i, ph in enumerate(order) if i == 0 or order[i - 1] != ph] == \
        ["I", "II", "III"]
    nq = hs.nq
    for ph in phases:
        mine = [s for s in specs if s.phase == ph.phase]
        assert abs(sum(s.duration0 for s in mine) - ph.duration) < 1e-12
        last = mine[-1]
        assert hs.event_list[ph.phase][last.event].name == ph.guard
        assert last.transition == hs.transitions[(ph.phase, ph.guard)].name
        assert all(s.transition is None for s in mine[:-1])
    for a, b in zip(nodes, nodes[1:], strict=False):
        np.testing.assert_array_equal(b[:nq, 0], a[:nq, -1])
    for s, X in zip(specs, nodes, strict=True):
        mode = dict(zip(hs.mode_keys, s.mode, strict=True))
        g = hs.events[s.phase].np(X[:, 0], params, s.mode).ravel()
        scale = np.abs(hs.events[s.phase].np(X[:, -1], params, s.mode).ravel()) + 1e-3
        for i, ev in enumerate(hs.event_list[s.phase]):
            if ev.indicator and abs(g[i]) > 1e-2 * scale[i]:
                assert mode[ev.indicator] == (1.0 if g[i] > 0 else 0.0), (s.phase, ev.name)
    xs = hs.full_to_section(nodes[0][:, 0]).full().ravel()
    ShootingNLP(problem, xs, params, segments=specs, nodes=nodes)  # the walker takes it


def test_the_pattern_of_the_walkers_own_curves_is_its_simulated_pattern(problem, hs):
    """Given the walker's own gait as the curves (its fixed point's knee, hip and thigh over
    the cycle) and its phases' durations, the pattern read off the guess switches as the
    simulator did: the same switch events in the same order, each within one point of the
    curves (1 % of the cycle: between their points the curves, and so the guess's rates,
    are linear)."""
    import pandas as pd

    from pdw_casadi.gait.curves import gait_cycle
    from pdw_casadi.gait.fixed_point import find_fixed_point
    from pdw_casadi.gait.simulate import Segment, Simulator
    from pdw_casadi.model.gait_data import GaitCurves
    from pdw_casadi.nlp.pattern import pattern_from_guess

    fp = find_fixed_point(problem)
    sim = Simulator(problem, hs)
    run = sim.run(fp.state, fp.parameters, steps=1, record=True)
    cycle = gait_cycle(run.trajectory.to_frame() if hasattr(run.trajectory, "to_frame")
                       else run.trajectory, hs.model.heel_strike_phase)
    curves = GaitCurves(pd.DataFrame({"cycle_pct": cycle["cycle_pct"],
                                      **{f"{c}_mean_deg": cycle[f"{c}_deg"]
                                         for c in ("knee", "hip", "thigh")}}),
                        "own.csv", "own")
    simulated, phases, t = [], [], 0.0
    for it in run.steps[0].plan.items:
        if not isinstance(it, Segment):
            continue
        ev = hs.event_list[it.phase][it.event]
        t += it.n * it.h + it.tau
        if ev.kind == GUARD:
            start = sum(ph.duration for ph in phases)
            phases.append(GuessPhase(it.phase, t - start, 0, ev.name))
        else:
            simulated.append((ev.name, t))
    q0 = hs.section_to_full(fp.state, fp.parameters).full().ravel()
    specs, _ = pattern_from_guess(hs, fp.parameters, curves, phases, q0, sim.h)
    found, t = [], 0.0
    for s in specs:
        t += s.duration0
        if s.transition is None:
            found.append((hs.event_list[s.phase][s.event].name, t))
    assert [n for n, _ in found] == [n for n, _ in simulated]
    spacing = 2 * sum(ph.duration for ph in phases) / (len(curves.cycle_pct) - 1)
    assert max(abs(a - b) for (_, a), (_, b) in zip(found, simulated, strict=True)) < spacing
