"""The adaptive kernel Kalman filter's steps in NumPy, for a program's first steps (see
:func:`fasttrack._jit.numpy_first`): the factored forms of ``fasttrack._jit.akkf`` and the
pivoted Cholesky factor of ``fasttrack._jit.gram``, the proposal drawn from the kernels'
random stream; values equal to the kernels' to rounding.

Kernels are ``(kind, params)`` with resolved parameters (:mod:`fasttrack._jit.gram`);
kernel covariances are their factors ``(Lt, sigma, V1t, V2t)``.
"""
import numpy as np

from .._jit.tunables import CHOLESKY_CONDITION, MEDIAN_PAIRS
from .kinds import GAUSSIAN, MATRIX, POLYNOMIAL
from .particle_numpy import block_normals


def work(m):
    """The :func:`~fasttrack._jit.numpy_first` units of a step of M particles."""
    return 1 + m * m // 256


def gram(kind, params, angles, x1, x2):
    """The (A, B) Gram matrix of the columns of ``x1`` (d, A) and ``x2`` (d, B) (a
    polynomial or Gaussian kernel)."""
    if kind == POLYNOMIAL:
        return (x1.T @ x2 * (1.0 / params[2]) + params[1]) ** int(params[0])
    differences = x1[:, :, None] - x2[:, None, :]
    differences[angles] = 2.0 * np.sin(0.5 * differences[angles])
    return params[1] * np.exp(-0.5 / params[0] * (differences ** 2).sum(axis=0))


def median_variance(angles, x):
    """The median squared distance between the columns of ``x`` (d, n) (chords of angle
    rows), over all pairs or ``MEDIAN_PAIRS`` fixed quasi-random ones, as
    ``fasttrack._jit.gram.median_variance``."""
    n = x.shape[1]
    if n < 2:
        return 1.0
    if n * (n - 1) // 2 <= MEDIAN_PAIRS:
        i, j = np.triu_indices(n, 1)
    else:
        k = np.arange(MEDIAN_PAIRS)
        u, v = k * 0.6180339887498949, k * 0.41421356237309503
        i = ((u - np.floor(u)) * n).astype(np.int64)
        j = i + 1 + ((v - np.floor(v)) * (n - 1)).astype(np.int64)
        j = np.where(j >= n, j - n, j)
    differences = x[:, i] - x[:, j]
    differences[angles] = 2.0 * np.sin(0.5 * differences[angles])
    distances = (differences ** 2).sum(axis=0)
    for variance in (np.median(distances), distances.mean()):
        if variance > 0.0:
            return float(variance)
    return 1.0


def resolve(kind, params, angles, x1, x2):
    """The kernel's parameters for the points ``x1`` and ``x2`` together (a Gaussian
    variance from the data resolved), as ``fasttrack._jit.gram.resolve``."""
    if kind != GAUSSIAN or params[0] > 0.0:
        return params
    variance = params[2] ** 2 * median_variance(angles, np.hstack((x1, x2)))
    return np.array([variance, 1.0, params[2]])


def diagonal(kind, params, points):
    """``k(x_j, x_j)`` of each of the (d, n) ``points`` (the (n, n) matrix's diagonal for
    MATRIX)."""
    if kind == MATRIX:
        return points.diagonal().copy()
    if kind == GAUSSIAN:
        return np.full(points.shape[1], params[1])
    return ((points ** 2).sum(axis=0) / params[2] + params[1]) ** int(params[0])


def factor(kind, params, angles, points):
    """Low-rank factor F (r, n) with ``F^T F`` the Gram matrix of the n points (an explicit
    (n, n) matrix for MATRIX): Cholesky with diagonal pivoting, stopped at LAPACK's
    ``dpstrf`` rule, as ``fasttrack._jit.gram.factor``."""
    residual = diagonal(kind, params, points)
    n = residual.size
    tol = n * 2.220446049250313e-16 * max(residual.max(), 0.0) if n > 0 else 0.0
    if not np.isfinite(tol):
        raise ValueError("the kernel values are not finite (they overflow): rescale the "
                         "points or use a lower-degree kernel")
    rows = []
    while len(rows) < n:
        p = int(np.argmax(residual))
        if residual[p] <= tol:
            break
        row = points[p] if kind == MATRIX \
            else gram(kind, params, angles, points, points[:, p:p + 1])[:, 0]
        if rows:
            done = np.array(rows)
            row = row - done[:, p] @ done
        new = row / np.sqrt(residual[p])
        residual = residual - new * new
        residual[p] = 0.0
        rows.append(new)
    return np.array(rows).reshape(len(rows), n)


