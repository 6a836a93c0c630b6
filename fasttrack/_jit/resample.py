"""Resampling kernels.

Every scheme is expressed through *starts*: ``starts[i]`` is the number of sorted points
below particle i's interval of the cumulative weights, i.e. the output position of its first
copy, so particle i has ``starts[i+1] - starts[i]`` copies. One branch-free pass
(:func:`expand`) turns starts into ascending ancestor indices and gathers the state. Index
generation is O(N + n) without sorting and cannot leave the valid range: particles after the
last non-empty interval start at n, so they are never drawn.

Points are in *stratum units*: the cumulative weights are scaled to [0, n]. Kernels write
into arrays allocated by the caller (NumPy's allocator is much cheaper than Numba's for large
arrays, whose fresh pages fault one by one).
"""
import numpy as np
from numba import prange

from .dispatch import jit
from .numeric import chunk_bounds, cumulate, fast_exp, fast_log, n_chunks, uniform


@jit()
def last_nonempty(cdf):
    """Index of the last particle whose interval ``[cdf[i-1], cdf[i])`` is not empty."""
    last = cdf.size - 1
    while last > 0 and cdf[last] == cdf[last - 1]:
        last -= 1
    return last


@jit()
def _prepare_starts(cdf, n, starts):
    """Set the starts no draw can reach (particles past the last non-empty interval start at
    n); return that last index and the scale of the cumulative weights to stratum units.

    Kernels then fill ``starts[1:last + 1]`` from the boundaries ``cdf[:last]``. (They slice
    the arrays themselves: a view returned by a helper and written in a ``prange`` loop
    loses its writes to Numba's parfor dead-code elimination.)
    """
    last = last_nonempty(cdf)
    starts[0] = 0
    starts[last + 1:] = n
    return last, n / cdf[cdf.size - 1]


@jit()
def _stratum(bound, scale, n):
    return min(np.int64(bound * scale), n - 1)


@jit()
def _first_in_stratum(bounds, scale, n, s, start):
    """First i >= start whose boundary lies in stratum s or above: gallop from start, then
    bisect (cheap when the answer is near start)."""
    lo = start
    step = 1
    hi = start
    while hi < bounds.size and _stratum(bounds[hi], scale, n) < s:
        lo = hi + 1
        hi = start + step
        step *= 2
    hi = min(hi, bounds.size)
    while lo < hi:
        mid = (lo + hi) // 2
        if _stratum(bounds[mid], scale, n) < s:
            lo = mid + 1
        else:
            hi = mid
    return lo


@jit(parallel=True, size=0)
def systematic_starts(cdf, n, key, starts):
    """Starts for the points ``j + u``, j = 0..n-1, one uniform ``u`` for all."""
    u = uniform(key, np.int64(0))
    last, scale = _prepare_starts(cdf, n, starts)
    bounds = cdf[:last]
    following = starts[1:last + 1]
    for i in prange(bounds.size):
        following[i] = np.int64(min(max(np.ceil(bounds[i] * scale - u), 0.0), n))


@jit(parallel=True, size=0)
def stratified_starts(cdf, n, key, starts):
    """Starts for the points ``j + u_j``, j = 0..n-1, one uniform per stratum.

    A boundary y in stratum s = floor(y) has s points below it from the strata before, plus
    one if stratum s's own point ``s + u_s`` is below y.
    """
    last, scale = _prepare_starts(cdf, n, starts)
    bounds = cdf[:last]
    following = starts[1:last + 1]
    for i in prange(bounds.size):
        s = _stratum(bounds[i], scale, n)
        following[i] = s + np.int64(s + uniform(key, s) < bounds[i] * scale)


@jit(parallel=True, size=2)
def sorted_uniforms(key, n, out):
    """``out[:n]`` = n ascending iid uniforms on [0, n), as normalised partial sums of the
    n + 1 exponentials drawn from counters 0..n; ``out`` has n + 1 entries."""
    for j in prange(n + 1):
        out[j] = -fast_log(1.0 - uniform(key, np.int64(j)))
    cumulate(out)
    scale = n / out[n]
    for j in prange(n):
        out[j] = min(out[j] * scale, n)


@jit(parallel=True, size=0)
def stratum_occupancy(points, n, occupancy):
    """``occupancy[s]`` = number of the n ascending points (in [0, n]) whose stratum
    ``min(floor(p), n - 1)`` is below s, for s = 0..n: per chunk of strata, a histogram of
    its points and a running sum."""
    k = n_chunks(n)
    for c in prange(k):
        lo, hi = chunk_bounds(np.int64(c), k, n)
        first = np.searchsorted(points[:n], lo, side="left") if lo > 0 else 0
        stop = np.searchsorted(points[:n], hi, side="left") if hi < n else n
        hist = np.zeros(hi - lo, dtype=np.int64)
        inside = points[first:stop]
        for j in range(inside.size):
            hist[min(np.int64(inside[j]), n - 1) - lo] += 1
        below = first
        chunk_occupancy = occupancy[lo:hi]
        for t in range(chunk_occupancy.size):
            chunk_occupancy[t] = below
            below += hist[t]
    occupancy[n] = n


