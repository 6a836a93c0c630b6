"""Gaussian mixtures on plain arrays: a mixture is a stack of K components, (K, d) means,
(K, d, d) covariances and (K,) log weights, with int64 labels grouping components (the
hypotheses of one track, the components one reduction merges)."""
import numpy as np

from .. import _jit, _validate
from .._jit.kinds import STONESOUP, TEXTBOOK
from . import kalman_numpy as _kalman_numpy
from . import mixture_numpy as _numpy

_mixture = _jit.lazy("mixture")

#: The reduction rules by name (see :func:`reduce`).
MODES = {"textbook": TEXTBOOK, "stonesoup": STONESOUP}


def segment_logsumexp(values, starts):
    """(S,) ``log sum exp`` of each CSR segment ``values[starts[s]:starts[s + 1]]`` of a
    (K,) float64 array (-inf for an empty segment or one of zero weights); ``starts``
    (S + 1,) integers, non-decreasing within ``[0, K]`` (ValueError otherwise)."""
    values = _validate.float_array(values, "values")
    starts = np.ascontiguousarray(starts)
    if values.ndim != 1 or starts.ndim != 1 or starts.size < 1 or starts.dtype.kind not in "iu":
        raise ValueError(f"values must be 1-D and starts a non-empty 1-D integer array, got "
                         f"shapes {values.shape} and {starts.shape} ({starts.dtype})")
    if starts[0] < 0 or starts[-1] > values.size or (np.diff(starts) < 0).any():
        raise ValueError(f"starts must be non-decreasing within [0, {values.size}] (the "
                         f"values), got {starts}")
    if _jit.numpy_first(starts.size - 1):
        return _segment_logsumexp(values, starts)
    out = np.empty(starts.size - 1)
    _mixture.segment_logsumexp(values, starts.astype(np.int64, copy=False), out)
    return out


def _segment_logsumexp(values, starts):
    """:func:`segment_logsumexp` in NumPy, as the kernel computes it (NaN for a NaN value,
    +inf for a +inf one)."""
    out = np.empty(starts.size - 1)
    for s in range(out.size):
        segment = values[starts[s]:starts[s + 1]]
        peak = segment.max() if segment.size else -np.inf
        shift = peak if abs(peak) <= np.finfo(np.float64).max else 0.0
        total = np.exp(segment - shift).sum()
        out[s] = -np.inf if total == 0.0 else np.log(total) + shift
    return out


def component_gains(covars, cross, innovation):
    """``(gains, updated)``: each component's Kalman gain ``K = C S^-1`` (J, d, m) and
    posterior covariance ``P - K C^T`` (J, d, d, symmetric) from its covariance P
    (J, d, d), ``cross`` C = P H^T (J, d, m) and innovation covariance S (J, m, m)
    (:func:`fasttrack._jit.mixture.component_gains`). Raises ValueError, naming the
    argument, for stacks that are not finite or whose shapes disagree, a P or S that is not
    symmetric (the kernel reads lower triangles), and naming the first component whose S
    is not positive definite."""
    covars, cross, innovation = (_validate.finite_array(a, name, 3) for a, name in (
        (covars, "covars"), (cross, "cross"), (innovation, "innovation")))
    j, d, m = cross.shape
    if covars.shape != (j, d, d) or innovation.shape != (j, m, m):
        raise ValueError(f"covars, cross and innovation must have shapes (J, d, d), (J, d, m) "
                         f"and (J, m, m), got {covars.shape}, {cross.shape} and "
                         f"{innovation.shape}")
    _validate.symmetric_stack(covars, "covars")
    _validate.symmetric_stack(innovation, "innovation")
    gains, updated = np.empty(cross.shape), np.empty(covars.shape)
    run = _numpy.component_gains if _jit.numpy_first(covars.size) else _mixture.component_gains
    failed = run(covars, np.ascontiguousarray(cross), np.ascontiguousarray(innovation), gains,
                 updated)
    if failed >= 0:
        raise ValueError(f"the innovation covariance of component {failed} is not positive "
                         f"definite")
    return gains, updated


def check_mode(value, name="mode"):
    """``value``, the name of reduction rules (see :func:`reduce`), else ValueError."""
    if not isinstance(value, str) or value not in MODES:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, MODES))}, got "
                         f"{value!r}")
    return value


def stack(means, covars):
    """The finite float64 (K, d) ``means``, d >= 1, and (K, d, d) ``covars`` of a stack of
    Gaussians, else an error naming the argument."""
    means = _validate.finite_array(means, "means", 2)
    k, d = means.shape
    if d < 1:
        raise ValueError(f"means must have at least one state dimension, got shape "
                         f"{means.shape}")
    covars = _validate.finite_array(covars, "covars", 3)
    if covars.shape != (k, d, d):
        raise ValueError(f"covars must have shape ({k}, {d}, {d}), got {covars.shape}")
    return means, covars


