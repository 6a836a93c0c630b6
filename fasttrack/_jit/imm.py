"""Multiple-model filtering (:mod:`fasttrack.core.imm`) over K filters of M linear models:
the IMM, GPB1 and GPB2 steps for a sensor that selects state components (each model's
prior, predicted with its F and Q and updated in the Joseph form, the models weighed in
logs); the fixed-interval smoother is :mod:`imm_smooth`'s. A filter whose step is undefined
gets a status code and the array layer reports it.

Filters go in blocks laid out as :mod:`kalman`'s, the block's filters last: means
(d, M, B), covariances (d, d, M, B), mode probabilities (M, B). The M models of the block's
filters (for GPB2 the M x M pairs of a model's posterior and the model it enters) are
predicted side by side, each with its own F and Q, and updated as M B (M^2 B) lanes; the
loops over a block's lanes vectorise. A model i of fewer components enters model j as
:func:`fasttrack.core.imm.converted` takes it: a component model j has and model i lacks
brings model j's own mean, variance and covariances with the others model i lacks; a
component model j lacks is 0.
"""
import math

import numpy as np

from .dispatch import jit
from .kalman import _from_block, _to_block
from .linalg import _covariance_code
from .numeric import fill
from .status import INNOVATION_NOT_PD, OK, PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC
from .tunables import FILTERS_PER_BLOCK

#: log(2 pi) / 2
HALF_LOG_TWO_PI = 0.9189385332046727


#: :func:`imm_linear_step`'s algorithms: the interacting multiple model filter, and the
#: generalised pseudo-Bayesian filters of first and second order.
IMM, GPB1, GPB2 = 0, 1, 2


