"""Unscented Kalman kernels of one Gaussian state (Stone Soup's ``gauss2sigma``,
``unscented_transform`` and ``sigma2gauss``).

Sigma points of a mean x (d,) and covariance P: ``lambda = alpha^2 (d + kappa) - d``,
``c = d + lambda``, L the lower Cholesky factor of P (where a pivot is not above
``eps = spacing(max diag P)`` it is ``sqrt(eps)``, Stone Soup's ``cholesky_eps`` fallback),
points ``x``, ``x + sqrt(c) L[:, i]`` (i < d), ``x - sqrt(c) L[:, i]``; mean weights
``lambda / c``, ``1 / 2c``; covariance weights the same but ``lambda / c + 1 - alpha^2 + beta``
for the centre. The transformed points Y give the mean ``sum(Wm Y) / sum(Wm)`` (for an angle
row the circular mean ``atan2(sum(Wm sin Y), sum(Wm cos Y))``, as Stone Soup's ``Bearing``
rows average), the covariance ``sum Wc (Y - y)(Y - y)^T + noise`` and the cross covariance
``sum Wc (X - X_0)(Y - y)^T``, with the angle rows of ``Y - y`` wrapped to [-pi, pi).

Layout: points are (n, 2d + 1), one sigma point per column. Covariances are computed on the
lower triangle and mirrored (exactly symmetric).
"""
import numpy as np

from . import jit
from .kalman import _check_covariance, _sandwich, _transition
from .numeric import cholesky, fill, wrap_angle
from .sensor import _predict_block
from .status import (INNOVATION_NOT_PD, MEASUREMENT_NOT_FINITE, OK, PREDICTION_NOT_PSD,
                     PREDICTION_NOT_SYMMETRIC, PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC)


@jit()
def _cholesky_eps(a, lower):
    """Lower Cholesky factor of the symmetric (n, n) ``a`` into ``lower``; a pivot not above
    ``spacing(max diag a)`` becomes its square root (Stone Soup's ``cholesky_eps``)."""
    n = a.shape[0]
    top = a[0, 0]
    for i in range(n):
        top = max(top, a[i, i])
    eps = np.spacing(top)
    for i in range(n):
        for j in range(n):
            lower[i, j] = 0.0
    for i in range(n):
        for j in range(i):
            s = a[i, j]
            for k in range(j):
                s -= lower[i, k] * lower[j, k]
            lower[i, j] = s / lower[j, j]
        s = a[i, i]
        for k in range(i):
            s -= lower[i, k] * lower[i, k]
        lower[i, i] = np.sqrt(s) if s > eps else np.sqrt(eps)


@jit()
def sigma_points(x, covariance, alpha, beta, kappa, lower, points, mean_weights,
                 covar_weights):
    """Sigma points (d, 2d + 1) of mean ``x`` (d, 1) and covariance (d, d) into ``points``,
    their weights (2d + 1,) into ``mean_weights`` and ``covar_weights``, and the Cholesky
    factor used into ``lower`` (d, d)."""
    d = x.shape[0]
    _cholesky_eps(covariance, lower)
    alpha2 = alpha * alpha
    lamda = alpha2 * (d + kappa) - d
    c = d + lamda
    root = np.sqrt(c)
    for r in range(d):
        points[r, 0] = x[r, 0]
        for i in range(d):
            step = lower[r, i] * root
            points[r, 1 + i] = x[r, 0] + step
            points[r, 1 + d + i] = x[r, 0] - step
    mean_weights[0] = lamda / c
    covar_weights[0] = lamda / c + (1.0 - alpha2 + beta)
    for i in range(1, 2 * d + 1):
        mean_weights[i] = 0.5 / c
        covar_weights[i] = 0.5 / c


@jit()
def unscented_moments(points, transformed, mean_weights, covar_weights, angles, noise, mean,
                      covar, cross):
    """Mean (m, 1), covariance (m, m) (plus ``noise``) and cross covariance (d, m) of the
    transformed sigma points (m, 2d + 1) of ``points`` (d, 2d + 1); rows where ``angles``
    (m,) is True are angles (circular mean, wrapped differences)."""
    _moments(points, transformed, mean_weights, covar_weights, angles, noise, mean, covar,
             cross, np.empty(transformed.shape))


