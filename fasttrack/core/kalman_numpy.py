"""Kalman, extended and unscented Kalman steps in NumPy, for a program's first steps.

The first compiled kernel of a process costs Numba's set-up (its import, target and exit:
about 0.6 s), more than a short script's whole filtering. :mod:`kalman` and
:mod:`unscented` therefore run a process's first one-filter steps and small stacks on
built-in models here (see :func:`fasttrack._jit.numpy_first`), with the kernels' formulas,
tolerances and status codes (``fasttrack._jit.kalman`` and ``unscented``): results agree
with the kernels' to rounding, errors are the same.

``x`` is (d, 1), covariances (d, d), ``z`` (m, 1); functions return new arrays.
"""
import functools
import math

import numpy as np

from .._jit.status import (INNOVATION_NOT_PD, JACOBIAN_UNDEFINED, MEAN_AT_SENSOR,
                           MEASUREMENT_NOT_FINITE, OK, PREDICTION_NOT_PSD,
                           PREDICTION_NOT_SYMMETRIC, PREDICTION_OVERFLOW,
                           PREDICTION_UNRESOLVED, PRIOR_NOT_PSD,
                           PRIOR_NOT_SYMMETRIC, PRIOR_UNRESOLVED, UPDATE_NOT_PSD)
from .._jit.tunables import NEGLIGIBLE_VARIANCE, PSD_TOLERANCE, SIGMA_RESOLUTION
from .._validate import asymmetric as _asymmetric
from .kinds import ANALYTIC, BEARING_RANGE, CENTRAL, FORWARD, SELECT


def covariance_status(a, asymmetric, indefinite):
    """OK, ``asymmetric`` or ``indefinite`` for the (n, n) ``a``, decided as the kernels
    decide (see :func:`covariance_statuses`)."""
    if not np.all(np.abs(a - a.T) <= 1e-9 * np.abs(a).max()):
        return asymmetric
    try:  # every pivot well clear of the tolerance: the kernels' factorisation is LAPACK's
        tol = PSD_TOLERANCE * max(a.diagonal().max(), 0.0)
        if np.linalg.cholesky(a).diagonal().min() ** 2 > 2.0 * tol:
            return OK
    except np.linalg.LinAlgError:
        pass
    return covariance_statuses(a[None], asymmetric, indefinite)[0]


def covariance_statuses(stack, asymmetric, indefinite):
    """(K,) int64: OK, ``asymmetric`` or ``indefinite`` for each of the (K, n, n) ``stack``,
    decided as the kernels decide: symmetric to 1e-9 of its largest entry, then a Cholesky
    factorisation whose pivots within ``PSD_TOLERANCE * max(diag)`` of zero count as zero
    (their column must then vanish to ``sqrt(PSD_TOLERANCE) * max(diag)``)."""
    status = np.where(_asymmetric(stack), asymmetric, OK)
    if _all_positive_definite(stack):  # every pivot well clear: the kernels' factorisation
        return status
    n = stack.shape[1]
    top = np.maximum(stack.diagonal(axis1=1, axis2=2).max(axis=1, initial=0.0), 0.0)
    tol = PSD_TOLERANCE * top
    lower = np.zeros(stack.shape)
    bad = np.zeros(stack.shape[0], dtype=np.bool_)
    for j in range(n):
        s = stack[:, j, j] - np.einsum("kq,kq->k", lower[:, j, :j], lower[:, j, :j])
        bad |= ~(s >= -tol)
        pivot = np.where(s > tol, np.sqrt(np.abs(s)), 0.0)
        lower[:, j, j] = pivot
        t = stack[:, j + 1:, j] - np.einsum("kiq,kq->ki", lower[:, j + 1:, :j],
                                            lower[:, j, :j])
        clear = pivot > 0.0
        lower[:, j + 1:, j] = np.where(clear[:, None], t / np.where(clear, pivot, 1.0)[:, None],
                                       0.0)
        bad |= ~clear & ~np.all(np.abs(t) <= np.sqrt(PSD_TOLERANCE) * top[:, None], axis=1)
    return np.where((status == OK) & bad, indefinite, status)


