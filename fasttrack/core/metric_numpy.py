"""OSPA in NumPy, for a process's first small calls (see :func:`fasttrack._jit.numpy_first`):
the rules, arguments and outputs of ``fasttrack._jit.assign.ospa_steps``, each step's pairs
from SciPy's ``linear_sum_assignment`` (whose choices, ties included, the kernels'
solver reproduces) and its sums added in the kernel's order."""
import numpy as np

from .mixture_numpy import ordered_sum


def ospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, p, stonesoup, out):
    """:func:`fasttrack._jit.assign.ospa_steps`."""
    for k in range(truth_offsets.size - 1):
        out[k] = _ospa_step(truths[truth_offsets[k]:truth_offsets[k + 1]],
                            estimates[estimate_offsets[k]:estimate_offsets[k + 1]], c, p,
                            stonesoup)


def _ospa_step(truths, estimates, c, p, stonesoup):
    n, m = truths.shape[0], estimates.shape[0]
    big = max(n, m)
    if big == 0:
        return 0.0
    if p == np.inf:
        if n != m:
            return c
        if stonesoup:  # Stone Soup minimises the sum, then takes the largest pair
            cost = _capped_costs(estimates, truths, c, 1.0)
            return float(cost[_pairs(cost)].max())
        return _bottleneck(_capped_costs(truths, estimates, c, 1.0))
    if stonesoup:  # Stone Soup: the square matrix of min(d, c) padded with c, then ^p
        cost = np.full((big, big), c)
        d = np.sqrt(_squared_distances(estimates, truths))
        cost[:m, :n] = np.where(d < c, d, c)
        total = ordered_sum(_power(cost[_pairs(cost)], p))
        return ((1.0 / big) * total) ** (1.0 / p)
    small = min(n, m)
    total = (big - small) * _power(c, p)
    if small > 0:
        cost = _capped_costs(truths, estimates, c, p) if n <= m else _capped_costs(
            estimates, truths, c, p)
        total = ordered_sum(np.r_[total, cost[_pairs(cost)]])
    return (total / big) ** (1.0 / p)


def _pairs(cost):
    """The optimal assignment of a (rows <= columns) ``cost`` as an index pair."""
    from scipy.optimize import linear_sum_assignment
    return linear_sum_assignment(cost)


def _squared_distances(rows, cols):
    """(len(rows), len(cols)) squared Euclidean distances, summed along the dimensions in
    order."""
    d2 = np.zeros((rows.shape[0], cols.shape[0]))
    for k in range(rows.shape[1]):
        delta = rows[:, None, k] - cols[None, :, k]
        d2 = d2 + delta * delta
    return d2


def _power(x, p):
    """``x ** p`` as the kernel computes it (no power for p = 1 or 2)."""
    if p == 1.0:
        return x
    if p == 2.0:
        return x * x
    return x ** p


def _capped_costs(rows, cols, c, p):
    """``min(|rows[i] - cols[j]|, c) ** p`` (the kernel's: a squared distance at or above
    ``c * c`` gives the cut-off without a root)."""
    d2 = _squared_distances(rows, cols)
    d = np.sqrt(d2)
    cut = _power(c, p)
    return np.where((d2 < c * c) & (d < c), _power(d, p), cut)


def _bottleneck(cost):
    """The smallest largest entry over the complete assignments of a square ``cost``
    (the kernel's bisection over the sorted entries)."""
    from scipy.optimize import linear_sum_assignment
    values = cost.ravel()
    order = np.argsort(values, kind="stable")
    lo, hi = 0, values.size - 1
    while lo < hi:
        mid = (lo + hi) // 2
        try:
            linear_sum_assignment(np.where(cost <= values[order[mid]], 0.0, np.inf))
            hi = mid
        except ValueError:  # no complete assignment within the bound
            lo = mid + 1
    return float(values[order[hi]])
