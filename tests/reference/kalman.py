"""Mirrors of ``fasttrack._jit.kalman``: Kalman prediction and update of one filter, of
batches of filters, and of batches of tracks (prediction with measurement, update)."""
import numpy as np

from .jacobian import (measurement_jacobian, measurement_jacobian_function,
                       transition_jacobian_function)
from .likelihood import measure
from .numeric import wrap_angle
from .status import (INNOVATION_NOT_PD, JACOBIAN_UNDEFINED, MEASUREMENT_NOT_FINITE, OK,
                     PREDICTION_NOT_PSD, PREDICTION_NOT_SYMMETRIC, PREDICTION_OVERFLOW,
                     PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC, UPDATE_NOT_PSD)
from .user import output_status


FIXED, CV = 0, 1


def _transition(kind, rates, fixed_matrix, fixed_covar, dt, d):
    if kind == FIXED:
        return fixed_matrix, fixed_covar
    blocks_f = [np.array([[1.0, dt], [0.0, 1.0]]) for _ in rates]
    t = abs(dt)
    blocks_q = [q * np.array([[t ** 3 / 3, t ** 2 / 2], [t ** 2 / 2, t]]) for q in rates]
    from scipy.linalg import block_diag
    return block_diag(*blocks_f), block_diag(*blocks_q)


def _positive_definite(a):
    try:
        np.linalg.cholesky(a)
        return True
    except np.linalg.LinAlgError:
        return False


def _positive_semi_definite(a, tolerance=1e-10):
    values = np.linalg.eigvalsh(a)
    return values.min() >= -tolerance * max(values.max(), 0.0)


def _covariance_status(a, asymmetric, indefinite):
    if np.abs(a - a.T).max() > 1e-9 * np.abs(a).max():
        return asymmetric
    return OK if _positive_semi_definite(a) else indefinite


def _standard_form(posterior, covariance_out):
    """The status of a standard-form update that wrote ``posterior`` into ``covariance_out``."""
    covariance_out[:] = posterior
    return _covariance_status((posterior + posterior.T) / 2, UPDATE_NOT_PSD, UPDATE_NOT_PSD)


