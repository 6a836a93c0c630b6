"""Two-dimensional assignment: the rectangular linear sum assignment problem, global
nearest neighbour association on top of it, and nearest-neighbour and global
nearest-neighbour association on a :class:`~fasttrack.core.gating.Gate`.

:func:`assign2d` is a compiled replacement of :func:`scipy.optimize.linear_sum_assignment`:
given an ``(n, m)`` cost matrix C it finds the one-to-one pairs ``(i, x(i))`` of
``min(n, m)`` rows and columns minimising ``sum_i C[i, x(i)]``, exactly, with the same
algorithm as SciPy (shortest augmenting paths, Crouse's form of Jonker-Volgenant) and the
same tie-breaking, so it returns SciPy's pairs on the same matrix. ``inf`` forbids a pair;
a matrix with no complete assignment over finite entries raises ``ValueError``.

:func:`gnn_assign` is the association of Stone Soup's ``GNNWith2DAssignment`` on a cost
matrix of tracks (rows) by detections (columns): each track takes one detection or is
missed at cost ``missed_cost``, each detection goes to one track at most, and the total cost
is minimised. As Stone Soup does, it solves the ``(r, m + r)`` matrix of the r tracks that
have at least one finite cost: their detection costs, then an ``r x r`` block holding each
track's own missed cost on the diagonal and ``inf`` elsewhere; tracks with no finite cost
are missed without entering the matrix. Given the same rows and columns in the same order,
it returns Stone Soup's association, ties included.

Differences from Stone Soup, by design: the costs are used as given, whereas Stone Soup's
``DistanceHypothesiser`` first drops each detection whose distance is not below
``missed_distance`` (unless ``include_all``), which changes no optimum but may break an exact
tie differently (pass ``np.where(cost < missed, cost, np.inf)`` to drop them too); for
probability hypotheses, which Stone Soup maximises, pass ``-probability`` as costs and
``-probability of a missed detection`` as ``missed_cost`` (SciPy maximises by negating, so
the pairs are the same); an infeasible problem (missed cost ``inf`` for tracks that cannot
all be given detections) raises ``ValueError`` where Stone Soup raises ``RuntimeError``.
"""
import numpy as np

from .. import _jit
from .. import _validate
from .. import threads as _threads
from .._jit.tunables import SERIAL_BELOW_ASSIGN
from .._validate import _describe, float_array
from . import gating_numpy as _numpy
from .gating import Clusters, checked
from .gating import clusters as _clusters

__all__ = ["assign2d", "assign2d_batch", "global_nearest_neighbour", "gnn_assign",
           "nearest_neighbour"]

_assign = _jit.lazy("assign")
_kernels = _jit.lazy("gating")


def _costs(value, name, maximize=False):
    """``value`` as a C-contiguous float64 2-D cost matrix: real numbers, no NaN, no
    ``-inf`` (no ``+inf`` when maximising)."""
    if isinstance(value, (str, bytes)) or value is None:
        raise TypeError(f"{name} must be a 2-D array of real numbers, got {_describe(value)}")
    cost = float_array(value, name, 2)
    if np.isnan(cost).any():
        raise ValueError(f"{name} contains NaN")
    bad = np.inf if maximize else -np.inf
    if (cost == bad).any():
        raise ValueError(f"{name} contains {'+' if maximize else '-'}inf: only "
                         f"{'-' if maximize else '+'}inf (a forbidden pair) is allowed "
                         f"when {'maximising' if maximize else 'minimising'}")
    return cost


def _infeasible(name, shape):
    return ValueError(f"{name} is infeasible: no assignment of {min(shape)} pairs of its "
                      f"{shape[0]} x {shape[1]} entries has a finite total cost")


