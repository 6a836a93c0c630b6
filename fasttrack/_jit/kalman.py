"""Kalman and extended Kalman kernels, on blocks of filters.

Filters are laid out component-major, the filter index last: means (d, B), covariances
(d, d, B), measurements (m, B), so every loop below runs innermost over the B filters of a
block and vectorises. One filter (B = 1) is a state's own (d, 1) column; a batch of K filters
goes in blocks of FILTERS_PER_BLOCK, in parallel.

Every block function takes the block's filter count ``nb`` first. The one-filter kernels pass
the constant 1, which Numba compiles as a literal, so their loops over the block fold away
(about 40% of a one-filter step) while the batches compile the same code for any ``nb``.

A transition is FIXED (F, Q given) or CV (nearly constant velocity blocks (position,
velocity) with rates q: ``F = [[1, dt], [0, 1]]``, ``Q = q [[t^3/3, t^2/2], [t^2/2, t]]``,
t = |dt|, per block), with an interval per filter. Measurements are the built-in kinds of
:mod:`likelihood`; for other models the caller provides the predicted measurement and its
Jacobian. Covariances are computed on the lower triangle and mirrored, so they are exactly
symmetric. Each filter gets a status (:mod:`status`): OK, or why its step is undefined.

Priors and predictions need only be positive semi-definite (a singular covariance is
legal); the innovation covariance must be positive definite. The covariance update is
either the standard form ``P - K S K^T`` or the Joseph form
``(I - K H) P (I - K H)^T + K R K^T``, a sum of two positive semi-definite terms, which
stays symmetric positive semi-definite when the standard form loses it to cancellation
(e.g. P = 1e12 I, R = 1e-12 I).
"""
import numpy as np

from .dispatch import jit
from .kinds import CV, FIXED
from .jacobian import (ANALYTIC, measurement_jacobian, measurement_jacobian_function,
                       transition_jacobian_function)
from .sensor import SELECT, _polar_jacobian, _predict_block, _sensor_frame
from .linalg import (_check_covariance, _check_overflow, _cholesky, _covariance_code, _sandwich,
                     _solve)
from .numeric import copy_into, fill, wrap_angle
from .status import (INNOVATION_NOT_PD, JACOBIAN_UNDEFINED, MEASUREMENT_NOT_FINITE, OK,
                     PREDICTION_NOT_PSD, PREDICTION_NOT_SYMMETRIC, PRIOR_NOT_PSD,
                     PRIOR_NOT_SYMMETRIC, UPDATE_NOT_PSD)
from .user import output_status
from .tunables import FILTERS_PER_BLOCK


@jit()
def _transition(nb, kind, rates, fixed_matrix, fixed_covar, dts, matrix, covar):
    """F and Q (d, d, B) of a FIXED or CV transition for the intervals ``dts`` (B,)."""
    d = matrix.shape[0]
    for r in range(d):
        for c in range(d):
            for b in range(nb):
                if kind == FIXED:
                    matrix[r, c, b] = fixed_matrix[r, c]
                    covar[r, c, b] = fixed_covar[r, c]
                else:
                    matrix[r, c, b] = 1.0 if r == c else 0.0
                    covar[r, c, b] = 0.0
    if kind == FIXED:
        return
    for block in range(rates.size):
        i, q = 2 * block, rates[block]
        for b in range(nb):
            t = abs(dts[b])
            matrix[i, i + 1, b] = dts[b]
            covar[i, i, b] = q * t ** 3 / 3.0
            covar[i, i + 1, b] = q * t ** 2 / 2.0
            covar[i + 1, i, b] = q * t ** 2 / 2.0
            covar[i + 1, i + 1, b] = q * t