@jit()
def _moments(points, transformed, mean_weights, covar_weights, angles, noise, mean, covar,
             cross, diff):
    """:func:`unscented_moments` with ``diff`` (m, 2d + 1) as workspace."""
    d, n = points.shape
    m = transformed.shape[0]
    total = 0.0
    for i in range(n):
        total += mean_weights[i]
    for r in range(m):
        if angles[r]:
            s, c = 0.0, 0.0
            for i in range(n):
                s += np.sin(transformed[r, i]) * mean_weights[i]
                c += np.cos(transformed[r, i]) * mean_weights[i]
            mean[r, 0] = wrap_angle(np.arctan2(s / total, c / total))
        else:
            s = 0.0
            for i in range(n):
                s += transformed[r, i] * mean_weights[i]
            mean[r, 0] = s / total
    for r in range(m):
        for i in range(n):
            v = transformed[r, i] - mean[r, 0]
            diff[r, i] = wrap_angle(v) if angles[r] else v
    for r in range(m):
        for c in range(r + 1):
            s = 0.0
            for i in range(n):
                s += diff[r, i] * covar_weights[i] * diff[c, i]
            s += noise[r, c]
            covar[r, c] = s
            covar[c, r] = s
    for r in range(d):
        for c in range(m):
            s = 0.0
            for i in range(n):
                s += (points[r, i] - points[r, 0]) * covar_weights[i] * diff[c, i]
            cross[r, c] = s


@jit()
def unscented_predict(kind, rates, fixed_matrix, fixed_covar, dt, alpha, beta, kappa, x,
                      covariance, x_out, covariance_out):
    """One filter's unscented prediction through a FIXED or CV transition (see
    :mod:`kalman`): the prior's sigma points moved by F, their moments plus Q. Returns the
    status (PRIOR_NOT_SYMMETRIC / PRIOR_NOT_PSD for a bad prior covariance)."""
    d = x.shape[0]
    n = 2 * d + 1
    status = np.zeros(1, dtype=np.int64)
    _check_covariance(covariance.reshape((d, d, 1)), status, PRIOR_NOT_SYMMETRIC,
                      PRIOR_NOT_PSD)
    if status[0] != OK:
        return status[0]
    # one workspace (few small allocations: they dominate at these sizes)
    work = np.empty(3 * d * d + 3 * d * n + 2 * n + 1)
    at = 0
    matrix = work[at:at + d * d].reshape((d, d, 1))
    at += d * d
    covar = work[at:at + d * d].reshape((d, d, 1))
    at += d * d
    lower = work[at:at + d * d].reshape((d, d))
    at += d * d
    points = work[at:at + d * n].reshape((d, n))
    at += d * n
    moved = work[at:at + d * n].reshape((d, n))
    at += d * n
    diff = work[at:at + d * n].reshape((d, n))
    at += d * n
    mean_weights = work[at:at + n]
    at += n
    covar_weights = work[at:at + n]
    at += n
    dts = work[at:at + 1]
    dts[0] = dt
    _transition(kind, rates, fixed_matrix, fixed_covar, dts, matrix, covar)
    sigma_points(x, covariance, alpha, beta, kappa, lower, points, mean_weights, covar_weights)
    for r in range(d):
        for i in range(n):
            s = 0.0
            for k in range(d):
                s += matrix[r, k, 0] * points[k, i]
            moved[r, i] = s
    angles = np.zeros(d, dtype=np.bool_)
    _moments(points, moved, mean_weights, covar_weights, angles, covar.reshape((d, d)),
             x_out, covariance_out, lower, diff)  # the cross covariance is not needed
    return OK


