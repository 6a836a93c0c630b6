"""Plain-NumPy mirrors of the kernels in ``fasttrack._jit`` (same names, same arguments,
loops allowed). Tests give both the same inputs, including the same random stream keys,
and compare: integers equal, floats close."""
import numpy as np

# --- numeric -------------------------------------------------------------------------------


def fast_exp(x):
    return np.exp(x)


def fast_log(x):
    return np.log(x)


def uniform(key, counter):
    """SplitMix64 of the Weyl sequence ``key + (counter + 1) * golden``, 53 high bits."""
    counter = np.asarray(counter, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = np.uint64(key) + (counter + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) * 2.0**-53


def fast_atan2(y, x):
    return np.arctan2(y, x)


def sin_cos_turns(u):
    return np.sin(2 * np.pi * u), np.cos(2 * np.pi * u)


def normal_pairs(key, pairs):
    """The cosine and sine normals of the Box-Muller pairs ``pairs`` of stream ``key``."""
    pairs = np.asarray(pairs, dtype=np.int64)
    radius = np.sqrt(-2.0 * np.log(1.0 - uniform(key, 2 * pairs)))
    turn = 2 * np.pi * uniform(key, 2 * pairs + 1)
    return radius * np.cos(turn), radius * np.sin(turn)


def fill_normals(key, first_pair, out):
    half = out.size // 2
    out[:half], out[half:2 * half] = normal_pairs(key, first_pair + np.arange(half))


def wrap_angle(a):
    """Stone Soup's mod_bearing: ((a + pi) mod 2 pi) - pi."""
    return np.mod(a + np.pi, 2 * np.pi) - np.pi


def n_chunks(n):
    return min(max(n // 8192, 1), 4096)


def chunk_bounds(c, k, n):
    return c * n // k, (c + 1) * n // k


def cumulate(w):
    w[:] = np.cumsum(w)


# --- weights -------------------------------------------------------------------------------


def relative_weights(log_w, log_w_max, out):
    out[:] = np.exp(log_w - log_w_max)


def log_sum_exp(log_w, log_w_max):
    return log_w_max + np.log(np.sum(np.exp(log_w - log_w_max)))


def ess(log_w, log_w_max):
    w = np.exp(log_w - log_w_max)
    return w.sum() ** 2 / (w**2).sum()


def weighted_mean_covar(x, log_w, log_w_max, mean, covar):
    w = np.exp(log_w - log_w_max)
    mean[:] = np.average(x, axis=1, weights=w)
    covar[:] = np.atleast_2d(np.cov(x, ddof=0, aweights=w))


def normalise_in_place(log_w, log_w_max):
    shift = log_sum_exp(log_w, log_w_max)
    log_w -= shift
    return shift


# --- propagate -----------------------------------------------------------------------------

PROPAGATE_BLOCK = 1024


def _process_noise(noise_root, key, n):
    """S z for n particles, with the kernels' layout of the normals: block b fills
    ``even * BLOCK`` normals (even = d rounded up to even) from pair ``b * BLOCK * even / 2``,
    and component c of its particle i is entry ``c * BLOCK + i``."""
    d = noise_root.shape[0]
    even = d + d % 2
    blocks = -(-n // PROPAGATE_BLOCK)
    z = np.empty((d, blocks * PROPAGATE_BLOCK))
    for b in range(blocks):
        block = np.empty(even * PROPAGATE_BLOCK)
        fill_normals(key, b * PROPAGATE_BLOCK * even // 2, block)
        z[:, b * PROPAGATE_BLOCK:(b + 1) * PROPAGATE_BLOCK] = block[:d * PROPAGATE_BLOCK].reshape(
            d, PROPAGATE_BLOCK)
    return noise_root @ z[:, :n]


def propagate_linear(x, matrix, noise_root, key, out):
    out[:] = matrix @ x
    if np.any(noise_root != 0):
        out += _process_noise(noise_root, key, x.shape[1])


def propagate_function(function, time_interval, x, noise_root, key, out):
    out[:] = function(x, time_interval)
    if np.any(noise_root != 0):
        out += _process_noise(noise_root, key, x.shape[1])


# --- likelihood ----------------------------------------------------------------------------

SELECT, BEARING_RANGE, BEARING = 0, 1, 2


def measure(kind, x, mapping, offset, rotation, out):
    if kind == SELECT:
        out[:] = x[mapping]
        return
    p = rotation @ (x[mapping[:2]] - offset[:, None])
    out[0] = wrap_angle(np.arctan2(p[1], p[0]))
    if kind == BEARING_RANGE:
        out[1] = np.hypot(p[0], p[1])


def _log_likelihoods(z, predicted, angles, whiten, log_norm, log_w, out):
    innovation = z[:, None] - predicted
    innovation[angles] = wrap_angle(innovation[angles])
    out[:] = log_w + log_norm - 0.5 * np.sum((whiten @ innovation) ** 2, axis=0)
    return np.nan if np.isnan(out).any() else out.max()


def log_likelihood(kind, z, x, mapping, offset, rotation, angles, whiten, log_norm, log_w, out):
    predicted = np.empty((z.size, x.shape[1]))
    measure(kind, x, mapping, offset, rotation, predicted)
    return _log_likelihoods(z, predicted, angles, whiten, log_norm, log_w, out)


def measure_function(function, x, angles, out):
    out[:] = function(x)
    out[angles] = wrap_angle(out[angles])


def log_likelihood_function(function, z, x, angles, whiten, log_norm, log_w, out):
    return _log_likelihoods(z, function(x), angles, whiten, log_norm, log_w, out)


# --- resample ------------------------------------------------------------------------------


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
