"""Mirrors of ``fasttrack._jit.unscented``: sigma points, unscented moments, and the
unscented Kalman prediction and update of one filter and of batches."""
import numpy as np

from .kalman import _covariance_status, _positive_definite, _standard_form, _transition
from .likelihood import measure
from .numeric import wrap_angle
from .sensor import SELECT
from .status import (INNOVATION_NOT_PD, MEAN_AT_SENSOR, MEASUREMENT_NOT_FINITE, OK,
                     PREDICTION_NOT_PSD, PREDICTION_NOT_SYMMETRIC, PREDICTION_OVERFLOW,
                     PREDICTION_UNRESOLVED, PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC,
                     PRIOR_UNRESOLVED)
from .user import output_status

#: ``fasttrack._jit.tunables.SIGMA_RESOLUTION``.
SIGMA_RESOLUTION = 1e12


def _status(x, covariance, asymmetric, indefinite, unresolved):
    """The covariance's status, or ``unresolved`` where a component of x is beyond
    SIGMA_RESOLUTION standard deviations (of a variance above 1e-200)."""
    status = _covariance_status(covariance, asymmetric, indefinite)
    for r in range(x.shape[0]):
        v = covariance[r, r]
        if status == OK and v > 1e-200 and abs(x[r, 0]) > SIGMA_RESOLUTION * np.sqrt(v):
            status = unresolved
    return status


def _cholesky_eps(a):
    """NumPy's Cholesky, else Stone Soup's ``cholesky_eps`` rule (pivots <= eps -> sqrt(eps))."""
    try:
        return np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        eps = np.spacing(np.max(np.diag(a)))
        lower = np.zeros(a.shape)
        for i in range(a.shape[0]):
            for j in range(i):
                lower[i, j] = (a[i, j] - lower[i, :] @ lower[j, :]) / lower[j, j]
            v = a[i, i] - lower[i, :] @ lower[i, :]
            lower[i, i] = np.sqrt(v) if v > eps else np.sqrt(eps)
        return lower


def sigma_points(x, covariance, alpha, beta, kappa, lower, points, mean_weights,
                 covar_weights):
    d = x.shape[0]
    lower[:] = _cholesky_eps(covariance)
    lamda = alpha ** 2 * (d + kappa) - d
    c = d + lamda
    points[:] = np.hstack([x, x + lower * np.sqrt(c), x - lower * np.sqrt(c)])
    mean_weights[:] = 0.5 / c
    covar_weights[:] = 0.5 / c
    mean_weights[0] = lamda / c
    covar_weights[0] = lamda / c + 1 - alpha ** 2 + beta


def unscented_moments(points, transformed, mean_weights, covar_weights, angles, noise, mean,
                      covar, cross):
    for r in range(transformed.shape[0]):
        row = transformed[r]
        if angles[r]:
            mean[r, 0] = wrap_angle(np.arctan2(np.sum(np.sin(row) * mean_weights),
                                               np.sum(np.cos(row) * mean_weights)))
        else:
            mean[r, 0] = np.average(row, weights=mean_weights)
    diff = transformed - mean
    diff[angles] = wrap_angle(diff[angles])
    covar[:] = diff @ np.diag(covar_weights) @ diff.T + noise
    cross[:] = (points - points[:, :1]) @ np.diag(covar_weights) @ diff.T


def _sigma(x, covariance, alpha, beta, kappa):
    d = x.shape[0]
    lower, points = np.empty((d, d)), np.empty((d, 2 * d + 1))
    wm, wc = np.empty(2 * d + 1), np.empty(2 * d + 1)
    sigma_points(x, covariance, alpha, beta, kappa, lower, points, wm, wc)
    return lower, points, wm, wc


def unscented_predict(kind, rates, fixed_matrix, fixed_covar, dt, alpha, beta, kappa, x,
                      covariance, x_out, covariance_out):
    status = _status(x, covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD, PRIOR_UNRESOLVED)
    if status != OK:
        return status
    d = x.shape[0]
    f, q = _transition(kind, rates, fixed_matrix, fixed_covar, dt, d)
    _, points, wm, wc = _sigma(x, covariance, alpha, beta, kappa)
    with np.errstate(over="ignore", invalid="ignore"):
        unscented_moments(points, f @ points, wm, wc, np.zeros(d, bool), q, x_out,
                          covariance_out, np.empty((d, d)))
    return _overflow(x_out, covariance_out)


