"""The fixed-interval IMM smoother of Kim (1994) (:mod:`fasttrack.core.imm_smooth`) over K
tracks of filtered multiple-model states, one track a thread; its RTS steps are the RTS
smoother's (:mod:`smooth`)."""
import numpy as np

from .dispatch import jit, with_constant
from .linalg import _covariance_code_of
from .mixture import _moment_match_group
from .numeric import copy_into
from .smooth import _rts_prediction, _rts_smoothed
from .status import OK, PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC


#: The state dimension :func:`imm_smooth` is compiled for; 0: any (read from the arrays).
_DIMENSION = 0

#: The dimensions :func:`imm_smooth` has builds of its own (a planar position and velocity);
#: each costs seconds of compiling at install.
SMOOTH_DIMENSIONS = (4,)


def imm_smooth_kernel(d):
    """:func:`imm_smooth` compiled for states of dimension ``d`` (an int): its own build for
    those in :data:`SMOOTH_DIMENSIONS`, else the build for any dimension."""
    return with_constant(imm_smooth, "_DIMENSION", d) if d in SMOOTH_DIMENSIONS \
        else imm_smooth


@jit(inline=True)
def _every(has):
    """Whether every entry of the bool array ``has`` (M, d) is True."""
    for i in range(has.shape[0]):
        for a in range(has.shape[1]):
            if not has[i, a]:
                return False
    return True


@jit(inline=True)
def _union(means, covars, has, i, j, x, p):
    """Model i's state of one filter (``means`` (M, d), ``covars`` (M, d, d)) with the
    components model j has and i lacks taken from model j (its mean, and its covariances
    among them; none with i's), into ``x`` (d,) and ``p`` (d, d): what model j's dynamics
    act on when smoothing model i (a component neither has is 0)."""
    d = x.size
    for a in range(d):
        x[a] = means[i, a] if has[i, a] else (means[j, a] if has[j, a] else 0.0)
        for b in range(d):
            if has[i, a] and has[i, b]:
                p[a, b] = covars[i, a, b]
            elif not has[i, a] and not has[i, b] and has[j, a] and has[j, b]:
                p[a, b] = covars[j, a, b]
            else:
                p[a, b] = 0.0


@jit(inline=True)
def _seen_by(has, j, cross, pp):
    """The prediction through model j restricted to j's components (``has`` (M, d)): the
    others' columns of ``cross`` zeroed and their rows and columns of ``pp`` those of the
    identity, so that the gain ``cross pp^-1`` takes nothing from them."""
    d = pp.shape[0]
    for a in range(d):
        if has[j, a]:
            continue
        for b in range(d):
            cross[b, a] = 0.0
            pp[a, b] = pp[b, a] = 0.0
        pp[a, a] = 1.0


@jit(inline=True)
def _restricted(has, i, x, p):
    """``x`` (d,) and ``p`` (d, d) with the components model i lacks zeroed."""
    d = x.size
    for a in range(d):
        if has[i, a]:
            continue
        x[a] = 0.0
        for b in range(d):
            p[a, b] = p[b, a] = 0.0