def _all_positive_definite(covars):
    """Whether each of the (K, n, n) ``covars`` is one :func:`covariance_status` passes at
    once (symmetric, every Cholesky pivot well clear of its tolerance); False if any needs
    a closer look."""
    k, n = covars.shape[:2]
    if _asymmetric(covars).any():
        return False
    try:
        pivots = np.linalg.cholesky(covars).reshape(k, n * n)[:, ::n + 1]
    except np.linalg.LinAlgError:
        return False
    top = covars.reshape(k, n * n)[:, ::n + 1].max(axis=1)  # > 0 (a factor exists)
    return bool((pivots * pivots > (2.0 * PSD_TOLERANCE) * top[:, None]).all())


def _symmetric(a):
    """``a``'s lower triangle, mirrored (the kernels compute only that), of one matrix or
    of a stack of them."""
    return np.where(_upper(a.shape[-1]), np.swapaxes(a, -1, -2), a)


@functools.lru_cache(maxsize=None)
def _upper(n):
    """The (n, n) mask of the strict upper triangle."""
    return np.triu(np.ones((n, n), dtype=np.bool_), 1)


def wrap(a):
    """Angles wrapped to [-pi, pi), as the kernels wrap them."""
    return a - 6.283185307179586 * np.floor((a + 3.141592653589793) * 0.15915494309189535)


def _mod_bearing(a):
    """Stone Soup's bearing wrap ``((a + pi) mod 2 pi) - pi``."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def predict(spec, x, covar):
    """``(status, x, P)``: ``F x`` and ``F P F^T + Q`` through a linear transition
    ``spec`` (:class:`~fasttrack.models.spec.TransitionSpec`); the status says whether the
    prior covariance is symmetric positive semi-definite."""
    matrix = spec.matrix
    status = covariance_status(covar, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
    with np.errstate(over="ignore", invalid="ignore"):
        x_out, covar_out = matrix @ x, _symmetric(matrix @ covar @ matrix.T + spec.noise)
    if status == OK and not (np.isfinite(x_out).all() and np.isfinite(covar_out).all()):
        status = PREDICTION_OVERFLOW
    return status, x_out, covar_out


def _polar(sensor, points):
    """The sensor-frame positions (px, py) of the (d, n) ``points`` (IEEE arithmetic, as
    Stone Soup and the kernels compute them)."""
    dx = points[sensor.mapping[0]] - sensor.offset[0]
    dy = points[sensor.mapping[1]] - sensor.offset[1]
    rotation = sensor.rotation
    return rotation[0, 0] * dx + rotation[0, 1] * dy, rotation[1, 0] * dx + rotation[1, 1] * dy


def measure(sensor, points):
    """The (m, n) measurements of a built-in ``sensor`` at the (d, n) ``points``, bearings
    wrapped to [-pi, pi)."""
    if sensor.kind == SELECT:
        return points[sensor.mapping]
    px, py = _polar(sensor, points)
    bearing = wrap(np.arctan2(py, px))
    if sensor.kind == BEARING_RANGE:
        return np.stack([bearing, np.sqrt(px * px + py * py)])
    return bearing[None]


def at_sensor(sensor, x):
    """Whether the state ``x`` (d, 1) is at the polar ``sensor``'s position."""
    px, py = _polar(sensor, x)
    return float(px[0]) == 0.0 and float(py[0]) == 0.0


def jacobians(sensor, points):
    """The (n, m, d) analytic measurement Jacobians of a built-in ``sensor`` at the (d, n)
    ``points``; NaN where a bearing is taken at the sensor."""
    m, (d, n) = sensor.ndim_meas, points.shape
    out = np.zeros((n, m, d))
    if sensor.kind == SELECT:
        out[:, np.arange(m), sensor.mapping] = 1.0
        return out
    px, py = _polar(sensor, points)
    rho2 = px * px + py * py
    columns, rotation = sensor.mapping[:2], sensor.rotation
    with np.errstate(divide="ignore", invalid="ignore"):
        out[:, 0, columns] = (-py[:, None] * rotation[0] + px[:, None] * rotation[1]) \
            / rho2[:, None]
        if sensor.kind == BEARING_RANGE:
            out[:, 1, columns] = (px[:, None] * rotation[0] + py[:, None] * rotation[1]) \
                / np.sqrt(rho2)[:, None]
    out[rho2 == 0.0] = np.nan
    return out


