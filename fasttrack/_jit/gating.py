"""Gating and clustering kernels of multi-target association.

K tracks have predicted measurements ``z_hats`` (K, m) and innovation covariances ``S``
(K, m, m); M detections are rows of (M, m). A detection is in track k's gate when its
squared Mahalanobis distance ``v^T S_k^-1 v`` (v = z - z_hat_k, angle rows wrapped) is
below ``threshold``. The gate ellipse lies inside the box ``|v_a| <= sqrt(threshold S_aa)``,
so on up to two *grid axes* (non-angle measurement rows) the detections are bucketed in
square cells, sorted by cell, and each track tests only the detections of the cells its box
meets: one binary search per cell row, O((K + M) log M) at a fixed density of targets.
Candidates come out track by track (CSR: ``starts`` (K + 1,), then detection index, squared
distance and log-likelihood per candidate), detections in ascending order per track: a
first pass counts them, a second writes them.
"""
import numpy as np

from .dispatch import jit
from .numeric import cholesky, stable_argsort, wrap_angle

_LOG_2PI = np.log(2.0 * np.pi)


@jit()
def _cell(value, origin, cell):
    return np.int64(np.floor((value - origin) / cell))


@jit()
def cell_keys(detections, axes, origin, cell, shape, keys):
    """``keys[j]`` = row-major cell index of detection j on the grid ``axes`` (0, 1 or 2
    measurement rows) of ``shape`` cells from ``origin``; 0 for every detection without
    axes."""
    for j in range(detections.shape[0]):
        key = np.int64(0)
        if axes.size > 0:
            key = _cell(detections[j, axes[0]], origin[0], cell)
            if axes.size > 1:
                key = key * shape[1] + _cell(detections[j, axes[1]], origin[1], cell)
        keys[j] = key


@jit()
def _distance2(z, z_hat, lower, angles, work):
    """Squared Mahalanobis distance of ``z`` from ``z_hat`` given the Cholesky factor."""
    m = z.shape[0]
    total = 0.0
    for r in range(m):
        v = z[r] - z_hat[r]
        s = wrap_angle(v) if angles[r] else v
        for k in range(r):
            s -= lower[r, k] * work[k]
        work[r] = s / lower[r, r]
        total += work[r] * work[r]
    return total


@jit()
def _cell_between(value, origin, cell, low, high):
    """The cell of ``value``, clamped to ``[low, high]`` while still a float (a gate box
    can span more cells than an int64 counts)."""
    c = np.floor((value - origin) / cell)
    if c <= low:
        return np.int64(low)
    if c >= high:
        return np.int64(high)
    return np.int64(c)


@jit()
def _cells_met(k, z_hats, covariances, axis, origin, cell, cells, threshold):
    """The cells ``[lo, hi]`` that track k's gate box meets on grid axis ``axis`` of
    ``cells`` cells from ``origin`` (lo > hi where it misses them)."""
    half = np.sqrt(threshold * covariances[k, axis, axis])
    centre = z_hats[k, axis]
    return (_cell_between(centre - half, origin, cell, 0, cells),
            _cell_between(centre + half, origin, cell, -1, cells - 1))


@jit()
def _box(k, z_hats, covariances, axes, origin, cell, shape, threshold):
    """Track k's gate box on the grid: the cells ``[lo0, hi0] x [lo1, hi1]`` it meets
    (lo > hi on an axis where it misses them; 0, 0 on an axis the grid lacks)."""
    lo0 = hi0 = lo1 = hi1 = np.int64(0)
    if axes.size > 0:
        lo0, hi0 = _cells_met(k, z_hats, covariances, axes[0], origin[0], cell, shape[0],
                              threshold)
    if axes.size > 1:
        lo1, hi1 = _cells_met(k, z_hats, covariances, axes[1], origin[1], cell, shape[1],
                              threshold)
    return lo0, hi0, lo1, hi1


