"""Mirrors of ``fasttrack._jit.gram``: kernel (Gram) matrices, the median heuristic and the
pivoted Cholesky factor (contract formulas, dense matrices)."""
import numpy as np


POLYNOMIAL, GAUSSIAN, MATRIX = 0, 1, 2


def gram(kind, params, angles, x1, x2, out):
    if kind == POLYNOMIAL:
        out[:] = (x1.T @ x2 / params[2] + params[1]) ** int(params[0])
        return
    variance, norm = params[:2]
    diff = x1[:, :, None] - x2[:, None, :]
    diff[angles] = 2 * np.sin(diff[angles] / 2)
    out[:] = norm * np.exp(-np.sum(diff ** 2, axis=0) / (2 * variance))


def median_variance(angles, x):
    n = x.shape[1]
    if n < 2:
        return 1.0
    if n * (n - 1) // 2 <= 256:
        i, j = np.triu_indices(n, 1)
    else:
        k = np.arange(256)
        u, v = k * 0.6180339887498949, k * 0.41421356237309503
        i = ((u - np.floor(u)) * n).astype(np.int64)
        j = (i + 1 + ((v - np.floor(v)) * (n - 1)).astype(np.int64)) % n
    diff = x[:, i] - x[:, j]
    diff[angles] = 2 * np.sin(diff[angles] / 2)
    squared = np.sum(diff ** 2, axis=0)
    for value in (np.median(squared), np.mean(squared)):
        if value > 0:
            return value
    return 1.0


def resolve(kind, params, angles, x1, x2):
    if kind != GAUSSIAN or params[0] > 0:
        return params
    variance = params[2] ** 2 * median_variance(angles, np.hstack((x1, x2)))
    return np.array([variance, 1.0, params[2]])


def factor(kind, params, angles, points):
    """Diagonally pivoted Cholesky on the dense matrix, stopped at n eps max(diag)."""
    if kind == MATRIX:
        k = points.copy()
    else:
        k = np.empty((points.shape[1], points.shape[1]))
        gram(kind, params, angles, points, points, k)
    n = k.shape[0]
    tol = n * np.finfo(float).eps * max(np.diag(k).max(), 0.0)
    rows = []
    residual = np.diag(k).copy()
    while len(rows) < n:
        p = int(np.argmax(residual))
        if residual[p] <= tol:
            break
        previous = np.array(rows).reshape(len(rows), n)
        row = (k[p] - previous[:, p] @ previous) / np.sqrt(residual[p])
        residual -= row ** 2
        residual[p] = 0.0
        rows.append(row)
    return np.array(rows).reshape(len(rows), n)
