"""Scalar building blocks shared by the kernels: vectorisable exp, log and sin/cos, a
counter-based random stream (uniforms and normals), and the fixed chunking of parallel
reductions."""
import numpy as np
from llvmlite import ir
from numba import prange, types
from numba.core import config
from numba.extending import intrinsic

from .dispatch import jit
from .tunables import BLOCK


if config.DISABLE_JIT:  # the same bit casts in Python, so that every kernel runs uncompiled
    def _int64_bits_as_float64(bits):
        return np.int64(bits).view(np.float64)

    def _float64_bits_as_int64(value):
        return np.float64(value).view(np.int64)
else:
    @intrinsic
    def _int64_bits_as_float64(typingctx, bits):
        """Reinterpret the 64 bits of an int64 as a float64 (a bit cast, not a conversion)."""
        if bits != types.int64:
            return None

        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.DoubleType())
        return types.float64(types.int64), codegen

    @intrinsic
    def _float64_bits_as_int64(typingctx, value):
        """Reinterpret the 64 bits of a float64 as an int64 (a bit cast, not a conversion)."""
        if value != types.float64:
            return None

        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.IntType(64))
        return types.int64(types.float64), codegen


@jit()
def _pow2(k):
    """2**k for an integer-valued float k in [-1022, 1023], built from its exponent bits."""
    return _int64_bits_as_float64((np.int64(k) + 1023) << 52)


@jit()
def fast_exp(x):
    """exp(x) within 1 ulp for normal results, branch-free so that loops vectorise.

    libm's exp is a scalar call; this one is a Cody-Waite reduction ``x = k ln2 + r`` with a
    degree-13 Taylor polynomial on ``|r| <= ln2/2``, scaled by ``2**k`` from bits. Results below
    the normal range (and the top binade) are scaled in two steps so they round correctly.
    """
    ln2_hi = 0.6931471803691238
    ln2_lo = 1.9082149292705877e-10
    inv_ln2 = 1.4426950408889634
    xc = min(max(x, -746.0), 709.8)
    k = np.floor(xc * inv_ln2 + 0.5)
    r = (xc - k * ln2_hi) - k * ln2_lo
    p = 1.0 / 6227020800.0  # Horner on 1/13!, 1/12!, ..., 1/0!
    for m in (479001600.0, 39916800.0, 3628800.0, 362880.0, 40320.0, 5040.0, 720.0,
              120.0, 24.0, 6.0, 2.0, 1.0, 1.0):
        p = p * r + 1.0 / m
    k_normal = min(max(k, -1020.0), 1023.0)
    y = p * _pow2(k_normal) * _pow2(k - k_normal)
    if x > 709.782712893384:
        y = np.inf
    if x != x:
        y = x
    return y


@jit()
def fast_log(x):
    """log(x) within 3 ulp for positive normal x, branch-free so that loops vectorise.

    ``x = 2**e * m`` with m in [sqrt(1/2), sqrt(2)) from the bits, then
    ``log m = 2 atanh(s)``, ``s = (m - 1) / (m + 1)``, as an odd series in s to s**23.
    Zero, subnormal, negative and non-finite x are outside its domain.
    """
    ln2_hi = 0.6931471803691238
    ln2_lo = 1.9082149292705877e-10
    bits = _float64_bits_as_int64(x)
    e = (bits >> 52) - 1023
    m = _int64_bits_as_float64((bits & 0xFFFFFFFFFFFFF) | 0x3FF0000000000000)
    if m > 1.4142135623730951:
        m *= 0.5
        e += 1
    s = (m - 1.0) / (m + 1.0)
    s2 = s * s
    series = 1.0 / 23.0  # Horner on 1/23, 1/21, ..., 1/3, 1
    for odd in (21.0, 19.0, 17.0, 15.0, 13.0, 11.0, 9.0, 7.0, 5.0, 3.0, 1.0):
        series = series * s2 + 1.0 / odd
    return e * ln2_hi + (2.0 * s * series + e * ln2_lo)


@jit()
def uniform(key, counter):
    """The ``counter``-th uniform double in [0, 1) of the stream named by ``key``.

    SplitMix64: the Weyl sequence ``key + (counter + 1) * golden`` through the SplitMix64
    finaliser, 53 high bits kept. A pure function of (key, counter), so parallel loops draw
    the same numbers whatever the thread count.
    """
    z = np.uint64(key) + np.uint64(counter + 1) * np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@jit()
