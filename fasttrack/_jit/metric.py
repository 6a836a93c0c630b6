"""Metric kernels: GOSPA and OSPA at every step, on the optimal assignment of
:mod:`fasttrack._jit.assign`, computed in units of a power of two near the cut-off.

GOSPA (A. S. Rahmathullah, A. F. Garcia-Fernandez, L. Svensson, "Generalized optimal
sub-pattern assignment metric", 2017) between truths X (n points) and estimates Y (m points)
with cut-off c > 0, order 1 <= p < inf and 0 < alpha <= 2, for n <= m (symmetric
otherwise)::

    d = ( min over injections pi of  sum_i min(|x_i - y_pi(i)|, c)^p
          + c^p / alpha * (m - n) )^(1/p)

With alpha = 2 this equals the assignment form ``(localisation + missed + false)^(1/p)``:
pairs closer than c are localisation errors ``|x - y|^p``, a pair at the cut-off counts as a
missed truth plus a false estimate, each ``c^p / 2``, as in Stone Soup's ``GOSPAMetric``.
OSPA (Schuhmacher, Vo and Vo, 2008) is ``( (min sum min(d, c)^p + c^p |m - n|) / max(n, m)
)^(1/p)``, and for p = inf the smallest largest pair distance (c if n != m).

Units. ``c ** p`` and ``d ** p`` leave float64 for ordinary settings (``c = 10, p = 400``,
``c = 1e200, p = 2``; points 1e200 apart), and underflow to 0 for a small ``c``. The kernels
therefore take a ``unit`` u, a power of two with ``1 <= c / u < 2`` (see
:func:`fasttrack.core.metric.unit`), and work with ``min(d, c) / u``: each coordinate
difference is multiplied by ``1 / u`` before it is squared, so the costs lie in
``[0, (c / u)^p] <= 2^p`` and the cut-off costs ``(c / u)^p >= 1``; the distance is
``u * (sum)^(1/p)``. Multiplying by a power of two is exact (away from the subnormal
range), so for p = 1 and 2 every cost, the assignment and the distance are bit for bit those
of the unscaled formulas, and for other p they agree to rounding. A cost below float64's
smallest normal number (a distance below ``u * 2^(-1022 / p)``) counts as 0, which is why
:mod:`fasttrack.metrics` bounds p.
"""
import numpy as np
from numba import prange

from .assign import _bottleneck, _shortest_paths
from .dispatch import jit
from .tunables import SERIAL_BELOW_ASSIGN


@jit(strict=True)
def _power(x, p):
    """``x ** p``, without a call to ``pow`` for p = 1 or 2 (the same value wherever it is
    computed, so that a pair at the cut-off compares equal to the cut-off's cost)."""
    if p == 1.0:
        return x
    if p == 2.0:
        return x * x
    return x ** p


@jit(strict=True)
def _scaled_distance(a, i, b, j, inverse):
    """Euclidean distance between rows ``a[i]`` and ``b[j]`` in units of ``1 / inverse``
    (inf if it overflows: a difference is scaled before it is squared)."""
    total = 0.0
    for k in range(a.shape[1]):
        delta = (a[i, k] - b[j, k]) * inverse
        total += delta * delta
    return np.sqrt(total)


@jit(strict=True)
def _capped_costs(rows, cols, c, unit, p):
    """The ``(len(rows), len(cols))`` matrix of ``(min(|rows[i] - cols[j]|, c) / unit)^p``.

    A squared scaled distance at or above ``(c / unit)^2`` has a root at or above
    ``c / unit``, so the far pairs (most of them, usually) skip the root and the power; a
    difference that overflows makes an infinite square, also beyond the cut-off."""
    inverse = 1.0 / unit
    cap = c * inverse
    cut = _power(cap, p)
    cap2 = cap * cap
    cost = np.empty((rows.shape[0], cols.shape[0]))
    dim = rows.shape[1]
    for i in range(rows.shape[0]):
        a = rows[i]
        out = cost[i]
        for j in range(cols.shape[0]):
            b = cols[j]
            d2 = 0.0
            for k in range(dim):
                delta = (a[k] - b[k]) * inverse
                d2 += delta * delta
            if d2 >= cap2:
                out[j] = cut
            else:
                d = np.sqrt(d2)
                out[j] = _power(d, p) if d < cap else cut
    return cost