@jit(inline=True)
def _covariances_code(covars, check):
    """OK, or why the first of one filter's model covariances (M, d, d) is not symmetric
    positive semi-definite; ``check`` (d, d) is scratch."""
    for i in range(covars.shape[0]):
        code = _covariance_code(covars[i], check, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
        if code != OK:
            return code
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


@jit(inline=True)
def _source(has, i, j, a):
    """The model whose value of component a model i brings into model j: i if it has a,
    else j (of the components j has)."""
    return i if has[i, a] else j


@jit(inline=True)
def _kept(has, i, j, a, c):
    """Whether entry (a, c) of :func:`_source`'s covariance enters model j from model i:
    where j has both and i has both or neither (else the two are independent: 0)."""
    return has[j, a] and has[j, c] and has[i, a] == has[i, c]


@jit()
def _normalise(nb, weights, total):
    """Each filter's column of ``weights`` (M, B) divided by its sum, into ``total`` (B,)."""
    for b in range(nb):
        total[b] = 0.0
    for i in range(weights.shape[0]):
        for b in range(nb):
            total[b] += weights[i, b]
    for i in range(weights.shape[0]):
        for b in range(nb):
            weights[i, b] /= total[b]


@jit()
def _moment_match(nb, has, j, weights, x, p, x0, p0):
    """The models ``x`` (d, M, B), ``p`` (d, d, M, B), each taken into model j's
    components, merged by the normalised ``weights`` (M, B) into one Gaussian of the same
    moments (spread included): ``x0[:, j]`` and ``p0[:, :, j]`` (lower triangle computed and
    mirrored)."""
    d, models = x.shape[0], x.shape[1]
    for a in range(d):
        for b in range(nb):
            x0[a, j, b] = 0.0
        for i in range(models if has[j, a] else 0):
            source = _source(has, i, j, a)
            for b in range(nb):
                x0[a, j, b] += weights[i, b] * x[a, source, b]
    for a in range(d):
        for c in range(a + 1):
            for b in range(nb):
                p0[a, c, j, b] = 0.0
            for i in range(models if has[j, a] and has[j, c] else 0):
                row, column = _source(has, i, j, a), _source(has, i, j, c)
                kept = 1.0 if _kept(has, i, j, a, c) else 0.0
                for b in range(nb):
                    spread = (x[a, row, b] - x0[a, j, b]) * (x[c, column, b] - x0[c, j, b])
                    p0[a, c, j, b] += weights[i, b] * (kept * p[a, c, row, b] + spread)
            for b in range(nb):
                p0[c, a, j, b] = p0[a, c, j, b]


@jit()
def _mixed_priors(nb, algorithm, matrix, has, x, p, mu, x0, p0, predicted):
    """Each model's prior of a block's filters into ``x0`` (d, M, B) and ``p0``
    (d, d, M, B); ``predicted`` (M, B) gets the predicted probabilities
    ``c_j = sum_i p_ij mu_i``. The prior of model j: for the IMM the models mixed by
    ``p_ij mu_i`` (where ``c_j`` is 0, model j's own state), for GPB1 all models merged by
    ``mu_i``. (A mixture of covariances is one: the models' own are what is checked.)"""
    models = x.shape[1]
    weights, total = np.empty((models, nb)), np.empty(nb)
    for j in range(models):
        for b in range(nb):
            predicted[j, b] = 0.0
        for i in range(models):
            for b in range(nb):
                predicted[j, b] += matrix[i, j] * mu[i, b]
        for i in range(models):
            for b in range(nb):
                if algorithm == GPB1:
                    weights[i, b] = mu[i, b]
                else:
                    weights[i, b] = matrix[i, j] * mu[i, b] if predicted[j, b] > 0.0 \
                        else (i == j) * 1.0
        _normalise(nb, weights, total)
        _moment_match(nb, has, j, weights, x, p, x0, p0)


@jit()
def _paired_priors(nb, has, x, p, x0, p0):
    """GPB2's priors of a block's filters: model i's posterior taken into model j's
    components for each pair, into lane ``i B + b`` of model j's in ``x0`` (d, M, M B) and
    ``p0`` (d, d, M, M B)."""
    d, models = x.shape[0], x.shape[1]
    for j in range(models):
        for i in range(models):
            for a in range(d):
                for b in range(nb):
                    x0[a, j, i * nb + b] = x[a, _source(has, i, j, a), b] if has[j, a] else 0.0
                for c in range(d):
                    kept = _kept(has, i, j, a, c)
                    for b in range(nb):
                        p0[a, c, j, i * nb + b] = p[a, c, _source(has, i, j, a), b] if kept \
                            else 0.0


@jit()
def _predict_models(transitions, noises, x, p, x_out, p_out):
    """Each model j's lanes of ``x`` (d, M, L), ``p`` (d, d, M, L) predicted through its F
    and Q (:func:`_predict_model`) into ``x_out`` and ``p_out``."""
    for j in range(x.shape[1]):
        _predict_model(transitions[j], noises[j], j, x, p, x_out, p_out)


@jit()
def _predict_model(f, q, j, x, p, x_out, p_out):
    """Model j's lanes of ``x`` (d, M, L) and ``p`` (d, d, M, L) predicted through its F
    and Q into ``x_out`` and ``p_out`` (the same shapes): ``F x`` and ``F P F^T + Q``
    (lower triangle computed, mirrored)."""
    d, lanes = x.shape[0], x.shape[2]
    work = np.empty((d, d, lanes))  # F P
    for r in range(d):
        for b in range(lanes):
            x_out[r, j, b] = 0.0
        for c in range(d):
            for b in range(lanes):
                x_out[r, j, b] += f[r, c] * x[c, j, b]
            for b in range(lanes):
                work[r, c, b] = 0.0
            for e in range(d):
                for b in range(lanes):
                    work[r, c, b] += f[r, e] * p[e, c, j, b]
    for r in range(d):
        for c in range(r + 1):
            for b in range(lanes):
                p_out[r, c, j, b] = q[r, c]
            for e in range(d):
                for b in range(lanes):
                    p_out[r, c, j, b] += work[r, e, b] * f[c, e]
            for b in range(lanes):
                p_out[c, r, j, b] = p_out[r, c, j, b]


@jit()
def _update_lanes(mapping, noise, x, p, z, x_out, p_out, log_likelihood, status):
    """The lanes ``x`` (d, L) and ``p`` (d, d, L), L a multiple of the block's B filters
    (filter b's lanes are ``b, B + b, ...``), updated with their filter's measurement ``z``
    (m, B) by the sensor selecting ``mapping`` (noise R) into ``x_out`` and ``p_out``
    (:func:`_select_update`); ``log_likelihood`` (L,) gets each lane's log likelihood.
    Where an innovation covariance is not positive definite, ``status`` (B,) becomes
    INNOVATION_NOT_PD."""
    m, nb = z.shape
    lanes = x.shape[1]
    measured = np.empty((m, lanes // nb, nb))
    for r in range(m):
        for i in range(lanes // nb):
            for b in range(nb):
                measured[r, i, b] = z[r, b]
    lane_status = np.zeros(lanes, dtype=np.int64)
    _select_update(mapping, noise, x, p, measured.reshape((m, lanes)), x_out, p_out,
                   log_likelihood, lane_status)
    _first_status(lane_status, status)


@jit()
def _select_update(mapping, noise, x, p, z, x_out, p_out, log_likelihood, status):
    """The Kalman update in the Joseph form of each lane of ``x`` (d, L), ``p`` (d, d, L)
    with ``z`` (m, L) by the sensor selecting ``mapping`` (noise R) into ``x_out`` and
    ``p_out`` (lower triangle computed, mirrored); ``log_likelihood`` (L,) gets
    ``log N(z; H x, S)``. Where S is not positive definite, ``status`` (L,) becomes
    INNOVATION_NOT_PD (that lane's outputs are then meaningless)."""
    d, lanes = x.shape
    m = mapping.size
    lower, gain = np.empty((m, m, lanes)), np.empty((d, m, lanes))
    innovation, half, t = np.empty((m, lanes)), np.empty((m, lanes)), np.empty(lanes)
    for r in range(m):  # S = H P H^T + R = L L^T
        for s in range(r + 1):
            for b in range(lanes):
                t[b] = p[mapping[r], mapping[s], b] + noise[r, s]
            for k in range(s):
                for b in range(lanes):
                    t[b] -= lower[r, k, b] * lower[s, k, b]
            for b in range(lanes):
                if r != s:
                    lower[r, s, b] = t[b] / lower[s, s, b]
                elif t[b] > 0.0:
                    lower[r, r, b] = math.sqrt(t[b])
                else:
                    status[b] = INNOVATION_NOT_PD
                    lower[r, r, b] = 1.0
    for b in range(lanes):
        log_likelihood[b] = -m * HALF_LOG_TWO_PI
    for r in range(m):  # the whitened innovation L^-1 (z - H x)
        for b in range(lanes):
            innovation[r, b] = z[r, b] - x[mapping[r], b]
            t[b] = innovation[r, b]
        for k in range(r):
            for b in range(lanes):
                t[b] -= lower[r, k, b] * half[k, b]
        for b in range(lanes):
            half[r, b] = t[b] / lower[r, r, b]
            log_likelihood[b] -= 0.5 * half[r, b] * half[r, b] + math.log(lower[r, r, b])
    for a in range(d):  # row a of K = P H^T S^-1 solves L L^T K[a]^T = (H P)[:, a]
        for r in range(m):
            for b in range(lanes):
                t[b] = p[a, mapping[r], b]
            for k in range(r):
                for b in range(lanes):
                    t[b] -= lower[r, k, b] * half[k, b]
            for b in range(lanes):
                half[r, b] = t[b] / lower[r, r, b]
        for r in range(m - 1, -1, -1):
            for b in range(lanes):
                t[b] = half[r, b]
            for k in range(r + 1, m):
                for b in range(lanes):
                    t[b] -= lower[k, r, b] * gain[a, k, b]
            for b in range(lanes):
                gain[a, r, b] = t[b] / lower[r, r, b]
    _joseph(mapping, noise, x, p, innovation, gain, x_out, p_out)


@jit()
def _joseph(mapping, noise, x, p, innovation, gain, x_out, p_out):
    """``x_out = x + K v`` and ``p_out = (I - K H) P (I - K H)^T + K R K^T`` per lane, for
    the gains ``gain`` (d, m, L) and innovations ``innovation`` (m, L) of
    :func:`_select_update`."""
    d, lanes = x.shape
    m = mapping.size
    work, t = np.empty((d, d, lanes)), np.empty(lanes)
    for a in range(d):
        for b in range(lanes):
            t[b] = x[a, b]
        for r in range(m):
            for b in range(lanes):
                t[b] += gain[a, r, b] * innovation[r, b]
        for b in range(lanes):
            x_out[a, b] = t[b]
        for c in range(d):  # work = (I - K H) P
            for b in range(lanes):
                t[b] = p[a, c, b]
            for r in range(m):
                for b in range(lanes):
                    t[b] -= gain[a, r, b] * p[mapping[r], c, b]
            for b in range(lanes):
                work[a, c, b] = t[b]
    for a in range(d):
        for c in range(a + 1):
            for b in range(lanes):
                t[b] = work[a, c, b]
            for r in range(m):
                for b in range(lanes):
                    t[b] -= work[a, mapping[r], b] * gain[c, r, b]
            for r in range(m):
                for s in range(m):
                    for b in range(lanes):
                        t[b] += gain[a, r, b] * noise[r, s] * gain[c, s, b]
            for b in range(lanes):
                p_out[a, c, b] = t[b]
                p_out[c, a, b] = t[b]


@jit()
def _weighed(nb, predicted, log_likelihood, mu_out):
    """The posterior mode probabilities ``mu_out`` (M, B) of a block's filters from the
    predicted ones (M, B) and the models' log likelihoods (M, B), weighed in logs."""
    log_posterior = np.empty(predicted.shape)
    for j in range(predicted.shape[0]):
        for b in range(nb):
            log_posterior[j, b] = log_likelihood[j, b] + (
                math.log(predicted[j, b]) if predicted[j, b] > 0.0 else -np.inf)
    _normalised_block(nb, log_posterior, mu_out)


@jit()
def _merge_pairs(nb, matrix, mu, log_pair, x, p, x_out, p_out, mu_out):
    """GPB2's merge of the updated pairs ``x`` (d, M, M, B), ``p`` (d, d, M, M, B) with log
    likelihoods ``log_pair`` (M, M, B) (pair (i, j) at ``[j, i]``; the log priors are added
    in place) into each model j's posterior ``x_out[:, j]``, ``p_out[:, :, j]`` and the mode
    probabilities ``mu_out``."""
    d, models = x.shape[0], x.shape[1]
    everything = np.ones((models, d), dtype=np.bool_)
    weights, total = np.empty((models, nb)), np.empty(nb)
    top, log_posterior = np.empty(nb), np.empty((models, nb))
    for j in range(models):
        fill(top, -np.inf)
        for i in range(models):
            for b in range(nb):
                prior = matrix[i, j] * mu[i, b]
                log_pair[j, i, b] += math.log(prior) if prior > 0.0 else -np.inf
                top[b] = max(top[b], log_pair[j, i, b])
        for i in range(models):
            for b in range(nb):
                weights[i, b] = math.exp(log_pair[j, i, b] - top[b]) if top[b] > -np.inf \
                    else (i == j) * 1.0
        _normalise(nb, weights, total)
        for b in range(nb):
            log_posterior[j, b] = top[b] + math.log(total[b]) if top[b] > -np.inf else -np.inf
        _moment_match(nb, everything, j, weights, np.ascontiguousarray(x[:, j]),
                      np.ascontiguousarray(p[:, :, j]), x_out, p_out)
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
    model i's posterior and merges them by ``p_ij mu_i`` times their likelihoods (if no
    pair is reached, ``p_ij mu_i > 0``, model j's own). Mode probabilities are weighed in
    logs. Filters go in blocks (the loops over a block's lanes vectorise).

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
        model i is taken into model j's components (see the module) before it enters j.
    means, covars, probs : (K, M, d), (K, M, d, d), (K, M) float64
    z : (K, m) float64
    out_means, out_covars, out_probs : arrays of the shapes of the inputs
    status : (K,) int64
        OK, or INNOVATION_NOT_PD where a model's innovation covariance is not positive
        definite (its outputs are then partly written). The inputs' values are not
        checked here (:func:`step_inputs_valid` does).
    """
    per_block = max(1, FILTERS_PER_BLOCK // means.shape[1]) if algorithm == GPB2 \
        else FILTERS_PER_BLOCK
    for lo in range(0, means.shape[0], per_block):
        nb = min(per_block, means.shape[0] - lo)
        _step_block(nb, lo, algorithm, transitions, noises, mapping, noise, matrix, has,
                    means, covars, probs, z, out_means, out_covars, out_probs, status)


@jit()
def _step_block(nb, lo, algorithm, transitions, noises, mapping, noise, matrix, has, means,
                covars, probs, z, out_means, out_covars, out_probs, status):
    """:func:`imm_linear_step` on the block of filters ``lo:lo + nb``."""
    hi = lo + nb
    x, p, mu = _block(means, covars, probs, lo, hi)
    zb = np.empty((mapping.size, nb))
    _to_block(z, lo, hi, zb)
    fill(status[lo:hi], OK)
    d, models = x.shape[0], x.shape[1]
    pairs = models if algorithm == GPB2 else 1
    lanes = models * pairs * nb
    x0, p0 = np.empty((d, models, pairs * nb)), np.empty((d, d, models, pairs * nb))
    predicted = np.empty((models, nb))
    if algorithm == GPB2:
        _paired_priors(nb, has, x, p, x0, p0)
    else:
        _mixed_priors(nb, algorithm, matrix, has, x, p, mu, x0, p0, predicted)
    x_pred, p_pred = np.empty_like(x0), np.empty_like(p0)
    _predict_models(transitions, noises, x0, p0, x_pred, p_pred)
    log_likelihood = np.empty(lanes)
    _update_lanes(mapping, noise, x_pred.reshape((d, lanes)), p_pred.reshape((d, d, lanes)), zb,
                  x0.reshape((d, lanes)), p0.reshape((d, d, lanes)), log_likelihood,
                  status[lo:hi])  # the priors' arrays take the posteriors
    mu_out = np.empty_like(mu)
    if algorithm == GPB2:
        _merge_pairs(nb, matrix, mu, log_likelihood.reshape((models, models, nb)),
                     x0.reshape((d, models, models, nb)),
                     p0.reshape((d, d, models, models, nb)), x, p, mu_out)
        _unblock(x, p, mu_out, lo, hi, out_means, out_covars, out_probs)
    else:
        _weighed(nb, predicted, log_likelihood.reshape((models, nb)), mu_out)
        _unblock(x0, p0, mu_out, lo, hi, out_means, out_covars, out_probs)


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
    for lo in range(0, means.shape[0], FILTERS_PER_BLOCK):
        nb = min(FILTERS_PER_BLOCK, means.shape[0] - lo)
        _predict_block(nb, lo, transitions, noises, matrix, has, means, covars, probs,
                       out_means, out_covars, out_predicted, status)


@jit()
def _predict_block(nb, lo, transitions, noises, matrix, has, means, covars, probs, out_means,
                   out_covars, out_predicted, status):
    """:func:`imm_predict` on the block of filters ``lo:lo + nb``."""
    hi = lo + nb
    x, p, mu = _block(means, covars, probs, lo, hi)
    x_pred, p_pred, predicted = np.empty_like(x), np.empty_like(p), np.empty_like(mu)
    check = np.empty(covars.shape[2:])
    for k in range(lo, hi):
        status[k] = _covariances_code(covars[k], check)
    x0, p0 = np.empty_like(x), np.empty_like(p)
    _mixed_priors(nb, IMM, matrix, has, x, p, mu, x0, p0, predicted)
    _predict_models(transitions, noises, x0, p0, x_pred, p_pred)
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
    for lo in range(0, means.shape[0], FILTERS_PER_BLOCK):
        nb = min(FILTERS_PER_BLOCK, means.shape[0] - lo)
        _update_block(nb, lo, mapping, noise, means, covars, predicted, z, out_means,
                      out_covars, out_probs, status)


@jit()
def _update_block(nb, lo, mapping, noise, means, covars, predicted, z, out_means, out_covars,
                  out_probs, status):
    """:func:`imm_update` on the block of filters ``lo:lo + nb``."""
    hi = lo + nb
    x, p, c = _block(means, covars, predicted, lo, hi)
    zb = np.empty((mapping.size, nb))
    _to_block(z, lo, hi, zb)
    x_out, p_out, mu_out = np.empty_like(x), np.empty_like(p), np.empty_like(c)
    fill(status[lo:hi], OK)
    d, lanes = x.shape[0], c.size
    log_likelihood = np.empty(lanes)
    _update_lanes(mapping, noise, x.reshape((d, lanes)), p.reshape((d, d, lanes)), zb,
                  x_out.reshape((d, lanes)), p_out.reshape((d, d, lanes)), log_likelihood,
                  status[lo:hi])
    _weighed(nb, c, log_likelihood.reshape(c.shape), mu_out)
    _unblock(x_out, p_out, mu_out, lo, hi, out_means, out_covars, out_probs)
