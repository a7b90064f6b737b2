"""IPOPT multipliers of one multiple-shooting NLP carried onto another of the same gait
pattern: a stride's from one step's (each step takes the step's rows), a homotopy step's
from the last one's; blocks of rows are matched by name, and a block of another size (the
NLPs were built from gaits whose segments have other numbers of shooting intervals) is
resampled along its segment."""

from __future__ import annotations

import re

import numpy as np

#: IPOPT's options of a warm start from a kept point with its multipliers: the point is
#: taken as it is (tiny bound pushes) and the barrier starts small, so that the solve does
#: not leave the point it starts from
WARM_IPOPT = {"warm_start_init_point": "yes", "warm_start_bound_push": 1e-9,
              "warm_start_bound_frac": 1e-9, "warm_start_slack_bound_push": 1e-9,
              "warm_start_slack_bound_frac": 1e-9, "warm_start_mult_bound_push": 1e-9,
              "mu_init": 1e-6}

SEGMENT_ROW = re.compile(r"^(\w+)\[(\d+)\](.*)$")


def row_key(name: str, n_segments: int) -> str:
    """A shooting row's name with its segment index taken modulo the step's segments and a
    later step's section rows named as the first step's: the name of the same row in a
    one-step NLP (``step_link[i]``, the leg swap into step i, is the one-step NLP's
    ``periodicity``)."""
    m = SEGMENT_ROW.match(name)
    if m is None:
        return name
    word, k, rest = m.group(1), int(m.group(2)), m.group(3)
    if word == "section":
        return "section"
    if word == "step_link":
        return "periodicity"
    return f"{word}[{k % n_segments}]{rest}"


def blocks(names) -> list[tuple[str, int, int]]:
    """Runs of equal names: (name, first row, rows)."""
    out, i = [], 0
    names = list(names)
    while i < len(names):
        j = i
        while j < len(names) and names[j] == names[i]:
            j += 1
        out.append((names[i], i, j - i))
        i = j
    return out


def resample_block(lam: np.ndarray, n_out: int, width: int, density: bool) -> np.ndarray:
    """A block of multipliers of rows along a segment (``lam``: points of ``width`` rows
    each, in time order, e.g. a continuity block's nodes of nx rows) on ``n_out`` rows of
    another grid of the same segment: each component interpolated linearly in the
    fraction of the segment (point k of n at (k + 1) / n). ``density``: inequality rows
    at samples, whose multipliers sum over the segment (a finer grid shares them out: the
    values scale by the ratio of point counts); else rows whose multipliers are values of
    a function of time (the continuity rows' costates), kept as they are."""
    lam = np.asarray(lam, float)
    n_in = lam.size // width
    n_pts = n_out // width
    if n_in * width != lam.size or n_pts * width != n_out or n_in == 0 or n_pts == 0:
        return np.zeros(n_out)
    src = lam.reshape(n_in, width)
    t_in = np.arange(1, n_in + 1) / n_in
    t_out = np.arange(1, n_pts + 1) / n_pts
    out = np.column_stack([np.interp(t_out, t_in, src[:, c]) for c in range(width)])
    if density:
        out *= n_in / n_pts
    return out.ravel()


def map_multipliers(one_step_rows, lam, stride_rows, nx: int = 1) -> tuple[np.ndarray,
                                                                           int]:
    """The multipliers of a stride NLP's shooting rows (names ``stride_rows``) from those
    ``lam`` of a one-step NLP of a symmetric gait (names ``one_step_rows``): every block of
    rows of a step takes the multipliers of the same block of the one step (by
    :func:`row_key`; a block that appears in both steps takes them twice). At a symmetric
    gait each step carries one leg's gait cycle, as the one step carries the cycle once,
    so the step's rows keep the one step's multipliers. A block of another row count (the
    one-step NLP was built from the gait its fit started at, with other numbers of shooting
    intervals per segment) is resampled along its segment (:func:`resample_block`: the
    continuity rows' ``nx`` states per node as values, the sign and margin rows at the
    samples as shares). Returns (multipliers, rows that got one)."""
    src = blocks(one_step_rows)
    n_seg = 1 + max((int(m.group(2)) for m in map(SEGMENT_ROW.match, one_step_rows)
                     if m and m.group(1) == "continuity"), default=0)
    lam = np.asarray(lam, float)
    by_key: dict[str, list[tuple[int, int]]] = {}
    for name, i, n in src:
        by_key.setdefault(row_key(name, n_seg), []).append((i, n))
    out = np.zeros(len(stride_rows))
    seen: dict[str, int] = {}
    mapped = 0
    for name, i, n in blocks(stride_rows):
        key = row_key(name, n_seg)
        occ = seen.get(key, 0)
        seen[key] = occ + 1
        cands = by_key.get(key)
        if not cands:
            continue
        j, m = cands[occ % len(cands)]
        if m == n:
            out[i: i + n] = lam[j: j + n]
            mapped += n
        elif key.startswith(("continuity[", "sign[", "margin[")):
            cont = key.startswith("continuity[")
            out[i: i + n] = resample_block(lam[j: j + m], n, nx if cont else 1,
                                           density=not cont)
            mapped += n
    return out, mapped


def bound_multipliers(lam_w, free, scale, n_segments: int, nlp, source=None,
                      weight=None) -> np.ndarray:
    """The bound multipliers of ``nlp``'s unknowns (a
    :class:`~pdw_casadi.nlp.shooting.ShootingNLP`: section state,
    free parameters, durations, nodes, ...) from those ``lam_w`` of another shooting NLP of
    the same section state, whose free parameters were ``free`` with scales ``scale`` and
    whose segments were ``n_segments``: each free parameter's from the one named
    ``source(name)`` (default: the same name), rescaled to this NLP's scale (the unknowns
    are p / scale) and times ``weight(name)`` (default 1); segment k's duration from
    segment k modulo ``n_segments``; the rest (unbounded) 0."""
    lam_w = np.asarray(lam_w, float)
    out = np.zeros(nlp.w.shape[0])
    ns = nlp.xs.shape[0]
    for j, name in enumerate(nlp.free):
        src = source(name) if source is not None else name
        if src in free:
            i = list(free).index(src)
            out[ns + j] = lam_w[ns + i] * nlp.p_scale[j] / scale[i] * \
                (weight(name) if weight is not None else 1.0)
    o, o_src = ns + len(nlp.free), ns + len(free)
    for k in range(len(nlp.specs)):
        out[o + k] = lam_w[o_src + k % n_segments]
    return out


__all__ = ["SEGMENT_ROW", "WARM_IPOPT", "blocks", "bound_multipliers", "map_multipliers",
           "resample_block", "row_key"]
