"""Input validation shared by the public API. Errors name the argument, what was expected
and what was given; nothing is repaired silently and inputs are never modified.

Numbers are strict: arrays must hold real numbers (integer or floating dtypes, or objects
that are real numbers), so complex values, strings and booleans are rejected rather than
truncated, parsed or cast; counts and indices must be integers (not floats or booleans).
"""
import math
import numbers
import os

import numpy as np
from ._jit.tunables import PSD_TOLERANCE


#: NumPy's native float64 dtype.
_FLOAT64 = np.dtype(np.float64)

#: Largest particle count accepted (2**40, about 1.1e12): any more could not be stored.
MAX_COUNT = 2**40


def _describe(value):
    if isinstance(value, np.ndarray):
        return f"an array of dtype {value.dtype}"
    return type(value).__name__


def iterator(value, name):
    """An iterator over ``value`` (an iterable, not a string), else a TypeError naming it."""
    if not isinstance(value, (str, bytes)):
        try:
            return iter(value)
        except TypeError:
            pass
    raise TypeError(f"{name} must be an iterable (a list, for instance), got "
                    f"{_describe(value)}")


def instances(value, kind, name):
    """The items of the iterable ``value`` as a list, each a ``kind``, else a TypeError
    naming ``name`` or the item."""
    items = list(iterator(value, name))
    for i, item in enumerate(items):
        if not isinstance(item, kind):
            raise TypeError(f"{name}[{i}] must be of type {kind.__name__}, got "
                            f"{_describe(item)}")
    return items


def instance(value, name, kind):
    """``value``, if it is a ``kind``; else a TypeError naming ``name``."""
    if not isinstance(value, kind):
        raise TypeError(f"{name} must be of type {kind.__name__}, got {_describe(value)}")
    return value


def is_real(value):
    """Whether ``value`` is a real number (Python or NumPy), not a bool."""
    return type(value) in _PLAIN_REALS or (isinstance(value, numbers.Real)
                                           and not isinstance(value, (bool, np.bool_)))


#: The types :func:`is_real` accepts without asking ``numbers.Real`` (a slow check).
_PLAIN_REALS = (float, int, np.float64)


