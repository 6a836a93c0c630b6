"""Propagation kernels: every particle through a transition, plus Gaussian process noise.

Particles go in blocks of BLOCK; block b draws ``e * BLOCK`` normals (e = d rounded up to
even) from the counter-based stream with :func:`numeric.fill_normals`, starting at pair
``b * BLOCK * e / 2``; component c of the block's particle i takes entry ``c * BLOCK + i``. The
noise is ``S z`` for a square root S of the covariance (``S S^T = Q``).
"""
import numpy as np
from numba import prange

from .dispatch import jit
from .tunables import SERIAL_BELOW_HEAVY
from .numeric import BLOCK, fill_normals
from .status import OK
from .user import columns, first_failure, output_status, store



@jit()
def _add_noise(noise_root, key, block, lo, hi, out):
    """``out[:, lo:hi] += S z`` with the normals of ``block``."""
    d = out.shape[0]
    even = d + (d & 1)
    z = np.empty(even * BLOCK)
    fill_normals(key, block * BLOCK * even // 2, z)
    for r in range(d):
        row = out[r, lo:hi]
        for c in range(d):
            s = noise_root[r, c]
            if s != 0.0:
                zc = z[c * BLOCK:c * BLOCK + row.size]
                for i in range(row.size):
                    row[i] += s * zc[i]


@jit()
def _any_nonzero(matrix):
    for value in matrix.ravel():
        if value != 0.0:
            return True
    return False


@jit(parallel=True, size=0, serial_below=SERIAL_BELOW_HEAVY)
def propagate_linear(x, matrix, noise_root, key, out):
    """``out = F x + S z``: (d, N) particles through the (d, d) transition matrix F, with
    normals z from stream ``key`` (no noise if S is all zero)."""
    d, n = x.shape
    noisy = _any_nonzero(noise_root)
    for b in prange((n + BLOCK - 1) // BLOCK):
        lo = b * BLOCK
        hi = min(lo + BLOCK, n)
        for r in range(d):
            row = out[r, lo:hi]
            for i in range(row.size):
                row[i] = 0.0
            for c in range(d):
                f = matrix[r, c]
                if f != 0.0:
                    xc = x[c, lo:hi]
                    for i in range(row.size):
                        row[i] += f * xc[i]
        if noisy:
            _add_noise(noise_root, key, np.int64(b), lo, hi, out)


@jit(parallel=True, size=2, serial_below=SERIAL_BELOW_HEAVY)
def propagate_function(function, time_interval, x, noise_root, key, out):
    """``out = f(x, dt) + S z`` for a user transition ``f((d, n) states, dt) -> (d, n)``,
    called block by block; returns the status of its outputs (see :mod:`user`): where it
    is not OK, ``out`` is not meaningful."""
    d, n = x.shape
    noisy = _any_nonzero(noise_root)
    blocks = (n + BLOCK - 1) // BLOCK
    codes = np.zeros(blocks, dtype=np.int64)
    for b in prange(blocks):
        lo = b * BLOCK
        hi = min(lo + BLOCK, n)
        values = function(columns(x, lo, hi), time_interval)
        codes[b] = output_status(values, d, hi - lo)
        if codes[b] == OK:
            store(values, out, lo)
            if noisy:
                _add_noise(noise_root, key, np.int64(b), lo, hi, out)
    return first_failure(codes)