def unscented_predict_function(function, dt, covar, alpha, beta, kappa, x, covariance,
                               x_out, covariance_out, cross):
    status = _status(x, covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD, PRIOR_UNRESOLVED)
    if status != OK:
        return status
    d = x.shape[0]
    _, points, wm, wc = _sigma(x, covariance, alpha, beta, kappa)
    moved = function(np.ascontiguousarray(points), dt)
    status = output_status(moved, d, points.shape[1])
    if status == OK:
        full = np.empty((d, d))
        with np.errstate(over="ignore", invalid="ignore"):
            unscented_moments(points, moved, wm, wc, np.zeros(d, bool), covar, x_out,
                              covariance_out, full)
        cross[:] = full[:cross.shape[0]]
        status = _overflow(x_out, covariance_out)
    return status


def _overflow(x, covariance):
    """PREDICTION_OVERFLOW if a predicted mean or covariance is not finite, else OK."""
    return OK if np.isfinite(x).all() and np.isfinite(covariance).all() \
        else PREDICTION_OVERFLOW


def unscented_update(kind, mapping, offset, rotation, noise, angles, alpha, beta, kappa,
                     joseph, x, covariance, z, x_out, covariance_out, z_hat,
                     innovation_covar, cross):
    status = _status(x, covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD,
                     PREDICTION_UNRESOLVED)
    if status != OK:
        return status
    _, points, wm, wc = _sigma(x, covariance, alpha, beta, kappa)
    transformed = np.empty((z.shape[0], points.shape[1]))
    measure(kind, points, mapping, offset, rotation, transformed)
    status = _unscented_correct(points, transformed, wm, wc, noise, angles, joseph, x,
                                covariance, z, x_out, covariance_out, z_hat, innovation_covar,
                                cross)
    at_sensor = kind != SELECT and not (rotation[:2, :2]
                                        @ (x[mapping[:2], 0] - offset[:2])).any()
    return MEAN_AT_SENSOR if status == OK and at_sensor else status


def _unscented_correct(points, transformed, wm, wc, noise, angles, joseph, x, covariance, z,
                       x_out, covariance_out, z_hat, innovation_covar, cross):
    unscented_moments(points, transformed, wm, wc, angles, noise, z_hat, innovation_covar,
                      cross)
    if not _positive_definite(innovation_covar):
        return INNOVATION_NOT_PD
    if not np.all(np.isfinite(z)):
        return MEASUREMENT_NOT_FINITE
    gain = cross @ np.linalg.inv(innovation_covar)
    v = z - z_hat
    v[angles] = wrap_angle(v[angles])
    x_out[:] = x + gain @ v
    if joseph:
        h = np.linalg.solve(covariance, cross).T
        square = np.eye(x.shape[0]) - gain @ h
        covariance_out[:] = square @ covariance @ square.T + gain @ noise @ gain.T
        return OK
    return _standard_form(covariance - gain @ innovation_covar @ gain.T, covariance_out)


def unscented_update_function(function, noise, angles, alpha, beta, kappa, joseph, x,
                              covariance, z, x_out, covariance_out, z_hat, innovation_covar,
                              cross):
    status = _status(x, covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD,
                     PREDICTION_UNRESOLVED)
    if status != OK:
        return status
    _, points, wm, wc = _sigma(x, covariance, alpha, beta, kappa)
    transformed = function(np.ascontiguousarray(points))
    status = output_status(transformed, z.shape[0], points.shape[1])
    if status != OK:
        return status
    return _unscented_correct(points, transformed, wm, wc, noise, angles, joseph, x,
                              covariance, z, x_out, covariance_out, z_hat, innovation_covar,
                              cross)


PREDICT, MEASURE, UPDATE = 1, 2, 4


def batch_unscented(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
                    rotation, noise, angles, alpha, beta, kappa, joseph, stages, means,
                    covars, measurements, means_out, covars_out, z_hats, innovation_covars,
                    status):
    d, m = means.shape[1], noise.shape[0]
    for k in range(means.shape[0]):
        x, p = means[k].reshape(d, 1).copy(), covars[k].copy()
        status[k] = OK
        if stages & PREDICT:
            status[k] = unscented_predict(t_kind, rates, fixed_matrix, fixed_covar, dts[k],
                                          alpha, beta, kappa, means[k].reshape(d, 1),
                                          covars[k], x, p)
        outs = (np.empty((d, 1)), np.empty((d, d)), np.empty((m, 1)), np.empty((m, m)),
                np.empty((d, m)))
        if status[k] == OK and stages & (MEASURE | UPDATE):
            z = measurements[k].reshape(m, 1) if stages & UPDATE else np.zeros((m, 1))
            code = unscented_update(m_kind, mapping, offset, rotation, noise, angles, alpha,
                                    beta, kappa, joseph, x, p, z, *outs)
            if stages & MEASURE:
                z_hats[k], innovation_covars[k] = outs[2][:, 0], outs[3]
            if stages & UPDATE:
                status[k] = code
                x, p = outs[0], outs[1]
        means_out[k], covars_out[k] = x[:, 0], p
