"""Measurement kernels: predicted measurements and log-likelihoods of particle clouds.

Built-in models are described by a kind and three arrays (see :mod:`sensor`), so no kernel
takes a function.

Angle rows are wrapped to [-pi, pi) in predictions and innovations. The log-likelihood of a
measurement z is ``log_norm - |W (z - h(x))|^2 / 2`` with W the inverse of the Cholesky factor
of the noise covariance. Particles go in blocks of BLOCK.
"""
import numpy as np
from numba import prange

from .dispatch import jit
from .tunables import SERIAL_BELOW_HEAVY
from .numeric import BLOCK, wrap_angle
from .sensor import _predict_block
from .status import OK
from .user import columns, first_failure, output_status, store


@jit()
def _wrap_rows(values, lo, hi, angles):
    """Wrap ``values[r, lo:hi]`` for the rows r flagged in ``angles``."""
    for r in range(angles.size):
        if angles[r]:
            row = values[r, lo:hi]
            for i in range(row.size):
                row[i] = wrap_angle(row[i])


@jit()
def _block_log_likelihoods(z, predicted, angles, whiten, log_norm, log_w, out):
    """``out = log_w + log_norm - |W (z - predicted)|^2 / 2`` for the block's ``out.size``
    particles (the first columns of ``predicted``, overwritten with the innovations);
    returns the block's maximum, or NaN if any entry is NaN."""
    m = z.size
    count = out.size
    for r in range(m):
        row = predicted[r, :count]
        for i in range(count):
            row[i] = z[r] - row[i]
    _wrap_rows(predicted, np.int64(0), count, angles)
    whitened = np.empty(count)
    for i in range(count):
        out[i] = 0.0
    for r in range(m):
        for i in range(count):
            whitened[i] = 0.0
        for c in range(r + 1):
            w = whiten[r, c]
            innovation = predicted[c, :count]
            for i in range(count):
                whitened[i] += w * innovation[i]
        for i in range(count):
            out[i] += whitened[i] * whitened[i]
    top = -np.inf
    invalid = False
    for i in range(count):
        out[i] = log_w[i] + log_norm - 0.5 * out[i]
        top = max(top, out[i])
        invalid |= out[i] != out[i]
    return np.nan if invalid else top


@jit(parallel=True, size=1, serial_below=SERIAL_BELOW_HEAVY)
def measure(kind, x, mapping, offset, rotation, out):
    """Predicted measurements (m, N) of (d, N) particles."""
    n = x.shape[1]
    for b in prange((n + BLOCK - 1) // BLOCK):
        lo = b * BLOCK
        hi = min(lo + BLOCK, n)
        _predict_block(kind, x, lo, hi, mapping, offset, rotation, out, lo)


@jit(parallel=True, size=2, serial_below=SERIAL_BELOW_HEAVY)
def log_likelihood(kind, z, x, mapping, offset, rotation, angles, whiten, log_norm, log_w,
                   out):
    """``out = log_w + log p(z | particle)`` for (d, N) particles; returns ``max(out)`` (NaN
    if any entry is NaN)."""
    n = x.shape[1]
    blocks = (n + BLOCK - 1) // BLOCK
    tops = np.empty(blocks)
    for b in prange(blocks):
        lo = b * BLOCK
        hi = min(lo + BLOCK, n)
        predicted = np.empty((z.size, BLOCK))
        _predict_block(kind, x, lo, hi, mapping, offset, rotation, predicted, np.int64(0))
        tops[b] = _block_log_likelihoods(z, predicted, angles, whiten, log_norm, log_w[lo:hi],
                                         out[lo:hi])
    return _max(tops)


@jit(parallel=True, size=1, serial_below=SERIAL_BELOW_HEAVY)
def measure_function(function, x, angles, out):
    """Predicted measurements of a user model ``h((d, n) states) -> (m, n)``; returns the
    status of its outputs (see :mod:`user`)."""
    m = out.shape[0]
    n = x.shape[1]
    blocks = (n + BLOCK - 1) // BLOCK
    codes = np.zeros(blocks, dtype=np.int64)
    for b in prange(blocks):
        lo = b * BLOCK
        hi = min(lo + BLOCK, n)
        values = function(columns(x, lo, hi))
        codes[b] = output_status(values, m, hi - lo)
        if codes[b] == OK:
            store(values, out, lo)
            _wrap_rows(out, lo, hi, angles)
    return first_failure(codes)


@jit(parallel=True, size=2, serial_below=SERIAL_BELOW_HEAVY)
def log_likelihood_function(function, z, x, angles, whiten, log_norm, log_w, out):
    """:func:`log_likelihood` for a user model ``h((d, n) states) -> (m, n)``; returns
    ``(max(out), status)``, the status of the function's outputs (see :mod:`user`)."""
    n = x.shape[1]
    blocks = (n + BLOCK - 1) // BLOCK
    tops = np.empty(blocks)
    codes = np.zeros(blocks, dtype=np.int64)
    for b in prange(blocks):
        lo = b * BLOCK
        hi = min(lo + BLOCK, n)
        predicted = np.empty((z.size, hi - lo))
        values = function(columns(x, lo, hi))
        codes[b] = output_status(values, z.size, hi - lo)
        tops[b] = np.nan
        if codes[b] == OK:
            store(values, predicted, np.int64(0))
            tops[b] = _block_log_likelihoods(z, predicted, angles, whiten, log_norm,
                                             log_w[lo:hi], out[lo:hi])
    return _max(tops), first_failure(codes)


@jit()
def _max(values):
    """The maximum, NaN if any value is NaN."""
    top = -np.inf
    for v in values:
        if v != v:
            return v
        top = max(top, v)
    return top
