"""Mirrors of ``fasttrack._jit.resample``: the resampling schemes' starts, floors and
expansion; and :func:`draw`, the resampling pipeline built on these mirrors."""
import numpy as np

from .numeric import cumulate, uniform
from .weights import relative_weights


def last_nonempty(cdf):
    nonempty = np.flatnonzero(np.diff(cdf) != 0)
    return int(nonempty[-1] + 1) if nonempty.size else 0


def _stratum(bound, scale, n):
    return np.minimum((bound * scale).astype(np.int64), n - 1)


def _starts_frame(cdf, n, starts):
    """Starts of particles no draw reaches, as the kernels set them."""
    last = last_nonempty(cdf)
    starts[0] = 0
    starts[last + 1:] = n
    return last, n / cdf[-1]


def systematic_starts(cdf, n, key, starts):
    last, scale = _starts_frame(cdf, n, starts)
    u = uniform(key, 0)
    starts[1:last + 1] = np.clip(np.ceil(cdf[:last] * scale - u), 0, n).astype(np.int64)


def stratified_starts(cdf, n, key, starts):
    last, scale = _starts_frame(cdf, n, starts)
    y = cdf[:last] * scale
    s = _stratum(cdf[:last], scale, n)
    starts[1:last + 1] = s + (s + uniform(key, s) < y)


def sorted_uniforms(key, n, out):
    spacing = -np.log(1.0 - uniform(key, np.arange(n + 1)))
    total = np.cumsum(spacing)
    out[:n] = np.minimum(total[:n] * (n / total[n]), n)
    out[n] = total[n]


def stratum_occupancy(points, n, occupancy):
    strata = np.minimum(points[:n].astype(np.int64), n - 1)
    occupancy[0] = 0
    occupancy[1:] = np.cumsum(np.bincount(strata, minlength=n))


def multinomial_starts(cdf, n, key, occupancy, starts):
    """The k-th point is ``s_k + u(key, n + 1 + k)``; starts count the points below each
    boundary by a search in the sorted points."""
    last, scale = _starts_frame(cdf, n, starts)
    point_strata = np.repeat(np.arange(n), np.diff(occupancy))
    points = np.sort(point_strata + uniform(key, n + 1 + np.arange(n)))
    starts[1:last + 1] = np.searchsorted(points, cdf[:last] * scale, side="left")


def scheme_points(scheme, key, n, occupancy, out):
    j = np.arange(n)
    if scheme == 0:
        out[:n] = (j + uniform(key, 0)) / n
    elif scheme == 1:
        out[:n] = (j + uniform(key, j)) / n
    else:
        out[:n] = (np.repeat(j, np.diff(occupancy[:n + 1])) + uniform(key, n + 1 + j)) / n


def residual_floors(cdf, log_w, log_w_max, n, floors, residuals):
    expected = np.exp(log_w - log_w_max) * (n / cdf[-1])
    floors[:] = np.floor(expected * (1.0 + 1e-12)).astype(np.int64)
    residuals[:] = np.maximum(expected - floors, 0.0)


def add_floors(starts, floor_sums):
    starts[1:] += floor_sums[:-1]


def expand(starts, idx, x, out):
    idx[:] = np.searchsorted(starts, np.arange(idx.size), side="right") - 1
    out[:] = x[:, idx]


def take_columns(x, idx, out):
    out[:] = x[:, idx]


# --- the resampling pipeline on these mirrors ----------------------------------------------


def draw(log_w, n, method, residual, key):
    """Ancestor indices of ``fasttrack.resampling.draw`` for the stream ``key``."""
    cdf = np.empty_like(log_w)
    log_w_max = log_w.max()
    relative_weights(log_w, log_w_max, cdf)
    cumulate(cdf)
    if residual:
        floors = np.empty(cdf.size, dtype=np.int64)
        residuals = np.empty_like(cdf)
        residual_floors(cdf, log_w, log_w_max, n, floors, residuals)
        cumulate(floors)
        n_rest = n - floors[-1]
        starts = np.zeros(cdf.size, dtype=np.int64)
        if n_rest > 0:
            cumulate(residuals)
            starts = scheme_starts(method, residuals, n_rest, key)
        add_floors(starts, floors)
    else:
        starts = scheme_starts(method, cdf, n, key)
    idx = np.empty(n, dtype=np.int64)
    expand(starts, idx, np.empty((0, cdf.size)), np.empty((0, n)))
    return idx


def scheme_starts(method, cdf, n, key):
    starts = np.empty(cdf.size, dtype=np.int64)
    if method == "systematic":
        systematic_starts(cdf, n, key, starts)
    elif method == "stratified":
        stratified_starts(cdf, n, key, starts)
    else:
        points = np.empty(n + 1)
        sorted_uniforms(key, n, points)
        occupancy = np.empty(n + 1, dtype=np.int64)
        stratum_occupancy(points, n, occupancy)
        multinomial_starts(cdf, n, key, occupancy, starts)
    return starts
