"""Unscented Kalman steps of one Gaussian state (over :mod:`fasttrack._jit.unscented`)."""
import numbers

import numpy as np

from .. import _errors
from .._jit import unscented as _unscented
from ..models.measurement import NonlinearGaussianMeasurement


def check_parameters(alpha, beta, kappa):
    """``(alpha, beta, kappa)`` as floats (``kappa`` None stays None), or an error naming
    the argument: ``alpha`` must be a finite real > 0, ``beta`` and ``kappa`` finite reals."""
    values = []
    for name, value in (("alpha", alpha), ("beta", beta), ("kappa", kappa)):
        if value is None and name == "kappa":
            values.append(None)
            continue
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
        value = float(value)
        if not np.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
        values.append(value)
    if values[0] <= 0.0:
        raise ValueError(f"alpha must be > 0, got {values[0]}")
    return tuple(values)


def scaling(alpha, kappa, d):
    """``kappa`` for ``d`` state dimensions (None: ``3 - d``), checked so that the sigma
    points are defined: ``c = alpha^2 (d + kappa)`` must be > 0."""
    kappa = 3.0 - d if kappa is None else kappa
    if not alpha * alpha * (d + kappa) > 0.0:
        raise ValueError(f"kappa must make alpha**2 * (ndim + kappa) > 0 (the sigma-point "
                         f"spread), got kappa={kappa} with alpha={alpha} and ndim={d}")
    return kappa


def check_transition(model):
    """A TypeError unless ``model`` is a built-in linear transition or one built from a
    user's Numba function (the kinds the kernels know)."""
    if not (hasattr(model, "_kalman_spec") or hasattr(model, "transition_function")):
        raise TypeError(f"transition_model: the unscented Kalman filter supports the built-in "
                        f"transition models and NonlinearGaussianTransitionModel, got "
                        f"{type(model).__name__}")


def check_measurement(model):
    """A TypeError unless ``model`` is a built-in measurement model (LinearGaussian, a polar
    sensor, or a NonlinearGaussianMeasurement of a user's function)."""
    if not (isinstance(model, NonlinearGaussianMeasurement) or hasattr(model, "_kalman_args")):
        raise TypeError(f"the unscented Kalman filter supports the built-in measurement "
                        f"models (LinearGaussian, the polar sensors and "
                        f"NonlinearGaussianMeasurement), got {type(model).__name__}")


def _function_error(status, model, x, covar, alpha, beta, kappa, dt=None):
    """Raise the error of ``status``; one about the user's function names it, with the
    sigma points it was called on."""
    if status in _errors.FUNCTION_CODES:
        d, n = x.shape[0], 2 * x.shape[0] + 1
        points = np.empty((d, n))
        _unscented.sigma_points(x, covar, alpha, beta, kappa, np.empty((d, d)), points,
                                np.empty(n), np.empty(n))
        _errors.check(status, model._function, points, dt)
    _errors.check(status)


def predict(model, dt, x, covar, alpha, beta, kappa):
    """``(x, P)`` predicted ``dt`` seconds ahead by the unscented transform of ``model``
    (see :func:`check_transition`): the sigma points of ``(x, covar)`` through the
    transition (F, or the user's function), their weighted mean and covariance plus Q.
    ``kappa`` is resolved (a float, see :func:`scaling`). Raises ValueError if ``covar`` is
    not symmetric positive semi-definite or the user's function returns a wrong shape or
    non-finite values."""
    d = x.shape[0]
    if not hasattr(model, "_kalman_spec"):
        return _through_function(model, dt, x, covar, alpha, beta, kappa, np.empty((0, d)))
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    kind, rates, matrix, noise = model._kalman_spec(dt)
    status = _unscented.unscented_predict(kind, rates, matrix, noise, dt, alpha, beta, kappa,
                                          x, covar, x_out, covar_out)
    if status:
        _errors.check(status)
    return x_out, covar_out


def transition_moments(model, dt, x, covar, alpha, beta, kappa):
    """``(x, P, C)``: :func:`predict` through a function-built ``model``, with the cross
    covariance C (d, d) of the sigma points of ``(x, covar)`` and their transition."""
    d = x.shape[0]
    cross = np.empty((d, d))
    return _through_function(model, dt, x, covar, alpha, beta, kappa, cross) + (cross,)


def _through_function(model, dt, x, covar, alpha, beta, kappa, cross):
    d = x.shape[0]
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    status = _unscented.unscented_predict_function(
        model.transition_function, dt, np.ascontiguousarray(model.covar(dt)), alpha, beta,
        kappa, x, covar, x_out, covar_out, cross)
    if status:
        _function_error(status, model, x, covar, alpha, beta, kappa, dt)
    return x_out, covar_out


def update(model, x, covar, z, alpha, beta, kappa, joseph=False):
    """``(x, P, z_hat, S, cross)`` of one unscented update with measurement ``z`` (m, 1) by
    ``model`` (see :func:`check_measurement`); ``kappa`` is resolved (a float, see
    :func:`scaling`). Raises ValueError when the step is undefined (see
    :mod:`fasttrack._errors`)."""
    m, d = model._ndim_meas, model._ndim_state
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    z_hat, s, cross = np.empty((m, 1)), np.empty((m, m)), np.empty((d, m))
    outputs = (x, covar, z, x_out, covar_out, z_hat, s, cross)
    if isinstance(model, NonlinearGaussianMeasurement):
        status = _unscented.unscented_update_function(
            model.measurement_function, model._noise_covar, model._angles, alpha, beta, kappa,
            joseph, *outputs)
    else:
        status = _unscented.unscented_update(*model._kalman_args, alpha, beta, kappa, joseph,
                                             *outputs)
    if status:
        _function_error(status, model, x, covar, alpha, beta, kappa)
    return x_out, covar_out, z_hat, s, cross
