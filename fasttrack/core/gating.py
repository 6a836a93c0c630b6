"""Gating of detections by tracks' predicted measurements, and the clusters of the gate
graph."""
import dataclasses

import numpy as np

from .. import _jit
from .. import _validate
from .. import threads as _threads
from .._jit.tunables import CHOLESKY_CONDITION, SERIAL_BELOW_LIGHT
from . import gating_numpy as _numpy

_kernels = _jit.lazy("gating")


@dataclasses.dataclass(frozen=True)
class Gate:
    """The candidate (track, detection) pairs of a gate, track by track.

    Attributes
    ----------
    starts : (K + 1,) int64 ndarray
        Track k's candidates are entries ``starts[k]:starts[k + 1]`` of the arrays below.
    detections : (n,) int64 ndarray
        Detection index of each candidate, ascending per track.
    distances2 : (n,) float64 ndarray
        Squared Mahalanobis distance ``v^T S^-1 v`` of each candidate (below the threshold).
    log_likelihoods : (n,) float64 ndarray
        ``log N(z; z_hat, S)`` of each candidate.
    n_detections : int
        M, the number of detections gated.
    """

    starts: np.ndarray
    detections: np.ndarray
    distances2: np.ndarray
    log_likelihoods: np.ndarray
    n_detections: int

    def __post_init__(self):
        """Check a gate built by hand."""
        object.__setattr__(self, "n_detections",
                           _validate.count(self.n_detections, "n_detections", minimum=0))
        for name in ("starts", "detections"):
            object.__setattr__(self, name, _indices(getattr(self, name), name))
        for name in ("distances2", "log_likelihoods"):
            object.__setattr__(self, name, _validate.float_array(getattr(self, name), name, 1))
        self.check()

    def check(self):
        """Raise a ValueError unless the indices the kernels follow are in range: ``starts``
        non-decreasing from 0 to n, ``detections`` (n,) in ``[0, n_detections)``, and the
        values (n,) (run on each use: the arrays can be written, or the fields replaced,
        after the gate is built)."""
        self._check_kinds()
        starts, detections, m = self.starts, self.detections, self.n_detections
        if starts.ndim != 1 or starts.size < 1 or starts[0] != 0 or (np.diff(starts) < 0).any():
            raise ValueError(f"gate.starts must be (K + 1,) non-decreasing from 0, got {starts}")
        n = int(starts[-1])
        if detections.shape != (n,) or (n and (detections.min() < 0 or detections.max() >= m)):
            raise ValueError(f"gate.detections must be starts[-1] = {n} indices in "
                             f"[0, n_detections = {m}), got {detections}")
        rising = np.diff(detections) > 0
        inner = starts[1:-1]
        rising[inner[(inner > 0) & (inner < n)] - 1] = True
        if not rising.all():
            raise ValueError("gate.detections must be ascending (no repeats) within each "
                             "track")
        for name in ("distances2", "log_likelihoods"):
            if getattr(self, name).shape != (n,):
                raise ValueError(f"gate.{name} must be starts[-1] = {n} numbers, got shape "
                                 f"{getattr(self, name).shape}")
        self._check_values()

    def _check_kinds(self):
        """TypeError unless the fields are of the kinds the kernels take (C-contiguous int64
        indices, float64 values, an int count)."""
        _validate.count(self.n_detections, "gate.n_detections", minimum=0)
        for name, kind in (("starts", np.int64), ("detections", np.int64),
                           ("distances2", np.float64), ("log_likelihoods", np.float64)):
            value = getattr(self, name)
            if not (isinstance(value, np.ndarray) and value.dtype == kind
                    and value.flags.c_contiguous):
                raise TypeError(f"gate.{name} must be a C-contiguous {np.dtype(kind)} ndarray, "
                                f"got {_validate._describe(value)}")

    def _check_values(self):
        """ValueError unless the candidates' distances are finite and >= 0 and their
        likelihoods not NaN or +inf (a gate holds only what lies within a finite
        threshold)."""
        d2, log_l = self.distances2, self.log_likelihoods  # (NaN fails each test below)
        if d2.size and not (d2.min() >= 0 and d2.max() < np.inf):
            raise ValueError("gate.distances2 must be finite and >= 0")
        if log_l.size and not log_l.max() < np.inf:
            raise ValueError("gate.log_likelihoods must not be NaN or +inf")

    @property
    def n_tracks(self):
        """K, the number of tracks."""
        return self.starts.size - 1

    def tracks(self):
        """The track index of each candidate, (n,) int64."""
        return np.repeat(np.arange(self.n_tracks), np.diff(self.starts))

    def dense(self, value="distances2", fill=np.inf):
        """A (K, M) matrix of ``value`` (``"distances2"`` or ``"log_likelihoods"``) at the
        candidates, ``fill`` elsewhere."""
        if value not in ("distances2", "log_likelihoods"):
            raise ValueError(f"value must be 'distances2' or 'log_likelihoods', got {value!r}")
        self.check()
        out = np.full((self.n_tracks, self.n_detections), fill)
        out[self.tracks(), self.detections] = getattr(self, value)
        return out


