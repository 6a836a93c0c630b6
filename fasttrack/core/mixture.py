"""Gaussian mixtures on plain arrays: a mixture is a stack of K components, (K, d) means,
(K, d, d) covariances and (K,) log weights, with int64 labels grouping components (the
hypotheses of one track, the components one reduction merges)."""
import numpy as np

from .. import _jit

_mixture = _jit.lazy("mixture")


def segment_logsumexp(values, starts):
    """(S,) ``log sum exp`` of each CSR segment ``values[starts[s]:starts[s + 1]]`` of a
    (K,) float64 array (-inf for an empty segment or one of zero weights)."""
    if _jit.numpy_first(starts.size - 1):
        return _segment_logsumexp(np.asarray(values, dtype=np.float64), starts)
    out = np.empty(starts.size - 1)
    _mixture.segment_logsumexp(np.ascontiguousarray(values, dtype=np.float64),
                               np.ascontiguousarray(starts, dtype=np.int64), out)
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


def groups(labels):
    """``(order, starts, unique)``: the stable order that sorts int64 ``labels`` (K,), the
    CSR starts of its runs and the distinct labels, ascending."""
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
        If a group has no positive finite total weight, naming its label.
    """
    if labels is None:
        labels = np.zeros(means.shape[0], dtype=np.int64)
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
    return (*out, unique)