@jit(strict=True)
def _gospa_step(truths, estimates, c, unit, p, alpha, assignment):
    """GOSPA of one step: ``(distance, localisation, missed, false)``, the distance in the
    units of the points and the parts in units of ``unit ** p``; ``assignment`` (n,) gets
    each truth's estimate (-1 if none or, with alpha = 2, at the cut-off)."""
    n = truths.shape[0]
    m = estimates.shape[0]
    cut = _power(c * (1.0 / unit), p)  # as in _capped_costs, so that pair == cut matches
    dummy = cut / alpha
    localisation = 0.0
    missed = 0.0
    false = 0.0
    for i in range(n):
        assignment[i] = -1
    if n == 0:
        false = m * dummy
        return unit * false ** (1.0 / p), 0.0, 0.0, false
    if m == 0:
        missed = n * dummy
        return unit * missed ** (1.0 / p), 0.0, missed, 0.0
    if n <= m:
        cost = _capped_costs(truths, estimates, c, unit, p)
        _shortest_paths(cost, assignment)
    else:
        cost = _capped_costs(estimates, truths, c, unit, p)
        truth_of = np.empty(m, dtype=np.int64)
        _shortest_paths(cost, truth_of)
        for j in range(m):
            assignment[truth_of[j]] = j
    total = (m - min(n, m)) * dummy
    false = total
    for i in range(n):
        j = assignment[i]
        if j == -1:
            total += dummy
            missed += dummy
            continue
        pair = cost[i, j] if n <= m else cost[j, i]
        total += pair
        if alpha == 2.0 and pair == cut:
            missed += dummy
            false += dummy
            assignment[i] = -1
        else:
            localisation += pair
    return unit * total ** (1.0 / p), localisation, missed, false


@jit(parallel=True, strict=True, size=0, serial_below=SERIAL_BELOW_ASSIGN)
def gospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, unit, p, alpha,
                assignment, out):
    """GOSPA at every step, in parallel over steps.

    Step k's truths are ``truths[truth_offsets[k]:truth_offsets[k + 1]]`` of the stacked
    ``(N, d)`` truths, its estimates likewise; ``unit`` is a power of two with
    ``1 <= c / unit < 2``. ``out`` (steps, 4) gets each step's distance (in the units of the
    points) and its localisation, missed and false parts divided by ``unit ** p``;
    ``assignment`` (N,) int64 each truth's estimate (its row within the step), -1 if
    unassigned (or at the cut-off, for alpha = 2).
    """
    for k in prange(truth_offsets.size - 1):
        t0, t1 = truth_offsets[k], truth_offsets[k + 1]
        e0, e1 = estimate_offsets[k], estimate_offsets[k + 1]
        step_assignment = assignment[t0:t1]
        distance, localisation, missed, false = _gospa_step(
            truths[t0:t1], estimates[e0:e1], c, unit, p, alpha, step_assignment)
        out[k, 0] = distance
        out[k, 1] = localisation
        out[k, 2] = missed
        out[k, 3] = false


@jit(strict=True)
def _ospa_step(truths, estimates, c, unit, p, stonesoup):
    """OSPA of one step, in the units of the points (costs in units of ``unit``)."""
    n = truths.shape[0]
    m = estimates.shape[0]
    big = max(n, m)
    if big == 0:
        return 0.0
    if p == np.inf:
        if n != m:
            return c
        if stonesoup:  # Stone Soup minimises the sum, then takes the largest pair
            cost = _capped_costs(estimates, truths, c, unit, 1.0)
            pairs = np.empty(n, dtype=np.int64)
            _shortest_paths(cost, pairs)
            largest = 0.0
            for i in range(n):
                largest = max(largest, cost[i, pairs[i]])
            return unit * largest
        return unit * _bottleneck(_capped_costs(truths, estimates, c, unit, 1.0))
    inverse = 1.0 / unit
    cap = c * inverse
    if stonesoup:  # Stone Soup: the square matrix of min(d, c) padded with c, then ^p
        cost = np.full((big, big), cap)
        for i in range(m):
            for j in range(n):
                d = _scaled_distance(estimates, i, truths, j, inverse)
                if d < cap:
                    cost[i, j] = d
        pairs = np.empty(big, dtype=np.int64)
        _shortest_paths(cost, pairs)
        total = 0.0
        for i in range(big):
            total += _power(cost[i, pairs[i]], p)
        return unit * ((1.0 / big) * total) ** (1.0 / p)
    small = min(n, m)
    total = (big - small) * _power(cap, p)
    if small > 0:
        cost = _capped_costs(truths, estimates, c, unit, p) if n <= m else _capped_costs(
            estimates, truths, c, unit, p)
        pairs = np.empty(small, dtype=np.int64)
        _shortest_paths(cost, pairs)
        for i in range(small):
            total += cost[i, pairs[i]]
    return unit * (total / big) ** (1.0 / p)


@jit(parallel=True, strict=True, size=0, serial_below=SERIAL_BELOW_ASSIGN)
def ospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, unit, p, stonesoup,
               out):
    """OSPA at every step (layout and ``unit`` as :func:`gospa_steps`), in parallel over
    steps: ``out`` (steps,), in the units of the points. ``stonesoup`` (bool) reproduces
    Stone Soup 1.9.1's ``OSPAMetric``, which chooses the pairs minimising ``sum min(d, c)``
    rather than ``sum min(d, c)^p`` (the same for p = 1), and for p = inf the largest pair of
    that choice rather than the bottleneck.
    """
    for k in prange(truth_offsets.size - 1):
        t0, t1 = truth_offsets[k], truth_offsets[k + 1]
        e0, e1 = estimate_offsets[k], estimate_offsets[k + 1]
        out[k] = _ospa_step(truths[t0:t1], estimates[e0:e1], c, unit, p, stonesoup)
