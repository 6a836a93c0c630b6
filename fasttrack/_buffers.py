"""Recycled arrays for the filters' per-step outputs and temporaries.

A particle-filter step at N = 1e5 allocates about 10 MB of fresh arrays and frees as much.
glibc hands large freed blocks back to the system, so every step faults fresh pages in again
(a step took 3-5x longer than with :func:`fasttrack.tune_allocator`, which changes the
whole process). Instead, :func:`empty` keeps the last few arrays of each shape it handed
out and returns one again once nothing but this pool refers to it (its reference count
says so): the array a state still holds is never reused, and a loop that drops its old
states reuses their memory. Each thread has its own pool; at most :data:`PER_SHAPE` arrays
of one shape and dtype are kept.

Every resampled state has the weights 1/n: :func:`uniform_log_weights` hands them out as one
read-only array per n, so a track of resampled states holds a single log-weight array (and
a fresh one is not faulted in at every step); :func:`is_uniform` recognises it.
"""
import sys
import threading

import numpy as np

#: Arrays kept per shape and dtype (a filter loop cycles through about three).
PER_SHAPE = 4
#: Arrays below this many bytes come from NumPy directly (the heap recycles them anyway).
SMALLEST = 1 << 16

_local = threading.local()
#: The uniform log weights last handed out, by size (one size kept).
_uniform = {}


def empty(shape, dtype=np.float64):
    """An uninitialised C-contiguous array, recycled when a free one of this shape and
    dtype is kept."""
    shape = (shape,) if isinstance(shape, (int, np.integer)) else tuple(shape)
    if np.prod(shape) * np.dtype(dtype).itemsize < SMALLEST:
        return np.empty(shape, dtype)
    pool = getattr(_local, "pool", None)
    if pool is None:
        pool = _local.pool = {}
    key = (shape, np.dtype(dtype).char)
    kept = pool.setdefault(key, [])
    for array in kept:
        if sys.getrefcount(array) <= 3:  # the list, this loop and the call's argument
            return array
    array = np.empty(shape, dtype)
    kept.append(array)
    if len(kept) > PER_SHAPE:  # forget the oldest: an array a state keeps for long
        del kept[0]
    return array


def empty_like(array):
    """:func:`empty` of ``array``'s shape and dtype."""
    return empty(array.shape, array.dtype)


def uniform_log_weights(n):
    """A read-only (n,) array of ``-log(n)``, shared by every caller asking for this n."""
    array = _uniform.get(n)
    if array is None:
        array = np.full(n, -np.log(n))
        array.flags.writeable = False
        _uniform.clear()  # one size kept: a loop resamples to one n
        _uniform[n] = array
    return array


def is_uniform(log_weight):
    """Whether ``log_weight`` is the array :func:`uniform_log_weights` returned last for its
    size."""
    return _uniform.get(log_weight.size) is log_weight
