"""Mirrors of ``fasttrack._jit.user``: the blocks of columns that users' model functions get
and the checks of what they return."""
import numpy as np

from .status import FUNCTION_NOT_FINITE, FUNCTION_SHAPE, OK


def columns(x, lo, hi):
    return np.ascontiguousarray(x[:, lo:hi])


def store(values, out, lo):
    out[:, lo:lo + values.shape[1]] = values


def output_status(values, rows, cols):
    if values.shape != (rows, cols):
        return FUNCTION_SHAPE
    return OK if np.isfinite(values).all() else FUNCTION_NOT_FINITE


def first_failure(codes):
    bad = [code for code in codes if code != OK]
    return bad[0] if bad else OK
