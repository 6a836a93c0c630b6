"""Kernels on Gaussian mixtures stored as stacks: K components with (K, d) means, (K, d, d)
covariances and (K,) log weights, grouped into segments by CSR ``starts`` (segment s is
components ``starts[s]:starts[s + 1]``).

Weights are handled in log space: each segment's are shifted by their largest before they
are exponentiated, so no weight underflows to zero while a larger one is finite. The
reduction (prune, merge, truncate) takes linear weights, as the PHD's are.
"""
import math

import numpy as np

from .dispatch import jit
from .gating import _distance2
from .kinds import STONESOUP
from .numeric import cholesky, stable_argsort
from .tunables import REDUCE_GRID_FROM, REDUCE_WIDE


@jit()
def _segment_peak(log_weights, lo, hi):
    """The largest of ``log_weights[lo:hi]`` (-inf for an empty segment)."""
    peak = -np.inf
    for i in range(lo, hi):
        if log_weights[i] > peak:
            peak = log_weights[i]
    return peak


@jit()
def segment_logsumexp(values, starts, out):
    """``out[s] = log sum exp values[starts[s]:starts[s + 1]]``: -inf for an empty segment
    or one of zero weights, +inf if a value is +inf, NaN if one is NaN."""
    for s in range(starts.size - 1):
        lo, hi = starts[s], starts[s + 1]
        peak = _segment_peak(values, lo, hi)
        shift = peak if abs(peak) <= 1.7976931348623157e308 else 0.0
        total = 0.0
        for i in range(lo, hi):
            total += math.exp(values[i] - shift)
        out[s] = -np.inf if total == 0.0 else math.log(total) + shift


@jit()
def component_gains(covars, cross, innovation, gains, updated):
    """Each component's Kalman gain ``K = C S^-1`` (J, d, m) and posterior covariance
    ``P - K C^T`` (J, d, d; lower triangle computed, mirrored) from its covariance P
    (J, d, d), ``cross`` C = P H^T (J, d, m) and innovation covariance S = H P H^T + R
    (J, m, m), by S's Cholesky factor: a mixture update's per-component work, shared by the
    detections it pairs with. Returns the first component whose S is not positive definite
    (its outputs unwritten), or -1."""
    j, d, m = cross.shape
    lower, half = np.empty((m, m)), np.empty(m)
    for k in range(j):
        if not cholesky(innovation[k], lower):
            return k
        for a in range(d):  # row a of K solves L L^T K[a]^T = C[a]^T
            for r in range(m):
                t = cross[k, a, r]
                for s in range(r):
                    t -= lower[r, s] * half[s]
                half[r] = t / lower[r, r]
            for r in range(m - 1, -1, -1):
                t = half[r]
                for s in range(r + 1, m):
                    t -= lower[s, r] * gains[k, a, s]
                gains[k, a, r] = t / lower[r, r]
        for a in range(d):
            for b in range(a + 1):
                t = covars[k, a, b]
                for r in range(m):
                    t -= gains[k, a, r] * cross[k, b, r]
                updated[k, a, b] = t
                updated[k, b, a] = t
    return -1


@jit()
def moment_match(means, covars, log_weights, starts, out_means, out_covars, out_log_weights):
    """Each segment's components merged into the Gaussian of the same mean and covariance:
    ``m = sum w_i m_i``, ``P = sum w_i (P_i + (m_i - m)(m_i - m)^T)`` with the weights
    normalised within the segment; ``out_log_weights[s]`` is the segment's log total weight.
    Returns the first segment with no finite positive total weight (nothing written for it),
    or -1 if every segment was merged."""
    d = means.shape[1]
    failed = -1
    for s in range(starts.size - 1):
        lo, hi = starts[s], starts[s + 1]
        peak = _segment_peak(log_weights, lo, hi)
        if not abs(peak) <= 1.7976931348623157e308:
            if failed < 0:
                failed = s
            continue
        total = 0.0
        for i in range(lo, hi):
            total += math.exp(log_weights[i] - peak)
        mean = out_means[s]
        for r in range(d):
            mean[r] = 0.0
        for i in range(lo, hi):
            w = math.exp(log_weights[i] - peak) / total
            for r in range(d):
                mean[r] += w * means[i, r]
        covar = out_covars[s]
        for r in range(d):
            for c in range(d):
                covar[r, c] = 0.0
        for i in range(lo, hi):
            w = math.exp(log_weights[i] - peak) / total
            for r in range(d):
                spread_r = means[i, r] - mean[r]
                for c in range(d):
                    covar[r, c] += w * (covars[i, r, c] + spread_r * (means[i, c] - mean[c]))
        out_log_weights[s] = peak + math.log(total)
    return failed


