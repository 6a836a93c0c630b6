"""Nearest-neighbour and global-nearest-neighbour association on a :class:`~.Gate`."""
import numpy as np

from .. import _validate
from .._jit import assign as _assign
from .._jit import gating as _kernels
from .gating import clusters as _clusters


def _costs(gate, missed_distance, costs):
    """The candidates' costs (default: Stone Soup's distance-hypothesis cost, the
    Mahalanobis distance) and the missed-detection cost of each track."""
    missed = _validate.float_array(missed_distance, "missed_distance")
    if missed.ndim == 0:
        missed = np.full(gate.n_tracks, float(missed))
    if missed.shape != (gate.n_tracks,) or not np.all(missed > 0):
        raise ValueError(f"missed_distance must be > 0 (inf allowed), a number or one per "
                         f"track ({gate.n_tracks},), got {missed_distance!r}")
    if costs is None:
        return np.sqrt(gate.distances2), np.ascontiguousarray(missed)
    costs = _validate.float_array(costs, "costs", 1)
    if costs.shape != gate.detections.shape or np.isnan(costs).any():
        raise ValueError(f"costs must be one number per candidate {gate.detections.shape}, "
                         f"not NaN, got shape {costs.shape}")
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
    costs, missed = _costs(gate, missed_distance, costs)
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
    costs, missed = _costs(gate, missed_distance, costs)
    missed[np.diff(gate.starts) == 0] = 0.0  # alone: missed, at no cost
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
    if not feasible.all():
        bad = int(np.flatnonzero(~feasible)[0])
        raise ValueError(f"no association of finite cost: the {shapes[bad, 0]} tracks of a "
                         f"cluster cannot all take one of its "
                         f"{shapes[bad, 1] - shapes[bad, 0]} detections (missed_distance is "
                         f"inf)")
    assigned = np.empty(k, dtype=np.int64)
    _kernels.gnn_assignments(labels, shapes, row_offsets, track_rows, detection_columns, m,
                             row_to_col, assigned)
    return assigned