@jit()
def _predict_covariance(nb, matrix, covar, covariance, covariance_out, status):
    """``P_out = F P F^T + Q`` per filter; the prior covariance must be positive
    semi-definite (else PRIOR_NOT_PSD)."""
    _check_covariance(nb, covariance, status, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
    copy_into(covar, covariance_out)
    _sandwich(nb, matrix, covariance, np.empty(covariance.shape), covariance_out)


@jit()
def _predict(nb, matrix, covar, x, covariance, x_out, covariance_out, status):
    """``x_out = F x`` and :func:`_predict_covariance` per filter."""
    d = x.shape[0]
    for r in range(d):
        for b in range(nb):
            s = 0.0
            for k in range(d):
                s += matrix[r, k, b] * x[k, b]
            x_out[r, b] = s
    _predict_covariance(nb, matrix, covar, covariance, covariance_out, status)
    _check_overflow(nb, x_out, covariance_out, status)


@jit()
def _measure(nb, kind, mapping, offset, rotation, method, x, z_hat, jacobian, status):
    """Predicted measurements ``z_hat`` (m, B) of a built-in kind and their Jacobians
    (m, d, B); JACOBIAN_UNDEFINED where a bearing is taken at the sensor."""
    d = x.shape[0]
    m = z_hat.shape[0]
    if kind == SELECT or method == ANALYTIC:
        fill(jacobian, 0.0)
        if kind == SELECT:
            for r in range(m):
                for b in range(nb):
                    z_hat[r, b] = x[mapping[r], b]
                    jacobian[r, mapping[r], b] = 1.0
            return
        _predict_block(kind, x, np.int64(0), np.int64(nb), mapping, offset, rotation, z_hat,
                       np.int64(0))
        for b in range(nb):
            px, py = _sensor_frame(x[mapping[0], b], x[mapping[1], b], offset, rotation)
            defined = _polar_jacobian(kind, px, py, rotation, mapping, jacobian[:, :, b])
            if not defined and status[b] == OK:
                status[b] = JACOBIAN_UNDEFINED
        return
    column = np.empty((d, 1))
    values = np.empty((m, 1))
    one = np.empty((m, d))
    angles = np.zeros(m, dtype=np.bool_)
    angles[0] = True
    point = np.empty(d)
    for b in range(nb):
        for r in range(d):
            column[r, 0] = x[r, b]
            point[r] = x[r, b]
        _predict_block(kind, column, np.int64(0), np.int64(1), mapping, offset, rotation,
                       values, np.int64(0))
        measurement_jacobian(kind, point, mapping, offset, rotation, angles, method, one)
        finite = True
        for r in range(m):
            z_hat[r, b] = values[r, 0]
            for c in range(d):
                jacobian[r, c, b] = one[r, c]
                finite &= np.isfinite(one[r, c])
        if not finite and status[b] == OK:
            status[b] = JACOBIAN_UNDEFINED


@jit()
def _innovation_covar(nb, covariance, jacobian, noise, cross, innovation_covar):
    """``cross = P H^T`` (d, m, B) and ``S = H P H^T + R`` (m, m, B) per filter."""
    d, m = cross.shape[0], cross.shape[1]
    for r in range(d):
        for c in range(m):
            for b in range(nb):
                s = 0.0
                for k in range(d):
                    s += covariance[r, k, b] * jacobian[c, k, b]
                cross[r, c, b] = s
    for r in range(m):
        for c in range(r + 1):
            for b in range(nb):
                s = noise[r, c]
                for k in range(d):
                    s += jacobian[r, k, b] * cross[k, c, b]
                innovation_covar[r, c, b] = s
                innovation_covar[c, r, b] = s


@jit()
def _update(nb, x, covariance, z, z_hat, jacobian, noise, angles, joseph, x_out, covariance_out,
           innovation_covar, cross, status):
    """The Kalman update of each filter given its predicted measurement and Jacobian H.

    ``cross = P H^T``, ``S = H P H^T + R``, ``K = cross S^-1`` (by Cholesky), innovation
    ``z - z_hat`` with angle rows wrapped, ``x_out = x + K v`` and ``P_out = P - K S K^T``
    (``K S K^T = W^T W`` with ``W = L^-1 cross^T``), or with ``joseph``
    ``(I - K H) P (I - K H)^T + K R K^T``. Filters whose S is not positive definite get
    INNOVATION_NOT_PD, non-finite measurements MEASUREMENT_NOT_FINITE, a standard-form
    ``P_out`` that is not positive semi-definite UPDATE_NOT_PSD.
    """
    _innovation_covar(nb, covariance, jacobian, noise, cross, innovation_covar)
    _correct(nb, x, covariance, z, z_hat, jacobian, noise, angles, joseph, x_out, covariance_out,
             innovation_covar, cross, status)


@jit()
def _correct(nb, x, covariance, z, z_hat, jacobian, noise, angles, joseph, x_out, covariance_out,
             innovation_covar, cross, status):
    """The gain step of :func:`_update` given each filter's ``cross`` (d, m, B) and
    ``innovation_covar`` (m, m, B) (the Jacobian is read only by the Joseph form)."""
    d = x.shape[0]
    m = z.shape[0]
    lower = np.empty((m, m, nb))
    _cholesky(nb, innovation_covar, lower, status, INNOVATION_NOT_PD)
    cross_t = np.empty((m, d, nb))
    for r in range(m):
        for c in range(d):
            for b in range(nb):
                cross_t[r, c, b] = cross[c, r, b]
    whitened = np.empty((m, d, nb))  # L^-1 cross^T
    gain_t = np.empty((m, d, nb))  # S^-1 cross^T = K^T
    _solve(nb, lower, cross_t, whitened, gain_t)
    innovation = np.empty((m, nb))
    for r in range(m):
        for b in range(nb):
            if not np.isfinite(z[r, b]) and status[b] == OK:
                status[b] = MEASUREMENT_NOT_FINITE
            v = z[r, b] - z_hat[r, b]
            innovation[r, b] = wrap_angle(v) if angles[r] else v
    for r in range(d):
        for b in range(nb):
            s = x[r, b]
            for k in range(m):
                s += gain_t[k, r, b] * innovation[k, b]
            x_out[r, b] = s
    if not joseph:
        for r in range(d):
            for c in range(r + 1):
                for b in range(nb):
                    s = covariance[r, c, b]
                    for k in range(m):
                        s -= whitened[k, r, b] * whitened[k, c, b]
                    covariance_out[r, c, b] = s
                    covariance_out[c, r, b] = s
        _check_covariance(nb, covariance_out, status, UPDATE_NOT_PSD, UPDATE_NOT_PSD)
        return
    square = np.empty((d, d, nb))  # I - K H
    for r in range(d):
        for c in range(d):
            for b in range(nb):
                s = 1.0 if r == c else 0.0
                for k in range(m):
                    s -= gain_t[k, r, b] * jacobian[k, c, b]
                square[r, c, b] = s
    fill(covariance_out, 0.0)
    _sandwich(nb, square, covariance, np.empty((d, d, nb)), covariance_out)
    gain = np.empty((d, m, nb))
    noises = np.empty((m, m, nb))
    for r in range(d):
        for c in range(m):
            for b in range(nb):
                gain[r, c, b] = gain_t[c, r, b]
    for r in range(m):
        for c in range(m):
            for b in range(nb):
                noises[r, c, b] = noise[r, c]
    _sandwich(nb, gain, noises, np.empty((d, m, nb)), covariance_out)


@jit()
def _step_block(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
                rotation, noise, angles, method, joseph, x, covariance, z, x_out,
                covariance_out, status):
    """Predict and update one block of filters (all in the block layout)."""
    d, nb = x.shape
    m = z.shape[0]
    matrix, covar = np.empty((d, d, nb)), np.empty((d, d, nb))
    _transition(nb, t_kind, rates, fixed_matrix, fixed_covar, dts, matrix, covar)
    x_pred, covariance_pred = np.empty((d, nb)), np.empty((d, d, nb))
    _predict(nb, matrix, covar, x, covariance, x_pred, covariance_pred, status)
    z_hat, jacobian = np.empty((m, nb)), np.empty((m, d, nb))
    _measure(nb, m_kind, mapping, offset, rotation, method, x_pred, z_hat, jacobian, status)
    _update(nb, x_pred, covariance_pred, z, z_hat, jacobian, noise, angles, joseph, x_out,
           covariance_out, np.empty((m, m, nb)), np.empty((d, m, nb)), status)


@jit()
def _to_block(rows, lo, hi, out):
    """``out[..., b] = rows[lo + b]`` for (K, ...) rows, out (..., hi - lo) as (n, hi - lo)."""
    flat = out.reshape((-1, out.shape[-1]))
    for b in range(hi - lo):
        row = rows[lo + b].ravel()
        for i in range(row.size):
            flat[i, b] = row[i]


@jit()
def _from_block(block, lo, hi, rows):
    flat = block.reshape((-1, block.shape[-1]))
    for b in range(hi - lo):
        row = rows[lo + b].reshape(-1)
        for i in range(row.size):
            row[i] = flat[i, b]


@jit()
def batch_step(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
               rotation, noise, angles, method, joseph, means, covariances, measurements,
               means_out, covariances_out, status):
    """Predict and update K independent filters (means (K, d), covariances (K, d, d),
    measurements (K, m), intervals dts (K,)) in blocks; ``status[k]`` says how each went.

    One thread: the loops over a block's filters vectorise, 10^4 filters take about 2 ms a
    step, and a parallel version compiled for 18 s more (its block body is optimised again
    inside Numba's parallel region)."""
    k_filters, d = means.shape
    m = measurements.shape[1]
    for block in range((k_filters + FILTERS_PER_BLOCK - 1) // FILTERS_PER_BLOCK):
        lo = block * FILTERS_PER_BLOCK
        hi = min(lo + FILTERS_PER_BLOCK, k_filters)
        nb = hi - lo
        x, covariance, z = np.empty((d, nb)), np.empty((d, d, nb)), np.empty((m, nb))
        _to_block(means, lo, hi, x)
        _to_block(covariances, lo, hi, covariance)
        _to_block(measurements, lo, hi, z)
        block_status = np.zeros(nb, dtype=np.int64)
        x_out, covariance_out = np.empty((d, nb)), np.empty((d, d, nb))
        _step_block(t_kind, rates, fixed_matrix, fixed_covar, dts[lo:hi], m_kind, mapping,
                    offset, rotation, noise, angles, method, joseph, x, covariance, z, x_out,
                    covariance_out, block_status)
        _from_block(x_out, lo, hi, means_out)
        _from_block(covariance_out, lo, hi, covariances_out)
        for b in range(nb):
            status[lo + b] = block_status[b]


@jit()
def batch_predict(t_kind, rates, fixed_matrix, fixed_covar, dts, m_kind, mapping, offset,
                  rotation, noise, method, means, covariances, means_out, covariances_out,
                  z_hats, innovation_covars, status):
    """Predict K filters (as :func:`batch_step`) and their measurements: the predicted means
    (K, d) and covariances (K, d, d), measurements ``z_hats`` (K, m) and innovation
    covariances ``S = H P H^T + R`` (K, m, m), for gating and association."""
    k_filters, d = means.shape
    m = z_hats.shape[1]
    for lo in range(0, k_filters, FILTERS_PER_BLOCK):
        hi = min(lo + FILTERS_PER_BLOCK, k_filters)
        nb = hi - lo
        x, covariance = np.empty((d, nb)), np.empty((d, d, nb))
        _to_block(means, lo, hi, x)
        _to_block(covariances, lo, hi, covariance)
        block_status = np.zeros(nb, dtype=np.int64)
        matrix, covar = np.empty((d, d, nb)), np.empty((d, d, nb))
        _transition(nb, t_kind, rates, fixed_matrix, fixed_covar, dts[lo:hi], matrix, covar)
        x_pred, covariance_pred = np.empty((d, nb)), np.empty((d, d, nb))
        _predict(nb, matrix, covar, x, covariance, x_pred, covariance_pred, block_status)
        z_hat, jacobian = np.empty((m, nb)), np.empty((m, d, nb))
        _measure(nb, m_kind, mapping, offset, rotation, method, x_pred, z_hat, jacobian,
                 block_status)
        innovation_covar = np.empty((m, m, nb))
        _innovation_covar(nb, covariance_pred, jacobian, noise, np.empty((d, m, nb)),
                          innovation_covar)
        _from_block(x_pred, lo, hi, means_out)
        _from_block(covariance_pred, lo, hi, covariances_out)
        _from_block(z_hat, lo, hi, z_hats)
        _from_block(innovation_covar, lo, hi, innovation_covars)
        for b in range(nb):
            status[lo + b] = block_status[b]


# --- tracks of a linear-Gaussian model, one row each: lean kernels that compile fast ------


@jit()
def linear_predict(matrix, covar, mapping, noise, means, covariances, means_out,
                   covariances_out, z_hats, innovation_covars, status):
    """Kalman prediction of K tracks (means (K, d), covariances (K, d, d)) through one F
    and Q (d, d), and their measurements by a sensor of the ``mapping`` rows with noise R:
    ``z_hats`` (K, m) and ``S = P[mapping, mapping] + R`` (K, m, m). ``status[k]`` says
    whether track k's covariance is symmetric positive semi-definite and its prediction
    finite."""
    k_tracks, d = means.shape
    m = mapping.size
    product = np.empty((d, d))
    for t in range(k_tracks):
        status[t] = OK
        _check_covariance(1, covariances[t].reshape((d, d, 1)), status[t:t + 1],
                          PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
        for r in range(d):
            s = 0.0
            for c in range(d):
                s += matrix[r, c] * means[t, c]
            means_out[t, r] = s
            for c in range(d):
                s = 0.0
                for q in range(d):
                    s += matrix[r, q] * covariances[t, q, c]
                product[r, c] = s
        for r in range(d):
            for c in range(r + 1):
                s = covar[r, c]
                for q in range(d):
                    s += product[r, q] * matrix[c, q]
                covariances_out[t, r, c] = s
                covariances_out[t, c, r] = s
        _check_overflow(1, means_out[t].reshape((d, 1)), covariances_out[t].reshape((d, d, 1)),
                        status[t:t + 1])
        for i in range(m):
            z_hats[t, i] = means_out[t, mapping[i]]
            for j in range(m):
                innovation_covars[t, i, j] = (covariances_out[t, mapping[i], mapping[j]]
                                              + noise[i, j])


@jit()
def linear_update(mapping, noise, angles, joseph, means, covariances, measurements, means_out,
                  covariances_out, status):
    """Kalman update of K predicted tracks with measurements (K, m) of their ``mapping``
    rows: ``S = P[mapping, mapping] + R`` by Cholesky, gain ``K = P[:, mapping] S^-1``,
    innovation with angle rows wrapped, and ``(I - K H) P`` or with ``joseph``
    ``(I - K H) P (I - K H)^T + K R K^T`` (lower triangles, mirrored). ``status[k]`` =
    PREDICTION_NOT_SYMMETRIC / PREDICTION_NOT_PSD for a bad P, INNOVATION_NOT_PD where S is
    not positive definite, MEASUREMENT_NOT_FINITE for a non-finite measurement,
    UPDATE_NOT_PSD where ``(I - K H) P`` is not positive semi-definite (else OK)."""
    k_tracks, d = means.shape
    m = mapping.size
    lower = np.empty((m, m))
    gain = np.empty((d, m))
    square = np.empty((d, d))
    work = np.empty((d, d))
    scratch = np.empty((d, d))
    for t in range(k_tracks):
        status[t] = _covariance_code(covariances[t], scratch, PREDICTION_NOT_SYMMETRIC,
                                     PREDICTION_NOT_PSD)
        for j in range(m):
            if not np.isfinite(measurements[t, j]):
                status[t] = MEASUREMENT_NOT_FINITE
        for j in range(m):
            s = covariances[t, mapping[j], mapping[j]] + noise[j, j]
            for q in range(j):
                s -= lower[j, q] * lower[j, q]
            if not s > 0.0:
                status[t] = INNOVATION_NOT_PD
                s = 1.0
            lower[j, j] = np.sqrt(s)
            for i in range(j + 1, m):
                s = covariances[t, mapping[i], mapping[j]] + noise[i, j]
                for q in range(j):
                    s -= lower[i, q] * lower[j, q]
                lower[i, j] = s / lower[j, j]
        for r in range(d):  # gain row r: solve L L^T g = P[r, mapping]
            for j in range(m):
                s = covariances[t, r, mapping[j]]
                for q in range(j):
                    s -= lower[j, q] * gain[r, q]
                gain[r, j] = s / lower[j, j]
            for j in range(m - 1, -1, -1):
                s = gain[r, j]
                for q in range(j + 1, m):
                    s -= lower[q, j] * gain[r, q]
                gain[r, j] = s / lower[j, j]
        for r in range(d):
            s = means[t, r]
            for j in range(m):
                v = measurements[t, j] - means[t, mapping[j]]
                s += gain[r, j] * (wrap_angle(v) if angles[j] else v)
            means_out[t, r] = s
        for r in range(d):  # I - K H
            for c in range(d):
                square[r, c] = 1.0 if r == c else 0.0
            for j in range(m):
                square[r, mapping[j]] -= gain[r, j]
        for r in range(d):
            for c in range(d):
                s = 0.0
                for q in range(d):
                    s += square[r, q] * covariances[t, q, c]
                work[r, c] = s
        for r in range(d):
            for c in range(r + 1):
                s = 0.0
                if joseph:
                    for q in range(d):
                        s += work[r, q] * square[c, q]
                    for i in range(m):
                        for j in range(m):
                            s += gain[r, i] * noise[i, j] * gain[c, j]
                else:
                    s = work[r, c]
                covariances_out[t, r, c] = s
                covariances_out[t, c, r] = s
        if not joseph and status[t] == OK:
            status[t] = _covariance_code(covariances_out[t], scratch, UPDATE_NOT_PSD,
                                         UPDATE_NOT_PSD)


@jit()
def stack_predict_function(function, dt, covar, central, means, covariances, means_out,
                           covariances_out, status):
    """K filters (means (K, d), covariances (K, d, d)) through a user transition
    ``f((d, n), dt)`` with noise ``covar`` (d, d), each as :func:`predict_function` (the
    function's outputs checked, F its finite-difference Jacobian at the filter's mean);
    ``status[k]`` is filter k's status."""
    k_filters, d = means.shape
    x, x_out = np.empty((d, 1)), np.empty((d, 1))
    for t in range(k_filters):
        for r in range(d):
            x[r, 0] = means[t, r]
        status[t] = predict_function(function, dt, covar, central, x, covariances[t], x_out,
                                     covariances_out[t])
        for r in range(d):
            means_out[t, r] = x_out[r, 0]


@jit()
def stack_linearise_function(function, dt, central, points, jacobians, values, status):
    """A user transition ``f((d, n), dt)`` linearised at each of the (n, d) ``points``:
    its finite-difference Jacobian (n, d, d) and value ``f(x)`` (n, d) there;
    ``status[k]`` is the status of the function's outputs at point k (see :mod:`user`)."""
    n, d = points.shape
    x = np.empty((d, 1))
    for k in range(n):
        for r in range(d):
            x[r, 0] = points[k, r]
        status[k] = transition_jacobian_function(function, dt, x[:, 0].copy(), central,
                                                 jacobians[k])
        if status[k] != OK:
            continue
        value = function(x, dt)
        status[k] = output_status(value, d, np.int64(1))
        if status[k] == OK:
            for r in range(d):
                values[k, r] = value[r, 0]


# --- one filter: a state's (d, 1) column, its (d, d) covariance (a block of one) -----------


@jit()
def predict_one(kind, rates, fixed_matrix, fixed_covar, dt, x, covariance, x_out,
                covariance_out):
    """One filter through a FIXED or CV transition; returns its status."""
    d = x.shape[0]
    matrix, covar = np.empty((d, d, 1)), np.empty((d, d, 1))
    status = np.zeros(1, dtype=np.int64)
    _transition(1, kind, rates, fixed_matrix, fixed_covar, np.full(1, dt), matrix, covar)
    _predict(1, matrix, covar, x, covariance.reshape((d, d, 1)), x_out,
            covariance_out.reshape((d, d, 1)), status)
    return status[0]


@jit()
def predict_function(function, dt, covar, central, x, covariance, x_out, covariance_out):
    """One filter through a user transition ``f((d, n), dt)``: ``x_out = f(x)``, and F its
    finite-difference Jacobian at x; returns the status (the function's outputs are
    checked first, see :mod:`user`)."""
    d = x.shape[0]
    jacobian = np.empty((d, d))
    code = transition_jacobian_function(function, dt, x[:, 0].copy(), central, jacobian)
    if code != OK:
        return code
    values = function(x, dt)
    code = output_status(values, d, np.int64(1))
    if code != OK:
        return code
    matrix = np.empty((d, d, 1))
    for r in range(d):
        x_out[r, 0] = values[r, 0]
        for c in range(d):
            matrix[r, c, 0] = jacobian[r, c]
    status = np.zeros(1, dtype=np.int64)
    _predict_covariance(1, matrix, covar.reshape((d, d, 1)), covariance.reshape((d, d, 1)),
                        covariance_out.reshape((d, d, 1)), status)
    _check_overflow(1, x_out, covariance_out.reshape((d, d, 1)), status)
    return status[0]


@jit()
def update_one(kind, mapping, offset, rotation, noise, angles, method, joseph, x, covariance,
               z, x_out, covariance_out, z_hat, innovation_covar, cross):
    """One filter's update with a built-in measurement kind; returns its status (the
    prediction's covariance must be positive semi-definite)."""
    d = x.shape[0]
    m = z.shape[0]
    status = np.zeros(1, dtype=np.int64)
    covariance = covariance.reshape((d, d, 1))
    _check_covariance(1, covariance, status, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    jacobian = np.empty((m, d, 1))
    _measure(1, kind, mapping, offset, rotation, method, x, z_hat, jacobian, status)
    _update(1, x, covariance, z, z_hat, jacobian, noise, angles, joseph, x_out,
            covariance_out.reshape((d, d, 1)), innovation_covar.reshape((m, m, 1)),
            cross.reshape((d, m, 1)), status)
    return status[0]


@jit()
def update_function(function, noise, angles, central, joseph, x, covariance, z, x_out,
                    covariance_out, z_hat, innovation_covar, cross):
    """One filter's update with a user measurement ``h((d, n)) -> (m, n)`` (Jacobian by
    finite differences); returns its status (the function's outputs are checked first)."""
    d = x.shape[0]
    m = z.shape[0]
    values = function(x)
    code = output_status(values, m, np.int64(1))
    if code != OK:
        return code
    one = np.empty((m, d))
    code = measurement_jacobian_function(function, x[:, 0].copy(), angles, central, one)
    if code != OK:
        return code
    status = np.zeros(1, dtype=np.int64)
    covariance = covariance.reshape((d, d, 1))
    _check_covariance(1, covariance, status, PREDICTION_NOT_SYMMETRIC, PREDICTION_NOT_PSD)
    jacobian = np.empty((m, d, 1))
    for r in range(m):
        z_hat[r, 0] = wrap_angle(values[r, 0]) if angles[r] else values[r, 0]
        for c in range(d):
            jacobian[r, c, 0] = one[r, c]
    _update(1, x, covariance, z, z_hat, jacobian, noise, angles, joseph, x_out,
            covariance_out.reshape((d, d, 1)), innovation_covar.reshape((m, m, 1)),
            cross.reshape((d, m, 1)), status)
    return status[0]
