"""Joint probabilistic data association (JPDA) on arrays: the hypothesis weights of Stone
Soup's ``PDAHypothesiser`` (:func:`pda_weights`) and the exact marginal association
probabilities of ``JPDA`` / ``JPDAwithEHM`` per cluster (:func:`jpda_marginals`, by
efficient hypothesis management).

A cluster's weights are a (T, M + 1) matrix: row t for track t, column 0 its missed
detection, column j >= 1 detection j - 1, 0 for a hypothesis outside the gate. Tracks that
share no detection (even indirectly) are independent: split them into clusters (connected
components of the nonzero pattern of the detection columns) before calling
:func:`jpda_marginals`; one big cluster gives the same marginals, only more slowly.

Stone Soup's formulas (``stonesoup.hypothesiser.probability``, 1.9.1), for a track with
predicted measurement ``z_hat`` and innovation covariance ``S`` (dimension m):

- missed detection: ``1 - prob_detect * prob_gate``;
- detection z with squared Mahalanobis distance ``d2 <= chi2.ppf(prob_gate, m)`` (or any
  d2 when ``include_all``): ``prob_detect * N(z; z_hat, S) / clutter_spatial_density``;
  the pdf is the plain Gaussian, not truncated to the gate;
- with no clutter density: ``prob_detect * N(z; z_hat, S) * V / n``, V the volume of the
  gate ellipsoid ``pi**(m/2) / Gamma(m/2 + 1) * chi2.ppf(prob_gate, m)**(m/2) *
  sqrt(det S)`` and n the number of detections inside the gate;
- then (``normalise=True``, the default) each row is divided by its sum; with
  ``prob_gate = 1`` and no clutter density (where Stone Soup's weights are infinite) the
  rows are their limits as ``prob_gate`` tends to 1: a track with detections in its gate
  has a missed-detection probability of 0 and detection probabilities in proportion to
  ``exp(-d2 / 2)``.

The JPDA marginals do not depend on the row normalisation.
"""
import functools
import math

import numpy as np

from .. import _jit
from .. import _validate
from .. import threads as _threads
from .._jit.tunables import (ENUMERATED_EVENTS, MAX_FRONTIER, MAX_NODES, SERIAL_BELOW_HEAVY,
                              SERIAL_BELOW_PAIRS)
from .gating import clusters

_kernels = _jit.lazy("jpda")


@functools.lru_cache(maxsize=256)
def _gate(prob_gate, m):
    """Stone Soup's gate threshold ``chi2.ppf(prob_gate, m)`` and the factor of the gate
    volume ``pi**(m/2) / Gamma(m/2 + 1) * threshold**(m/2)`` (times ``sqrt(det S)``).

    The threshold is computed as scipy's chi2 computes it, ``2 gammaincinv(m/2, p)``
    (identical values), without importing scipy.stats (half a second)."""
    from scipy.special import gammaincinv
    threshold = float(2.0 * gammaincinv(m / 2, prob_gate))
    if threshold == 0.0:  # (prob_gate = 0: a gate of no volume)
        return threshold, 0.0
    try:  # (in logs: Gamma(m/2 + 1) alone overflows from m = 343)
        return threshold, math.exp(m / 2 * math.log(math.pi * threshold)
                                   - math.lgamma(m / 2 + 1))
    except OverflowError:
        raise ValueError(f"detections of {m} dimensions: their gate volume is beyond the float "
                         f"range") from None