def assign2d(cost, maximize=False):
    """Solve the rectangular linear sum assignment problem (as
    :func:`scipy.optimize.linear_sum_assignment`).

    Parameters
    ----------
    cost : (n, m) array_like of float
        Cost of assigning row i to column j; ``inf`` (``-inf`` if ``maximize``) forbids the
        pair. No NaN.
    maximize : bool
        Maximise the total instead.

    Returns
    -------
    rows, cols : (min(n, m),) ndarray of int64
        The assigned pairs ``(rows[k], cols[k])``, rows ascending; ``cost[rows, cols].sum()``
        is the optimum.

    Raises
    ------
    ValueError
        If ``cost`` is not 2-D, holds NaN or ``-inf`` (``+inf`` if maximising), or no
        complete assignment over its finite entries exists.
    TypeError
        If ``cost`` does not hold real numbers.
    """
    maximize = _validate.flag(maximize, "maximize")
    matrix = _costs(cost, "cost", maximize)
    if maximize:
        matrix = -matrix
    row_to_col = np.empty(matrix.shape[0], dtype=np.int64)
    if not _assign.lsap(matrix, row_to_col):
        raise _infeasible("cost", matrix.shape)
    rows = np.flatnonzero(row_to_col >= 0)
    return rows, row_to_col[rows]


def assign2d_batch(costs, maximize=False):
    """Solve many independent assignment problems in one compiled call (in parallel over
    the problems).

    Parameters
    ----------
    costs : sequence of (n_q, m_q) array_like of float, or (k, n, m) array_like
        The cost matrices, each as for :func:`assign2d` (or k of one shape).
    maximize : bool
        Maximise every total instead.

    Returns
    -------
    list of (n_q,) ndarray of int64
        Each problem's column for every row, -1 for the rows left out (when n_q > m_q).

    Raises
    ------
    ValueError, TypeError
        As :func:`assign2d`, naming the problem (``costs[q]``).
    """
    maximize = _validate.flag(maximize, "maximize")
    if isinstance(costs, np.ndarray) and costs.ndim == 3:  # k problems of one shape
        k, nr, nc = costs.shape
        flat = float_array(costs, "costs").reshape(-1)
        shapes = np.tile(np.array([nr, nc], dtype=np.int64), (k, 1))
    else:
        if isinstance(costs, (str, bytes)) or not hasattr(costs, "__iter__"):
            raise TypeError(f"costs must be a sequence of 2-D cost matrices or a 3-D array, "
                            f"got {_describe(costs)}")
        matrices = []
        for q, c in enumerate(costs):
            if type(c) is not np.ndarray or c.ndim != 2 or c.dtype.kind not in "fiu":
                c = _costs(c, f"costs[{q}]", maximize)  # converts, or names the problem
            matrices.append(c)
        k = len(matrices)
        shapes = np.array([m.shape for m in matrices], dtype=np.int64).reshape(k, 2)
        flat = np.concatenate([m.ravel() for m in matrices] + [np.empty(0)],
                              dtype=np.float64)
    if k == 0:
        return []
    offsets = np.zeros(k + 1, dtype=np.int64)
    np.cumsum(shapes[:, 0] * shapes[:, 1], out=offsets[1:])
    row_offsets = np.zeros(k + 1, dtype=np.int64)
    np.cumsum(shapes[:, 0], out=row_offsets[1:])
    bad = np.isnan(flat) | (flat == (np.inf if maximize else -np.inf))
    if bad.any():  # checked once for all; the first bad problem is named
        q = int(np.searchsorted(offsets, np.flatnonzero(bad)[0], side="right")) - 1
        _costs(flat[offsets[q]:offsets[q + 1]].reshape(shapes[q]), f"costs[{q}]", maximize)
    if maximize:
        flat = -flat
    row_to_col, feasible = _solve(flat, offsets, shapes, row_offsets)
    if not feasible.all():
        q = int(np.flatnonzero(~feasible)[0])
        raise _infeasible(f"costs[{q}]", tuple(shapes[q]))
    return [row_to_col[a:b] for a, b in zip(row_offsets[:-1].tolist(), row_offsets[1:].tolist())]