@jit(parallel=True, size=0)
def multinomial_starts(cdf, n, key, occupancy, starts):
    """Starts for n iid uniform points given how many fall in each stratum.

    ``occupancy[s]`` is the number of points in strata 0..s-1 (n + 1 entries). A boundary y
    in stratum s has ``occupancy[s]`` points below its stratum, plus those points
    ``s + u_k`` of stratum s below y, where ``u_k`` is a fresh uniform from counter
    ``n + 1 + k`` for the k-th point (given the occupancies, positions inside a stratum are
    iid uniform). The
    first eight points of a stratum are tested without branches (a stratum holds more with
    probability 1e-6); the rare crowded strata are finished afterwards.
    """
    last, scale = _prepare_starts(cdf, n, starts)
    bounds = cdf[:last]
    following = starts[1:last + 1]
    for i in prange(bounds.size):
        y = bounds[i] * scale
        s = _stratum(bounds[i], scale, n)
        first = occupancy[s]
        inside = occupancy[s + 1] - first
        count = first
        for q in range(8):
            count += np.int64(q < inside) * np.int64(s + uniform(key, n + 1 + first + q) < y)
        following[i] = count
    first = np.int64(0)
    for s in range(n):
        inside = occupancy[s + 1] - occupancy[s]
        if inside > 8:
            first = _first_in_stratum(bounds, scale, n, s, first)
            stop = _first_in_stratum(bounds, scale, n, s + 1, first)
            for i in range(first, stop):
                y = bounds[i] * scale
                for q in range(8, inside):
                    following[i] += np.int64(s + uniform(key, n + 1 + occupancy[s] + q) < y)


@jit()
def scheme_points(scheme, key, n, occupancy, out):
    """``out[:n]`` = the n points (in [0, 1)) that the starts kernels above test for stream
    ``key``: scheme 0 systematic, 1 stratified, 2 multinomial (from the ``occupancy`` of
    :func:`stratum_occupancy`; in counter order, not sorted)."""
    for s in range(n):
        if scheme == 0:
            out[s] = (s + uniform(key, np.int64(0))) / n
        elif scheme == 1:
            out[s] = (s + uniform(key, np.int64(s))) / n
        else:
            for k in range(occupancy[s], occupancy[s + 1]):
                out[k] = (s + uniform(key, n + 1 + k)) / n


@jit(parallel=True, size=1)
def residual_floors(cdf, log_w, log_w_max, n, floors, residuals):
    """``floors = floor(n w)`` and ``residuals = n w - floors`` for w normalised by the sum
    ``cdf[-1]``.

    An expected count less than 1e-12 (relative) below an integer counts as that integer, so
    exact counts such as 5 x 0.2 survive the rounding of the normalisation; the floors still
    never add up to more than n (for n N < 1e12).
    """
    scale = n / cdf[cdf.size - 1]
    for i in prange(log_w.size):
        expected = fast_exp(log_w[i] - log_w_max) * scale
        floors[i] = np.int64(np.floor(expected * (1.0 + 1e-12)))
        residuals[i] = max(expected - floors[i], 0.0)


@jit(parallel=True, size=0)
def add_floors(starts, floor_sums):
    """Residual starts: ``starts[i] += floor_sums[i - 1]`` (running sums of the floors)."""
    following = starts[1:]
    for i in prange(following.size):
        following[i] += floor_sums[i]


@jit(parallel=True, size=1)
def expand(starts, idx, x, out):
    """``idx[j]`` = largest i with ``starts[i] <= j`` (ascending), and ``out = x[:, idx]``.

    Each chunk of outputs histograms the starts that fall inside it and takes a running sum,
    with no data-dependent branches. ``idx`` is -1 where no start is <= j. ``x`` and ``out``
    may have 0 rows.
    """
    n = idx.size
    k = n_chunks(n)
    for c in prange(k):
        lo, hi = chunk_bounds(np.int64(c), k, n)
        first = np.searchsorted(starts, lo, side="left")
        stop = np.searchsorted(starts, hi, side="left")
        hist = np.zeros(hi - lo, dtype=np.int64)
        inside = starts[first:stop]
        for i in range(inside.size):
            hist[inside[i] - lo] += 1
        ancestor = first - 1
        chunk_idx = idx[lo:hi]
        for j in range(chunk_idx.size):
            ancestor += hist[j]
            chunk_idx[j] = ancestor
        for r in range(x.shape[0]):
            row_in = x[r]
            row_out = out[r, lo:hi]
            for j in range(chunk_idx.size):
                row_out[j] = row_in[chunk_idx[j]]


@jit(parallel=True, size=2)
def take_columns(x, idx, out):
    """``out = x[:, idx]`` for a (d, N) array and ascending indices."""
    for r in range(x.shape[0]):
        row_in = x[r]
        row_out = out[r]
        for j in prange(idx.size):
            row_out[j] = row_in[idx[j]]
