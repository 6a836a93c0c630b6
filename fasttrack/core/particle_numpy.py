"""The particle filter's steps in NumPy, for a program's first steps (see
:func:`fasttrack._jit.numpy_first`): the kernels' random stream and rules
(``fasttrack._jit.numeric``, ``propagate``, ``likelihood``, ``weights`` and ``resample``),
so the same key gives the same particles and ancestors, values equal to rounding.

Particles are (d, N) arrays, log weights (N,); functions return new arrays.
"""
import numpy as np

from .._jit.tunables import BLOCK
from .kalman_numpy import measure, wrap

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def work(x):
    """The :func:`~fasttrack._jit.numpy_first` units of a step over the (d, N) or (N,)
    array ``x``: one per few thousand entries (a vectorised NumPy pass over them costs
    about what one filter's Kalman step does)."""
    return 1 + x.size // 4096


def uniforms(key, counters):
    """The stream ``key``'s uniform doubles in [0, 1) at the int64 ``counters``
    (SplitMix64, as :func:`fasttrack._jit.numeric.uniform`)."""
    with np.errstate(over="ignore"):
        z = np.uint64(key) + (counters.astype(np.uint64) + np.uint64(1)) * _GOLDEN
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z ^= z >> np.uint64(31)
    return (z >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)


def block_normals(key, blocks, size):
    """(blocks, size) normals: row b as ``fill_normals`` fills a block's ``size`` entries
    from pair ``b * size / 2`` on (cosine normals, then sine normals)."""
    pairs = np.arange(blocks * size // 2, dtype=np.int64).reshape(blocks, size // 2)
    radii = np.sqrt(-2.0 * np.log(1.0 - uniforms(key, 2 * pairs)))
    turns = 2.0 * np.pi * uniforms(key, 2 * pairs + 1)
    return np.concatenate((radii * np.cos(turns), radii * np.sin(turns)), axis=1)


def propagate(spec, x, key):
    """``F x + S z`` for a linear transition ``spec``: the normals z of stream ``key`` laid
    out as ``fasttrack._jit.propagate`` lays them (blocks of BLOCK particles)."""
    out = spec.matrix @ x
    if not np.any(spec.noise_root):
        return out
    d, n = x.shape
    even, blocks = d + (d & 1), -(-n // BLOCK)
    z = block_normals(key, blocks, even * BLOCK).reshape(blocks, even, BLOCK)
    noise = z[:, :d].transpose(1, 0, 2).reshape(d, blocks * BLOCK)[:, :n]
    return out + spec.noise_root @ noise


def log_likelihood(spec, z, x, log_w):
    """``(out, max)``: ``log_w + log p(z | x[:, i])`` by a built-in sensor ``spec``, with
    ``z`` (m,)."""
    whiten, log_norm = spec.noise.whitening()
    innovation = z[:, None] - measure(spec, x)
    innovation[spec.angles] = wrap(innovation[spec.angles])
    out = log_w + log_norm - 0.5 * np.sum((whiten @ innovation) ** 2, axis=0)
    return out, (np.nan if np.isnan(out).any() else out.max())


def _power_sums(log_w, log_w_max):
    w = np.exp(log_w - log_w_max)
    return w.sum(), (w * w).sum()


def ess(log_w, log_w_max):
    """Kish's effective sample size of unnormalised log weights."""
    s1, s2 = _power_sums(log_w, log_w_max)
    return s1 * s1 / s2


def normalise(log_w, log_w_max):
    """``(normalised log weights, ess)``, as ``normalise_in_place`` computes them."""
    s1, s2 = _power_sums(log_w, log_w_max)
    return (log_w - log_w_max) - np.log(s1), s1 * s1 / s2


def mean(x, log_w):
    """``(mean (d, 1), weights (N,), total)``: the weighted mean of the columns of ``x``
    (d, N) with unnormalised ``log_w``, the weights ``exp(log_w - max)`` and their sum."""
    w = np.exp(log_w - log_w.max())
    total = w.sum()
    return (x @ w / total)[:, None], w, total


def mean_covar(x, log_w):
    """``(mean (d, 1), covar (d, d))``: the weighted mean and covariance of the columns of
    ``x`` (d, N) with unnormalised ``log_w`` (two passes, as ``weighted_mean_covar``)."""
    centre, w, total = mean(x, log_w)
    deviations = x - centre
    return centre, deviations @ (deviations * w).T / total


def starts(stratified, log_w, log_w_max, n, key):
    """The starts (see ``fasttrack._jit.resample``) of a systematic draw of ``n`` points
    (one uniform for all), or a ``stratified`` one (one per stratum)."""
    cdf = np.cumsum(np.exp(log_w - log_w_max))
    changed = np.flatnonzero(cdf[1:] != cdf[:-1])
    last = changed[-1] + 1 if changed.size else 0
    out = np.full(cdf.size, n, dtype=np.int64)
    out[0] = 0
    bounds = cdf[:last] * (n / cdf[-1])
    if stratified:
        strata = np.minimum(bounds.astype(np.int64), n - 1)
        out[1:last + 1] = strata + (strata + uniforms(key, strata) < bounds)
    else:
        u = uniforms(key, np.zeros(1, dtype=np.int64))[0]
        out[1:last + 1] = np.minimum(np.maximum(np.ceil(bounds - u), 0.0), n)
    return out


def expand(starts, n):
    """Ancestor indices (n,): ``idx[j]`` the largest i with ``starts[i] <= j``."""
    return np.searchsorted(starts, np.arange(n), side="right") - 1