def _built(cls, *fields):
    """An instance of the frozen dataclass ``cls`` holding ``fields`` that this module made
    (not checked again)."""
    out = object.__new__(cls)
    for field, value in zip(dataclasses.fields(cls), fields):
        object.__setattr__(out, field.name, value)
    return out


def _indices(value, name):
    """``value`` as a 1-D int64 array (a TypeError unless it holds integers)."""
    a = np.asarray(value)
    if a.ndim != 1 or (a.dtype.kind not in "iu" and a.size):  # (an empty list is float64)
        raise TypeError(f"{name} must be a 1-D array of integers, got "
                        f"{a.ndim}-D {a.dtype}")
    return np.ascontiguousarray(a, dtype=np.int64)


def squared_distance(difference, covar):
    """``v^T S^-1 v`` for a (m,) ``difference`` v and a (m, m) covariance S, by S's
    Cholesky factor; None if S is not positive definite, or so ill-conditioned (its
    Cholesky pivots spread beyond ``CHOLESKY_CONDITION``) that the factor's answer could
    differ from a pseudo-inverse's by more than rounding."""
    try:
        lower = np.linalg.cholesky(covar)
    except np.linalg.LinAlgError:
        return None
    if lower.diagonal().min() ** 2 * CHOLESKY_CONDITION < covar.diagonal().max():
        return None
    whitened = np.linalg.solve(lower, difference)
    return float(whitened @ whitened)


def default_axes(angles):
    """The grid's default rows: the first two that are not angles (``angles`` (m,) bool)."""
    return np.flatnonzero(~angles)[:2].astype(np.int64)


def _grid_axes(m, angles, grid_axes):
    if grid_axes is None:
        return default_axes(angles)
    axes = np.array(_validate.indices(grid_axes, "grid_axes", m), dtype=np.int64)
    if axes.size > 2 or np.unique(axes).size != axes.size:
        raise ValueError(f"grid_axes must be up to 2 distinct measurement rows in [0, {m}), "
                         f"got {list(axes)}")
    if angles[axes].any():
        raise ValueError(f"grid_axes must not be angle rows, got {list(axes)} "
                         f"(angle rows {list(np.flatnonzero(angles))})")
    return axes


def _grid(detections, covars, axes, threshold):
    """Axes, origin, cell size and shape of the detection grid: cells as large as the median
    gate half-width, so that a typical gate meets a few cells; no axes (every track tests
    every detection) when there are none or the detections' extent overflows."""
    origin = np.zeros(2)
    none = np.empty(0, dtype=np.int64), origin, 1.0, np.ones(2, dtype=np.int64)
    if axes.size == 0 or detections.shape[0] == 0:
        return none
    with np.errstate(over="ignore", invalid="ignore"):
        extent = detections[:, axes].max(axis=0) - detections[:, axes].min(axis=0)
        spread = covars[:, axes, axes].max(axis=1) if covars.shape[0] else np.ones(1)
        cell = max(float(np.sqrt(threshold * np.median(spread))), 1e-300)
    if not (np.isfinite(extent).all() and np.isfinite(cell)):
        return none
    origin[:axes.size] = detections[:, axes].min(axis=0)
    cell = max(cell, float(extent.max()) / 2**30)  # at most 2^30 cells a side
    shape = np.ones(2, dtype=np.int64)
    shape[:axes.size] = np.floor(extent / cell).astype(np.int64) + 1
    return axes, origin, cell, shape