@jit()
def _scan(k, z_hats, covariances, detections, order, sorted_keys, axes, angles, origin, cell,
          shape, threshold, write, first, candidates, distances2, log_likelihoods):
    """Test track k's gate; count its candidates, and with ``write`` store them from
    ``first`` on (ascending detection index). Returns the count, -1 if S is not positive
    definite."""
    m = z_hats.shape[1]
    lower = np.zeros((m, m))
    if not cholesky(covariances[k], lower):
        return np.int64(-1)
    log_norm = 0.5 * m * _LOG_2PI
    for r in range(m):
        log_norm += np.log(lower[r, r])
    work = np.empty(m)
    count = np.int64(0)
    lo0, hi0, lo1, hi1 = _box(k, z_hats, covariances, axes, origin, cell, shape, threshold)
    rows = max(hi0 - lo0 + 1, 0) if axes.size > 1 else 1  # (cell rows of the box)
    whole = rows > detections.shape[0]  # more rows than detections: test each detection
    for row in range(1 if whole else rows):
        if whole:
            start, stop = 0, detections.shape[0]
        else:  # the keys of the box's cells in this row (lo > hi: none)
            low, high = lo0, hi0  # (0, 0: every key, without grid axes)
            if axes.size > 1:
                low, high = (lo0 + row) * shape[1] + lo1, (lo0 + row) * shape[1] + hi1
            start = np.searchsorted(sorted_keys, low, side="left")
            stop = np.searchsorted(sorted_keys, high, side="right")
        for i in range(start, stop):
            j = i if whole else order[i]
            d2 = _distance2(detections[j], z_hats[k], lower, angles, work)
            if d2 < threshold:
                if write:
                    candidates[first + count] = j
                    distances2[first + count] = d2
                    log_likelihoods[first + count] = -0.5 * d2 - log_norm
                count += 1
    if write and not whole:  # cells come row by row: restore ascending detection order
        for q in range(first + 1, first + count):
            j, d2, ll = candidates[q], distances2[q], log_likelihoods[q]
            p = q
            while p > first and candidates[p - 1] > j:
                candidates[p] = candidates[p - 1]
                distances2[p] = distances2[p - 1]
                log_likelihoods[p] = log_likelihoods[p - 1]
                p -= 1
            candidates[p], distances2[p], log_likelihoods[p] = j, d2, ll
    return count


@jit()
def gate(z_hats, covariances, detections, order, sorted_keys, axes, angles, origin, cell,
         shape, threshold, write, starts, candidates, distances2, log_likelihoods, status):
    """Without ``write``: each track k's number of candidates into ``starts[k + 1]``
    (``starts[0]`` is left alone: the caller cumulates), ``status[k]`` = 1 where S_k is
    not positive definite (no candidates). With ``write``: store track k's candidates from
    ``starts[k]``, once ``starts`` holds the cumulated counts (one kernel for both passes,
    so that it compiles once). The entries of ``candidates`` and the others are positions
    given by ``starts``, so a slice of the tracks (of ``z_hats``, ``covariances``,
    ``starts`` with one more entry, ``status``) gates those tracks alone."""
    for k in range(z_hats.shape[0]):
        count = _scan(k, z_hats, covariances, detections, order, sorted_keys, axes, angles,
                      origin, cell, shape, threshold, write, starts[k] if write else 0,
                      candidates, distances2, log_likelihoods)
        if not write:
            status[k] = np.int64(count < 0)
            starts[k + 1] = max(count, 0)