def is_integer(value):
    """Whether ``value`` is an integer (Python or NumPy), not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def float_array(value, name, ndim=None):
    """``value`` as a writable C-contiguous float64 array with ``ndim`` dimensions (any if
    None; no copy if it is one already: a read-only array is copied, since kernels compile
    for writable arrays).

    Raises TypeError unless ``value`` holds real numbers: a complex, string, boolean or
    other non-numeric array is not converted.
    """
    if type(value) is np.ndarray and value.dtype is _FLOAT64 and value.flags.c_contiguous \
            and value.flags.writeable:
        a = value  # already what the kernels take
    else:
        a = _converted(value, name)
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-D, got {a.ndim}-D with shape {a.shape}")
    return a


def _converted(value, name):
    """:func:`float_array`'s conversion of ``value`` (a new array, unless ``value`` is a
    writable C-contiguous float64 array)."""
    if type(value) is np.ndarray and value.dtype == np.float64:
        a = value
    else:
        try:
            a = np.asarray(value)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a numeric array of real numbers, "
                            f"got {_describe(value)}") from None
        if a.dtype.kind == "O" and all(is_real(v) for v in a.flat):
            try:
                a = a.astype(np.float64)
            except OverflowError:  # (a huge int)
                raise ValueError(f"{name} must lie within the float range (|x| < 1.8e308)"
                                 ) from None
        if a.dtype.kind not in "fiu":
            raise TypeError(f"{name} must be a numeric array of real numbers, got "
                            f"{_describe(value) if a.dtype.kind == 'O' else _describe(a)}")
    a = np.asarray(a, dtype=np.float64, order="C")  # keeps a scalar 0-D
    return a if a.flags.writeable else a.copy()


def finite_array(value, name, ndim=None):
    """:func:`float_array` that also rejects NaN and infinite entries."""
    a = float_array(value, name, ndim)
    if not np.isfinite(a).all():
        bad = "NaN" if np.isnan(a).any() else "infinite values"
        raise ValueError(f"{name} contains {bad}")
    return a


def intervals(value, shape):
    """Finite ``time_intervals`` (seconds) as a new float64 array of ``shape``: one scalar
    for every entry, or values that broadcast to it."""
    if is_real(value) and math.isfinite(_float(value, "time_intervals")):
        out = np.empty(shape)
        out.fill(float(value))
        return out
    a = finite_array(value, "time_intervals")
    try:
        return np.broadcast_to(a, shape).copy()
    except ValueError:
        raise ValueError(f"time_intervals (seconds) must broadcast to {shape}, "
                         f"got shape {a.shape}") from None


def square_matrix(value, name, size):
    """A finite (size, size) float64 matrix."""
    a = finite_array(value, name, 2)
    if a.shape != (size, size):
        raise ValueError(f"{name} must have shape ({size}, {size}), got {a.shape}")
    return a


def covariance(value, name, size):
    """A finite, symmetric (size, size) float64 covariance matrix."""
    a = square_matrix(value, name, size)
    if not a.size:
        raise ValueError(f"{name} must have at least one row and column, got shape (0, 0)")
    scale = max(np.abs(a).max(), np.finfo(float).tiny)
    if np.abs(a - a.T).max() > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric")
    return a


def psd_covariance(value, name, size):
    """:func:`covariance` that is also positive semi-definite (eigenvalues >= 0 to
    :data:`PSD_TOLERANCE` relative)."""
    a = covariance(value, name, size)
    values = np.linalg.eigvalsh(a)
    top = max(values.max(), np.finfo(float).tiny)
    if values.min() < -PSD_TOLERANCE * top:
        raise ValueError(f"{name} is not positive semi-definite "
                         f"(eigenvalues from {values.min():.3g} to {values.max():.3g})")
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


def storable(count, bytes_each, name, described=None):
    """ValueError naming ``name`` when ``count`` items of ``bytes_each`` bytes would need
    more than the machine's physical memory (rather than NumPy's MemoryError, which names
    only a shape); ``described``, if given, says what was asked for in the arguments'
    terms instead of ``name=count``."""
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # (no sysconf: NumPy's error stands)
        return
    if count * bytes_each > memory:
        raise ValueError(f"{described or f'{name}={count}'} needs "
                         f"{count * bytes_each / 2**30:.3g} GiB of arrays, more than this "
                         f"machine's {memory / 2**30:.3g} GiB of memory")


def count(value, name, default=None, minimum=1, maximum=MAX_COUNT):
    """An integer in ``[minimum, maximum]`` (``None`` gives ``default``)."""
    if value is None and default is not None:
        return default
    if not is_integer(value):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value}")
    return int(value)


def indices(value, name, size, minimum=0):
    """A tuple of integers in ``[0, size)`` from a sequence (at least ``minimum`` of them).

    Raises TypeError for a non-sequence or an entry that is not an integer (a float or a
    bool is not an index), ValueError for entries out of range.
    """
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"{name} must be a sequence of integer indices, "
                        f"got {type(value).__name__}")
    entries = tuple(value.ravel()) if isinstance(value, np.ndarray) else tuple(value)
    bad = [entry for entry in entries if not is_integer(entry)]
    if bad:
        raise TypeError(f"{name} must hold integer indices, got {bad[0]!r} "
                        f"({type(bad[0]).__name__}) in {entries!r}")
    entries = tuple(int(entry) for entry in entries)
    if len(entries) < minimum:
        raise ValueError(f"{name} needs at least {minimum} indices, got {entries}")
    if any(not 0 <= entry < size for entry in entries):
        raise ValueError(f"{name} indices must lie in [0, {size}), got {entries}")
    return entries


def flag(value, name):
    """A bool (Python or NumPy), as a bool: a TypeError for anything else."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(value).__name__}")
    return bool(value)


def bool_array(value, name, shape):
    """A C-contiguous boolean array of ``shape``: a TypeError for another dtype."""
    a = np.asarray(value)
    if a.dtype != np.bool_:
        raise TypeError(f"{name} must be a boolean array, got {_describe(a)}")
    if a.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
    return np.ascontiguousarray(a)


def _float(value, name):
    """A real number (not a bool) as a float: a TypeError for another type, a ValueError for
    one beyond the float range (a huge int, a Fraction)."""
    if not is_real(value):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    try:
        return float(value)
    except OverflowError:
        raise ValueError(f"{name} must lie within the float range (|x| < 1.8e308); the "
                         f"{type(value).__name__} given does not") from None