def check_covariances(covars, name):
    """ValueError naming the first of the (K, d, d) ``covars`` that is not symmetric
    positive semi-definite, by the kernels' rule (see
    :func:`~fasttrack.core.kalman_numpy.covariance_statuses`)."""
    status = _kalman_numpy.covariance_statuses(_validate.float_array(covars, name, 3), 1, 2)
    bad = np.flatnonzero(status)
    if bad.size:
        problem = "symmetric" if status[bad[0]] == 1 else "positive semi-definite"
        raise ValueError(f"{name}[{bad[0]}] is not {problem}")


def log_weight_array(log_weights, k):
    """(K,) float64 ``log_weights`` (-inf for a zero weight; not NaN or +inf), else an error
    naming them."""
    log_weights = _validate.float_array(log_weights, "log_weights", 1)
    if log_weights.shape != (k,):
        raise ValueError(f"log_weights must have shape ({k},), got {log_weights.shape}")
    if np.isnan(log_weights).any() or (log_weights == np.inf).any():
        raise ValueError("log_weights must not be NaN or +inf")
    return log_weights


def label_array(labels, k=None):
    """(K,) int64 ``labels`` (integers that int64 holds; K any if None), else an error
    naming them."""
    labels = np.asarray(labels)
    k = labels.shape[0] if k is None and labels.ndim == 1 else k
    if labels.shape != (k,) or labels.dtype.kind not in "iu":
        raise ValueError(f"labels must be {'a 1-D array of' if k is None else k} integers, "
                         f"got {labels.dtype} of shape {labels.shape}")
    if labels.dtype.kind == "u" and k and labels.max() > np.iinfo(np.int64).max:
        raise ValueError(f"labels must be below 2**63, got {labels.max()}")
    return labels.astype(np.int64)


def groups(labels):
    """``(order, starts, unique)``: the stable order that sorts int64 ``labels`` (K,), the
    CSR starts of its runs and the distinct labels, ascending."""
    labels = label_array(labels)
    order = np.argsort(labels, kind="stable")
    unique, counts = np.unique(labels[order], return_counts=True)
    starts = np.zeros(unique.size + 1, dtype=np.int64)
    np.cumsum(counts, out=starts[1:])
    return order, starts, unique


def moment_match(means, covars, log_weights, labels=None):
    """The components of each label merged into one Gaussian of the same mean and
    covariance (Stone Soup's ``gm_reduce_single`` per label).

    Parameters
    ----------
    means : (K, d) float64 ndarray
    covars : (K, d, d) float64 ndarray
        Symmetric positive semi-definite (checked).
    log_weights : (K,) float64 ndarray
        Unnormalised; -inf is a zero weight.
    labels : (K,) int64 ndarray, optional
        Which components merge together; None merges all of them.

    Returns
    -------
    means, covars, log_weights : (L, d), (L, d, d), (L,) ndarray
        One per distinct label, in ascending label order; the log weights are each group's
        total (logsumexp).
    labels : (L,) int64 ndarray

    Raises
    ------
    ValueError
        If a covariance is not symmetric positive semi-definite, or a group has no positive
        finite total weight, naming it.
    """
    means, covars = stack(means, covars)
    check_covariances(covars, "covars")
    log_weights = log_weight_array(log_weights, means.shape[0])
    labels = np.zeros(means.shape[0], dtype=np.int64) if labels is None \
        else label_array(labels, means.shape[0])
    order, starts, unique = groups(labels)
    if not np.array_equal(order, np.arange(order.size)):
        means, covars, log_weights = means[order], covars[order], log_weights[order]
    k, d = unique.size, means.shape[1]
    out = np.empty((k, d)), np.empty((k, d, d)), np.empty(k)
    failed = _mixture.moment_match(*(np.ascontiguousarray(a, dtype=np.float64)
                                     for a in (means, covars, log_weights)), starts, *out)
    if failed >= 0:
        raise ValueError(f"the components labelled {unique[failed]} have no positive finite "
                         f"total weight to merge by")
    check_finite_moments(out[0], out[1])
    return (*out, unique)


def check_finite_moments(*moments):
    """ValueError unless the merged ``moments`` (means, covariances) are finite."""
    if not all(np.isfinite(m).all() for m in moments):
        raise ValueError("the merged mean or covariance is not finite: the components' means "
                         "lie too far apart or too far out (differences or values beyond "
                         "about 1e154, squared, overflow float64), or their weights are not "
                         "finite")