@jit()
def _root(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@jit()
def clusters(starts, candidates, n_detections, labels):
    """Connected components of the gate graph: ``labels`` (K + M,) for the K tracks then the
    M detections, numbered 0, 1, ... in order of their first member; a detection in no gate
    is a cluster of its own. Returns the number of clusters."""
    k_tracks = starts.size - 1
    n = k_tracks + n_detections
    parent = np.arange(n)
    for k in range(k_tracks):
        for q in range(starts[k], starts[k + 1]):
            a, b = _root(parent, k), _root(parent, k_tracks + candidates[q])
            if a != b:
                parent[max(a, b)] = min(a, b)
    count = np.int64(0)
    for i in range(n):
        r = _root(parent, i)
        if r == i:
            labels[i] = count
            count += 1
        else:
            labels[i] = labels[r]
    return count


@jit()
def _positions(labels, lo, hi, n_clusters, counts, local):
    """Per cluster the number of nodes ``lo..hi-1`` in it (``counts``), and each node's rank
    within its cluster (``local``)."""
    for c in range(n_clusters):
        counts[c] = 0
    for i in range(lo, hi):
        c = labels[i]
        local[i - lo] = counts[c]
        counts[c] += 1


@jit()
def gnn_problems(labels, n_clusters, k_tracks, n_detections, shapes, offsets, row_offsets,
                 track_rows, detection_columns):
    """Size the assignment problem of each cluster: its tracks as rows, its detections then
    one missed column per track as columns (``shapes`` (C, 2), flat ``offsets`` and
    ``row_offsets`` (C + 1,)); ``track_rows`` (K,) and ``detection_columns`` (M,) give each
    node's row or column in its cluster. Returns the flat size; :func:`gnn_fill` fills."""
    track_counts = np.empty(n_clusters, dtype=np.int64)
    detection_counts = np.empty(n_clusters, dtype=np.int64)
    _positions(labels, 0, k_tracks, n_clusters, track_counts, track_rows)
    _positions(labels, k_tracks, k_tracks + n_detections, n_clusters, detection_counts,
               detection_columns)
    offsets[0] = 0
    row_offsets[0] = 0
    for c in range(n_clusters):
        shapes[c, 0] = track_counts[c]
        shapes[c, 1] = detection_counts[c] + track_counts[c]
        offsets[c + 1] = offsets[c] + shapes[c, 0] * shapes[c, 1]
        row_offsets[c + 1] = row_offsets[c] + shapes[c, 0]
    return offsets[n_clusters]


@jit()
def gnn_fill(labels, starts, candidates, costs, missed, shapes, offsets, track_rows,
             detection_columns, flat):
    """Fill the problems sized by :func:`gnn_problems`: ``costs`` of the candidates, the
    ``missed`` cost (K,) on each track's own missed column, ``inf`` elsewhere."""
    for i in range(flat.size):
        flat[i] = np.inf
    k_tracks = starts.size - 1
    for k in range(k_tracks):
        c = labels[k]
        width = shapes[c, 1]
        n_dets = width - shapes[c, 0]
        row = offsets[c] + track_rows[k] * width
        for q in range(starts[k], starts[k + 1]):
            flat[row + detection_columns[candidates[q]]] = costs[q]
        flat[row + n_dets + track_rows[k]] = missed[k]


@jit()
def gnn_assignments(labels, shapes, row_offsets, track_rows, detection_columns, n_detections,
                    row_to_col, assigned):
    """Each track's detection (``assigned`` (K,), -1 if missed) from the clusters'
    solutions."""
    k_tracks = track_rows.size
    n_clusters = shapes.shape[0]
    first = np.zeros(n_clusters + 1, dtype=np.int64)  # detections of each cluster, in order
    for j in range(n_detections):
        first[labels[k_tracks + j] + 1] += 1
    for c in range(n_clusters):
        first[c + 1] += first[c]
    by_cluster = np.empty(n_detections, dtype=np.int64)
    for j in range(n_detections):
        c = labels[k_tracks + j]
        by_cluster[first[c] + detection_columns[j]] = j
    for k in range(k_tracks):
        c = labels[k]
        col = row_to_col[row_offsets[c] + track_rows[k]]
        n_dets = shapes[c, 1] - shapes[c, 0]
        assigned[k] = by_cluster[first[c] + col] if 0 <= col < n_dets else -1


@jit()
def greedy_assignments(starts, candidates, costs, missed, n_detections, assigned):
    """Nearest-neighbour association: over all (track, detection) candidates and each
    track's missed option (cost ``missed[k]``), cheapest first, a track not yet decided
    takes the option if its detection is still free (a missed option always is); of equal
    costs, the candidates come first in their order (by track, then detection), then the
    missed options."""
    k_tracks = starts.size - 1
    n = candidates.size
    options = np.empty(n + k_tracks)
    for q in range(n):
        options[q] = costs[q]
    for k in range(k_tracks):
        options[n + k] = missed[k]
    owner = np.empty(n + k_tracks, dtype=np.int64)
    for k in range(k_tracks):
        for q in range(starts[k], starts[k + 1]):
            owner[q] = k
        owner[n + k] = k
    order = stable_argsort(options)
    decided = np.zeros(k_tracks, dtype=np.bool_)
    taken = np.zeros(n_detections, dtype=np.bool_)
    for k in range(k_tracks):
        assigned[k] = -1
    for i in range(order.size):
        q = order[i]
        k = owner[q]
        if decided[k]:
            continue
        if q >= n:
            decided[k] = True
        elif not taken[candidates[q]]:
            decided[k] = True
            taken[candidates[q]] = True
            assigned[k] = candidates[q]