def sin_cos_turns(u):
    """``(sin(2 pi u), cos(2 pi u))`` for u in [0, 1), branch-free so that loops vectorise.

    ``4u = k + r`` with k the nearest integer (exact), ``x = r pi / 2`` in [-pi/4, pi/4],
    Taylor polynomials to x**17 and x**16, then the quarter turn k picks signs and order.
    """
    quarters = 4.0 * u
    k = np.floor(quarters + 0.5)
    x = (quarters - k) * 1.5707963267948966
    x2 = x * x
    sin_x = 1.0 / 355687428096000.0  # Horner on 1/17!, -1/15!, ..., 1
    for m in (-1.0 / 1307674368000.0, 1.0 / 6227020800.0, -1.0 / 39916800.0,
              1.0 / 362880.0, -1.0 / 5040.0, 1.0 / 120.0, -1.0 / 6.0, 1.0):
        sin_x = sin_x * x2 + m
    sin_x *= x
    cos_x = 1.0 / 20922789888000.0  # Horner on 1/16!, -1/14!, ..., 1
    for m in (-1.0 / 87178291200.0, 1.0 / 479001600.0, -1.0 / 3628800.0,
              1.0 / 40320.0, -1.0 / 720.0, 1.0 / 24.0, -0.5, 1.0):
        cos_x = cos_x * x2 + m
    quadrant = np.int64(k) & 3
    swap = (quadrant & 1) == 1
    sin_value = cos_x if swap else sin_x
    cos_value = sin_x if swap else cos_x
    if quadrant >= 2:
        sin_value = -sin_value
    if quadrant == 1 or quadrant == 2:
        cos_value = -cos_value
    return sin_value, cos_value


@jit()
def fast_atan2(y, x):
    """atan2(y, x) within a few ulp, branch-free so that loops vectorise (finite inputs;
    atan2(0, 0) = 0).

    ``t = min(|x|, |y|) / max(|x|, |y|)`` in [0, 1]; above tan(pi/8) it is mapped to
    ``(t - 1) / (t + 1)`` with pi/4 added back; the odd Taylor series of atan to t**43 on
    ``|t| <= tan(pi/8)``; then octant, quadrant and sign from |y| > |x|, x < 0 and y < 0.
    """
    ax = abs(x)
    ay = abs(y)
    big = max(ax, ay)
    small = min(ax, ay)
    t = small / max(big, 1e-300)
    reduced = t > 0.41421356237309503
    t = (t - 1.0) / (t + 1.0) if reduced else t
    t2 = t * t
    series = -1.0 / 43.0  # Horner on (-1)^k / (2k + 1), k = 21 .. 0, in two loops that
    for c in (1.0 / 41.0, -1.0 / 39.0, 1.0 / 37.0, -1.0 / 35.0, 1.0 / 33.0,  # LLVM unrolls
              -1.0 / 31.0, 1.0 / 29.0, -1.0 / 27.0, 1.0 / 25.0, -1.0 / 23.0):
        series = series * t2 + c
    for c in (1.0 / 21.0, -1.0 / 19.0, 1.0 / 17.0, -1.0 / 15.0, 1.0 / 13.0, -1.0 / 11.0,
              1.0 / 9.0, -1.0 / 7.0, 1.0 / 5.0, -1.0 / 3.0, 1.0):
        series = series * t2 + c
    angle = t * series + (0.7853981633974483 if reduced else 0.0)
    angle = 1.5707963267948966 - angle if ay > ax else angle
    angle = 3.141592653589793 - angle if x < 0.0 else angle
    return -angle if y < 0.0 else angle


@jit()
def fill_normals(key, first_pair, out):
    """Standard normals of stream ``key`` into ``out`` (even size 2h), from the Box-Muller
    pairs ``first_pair .. first_pair + h - 1``: ``out[j]`` and ``out[h + j]`` are the cosine
    and sine normals of pair ``first_pair + j``.

    Pair p turns the uniforms ``2p`` and ``2p + 1`` into
    ``sqrt(-2 log(1 - u)) (cos 2 pi v, sin 2 pi v)``, in passes that each vectorise (a loop
    doing all of it per pair does not), in place.
    """
    half = out.size // 2
    radii = out[:half]
    turns = out[half:2 * half]
    for j in range(half):
        radii[j] = uniform(key, 2 * (first_pair + j))
        turns[j] = uniform(key, 2 * (first_pair + j) + 1)
    for j in range(half):
        radii[j] = np.sqrt(-2.0 * fast_log(1.0 - radii[j]))
    for j in range(half):
        sin_value, cos_value = sin_cos_turns(turns[j])
        turns[j] = radii[j] * sin_value
        radii[j] = radii[j] * cos_value


