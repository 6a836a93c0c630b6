"""Sequences of states read into arrays, each error naming the first bad state
(``track[3].covar``, ``particle_states[2].timestamp``)."""
import datetime

import numpy as np

from .types import seconds, time_interval

_MICROSECOND = datetime.timedelta(microseconds=1)


def check_finite(values, name, offset=0):
    """A ValueError naming ``name.format(offset + i)`` for the first of ``values`` (n, ...)
    that holds NaN or infinite values."""
    finite = np.isfinite(values).reshape(len(values), -1).all(axis=1)
    if not finite.all():
        raise ValueError(f"{name.format(offset + np.argmin(finite))} contains NaN or "
                         f"infinite values")


def step_intervals(time_intervals, n):
    """(n - 1,) float seconds between n steps from ``time_intervals``: a scalar or a
    timedelta (every step), or a sequence of either; a ValueError for one < 0."""
    if np.ndim(time_intervals) == 0:
        if isinstance(time_intervals, np.ndarray):
            time_intervals = time_intervals.item()
        value = seconds(time_intervals, "time_intervals")
        if value < 0:
            raise ValueError(f"time_intervals must be >= 0 seconds, got {value}")
        return np.full(n - 1, value)
    if isinstance(time_intervals, np.ndarray) and time_intervals.ndim != 1:
        raise ValueError(f"time_intervals must be one interval or T - 1 = {n - 1} of them, "
                         f"got an array of shape {time_intervals.shape}")
    values = list(time_intervals)
    if len(values) != n - 1:
        raise ValueError(f"time_intervals must hold T - 1 = {n - 1} intervals, "
                         f"got {len(values)}")
    out = np.array([seconds(v, f"time_intervals[{k}]") for k, v in enumerate(values)],
                   dtype=np.float64)
    if (out < 0).any():
        k = int(np.argmax(out < 0))
        raise ValueError(f"time_intervals[{k}] must be >= 0 seconds, got {out[k]}")
    return out


def track_intervals(states, offset, name="track", strict=False):
    """(n - 1,) seconds between consecutive states' timestamps (all datetimes or all
    numbers), or a TypeError naming the first bad timestamp; a ValueError where one goes
    back (or, if ``strict``, does not go forward) or is NaN."""
    intervals = _intervals_of(states, offset)
    bad = ~(intervals > 0) if strict else ~(intervals >= 0)
    if bad.any():
        t = int(np.argmax(bad))
        raise ValueError(f"{name}[{offset + t + 1}].timestamp must be "
                         f"{'after' if strict else 'at or after'} {name}[{offset + t}]'s "
                         f"(got an interval of {intervals[t]} s)")
    return intervals


def _intervals_of(states, offset):
    stamps = [state.timestamp for state in states]
    first = type(stamps[0])
    if first is datetime.datetime:
        origin = stamps[0]
        try:  # whole microseconds from the first: exact, as timedelta.total_seconds()
            micro = [(t - origin) // _MICROSECOND for t in stamps]
        except TypeError:  # not all datetimes, or naive and aware mixed: named below
            micro = None
        if micro is not None:
            return np.diff(np.array(micro, dtype=np.int64)).astype(np.float64) / 1e6
    elif first in (int, float) and all(type(t) in (int, float) for t in stamps):
        return np.diff(np.array(stamps, dtype=np.float64))
    out = np.empty(len(stamps) - 1)
    for t in range(len(stamps) - 1):
        earlier, later = stamps[t], stamps[t + 1]
        if earlier is None or later is None:
            where = t if earlier is None else t + 1
            raise TypeError(f"track[{offset + where}].timestamp must be a datetime or "
                            f"seconds to smooth, got None")
        try:
            out[t] = time_interval(later, earlier, f"track[{offset + t + 1}].timestamp")
        except TypeError as error:
            raise TypeError(str(error).replace("the prior's timestamp",
                                               f"track[{offset + t}].timestamp")) from None
    return out


def stack(states, attribute, shape, offset):
    """The ``attribute`` arrays of ``states`` stacked (n, *shape), or a ValueError naming
    the first state whose array has another shape."""
    arrays = [getattr(state, attribute) for state in states]
    try:
        out = np.array(arrays, dtype=np.float64)
    except ValueError:
        out = None
    if out is None or out.shape[1:] != shape:
        for k, a in enumerate(arrays):
            if np.shape(a) != shape:
                raise ValueError(f"track[{offset + k}].{attribute} must have shape {shape} "
                                 f"(the transition model's ndim_state), got {np.shape(a)}")
    return out