@jit()
def _smooth_track(d, transitions, offsets, noises, linearisation, step, matrix, has, means,
                  covars, probs, out_means, out_covars, out_probs):
    """One track's backward pass (see :func:`imm_smooth`; ``linearisation`` (T, M) the
    track's) for states of dimension ``d``; returns its status."""
    n_times, models = means.shape[:2]
    cross, pp, chol = np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    gain, work = np.empty((d, d)), np.empty((d, d))
    every, x_union, p_union = _every(has), np.empty(d), np.empty((d, d))
    for t in range(n_times):
        for i in range(models):
            if _covariance_code_of(d, covars[t, i], chol, PRIOR_NOT_SYMMETRIC,
                                   PRIOR_NOT_PSD) != OK:
                return -(1 + t * models + i)
    xp, inverse, diff = np.empty(d), np.empty(d), np.empty(d)
    pair_means, pair_covars = np.empty((models, d)), np.empty((models, d, d))
    ratio, weights = np.empty(models), np.empty(models)
    reached = np.empty(models, dtype=np.int64)
    copy_into(means[-1], out_means[-1])
    copy_into(covars[-1], out_covars[-1])
    copy_into(probs[-1], out_probs[-1])
    for t in range(n_times - 2, -1, -1):
        v = step[t]
        for j in range(models):  # smoothed over predicted probability of model j at t + 1
            predicted = 0.0
            for i in range(models):
                predicted += matrix[i, j] * probs[t, i]
            ratio[j] = out_probs[t + 1, j] / predicted if predicted > 0.0 else 0.0
        norm = 0.0
        for i in range(models):
            total = 0.0
            for j in range(models):
                weights[j] = matrix[i, j] * ratio[j]
                total += weights[j]
            out_probs[t, i] = probs[t, i] * total
            norm += out_probs[t, i]
            if not total > 0.0:  # no future reached from model i: its filtered state stays
                copy_into(means[t, i], out_means[t, i])
                copy_into(covars[t, i], out_covars[t, i])
                continue
            u, count = linearisation[t, i], 0
            for j in range(models):
                if weights[j] == 0.0:
                    continue
                reached[count] = j
                count += 1
                x, p = means[t, i], covars[t, i]
                if not every:
                    _union(means[t], covars[t], has, i, j, x_union, p_union)
                    x, p = x_union, p_union
                _rts_prediction(d, transitions[u, j], noises[v, j], x, p, cross, xp, pp)
                for a in range(d):
                    xp[a] += offsets[u, j, a]
                if not every:
                    _seen_by(has, j, cross, pp)
                if not _rts_smoothed(d, x, p, cross, xp, pp, out_means[t + 1, j],
                                     out_covars[t + 1, j], chol, inverse, diff, gain, work,
                                     pair_means[j], pair_covars[j]):
                    return 1 + t
                if not every:
                    _restricted(has, i, pair_means[j], pair_covars[j])
            _moment_match_group(pair_means, pair_covars, weights, reached, count,
                                out_means[t, i], out_covars[t, i])
        for i in range(models):
            out_probs[t, i] /= norm
    return 0


@jit()
def imm_smooth(transitions, offsets, noises, linearisation, step, matrix, has, means, covars,
               probs, out_means, out_covars, out_probs, status):
    """The fixed-interval IMM smoother of Kim (1994) over K tracks of T filtered IMM states
    of M models, each linear or linearised (the array layer runs chunks of the tracks on
    threads).

    Backwards from the last time, with ``c_j = sum_i p_ij mu_i(t)`` the predicted
    probability of model j at t + 1: the smoothed probability of model i at t is
    ``mu_i(t|T) = mu_i(t) sum_j p_ij mu_j(t+1|T) / c_j``; its smoothed state is the
    moment match over j, with weights ``p_ij mu_j(t+1|T) / c_j``, of one RTS step from
    model i's filtered state through model j's transition ``x -> F x + b`` (and Q) to model
    j's smoothed state at t + 1. Where the models have different components (``has``),
    that step starts from model i's state with the components it lacks and model j has
    taken from model j (as the forward mixing takes them), learns from model j's smoothed
    components only (model i's others follow by their correlations), and keeps model i's
    components.

    Parameters
    ----------
    transitions : (U, M, d, d) float64
        Each model's F in each of U linearisations (for linear models, one an interval).
    offsets : (U, M, d) float64
        Each model's b in each linearisation (0 for linear models).
    noises : (V, M, d, d) float64
        Each model's Q over each distinct interval.
    linearisation : (K, T, M) int64
        The linearisation (index into ``transitions``) of the step from t to t + 1 from
        model i's filtered state of track k (the last time unused).
    step : (T,) int64
        ``step[t]``: the interval index (into ``noises``) of the step from t to t + 1 (the
        last unused).
    matrix : (M, M) float64
        ``matrix[i, j]``: the probability of switching from model i to model j.
    has : (M, d) bool
        The state components of each model (its arrays' others are 0).
    means, covars, probs : (K, T, M, d), (K, T, M, d, d), (K, T, M) float64
        The filtered states and mode probabilities.
    out_means, out_covars, out_probs : arrays of the shapes of the inputs
    status : (K,) int64
        0; ``1 + t`` for the first time t of the track whose prediction to t + 1 (from one
        model through another) is not positive definite; ``-(1 + t M + i)`` for the first
        filtered covariance (time t, model i) that is not symmetric positive semi-definite.
        The outputs of a track of non-zero status are partly written.
    """
    d = means.shape[3] if _DIMENSION == 0 else _DIMENSION
    if means.shape[3] != d:
        raise ValueError("imm_smooth: the states must have this build's dimension")
    for k in range(means.shape[0]):
        status[k] = _smooth_track(d, transitions, offsets, noises, linearisation[k], step,
                                  matrix, has, means[k], covars[k], probs[k], out_means[k],
                                  out_covars[k], out_probs[k])
