"""Multiple-model filtering (:mod:`fasttrack.core.imm`) over K filters of M linear models,
one filter a thread: the IMM, GPB1 and GPB2 steps for a sensor that selects state components
(each model's prior, predicted with its F and Q and updated in the Joseph form, the models
weighed in logs); the fixed-interval smoother is :mod:`imm_smooth`'s. A filter whose step is
undefined gets a status code and the array layer reports it."""
import math

import numpy as np

from .dispatch import jit
from .kalman import _from_block, _propagate, _to_block, _update
from .linalg import _check_covariance, _cholesky, _covariance_code
from .mixture import _moment_match_group
from .numeric import cholesky, copy_into, fill
from .status import INNOVATION_NOT_PD, OK, PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC
from .tunables import FILTERS_PER_BLOCK

#: log(2 pi) / 2
HALF_LOG_TWO_PI = 0.9189385332046727


#: :func:`imm_linear_step`'s algorithms: the interacting multiple model filter, and the
#: generalised pseudo-Bayesian filters of first and second order.
IMM, GPB1, GPB2 = 0, 1, 2


@jit(inline=True)
def _every(has):
    """Whether every entry of the bool array ``has`` (M, d) is True."""
    for i in range(has.shape[0]):
        for a in range(has.shape[1]):
            if not has[i, a]:
                return False
    return True


@jit(inline=True)
def _converted_covariance(covars, has, i, j, a, b):
    """Entry (a, b) of model i's covariance in model j's components (of those j has): model
    i's where i has both, model j's own where i has neither, else 0."""
    if has[i, a] and has[i, b]:
        return covars[i, a, b]
    if not has[i, a] and not has[i, b]:
        return covars[j, a, b]
    return 0.0


@jit(inline=True)
def _converted(means, covars, has, i, j, x, p):
    """Model i's state of one filter in model j's components into ``x`` (d,) and ``p``
    (d, d): a component j has and i lacks takes model j's own mean, variance and
    covariances with the others i lacks; a component j lacks is 0."""
    d = x.size
    if _every(has):
        copy_into(means[i], x)
        copy_into(covars[i], p)
        return
    for a in range(d):
        x[a] = (means[i, a] if has[i, a] else means[j, a]) if has[j, a] else 0.0
        for b in range(d):
            p[a, b] = _converted_covariance(covars, has, i, j, a, b) \
                if has[j, a] and has[j, b] else 0.0


