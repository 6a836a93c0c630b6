"""Calls of users' model functions (``@numba.njit``) from kernels.

A user function is always called with a C-contiguous (d, n) float64 array, so that it
compiles once for every kernel and for calls from Python, and its output is checked before
anything is read from it: the shape (rows, n) and finite values. A kernel that finds a bad
output writes nothing from it and returns the status (``FUNCTION_SHAPE`` or
``FUNCTION_NOT_FINITE``), which the model turns into an error naming the function.
"""
import numpy as np

from .dispatch import jit
from .status import FUNCTION_NOT_FINITE, FUNCTION_SHAPE, OK


@jit()
def columns(x, lo, hi):
    """A C-contiguous copy of ``x[:, lo:hi]``."""
    out = np.empty((x.shape[0], hi - lo))
    for r in range(x.shape[0]):
        row = out[r]
        source = x[r, lo:hi]
        for i in range(row.size):
            row[i] = source[i]
    return out


@jit()
def store(values, out, lo):
    """``out[:, lo:lo + n] = values`` for checked (rows, n) values."""
    for r in range(values.shape[0]):
        row = out[r, lo:lo + values.shape[1]]
        for i in range(row.size):
            row[i] = values[r, i]


@jit()
def output_status(values, rows, cols):
    """OK if ``values`` is a finite (rows, cols) array, else why not."""
    if values.shape[0] != rows or values.shape[1] != cols:
        return FUNCTION_SHAPE
    finite = True
    for r in range(rows):
        for i in range(cols):  # a branch-free test, so that the loop vectorises
            finite &= abs(values[r, i]) <= 1.7976931348623157e308
    return OK if finite else FUNCTION_NOT_FINITE


@jit()
def first_failure(codes):
    """The first non-OK code of per-block ``codes``, else OK."""
    for code in codes:
        if code != OK:
            return code
    return OK
