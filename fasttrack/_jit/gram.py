"""Kernel (Gram) matrices of particle sets and their low-rank factors.

A kernel is a kind code plus a float parameter array:

- ``POLYNOMIAL``, params ``(power, c, ialpha)``: ``k(x, y) = (x.y / ialpha + c) ** power``;
- ``GAUSSIAN``, params ``(variance, norm, width)``: ``norm exp(-|x - y|^2 / 2 variance)``,
  where a component flagged in ``angles`` contributes its chord ``(2 sin(diff / 2))^2``
  instead of ``diff^2``: periodic, equal to the wrapped difference squared to within a
  relative ``diff^2 / 12``, and, unlike the wrapped difference, it keeps the kernel
  positive semi-definite (it is the Gaussian kernel of the angle's point on the unit
  circle). A variance of 0 means *from the data*: ``width**2`` times the median of the
  squared distances between the points of the Gram matrix (over all pairs of up to 23
  points, else over 256 fixed quasi-random pairs), with norm 1, so that the kernel does
  not depend on the units of the points; callers settle it with :func:`resolve` before
  calling :func:`gram` or :func:`factor`;
- ``MATRIX`` (internal): the "points" are a symmetric matrix and ``k(i, j)`` its entry, so
  that :func:`factor` also factors explicit matrices.
"""
import numpy as np
from numba import prange

from .dispatch import jit
from .kinds import GAUSSIAN, MATRIX, POLYNOMIAL
from .numeric import fast_exp
from .tunables import MEDIAN_PAIRS as _PAIRS
from .tunables import SERIAL_BELOW_HEAVY


@jit()
def _squared_distance(angles, x, i, j):
    total = 0.0
    for r in range(x.shape[0]):
        diff = x[r, i] - x[r, j]
        if angles[r]:
            diff = 2.0 * np.sin(0.5 * diff)
        total += diff * diff
    return total


