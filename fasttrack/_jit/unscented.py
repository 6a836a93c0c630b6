"""Unscented Kalman kernels, on blocks of filters (Stone Soup's ``gauss2sigma``,
``unscented_transform`` and ``sigma2gauss``).

Sigma points of a mean x (d,) and covariance P: ``lambda = alpha^2 (d + kappa) - d``,
``c = d + lambda``, L the lower Cholesky factor of P (where a pivot is not above
``eps = spacing(max diag P)`` it is ``sqrt(eps)``, Stone Soup's ``cholesky_eps`` fallback),
points ``x``, ``x + sqrt(c) L[:, i]`` (i < d), ``x - sqrt(c) L[:, i]``; mean weights
``lambda / c``, ``1 / 2c``; covariance weights the same but ``lambda / c + 1 - alpha^2 + beta``
for the centre. The transformed points Y give the mean ``sum(Wm Y) / sum(Wm)`` (for an angle
row the circular mean ``atan2(sum(Wm sin Y), sum(Wm cos Y))``, as Stone Soup's ``Bearing``
rows average; other rows summed as ``Y_0 + sum(Wm (Y - Y_0)) / sum(Wm)``, so that the points
of a state known exactly give its image exactly), the covariance
``sum Wc (Y - y)(Y - y)^T + noise`` and the cross covariance
``sum Wc (X - X_0)(Y - y)^T``, with the angle rows of ``Y - y`` wrapped to [-pi, pi). The
update is the Kalman gain step of :mod:`kalman` with that cross covariance.

Layout as :mod:`kalman`: the filter index last, means (d, B), covariances (d, d, B), sigma
points (d, 2d + 1, B), so that the loops over a block's filters vectorise; one filter is a
block of one, passed as the literal ``nb = 1`` (the first argument of every block function,
as in :mod:`kalman`). Covariances are computed on the lower triangle and mirrored (exactly
symmetric).
"""
import numpy as np

from .dispatch import jit
from .kalman import FILTERS_PER_BLOCK, _correct, _from_block, _to_block, _transition
from .linalg import _check_covariance, _check_overflow, _solve
from .numeric import copy_into, fill, sin_cos_turns, wrap_angle
from .kinds import SELECT
from .sensor import _predict_block, _sensor_frame
from .status import (MEAN_AT_SENSOR, OK, PREDICTION_NOT_PSD, PREDICTION_NOT_SYMMETRIC,
                     PREDICTION_UNRESOLVED, PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC, PRIOR_UNRESOLVED)
from .tunables import NEGLIGIBLE_VARIANCE, SIGMA_RESOLUTION
from .user import output_status

#: Stages of :func:`batch_unscented` (a bit mask).
PREDICT, MEASURE, UPDATE = np.int64(1), np.int64(2), np.int64(4)


# --- blocks: the filter index last --------------------------------------------------------


@jit()
def _weights(d, alpha, beta, kappa):
    """The mean and covariance weights (2d + 1,) and the spread ``sqrt(c)``."""
    alpha2 = alpha * alpha
    lamda = alpha2 * (d + kappa) - d
    c = d + lamda
    mean_weights = np.full(2 * d + 1, 0.5 / c)
    covar_weights = np.full(2 * d + 1, 0.5 / c)
    mean_weights[0] = lamda / c
    covar_weights[0] = lamda / c + (1.0 - alpha2 + beta)
    return mean_weights, covar_weights, np.sqrt(c)


@jit()
def _cholesky_eps(nb, a, lower):
    """Lower Cholesky factors of the symmetric (d, d, B) ``a`` into ``lower``; a pivot not
    above ``spacing(max diag a)`` becomes its square root (Stone Soup's ``cholesky_eps``)."""
    d = a.shape[0]
    eps = np.empty(nb)
    for b in range(nb):
        top = a[0, 0, b]
        for i in range(d):
            top = max(top, a[i, i, b])
        eps[b] = np.spacing(top)
    fill(lower, 0.0)
    acc = np.empty(nb)
    for i in range(d):
        for j in range(i + 1):
            for b in range(nb):
                acc[b] = a[i, j, b]
            for k in range(j):
                for b in range(nb):
                    acc[b] -= lower[i, k, b] * lower[j, k, b]
            if j < i:
                for b in range(nb):
                    lower[i, j, b] = acc[b] / lower[j, j, b]
            else:
                for b in range(nb):
                    lower[i, i, b] = np.sqrt(acc[b]) if acc[b] > eps[b] else np.sqrt(eps[b])


