"""Multiple-model filtering (:mod:`fasttrack.core.imm`) over K filters of M linear models,
one filter a thread: the IMM, GPB1 and GPB2 steps for a sensor that selects state components
(each model's prior, predicted with its F and Q and updated in the Joseph form, the models
weighed in logs); the fixed-interval smoother is :mod:`imm_smooth`'s. A filter whose step is
undefined gets a status code and the array layer reports it."""
import math

import numpy as np

from .dispatch import jit
from .linalg import _covariance_code
from .mixture import _moment_match_group
from .numeric import cholesky, copy_into
from .status import INNOVATION_NOT_PD, OK, PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC

#: log(2 pi) / 2
HALF_LOG_TWO_PI = 0.9189385332046727


#: :func:`imm_linear_step`'s algorithms: the interacting multiple model filter, and the
#: generalised pseudo-Bayesian filters of first and second order.
IMM, GPB1, GPB2 = 0, 1, 2


@jit(inline=True)
def _mixed(algorithm, matrix, probs, means, covars, has, j, predicted, weights, everyone, x0,
           p0):
    """Model j's prior of one filter into ``x0`` (d,) and ``p0`` (d, d) (symmetric): for
    the IMM the models mixed by ``p_ij mu_i`` (``predicted`` their sum; a model of predicted
    probability 0 keeps its own state), for GPB1 all models merged by ``mu_i``; each model
    i :func:`_converted` into model j's components (``has`` (M, d)). ``weights`` (M,) is
    scratch; ``everyone`` is ``arange(M)``."""
    models = means.shape[0]
    total = 0.0
    for i in range(models):
        if algorithm == GPB1:
            weights[i] = probs[i]
        else:
            weights[i] = matrix[i, j] * probs[i] if predicted > 0.0 else (i == j) * 1.0
        total += weights[i]
    if _every(has):  # no conversion: the plain moment match
        _moment_match_group(means, covars, weights, everyone, models, x0, p0)
    else:
        _converted_match(means, covars, has, j, weights, total, x0, p0)


@jit()
def _converted_match(means, covars, has, j, weights, total, x0, p0):
    """:func:`_mixed`'s moment match of the models :func:`_converted` into model j's
    components with ``weights`` (M,) of sum ``total`` (symmetric ``p0``)."""
    models, d = means.shape
    for a in range(d):
        x0[a] = 0.0
        for i in range(models):
            if has[j, a]:
                x0[a] += weights[i] / total * (means[i, a] if has[i, a] else means[j, a])
        for b in range(d):
            p0[a, b] = 0.0
    for i in range(models):
        w = weights[i] / total
        if w == 0.0:
            continue
        for a in range(d):
            if not has[j, a]:
                continue
            da = (means[i, a] if has[i, a] else means[j, a]) - x0[a]
            for b in range(a + 1):
                if has[j, b]:
                    db = (means[i, b] if has[i, b] else means[j, b]) - x0[b]
                    p0[a, b] += w * (_converted_covariance(covars, has, i, j, a, b) + da * db)
    for a in range(d):
        for b in range(a):
            p0[b, a] = p0[a, b]


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
def _prior(algorithm, matrix, probs, means, covars, has, j, space):
    """Model j's prior of one filter (:func:`_mixed`) into ``space``'s prior arrays; returns
    its predicted probability ``c_j = sum_i p_ij mu_i``. ``space`` is :func:`_workspace`'s.
    (A mixture of covariances is one: the models' own are what is checked.)"""
    predicted = 0.0
    for i in range(means.shape[0]):
        predicted += matrix[i, j] * probs[i]
    x0, p0, weights, everyone = space[1], space[2], space[5], space[7]
    _mixed(algorithm, matrix, probs, means, covars, has, j, predicted, weights, everyone, x0,
           p0)
    return predicted


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
def _predict(f, q, x0, p0, x, p, work):
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
    _predict(f, q, x0, p0, x, p, work)
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
def _mixing_step(algorithm, transitions, noises, mapping, noise, matrix, has, means, covars,
                 probs, z, out_means, out_covars, out_probs, space):
    """One filter's IMM or GPB1 step (see :func:`imm_linear_step`); returns its status.
    ``space`` is :func:`_workspace`'s."""
    scratch, x0, p0, log_posterior = space[0], space[1], space[2], space[4]
    for j in range(means.shape[0]):
        predicted = _prior(algorithm, matrix, probs, means, covars, has, j, space)
        log_likelihood = _model_step(transitions[j], noises[j], mapping, noise, x0, p0, z,
                                     out_means[j], out_covars[j], scratch)
        if log_likelihood != log_likelihood:
            return INNOVATION_NOT_PD
        log_posterior[j] = (math.log(predicted) + log_likelihood) if predicted > 0.0 \
            else -np.inf
    _normalised(log_posterior, out_probs)
    return OK


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
def imm_linear_step(algorithm, transitions, noises, mapping, noise, matrix, has, means, covars,
                    probs, z, out_means, out_covars, out_probs, status):
    """One step of K multiple-model filters of M linear models sharing one interval.

    IMM: each model's prior is mixed from all models' posteriors by ``p_ij mu_i``. GPB1:
    every model starts from the moment match of all. GPB2: each model j updates every
    model i's posterior (the pairs reached, ``p_ij mu_i > 0``) and merges them by
    ``p_ij mu_i`` times their likelihoods. Mode probabilities are weighed in logs.

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
        definite (its outputs are then partly written). The inputs' values are not checked
        here (:func:`step_inputs_valid` does).
    """
    space = _workspace(means.shape[2], mapping.size, means.shape[1])
    for k in range(means.shape[0]):
        if algorithm == GPB2:
            status[k] = _gpb2_step(transitions, noises, mapping, noise, matrix, has, means[k],
                                   covars[k], probs[k], z[k], out_means[k], out_covars[k],
                                   out_probs[k], space)
        else:
            status[k] = _mixing_step(algorithm, transitions, noises, mapping, noise, matrix,
                                     has, means[k], covars[k], probs[k], z[k], out_means[k],
                                     out_covars[k], out_probs[k], space)


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
    space = _workspace(d, 1, models)
    for k in range(filters):
        status[k] = _covariances_code(covars[k], space[3])
        if status[k] != OK:
            continue
        for j in range(models):
            out_predicted[k, j] = _prior(IMM, matrix, probs[k], means[k], covars[k], has, j,
                                         space)
            _predict(transitions[j], noises[j], space[1], space[2], out_means[k, j],
                     out_covars[k, j], space[0][2])


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
    space = _workspace(d, mapping.size, models)
    scratch, log_posterior = space[0], space[4]
    for k in range(filters):
        status[k] = OK
        for j in range(models):
            log_likelihood = _kalman_update(mapping, noise, means[k, j], covars[k, j], z[k],
                                            out_means[k, j], out_covars[k, j], scratch)
            if log_likelihood != log_likelihood:
                status[k] = INNOVATION_NOT_PD
                break
            log_posterior[j] = math.log(predicted[k, j]) + log_likelihood \
                if predicted[k, j] > 0.0 else -np.inf
        if status[k] == OK:
            _normalised(log_posterior, out_probs[k])