def pda_weights(means, covars, detections, prob_detect=0.85, prob_gate=0.95,
                clutter_spatial_density=None, gate=None, angles=None, include_all=False,
                normalise=True):
    """PDA hypothesis weights of T tracks against M detections, as Stone Soup's
    ``PDAHypothesiser`` computes them.

    Parameters
    ----------
    means : (T, m) array_like
        Each track's predicted measurement ``z_hat``.
    covars : (T, m, m) array_like
        Each track's innovation covariance ``S = H P H^T + R`` (symmetric positive
        definite).
    detections : (M, m) array_like
        The detections' measurement vectors (M may be 0).
    prob_detect : float
        Probability of detection, in [0, 1] (Stone Soup's default 0.85).
    prob_gate : float
        Probability that the gate holds a detected target's measurement, in [0, 1]
        (default 0.95); the gate is ``d2 <= chi2.ppf(prob_gate, m)``.
    clutter_spatial_density : float, optional
        Clutter density (> 0). None: Stone Soup's estimate from the gate volume and the
        number of detections inside the gate.
    gate : (T, M) bool array_like, optional
        Pairs that may associate at all (e.g. from a coarse gating step). A False pair
        gets weight 0 and is not counted inside the gate; None allows every pair.
    angles : (m,) bool array_like, optional
        Components that are angles: their innovations are wrapped to [-pi, pi) (as Stone
        Soup's ``Bearing`` components are).
    include_all : bool
        Keep detections outside the gate (needs ``clutter_spatial_density``).
    normalise : bool
        Divide each row by its sum (Stone Soup's default), so row t holds the
        hypothesiser's probabilities.

    Returns
    -------
    weights : (T, M + 1) ndarray
        Column 0 the missed detection, column j >= 1 detection j - 1; 0 outside the gate.

    Raises
    ------
    ValueError
        For wrong shapes, non-finite values, probabilities outside [0, 1], a covariance
        that is not symmetric positive definite, ``include_all`` without a clutter density,
        or (with ``normalise``) a track with no possible hypothesis.
    TypeError
        For non-numeric arrays, a non-boolean ``gate`` or ``angles``, a non-bool flag.
    """
    means = _validate.finite_array(means, "means", 2)
    n_tracks, m = means.shape
    if m < 1:
        raise ValueError(f"means must have shape (T, m) with m >= 1, got {means.shape}")
    covars = _validate.finite_array(covars, "covars", 3)
    if covars.shape != (n_tracks, m, m):
        raise ValueError(f"covars must have shape {(n_tracks, m, m)} (means has shape "
                         f"{means.shape}), got {covars.shape}")
    detections = _validate.finite_array(detections, "detections")
    if detections.ndim == 1 and detections.size == 0:
        detections = detections.reshape(0, m)
    if detections.ndim != 2 or detections.shape[1] != m:
        raise ValueError(f"detections must have shape (M, {m}) (means has {m} components), "
                         f"got {detections.shape}")
    n_dets = detections.shape[0]
    prob_detect = _validate.probability(prob_detect, "prob_detect")
    prob_gate = _validate.probability(prob_gate, "prob_gate")
    include_all = _validate.flag(include_all, "include_all")
    normalise = _validate.flag(normalise, "normalise")
    if clutter_spatial_density is None:
        if include_all:
            raise ValueError("include_all=True needs a clutter_spatial_density (got None)")
        density = 0.0
    else:
        density = _validate.positive(clutter_spatial_density, "clutter_spatial_density")
    gate = (np.ones((n_tracks, n_dets), dtype=np.bool_) if gate is None
            else _validate.bool_array(gate, "gate", (n_tracks, n_dets)))
    angles = (np.zeros(m, dtype=np.bool_) if angles is None
              else _validate.bool_array(angles, "angles", (m,)))
    _validate.angle_columns(means, angles, "means")
    _validate.angle_columns(detections, angles, "detections")
    if n_tracks:
        asym = _validate.asymmetric(covars)
        if asym.any():
            raise ValueError(f"covars[{int(np.argmax(asym))}] must be symmetric")

    if prob_gate == 1.0 and density == 0.0 and n_tracks and not normalise:
        raise ValueError("prob_gate=1 makes the gate infinite, so the clutter density "
                         "estimated from it is 0 and the detections' weights infinite: "
                         "give clutter_spatial_density, prob_gate < 1 or normalise=True")
    threshold, volume_factor = _gate(prob_gate, m)
    out = np.empty((n_tracks, n_dets + 1))
    status = np.empty(n_tracks, dtype=np.int64)
    _threads.in_chunks(lambda lo, hi: _kernels.pda_weight_matrix(
        means[lo:hi], covars[lo:hi], detections, angles, gate[lo:hi], prob_detect, prob_gate,
        threshold, density, volume_factor, include_all, out[lo:hi], status[lo:hi]),
        n_tracks, SERIAL_BELOW_PAIRS, work=out.size)
    if n_tracks and status.any():
        t = int(np.flatnonzero(status)[0])
        raise ValueError(f"covars[{t}] is not positive definite")
    if not np.isfinite(out).all():
        t = int(np.flatnonzero(~np.isfinite(out).all(axis=1))[0])
        density = f"clutter_spatial_density={clutter_spatial_density!r} is" \
            if clutter_spatial_density is not None else \
            f"the clutter density estimated from covars[{t}]'s gate volume is"
        raise ValueError(f"track {t}'s detection weights prob_detect N(z; z_hat, S) / "
                         f"clutter density overflow: {density} too small for its likelihoods")
    if normalise and n_tracks:
        sums = out.sum(axis=1)
        if not (sums > 0).all():
            t = int(np.flatnonzero(~(sums > 0))[0])
            raise ValueError(f"track {t} has no possible hypothesis: its missed-detection "
                             f"weight 1 - prob_detect * prob_gate is 0 and no detection is "
                             f"inside its gate")
        out /= sums[:, None]
    return out


