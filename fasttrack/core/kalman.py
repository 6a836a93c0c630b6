"""Kalman and extended Kalman steps of one Gaussian state."""
import numpy as np

from .. import _errors
from .._jit import jacobian as _jacobian
from .._jit import kalman as _kalman
from ..models.measurement import NonlinearGaussianMeasurement

#: Jacobian methods by name: the built-in sensors' analytic Jacobian, or finite differences
#: (forward: Stone Soup's rule).
JACOBIANS = {"analytic": _jacobian.ANALYTIC, "forward": _jacobian.FORWARD,
             "central": _jacobian.CENTRAL}


def check_jacobian(name, allowed=tuple(JACOBIANS)):
    """``name`` if it is one of ``allowed``, else a ValueError listing them."""
    if name not in allowed:
        raise ValueError(f"jacobian must be one of {', '.join(map(repr, allowed))}, got {name!r}")
    return name


def predict(model, dt, x, covar, jacobian="forward"):
    """``(x, P)`` predicted ``dt`` seconds ahead: ``F x``, ``F P F^T + Q`` for a linear
    ``model``; for a model built from a function, ``f(x)`` and the finite-difference
    Jacobian (``jacobian`` 'forward' or 'central') in place of F.

    ``x`` is (d, 1), ``covar`` (d, d); returns new arrays of those shapes. Raises ValueError
    if ``covar`` is not symmetric positive semi-definite, or the user's function returns a
    wrong shape or non-finite values.
    """
    d = x.shape[0]
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    if hasattr(model, "matrix"):
        kind, rates, matrix, noise = model._kalman_spec(dt)
        status = _kalman.predict_one(kind, rates, matrix, noise, dt, x, covar, x_out,
                                     covar_out)
    else:
        status = _kalman.predict_function(model.transition_function, dt,
                                          np.ascontiguousarray(model.covar(dt)),
                                          jacobian == "central", x, covar, x_out, covar_out)
    if status:
        _errors.check(status, model._function, x, dt)
    return x_out, covar_out


def update(model, x, covar, z, jacobian="analytic", joseph=True):
    """``(x, P, z_hat, S, cross)`` of one update with measurement ``z`` (m, 1): the
    posterior (d, 1) and (d, d), the predicted measurement (m, 1), its innovation covariance
    (m, m) and the cross covariance ``P H^T`` (d, m).

    ``jacobian`` names the linearisation of a nonlinear ``model`` (see :data:`JACOBIANS`;
    function-built models use finite differences, 'analytic' meaning 'forward'); ``joseph``
    selects the Joseph-form covariance. Raises ValueError when the step is undefined (see
    :mod:`fasttrack._errors`).
    """
    m, d = model._ndim_meas, model._ndim_state
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    z_hat, s, cross = np.empty((m, 1)), np.empty((m, m)), np.empty((d, m))
    arguments = (x, covar, z, x_out, covar_out, z_hat, s, cross)
    if isinstance(model, NonlinearGaussianMeasurement):
        status = _kalman.update_function(model.measurement_function, model._noise_covar,
                                         model._angles, jacobian == "central", joseph,
                                         *arguments)
    else:
        status = _kalman.update_one(*model._kalman_args, JACOBIANS[jacobian], joseph,
                                    *arguments)
    if status:
        _errors.check(status, model._function, x)
    return x_out, covar_out, z_hat, s, cross
