"""Nearest-neighbour and global-nearest-neighbour association on a :class:`~.Gate`."""
import numpy as np

from .. import _validate
from .._jit import assign as _assign
from .._jit import gating as _kernels
from .gating import clusters as _clusters


def _costs(gate, missed_distance):
    """Stone Soup's distance-hypothesis costs: the Mahalanobis distance of each candidate,
    and ``missed_distance`` (scalar or per track) for a track taking no detection."""
    missed = _validate.float_array(missed_distance, "missed_distance")
    if missed.ndim == 0:
        missed = np.full(gate.n_tracks, float(missed))
    if missed.shape != (gate.n_tracks,) or not np.all(missed > 0):
        raise ValueError(f"missed_distance must be > 0, a number or one per track "
                         f"({gate.n_tracks},), got {missed_distance!r}")
    return np.sqrt(gate.distances2), np.ascontiguousarray(missed)


def nearest_neighbour(gate, missed_distance):
    """Greedy association (Stone Soup's ``NearestNeighbour``): the closest remaining
    (track, detection) pair or missed option first, each detection to at most one track.

    Parameters
    ----------
    gate : Gate
        The candidates; only gated pairs are hypotheses.
    missed_distance : float or (K,) array_like
        Distance of the missed-detection option (Stone Soup's ``missed_distance``), > 0.

    Returns
    -------
    (K,) int64 ndarray
        Each track's detection, -1 if missed.
    """
    costs, missed = _costs(gate, missed_distance)
    assigned = np.empty(gate.n_tracks, dtype=np.int64)
    _kernels.greedy_assignments(gate.starts, gate.detections, costs, missed,
                                gate.n_detections, assigned)
    return assigned


def global_nearest_neighbour(gate, missed_distance, clusters=None):
    """Global nearest neighbour association (Stone Soup's ``GNNWith2DAssignment``): the
    joint assignment of minimum total distance, a missed track costing ``missed_distance``,
    solved exactly per cluster of the gate graph.

    Parameters
    ----------
    gate : Gate
        The candidates; only gated pairs are hypotheses.
    missed_distance : float or (K,) array_like
        Distance of the missed-detection option, > 0.
    clusters : Clusters, optional
        The gate's clusters (computed if not given).

    Returns
    -------
    (K,) int64 ndarray
        Each track's detection, -1 if missed.
    """
    costs, missed = _costs(gate, missed_distance)
    clusters = _clusters(gate) if clusters is None else clusters
    labels = np.concatenate((clusters.track_labels, clusters.detection_labels))
    c, k, m = clusters.n_clusters, gate.n_tracks, gate.n_detections
    shapes = np.empty((c, 2), dtype=np.int64)
    offsets, row_offsets = np.empty(c + 1, dtype=np.int64), np.empty(c + 1, dtype=np.int64)
    track_rows, detection_columns = np.empty(k, dtype=np.int64), np.empty(m, dtype=np.int64)
    size = _kernels.gnn_problems(labels, c, k, m, shapes, offsets, row_offsets, track_rows,
                                 detection_columns)
    flat = np.empty(size)
    _kernels.gnn_fill(labels, gate.starts, gate.detections, costs, missed, shapes, offsets,
                      track_rows, detection_columns, flat)
    row_to_col = np.empty(k, dtype=np.int64)
    feasible = np.empty(c, dtype=np.bool_)
    _assign.lsap_batch(flat, offsets, shapes, row_offsets, row_to_col, feasible)
    assigned = np.empty(k, dtype=np.int64)
    _kernels.gnn_assignments(labels, shapes, row_offsets, track_rows, detection_columns, m,
                             row_to_col, assigned)
    return assigned
