"""Mirrors of ``fasttrack._jit.numeric``: exp and log, the counter-based uniforms and the
Box-Muller normals of a stream key, angles, Cholesky, fills and chunking."""
import numpy as np


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


def cholesky(a, lower):
    try:
        lower[:] = np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        return False
    return True


def fill(out, value):
    out[...] = value


def copy_into(source, out):
    out.reshape(-1)[:] = source.reshape(-1)


def stable_argsort(values):
    return np.argsort(values, kind="stable")


def n_chunks(n):
    return min(max(n // 8192, 1), 4096)


def chunk_bounds(c, k, n):
    return c * n // k, (c + 1) * n // k


def cumulate(w):
    w[:] = np.cumsum(w)
