"""The IMM step of K filters of M linear models and a sensor that selects state components
(:mod:`fasttrack.core.imm`), one filter a thread: mix, predict (F, Q a model), update in the
Joseph form, weigh the models in logs. A filter whose step is undefined gets a status code
and the array layer reports it."""
import math

import numpy as np
from numba import prange

from .dispatch import jit
from .linalg import _covariance_code
from .numeric import cholesky
from .status import INNOVATION_NOT_PD, OK, PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC

#: log(2 pi) / 2
HALF_LOG_TWO_PI = 0.9189385332046727


@jit()
def _mixed(matrix, probs, means, covars, j, predicted, x0, p0):
    """Model j's mixed prior of one filter into ``x0`` (d,) and ``p0`` (d, d), its
    predicted probability ``predicted`` (a model of probability 0 keeps its own state)."""
    models, d = means.shape
    for a in range(d):
        x0[a] = 0.0
        for b in range(d):
            p0[a, b] = 0.0
    for i in range(models):
        w = (i == j) * 1.0 if predicted <= 0.0 else matrix[i, j] * probs[i] / predicted
        if w == 0.0:
            continue
        for a in range(d):
            x0[a] += w * means[i, a]
    for i in range(models):
        w = (i == j) * 1.0 if predicted <= 0.0 else matrix[i, j] * probs[i] / predicted
        if w == 0.0:
            continue
        for a in range(d):
            da = means[i, a] - x0[a]
            for b in range(d):
                p0[a, b] += w * (covars[i, a, b] + da * (means[i, b] - x0[b]))
    for a in range(d):
        for b in range(a):
            p0[a, b] = p0[b, a] = 0.5 * (p0[a, b] + p0[b, a])


@jit()
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
def _update(mapping, noise, x, p, z, x_out, p_out, lower, gain, work):
    """The Joseph-form update of ``(x, p)`` with ``z`` by the sensor selecting ``mapping``
    (noise R) into ``(x_out, p_out)``; returns the measurement's log likelihood, or NaN if
    the innovation covariance is not positive definite. ``lower`` (m, m), ``gain`` (d, m)
    and ``work`` (d, d) are scratch."""
    d, m = x.size, mapping.size
    s = np.empty((m, m))
    for r in range(m):
        for c in range(m):
            s[r, c] = p[mapping[r], mapping[c]] + noise[r, c]
    if not cholesky(s, lower):
        return np.nan
    innovation, v = np.empty(m), np.empty(m)
    for r in range(m):  # v = L^-1 (z - H x)
        innovation[r] = z[r] - x[mapping[r]]
        t = innovation[r]
        for c in range(r):
            t -= lower[r, c] * v[c]
        v[r] = t / lower[r, r]
    log_likelihood = -m * HALF_LOG_TWO_PI
    for r in range(m):
        log_likelihood -= 0.5 * v[r] * v[r] + math.log(lower[r, r])
    for a in range(d):  # K = P H^T S^-1: solve L (L^T K^T) = H P for each row a of K
        row = np.empty(m)
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


@jit()
def _filter_step(transitions, noises, mapping, noise, matrix, means, covars, probs, z,
                 out_means, out_covars, out_probs):
    """One filter's IMM step (see :func:`imm_linear_step`); returns its status."""
    models, d = means.shape
    m = mapping.size
    x0, p0 = np.empty(d), np.empty((d, d))
    x, p, work = np.empty(d), np.empty((d, d)), np.empty((d, d))
    lower, gain, scratch = np.empty((m, m)), np.empty((d, m)), np.empty((d, d))
    log_posterior = np.empty(models)
    top = -np.inf
    for j in range(models):
        predicted = 0.0
        for i in range(models):
            predicted += matrix[i, j] * probs[i]
        _mixed(matrix, probs, means, covars, j, predicted, x0, p0)
        code = _covariance_code(p0, scratch, PRIOR_NOT_SYMMETRIC, PRIOR_NOT_PSD)
        if code != OK:
            return code
        _predict(transitions[j], noises[j], x0, p0, x, p, work)
        log_likelihood = _update(mapping, noise, x, p, z, out_means[j], out_covars[j], lower,
                                 gain, work)
        if log_likelihood != log_likelihood:
            return INNOVATION_NOT_PD
        log_posterior[j] = (math.log(predicted) + log_likelihood) if predicted > 0.0 \
            else -np.inf
        top = max(top, log_posterior[j])
    total = 0.0
    for j in range(models):
        total += math.exp(log_posterior[j] - top)
    for j in range(models):
        out_probs[j] = math.exp(log_posterior[j] - top) / total
    return OK


@jit(parallel=True, size=5)
def imm_linear_step(transitions, noises, mapping, noise, matrix, means, covars, probs, z,
                    out_means, out_covars, out_probs, status):
    """One IMM step of K filters of M linear models sharing one interval.

    Parameters
    ----------
    transitions, noises : (M, d, d) float64
        Each model's F and Q over the interval.
    mapping : (m,) int64
        The state components the sensor measures; ``noise`` (m, m) is its R.
    matrix : (M, M) float64
        ``matrix[i, j]``: the probability of switching from model i to model j.
    means, covars, probs : (K, M, d), (K, M, d, d), (K, M) float64
    z : (K, m) float64
    out_means, out_covars, out_probs : arrays of the shapes of the inputs
    status : (K,) int64
        OK, or why the filter's step is undefined (its outputs are then partly written).
    """
    for k in prange(means.shape[0]):
        status[k] = _filter_step(transitions, noises, mapping, noise, matrix, means[k],
                                 covars[k], probs[k], z[k], out_means[k], out_covars[k],
                                 out_probs[k])
