"""Timestamps, time intervals and the links between states (see :mod:`fasttrack.types`)."""
import datetime
import weakref

import numpy as np

from .._validate import is_real, real


def check_timestamp(value, name="timestamp"):
    """A timestamp: ``None``, a ``datetime.datetime`` or a real number of seconds."""
    if value is None or isinstance(value, datetime.datetime):
        return value
    if is_real(value):
        real(value, name)  # (finite, within the float range)
        return value
    raise TypeError(f"{name} must be None, a datetime or a number of seconds, "
                    f"got {type(value).__name__}")


class Link:
    """An attribute linking to an earlier state: held strongly when assigned the state,
    weakly when assigned a ``weakref.ref`` to it (then None once the state is gone)."""

    def __set_name__(self, owner, name):
        self.slot = "_" + name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return self
        value = obj.__dict__.get(self.slot)
        return value() if type(value) is weakref.ref else value

    def __set__(self, obj, value):
        obj.__dict__[self.slot] = value


def weak(state):
    """A weak link to ``state`` (None stays None)."""
    return None if state is None else weakref.ref(state)


def time_interval(later, earlier, name="timestamp"):
    """Seconds from ``earlier`` to ``later`` (two datetimes or two numbers of seconds)."""
    if isinstance(later, datetime.datetime) and isinstance(earlier, datetime.datetime):
        if (later.utcoffset() is None) != (earlier.utcoffset() is None):
            raise TypeError(f"{name} {later!r} and the prior's timestamp {earlier!r} must both "
                            f"have a time zone or both have none")
        return (later - earlier).total_seconds()
    if is_real(later) and is_real(earlier):
        return float(later) - float(earlier)
    raise TypeError(f"{name} {later!r} and the prior's timestamp {earlier!r} must both be "
                    f"datetimes or both numbers of seconds")


def seconds(interval, name="time_interval"):
    """A time interval in seconds from a ``datetime.timedelta`` or a real number."""
    if isinstance(interval, datetime.timedelta):
        return interval.total_seconds()
    if isinstance(interval, np.timedelta64):
        return real(interval / np.timedelta64(1, "s"), name)  # (NaT: NaN, refused)
    if is_real(interval):
        return real(interval, name)
    raise TypeError(f"{name} must be a datetime.timedelta, numpy.timedelta64 or a number of "
                    f"seconds, got {type(interval).__name__}")
