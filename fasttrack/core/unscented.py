"""Unscented Kalman steps of one Gaussian state (over :mod:`fasttrack._jit.unscented`)."""
import numpy as np

from .. import _errors, _jit, _validate
from . import kalman_numpy as _numpy
from . import stack as _stack
from .kalman import in_numpy
from .kinds import FUNCTION

_unscented = _jit.lazy("unscented")


#: The least sigma-point spread ``c = alpha^2 (ndim + kappa)``: the weights ``1 - ndim / c``
#: and ``1 / 2c`` lose about ``-log10(c)`` of float64's 16 digits to cancellation.
SMALLEST_SPREAD = 1e-12
#: The largest: the points ``x +- sqrt(c) L`` stay far inside float64's range.
LARGEST_SPREAD = 1e100


def check_parameters(alpha, beta, kappa):
    """``(alpha, beta, kappa)`` as floats (``kappa`` None stays None), or an error naming
    the argument: ``alpha`` must be a finite real > 0, ``beta`` and ``kappa`` finite reals."""
    values = []
    for name, value in (("alpha", alpha), ("beta", beta), ("kappa", kappa)):
        if value is None and name == "kappa":
            values.append(None)
            continue
        values.append(_validate.real(value, name))
    if values[0] <= 0.0:
        raise ValueError(f"alpha must be > 0, got {values[0]}")
    return tuple(values)


def scaling(alpha, kappa, d):
    """``kappa`` for ``d`` state dimensions (None: ``3 - d``), checked so that the sigma
    points are defined: ``c = alpha^2 (d + kappa)`` must be > 0."""
    kappa = 3.0 - d if kappa is None else kappa
    spread = alpha * alpha * (d + kappa)
    if not spread > 0.0:
        raise ValueError(f"kappa must make alpha**2 * (ndim + kappa) > 0 (the sigma-point "
                         f"spread), got kappa={kappa} with alpha={alpha} and ndim={d}")
    if not SMALLEST_SPREAD <= spread <= LARGEST_SPREAD:
        raise ValueError(f"alpha**2 * (ndim + kappa) must lie in [{SMALLEST_SPREAD:.0e}, "
                         f"{LARGEST_SPREAD:.0e}] (its inverse weighs the sigma points: "
                         f"beyond, their moments lose their digits or overflow), got "
                         f"{spread:.3g} with alpha={alpha}, kappa={kappa} and ndim={d}")
    return kappa


def check_transition(model):
    """A TypeError unless ``model`` is a built-in linear transition or one built from a
    user's Numba function (the kinds the kernels know)."""
    if not hasattr(model, "spec"):
        raise TypeError(f"transition_model: the unscented Kalman filter supports the built-in "
                        f"transition models and NonlinearGaussianTransitionModel, got "
                        f"{type(model).__name__}")


def check_measurement(model):
    """A TypeError unless ``model`` is a built-in measurement model (LinearGaussian, a polar
    sensor, or a NonlinearGaussianMeasurement of a user's function)."""
    try:
        model.spec
    except (AttributeError, NotImplementedError):
        raise TypeError(f"the unscented Kalman filter supports the built-in measurement "
                        f"models (LinearGaussian, the polar sensors and "
                        f"NonlinearGaussianMeasurement), got {type(model).__name__}") from None


def _function_error(status, function, x, covar, alpha, beta, kappa, dt=None):
    """Raise the error of ``status``; one about the user's function names it, with the
    sigma points it was called on."""
    if status in _errors.FUNCTION_CODES:
        d, n = x.shape[0], 2 * x.shape[0] + 1
        points = np.empty((d, n))
        _unscented.sigma_points(x, covar, alpha, beta, kappa, np.empty((d, d)), points,
                                np.empty(n), np.empty(n))
        _errors.check(status, function, points, dt)
    _errors.check(status)


def predict(model, dt, x, covar, alpha, beta, kappa):
    """``(x, P)`` predicted ``dt`` seconds ahead by the unscented transform of ``model``
    (see :func:`check_transition`): the sigma points of ``(x, covar)`` through the
    transition (F, or the user's function), their weighted mean and covariance plus Q.
    ``kappa`` is resolved (a float, see :func:`scaling`). Raises ValueError if ``covar`` is
    not symmetric positive semi-definite or the user's function returns a wrong shape or
    non-finite values."""
    d = x.shape[0]
    spec = model.spec(dt)
    if spec.kind == FUNCTION:
        return _through_function(spec, x, covar, alpha, beta, kappa, np.empty((0, d)))
    if in_numpy(spec.kind):
        status, x_out, covar_out = _numpy.unscented_predict(spec, alpha, beta, kappa, x, covar)
        if status:
            _errors.check(status)
        return x_out, covar_out
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    status = _unscented.unscented_predict(*spec.kalman(), dt, alpha, beta, kappa, x, covar,
                                          x_out, covar_out)
    if status:
        _errors.check(status)
    return x_out, covar_out