def predict_one(kind, rates, fixed_matrix, fixed_covar, dt, x, covariance, x_out,
                covariance_out):
    f, q = _transition(kind, rates, fixed_matrix, fixed_covar, dt, x.shape[0])
    with np.errstate(over="ignore", invalid="ignore"):
        x_out[:] = f @ x
        covariance_out[:] = f @ covariance @ f.T + q
    status = _covariance_status(covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
    if status == OK and not (np.isfinite(x_out).all() and np.isfinite(covariance_out).all()):
        return PREDICTION_OVERFLOW
    return status


def predict_function(function, dt, covar, central, x, covariance, x_out, covariance_out):
    f = np.empty((x.shape[0], x.shape[0]))
    status = transition_jacobian_function(function, dt, x[:, 0], central, f)
    if status != OK:
        return status
    values = function(np.ascontiguousarray(x), dt)
    status = output_status(values, x.shape[0], 1)
    if status != OK:
        return status
    x_out[:] = values
    covariance_out[:] = f @ covariance @ f.T + covar
    return _covariance_status(covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)


def stack_predict_function(function, dt, covar, central, means, covariances, means_out,
                           covariances_out, status):
    for t in range(means.shape[0]):
        x_out = np.empty((means.shape[1], 1))
        status[t] = predict_function(function, dt, covar, central, means[t][:, None].copy(),
                                     covariances[t], x_out, covariances_out[t])
        means_out[t] = x_out[:, 0]


def stack_linearise_function(function, dt, central, points, jacobians, values, status):
    for k in range(points.shape[0]):
        status[k] = transition_jacobian_function(function, dt, points[k], central, jacobians[k])
        if status[k] == OK:
            value = function(np.ascontiguousarray(points[k][:, None]), dt)
            status[k] = output_status(value, points.shape[1], 1)
            values[k] = value[:, 0]


def _kalman_update(x, covariance, z, z_hat, h, noise, angles, joseph, x_out, covariance_out,
                   innovation_covar, cross):
    cross[:] = covariance @ h.T
    innovation_covar[:] = h @ cross + noise
    if not np.isfinite(z).all():
        return MEASUREMENT_NOT_FINITE
    if not _positive_definite(innovation_covar):
        return INNOVATION_NOT_PD
    gain = cross @ np.linalg.inv(innovation_covar)
    innovation = z - z_hat
    innovation[angles] = wrap_angle(innovation[angles])
    x_out[:] = x + gain @ innovation
    if joseph:
        a = np.eye(x.shape[0]) - gain @ h
        covariance_out[:] = a @ covariance @ a.T + gain @ noise @ gain.T
        return OK
    return _standard_form(covariance - gain @ innovation_covar @ gain.T, covariance_out)


def update_one(kind, mapping, offset, rotation, noise, angles, method, joseph, x, covariance,
               z, x_out, covariance_out, z_hat, innovation_covar, cross):
    m, d = noise.shape[0], x.shape[0]
    status = _covariance_status(covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    if status != OK:
        return status
    measure(kind, x, mapping, offset, rotation, z_hat)
    h = np.empty((m, d))
    measurement_jacobian(kind, x[:, 0], mapping, offset, rotation, angles, method, h)
    if not np.isfinite(h).all():
        return JACOBIAN_UNDEFINED
    return _kalman_update(x, covariance, z, z_hat, h, noise, angles, joseph, x_out,
                          covariance_out, innovation_covar, cross)


def update_function(function, noise, angles, central, joseph, x, covariance, z, x_out,
                    covariance_out, z_hat, innovation_covar, cross):
    values = function(np.ascontiguousarray(x))
    status = output_status(values, noise.shape[0], 1)
    if status != OK:
        return status
    h = np.empty((noise.shape[0], x.shape[0]))
    status = measurement_jacobian_function(function, x[:, 0], angles, central, h)
    if status != OK:
        return status
    status = _covariance_status(covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    if status != OK:
        return status
    z_hat[:] = values
    z_hat[angles] = wrap_angle(z_hat[angles])
    return _kalman_update(x, covariance, z, z_hat, h, noise, angles, joseph, x_out,
                          covariance_out, innovation_covar, cross)


def _filter_step(t_spec, dt, m_spec, method, joseph, x, covariance, z):
    d, m = x.size, z.size
    x_pred, covariance_pred = np.empty((d, 1)), np.empty((d, d))
    status = predict_one(*t_spec, dt, x[:, None], covariance, x_pred, covariance_pred)
    x_out, covariance_out = np.empty((d, 1)), np.empty((d, d))
    code = update_one(*m_spec, method, joseph, x_pred, covariance_pred, z[:, None], x_out,
                      covariance_out, np.empty((m, 1)), np.empty((m, m)), np.empty((d, m)))
    return status or code, x_out[:, 0], covariance_out


def batch_step(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
               rotation, noise, angles, method, joseph, means, covariances, measurements,
               means_out, covariances_out, status):
    t_spec = (t_kind, rates, fixed_matrix, fixed_covar)
    m_spec = (m_kind, mapping, offset, rotation, noise, angles)
    for k in range(means.shape[0]):
        status[k], means_out[k], covariances_out[k] = _filter_step(
            t_spec, dts[k], m_spec, method, joseph, means[k], covariances[k], measurements[k])


def batch_run(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset, rotation,
              noise, angles, method, joseph, mean0, covariance0, measurements, means_out,
              covariances_out, status):
    t_spec = (t_kind, rates, fixed_matrix, fixed_covar)
    m_spec = (m_kind, mapping, offset, rotation, noise, angles)
    steps = measurements.shape[0]
    for k in range(mean0.shape[0]):
        x, covariance = mean0[k], covariance0[k]
        status[k] = (steps, OK)
        for t in range(steps):
            code, x, covariance = _filter_step(t_spec, dts[t, k], m_spec, method, joseph, x,
                                               covariance, measurements[t, k])
            means_out[t, k], covariances_out[t, k] = x, covariance
            if code != OK and status[k][1] == OK:
                status[k] = (t, code)


# --- batches of tracks (prediction with measurement, update) -------------------------------


def linear_predict(matrix, covar, mapping, noise, means, covariances, means_out,
                   covariances_out, z_hats, innovation_covars, status):
    for k in range(means.shape[0]):
        status[k] = _covariance_status(covariances[k], PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
        with np.errstate(over="ignore", invalid="ignore"):
            means_out[k] = matrix @ means[k]
            covariances_out[k] = matrix @ covariances[k] @ matrix.T + covar
        if status[k] == OK and not (np.isfinite(means_out[k]).all()
                                    and np.isfinite(covariances_out[k]).all()):
            status[k] = PREDICTION_OVERFLOW
        z_hats[k] = means_out[k][mapping]
        innovation_covars[k] = covariances_out[k][np.ix_(mapping, mapping)] + noise


def linear_update(mapping, noise, angles, joseph, means, covariances, measurements, means_out,
                  covariances_out, status):
    d, m = means.shape[1], measurements.shape[1]
    h = np.zeros((m, d))
    h[np.arange(m), mapping] = 1.0
    for k in range(means.shape[0]):
        x_out = np.empty((d, 1))
        code = _kalman_update(means[k][:, None], covariances[k], measurements[k][:, None],
                              means[k][mapping][:, None], h, noise, angles, joseph, x_out,
                              covariances_out[k], np.empty((m, m)), np.empty((d, m)))
        prior = _covariance_status(covariances[k], PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
        status[k] = prior if prior != OK and code in (OK, UPDATE_NOT_PSD) else code
        means_out[k] = x_out[:, 0]


def batch_predict(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
                  rotation, noise, method, means, covariances, means_out, covariances_out,
                  z_hats, innovation_covars, status):
    d, m = means.shape[1], z_hats.shape[1]
    angles = np.zeros(m, dtype=bool)
    for k in range(means.shape[0]):
        x, p = np.empty((d, 1)), np.empty((d, d))
        status[k] = predict_one(t_kind, rates, fixed_matrix, fixed_covar, dts[k],
                                means[k][:, None], covariances[k], x, p)
        z_hat, h = np.empty((m, 1)), np.empty((m, d))
        measure(m_kind, x, mapping, offset, rotation, z_hat)
        measurement_jacobian(m_kind, x[:, 0], mapping, offset, rotation, angles, method, h)
        means_out[k], covariances_out[k] = x[:, 0], p
        z_hats[k], innovation_covars[k] = z_hat[:, 0], h @ p @ h.T + noise
