"""Mirrors of ``fasttrack._jit.metric``: GOSPA and OSPA from their definitions with SciPy's
pairs, the costs ``(min(d, c) / unit) ** p`` built with NumPy."""
import numpy as np


def _capped(rows, cols, c, unit):
    """min(|rows[i] - cols[j]|, c) / unit for every pair (differences scaled before they
    are squared; a pair whose square overflows is at the cut-off)."""
    with np.errstate(over="ignore"):
        delta = (rows[:, None, :] - cols[None, :, :]) * (1.0 / unit)
        d = np.sqrt((delta * delta).sum(axis=-1))
    cap = c * (1.0 / unit)
    return np.where(d < cap, d, cap)


def _power(x, p):
    return x * x if p == 2.0 else x ** p


def gospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, unit, p, alpha,
                assignment, out):
    """GOSPA from its definition, step by step: scipy's pairs on (min(d, c) / unit)^p
    (truth rows), then (c / unit)^p / alpha per unassigned point; with alpha = 2 a pair at
    the cut-off is split into a missed truth and a false estimate. The distance is
    ``unit * total ** (1 / p)``, the parts stay in units of ``unit ** p``."""
    from scipy.optimize import linear_sum_assignment
    cut = _power(c * (1.0 / unit), p)
    dummy = cut / alpha
    for k in range(truth_offsets.size - 1):
        x = truths[truth_offsets[k]:truth_offsets[k + 1]]
        y = estimates[estimate_offsets[k]:estimate_offsets[k + 1]]
        n, m = len(x), len(y)
        pairs = np.full(n, -1)
        loc = missed = false = 0.0
        if n and m:
            cost = _power(_capped(x, y, c, unit), p)
            rows, cols = linear_sum_assignment(cost)
            pairs[rows] = cols
            at_cut = (cost[rows, cols] == cut) if alpha == 2 else np.zeros(len(rows), bool)
            loc = cost[rows, cols][~at_cut].sum()
            pairs[rows[at_cut]] = -1
            missed = dummy * (n - len(rows) + at_cut.sum())
            false = dummy * (m - len(rows) + at_cut.sum())
            total = cost[rows, cols].sum() + dummy * (n + m - 2 * len(rows))
        else:
            missed, false = dummy * n, dummy * m
            total = missed + false
        assignment[truth_offsets[k]:truth_offsets[k + 1]] = pairs
        out[k] = unit * total ** (1 / p), loc, missed, false


def _bottleneck(cost):
    """min over complete assignments of the largest entry: the least threshold at which
    scipy still finds an assignment."""
    from scipy.optimize import linear_sum_assignment
    for value in np.unique(cost):
        try:
            linear_sum_assignment(np.where(cost <= value, 0.0, np.inf))
        except ValueError:
            continue
        return value


def ospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, unit, p, stonesoup,
               out):
    """OSPA from its definition (or, with ``stonesoup``, Stone Soup 1.9.1's computation:
    the square matrix of min(d, c) padded with c, scipy's pairs on it, then the powers), in
    units of ``unit``, then back to the units of the points."""
    from scipy.optimize import linear_sum_assignment
    cap = c * (1.0 / unit)
    for k in range(truth_offsets.size - 1):
        x = truths[truth_offsets[k]:truth_offsets[k + 1]]
        y = estimates[estimate_offsets[k]:estimate_offsets[k + 1]]
        n, m = len(x), len(y)
        big = max(n, m)
        if big == 0:
            out[k] = 0.0
        elif p == np.inf:
            if n != m:
                out[k] = c
            elif stonesoup:
                cost = _capped(y, x, c, unit)
                out[k] = unit * cost[linear_sum_assignment(cost)].max()
            else:
                out[k] = unit * _bottleneck(_capped(x, y, c, unit))
        elif stonesoup:
            cost = np.full((big, big), cap)
            cost[:m, :n] = _capped(y, x, c, unit)
            out[k] = unit * ((1 / big) * np.sum(_power(cost[linear_sum_assignment(cost)], p))
                             ) ** (1 / p)
        else:
            cost = _power(_capped(x, y, c, unit), p)
            total = cost[linear_sum_assignment(cost)].sum() + _power(cap, p) * (big - min(n, m))
            out[k] = unit * (total / big) ** (1 / p)