@jit()
def _prune(weights, stonesoup, threshold, kept, work):
    """The components that pruning keeps, in input order: their indices into ``kept`` and
    weights into ``work``; returns how many. Stone Soup keeps ``w >= threshold`` and adds the
    pruned mass evenly to the kept; the textbook keeps ``w > threshold``."""
    n = 0
    pruned = 0.0
    for i in range(weights.size):
        w = weights[i]
        if w > threshold or (stonesoup and w == threshold):
            kept[n] = i
            work[n] = w
            n += 1
        else:
            pruned += w
    if stonesoup and n > 0:
        share = pruned / n
        for j in range(n):
            work[j] += share
    return n


@jit()
def _copy_component(means, covars, i, mean, covar):
    """Component i's mean and covariance into ``mean`` (d,) and ``covar`` (d, d)."""
    d = mean.size
    for r in range(d):
        mean[r] = means[i, r]
        for c in range(d):
            covar[r, c] = covars[i, r, c]


@jit()
def _symmetric(a):
    """Whether the square ``a`` is symmetric to 1e-9 of its largest entry."""
    d = a.shape[0]
    largest = 0.0
    for r in range(d):
        for c in range(d):
            largest = max(largest, abs(a[r, c]))
    for r in range(d):
        for c in range(r):
            if not abs(a[r, c] - a[c, r]) <= 1e-9 * largest:
                return False
    return True


@jit()
def _merge_pair(mean, covar, weight, other_mean, other_covar, other_weight, diff):
    """Stone Soup's ``merge_components`` of (``mean``, ``covar``, ``weight``), updated in
    place, with another component (moment matching, spread included); returns the merged
    weight, capped at 1."""
    total = weight + other_weight
    w1, w2 = weight / total, other_weight / total
    d = mean.size
    for r in range(d):
        diff[r] = mean[r] - other_mean[r]
        mean[r] = mean[r] * w1 + other_mean[r] * w2
    for r in range(d):
        for c in range(d):
            covar[r, c] = covar[r, c] * w1 + other_covar[r, c] * w2 + diff[r] * diff[c] * w1 * w2
    return min(total, 1.0)


@jit()
def _moment_match_group(means, covars, weights, group, count, mean, covar):
    """``group[:count]``'s components merged into one Gaussian of the same moments (spread
    included) into ``mean`` and ``covar`` (its lower triangle computed and mirrored, so
    exactly symmetric); returns their total weight."""
    d = means.shape[1]
    total = 0.0
    for r in range(d):
        mean[r] = 0.0
    for g in range(count):
        total += weights[group[g]]
    for g in range(count):
        w = weights[group[g]] / total
        for r in range(d):
            mean[r] += w * means[group[g], r]
    for r in range(d):
        for c in range(r + 1):
            covar[r, c] = 0.0
    for g in range(count):
        i = group[g]
        w = weights[i] / total
        for r in range(d):
            spread = means[i, r] - mean[r]
            for c in range(r + 1):
                covar[r, c] += w * (covars[i, r, c] + spread * (means[i, c] - mean[c]))
    for r in range(d):
        for c in range(r):
            covar[c, r] = covar[r, c]
    return total


@jit()
def _cell(value, low, cell, cells):
    """The cell index of ``value`` along one axis, clipped to ``[0, cells)``."""
    return min(max(np.int64(math.floor((value - low) / cell)), 0), cells - 1)