def _is_cluster_list(weights):
    if isinstance(weights, np.ndarray) or not isinstance(weights, (list, tuple)):
        return False
    return len(weights) == 0 or any(np.ndim(w) == 2 for w in weights)  # (each is checked)


def _cluster(value, name):
    """``value`` as a float64 (T, M + 1) matrix (its entries are checked by _check)."""
    w = _validate.float_array(value, name, 2)
    if w.shape[1] < 1:
        raise ValueError(f"{name} must have shape (T, M + 1) with at least the "
                         f"missed-detection column, got {w.shape}")
    return w


def _check(w, name):
    """Raise for non-finite or negative entries of ``w``."""
    if not np.isfinite(w).all():
        bad = "NaN" if np.isnan(w).any() else "infinite values"
        raise ValueError(f"{name} contains {bad}")
    if (w < 0).any():
        raise ValueError(f"{name} contains negative weights")


def _row_scaled(w):
    """``w`` with each row divided by its largest entry: the same marginals (each joint
    event takes one entry a row), with no product of a row's entries overflowing."""
    top = w.max(axis=1, keepdims=True, initial=0.0)
    return w / np.where(top > 0, top, 1.0)


def _raise(code, detail, name, shape, max_nodes):
    size = f"{shape[0]} tracks x {shape[1] - 1} detections"
    if code == _kernels.EHM_FRONTIER:
        raise ValueError(
            f"{name} ({size}) is too big for exact JPDA: its EHM net would need a frontier "
            f"of {detail} shared detections, more than {MAX_FRONTIER}; split the cluster "
            f"(tighter gating) or use an approximate association")
    if code == _kernels.EHM_NODES:
        raise ValueError(
            f"{name} ({size}) is too big for exact JPDA: its EHM net needs more than "
            f"max_nodes={max_nodes} nodes; split the cluster (tighter gating), raise "
            f"max_nodes or use an approximate association")
    _unassociable(detail, name, shape)


def _unassociable(row, name, shape):
    """Raise for a cluster with a row of zero weights (``row`` >= 0) or no joint event of
    positive weight (``row`` -1)."""
    if row >= 0:
        raise ValueError(f"{name} row {row} is all zero: track {row} has no possible "
                         f"hypothesis")
    raise ValueError(f"{name} ({shape[0]} tracks x {shape[1] - 1} detections) has no joint "
                     f"association of positive weight: every joint event gives some "
                     f"detection to two tracks")