@jit()
def unscented_update(kind, mapping, offset, rotation, noise, angles, alpha, beta, kappa,
                     joseph, x, covariance, z, x_out, covariance_out, z_hat,
                     innovation_covar, cross):
    """One filter's unscented update with a built-in measurement kind (see :mod:`sensor`).

    The predicted measurement ``z_hat``, innovation covariance S and cross covariance C come
    from the sigma points of the prediction; ``K = C S^-1`` (by Cholesky of S), innovation
    ``z - z_hat`` with angle rows wrapped, ``x_out = x + K v``, and ``P - K S K^T`` or with
    ``joseph`` ``(I - K H) P (I - K H)^T + K R K^T`` with the statistical linearisation
    ``H = C^T P^-1`` (exact for a linear sensor). Returns the status."""
    d = x.shape[0]
    m = z.shape[0]
    n = 2 * d + 1
    status = np.zeros(1, dtype=np.int64)
    _check_covariance(covariance.reshape((d, d, 1)), status, PREDICTION_NOT_SYMMETRIC,
                      PREDICTION_NOT_PSD)
    if status[0] != OK:
        return status[0]
    work = np.empty(d * d + d * n + 2 * m * n + 2 * n + m * m + 2 * m * d + m)
    at = 0
    lower = work[at:at + d * d].reshape((d, d))
    at += d * d
    points = work[at:at + d * n].reshape((d, n))
    at += d * n
    transformed = work[at:at + m * n].reshape((m, n))
    at += m * n
    diff = work[at:at + m * n].reshape((m, n))
    at += m * n
    mean_weights = work[at:at + n]
    at += n
    covar_weights = work[at:at + n]
    at += n
    chol = work[at:at + m * m].reshape((m, m))
    at += m * m
    whitened = work[at:at + m * d].reshape((m, d))  # L^-1 C^T
    at += m * d
    gain_t = work[at:at + m * d].reshape((m, d))  # S^-1 C^T = K^T
    at += m * d
    innovation = work[at:at + m]
    sigma_points(x, covariance, alpha, beta, kappa, lower, points, mean_weights, covar_weights)
    _predict_block(kind, points, np.int64(0), np.int64(n), mapping, offset, rotation,
                   transformed, np.int64(0))
    _moments(points, transformed, mean_weights, covar_weights, angles, noise, z_hat,
             innovation_covar, cross, diff)
    if not cholesky(innovation_covar, chol):
        return INNOVATION_NOT_PD
    for c in range(d):
        for r in range(m):
            s = cross[c, r]
            for k in range(r):
                s -= chol[r, k] * whitened[k, c]
            whitened[r, c] = s / chol[r, r]
        for r in range(m - 1, -1, -1):
            s = whitened[r, c]
            for k in range(r + 1, m):
                s -= chol[k, r] * gain_t[k, c]
            gain_t[r, c] = s / chol[r, r]
    for r in range(m):
        if not np.isfinite(z[r, 0]):
            return MEASUREMENT_NOT_FINITE
        v = z[r, 0] - z_hat[r, 0]
        innovation[r] = wrap_angle(v) if angles[r] else v
    for r in range(d):
        s = x[r, 0]
        for k in range(m):
            s += gain_t[k, r] * innovation[k]
        x_out[r, 0] = s
    if not joseph:
        for r in range(d):
            for c in range(r + 1):
                s = covariance[r, c]
                for k in range(m):
                    s -= whitened[k, r] * whitened[k, c]
                covariance_out[r, c] = s
                covariance_out[c, r] = s
        return OK
    # H^T = P^-1 C = L^-T L^-1 C with the sigma points' factor L
    h_t = np.empty((d, m))
    for c in range(m):
        for r in range(d):
            s = cross[r, c]
            for k in range(r):
                s -= lower[r, k] * h_t[k, c]
            h_t[r, c] = s / lower[r, r]
        for r in range(d - 1, -1, -1):
            s = h_t[r, c]
            for k in range(r + 1, d):
                s -= lower[k, r] * h_t[k, c]
            h_t[r, c] = s / lower[r, r]
    square = np.empty((d, d, 1))  # I - K H
    for r in range(d):
        for c in range(d):
            s = 1.0 if r == c else 0.0
            for k in range(m):
                s -= gain_t[k, r] * h_t[c, k]
            square[r, c, 0] = s
    out = covariance_out.reshape((d, d, 1))
    fill(out, 0.0)
    _sandwich(square, covariance.reshape((d, d, 1)), np.empty((d, d, 1)), out)
    gain = np.empty((d, m, 1))
    noises = np.empty((m, m, 1))
    for r in range(d):
        for c in range(m):
            gain[r, c, 0] = gain_t[c, r]
    for r in range(m):
        for c in range(m):
            noises[r, c, 0] = noise[r, c]
    _sandwich(gain, noises, np.empty((d, m, 1)), out)
    return OK