def jacobian(sensor, method, x):
    """The (m, d) measurement Jacobian at ``x`` (d, 1) by ``method`` (ANALYTIC, FORWARD,
    CENTRAL: the kernels' rules and steps); NaN where a bearing is taken at the sensor
    (but for FORWARD, Stone Soup's rule)."""
    m, d = sensor.ndim_meas, x.shape[0]
    out = np.zeros((m, d))
    if sensor.kind == SELECT:
        out[np.arange(m), sensor.mapping] = 1.0
        return out
    px, py = (float(v[0]) for v in _polar(sensor, x))
    rho2 = px * px + py * py
    if rho2 == 0.0 and method != FORWARD:
        return np.full((m, d), np.nan)
    if method == ANALYTIC:
        return jacobians(sensor, x)[0]
    point = x[:, 0]
    eye = np.eye(d)
    if method == CENTRAL:
        steps = 6.0554544523933395e-06 * np.maximum(np.abs(point), 1.0)
        values = measure(sensor, np.hstack([x + eye * steps, x - eye * steps]))
        delta = values[:, :d] - values[:, d:]
        delta[0] = wrap(delta[0])
        return delta / (2.0 * steps)
    steps = 1e8 * np.spacing(point)
    steps = np.where(steps >= 1e-8, steps, 1e-8)
    px, py = _polar(sensor, np.hstack([x + eye * steps, x]))
    # libm's atan2, as the kernel's: these steps turn an ulp of difference into 1e-6
    values = [_mod_bearing(np.array([math.atan2(b, a) for a, b in zip(px, py)]))]
    if sensor.kind == BEARING_RANGE:
        values.append(np.sqrt(px ** 2 + py ** 2))
    values = np.stack(values)
    delta = values[:, :d] - values[:, d:]
    delta[0] = _mod_bearing(delta[0])
    return delta / steps


