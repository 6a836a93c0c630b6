"""Input validation shared by the public API. Errors name the argument, what was expected
and what was given; nothing is repaired silently and inputs are never modified."""
import numbers

import numpy as np


def _describe(a):
    return f"shape {a.shape}" if isinstance(a, np.ndarray) else type(a).__name__


def float_array(value, name, ndim=None):
    """``value`` as a C-contiguous float64 array with ``ndim`` dimensions (any if None; no
    copy if it is one already)."""
    try:
        a = np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a numeric array, got {type(value).__name__}") from None
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-D, got {a.ndim}-D with shape {a.shape}")
    return a


def finite_array(value, name, ndim=None):
    """:func:`float_array` that also rejects NaN and infinite entries."""
    a = float_array(value, name, ndim)
    if not np.isfinite(a).all():
        bad = "NaN" if np.isnan(a).any() else "infinite values"
        raise ValueError(f"{name} contains {bad}")
    return a


def square_matrix(value, name, size):
    """A finite (size, size) float64 matrix."""
    a = finite_array(value, name, 2)
    if a.shape != (size, size):
        raise ValueError(f"{name} must have shape ({size}, {size}), got {a.shape}")
    return a


def covariance(value, name, size):
    """A finite, symmetric (size, size) float64 covariance matrix."""
    a = square_matrix(value, name, size)
    scale = max(np.abs(a).max(), np.finfo(float).tiny)
    if np.abs(a - a.T).max() > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric")
    return a


def state_array(value, name):
    """A (d, N) float64 state array: d >= 1 rows, N >= 1 columns, all finite."""
    a = finite_array(value, name, 2)
    if a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError(f"{name} must have shape (d, N) with d >= 1 and N >= 1, "
                         f"got {a.shape}")
    return a


def log_weights(value, name, size=None):
    """Validate log weights: 1-D, no NaN or +inf, not all -inf.

    Returns
    -------
    log_w : (N,) float64
    log_w_max : float
        The largest log weight (finite).
    """
    lw = float_array(value, name, 1)
    if size is not None and lw.size != size:
        raise ValueError(f"{name} must have length {size}, got {lw.size}")
    if lw.size == 0:
        raise ValueError(f"{name} is empty")
    top = lw.max()
    if np.isnan(top):
        raise ValueError(f"{name} contains NaN")
    if top == np.inf:
        raise ValueError(f"{name} contains +inf")
    if top == -np.inf:
        raise ValueError(f"{name}: all weights are zero (every log weight is -inf)")
    return lw, float(top)


def linear_weights(value, name, size=None):
    """Validate linear weights (finite, >= 0, not all zero) and return their logs."""
    w = finite_array(value, name, 1)
    if size is not None and w.size != size:
        raise ValueError(f"{name} must have length {size}, got {w.size}")
    if (w < 0).any():
        raise ValueError(f"{name} contains negative weights")
    if w.size == 0 or not (w > 0).any():
        raise ValueError(f"{name}: all weights are zero")
    with np.errstate(divide="ignore"):
        return np.log(w)


def count(value, name, default=None, minimum=1):
    """An integer >= ``minimum`` (``None`` gives ``default``)."""
    if value is None and default is not None:
        return default
    if not isinstance(value, numbers.Integral) or isinstance(value, bool):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return int(value)


def positive(value, name):
    """A finite real number > 0, as a float."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be finite and > 0, got {value}")
    return float(value)