@jit()
def _grid(points, members, cell):
    """Components ``members`` bucketed by their ``points`` (n, 2) into square cells of side
    at least ``cell``, at most about 4 cells a component (wider cells when the points
    spread further): ``(low (2,), shape (2,), cell, starts, order)``, ``order`` the members
    by cell ``row * shape[1] + column`` and cell k's in ``order[starts[k]:starts[k + 1]]``.
    The cell is 0 (no grid) if there are no points or they span no finite box."""
    count = members.size
    low, high = np.full(2, np.inf), np.full(2, -np.inf)
    for g in range(count):
        for a in range(2):
            low[a] = min(low[a], points[members[g], a])
            high[a] = max(high[a], points[members[g], a])
    shape = np.zeros(2, dtype=np.int64)
    none = np.empty(0, dtype=np.int64)
    if count == 0 or not (high[0] - low[0] < np.inf and high[1] - low[1] < np.inf):
        return low, shape, 0.0, none, none
    cells = ((high[0] - low[0]) / cell + 1.0) * ((high[1] - low[1]) / cell + 1.0)
    if cells > 4.0 * count + 16.0:
        cell *= math.sqrt(cells / (4.0 * count + 16.0))
    for a in range(2):
        shape[a] = np.int64((high[a] - low[a]) / cell) + 1
    keys = np.empty(count, dtype=np.int64)
    starts = np.zeros(shape[0] * shape[1] + 1, dtype=np.int64)
    for g in range(count):
        i = members[g]
        keys[g] = (_cell(points[i, 0], low[0], cell, shape[0]) * shape[1]
                   + _cell(points[i, 1], low[1], cell, shape[1]))
        starts[keys[g] + 1] += 1
    for k in range(starts.size - 1):
        starts[k + 1] += starts[k]
    order = np.empty(count, dtype=np.int64)
    filled = starts[:-1].copy()
    for g in range(count):
        order[filled[keys[g]]] = members[g]
        filled[keys[g]] += 1
    return low, shape, cell, starts, order


@jit()
def _sort_small(values, count):
    """``values[:count]`` sorted in place: by insertion for a few (no allocation)."""
    if count > 32:
        values[:count].sort()
        return
    for i in range(1, count):
        v = values[i]
        k = i - 1
        while k >= 0 and values[k] > v:
            values[k + 1] = values[k]
            k -= 1
        values[k + 1] = v


@jit()
def _radius(covars, i, threshold, axes):
    """``sqrt(threshold * max(P_i[a, a]))`` over the grid ``axes``: no point farther than
    this from a mean along either axis is within ``threshold`` of it (squared Mahalanobis
    distance by P_i; a coordinate's own distance is at most the whole vector's)."""
    return math.sqrt(threshold * max(covars[i, axes[0], axes[0]], covars[i, axes[1], axes[1]]))


@jit()
def _candidates(grid, radius, x, y, alive, rank, by_rank, top, out):
    """The ranks of the live components that may lie within ``radius`` of (x, y) on the
    grid's axes, ascending, into ``out``; returns how many. With the grid (``grid[2]``, its
    cell, > 0): those in the cells the circle meets and the ``wide`` ones; else every live
    component ranked below ``top``."""
    low, shape, cell, starts, order, wide = grid
    count = 0
    if cell > 0.0:
        c0 = _cell(y - radius, low[1], cell, shape[1])
        c1 = _cell(y + radius, low[1], cell, shape[1])
        for row in range(_cell(x - radius, low[0], cell, shape[0]),
                         _cell(x + radius, low[0], cell, shape[0]) + 1):
            for g in range(starts[row * shape[1] + c0], starts[row * shape[1] + c1 + 1]):
                if alive[order[g]]:
                    out[count] = rank[order[g]]
                    count += 1
        for i in wide:
            if alive[i]:
                out[count] = rank[i]
                count += 1
        _sort_small(out, count)
    else:
        for r in range(top):
            if alive[by_rank[r]]:
                out[count] = r
                count += 1
    return count


@jit()
def _factors(covars):
    """The lower Cholesky factors of the (n, d, d) ``covars``, and -1; or, for the first
    that is not symmetric (to 1e-9 of its largest entry) or not positive definite, None-like
    factors and ``2 j + 1`` or ``2 j``."""
    n, d = covars.shape[:2]
    factors = np.empty((n, d, d))
    for j in range(n):
        if not _symmetric(covars[j]):
            return factors, 2 * j + 1
        if not cholesky(covars[j], factors[j]):
            return factors, 2 * j
    return factors, -1