@jit()
def _sigma(nb, x, covariance, alpha, beta, kappa):
    """Sigma points (d, 2d + 1, B) of the means ``x`` (d, B) and covariances (d, d, B), the
    Cholesky factors used (d, d, B) and the weights (see :func:`_weights`)."""
    d = x.shape[0]
    mean_weights, covar_weights, root = _weights(d, alpha, beta, kappa)
    lower = np.empty((d, d, nb))
    _cholesky_eps(nb, covariance, lower)
    points = np.empty((d, 2 * d + 1, nb))
    for r in range(d):
        for b in range(nb):
            points[r, 0, b] = x[r, b]
        for i in range(d):
            for b in range(nb):
                step = lower[r, i, b] * root
                points[r, 1 + i, b] = x[r, b] + step
                points[r, 1 + d + i, b] = x[r, b] - step
    return points, lower, mean_weights, covar_weights


@jit()
def _moments(nb, points, transformed, mean_weights, covar_weights, angles, noise, mean, covar,
             cross):
    """Mean (m, B), covariance (m, m, B) plus ``noise`` (m, m, B), and cross covariance
    (d, m, B) of the transformed sigma points (m, 2d + 1, B) of ``points``
    (d, 2d + 1, B); rows where ``angles`` (m,) is True are angles (circular mean, wrapped
    differences). ``cross`` with no rows: not computed."""
    n = points.shape[1]
    m = transformed.shape[0]
    total = 0.0
    for i in range(n):
        total += mean_weights[i]
    for r in range(m):
        if angles[r]:
            sines, cosines = np.zeros(nb), np.zeros(nb)
            for i in range(n):
                w = mean_weights[i]
                for b in range(nb):
                    turns = transformed[r, i, b] * 0.15915494309189535
                    s, c = sin_cos_turns(turns - np.floor(turns))
                    sines[b] += s * w
                    cosines[b] += c * w
            for b in range(nb):
                mean[r, b] = wrap_angle(np.arctan2(sines[b] / total, cosines[b] / total))
        else:  # about the centre point: an exact state's points give it exactly
            for b in range(nb):
                mean[r, b] = 0.0
            for i in range(1, n):
                w = mean_weights[i]
                for b in range(nb):
                    mean[r, b] += (transformed[r, i, b] - transformed[r, 0, b]) * w
            for b in range(nb):
                mean[r, b] = transformed[r, 0, b] + mean[r, b] / total
    diff = np.empty(transformed.shape)
    for r in range(m):
        for i in range(n):
            if angles[r]:
                for b in range(nb):
                    diff[r, i, b] = wrap_angle(transformed[r, i, b] - mean[r, b])
            else:
                for b in range(nb):
                    diff[r, i, b] = transformed[r, i, b] - mean[r, b]
    for r in range(m):
        for c in range(r + 1):
            for b in range(nb):
                covar[r, c, b] = noise[r, c, b]
            for i in range(n):
                w = covar_weights[i]
                for b in range(nb):
                    covar[r, c, b] += diff[r, i, b] * w * diff[c, i, b]
            for b in range(nb):
                covar[c, r, b] = covar[r, c, b]
    for r in range(cross.shape[0]):
        for c in range(m):
            for b in range(nb):
                cross[r, c, b] = 0.0
            for i in range(n):
                w = covar_weights[i]
                for b in range(nb):
                    cross[r, c, b] += (points[r, i, b] - points[r, 0, b]) * w * diff[c, i, b]


@jit()
def _no_cross(m, nb):
    return np.empty((0, m, nb))