def _solve(flat, offsets, shapes, row_offsets):
    """``(row_to_col, feasible)``: the problems stored flat (see
    :func:`fasttrack._jit.assign.lsap_batch`), solved in chunks of problems on threads."""
    row_to_col = np.empty(row_offsets[-1], dtype=np.int64)
    feasible = np.empty(shapes.shape[0], dtype=np.bool_)
    _threads.in_chunks(lambda lo, hi: _assign.lsap_batch(
        flat, offsets[lo:hi + 1], shapes[lo:hi], row_offsets[lo:hi + 1], row_to_col,
        feasible[lo:hi]), shapes.shape[0], SERIAL_BELOW_ASSIGN, work=flat.size, per_thread=4)
    return row_to_col, feasible


def gnn_assign(cost, missed_cost):
    """Global nearest neighbour association (Stone Soup's ``GNNWith2DAssignment``): each
    track takes at most one detection, each detection goes to at most one track, a track
    without one costs ``missed_cost``, and the total cost is minimised.

    Parameters
    ----------
    cost : (n_tracks, n_detections) array_like of float
        Cost (e.g. a Mahalanobis distance) of each track-detection pair; ``inf`` where the
        detection is not a hypothesis of the track (gated out). No NaN or ``-inf``.
    missed_cost : float or (n_tracks,) array_like of float
        Cost of a track taking no detection (Stone Soup's ``missed_distance``), for all
        tracks or per track; ``inf`` means the track must take a detection.

    Returns
    -------
    (n_tracks,) ndarray of int64
        Each track's detection (column of ``cost``), -1 if it is missed.

    Raises
    ------
    ValueError
        If the shapes do not match, an entry is NaN or ``-inf``, or tracks whose missed cost
        is ``inf`` cannot all be given detections.
    TypeError
        If ``cost`` or ``missed_cost`` do not hold real numbers.
    """
    cost = _costs(cost, "cost")
    n, m = cost.shape
    missed = float_array(missed_cost, "missed_cost")
    if missed.ndim == 0:
        missed = np.full(n, float(missed))
    elif missed.shape != (n,):
        raise ValueError(f"missed_cost must be a number or have shape ({n},) (one per row "
                         f"of cost), got shape {missed.shape}")
    if np.isnan(missed).any() or (missed == -np.inf).any():
        raise ValueError("missed_cost contains NaN or -inf")
    out = np.full(n, -1, dtype=np.int64)
    detected = np.flatnonzero(np.isfinite(cost).any(axis=1))
    r = detected.size
    if r == 0:
        return out
    augmented = np.full((r, m + r), np.inf)
    augmented[:, :m] = cost[detected]
    augmented[np.arange(r), m + np.arange(r)] = missed[detected]
    row_to_col = np.empty(r, dtype=np.int64)
    if not _assign.lsap(augmented, row_to_col):
        must = int(np.isinf(missed[detected]).sum())
        raise ValueError(f"no feasible association: {must} tracks with missed_cost=inf must "
                         f"take a detection, and they cannot all be given one among their "
                         f"finite costs")
    out[detected] = np.where(row_to_col < m, row_to_col, -1)
    return out


def _gate_costs(gate, missed_distance, costs):
    """The candidates' costs (default: Stone Soup's distance-hypothesis cost, the
    Mahalanobis distance) and the missed-detection cost of each track."""
    checked(gate)
    missed = _validate.float_array(missed_distance, "missed_distance")
    if missed.ndim == 0:
        missed = np.full(gate.n_tracks, float(missed))
    if missed.shape != (gate.n_tracks,) or not np.all(missed > 0):
        raise ValueError(f"missed_distance must be > 0 (inf allowed), a number or one per "
                         f"track ({gate.n_tracks},), got {missed_distance!r}")
    if costs is None:
        return np.sqrt(gate.distances2), np.ascontiguousarray(missed)
    costs = _validate.float_array(costs, "costs", 1)
    if costs.shape != gate.detections.shape or np.isnan(costs).any() \
            or (costs == -np.inf).any():
        raise ValueError(f"costs must be one number per candidate {gate.detections.shape}, "
                         f"not NaN or -inf, got shape {costs.shape}")
    return costs, np.ascontiguousarray(missed)