def real(value, name):
    """A finite real number (not a bool), as a float."""
    value = _float(value, name)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    return value


def scan_time(time, previous):
    """``(time, dt)``: a scan's ``time`` (a finite real, seconds) and the interval since the
    ``previous`` scan's (0 for the first, None), which must be > 0 and finite."""
    time = real(time, "time")
    if previous is None:
        return time, 0.0
    dt = time - previous
    if not dt > 0:
        raise ValueError(f"time must be after the previous scan's ({previous} s), got {time}")
    if not math.isfinite(dt):
        raise ValueError(f"time must lie within 1.8e308 s of the previous scan's "
                         f"({previous} s), got {time}")
    return time, dt


def probability(value, name):
    """A real number in [0, 1], as a float."""
    value = real(value, name)
    if not 0.0 <= value <= 1.0:
        raise ValueError(f"{name} must lie in [0, 1], got {value}")
    return value


def positive(value, name):
    """A finite real number > 0, as a float."""
    value = real(value, name)
    if not value > 0:
        raise ValueError(f"{name} must be finite and > 0, got {value}")
    return value


def non_negative(value, name):
    """A finite real number >= 0, as a float."""
    value = real(value, name)
    if not value >= 0:
        raise ValueError(f"{name} must be finite and >= 0, got {value}")
    return value


def threshold(value, name):
    """A real number >= 0 or +inf, as a float."""
    value = _float(value, name)
    if not value >= 0:
        raise ValueError(f"{name} must be >= 0, got {value}")
    return value


#: The largest angle a measurement may hold, radians: wrapping it to [-pi, pi) keeps about
#: 7 digits (float64's spacing at 1e9 is 1.2e-7).
LARGEST_ANGLE = 1e9


def angle_columns(z, angles, name):
    """ValueError naming ``name`` if a column of the (..., m) float64 array ``z`` that the
    (m,) bool mask ``angles`` marks holds an angle beyond :data:`LARGEST_ANGLE`."""
    largest = np.abs(z[..., angles]).max(initial=0.0) if angles.any() else 0.0
    if largest > LARGEST_ANGLE:
        raise ValueError(f"{name} must hold angles within +-{LARGEST_ANGLE:.0e} rad (wrapped "
                         f"to [-pi, pi) in float64, a larger one keeps fewer than 7 digits), "
                         f"got {largest:.3g}")


def asymmetric(stack):
    """(K,) bool: which matrices of a (K, n, n) float array are not symmetric to 1e-9 of
    their largest entry (the kernels' rule; one with a NaN counts as not symmetric)."""
    largest = np.abs(stack).max(axis=(1, 2), initial=0.0)
    return ~(np.abs(stack - stack.transpose(0, 2, 1)) <= 1e-9 * largest[:, None, None]).all(
        axis=(1, 2))


def symmetric_stack(value, name):
    """ValueError naming the first matrix of a (K, n, n) float array that is not symmetric
    (to 1e-9 of its largest entry)."""
    bad = asymmetric(value)
    if bad.any():
        raise ValueError(f"{name}[{np.argmax(bad)}] is not symmetric")


def optional(check):
    """``check`` that lets None through (a setting that may be absent)."""
    def checked(value, name, **options):
        return None if value is None else check(value, name, **options)
    return checked


class Setting:
    """An attribute checked on every assignment, the constructor's and any later one, so
    that a bad value is refused where it is set: ``check(value, name, **options)`` returns
    the value stored or raises naming ``name``. A string ``check`` names a method of the
    owner (a check that reads the owner's other attributes).

    The value is kept in the instance's ``__dict__`` under the attribute's own name, and
    read from there at the speed of a plain attribute: a descriptor with ``__set__`` and no
    ``__get__`` only intercepts assignments."""

    def __init__(self, check, **options):
        self.check, self.options = check, options

    def __set_name__(self, owner, name):
        self.name = name

    def __set__(self, obj, value):
        check = getattr(obj, self.check) if isinstance(self.check, str) else self.check
        obj.__dict__[self.name] = check(value, self.name, **self.options)