@jit()
def _predict(nb, matrix, covar, alpha, beta, kappa, x, covariance, x_out, covariance_out):
    """The unscented prediction of checked priors through F (d, d, B), plus Q (d, d, B)."""
    d = x.shape[0]
    points, _, mean_weights, covar_weights = _sigma(nb, x, covariance, alpha, beta, kappa)
    moved = np.zeros(points.shape)
    for r in range(d):
        for i in range(points.shape[1]):
            for k in range(d):
                for b in range(nb):
                    moved[r, i, b] += matrix[r, k, b] * points[k, i, b]
    _moments(nb, points, moved, mean_weights, covar_weights, np.zeros(d, dtype=np.bool_), covar,
             x_out, covariance_out, _no_cross(d, nb))


@jit()
def _measure(nb, kind, mapping, offset, rotation, alpha, beta, kappa, x, covariance, m):
    """The sigma points of ``(x, covariance)`` (as :func:`_sigma`) and their predicted
    measurements (m, 2d + 1, B) by a built-in kind."""
    points, lower, mean_weights, covar_weights = _sigma(nb, x, covariance, alpha, beta, kappa)
    d, n = points.shape[0], points.shape[1]
    transformed = np.empty((m, n, nb))
    _predict_block(kind, points.reshape((d, n * nb)), np.int64(0), np.int64(n * nb), mapping,
                   offset, rotation, transformed.reshape((m, n * nb)), np.int64(0))
    return transformed, points, lower, mean_weights, covar_weights


@jit()
def _mean_at_sensor(nb, kind, mapping, offset, rotation, x, status):
    """``status[b]`` (if still OK) becomes MEAN_AT_SENSOR where the mean ``x[:, b]`` (of
    ``x`` (d, B)) lies at a polar sensor: the transform's central point has no bearing (the
    outputs are those of the bearing atan2(0, 0) = 0, as Stone Soup computes them)."""
    if kind == SELECT:
        return
    for b in range(nb):
        px, py = _sensor_frame(x[mapping[0], b], x[mapping[1], b], offset, rotation)
        if px == 0.0 and py == 0.0 and status[b] == OK:
            status[b] = MEAN_AT_SENSOR


@jit()
def _tiled(matrix, nb):
    """The (r, c) ``matrix`` repeated for B filters: (r, c, B)."""
    rows, cols = matrix.shape
    out = np.empty((rows, cols, nb))
    for r in range(rows):
        for c in range(cols):
            for b in range(nb):
                out[r, c, b] = matrix[r, c]
    return out


@jit()
def _linearisation(nb, lower, cross):
    """The statistical linearisation ``H = C^T P^-1`` (m, d, B) of cross covariances C
    (d, m, B), with ``P = L L^T`` the sigma points' factors: ``H^T = L^-T L^-1 C``."""
    d, m = cross.shape[0], cross.shape[1]
    h_t = np.empty((d, m, nb))
    _solve(nb, lower, cross, np.empty((d, m, nb)), h_t)
    h = np.empty((m, d, nb))
    for r in range(m):
        for c in range(d):
            for b in range(nb):
                h[r, c, b] = h_t[c, r, b]
    return h


@jit()
def _update(nb, measured, noise, angles, joseph, x, covariance, z, x_out, covariance_out,
            z_hat, innovation_covar, cross, status):
    """The update of the filters whose sigma points (of ``x``, ``covariance``) measure
    ``transformed``, with ``measured`` = ``(transformed, points, lower, mean_weights,
    covar_weights)`` (as :func:`_measure` returns it): the moments, then the Kalman gain step
    (:func:`kalman._correct`, the Joseph form with the statistical linearisation)."""
    transformed, points, lower, mean_weights, covar_weights = measured
    d = x.shape[0]
    m = z.shape[0]
    tiled = _tiled(noise, nb)
    _moments(nb, points, transformed, mean_weights, covar_weights, angles, tiled, z_hat,
             innovation_covar, cross)
    jacobian = _linearisation(nb, lower, cross) if joseph else np.empty((m, d, 0))
    _correct(nb, x, covariance, z, z_hat, jacobian, noise, angles, joseph, x_out, covariance_out,
             innovation_covar, cross, status)