def nearest_neighbour(gate, missed_distance, costs=None):
    """Greedy association (Stone Soup's ``NearestNeighbour``): the closest remaining
    (track, detection) pair or missed option first, each detection to at most one track.

    Parameters
    ----------
    gate : Gate
        The candidates; only gated pairs are hypotheses.
    missed_distance : float or (K,) array_like
        Distance of the missed-detection option (Stone Soup's ``missed_distance``), > 0.
    costs : (n,) array_like, optional
        The candidates' distances (default their Mahalanobis distance
        ``sqrt(gate.distances2)``).

    Returns
    -------
    (K,) int64 ndarray
        Each track's detection, -1 if missed.
    """
    costs, missed = _gate_costs(gate, missed_distance, costs)
    if _jit.numpy_first(gate.n_tracks + gate.n_detections):
        return _numpy.greedy_assignments(gate.starts, gate.detections, costs, missed,
                                         gate.n_detections)
    assigned = np.empty(gate.n_tracks, dtype=np.int64)
    _kernels.greedy_assignments(gate.starts, gate.detections, costs, missed,
                                gate.n_detections, assigned)
    return assigned


def global_nearest_neighbour(gate, missed_distance, clusters=None, costs=None):
    """Global nearest neighbour association (Stone Soup's ``GNNWith2DAssignment``): the
    joint assignment of minimum total distance, a missed track costing ``missed_distance``,
    solved exactly per cluster of the gate graph. A track without candidates is missed,
    whatever the cost.

    Parameters
    ----------
    gate : Gate
        The candidates; only gated pairs are hypotheses.
    missed_distance : float or (K,) array_like
        Distance of the missed-detection option, > 0; ``inf`` makes every track with
        candidates take one.
    clusters : Clusters, optional
        The gate's clusters (computed if not given).
    costs : (n,) array_like, optional
        The candidates' distances (default their Mahalanobis distance).

    Returns
    -------
    (K,) int64 ndarray
        Each track's detection, -1 if missed.

    Raises
    ------
    ValueError
        If no assignment of finite total cost exists (infinite missed distances).
    """
    costs, missed = _gate_costs(gate, missed_distance, costs)
    missed[np.diff(gate.starts) == 0] = 0.0  # alone: missed, at no cost
    if clusters is None:
        clusters = _clusters(gate)
    elif isinstance(clusters, Clusters):
        clusters.check(gate)
    else:
        raise TypeError(f"clusters must be Clusters, got {type(clusters).__name__}")
    labels = np.concatenate((clusters.track_labels, clusters.detection_labels))
    c, k, m = clusters.n_clusters, gate.n_tracks, gate.n_detections
    if _jit.numpy_first(k + m):
        assigned = _numpy.global_nearest_neighbour(gate.starts, gate.detections, costs, missed,
                                                   labels, c)
        if isinstance(assigned, tuple):
            _no_finite_association(*assigned)
        return assigned
    shapes = np.empty((c, 2), dtype=np.int64)
    offsets, row_offsets = np.empty(c + 1, dtype=np.int64), np.empty(c + 1, dtype=np.int64)
    track_rows, detection_columns = np.empty(k, dtype=np.int64), np.empty(m, dtype=np.int64)
    size = _kernels.gnn_problems(labels, c, k, m, shapes, offsets, row_offsets, track_rows,
                                 detection_columns)
    flat = np.empty(size)
    _kernels.gnn_fill(labels, gate.starts, gate.detections, costs, missed, shapes, offsets,
                      track_rows, detection_columns, flat)
    row_to_col, feasible = _solve(flat, offsets, shapes, row_offsets)
    if not feasible.all():
        bad = int(np.flatnonzero(~feasible)[0])
        _no_finite_association(shapes[bad, 0], shapes[bad, 1] - shapes[bad, 0])
    assigned = np.empty(k, dtype=np.int64)
    _kernels.gnn_assignments(labels, shapes, row_offsets, track_rows, detection_columns, m,
                             row_to_col, assigned)
    return assigned


def _no_finite_association(tracks, detections):
    raise ValueError(f"no association of finite cost: the {tracks} tracks of a cluster "
                     f"cannot all take one of its {detections} detections (missed_distance "
                     f"is inf)")