def reduce(means, covars, weights, mode="textbook", prune_threshold=1e-9,
           merge_threshold=16.0, max_components=None, merging=True):
    """Prune, merge and cap a Gaussian mixture, one compiled pass.

    Pruning drops the components lighter than ``prune_threshold``; merging takes the
    heaviest component left, merges into it every one within ``merge_threshold``
    (squared Mahalanobis distance), and repeats; capping keeps the ``max_components``
    heaviest. Two sets of rules:

    - ``"textbook"`` (Vo and Ma 2006): keep ``w > prune_threshold``; the heaviest's
      covariance measures ``<= merge_threshold`` from its mean; the group becomes the
      Gaussian of the same moments (spread of the means included) with the summed weight;
      the cap rescales the kept weights to the whole mass.
    - ``"stonesoup"`` (Stone Soup's ``GaussianMixtureReducer``): keep
      ``w >= prune_threshold`` and add the pruned mass evenly to the kept; candidates in
      ascending weight, each's own covariance measuring ``< merge_threshold`` from the
      running merged mean, merged pairwise with the merged weight capped at 1; the cap
      adds the cut mass evenly.

    Parameters
    ----------
    means : (J, d) array_like
    covars : (J, d, d) array_like
        Symmetric positive definite (checked when merging).
    weights : (J,) array_like
        Linear weights >= 0 (e.g. a PHD's: they sum to the expected number of targets).
    mode : {"textbook", "stonesoup"}
    prune_threshold : float or None
        >= 0; None: no pruning.
    merge_threshold : float
        >= 0 (inf merges everything).
    max_components : int, optional
        The cap (default: none).
    merging : bool

    Returns
    -------
    means, covars, weights : (L, d), (L, d, d), (L,) ndarray
        The reduced mixture, each merge's heaviest first (by weight when capped).
    source : (L,) int64 ndarray
        The input component each output grew from (its heaviest: whose tag it keeps).
    member : (J,) int64 ndarray
        The output each input component went into, -1 if pruned or cut.

    Raises
    ------
    ValueError
        For weights that are negative or not finite, a covariance that is not symmetric
        or not positive definite, or thresholds out of range, naming the argument.
    """
    check_mode(mode)
    means, covars = stack(means, covars)
    j, d = means.shape
    weights = _validate.finite_array(weights, "weights", 1)
    if weights.shape != (j,):
        raise ValueError(f"weights must have shape ({j},), got {weights.shape}")
    if (weights < 0).any():
        raise ValueError(f"weights must be >= 0, got {weights.min()} at "
                         f"weights[{int(weights.argmin())}]")
    prune = -np.inf if prune_threshold is None else \
        _validate.non_negative(prune_threshold, "prune_threshold")
    merge = _validate.threshold(merge_threshold, "merge_threshold")
    cap = _validate.count(max_components, "max_components", default=_validate.MAX_COUNT)
    out = np.empty((j, d)), np.empty((j, d, d)), np.empty(j)
    source, member = np.empty(j, dtype=np.int64), np.empty(j, dtype=np.int64)
    run, axes = (_numpy.reduce, None) if _jit.numpy_first(_numpy.reduce_work(j, d)) \
        else (_mixture.reduce, _grid_axes(means))
    count = run(means, covars, weights, MODES[mode], prune, _validate.flag(merging, "merging"),
                merge, cap, axes, *out, source, member)
    if count < 0:
        i, asymmetric = divmod(-(1 + count), 2)
        problem = "symmetric" if asymmetric else "positive definite"
        raise ValueError(f"covars[{i}] is not {problem}")
    if np.isinf(out[2][:count]).any():
        raise ValueError("weights: a merged weight overflows float64 (a sum beyond 1.8e308)")
    if not (np.isfinite(out[0][:count]).all() and np.isfinite(out[2][:count]).all()):
        raise ValueError("weights: components of zero weight (or below 2.2e-308, which the "
                         "kernels count as zero) merged: there is no weight to average them "
                         "by; prune them (prune_threshold > 0)")
    check_finite_moments(out[1][:count])
    return out[0][:count], out[1][:count], out[2][:count], source[:count], member


def _grid_axes(means):
    """(2,) int64: the state rows along which the means spread most (the merge grid's)."""
    if means.shape[0] == 0 or means.shape[1] == 1:
        return np.zeros(2, dtype=np.int64)
    return np.argsort(np.ptp(means, axis=0))[::-1][:2].astype(np.int64)


def relabel(labels, weights, first_new):
    """``labels`` (L,) int64 with each label left on several components kept by the
    heaviest (the first of equals, by the (L,) float ``weights``) and the others numbered
    ``first_new``, ``first_new + 1``, ... in component order (``first_new`` an int >= 0 that
    leaves room for L new labels below 2**63)."""
    labels = label_array(labels)
    weights = _validate.float_array(weights, "weights", 1)
    if weights.shape != labels.shape or np.isnan(weights).any():
        raise ValueError(f"weights must be {labels.size} numbers (not NaN), one a label, got "
                         f"shape {weights.shape}")
    first_new = _validate.count(first_new, "first_new", minimum=0,
                                maximum=np.iinfo(np.int64).max - labels.size)
    order = np.lexsort((-weights, labels))
    repeat = np.zeros(labels.size, dtype=bool)
    repeat[order[1:]] = labels[order[1:]] == labels[order[:-1]]
    out = labels.copy()
    out[repeat] = first_new + np.arange(np.count_nonzero(repeat))
    return out