# --- one filter: a state's (d, 1) column and its (d, d) covariance ------------------------


@jit()
def sigma_points(x, covariance, alpha, beta, kappa, lower, points, mean_weights,
                 covar_weights):
    """Sigma points (d, 2d + 1) of mean ``x`` (d, 1) and covariance (d, d) into ``points``,
    their weights (2d + 1,) into ``mean_weights`` and ``covar_weights``, and the Cholesky
    factor used into ``lower`` (d, d)."""
    d = x.shape[0]
    block, factor, wm, wc = _sigma(1, x, covariance.reshape((d, d, 1)), alpha, beta, kappa)
    copy_into(block, points)
    copy_into(factor, lower)
    copy_into(wm, mean_weights)
    copy_into(wc, covar_weights)


@jit()
def unscented_moments(points, transformed, mean_weights, covar_weights, angles, noise, mean,
                      covar, cross):
    """Mean (m, 1), covariance (m, m) (plus ``noise``) and cross covariance (d, m) of the
    transformed sigma points (m, 2d + 1) of ``points`` (d, 2d + 1); rows where ``angles``
    (m,) is True are angles (circular mean, wrapped differences)."""
    d, n = points.shape
    m = transformed.shape[0]
    _moments(1, points.reshape((d, n, 1)), transformed.reshape((m, n, 1)), mean_weights,
             covar_weights, angles, noise.reshape((m, m, 1)), mean,
             covar.reshape((m, m, 1)), cross.reshape((d, m, 1)))


@jit()
def _check_resolved(nb, x, covariance, status, unresolved):
    """``status[b]`` (if still OK) becomes ``unresolved`` where a component of the mean
    ``x[:, b]`` exceeds :data:`SIGMA_RESOLUTION` times its standard deviation (of a
    variance above :data:`NEGLIGIBLE_VARIANCE`): its sigma points would round to it."""
    d = x.shape[0]
    for b in range(nb):
        for r in range(d):
            v = covariance[r, r, b]
            if status[b] == OK and v > NEGLIGIBLE_VARIANCE \
                    and abs(x[r, b]) > SIGMA_RESOLUTION * np.sqrt(v):
                status[b] = unresolved


@jit()
def _checked(x, covariance, asymmetric, indefinite, unresolved):
    """The status (1,) of a mean (d, 1) and (d, d) covariance: OK if the covariance is
    symmetric positive semi-definite and the sigma points resolve the mean (see
    :func:`_check_resolved`), else ``asymmetric``, ``indefinite`` or ``unresolved``."""
    d = covariance.shape[0]
    status = np.zeros(1, dtype=np.int64)
    _check_covariance(1, covariance.reshape((d, d, 1)), status, asymmetric, indefinite)
    _check_resolved(1, x, covariance.reshape((d, d, 1)), status, unresolved)
    return status


@jit()
def unscented_predict(kind, rates, fixed_matrix, fixed_covar, dt, alpha, beta, kappa, x,
                      covariance, x_out, covariance_out):
    """One filter's unscented prediction through a FIXED or CV transition (see
    :mod:`kalman`): the prior's sigma points moved by F, their moments plus Q. Returns the
    status (PRIOR_NOT_SYMMETRIC / PRIOR_NOT_PSD for a bad prior covariance,
    PREDICTION_OVERFLOW for a prediction beyond float64's range)."""
    d = x.shape[0]
    status = _checked(x, covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD, PRIOR_UNRESOLVED)
    if status[0] == OK:
        matrix, covar = np.empty((d, d, 1)), np.empty((d, d, 1))
        _transition(1, kind, rates, fixed_matrix, fixed_covar, np.full(1, dt), matrix, covar)
        _predict(1, matrix, covar, alpha, beta, kappa, x, covariance.reshape((d, d, 1)), x_out,
                 covariance_out.reshape((d, d, 1)))
        _check_overflow(1, x_out, covariance_out.reshape((d, d, 1)), status)
    return status[0]


