"""Gating, clusters and nearest-neighbour assignment of a small scan in NumPy, for a
program's first scans (see :func:`fasttrack._jit.numpy_first`): the rules of the kernels
in ``fasttrack._jit.gating`` and ``assign``, results equal to theirs to rounding.

K tracks, M detections; candidates in CSR form (``starts`` (K + 1,), ``candidates`` (n,)
detection indices, ascending per track), as :class:`~fasttrack.core.gating.Gate` holds
them.
"""
import numpy as np

from .kalman_numpy import wrap

_LOG_2PI = np.log(2.0 * np.pi)


def gate(z_hats, covars, detections, threshold, angles):
    """``(starts, candidates, distances2, log_likelihoods)`` of the detections with
    ``v^T S^-1 v < threshold``, or the index of the first track whose S is not positive
    definite. Every (track, detection) pair at once."""
    k, m = z_hats.shape
    try:
        lower = np.linalg.cholesky(covars)
    except np.linalg.LinAlgError:
        for t in range(k):
            try:
                np.linalg.cholesky(covars[t])
            except np.linalg.LinAlgError:
                return t
    innovations = detections[None] - z_hats[:, None]  # (K, M, m)
    if angles.any():
        innovations[:, :, angles] = wrap(innovations[:, :, angles])
    whitened = _forward(lower, innovations.transpose(0, 2, 1))  # (K, m, M)
    distances2 = np.einsum("kij,kij->kj", whitened, whitened)
    tracks, candidates = np.nonzero(distances2 < threshold)  # by track, then detection
    starts = np.zeros(k + 1, dtype=np.int64)
    np.cumsum(np.bincount(tracks, minlength=k), out=starts[1:])
    log_norm = 0.5 * m * _LOG_2PI + np.log(lower.diagonal(axis1=1, axis2=2)).sum(axis=1)
    inside = distances2[tracks, candidates]
    return (starts, candidates.astype(np.int64), inside,
            -0.5 * inside - log_norm[tracks])


def _forward(lower, b):
    """``L^-1 b`` for lower-triangular ``lower`` (K, m, m) and ``b`` (K, m, M), by forward
    substitution (row by row over the stack)."""
    out = np.empty_like(b)
    out[:, 0] = b[:, 0] / lower[:, 0, 0, None]
    for i in range(1, b.shape[1]):
        out[:, i] = (b[:, i] - np.einsum("kj,kjn->kn", lower[:, i, :i], out[:, :i])) \
            / lower[:, i, i, None]
    return out


def clusters(starts, candidates, n_detections):
    """``(labels, n)``: the connected component of each track, then of each detection
    (K + M,), numbered in order of their first member."""
    k = starts.size - 1
    parent = list(range(k + n_detections))

    def root(node):
        while parent[node] != node:
            parent[node] = node = parent[parent[node]]
        return node

    for t in range(k):
        for j in candidates[starts[t]:starts[t + 1]]:
            parent[root(k + int(j))] = root(t)
    numbers = {}
    labels = np.array([numbers.setdefault(root(node), len(numbers)) for node in range(len(parent))],
                      dtype=np.int64)
    return labels, len(numbers)


def greedy_assignments(starts, candidates, costs, missed, n_detections):
    """Each track's detection (K,), -1 missed, by Stone Soup's nearest neighbour: the
    cheapest option first (of equal costs, candidates in their order, then the missed
    options), a detection to at most one track."""
    k, n = starts.size - 1, candidates.size
    owners = np.concatenate((np.repeat(np.arange(k), np.diff(starts)), np.arange(k)))
    assigned = np.full(k, -1, dtype=np.int64)
    decided, taken = np.zeros(k, dtype=np.bool_), np.zeros(n_detections, dtype=np.bool_)
    for q in np.argsort(np.concatenate((costs, missed)), kind="mergesort"):
        t = owners[q]
        if decided[t] or (q < n and taken[candidates[q]]):
            continue
        decided[t] = True
        if q < n:
            taken[candidates[q]] = True
            assigned[t] = candidates[q]
    return assigned


def global_nearest_neighbour(starts, candidates, costs, missed, labels, n_clusters):
    """Each track's detection (K,), -1 missed, of least total cost per cluster (``labels``
    of :func:`clusters`), a track missed at its ``missed`` cost; or ``(tracks,
    detections)``, the size of the first cluster with no assignment of finite cost."""
    from scipy.optimize import linear_sum_assignment

    k = starts.size - 1
    assigned = np.full(k, -1, dtype=np.int64)
    for c in range(n_clusters):
        tracks = np.flatnonzero(labels[:k] == c)
        detections = np.flatnonzero(labels[k:] == c)
        r, columns = tracks.size, detections.size
        if r == 0:
            continue
        cost = np.full((r, columns + r), np.inf)
        cost[np.arange(r), columns + np.arange(r)] = missed[tracks]
        for row, t in enumerate(tracks):
            lo, hi = starts[t], starts[t + 1]
            cost[row, np.searchsorted(detections, candidates[lo:hi])] = costs[lo:hi]
        try:
            rows, chosen = linear_sum_assignment(cost)
        except ValueError:  # infeasible
            return r, columns
        taken = chosen < columns
        assigned[tracks[rows[taken]]] = detections[chosen[taken]]
    return assigned