@jit()
def _merge(means, covars, weights, stonesoup, threshold, axes, out_means, out_covars,
           out_weights, source, member):
    """Greedy merging of n components, heaviest first (ties: the later), each taking the
    live components within ``threshold`` (squared Mahalanobis distance) tested in
    ascending weight. Stone Soup's rule: each candidate's covariance measures it from the
    running merged mean, ``<``, merged pairwise (:func:`_merge_pair`, weight capped at 1);
    the textbook's: the heaviest's covariance from its own mean, ``<=``, merged at once
    (:func:`_moment_match_group`). From ``REDUCE_GRID_FROM`` components a grid on the
    state ``axes`` (2,) gates the tests (:func:`_merge_grid`): by Stone Soup's rule the
    cells within 1.5 cells, and again every live component if the merged mean drifts
    more than half a cell on those axes.

    Writes the merged components, ``source[o]`` (the heaviest of output o) and
    ``member[j]`` (the output of component j); returns their count, or ``-(1 + 2 j)`` if
    component j's covariance is not positive definite, ``-(2 + 2 j)`` if it is not
    symmetric. (One loop: per-merge calls with this many arrays cost a third more.)"""
    n, d = means.shape
    factors, failed = _factors(covars)
    if failed >= 0:
        return -(1 + failed)
    by_rank = stable_argsort(weights)
    rank = np.empty(n, dtype=np.int64)
    points = np.empty((n, 2))
    for j in range(n):
        rank[by_rank[j]] = j
        points[j, 0], points[j, 1] = means[j, axes[0]], means[j, axes[1]]
    grid = _merge_grid(covars, points, threshold, stonesoup, axes)
    no_grid = grid[:2] + (0.0,) + grid[3:]
    alive = np.ones(n, dtype=np.bool_)
    candidates, merged, diff = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64), \
        np.empty(d)
    flat = np.zeros(d, dtype=np.bool_)  # no angle components
    count = 0
    for top in range(n - 1, -1, -1):
        b = by_rank[top]
        if not alive[b]:
            continue
        alive[b] = False
        member[b], source[count] = count, b
        mean, covar = out_means[count], out_covars[count]
        x, y = points[b, 0], points[b, 1]
        if stonesoup:
            g = grid
            while True:
                cell = g[2]
                m = _candidates(g, 1.5 * cell, x, y, alive, rank, by_rank, top, candidates)
                _copy_component(means, covars, b, mean, covar)
                weight, n_merged, drifted = weights[b], 0, False
                for q in range(m):
                    c = by_rank[candidates[q]]
                    if _distance2(means[c], mean, factors[c], flat, diff) < threshold:
                        weight = _merge_pair(mean, covar, weight, means[c], covars[c],
                                             weights[c], diff)
                        alive[c], member[c] = False, count
                        merged[n_merged] = c
                        n_merged += 1
                        drifted = cell > 0.0 and ((mean[axes[0]] - x) ** 2
                                                  + (mean[axes[1]] - y) ** 2 > 0.25 * cell**2)
                        if drifted:
                            break
                if not drifted:
                    break
                for q in range(n_merged):
                    alive[merged[q]] = True
                g = no_grid
            out_weights[count] = weight
        else:
            radius = _radius(covars, b, threshold, axes)
            m = _candidates(grid if radius <= 4.0 * grid[2] else no_grid, radius, x, y, alive,
                            rank, by_rank, top, candidates)
            merged[0], n_merged = b, 1
            for q in range(m):
                c = by_rank[candidates[q]]
                if _distance2(means[c], means[b], factors[b], flat, diff) <= threshold:
                    alive[c], member[c] = False, count
                    merged[n_merged] = c
                    n_merged += 1
            out_weights[count] = _moment_match_group(means, covars, weights, merged, n_merged,
                                                     mean, covar)
        count += 1
    return count