def _enumerable(clusters, max_nodes):
    """Whether the clusters' joint events are few enough to enumerate in NumPy (a process's
    first small calls, see :func:`fasttrack._jit.numpy_first`; not more than an EHM net of
    ``max_nodes`` nodes could hold)."""
    events = [np.prod((w > 0).sum(axis=1), dtype=np.float64) for w in clusters]
    return all(e * w.shape[0] <= min(max_nodes, ENUMERATED_EVENTS)
               for e, w in zip(events, clusters)) and _jit.numpy_first(int(sum(events)))


def _enumerated(w):
    """``(marginals, row)`` of a (T, M + 1) cluster by enumerating its joint events in
    NumPy; ``row`` None, else as :func:`_unassociable` takes it."""
    if w.shape[0] == 0:
        return np.zeros_like(w), None
    options = [np.flatnonzero(row > 0) for row in w]
    if any(o.size == 0 for o in options):
        return None, next(t for t, o in enumerate(options) if o.size == 0)
    t = w.shape[0]
    events = np.stack(np.meshgrid(*options, indexing="ij"), axis=-1).reshape(-1, t)
    ordered = np.sort(events, axis=1)
    events = events[~((ordered[:, 1:] == ordered[:, :-1]) & (ordered[:, 1:] > 0)).any(axis=1)]
    weights = np.prod(w[np.arange(t), events], axis=1)
    total = weights.sum()
    if not total > 0:
        return None, -1
    weights /= total
    out = np.zeros_like(w)
    for row in range(t):
        np.add.at(out[row], events[:, row], weights)
    return out, None


def jpda_marginals(weights, max_nodes=MAX_NODES):
    """Exact JPDA marginal association probabilities, per cluster (efficient hypothesis
    management): Stone Soup's ``JPDA`` and ``JPDAwithEHM`` probabilities.

    Parameters
    ----------
    weights : (T, M + 1) array_like, or a list of them
        One cluster's hypothesis weights (>= 0; column 0 missed detection, column j
        detection j - 1; 0 = impossible), e.g. from :func:`pda_weights`; or a list of
        clusters, computed in parallel.
    max_nodes : int
        Most nodes of one cluster's EHM net (:data:`MAX_NODES` by default), a bound on
        time and memory.

    Returns
    -------
    marginals : (T, M + 1) ndarray, or a list of them
        ``marginals[t, j]``: the probability that track t takes hypothesis j given that no
        detection goes to two tracks; each row sums to 1 and is 0 where ``weights`` is.
        For a list: one array per cluster (views of one buffer).

    Raises
    ------
    ValueError
        For a non-finite or negative weight, a row with no positive weight, a cluster with
        no joint event of positive weight, or a cluster too big for exact association
        (an EHM frontier of more than :data:`MAX_FRONTIER` detections, or more than
        ``max_nodes`` nodes); the message names the cluster and its size.
    TypeError
        For non-numeric weights or a non-integer ``max_nodes``.
    """
    max_nodes = _validate.count(max_nodes, "max_nodes")
    if not _is_cluster_list(weights):
        w = _cluster(weights, "weights")
        _check(w, "weights")
        w = _row_scaled(w)
        if _enumerable([w], max_nodes):
            out, row = _enumerated(w)
            if out is None:
                _unassociable(row, "weights", w.shape)
            return out
        out = np.empty_like(w)
        code, detail = _kernels.ehm_marginals(w, max_nodes, out)
        if code != _kernels.EHM_OK:
            _raise(code, detail, "weights", w.shape, max_nodes)
        return out
    clusters = [_cluster(w, f"weights[{k}]") for k, w in enumerate(weights)]
    if not clusters:
        return []
    for k, w in enumerate(clusters):
        _check(w, f"weights[{k}]")
    clusters = [_row_scaled(w) for w in clusters]
    shapes = np.array([(w.shape[0], w.shape[1] - 1) for w in clusters], dtype=np.int64)
    offsets = np.zeros(len(clusters) + 1, dtype=np.int64)
    np.cumsum([w.size for w in clusters], out=offsets[1:])
    flat = np.concatenate([w.reshape(-1) for w in clusters])
    if _enumerable(clusters, max_nodes):
        found = [_enumerated(w) for w in clusters]
        for k, (w, (out, row)) in enumerate(zip(clusters, found)):
            if out is None:
                _unassociable(row, f"weights[{k}]", w.shape)
        return [out for out, _ in found]
    out = np.empty_like(flat)
    info = np.empty((len(clusters), 2), dtype=np.int64)
    _threads.in_chunks(lambda lo, hi: _kernels.ehm_marginals_batch(
        flat, offsets[lo:hi + 1], shapes[lo:hi], max_nodes, out, info[lo:hi]),
        len(clusters), SERIAL_BELOW_HEAVY, work=flat.size, per_thread=4)
    bad = np.flatnonzero(info[:, 0])
    if bad.size:
        k = int(bad[0])
        _raise(info[k, 0], int(info[k, 1]), f"weights[{k}]", clusters[k].shape, max_nodes)
    return [out[offsets[k]:offsets[k + 1]].reshape(w.shape) for k, w in enumerate(clusters)]