@jit()
def unscented_predict_function(function, dt, covar, alpha, beta, kappa, x, covariance,
                               x_out, covariance_out, cross):
    """One filter's unscented prediction through a user transition ``f((d, n), dt)``: the
    prior's sigma points through f (its output checked first, see :mod:`user`), their
    moments plus ``covar`` (Q), and their cross covariance with the prior's sigma points
    into ``cross`` (d, d; not computed if it has no rows). Returns the status
    (PREDICTION_OVERFLOW for moments beyond float64's range)."""
    d = x.shape[0]
    status = _checked(x, covariance, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD, PRIOR_UNRESOLVED)
    if status[0] != OK:
        return status[0]
    points, _, mean_weights, covar_weights = _sigma(1, x, covariance.reshape((d, d, 1)), alpha,
                                                    beta, kappa)
    n = points.shape[1]
    moved = function(points.reshape((d, n)), dt)
    status[0] = output_status(moved, d, n)
    if status[0] == OK:
        _moments(1, points, np.ascontiguousarray(moved).reshape((d, n, 1)), mean_weights,
                 covar_weights, np.zeros(d, dtype=np.bool_), covar.reshape((d, d, 1)), x_out,
                 covariance_out.reshape((d, d, 1)), cross.reshape((cross.shape[0], d, 1)))
        _check_overflow(1, x_out, covariance_out.reshape((d, d, 1)), status)
    return status[0]


@jit()
def unscented_update(kind, mapping, offset, rotation, noise, angles, alpha, beta, kappa,
                     joseph, x, covariance, z, x_out, covariance_out, z_hat,
                     innovation_covar, cross):
    """One filter's unscented update with a built-in measurement kind (see :mod:`sensor`).

    The predicted measurement ``z_hat``, innovation covariance S and cross covariance C come
    from the sigma points of the prediction; ``K = C S^-1`` (by Cholesky of S), innovation
    ``z - z_hat`` with angle rows wrapped, ``x_out = x + K v``, and ``P - K S K^T`` or with
    ``joseph`` ``(I - K H) P (I - K H)^T + K R K^T`` with the statistical linearisation
    ``H = C^T P^-1`` (exact for a linear sensor). Returns the status (MEAN_AT_SENSOR where
    the prediction's mean lies at a polar sensor)."""
    d, m = x.shape[0], z.shape[0]
    status = _checked(x, covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD,
                      PREDICTION_UNRESOLVED)
    if status[0] == OK:
        covariance = covariance.reshape((d, d, 1))
        measured = _measure(1, kind, mapping, offset, rotation, alpha, beta, kappa, x,
                            covariance, m)
        _update(1, measured, noise, angles, joseph, x, covariance, z, x_out,
                covariance_out.reshape((d, d, 1)), z_hat, innovation_covar.reshape((m, m, 1)),
                cross.reshape((d, m, 1)), status)
        _mean_at_sensor(1, kind, mapping, offset, rotation, x, status)
    return status[0]


@jit()
def unscented_update_function(function, noise, angles, alpha, beta, kappa, joseph, x,
                              covariance, z, x_out, covariance_out, z_hat, innovation_covar,
                              cross):
    """One filter's unscented update with a user measurement ``h((d, n)) -> (m, n)`` (its
    output checked first); otherwise as :func:`unscented_update`. Returns the status."""
    d, m = x.shape[0], z.shape[0]
    status = _checked(x, covariance, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD,
                      PREDICTION_UNRESOLVED)
    if status[0] != OK:
        return status[0]
    covariance = covariance.reshape((d, d, 1))
    points, lower, mean_weights, covar_weights = _sigma(1, x, covariance, alpha, beta, kappa)
    n = points.shape[1]
    transformed = function(points.reshape((d, n)))
    code = output_status(transformed, m, n)
    if code != OK:
        return code
    measured = (np.ascontiguousarray(transformed).reshape((m, n, 1)), points, lower,
                mean_weights, covar_weights)
    _update(1, measured, noise, angles, joseph, x, covariance, z, x_out,
            covariance_out.reshape((d, d, 1)), z_hat, innovation_covar.reshape((m, m, 1)),
            cross.reshape((d, m, 1)), status)
    return status[0]