def update(sensor, method, joseph, x, covar, z):
    """``(status, x, P, z_hat, S, cross)`` of a Kalman update with ``z`` by a built-in
    ``sensor`` (:class:`~fasttrack.models.spec.MeasurementSpec`), linearised by ``method``
    (see :func:`jacobian`), with the Joseph-form covariance if ``joseph``: the statuses,
    in the kernels' order, of the prediction's covariance, the Jacobian, ``S`` and ``z``."""
    status = covariance_status(covar, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    z_hat = measure(sensor, x)
    h = jacobian(sensor, method, x)
    if status == OK and not np.all(np.isfinite(h)):
        status = JACOBIAN_UNDEFINED
    cross = covar @ h.T
    s = _symmetric(h @ cross + sensor.noise_covar)
    return _correct(status, sensor, joseph, x, covar, z, z_hat, h, s, cross)


def _transitions(transition_model, intervals):
    """Each filter's F and Q (K, d, d) over its interval of the (K,) ``intervals``, or the
    one (d, d) pair when the intervals are all equal."""
    values = sorted(set(intervals.tolist()))
    specs = [transition_model.spec(float(interval)) for interval in values]
    if len(specs) == 1:
        return specs[0].matrix, specs[0].noise
    which = np.searchsorted(np.array(values), intervals)
    return (np.array([spec.matrix for spec in specs])[which],
            np.array([spec.noise for spec in specs])[which])


def stack_predict(transition_model, sensor, method, intervals, means, covars):
    """``(status, means, covars, z_hats, S)``: K filters (means (K, d), covariances
    (K, d, d)) predicted ``intervals`` (K,) seconds ahead through a linear
    ``transition_model``, their measurements (K, m) by ``sensor`` and innovation
    covariances ``H P H^T + R`` (K, m, m), H linearised by ``method``; one status per
    filter (the prior's covariance, then the Jacobian)."""
    k, d = means.shape
    m = sensor.ndim_meas
    status = np.zeros(k, dtype=np.int64)
    if sensor.kind == SELECT and k > 1 and _all_positive_definite(covars):
        h = jacobian(sensor, method, means[0, :, None])
        f, q = _transitions(transition_model, intervals)
        with np.errstate(over="ignore", invalid="ignore"):
            x = (f @ means[:, :, None])[:, :, 0]
            covar = _symmetric(f @ covars @ np.swapaxes(f, -1, -2) + q)
        if not np.isfinite(covar.sum(axis=(1, 2)) + x.sum(axis=1)).all():
            status[~(np.isfinite(x).all(axis=1) & np.isfinite(covar).all(axis=(1, 2)))] = \
                PREDICTION_OVERFLOW
        return status, x, covar, x[:, sensor.mapping], _symmetric(
            h @ covar @ h.T + sensor.noise_covar)
    out = np.empty((k, d)), np.empty((k, d, d)), np.empty((k, m)), np.empty((k, m, m))
    for t in range(k):
        status[t], x, covar = predict(transition_model.spec(float(intervals[t])),
                                      means[t, :, None], covars[t])
        h = jacobian(sensor, method, x)
        if status[t] == OK and not np.all(np.isfinite(h)):
            status[t] = JACOBIAN_UNDEFINED
        for whole, value in zip(out, (x[:, 0], covar, measure(sensor, x)[:, 0],
                                      _symmetric(h @ covar @ h.T + sensor.noise_covar))):
            whole[t] = value
    return (status, *out)


def _correct(status, sensor, joseph, x, covar, z, z_hat, h, s, cross):
    """The gain step of an update given ``z_hat``, the innovation covariance ``s``, the
    cross covariance and the linearisation ``h`` (read by the Joseph form only): as
    :func:`update` returns it, ``S`` by Cholesky (INNOVATION_NOT_PD) and ``z`` checked
    (MEASUREMENT_NOT_FINITE) unless ``status`` is already set, a standard-form posterior
    that is not positive semi-definite UPDATE_NOT_PSD."""
    try:
        lower = np.linalg.cholesky(s)
    except np.linalg.LinAlgError:
        lower = None
    if status == OK and (lower is None or not np.all(np.isfinite(lower))):
        status = INNOVATION_NOT_PD
    if status == OK and not np.all(np.isfinite(z)):
        status = MEASUREMENT_NOT_FINITE
    if status != OK:  # the caller raises
        return status, x, covar, z_hat, s, cross
    whitened = np.linalg.solve(lower, cross.T)
    gain = np.linalg.solve(lower.T, whitened).T
    innovation = z - z_hat
    innovation[sensor.angles] = wrap(innovation[sensor.angles])
    x_out = x + gain @ innovation
    if joseph:
        square = np.eye(x.shape[0]) - gain @ h
        return (status, x_out, _symmetric(square @ covar @ square.T
                                          + gain @ sensor.noise_covar @ gain.T), z_hat, s, cross)
    covar_out = _symmetric(covar - whitened.T @ whitened)
    status = covariance_status(covar_out, UPDATE_NOT_PSD, UPDATE_NOT_PSD)
    return status, x_out, covar_out, z_hat, s, cross


# -- the unscented transform (``fasttrack._jit.unscented``) ----------------------------------


def _cholesky_eps(a):
    """The lower Cholesky factor of the symmetric ``a``, a pivot not above
    ``spacing(max diag a)`` replaced by its square root (Stone Soup's ``cholesky_eps``)."""
    d = a.shape[0]
    eps = np.spacing(a.diagonal().max())
    lower = np.zeros((d, d))
    for i in range(d):
        for j in range(i + 1):
            acc = a[i, j] - lower[i, :j] @ lower[j, :j]
            if j < i:
                lower[i, j] = acc / lower[j, j]
            else:
                lower[i, i] = np.sqrt(acc) if acc > eps else np.sqrt(eps)
    return lower


def _sigma(x, covar, alpha, beta, kappa):
    """Sigma points (d, 2d + 1) of ``(x, covar)``, the Cholesky factor used, and the mean
    and covariance weights (2d + 1,)."""
    d = x.shape[0]
    alpha2 = alpha * alpha
    lamda = alpha2 * (d + kappa) - d
    c = d + lamda
    mean_weights, covar_weights = np.full(2 * d + 1, 0.5 / c), np.full(2 * d + 1, 0.5 / c)
    mean_weights[0] = lamda / c
    covar_weights[0] = lamda / c + (1.0 - alpha2 + beta)
    lower = _cholesky_eps(covar)
    steps = lower * np.sqrt(c)
    return np.hstack([x, x + steps, x - steps]), lower, mean_weights, covar_weights


def _moments(sigma, transformed, angles, noise):
    """Mean (m, 1), covariance (m, m) plus ``noise`` and cross covariance (d, m) of the
    ``transformed`` sigma points (m, 2d + 1) of ``sigma`` (as :func:`_sigma` returns it);
    ``angles`` rows by circular mean and wrapped differences."""
    points, _, mean_weights, covar_weights = sigma
    total = mean_weights.sum()
    centre = transformed[:, 0]  # (the kernels' sum about the centre point)
    mean = centre + (transformed[:, 1:] - centre[:, None]) @ mean_weights[1:] / total
    if angles.any():
        turns = transformed[angles] * 0.15915494309189535
        radians = 2.0 * np.pi * (turns - np.floor(turns))
        mean[angles] = wrap(np.arctan2(np.sin(radians) @ mean_weights / total,
                                        np.cos(radians) @ mean_weights / total))
    diff = transformed - mean[:, None]
    diff[angles] = wrap(diff[angles])
    covar = _symmetric((diff * covar_weights) @ diff.T + noise)
    cross = ((points - points[:, :1]) * covar_weights) @ diff.T
    return mean[:, None], covar, cross


def _resolved(status, x, covar, unresolved):
    """``status``, or ``unresolved`` if it is OK and a component of the mean ``x`` (d, 1)
    exceeds ``SIGMA_RESOLUTION`` times its standard deviation, of a variance above
    ``NEGLIGIBLE_VARIANCE`` (the kernels' rule: its sigma points would round to it)."""
    variances = np.diagonal(covar)
    far = (variances > NEGLIGIBLE_VARIANCE) \
        & (np.abs(x[:, 0]) > SIGMA_RESOLUTION * np.sqrt(np.maximum(variances, 0.0)))
    return unresolved if status == OK and far.any() else status


def unscented_predict(spec, alpha, beta, kappa, x, covar):
    """``(status, x, P)``: the sigma points of ``(x, covar)`` moved by F of the linear
    transition ``spec``, their moments plus Q (PREDICTION_OVERFLOW if they are beyond
    float64's range)."""
    status = _resolved(covariance_status(covar, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD), x, covar,
                       PRIOR_UNRESOLVED)
    if status != OK:
        return status, x, covar
    sigma = _sigma(x, covar, alpha, beta, kappa)
    with np.errstate(over="ignore", invalid="ignore"):
        mean, covar_out, _ = _moments(sigma, spec.matrix @ sigma[0],
                                      np.zeros(x.shape[0], dtype=np.bool_), spec.noise)
    if not (np.isfinite(mean).all() and np.isfinite(covar_out).all()):
        status = PREDICTION_OVERFLOW
    return status, mean, covar_out


def unscented_update(sensor, alpha, beta, kappa, joseph, x, covar, z):
    """``(status, x, P, z_hat, S, cross)`` of an unscented update with ``z`` by a built-in
    ``sensor``: the moments of the prediction's sigma points measured, then the gain step of
    :func:`update` (the Joseph form with the statistical linearisation ``C^T P^-1``)."""
    status = _resolved(covariance_status(covar, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD),
                       x, covar, PREDICTION_UNRESOLVED)
    if status != OK:
        return status, x, covar, None, None, None
    z_hat, s, cross, lower = measurement_moments(sensor, alpha, beta, kappa, x, covar)
    h = np.linalg.solve(lower.T, np.linalg.solve(lower, cross)).T if joseph else None
    status, *out = _correct(status, sensor, joseph, x, covar, z, z_hat, h, s, cross)
    if status == OK and sensor.kind != SELECT and at_sensor(sensor, x):
        status = MEAN_AT_SENSOR  # the outputs are those of the bearing atan2(0, 0) = 0
    return (status, *out)


def measurement_moments(sensor, alpha, beta, kappa, x, covar):
    """``(z_hat, S, cross, lower)``: the mean (m, 1), covariance (m, m) plus R and cross
    covariance (d, m) of the sigma points of ``(x, covar)`` measured by a built-in
    ``sensor``, and the Cholesky factor (d, d) that spread them."""
    sigma = _sigma(x, covar, alpha, beta, kappa)
    return (*_moments(sigma, measure(sensor, sigma[0]), sensor.angles, sensor.noise_covar),
            sigma[1])