@jit()
def _merge_grid(covars, points, threshold, stonesoup, axes):
    """The grid that gates the merge tests: ``(low, shape, cell, starts, order, wide)``
    (:func:`_grid`), ``cell`` 0 for none (below ``REDUCE_GRID_FROM`` components, or when no
    grid fits). A pair within ``threshold`` lies within :func:`_radius` of each other
    along the grid axes, by the covariance that measures it; the cell is the largest
    radius, or if that is over twice the radius that at most ``REDUCE_WIDE`` (or an
    eighth) of the components exceed, the latter. By Stone Soup's rule the candidate's covariance
    measures, so the components of larger radius (``wide``) are kept out of the cells and
    tested for every merge."""
    n = points.shape[0]
    radii = np.empty(n)
    for j in range(n):
        radii[j] = _radius(covars, j, threshold, axes)
    cell = 0.0
    if n >= REDUCE_GRID_FROM:
        by_radius = stable_argsort(radii)
        cell = radii[by_radius[n - 1 - min(REDUCE_WIDE, n // 8)]]
        if radii[by_radius[n - 1]] <= 2.0 * cell:  # no component is much wider: none kept out
            cell = radii[by_radius[n - 1]]
    none = np.empty(0, dtype=np.int64)
    if not 0.0 < cell < np.inf:
        return np.zeros(2), np.zeros(2, dtype=np.int64), 0.0, none, none, none
    wide = np.flatnonzero(radii > cell) if stonesoup else none
    low, shape, cell, starts, order = _grid(points, np.flatnonzero(radii <= cell) if stonesoup
                                            else np.arange(n), cell)
    return low, shape, cell, starts, order, wide


@jit()
def _truncate(stonesoup, count, keep, means, covars, weights, source, member):
    """The ``keep`` heaviest of the ``count`` components (ties: the earlier), heaviest
    first, in place; the cut mass added evenly (Stone Soup) or the kept rescaled to the
    whole mass (textbook). Renumbers ``member`` (-1: cut). Returns ``keep``."""
    order = stable_argsort(-weights[:count])
    kept_mass, cut_mass = 0.0, 0.0
    for q in range(keep):
        kept_mass += weights[order[q]]
    for q in range(keep, count):
        cut_mass += weights[order[q]]
    d = means.shape[1]
    new_means, new_covars = np.empty((keep, d)), np.empty((keep, d, d))
    new_weights, new_source = np.empty(keep), np.empty(keep, dtype=np.int64)
    position = np.full(count, -1)
    for q in range(keep):
        o = order[q]
        _copy_component(means, covars, o, new_means[q], new_covars[q])
        new_source[q] = source[o]
        new_weights[q] = (weights[o] + cut_mass / keep if stonesoup
                          else weights[o] * ((kept_mass + cut_mass) / kept_mass))
        position[o] = q
    for q in range(keep):
        _copy_component(new_means, new_covars, q, means[q], covars[q])
        weights[q], source[q] = new_weights[q], new_source[q]
    for i in range(member.size):
        if member[i] >= 0:
            member[i] = position[member[i]]
    return keep


@jit()
def reduce(means, covars, weights, mode, prune_threshold, merging, merge_threshold,
           max_components, axes, out_means, out_covars, out_weights, source, member):
    """Prune, merge and truncate the J components of a mixture with linear ``weights``
    (J,) by the rules of ``mode`` (``kinds.STONESOUP`` or ``kinds.TEXTBOOK``; see
    :func:`_prune`, :func:`_merge`, :func:`_truncate`): ``prune_threshold`` (-inf: no
    pruning), ``merging``, ``merge_threshold`` (squared Mahalanobis distance),
    ``max_components`` (the cap), ``axes`` (2,) the state rows the merge grid uses.

    Writes the components out (heaviest of each merge first) and, per output, ``source``
    (the input component whose tag it keeps); ``member`` (J,) is each input component's
    output (-1: pruned or truncated). Returns the number out, or ``-(1 + 2 i)`` if input
    component i's covariance (checked when merging) is not positive definite,
    ``-(2 + 2 i)`` if it is not symmetric."""
    n_in, d = means.shape
    stonesoup = mode == STONESOUP
    kept, work = np.empty(n_in, dtype=np.int64), np.empty(n_in)
    n = _prune(weights, stonesoup, prune_threshold, kept, work)
    kept_means, kept_covars = np.empty((n, d)), np.empty((n, d, d))
    for j in range(n):
        _copy_component(means, covars, kept[j], kept_means[j], kept_covars[j])
    local_source, local_member = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    if merging and n > 1:
        count = _merge(kept_means, kept_covars, work[:n], stonesoup, merge_threshold, axes,
                       out_means, out_covars, out_weights, local_source, local_member)
        if count < 0:
            j, kind = divmod(-(1 + count), 2)
            return -(1 + 2 * kept[j] + kind)
    else:
        for j in range(n):
            _copy_component(kept_means, kept_covars, j, out_means[j], out_covars[j])
            out_weights[j] = work[j]
            local_source[j] = local_member[j] = j
        count = n
    for i in range(n_in):
        member[i] = -1
    for j in range(n):
        member[kept[j]] = local_member[j]
    for o in range(count):
        source[o] = kept[local_source[o]]
    if count > max_components:
        count = _truncate(stonesoup, count, max_components, out_means, out_covars,
                          out_weights, source, member)
    return count