@jit()
def wrap_angle(a):
    """``a`` wrapped to [-pi, pi): ``a - 2 pi floor((a + pi) / 2 pi)``."""
    return a - 6.283185307179586 * np.floor((a + 3.141592653589793) * 0.15915494309189535)


@jit()
def cholesky(a, lower):
    """The lower Cholesky factor of the symmetric (m, m) ``a`` into ``lower`` (its upper
    triangle zeroed); False, leaving ``lower`` partly written, if ``a`` is not positive
    definite."""
    m = a.shape[0]
    for j in range(m):
        for i in range(j):
            lower[i, j] = 0.0
        s = a[j, j]
        for k in range(j):
            s -= lower[j, k] * lower[j, k]
        if not s > 0.0:
            return False
        lower[j, j] = np.sqrt(s)
        for i in range(j + 1, m):
            t = a[i, j]
            for k in range(j):
                t -= lower[i, k] * lower[j, k]
            lower[i, j] = t / lower[j, j]
    return True


@jit()
def fill(out, value):
    """Every entry of a C-contiguous array set to ``value`` (a loop: Numba compiles a
    slice assignment far more slowly)."""
    flat = out.reshape(-1)
    for i in range(flat.size):
        flat[i] = value


@jit()
def copy_into(source, out):
    """``out[...] = source`` for C-contiguous arrays of the same size."""
    flat_out = out.reshape(-1)
    flat_in = source.reshape(-1)
    for i in range(flat_out.size):
        flat_out[i] = flat_in[i]


@jit()
def stable_argsort(values):
    """The indices that sort the 1-D ``values`` (no NaN) ascending, equal values in index
    order: ``np.argsort(values, kind="stable")``, as runs of 16 sorted by insertion, then
    merged pairwise (a small kernel, much quicker to compile than NumPy's sorts in Numba)."""
    n = values.size
    order = np.arange(n)
    for lo in range(0, n, 16):
        for i in range(lo + 1, min(lo + 16, n)):
            item = order[i]
            k = i - 1
            while k >= lo and values[order[k]] > values[item]:
                order[k + 1] = order[k]
                k -= 1
            order[k + 1] = item
    merged = np.empty(n, dtype=np.int64)
    width = 16
    while width < n:
        for lo in range(0, n, 2 * width):
            mid, hi = min(lo + width, n), min(lo + 2 * width, n)
            i, j = lo, mid
            for k in range(lo, hi):
                if j == hi or (i < mid and values[order[i]] <= values[order[j]]):
                    merged[k] = order[i]
                    i += 1
                else:
                    merged[k] = order[j]
                    j += 1
        order, merged = merged, order
        width *= 2
    return order


@jit()
def n_chunks(n):
    """Number of work chunks for ``n`` items: a function of ``n`` alone, so chunked
    reductions give the same bits whatever the thread count."""
    return min(max(n // 8192, 1), 4096)


@jit()
def chunk_bounds(c, k, n):
    """Half-open range of items in chunk ``c`` of ``k`` over ``n`` items."""
    return c * n // k, (c + 1) * n // k


@jit(parallel=True, size=0)
def cumulate(w):
    """Running sum of ``w`` (float or int), in place: each of :func:`n_chunks` chunks is
    summed sequentially, then offset by the sequential sum of the chunks before it, so the
    bits do not depend on the thread count."""
    n = w.size
    k = n_chunks(n)
    ends = np.empty(k, dtype=w.dtype)
    for c in prange(k):
        lo, hi = chunk_bounds(np.int64(c), k, n)
        part = w[lo:hi]
        total = w.dtype.type(0)
        for i in range(part.size):
            total += part[i]
            part[i] = total
        ends[c] = total
    offsets = np.zeros(k, dtype=w.dtype)
    for c in range(1, k):
        offsets[c] = offsets[c - 1] + ends[c - 1]
    for c in prange(1, k):
        lo, hi = chunk_bounds(np.int64(c), k, n)
        part = w[lo:hi]
        for i in range(part.size):
            part[i] += offsets[c]