def gate(z_hats, innovation_covars, detections, threshold, angles=None, grid_axes=None):
    """The detections in each track's gate ``v^T S^-1 v < threshold``.

    Parameters
    ----------
    z_hats : (K, m) array_like
        Predicted measurement of each track.
    innovation_covars : (K, m, m) array_like
        Innovation covariance S of each track, symmetric positive definite.
    detections : (M, m) array_like
        Measurements (an empty list for none).
    threshold : float
        Squared Mahalanobis distance of the gate, finite, > 0 (Stone Soup's
        ``missed_distance`` d gives ``d**2``; a gate of probability P_G in m dimensions
        ``chi2.ppf(P_G, m)``).
    angles : (m,) array_like of bool, optional
        Angle rows, wrapped to [-pi, pi) in the innovations (default none).
    grid_axes : sequence of int, optional
        Up to two non-angle rows on which detections are bucketed (default the first two
        non-angle rows); with none every track tests every detection.

    Returns
    -------
    Gate

    Raises
    ------
    ValueError
        For shapes that do not match, non-finite values, a threshold that is not finite
        and > 0, or an innovation covariance that is not positive definite (naming the
        track).
    """
    z_hats = _validate.finite_array(z_hats, "z_hats", 2)
    k, m = z_hats.shape
    if m < 1:
        raise ValueError(f"z_hats must have shape (K, m) with m >= 1, got {z_hats.shape}")
    covars = _validate.finite_array(innovation_covars, "innovation_covars", 3)
    if covars.shape != (k, m, m):
        raise ValueError(f"innovation_covars must have shape ({k}, {m}, {m}), "
                         f"got {covars.shape}")
    _validate.symmetric_stack(covars, "innovation_covars")
    detections = _validate.finite_array(detections, "detections")
    if detections.shape == (0,):  # (an empty list)
        detections = detections.reshape(0, m)
    if detections.ndim != 2 or detections.shape[1] != m:
        raise ValueError(f"detections must have shape (M, {m}), got {detections.shape}")
    threshold = _validate.positive(threshold, "threshold")
    angles = (np.zeros(m, dtype=np.bool_) if angles is None
              else _validate.bool_array(angles, "angles", (m,)))
    _validate.angle_columns(z_hats, angles, "z_hats")
    _validate.angle_columns(detections, angles, "detections")
    return gate_arrays(z_hats, covars, detections, threshold, angles,
                       _grid_axes(m, angles, grid_axes))


def gate_arrays(z_hats, covars, detections, threshold, angles, axes):
    """:func:`gate` of checked float64 arrays, ``threshold`` > 0 or ``inf`` (every pair),
    ``angles`` a bool mask (None: none), ``axes`` the grid rows (int64, none for no grid)."""
    k = z_hats.shape[0]
    if angles is None:
        angles = np.zeros(z_hats.shape[1], dtype=np.bool_)
    z_hats, covars, detections = map(np.ascontiguousarray, (z_hats, covars, detections))
    if _jit.numpy_first(k + detections.shape[0]):
        found = _numpy.gate(z_hats, covars, detections, threshold, angles)
        if isinstance(found, int):
            _not_positive_definite(found)
        return _built(Gate, *found, detections.shape[0])
    axes, origin, cell, shape = _grid(detections, covars, axes, threshold)
    keys = np.empty(detections.shape[0], dtype=np.int64)
    _kernels.cell_keys(detections, axes, origin, cell, shape, keys)
    order = np.argsort(keys, kind="stable")
    sorted_keys = np.ascontiguousarray(keys[order])
    starts = np.empty(k + 1, dtype=np.int64)
    status = np.empty(k, dtype=np.int64)
    grid = (detections, order, sorted_keys, axes, angles, origin, cell, shape, threshold)

    def scan(write, found):  # one pass of the gate kernel, on chunks of the tracks
        _threads.in_chunks(lambda lo, hi: _kernels.gate(
            z_hats[lo:hi], covars[lo:hi], *grid, write, starts[lo:hi + 1], *found,
            status[lo:hi]), k, SERIAL_BELOW_LIGHT, work=z_hats.size)

    scan(False, (np.empty(0, dtype=np.int64), np.empty(0), np.empty(0)))  # count
    if status.any():
        _not_positive_definite(int(np.flatnonzero(status)[0]))
    starts[0] = 0
    np.cumsum(starts, out=starts)
    n = int(starts[-1])
    found = np.empty(n, dtype=np.int64), np.empty(n), np.empty(n)
    scan(True, found)  # store
    return _built(Gate, starts, *found, detections.shape[0])