def gate_marginals(gate, log_missed, log_weights, max_nodes=MAX_NODES):
    """Exact JPDA marginals of the candidate pairs of a :class:`~fasttrack.core.gating.Gate`
    (:func:`jpda_marginals` on each cluster of tracks that share detections; a track alone
    gets its normalised weights).

    Parameters
    ----------
    gate : Gate
        The pairs that may associate (its distances and likelihoods are not read).
    log_missed : float or (K,) ndarray
        The log weight of each track's missed detection.
    log_weights : (n,) ndarray
        The log weight of each candidate pair, in the gate's order.
    max_nodes : int
        As :func:`jpda_marginals`'.

    Returns
    -------
    marginal_missed : (K,) ndarray
        Each track's probability of no detection.
    marginal : (n,) ndarray
        Each pair's probability.
    """
    starts, candidates = gate.starts, gate.detections
    k = starts.size - 1
    owners = np.repeat(np.arange(k), np.diff(starts))
    row_max = np.broadcast_to(np.asarray(log_missed, dtype=np.float64), (k,)).copy()
    np.maximum.at(row_max, owners, log_weights)
    missed = np.exp(log_missed - row_max)
    weights = np.exp(log_weights - row_max[owners])
    totals = missed.copy()
    np.add.at(totals, owners, weights)
    marginal_missed, marginal = missed / totals, weights / totals[owners]
    groups = clusters(gate)
    sizes = np.bincount(groups.track_labels, minlength=groups.n_clusters)
    shared = np.flatnonzero(sizes > 1)  # clusters of one track: its normalised weights
    if shared.size == 0:
        return marginal_missed, marginal
    members = np.split(np.argsort(groups.track_labels, kind="stable"), np.cumsum(sizes)[:-1])
    column = np.empty(gate.n_detections, dtype=np.int64)
    matrices, rows = [], []
    for c in shared:
        tracks = members[c]
        qs = [np.arange(starts[t], starts[t + 1]) for t in tracks]
        dets = np.unique(candidates[np.concatenate(qs)])
        column[dets] = np.arange(1, dets.size + 1)
        matrix = np.zeros((tracks.size, dets.size + 1))
        matrix[:, 0] = missed[tracks]
        for i, q in enumerate(qs):
            matrix[i, column[candidates[q]]] = weights[q]
        matrices.append(matrix)
        rows.append((tracks, qs))
    for result, (tracks, qs) in zip(jpda_marginals(matrices, max_nodes), rows):
        marginal_missed[tracks] = result[:, 0]
        for i, q in enumerate(qs):  # (a detection is in one cluster: its column stays)
            marginal[q] = result[i, column[candidates[q]]]
    return marginal_missed, marginal