def transition_moments(model, dt, x, covar, alpha, beta, kappa):
    """``(x, P, C)``: :func:`predict` through a function-built ``model``, with the cross
    covariance C (d, d) of the sigma points of ``(x, covar)`` and their transition."""
    d = x.shape[0]
    cross = np.empty((d, d))
    return _through_function(model.spec(dt), x, covar, alpha, beta, kappa, cross) + (cross,)


def _through_function(spec, x, covar, alpha, beta, kappa, cross):
    d = x.shape[0]
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    status = _unscented.unscented_predict_function(
        spec.function.callee, spec.dt, spec.noise, alpha, beta, kappa, x, covar, x_out,
        covar_out, cross)
    if status:
        _function_error(status, spec.function, x, covar, alpha, beta, kappa, spec.dt)
    return x_out, covar_out


def update(model, x, covar, z, alpha, beta, kappa, joseph=False, strict=True):
    """``(x, P, z_hat, S, cross)`` of one unscented update with measurement ``z`` (m, 1) by
    ``model`` (see :func:`check_measurement`); ``kappa`` is resolved (a float, see
    :func:`scaling`). Raises ValueError when the step is undefined (see
    :mod:`fasttrack._errors`); unless ``strict``, not for a standard-form posterior that
    is not positive semi-definite or a mean at a polar sensor (Stone Soup's numbers)."""
    spec = model.spec
    if in_numpy(spec.kind):
        status, *out = _numpy.unscented_update(spec, alpha, beta, kappa, joseph, x, covar, z)
        if status and (strict or status not in _errors.LENIENT):
            _errors.check(status)
        return tuple(out)
    m, d = spec.ndim_meas, spec.ndim_state
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    z_hat, s, cross = np.empty((m, 1)), np.empty((m, m)), np.empty((d, m))
    outputs = (x, covar, z, x_out, covar_out, z_hat, s, cross)
    if spec.kind == FUNCTION:
        status = _unscented.unscented_update_function(
            spec.function.callee, spec.noise_covar, spec.angles, alpha, beta, kappa,
            joseph, *outputs)
    else:
        status = _unscented.unscented_update(*spec.sensor, alpha, beta, kappa, joseph,
                                             *outputs)
    if status and (strict or status not in _errors.LENIENT):
        _function_error(status, spec.function, x, covar, alpha, beta, kappa)
    return x_out, covar_out, z_hat, s, cross


# -- stacks of K filters: (K, d) means, (K, d, d) covariances ----------------------------


def _stack_stages(stages, transition, intervals, model, parameters, means, covars,
                  measurements, outputs, status):
    """:func:`fasttrack._jit.unscented.batch_unscented` over the K filters in chunks;
    ``parameters`` are ``(alpha, beta, kappa, joseph)``, ``outputs`` means, covars,
    z_hats, innovation_covars ((K, 0) arrays where a stage does not write them)."""
    settings = (*model.spec.sensor, *parameters, stages)

    def run(lo, hi):
        _unscented.batch_unscented(*transition, intervals[lo:hi], *settings, means[lo:hi],
                                   covars[lo:hi], measurements[lo:hi],
                                   *[a[lo:hi] for a in outputs], status[lo:hi])

    _stack.in_chunks(means.shape[0], run)


def stack_predict(transition_model, model, intervals, means, covars, parameters):
    """``(means, covars, z_hats, S)`` of K filters predicted ``intervals`` (K,) seconds
    ahead by the unscented transform (``parameters`` = ``(alpha, beta, kappa, joseph)``,
    kappa resolved), with their predicted measurements by ``model`` and innovation
    covariances. Raises ValueError naming the first failed filter."""
    k, d = means.shape
    m = model.spec.ndim_meas
    out = np.empty((k, d)), np.empty((k, d, d)), np.empty((k, m)), np.empty((k, m, m))
    status = np.zeros(k, dtype=np.int64)
    if k:
        _stack_stages(_unscented.PREDICT | _unscented.MEASURE,
                      _stack.transition(transition_model, intervals), intervals, model,
                      parameters, means, covars, np.empty((k, 0)), out, status)
        _stack.check(status)
    return out


def stack_update(model, means, covars, measurements, parameters):
    """``(means, covars)``: K predicted filters updated with their ``measurements`` (K, m)
    by ``model`` (see :func:`stack_predict`)."""
    k, d = means.shape
    means_out, covars_out = np.empty_like(means), np.empty_like(covars)
    status = np.zeros(k, dtype=np.int64)
    if k:
        _stack_stages(_unscented.UPDATE, _stack.identity(d), np.zeros(k), model, parameters,
                      means, covars, measurements,
                      (means_out, covars_out, np.empty((k, 0)), np.empty((k, 0, 0))), status)
        _stack.check(status)
    return means_out, covars_out


def stack_step(transition, intervals, means, covars, measurements, means_out, covars_out,
               status, *, model, parameters):
    """One unscented predict + update of K filters (see
    :func:`fasttrack.core.kalman.stack_step`)."""
    k = means.shape[0]
    _stack_stages(_unscented.PREDICT | _unscented.UPDATE, transition, intervals, model,
                  parameters, means, covars, measurements,
                  (means_out, covars_out, np.empty((k, 0)), np.empty((k, 0, 0))), status)