@jit(inline=True)
def _covariances_code(covars, check):
    """OK, or why the first of one filter's model covariances (M, d, d) is not symmetric
    positive semi-definite; ``check`` (d, d) is scratch."""
    for i in range(covars.shape[0]):
        code = _covariance_code(covars[i], check, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
        if code != OK:
            return code
    return OK


@jit(inline=True)
def _predict_one(f, q, x0, p0, x, p, work):
    """``x = F x0`` and ``p = F p0 F^T + Q`` (symmetric); ``work`` (d, d) is scratch."""
    d = x0.size
    for a in range(d):
        s = 0.0
        for b in range(d):
            s += f[a, b] * x0[b]
        x[a] = s
        for b in range(d):
            s = 0.0
            for c in range(d):
                s += f[a, c] * p0[c, b]
            work[a, b] = s
    for a in range(d):
        for b in range(a + 1):
            s = q[a, b]
            for c in range(d):
                s += work[a, c] * f[b, c]
            p[a, b] = s
            p[b, a] = s


@jit()
def _scratch(d, m):
    """The work arrays of :func:`_model_step` for states of dimension d and measurements
    of dimension m."""
    return (np.empty(d), np.empty((d, d)), np.empty((d, d)), np.empty((m, m)),
            np.empty((m, m)), np.empty((d, m)), np.empty(m), np.empty(m))


@jit()
def _workspace(d, m, models):
    """The scratch of a filter's step: :func:`_scratch`'s, a prior (d,) and (d, d), a
    (d, d) matrix, three (M,) vectors, ``arange(M)``, M pairs' means and covariances, and
    an (M,) int64 index."""
    return (_scratch(d, m), np.empty(d), np.empty((d, d)), np.empty((d, d)), np.empty(models),
            np.empty(models), np.empty(models), np.arange(models), np.empty((models, d)),
            np.empty((models, d, d)), np.empty(models, dtype=np.int64))


@jit(inline=True)
def _model_step(f, q, mapping, noise, x0, p0, z, x_out, p_out, scratch):
    """One model's Kalman step: ``(x0, p0)`` predicted through ``(F, Q)``, then updated
    (:func:`_kalman_update`) into ``(x_out, p_out)``; returns the log likelihood or NaN.
    ``scratch`` is :func:`_scratch`'s."""
    x, p, work = scratch[:3]
    _predict_one(f, q, x0, p0, x, p, work)
    return _kalman_update(mapping, noise, x, p, z, x_out, p_out, scratch)


@jit(inline=True)
def _kalman_update(mapping, noise, x, p, z, x_out, p_out, scratch):
    """The Joseph-form update of ``(x, p)`` with ``z`` by the sensor selecting ``mapping``
    (noise R) into ``(x_out, p_out)``. Returns the measurement's log likelihood, or NaN if
    the innovation covariance is not positive definite. ``scratch`` is
    :func:`_scratch`'s (its first two arrays untouched)."""
    work, s, lower, gain, innovation, v = scratch[2:]
    d, m = x.size, mapping.size
    for r in range(m):
        for c in range(m):
            s[r, c] = p[mapping[r], mapping[c]] + noise[r, c]
    if not cholesky(s, lower):
        return np.nan
    for r in range(m):  # v = L^-1 (z - H x)
        innovation[r] = z[r] - x[mapping[r]]
        t = innovation[r]
        for c in range(r):
            t -= lower[r, c] * v[c]
        v[r] = t / lower[r, r]
    log_likelihood = -m * HALF_LOG_TWO_PI
    for r in range(m):
        log_likelihood -= 0.5 * v[r] * v[r] + math.log(lower[r, r])
    row = v
    for a in range(d):  # K = P H^T S^-1: solve L (L^T K^T) = H P for each row a of K
        for r in range(m):
            t = p[a, mapping[r]]
            for c in range(r):
                t -= lower[r, c] * row[c]
            row[r] = t / lower[r, r]
        for r in range(m - 1, -1, -1):
            t = row[r]
            for c in range(r + 1, m):
                t -= lower[c, r] * gain[a, c]
            gain[a, r] = t / lower[r, r]
    for a in range(d):
        t = x[a]
        for r in range(m):
            t += gain[a, r] * innovation[r]
        x_out[a] = t
    for a in range(d):  # work = (I - K H) P
        for b in range(d):
            t = p[a, b]
            for r in range(m):
                t -= gain[a, r] * p[mapping[r], b]
            work[a, b] = t
    for a in range(d):  # p_out = work (I - K H)^T + K R K^T
        for b in range(a + 1):
            t = work[a, b]
            for r in range(m):
                t -= work[a, mapping[r]] * gain[b, r]
            for r in range(m):
                kr = 0.0
                for c in range(m):
                    kr += noise[r, c] * gain[b, c]
                t += gain[a, r] * kr
            p_out[a, b] = t
            p_out[b, a] = t
    return log_likelihood


@jit(inline=True)
def _normalised(log_weights, out):
    """``out = exp(log_weights)`` normalised to sum to one (the largest finite)."""
    top = -np.inf
    for j in range(log_weights.size):
        top = max(top, log_weights[j])
    total = 0.0
    for j in range(log_weights.size):
        total += math.exp(log_weights[j] - top)
    for j in range(log_weights.size):
        out[j] = math.exp(log_weights[j] - top) / total


@jit()
def _gpb2_step(transitions, noises, mapping, noise, matrix, has, means, covars, probs, z,
               out_means, out_covars, out_probs, space):
    """One filter's GPB2 step (see :func:`imm_linear_step`); returns its status.
    ``space`` is :func:`_workspace`'s."""
    scratch, x0, p0, _, log_posterior, weights, log_pair = space[:7]
    pair_means, pair_covars, reached = space[8:]
    models = means.shape[0]
    for j in range(models):
        count, top = 0, -np.inf
        for i in range(models):
            prior = matrix[i, j] * probs[i]
            if prior <= 0.0 and i != j:
                continue
            _converted(means, covars, has, i, j, x0, p0)
            log_likelihood = _model_step(transitions[j], noises[j], mapping, noise, x0, p0, z,
                                         pair_means[i], pair_covars[i], scratch)
            if log_likelihood != log_likelihood:
                return INNOVATION_NOT_PD
            if prior > 0.0:
                log_pair[i] = math.log(prior) + log_likelihood
                top = max(top, log_pair[i])
                reached[count] = i
                count += 1
        if count == 0:  # nothing switches into model j: its own state, updated
            copy_into(pair_means[j], out_means[j])
            copy_into(pair_covars[j], out_covars[j])
            log_posterior[j] = -np.inf
            continue
        for g in range(count):
            weights[reached[g]] = math.exp(log_pair[reached[g]] - top)
        total = _moment_match_group(pair_means, pair_covars, weights, reached, count,
                                    out_means[j], out_covars[j])
        log_posterior[j] = top + math.log(total)
    _normalised(log_posterior, out_probs)
    return OK


@jit()
def step_inputs_valid(means, covars, probs, z, tolerance):
    """Whether every entry of the (K, M, d), (K, M, d, d), (K, M) and (K, m) arrays is
    finite, each row of ``probs`` is >= 0 and sums to 1 within ``tolerance``, and each
    covariance is symmetric positive semi-definite: the checks of a multiple-model step's
    values, which :func:`imm_linear_step` takes as done."""
    finite = True
    for a in (means.ravel(), covars.ravel(), z.ravel()):
        for i in range(a.size):  # a branch-free test, so that the loop vectorises
            finite &= abs(a[i]) <= 1.7976931348623157e308
    for k in range(probs.shape[0]):
        total = 0.0
        for j in range(probs.shape[1]):
            finite &= 0.0 <= probs[k, j] <= 1.7976931348623157e308
            total += probs[k, j]
        finite &= abs(total - 1.0) <= tolerance
    if not finite:
        return False
    check = np.empty(covars.shape[2:])
    for k in range(covars.shape[0]):
        if _covariances_code(covars[k], check) != OK:
            return False
    return True


@jit()
def _mix(nb, algorithm, matrix, has, j, x, p, mu, predicted, weights, x0, p0):
    """Model j's prior of each filter of a block into ``x0[:, j]`` and ``p0[:, :, j]``
    (symmetric): for the IMM the models mixed by ``p_ij mu_i`` (where model j's predicted
    probability ``predicted[j]`` is 0, model j's own state), for GPB1 all models merged by
    ``mu_i``; each model i taken in model j's components as :func:`_converted` takes it.
    Arrays in the block layout (:func:`_to_lanes`); ``weights`` (M, B) is scratch."""
    d, models = x.shape[0], x.shape[1]
    total = np.zeros(nb)
    for i in range(models):
        for b in range(nb):
            if algorithm == GPB1:
                weights[i, b] = mu[i, b]
            else:
                weights[i, b] = matrix[i, j] * mu[i, b] if predicted[j, b] > 0.0 \
                    else (i == j) * 1.0
            total[b] += weights[i, b]
    for i in range(models):
        for b in range(nb):
            weights[i, b] /= total[b]
    for a in range(d):
        for b in range(nb):
            x0[a, j, b] = 0.0
        for i in range(models if has[j, a] else 0):
            source = i if has[i, a] else j
            for b in range(nb):
                x0[a, j, b] += weights[i, b] * x[a, source, b]
    for a in range(d):
        for c in range(a + 1):
            for b in range(nb):
                p0[a, c, j, b] = 0.0
            for i in range(models if has[j, a] and has[j, c] else 0):
                row, column = (i if has[i, a] else j), (i if has[i, c] else j)
                own = 1.0 if has[i, a] == has[i, c] else 0.0  # else the two are independent
                for b in range(nb):
                    spread = (x[a, row, b] - x0[a, j, b]) * (x[c, column, b] - x0[c, j, b])
                    p0[a, c, j, b] += weights[i, b] * (own * p[a, c, row, b] + spread)
            for b in range(nb):
                p0[c, a, j, b] = p0[a, c, j, b]


@jit()
def _predict_models(nb, algorithm, transitions, noises, matrix, has, x, p, mu, x_out, p_out,
                    predicted):
    """Each model's prior of a block's filters (:func:`_mix`) predicted through its F and Q
    into ``x_out`` (d, M, B) and ``p_out`` (d, d, M, B); ``predicted`` (M, B) gets the
    predicted probabilities ``c_j = sum_i p_ij mu_i``. (A mixture of covariances is one:
    the models' own are what is checked.)"""
    d, models = x.shape[0], x.shape[1]
    lanes = models * nb
    weights, x0, p0 = np.empty((models, nb)), np.empty(x.shape), np.empty(p.shape)
    f, q = np.empty(p.shape), np.empty(p.shape)
    for j in range(models):
        for b in range(nb):
            predicted[j, b] = 0.0
        for i in range(models):
            for b in range(nb):
                predicted[j, b] += matrix[i, j] * mu[i, b]
        _mix(nb, algorithm, matrix, has, j, x, p, mu, predicted, weights, x0, p0)
        for r in range(d):
            for c in range(d):
                for b in range(nb):
                    f[r, c, j, b] = transitions[j, r, c]
                    q[r, c, j, b] = noises[j, r, c]
    _propagate(lanes, f.reshape((d, d, lanes)), q.reshape((d, d, lanes)),
               x0.reshape((d, lanes)), p0.reshape((d, d, lanes)), x_out.reshape((d, lanes)),
               p_out.reshape((d, d, lanes)))


@jit()
def _update_models(nb, mapping, noise, x, p, predicted, z, x_out, p_out, mu_out, status):
    """Each model's prediction of a block's filters (``x`` (d, M, B), ``p`` (d, d, M, B))
    updated in the Joseph form with ``z`` (m, B) by the sensor selecting ``mapping`` (noise
    R) into ``x_out`` and ``p_out``; ``mu_out`` (M, B) gets the posterior mode
    probabilities from the predicted ones (M, B), weighed in logs. Where a model's
    innovation covariance is not positive definite, ``status`` becomes INNOVATION_NOT_PD."""
    d, models, m = x.shape[0], x.shape[1], mapping.size
    lanes = models * nb
    x, p = x.reshape((d, lanes)), p.reshape((d, d, lanes))
    measured, z_hat, jacobian = np.empty((m, models, nb)), np.empty((m, lanes)), \
        np.zeros((m, d, lanes))
    for r in range(m):
        for j in range(models):
            for b in range(nb):
                measured[r, j, b] = z[r, b]
        for b in range(lanes):
            z_hat[r, b] = x[mapping[r], b]
            jacobian[r, mapping[r], b] = 1.0
    measured = measured.reshape((m, lanes))
    innovation_covar, cross = np.empty((m, m, lanes)), np.empty((d, m, lanes))
    lane_status = np.zeros(lanes, dtype=np.int64)
    _update(lanes, x, p, measured, z_hat, jacobian, noise, np.zeros(m, dtype=np.bool_), True,
            x_out.reshape((d, lanes)), p_out.reshape((d, d, lanes)), innovation_covar, cross,
            lane_status)
    log_posterior = np.empty(lanes)
    _log_gaussian(lanes, innovation_covar, measured, z_hat, log_posterior, lane_status)
    log_posterior = log_posterior.reshape((models, nb))
    for j in range(models):
        for b in range(nb):
            log_posterior[j, b] += math.log(predicted[j, b]) if predicted[j, b] > 0.0 \
                else -np.inf
    _first_status(lane_status, status)
    _normalised_block(nb, log_posterior, mu_out)


@jit()
def _first_status(lane_status, status):
    """``status[b]``, where still OK, becomes the first of the block's models' statuses
    ``lane_status`` (M * B,) that is not."""
    lane_status = lane_status.reshape((-1, status.size))
    for j in range(lane_status.shape[0]):
        for b in range(status.size):
            if status[b] == OK:
                status[b] = lane_status[j, b]


@jit()
def _log_gaussian(nb, covar, z, mean, out, status):
    """``out[b] = log N(z; mean, S)`` per filter for the (m, m, B) ``covar`` S (where it is
    not positive definite, ``status`` becomes INNOVATION_NOT_PD)."""
    m = z.shape[0]
    lower, whitened = np.empty((m, m, nb)), np.empty((m, nb))
    _cholesky(nb, covar, lower, status, INNOVATION_NOT_PD)
    for b in range(nb):
        out[b] = -m * HALF_LOG_TWO_PI
    for r in range(m):
        for b in range(nb):
            t = z[r, b] - mean[r, b]
            for c in range(r):
                t -= lower[r, c, b] * whitened[c, b]
            whitened[r, b] = t / lower[r, r, b]
            out[b] -= 0.5 * whitened[r, b] * whitened[r, b] + math.log(lower[r, r, b])


@jit()
def _normalised_block(nb, log_weights, out):
    """``out[:, b] = exp(log_weights[:, b])`` normalised to sum to one (the largest finite)
    for each filter of a block (M, B)."""
    top = np.full(nb, -np.inf)
    total = np.zeros(nb)
    for j in range(log_weights.shape[0]):
        for b in range(nb):
            top[b] = max(top[b], log_weights[j, b])
    for j in range(log_weights.shape[0]):
        for b in range(nb):
            out[j, b] = math.exp(log_weights[j, b] - top[b])
            total[b] += out[j, b]
    for j in range(log_weights.shape[0]):
        for b in range(nb):
            out[j, b] /= total[b]


@jit()
def _to_lanes(rows, lo, hi, out):
    """``out[..., j, b] = rows[lo + b, j]`` for (K, M, ...) rows: the block layout, with
    out (..., M, hi - lo)."""
    models, nb = rows.shape[1], hi - lo
    flat = out.reshape((-1, models, nb))
    for b in range(nb):
        for j in range(models):
            row = rows[lo + b, j].ravel()
            for i in range(row.size):
                flat[i, j, b] = row[i]


@jit()
def _from_lanes(block, lo, hi, rows):
    """The inverse of :func:`_to_lanes`: ``rows[lo + b, j] = block[..., j, b]``."""
    models, nb = rows.shape[1], hi - lo
    flat = block.reshape((-1, models, nb))
    for b in range(nb):
        for j in range(models):
            row = rows[lo + b, j].reshape(-1)
            for i in range(row.size):
                row[i] = flat[i, j, b]


@jit()
def _block(means, covars, probs, lo, hi):
    """Filters ``lo:hi``'s rows of the (K, M, d), (K, M, d, d) and (K, M) arrays in the
    block layout, the block's filters last: (d, M, B), (d, d, M, B) and (M, B)."""
    models, d, nb = means.shape[1], means.shape[2], hi - lo
    x, p, mu = np.empty((d, models, nb)), np.empty((d, d, models, nb)), np.empty((models, nb))
    _to_lanes(means, lo, hi, x)
    _to_lanes(covars, lo, hi, p)
    _to_block(probs, lo, hi, mu)
    return x, p, mu


@jit()
def _unblock(x, p, mu, lo, hi, means, covars, probs):
    """The block arrays of :func:`_block` written back into filters ``lo:hi``'s rows."""
    _from_lanes(x, lo, hi, means)
    _from_lanes(p, lo, hi, covars)
    _from_block(mu, lo, hi, probs)


@jit()
def imm_linear_step(algorithm, transitions, noises, mapping, noise, matrix, has, means, covars,
                    probs, z, out_means, out_covars, out_probs, status):
    """One step of K multiple-model filters of M linear models sharing one interval.

    IMM: each model's prior is mixed from all models' posteriors by ``p_ij mu_i``. GPB1:
    every model starts from the moment match of all. GPB2: each model j updates every
    model i's posterior (the pairs reached, ``p_ij mu_i > 0``) and merges them by
    ``p_ij mu_i`` times their likelihoods. Mode probabilities are weighed in logs. The IMM
    and GPB1 go in blocks of filters (the loops over a block's filters vectorise), GPB2
    filter by filter.

    Parameters
    ----------
    algorithm : int
        :data:`IMM`, :data:`GPB1` or :data:`GPB2`.
    transitions, noises : (M, d, d) float64
        Each model's F and Q over the interval.
    mapping : (m,) int64
        The state components the sensor measures; ``noise`` (m, m) is its R.
    matrix : (M, M) float64
        ``matrix[i, j]``: the probability of switching from model i to model j.
    has : (M, d) bool
        The state components of each model (the rest of its mean and covariance are 0); a
        model i is :func:`_converted` into model j's components before it enters model j.
    means, covars, probs : (K, M, d), (K, M, d, d), (K, M) float64
    z : (K, m) float64
    out_means, out_covars, out_probs : arrays of the shapes of the inputs
    status : (K,) int64
        OK, or INNOVATION_NOT_PD where a model's innovation covariance is not positive
        definite (its outputs are then partly written). The inputs' values are not
        checked here (:func:`step_inputs_valid` does).
    """
    if algorithm == GPB2:
        space = _workspace(means.shape[2], mapping.size, means.shape[1])
        for k in range(means.shape[0]):
            status[k] = _gpb2_step(transitions, noises, mapping, noise, matrix, has, means[k],
                                   covars[k], probs[k], z[k], out_means[k], out_covars[k],
                                   out_probs[k], space)
        return
    filters, models, d = means.shape
    for lo in range(0, filters, FILTERS_PER_BLOCK):
        hi = min(lo + FILTERS_PER_BLOCK, filters)
        nb = hi - lo
        x, p, mu = _block(means, covars, probs, lo, hi)
        zb = np.empty((mapping.size, nb))
        _to_block(z, lo, hi, zb)
        x_pred, p_pred, predicted = np.empty_like(x), np.empty_like(p), np.empty_like(mu)
        fill(status[lo:hi], OK)
        _predict_models(nb, algorithm, transitions, noises, matrix, has, x, p, mu, x_pred,
                        p_pred, predicted)
        _update_models(nb, mapping, noise, x_pred, p_pred, predicted, zb, x, p, mu,
                       status[lo:hi])  # the prior's block arrays take the posterior
        _unblock(x, p, mu, lo, hi, out_means, out_covars, out_probs)


@jit()
def imm_predict(transitions, noises, matrix, has, means, covars, probs, out_means, out_covars,
                out_predicted, status):
    """The IMM's prediction of K filters (the first half of :func:`imm_linear_step`):
    each model's prior mixed from all models' posteriors, predicted through its F and Q.

    Parameters
    ----------
    transitions, noises, matrix, has, means, covars, probs
        As :func:`imm_linear_step`'s.
    out_means, out_covars, out_predicted : arrays of the shapes of the inputs
        The models' predictions and predicted probabilities ``c_j = sum_i p_ij mu_i``.
    status : (K,) int64
        OK, or why the first of the filter's model covariances is not symmetric positive
        semi-definite.
    """
    filters, models, d = means.shape
    for lo in range(0, filters, FILTERS_PER_BLOCK):
        hi = min(lo + FILTERS_PER_BLOCK, filters)
        nb = hi - lo
        x, p, mu = _block(means, covars, probs, lo, hi)
        x_pred, p_pred, predicted = np.empty_like(x), np.empty_like(p), np.empty_like(mu)
        fill(status[lo:hi], OK)
        lane_status = np.zeros(models * nb, dtype=np.int64)
        _check_covariance(models * nb, p.reshape((d, d, models * nb)), lane_status,
                          PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
        _first_status(lane_status, status[lo:hi])
        _predict_models(nb, IMM, transitions, noises, matrix, has, x, p, mu, x_pred, p_pred,
                        predicted)
        _unblock(x_pred, p_pred, predicted, lo, hi, out_means, out_covars, out_predicted)


@jit()
def imm_update(mapping, noise, means, covars, predicted, z, out_means, out_covars,
               out_probs, status):
    """The IMM's update of K filters (the second half of :func:`imm_linear_step`): each
    model's prediction updated with the filter's measurement, the models weighed in logs.

    Parameters
    ----------
    mapping, noise
        As :func:`imm_linear_step`'s.
    means, covars, predicted : (K, M, d), (K, M, d, d), (K, M) float64
        The models' predictions and predicted probabilities.
    z : (K, m) float64
    out_means, out_covars, out_probs : arrays of the shapes of the inputs
    status : (K,) int64
        OK, or INNOVATION_NOT_PD.
    """
    filters, models, d = means.shape
    for lo in range(0, filters, FILTERS_PER_BLOCK):
        hi = min(lo + FILTERS_PER_BLOCK, filters)
        nb = hi - lo
        x, p, c = _block(means, covars, predicted, lo, hi)
        zb = np.empty((mapping.size, nb))
        _to_block(z, lo, hi, zb)
        x_out, p_out, mu_out = np.empty_like(x), np.empty_like(p), np.empty_like(c)
        fill(status[lo:hi], OK)
        _update_models(nb, mapping, noise, x, p, c, zb, x_out, p_out, mu_out, status[lo:hi])
        _unblock(x_out, p_out, mu_out, lo, hi, out_means, out_covars, out_probs)
