"""Kernels on log weights: relative weights, logsumexp, effective sample size and the
weighted mean and covariance of a particle cloud.

Sums are chunked reductions with a chunk count that depends only on N, so the results have
the same bits whatever the thread count. Inside a chunk, weights are exponentiated a block at
a time into a small buffer (a loop that vectorises) before they are summed, each block in
four interleaved partial sums (:func:`_dot`), so that the additions do not wait on each
other.
"""
import numpy as np
from numba import prange

from .dispatch import jit
from .numeric import BLOCK, chunk_bounds, fast_exp, n_chunks


@jit(parallel=True, size=0)
def relative_weights(log_w, log_w_max, out):
    """``out = exp(log_w - log_w_max)``, shape (N,)."""
    for i in prange(log_w.size):
        out[i] = fast_exp(log_w[i] - log_w_max)


@jit()
def _block_weights(log_w, start, log_w_max, buf):
    """``exp(log_w[start:start + m] - log_w_max)`` into ``buf[:m]``, m <= buf.size; returns
    the filled view."""
    block = log_w[start:start + buf.size]
    w = buf[:block.size]
    if _all_equal(block, log_w_max):  # equal weights, as after resampling: exp(0) is 1
        w[:] = 1.0
        return w
    for i in range(block.size):
        w[i] = fast_exp(block[i] - log_w_max)
    return w


@jit()
def _all_equal(values, value):
    """Whether every element of 1-D ``values`` equals ``value`` (stops at the first that
    does not)."""
    for v in values:
        if v != value:
            return False
    return True


@jit()
def _dot(a, b):
    """``sum a[i] b[i]`` over equal-sized 1-D ``a`` and ``b``, in four partial sums over
    i mod 4, added in a fixed order (the same bits on every run)."""
    n = a.size
    s0 = s1 = s2 = s3 = 0.0
    for i in range(0, n - n % 4, 4):
        s0 += a[i] * b[i]
        s1 += a[i + 1] * b[i + 1]
        s2 += a[i + 2] * b[i + 2]
        s3 += a[i + 3] * b[i + 3]
    for i in range(n - n % 4, n):
        s0 += a[i] * b[i]
    return (s0 + s1) + (s2 + s3)


@jit(parallel=True)
def _power_sums(log_w, log_w_max):
    """``(sum w, sum w**2)`` of ``w = exp(log_w - log_w_max)``."""
    n = log_w.size
    k = n_chunks(n)
    partial = np.zeros((k, 2))
    for c in prange(k):
        lo, hi = chunk_bounds(np.int64(c), k, n)
        part = log_w[lo:hi]
        buf, ones = np.empty(BLOCK), np.ones(BLOCK)
        s1 = 0.0
        s2 = 0.0
        for start in range(0, part.size, BLOCK):
            w = _block_weights(part, start, log_w_max, buf)
            s1 += _dot(w, ones[:w.size])
            s2 += _dot(w, w)
        partial[c, 0] = s1
        partial[c, 1] = s2
    sums = _sum_rows(partial)
    return sums[0], sums[1]


@jit(size=0)
def log_sum_exp(log_w, log_w_max):
    """``log(sum(exp(log_w)))`` given the (finite) maximum."""
    return log_w_max + np.log(_power_sums(log_w, log_w_max)[0])


@jit(size=0)
def ess(log_w, log_w_max):
    """Kish's effective sample size ``(sum w)**2 / sum w**2`` of unnormalised log weights."""
    s1, s2 = _power_sums(log_w, log_w_max)
    return s1 * s1 / s2


@jit(size=0)
def weighted_mean(x, log_w, log_w_max, mean):
    """Weighted mean (d,) of the columns of a (d, N) array, with weights
    ``exp(log_w - log_w_max)``: one pass, the first of :func:`weighted_mean_covar`."""
    d, n = x.shape
    total = _weighted_sums(x, log_w, log_w_max)
    for r in range(d):
        mean[r] = total[r] / total[d]


@jit(parallel=True)
def _weighted_sums(x, log_w, log_w_max):
    """``(sum w x_r for each row r, sum w)`` (d + 1,), chunked in a fixed order."""
    d, n = x.shape
    k = n_chunks(n)
    partial = np.zeros((k, d + 1))
    for c in prange(k):
        lo, hi = chunk_bounds(np.int64(c), k, n)
        xs = x[:, lo:hi]
        part = log_w[lo:hi]
        buf, ones = np.empty(BLOCK), np.ones(BLOCK)
        acc = partial[c]
        for start in range(0, part.size, BLOCK):
            w = _block_weights(part, start, log_w_max, buf)
            acc[d] += _dot(w, ones[:w.size])
            for r in range(d):
                acc[r] += _dot(w, xs[r, start:start + w.size])
    return _sum_rows(partial)


@jit(parallel=True, size=0)
def weighted_mean_covar(x, log_w, log_w_max, mean, covar):
    """Weighted mean (d,) and covariance (d, d) of the columns of a (d, N) array, with
    weights ``exp(log_w - log_w_max)``: ``sum w (x - mean)(x - mean)^T / sum w``.

    Two passes (mean, then centred products) for accuracy.
    """
    d, n = x.shape
    k = n_chunks(n)
    sums = _weighted_sums(x, log_w, log_w_max)
    total = sums[d]
    for r in range(d):
        mean[r] = sums[r] / total
    products = np.zeros((k, d * d))
    for c in prange(k):
        lo, hi = chunk_bounds(np.int64(c), k, n)
        xs = x[:, lo:hi]
        part = log_w[lo:hi]
        buf = np.empty(BLOCK)
        acc = products[c]
        centred = np.empty(d)
        for start in range(0, part.size, BLOCK):
            w = _block_weights(part, start, log_w_max, buf)
            for i in range(w.size):
                for r in range(d):
                    centred[r] = xs[r, start + i] - mean[r]
                for r in range(d):
                    for q in range(r + 1):
                        acc[r * d + q] += w[i] * centred[r] * centred[q]
    sums = _sum_rows(products)
    for r in range(d):
        for q in range(r + 1):
            covar[r, q] = sums[r * d + q] / total
            covar[q, r] = covar[r, q]


@jit()
def _sum_rows(partial):
    """Column sums of a (k, m) array of per-chunk partial sums, added in chunk order."""
    sums = np.zeros(partial.shape[1])
    for c in range(partial.shape[0]):
        for j in range(partial.shape[1]):
            sums[j] += partial[c, j]
    return sums


@jit(parallel=True, size=0)
def normalise_in_place(log_w, log_w_max):
    """Shift log weights so that their exponentials sum to 1; returns their effective sample
    size (see :func:`ess`), from the same pass.

    Each weight becomes ``(log_w - log_w_max) - log(sum exp(log_w - log_w_max))``: the
    large common offset is removed first, exactly, so the sum of the normalised weights is
    1 to rounding whatever the magnitude of the log weights (subtracting the logsumexp
    itself would lose up to its last bit, half a unit at 1e15).
    """
    s1, s2 = _power_sums(log_w, log_w_max)
    log_total = np.log(s1)
    for i in prange(log_w.size):
        log_w[i] = (log_w[i] - log_w_max) - log_total
    return s1 * s1 / s2
