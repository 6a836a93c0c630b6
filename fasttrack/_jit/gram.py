"""Kernel (Gram) matrices of particle sets and their low-rank factors.

A kernel is a kind code plus a float parameter array:

- ``POLYNOMIAL``, params ``(power, c, ialpha)``: ``k(x, y) = (x.y / ialpha + c) ** power``;
- ``GAUSSIAN``, params ``(variance,)``: ``exp(-|x - y|^2 / 2 variance) / sqrt(2 pi variance)``,
  where a component flagged in ``angles`` contributes its chord ``(2 sin(diff / 2))^2``
  instead of ``diff^2``: periodic, equal to the wrapped difference squared to within a
  relative ``diff^2 / 12``, and, unlike the wrapped difference, it keeps the kernel
  positive semi-definite (it is the Gaussian kernel of the angle's point on the unit
  circle);
- ``MATRIX`` (internal): the "points" are a symmetric matrix and ``k(i, j)`` its entry, so
  that :func:`factor` also factors explicit matrices.
"""
import numpy as np
from numba import prange

from . import jit
from .numeric import fast_exp

POLYNOMIAL, GAUSSIAN, MATRIX = 0, 1, 2


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
        norm = 1.0 / np.sqrt(2.0 * np.pi * params[0])
        for b in range(out.size):
            out[b] = norm * fast_exp(scale * out[b])


@jit(parallel=True)
def gram(kind, params, angles, x1, x2, out):
    """The (A, B) Gram matrix ``out[a, b] = k(x1[:, a], x2[:, b])`` of (d, A) and (d, B)
    points, rows in parallel."""
    for a in prange(x1.shape[1]):
        _kernel_row(kind, params, angles, x1, a, x2, out[a])


@jit()
def _diagonal(kind, params, points, out):
    """``out[j] = k(x_j, x_j)``."""
    for j in range(out.size):
        if kind == MATRIX:
            out[j] = points[j, j]
        elif kind == GAUSSIAN:
            out[j] = 1.0 / np.sqrt(2.0 * np.pi * params[0])
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
            grown[:rank] = rows
            rows = grown
        scale = 1.0 / np.sqrt(pivot)
        new = rows[rank]
        for b in range(new.size):
            new[b] = row[b] * scale
            residual[b] -= new[b] * new[b]
        residual[p] = 0.0
        rank += 1
    return rows[:rank]