@jit()
def median_variance(angles, x):
    """The median of the squared distances between the columns of (d, n) ``x`` (their
    mean if the median is 0, and 1 if every point is the same)."""
    n = x.shape[1]
    if n < 2:
        return 1.0
    if n * (n - 1) // 2 <= _PAIRS:
        distances = np.empty(n * (n - 1) // 2)
        k = 0
        for i in range(n):
            for j in range(i + 1, n):
                distances[k] = _squared_distance(angles, x, i, j)
                k += 1
    else:  # pair k: i from the golden-ratio sequence, j = i + 1 + an offset below n - 1
        distances = np.empty(_PAIRS)
        for k in range(_PAIRS):
            u = k * 0.6180339887498949
            v = k * 0.41421356237309503
            i = np.int64((u - np.floor(u)) * n)
            j = i + 1 + np.int64((v - np.floor(v)) * (n - 1))
            j = j - n if j >= n else j
            distances[k] = _squared_distance(angles, x, i, j)
    variance = np.median(distances)
    if variance > 0.0:
        return variance
    variance = np.mean(distances)
    return variance if variance > 0.0 else 1.0


@jit()
def resolve(kind, params, angles, x1, x2):
    """The kernel's parameters for the points ``x1`` and ``x2`` (together): a data-chosen
    Gaussian variance resolved (``width**2`` times their median squared distance, norm 1);
    other parameters as given."""
    if kind != GAUSSIAN or params[0] > 0.0:
        return params
    joint = np.empty((x1.shape[0], x1.shape[1] + x2.shape[1]))
    for r in range(x1.shape[0]):
        for i in range(x1.shape[1]):
            joint[r, i] = x1[r, i]
        for i in range(x2.shape[1]):
            joint[r, x1.shape[1] + i] = x2[r, i]
    resolved = np.empty(3)
    resolved[0] = params[2] * params[2] * median_variance(angles, joint)
    resolved[1] = 1.0
    resolved[2] = params[2]
    return resolved


@jit()
def _kernel_row(kind, params, angles, x1, a, x2, out):
    """``out[b] = k(x1[:, a], x2[:, b])`` for every column b of ``x2``."""
    if kind == MATRIX:
        for b in range(out.size):
            out[b] = x1[a, b]
        return
    for b in range(out.size):
        out[b] = 0.0
    for i in range(x1.shape[0]):
        xa = x1[i, a]
        x2i = x2[i]
        if kind == POLYNOMIAL:
            for b in range(out.size):
                out[b] += xa * x2i[b]
        elif angles[i]:
            for b in range(out.size):
                chord = 2.0 * np.sin(0.5 * (xa - x2i[b]))
                out[b] += chord * chord
        else:
            for b in range(out.size):
                diff = xa - x2i[b]
                out[b] += diff * diff
    if kind == POLYNOMIAL:
        power = np.int64(params[0])
        c = params[1]
        inv_ialpha = 1.0 / params[2]
        for b in range(out.size):
            out[b] = (out[b] * inv_ialpha + c) ** power
    else:
        scale = -0.5 / params[0]
        norm = params[1]
        for b in range(out.size):
            out[b] = norm * fast_exp(scale * out[b])


@jit(parallel=True, size=5, serial_below=SERIAL_BELOW_HEAVY)
def gram(kind, params, angles, x1, x2, out):
    """The (A, B) Gram matrix ``out[a, b] = k(x1[:, a], x2[:, b])`` of (d, A) and (d, B)
    points, rows in parallel (``params`` resolved: see :func:`resolve`)."""
    for a in prange(x1.shape[1]):
        _kernel_row(kind, params, angles, x1, np.int64(a), x2, out[a])


@jit()
def _diagonal(kind, params, points, out):
    """``out[j] = k(x_j, x_j)``."""
    for j in range(out.size):
        if kind == MATRIX:
            out[j] = points[j, j]
        elif kind == GAUSSIAN:
            out[j] = params[1]
        else:
            norm = 0.0
            for i in range(points.shape[0]):
                norm += points[i, j] * points[i, j]
            out[j] = (norm / params[2] + params[1]) ** np.int64(params[0])


@jit()
def factor(kind, params, angles, points):
    """Low-rank factor F (r, n) of the Gram matrix K of n points, ``K = F^T F`` up to
    working precision: Cholesky with diagonal pivoting, stopped when every remaining pivot is
    at most ``n eps max(diag K)`` (the stopping rule of LAPACK's ``dpstrf``).

    Only the r pivot rows of K are evaluated, so the cost is O(n r (d + r)). K must be
    positive semi-definite (kernel Gram matrices are); callers check other matrices.
    ``params`` are resolved (:func:`resolve`: a data-chosen length scale is the caller's to
    settle, so that kernels with fixed parameters never compile the median).
    Raises ValueError if its diagonal is not finite.
    """
    n = points.shape[1] if kind != MATRIX else points.shape[0]
    residual = np.empty(n)
    _diagonal(kind, params, points, residual)
    tol = n * 2.220446049250313e-16 * max(residual.max(), 0.0) if n > 0 else 0.0
    if not np.isfinite(tol):
        raise ValueError("the kernel values are not finite (they overflow): rescale the "
                         "points or use a lower-degree kernel")
    rows = np.empty((min(n, 16), n))
    row = np.empty(n)
    rank = 0
    while rank < n:
        p = np.argmax(residual)
        pivot = residual[p]
        if pivot <= tol:
            break
        _kernel_row(kind, params, angles, points, p, points, row)
        for i in range(rank):
            coef = rows[i, p]
            previous = rows[i]
            for b in range(row.size):
                row[b] -= coef * previous[b]
        if rank == rows.shape[0]:
            grown = np.empty((min(n, 2 * rank), n))
            for i in range(rank):
                for b in range(n):
                    grown[i, b] = rows[i, b]
            rows = grown
        scale = 1.0 / np.sqrt(pivot)
        new = rows[rank]
        for b in range(new.size):
            new[b] = row[b] * scale
            residual[b] -= new[b] * new[b]
        residual[p] = 0.0
        rank += 1
    return rows[:rank]