def checked(gate):
    """``gate``, a TypeError unless it is a :class:`Gate`, a ValueError unless its indices
    are in range (see :meth:`Gate.check`)."""
    if not isinstance(gate, Gate):
        raise TypeError(f"gate must be a Gate, got {type(gate).__name__}")
    gate.check()
    return gate


def _not_positive_definite(track):
    raise ValueError(f"innovation_covars[{track}] is not positive definite")


@dataclasses.dataclass(frozen=True)
class Clusters:
    """Independent groups of tracks and detections: the connected components of the gate
    graph (a track and a detection are joined when the detection is in the track's gate).

    Attributes
    ----------
    track_labels : (K,) int64 ndarray
        Cluster of each track.
    detection_labels : (M,) int64 ndarray
        Cluster of each detection (a detection in no gate is a cluster of its own).
    n_clusters : int
    """

    track_labels: np.ndarray
    detection_labels: np.ndarray
    n_clusters: int

    def __post_init__(self):
        """Check clusters built by hand."""
        object.__setattr__(self, "n_clusters",
                           _validate.count(self.n_clusters, "n_clusters", minimum=0))
        for name in ("track_labels", "detection_labels"):
            object.__setattr__(self, name, _indices(getattr(self, name), name))
        self._check_labels()

    def _check_labels(self):
        c = self.n_clusters
        for name in ("track_labels", "detection_labels"):
            labels = getattr(self, name)
            if labels.ndim != 1 or (labels.size and (labels.min() < 0 or labels.max() >= c)):
                raise ValueError(f"clusters.{name} must lie in [0, n_clusters = {c}), "
                                 f"got {labels}")

    def check(self, gate):
        """Raise a ValueError unless these are clusters of ``gate``: a label in range per
        track and detection, and each candidate's track and detection in one cluster (run
        on each use: the arrays can be written after they are built)."""
        self._check_labels()
        if self.track_labels.size != gate.n_tracks or \
                self.detection_labels.size != gate.n_detections:
            raise ValueError(f"clusters must label the gate's {gate.n_tracks} tracks and "
                             f"{gate.n_detections} detections, got {self.track_labels.size} "
                             f"and {self.detection_labels.size}")
        split = self.track_labels[gate.tracks()] != self.detection_labels[gate.detections]
        if split.any():
            raise ValueError("clusters must hold each gated (track, detection) pair in one "
                             "cluster: they are not the gate's")

    def members(self, c):
        """The tracks and detections of cluster ``c``, two ascending int64 arrays."""
        if not _validate.is_integer(c):
            raise TypeError(f"c must be an int cluster number, got {type(c).__name__}")
        if not 0 <= c < self.n_clusters:
            raise ValueError(f"c must lie in [0, n_clusters = {self.n_clusters}), got {c}")
        return (np.flatnonzero(self.track_labels == c),
                np.flatnonzero(self.detection_labels == c))


def clusters(gate):
    """The clusters of a :class:`Gate`, numbered in order of their first track (then of
    the detections in no gate)."""
    checked(gate)
    k = gate.n_tracks
    if _jit.numpy_first(k + gate.n_detections):
        labels, n = _numpy.clusters(gate.starts, gate.detections, gate.n_detections)
    else:
        labels = np.empty(k + gate.n_detections, dtype=np.int64)
        n = _kernels.clusters(gate.starts, gate.detections, gate.n_detections, labels)
    return _built(Clusters, labels[:k], labels[k:], int(n))