# --- many filters: rows of (K, d) means and (K, d, d) covariances ------------------------


@jit()
def batch_unscented(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
                    rotation, noise, angles, alpha, beta, kappa, joseph, stages, means,
                    covars, measurements, means_out, covars_out, z_hats, innovation_covars,
                    status):
    """Unscented steps of K filters, rows of ``means`` (K, d) and ``covars`` (K, d, d),
    in blocks, each filter as the one-filter kernels do it, with its status into
    ``status`` (K,).

    ``stages`` (a mask of PREDICT, MEASURE, UPDATE): PREDICT by the transition (interval
    ``dts[k]`` seconds for filter k) into ``means_out``/``covars_out``; MEASURE the
    predicted measurement and innovation covariance of the prediction (or of the input
    with no PREDICT) into ``z_hats`` (K, m) and ``innovation_covars`` (K, m, m); UPDATE
    the prediction (or the input) by ``measurements`` (K, m) into ``means_out``/
    ``covars_out``. A filter whose status is not OK has unspecified outputs."""
    k, d = means.shape
    m = noise.shape[0]
    for lo in range(0, k, FILTERS_PER_BLOCK):
        hi = min(k, lo + FILTERS_PER_BLOCK)
        nb = hi - lo
        x, covariance = np.empty((d, nb)), np.empty((d, d, nb))
        _to_block(means, lo, hi, x)
        _to_block(covars, lo, hi, covariance)
        block_status = np.zeros(nb, dtype=np.int64)
        if stages & PREDICT:
            _check_covariance(nb, covariance, block_status, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
            _check_resolved(nb, x, covariance, block_status, PRIOR_UNRESOLVED)
            matrix, covar = np.empty((d, d, nb)), np.empty((d, d, nb))
            _transition(nb, t_kind, rates, fixed_matrix, fixed_covar, dts[lo:hi], matrix, covar)
            x_pred, covariance_pred = np.empty((d, nb)), np.empty((d, d, nb))
            _predict(nb, matrix, covar, alpha, beta, kappa, x, covariance, x_pred,
                     covariance_pred)
            _check_overflow(nb, x_pred, covariance_pred, block_status)
            x, covariance = x_pred, covariance_pred
        if stages & (MEASURE | UPDATE):
            _check_covariance(nb, covariance, block_status, PREDICTION_NOT_SYMMETRIC,
                              PREDICTION_NOT_PSD)
            _check_resolved(nb, x, covariance, block_status, PREDICTION_UNRESOLVED)
            measured = _measure(nb, m_kind, mapping, offset, rotation, alpha, beta, kappa, x,
                                covariance, m)
            z_hat, innovation_covar = np.empty((m, nb)), np.empty((m, m, nb))
            if stages & MEASURE:
                transformed, points, _, mean_weights, covar_weights = measured
                _moments(nb, points, transformed, mean_weights, covar_weights, angles,
                         _tiled(noise, nb), z_hat, innovation_covar, _no_cross(m, nb))
                _from_block(z_hat, lo, hi, z_hats)
                _from_block(innovation_covar, lo, hi, innovation_covars)
            if stages & UPDATE:
                z = np.empty((m, nb))
                _to_block(measurements, lo, hi, z)
                x_post, covariance_post = np.empty((d, nb)), np.empty((d, d, nb))
                _update(nb, measured, noise, angles, joseph, x, covariance, z, x_post,
                        covariance_post, z_hat, innovation_covar, np.empty((d, m, nb)),
                        block_status)
                _mean_at_sensor(nb, m_kind, mapping, offset, rotation, x, block_status)
                x, covariance = x_post, covariance_post
        _from_block(x, lo, hi, means_out)
        _from_block(covariance, lo, hi, covars_out)
        for b in range(nb):
            status[lo + b] = block_status[b]