def ridge_map(f, lam):
    """``(F F^T + lam I)^-1 F`` for F (p, n): by Cholesky while ``trace / lam`` stays within
    ``CHOLESKY_CONDITION``, else by the QR factors of ``[F, sqrt(lam) I]^T``."""
    p, n = f.shape
    if p * lam + (f * f).sum() > CHOLESKY_CONDITION * lam:
        q, r = np.linalg.qr(np.hstack((f, np.sqrt(lam) * np.eye(p))).T)
        return np.linalg.solve(r, q[:n].T)
    lower = np.linalg.cholesky(f @ f.T + lam * np.eye(p))
    return np.linalg.solve(lower.T, np.linalg.solve(lower, f))


def _deviation(a, v1t, v2t):
    """``a Z = a - (a V1t^T) V2t``."""
    return a - (a @ v1t.T) @ v2t


def sandwich(a, lt, sigma, v1t, v2t):
    """``a S a^T`` for a (n, M) and the kernel covariance factors."""
    t, u = a @ lt.T, _deviation(a, v1t, v2t)
    return t @ t.T + sigma * (u @ u.T)


def predict_embedding(kind, params, angles, proposal, x, w, lt, sigma, v1t, v2t, lam):
    """``(w, Lt, V1t, V2t)`` predicted, as ``fasttrack._jit.akkf.predict_embedding``."""
    m = w.size
    joint = factor(kind, params, angles, np.hstack((proposal, x)))
    phi_new, phi = joint[:, :m], joint[:, m:]
    if phi_new.shape[0] <= m:
        v2t_pred = ridge_map(phi_new, lam)
        root = factor(MATRIX, None, None, sandwich(phi, lt, sigma, v1t, v2t))
        return (phi @ w) @ v2t_pred, root @ v2t_pred, phi_new, v2t_pred
    solve = ridge_map(phi_new.T, lam)
    gamma = solve @ phi
    root = factor(MATRIX, None, None, sandwich(gamma, lt, sigma, v1t, v2t))
    return gamma @ w, root, np.eye(m), solve @ phi_new


def update_embedding(kind, params, angles, y, z, w, lt, sigma, v1t, v2t, lam, x, key):
    """``(w, Lt, V1t, V2t, proposal)`` updated with ``z`` (m, 1), as
    ``fasttrack._jit.akkf.update_embedding``."""
    m = w.size
    joint = factor(kind, params, angles, np.hstack((y, z)))
    psi = joint[:, :m]
    t1, u = psi @ lt.T, _deviation(psi, v1t, v2t)
    k = t1.shape[1]
    root_sigma = np.sqrt(sigma)
    solve = ridge_map(np.hstack((t1, root_sigma * u)), lam)
    gain_t = solve[:, :k] @ lt + root_sigma * _deviation(solve[:, k:], v2t, v1t)
    w_post = w + (joint[:, m] - psi @ w) @ gain_t
    lt_post = np.vstack((lt - t1.T @ gain_t, np.sqrt(lam) * gain_t))
    v1t_post, v2t_post = np.vstack((v1t, gain_t)), np.vstack((v2t, u))
    return (w_post, lt_post, v1t_post, v2t_post,
            draw_proposal(x, w_post, lt_post, sigma, v1t_post, v2t_post, key))


def draw_proposal(x, w, lt, sigma, v1t, v2t, key):
    """(d, M) proposal: ``x w + sqrt(diag(x S x^T))`` times the stream's normals, row-major,
    as ``fasttrack._jit.akkf.draw_proposal``."""
    d, m = x.shape
    normals = block_normals(key, 1, d * m + (d * m) % 2)[0, :d * m].reshape(d, m)
    scale = np.sqrt(sandwich(x, lt, sigma, v1t, v2t).diagonal())
    return (x @ w)[:, None] + scale[:, None] * normals
