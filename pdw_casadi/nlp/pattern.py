"""A prescribed gait pattern's shooting segments and nodes, from a kinematic guess.

The shooting NLP of a gait the simulator has not found
(:class:`~pdw_casadi.nlp.shooting.ShootingNLP` with ``segments`` and ``nodes``) needs the
pattern as the simulator would cut it: each phase split at the walker's mode switches (a
knee's rate changing sign, a knee spring engaging, a clutch), each segment with the mode it
runs in. :func:`pattern_from_guess` reads them off a kinematic guess
(:func:`~pdw_casadi.gait.kinematic.kinematic_guess`) of the prescribed phases: it walks the
guess on a fine grid, cuts a segment where an enabled switch changes sign (at the linear
interpolation of the crossing) and changes the mode there as the simulator does (the switch's
flag from its crossing direction, its effect, the flags read from the state), takes each
phase's transition at its ending guard (the mode after it, the flags read again), and builds
the guess again at every segment's shooting nodes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pdw_casadi.gait.kinematic import GUESS_TARGETS, GuessPhase, KinematicGuess, kinematic_guess
from pdw_casadi.model.hybrid import SWITCH
from pdw_casadi.nlp.shooting import N_SUB, SegmentSpec, shooting_intervals

#: instants per second of the fine grid the switches are located on (2 ms apart)
FINE_RATE_HZ = 500.0


def pattern_from_guess(hs, p, human, phases: Sequence[GuessPhase], q_start, h: float,
                       n_sub: int = N_SUB, targets: Sequence[str] = GUESS_TARGETS
                       ) -> tuple[list[SegmentSpec], list[np.ndarray]]:
    """The segments and their nodes (nx x (n_int + 1), SI) of one step of the walker ``hs``
    (parameters ``p``) along the prescribed ``phases`` (each ended by its ``guard``, whose
    transition the walker defines), guessed from the curves ``human`` from the posture
    ``q_start`` (module docstring). ``h`` (s): the simulator's RK4 step; a segment of
    duration d gets ceil(d / (n_sub h)) + 1 intervals, as a simulated gait's."""
    model = hs.model
    p = np.asarray(p, float).ravel()
    for ph in phases:
        if ph.guard is None or (ph.phase, ph.guard) not in hs.transitions:
            raise ValueError(f"phase {ph.phase}: no transition leaves it at "
                             f"{ph.guard!r}; name the guard that ends it")
    fine = [GuessPhase(ph.phase, ph.duration, max(3, math.ceil(ph.duration * FINE_RATE_HZ)),
                       ph.guard) for ph in phases]
    kg = KinematicGuess(hs, targets)  # its posture NLPs serve both passes
    guess = kinematic_guess(hs, p, human, fine, q_start, kg=kg)
    mode = dict(model.initial_mode)
    mode = hs.refresh_indicators(phases[0].phase, guess[0][:, 0], p, mode)
    cuts: list[tuple[str, tuple, int, str | None, float]] = []
    for ph, X in zip(fine, guess, strict=True):
        evs = hs.event_list[ph.phase]
        ts = np.linspace(0.0, ph.duration, ph.n_nodes)
        t_seg = 0.0
        for j in range(1, ph.n_nodes):
            handled: set[int] = set()
            last = 0.0
            while True:  # every switch crossed between the two instants, in time order
                mv = hs.mode_vector(mode)
                g0 = hs.events[ph.phase].np(X[:, j - 1], p, mv).ravel()
                g = hs.events[ph.phase].np(X[:, j], p, mv).ravel()
                frac = {i: g0[i] / (g0[i] - g[i]) for i, ev in enumerate(evs)
                        if i not in handled and ev.kind == SWITCH and ev.enabled(mode)
                        and g0[i] * g[i] < 0
                        and (ev.direction == 0 or np.sign(g[i]) == ev.direction)}
                frac = {i: f for i, f in frac.items() if f >= last}
                if not frac:
                    break
                # the first crossing (linear in between), then the mode it leaves
                i = min(frac, key=frac.get)
                last = frac[i]
                handled.add(i)
                t = ts[j - 1] + last * (ts[j] - ts[j - 1])
                if t > t_seg:
                    cuts.append((ph.phase, tuple(mv), i, None, t - t_seg))
                    t_seg = t
                mode = hs.mode_after_switch(ph.phase, i, 1.0 if g[i] > 0 else -1.0, X[:, j],
                                            p, mode)
        tr = hs.transitions[(ph.phase, ph.guard)]
        i_guard = [e.name for e in evs].index(ph.guard)
        cuts.append((ph.phase, tuple(hs.mode_vector(mode)), i_guard, tr.name,
                     ph.duration - t_seg))
        # the flags read right after the impact, as the simulator does
        x_plus = np.asarray(hs.impact_at(tr.name, X[:, -1], p).x_plus, float).ravel()
        mode = hs.mode_after_transition(tr, x_plus, p, mode)
        if isinstance(mode, str):
            raise ValueError(f"the guess breaks the walker's mode rule at {tr.name}: {mode}")
    # the guess again, at each segment's shooting nodes
    specs, layout = [], []
    for phase, mv, event, transition, duration in cuts:
        n_int = shooting_intervals(duration, n_sub, h)
        specs.append(SegmentSpec(phase, mv, event, transition, n_int, n_sub, duration))
        guard = hs.event_list[phase][event].name if transition is not None else None
        layout.append(GuessPhase(phase, duration, n_int + 1, guard))
    return specs, kinematic_guess(hs, p, human, layout, q_start, kg=kg)


__all__ = ["FINE_RATE_HZ", "pattern_from_guess"]
