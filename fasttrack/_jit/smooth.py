"""Rauch-Tung-Striebel (Kalman) smoothing: the backward pass over a whole track, or over a
batch of K tracks of equal length, in one call."""
import numpy as np

from .dispatch import jit, with_constant
from .linalg import _covariance_code_of
from .status import PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC
from .numeric import fast_exp
from .tunables import FFBS_BLOCK as _BLOCK
from .tunables import MAX_PROPOSALS, PROPOSAL_COST, UNROLLED_DIMENSIONS


#: The state dimension :func:`rts` is compiled for; 0: any (read from the arrays).
_DIMENSION = 0


def rts_kernel(d):
    """:func:`rts` compiled for states of dimension ``d`` (an int): its own build for
    those in :data:`UNROLLED_DIMENSIONS`, else the build for any dimension."""
    return with_constant(rts, "_DIMENSION", d) if d in UNROLLED_DIMENSIONS else rts


@jit()
def rts(x, covar, x_pred, covar_pred, recompute, matrix, noise, step, x_out, covar_out):
    """Backward Rauch-Tung-Striebel pass over K tracks of T states of dimension d.

    ``x`` (K, T, d) and ``covar`` (K, T, d, d) are the filtered states; ``x_pred`` and
    ``covar_pred`` (same shapes) the predictions at each time t (from t - 1; index 0 is
    unused). Where ``recompute[t]`` (T,) is 1, the prediction at t is computed here
    instead, ``F x[t-1]`` and ``F covar[t-1] F^T + Q``; where it is 2, the smoothed state at
    t stands for it (Stone Soup's reading of a prediction in a track, which leaves the state
    before it unsmoothed). ``matrix`` and ``noise`` (U, d, d)
    hold the transition matrices F (Jacobians) and noise covariances Q, and ``step`` (T,)
    int64 names for each t < T - 1 the pair that leads from t to t + 1. Smoothed states go to
    ``x_out`` and ``covar_out``; the gain is ``G = covar[t] F^T covar_pred[t+1]^{-1}``
    (through a Cholesky factor). Returns 0; or 1 + (k * T + t) for the first prediction
    (track k, time t) whose covariance is not positive definite, -(1 + (k * T + t)) for the
    first filtered covariance that is not symmetric positive semi-definite (then the
    outputs are partial).
    """
    n_tracks, n_times = x.shape[0], x.shape[1]
    d = x.shape[2] if _DIMENSION == 0 else _DIMENSION
    if x.shape[2] != d or matrix.shape[1] != d or matrix.shape[2] != d \
            or noise.shape[1] != d or noise.shape[2] != d:
        raise ValueError("rts: the states, matrices and noises must all have this build's "
                         "dimension")
    xp = np.empty(d)
    pp = np.empty((d, d))
    chol = np.empty((d, d))
    gain = np.empty((d, d))
    work = np.empty((d, d))
    cross = np.empty((d, d))
    diff = np.empty(d)
    inverse = np.empty(d)
    for k in range(n_tracks):
        for t in range(n_times):
            if _covariance_code_of(d, covar[k, t], chol, PRIOR_NOT_SYMMETRIC,
                                   PRIOR_NOT_PSD) != 0:
                return -(1 + k * n_times + t)
        last = n_times - 1
        for i in range(d):
            x_out[k, last, i] = x[k, last, i]
            for j in range(d):
                covar_out[k, last, i, j] = covar[k, last, i, j]
        for t in range(n_times - 2, -1, -1):
            u = step[t]
            xs = x_out[k, t + 1]
            ps = covar_out[k, t + 1]
            if recompute[t + 1] == 1:
                _rts_prediction(d, matrix[u], noise[u], x[k, t], covar[k, t], cross, xp, pp)
            else:
                _cross_covariance(d, covar[k, t], matrix[u], cross)
                source_x = xs if recompute[t + 1] == 2 else x_pred[k, t + 1]
                source_p = ps if recompute[t + 1] == 2 else covar_pred[k, t + 1]
                for i in range(d):
                    xp[i] = source_x[i]
                    for j in range(d):
                        pp[i, j] = source_p[i, j]
            if not _rts_smoothed(d, x[k, t], covar[k, t], cross, xp, pp, xs, ps, chol, inverse,
                                diff, gain, work, x_out[k, t], covar_out[k, t]):
                return 1 + k * n_times + t + 1
    return 0


@jit(inline=True)
def _cross_covariance(d, p, f, cross):
    """``cross = P F^T`` (d, d): the covariance of the state and its prediction."""
    for i in range(d):
        for j in range(d):
            acc = 0.0
            for l in range(d):
                acc += p[i, l] * f[j, l]
            cross[i, j] = acc


@jit(inline=True)
def _rts_prediction(d, f, q, x, p, cross, xp, pp):
    """The one-step prediction of ``(x, P)`` through ``(F, Q)``: ``cross = P F^T``,
    ``xp = F x`` and ``pp = F P F^T + Q``."""
    _cross_covariance(d, p, f, cross)
    for i in range(d):
        acc = 0.0
        for l in range(d):
            acc += f[i, l] * x[l]
        xp[i] = acc
    for i in range(d):
        for j in range(d):
            acc = 0.0
            for l in range(d):
                acc += f[i, l] * cross[l, j]
            pp[i, j] = acc + q[i, j]


@jit(inline=True)
def _rts_smoothed(d, x, p, cross, xp, pp, xs, ps, chol, inverse, diff, gain, work, x_out,
                 p_out):
    """One RTS step: the filtered ``(x, P)`` with cross covariance ``cross = P F^T``,
    prediction ``(xp, pp)`` and smoothed successor ``(xs, ps)`` give the smoothed
    ``x_out = x + G (xs - xp)`` and ``p_out = P + G (ps - pp) G^T`` (symmetric), with
    ``G = cross pp^{-1}``. Returns False, writing nothing, if ``pp`` is not positive
    definite. ``chol``, ``gain``, ``work`` (d, d), ``inverse`` and ``diff`` (d,) are
    scratch."""
    for j in range(d):  # Cholesky of pp into chol, inline: a build's constant d unrolls it
        s = pp[j, j]
        for l in range(j):
            s -= chol[j, l] * chol[j, l]
        if not s > 0.0:
            return False
        chol[j, j] = np.sqrt(s)
        inverse[j] = 1.0 / chol[j, j]
        for i in range(j + 1, d):
            s = pp[i, j]
            for l in range(j):
                s -= chol[i, l] * chol[j, l]
            chol[i, j] = s * inverse[j]
    for r in range(d):  # gain rows: solve pp g = cross[r, :]
        for j in range(d):
            diff[j] = cross[r, j]
        for j in range(d):  # forward substitution L y = b
            s = diff[j]
            for l in range(j):
                s -= chol[j, l] * diff[l]
            diff[j] = s * inverse[j]
        for j in range(d - 1, -1, -1):  # back substitution L^T g = y
            s = diff[j]
            for l in range(j + 1, d):
                s -= chol[l, j] * diff[l]
            diff[j] = s * inverse[j]
        for j in range(d):
            gain[r, j] = diff[j]
    for j in range(d):
        diff[j] = xs[j] - xp[j]
    for i in range(d):
        acc = x[i]
        for l in range(d):
            acc += gain[i, l] * diff[l]
        x_out[i] = acc
    for i in range(d):
        for j in range(d):
            acc = 0.0
            for l in range(d):
                acc += gain[i, l] * (ps[l, j] - pp[l, j])
            work[i, j] = acc
    for i in range(d):
        for j in range(i, d):
            acc = p[i, j]
            for l in range(d):
                acc += work[i, l] * gain[j, l]
            p_out[i, j] = acc
            p_out[j, i] = acc
    return True


#: Below this, a sum of weights taken relative to a bound of their maximum may have lost
#: bits to underflow; they are then taken relative to their maximum.
_TINY = 1e-280


@jit()
def _top(values):
    """The largest of ``values`` (``-inf`` if empty or all ``-inf``)."""
    top = -np.inf
    for i in range(values.size):
        top = max(top, values[i])
    return top


@jit()
def _cumulate(logw, cumulative):
    """Fill ``cumulative`` (N,) with the running sums of the weights ``exp(logw - max)``
    (zero where ``logw`` is ``-inf``); return the index of the last particle of positive
    weight."""
    top = _top(logw)
    total = 0.0
    last = 0
    for i in range(logw.size):
        w = fast_exp(logw[i] - top)
        if w > 0.0:
            last = i
        total += w
        cumulative[i] = total
    return last


@jit()
def _search(cumulative, last, u):
    """The first index whose cumulative weight exceeds ``u`` (in [0, 1)) times the total,
    found by bisection; ``last`` if rounding puts none above it."""
    target = u * cumulative[cumulative.size - 1]
    lo, hi = 0, cumulative.size
    while lo < hi:
        mid = (lo + hi) // 2
        above = cumulative[mid] > target
        hi = mid if above else hi
        lo = lo if above else mid + 1
    return lo if lo < cumulative.size else last


@jit()
def _block_sums(weights, sums):
    """``sums[b]``: the sum of block b of ``weights`` (:data:`_BLOCK` of them); returns the
    total."""
    for b in range(sums.size):
        part = weights[b * _BLOCK:(b + 1) * _BLOCK]
        acc = 0.0
        for i in range(part.size):
            acc += part[i]
        sums[b] = acc
    total = 0.0
    for b in range(sums.size):
        total += sums[b]
    return total


@jit()
def _block_search(weights, sums, target):
    """The first index at which the running sum of ``weights`` exceeds ``target``, found
    through the block sums (see :func:`_block_sums`); the last of positive weight if
    rounding puts none above it."""
    acc = 0.0
    for b in range(sums.size):
        if acc + sums[b] <= target:
            acc += sums[b]
            continue
        part = weights[b * _BLOCK:(b + 1) * _BLOCK]
        for i in range(part.size):
            acc += part[i]
            if acc > target:
                return b * _BLOCK + i
    last = weights.size - 1
    while last > 0 and not weights[last] > 0.0:
        last -= 1
    return last


@jit()
def _whiten(root, x, out):
    """``out = root @ x`` for a lower-triangular ``root`` (d, d) and ``x`` (d, N)."""
    for r in range(root.shape[0]):
        row = out[r]
        for i in range(row.size):
            row[i] = root[r, 0] * x[0, i]
        for c in range(1, r + 1):
            a, column = root[r, c], x[c]
            for i in range(row.size):
                row[i] += a * column[i]


@jit()
def _distance(point, whitened, i):
    """``|point - whitened[:, i]|^2``: the exponent, times -2, of the transition density
    from particle i to the point (both whitened)."""
    quad = 0.0
    for r in range(point.size):
        quad += (point[r] - whitened[r, i]) ** 2
    return quad


@jit()
def _rejection_draw(cumulative, last, point, whitened, rng, max_proposals):
    """Up to ``max_proposals`` particles proposed by filter weight (``cumulative``, see
    :func:`_cumulate`), each accepted with probability ``exp(-quad / 2)``, the transition
    density over its maximum; the accepted index (or -1 if all were rejected) and the number
    of proposals made."""
    for k in range(max_proposals):
        i = _search(cumulative, last, rng.random())
        if rng.random() < fast_exp(-0.5 * _distance(point, whitened, i)):
            return i, k + 1
    return -1, max_proposals


@jit()
def _backward_weights(log_weights, shift, point, whitened, out):
    """``out[i] = exp(log_weights[i] - shift - |point - whitened[:, i]|^2 / 2)``."""
    for i in range(out.size):
        out[i] = log_weights[i] - shift
    for r in range(point.size):
        p, row = point[r], whitened[r]
        for i in range(out.size):
            out[i] -= 0.5 * (p - row[i]) ** 2
    for i in range(out.size):
        out[i] = fast_exp(out[i])


@jit()
def _backward_top(log_weights, point, whitened):
    """The largest of ``log_weights[i] - |point - whitened[:, i]|^2 / 2``."""
    top = -np.inf
    for i in range(log_weights.size):
        top = max(top, log_weights[i] - 0.5 * _distance(point, whitened, i))
    return top


@jit()
def _exact_draw(log_weights, top, point, whitened, weights, sums, u):
    """The index drawn by ``u`` with weight ``exp(log_weights[i] - |point - whitened[:, i]|^2
    / 2)``; ``top`` is the largest of ``log_weights``, ``weights`` (N,) and ``sums``
    (N / :data:`_BLOCK` rounded up) work space."""
    _backward_weights(log_weights, top, point, whitened, weights)
    total = _block_sums(weights, sums)
    if not total > _TINY:
        _backward_weights(log_weights, _backward_top(log_weights, point, whitened), point,
                          whitened, weights)
        total = _block_sums(weights, sums)
    return _block_search(weights, sums, u * total)


@jit()
def ffbs(states, log_weights, mean_next, precision_root, rng, max_proposals,
         min_acceptance, out_index):
    """Backward simulation (forward-filter backward-simulation) of M paths through T
    particle sets of N particles.

    ``states`` (T, d, N) and ``log_weights`` (T, N) are the filter's posteriors;
    ``mean_next`` (T - 1, d, N) the noise-free transition of each particle of time t to
    t + 1, and ``precision_root`` (T - 1, d, d) the inverse of a Cholesky factor of that
    step's noise covariance (``L^{-1}`` for ``Q = L L^T``), so that the transition density
    is proportional to ``exp(-|L^{-1} (x' - f(x))|^2 / 2)``. The particle index of path m at
    time t goes to ``out_index[t, m]`` (T, M): at T - 1 drawn by weight; before, given the
    particle j at t + 1, with weight ``w_t^i p(x_{t+1}^j | x_t^i)``: first by rejection
    from the filter weights (:func:`_rejection_draw`, up to ``max_proposals`` proposals),
    then, if all were rejected, exactly (:func:`_exact_draw`, O(N)); both give the same
    distribution. Rejection stops for the rest of a step once the acceptance rate of its
    proposals there, counted as ``(accepted + 1) / proposed``, falls below
    ``min_acceptance`` (the decision for a path depends only on the paths before it, so
    each draw stays exact). The uniforms come from ``rng`` (a numpy.random.Generator, its
    ``random()`` called in order of decreasing t, then increasing m): one per draw by
    weight, two per proposal. A uniform at or beyond the last cumulative weight takes the
    last particle of positive weight, so rounding never indexes out of range.
    """
    n_times, d, n = states.shape
    n_paths = out_index.shape[1]
    cumulative = np.empty(n)
    weights = np.empty(n)
    sums = np.empty((n + _BLOCK - 1) // _BLOCK)
    whitened = np.empty((d, n))
    column = np.empty((d, 1))
    point = column[:, 0]
    last = _cumulate(log_weights[n_times - 1], cumulative)
    for m in range(n_paths):
        out_index[n_times - 1, m] = _search(cumulative, last, rng.random())
    for t in range(n_times - 2, -1, -1):
        last = _cumulate(log_weights[t], cumulative)
        top = _top(log_weights[t])
        _whiten(precision_root[t], mean_next[t], whitened)
        accepted, proposed = 0, 0
        for m in range(n_paths):
            x_next = states[t + 1, :, out_index[t + 1, m]:out_index[t + 1, m] + 1]
            _whiten(precision_root[t], x_next, column)
            chosen, tries = -1, 0
            if accepted + 1 >= proposed * min_acceptance:
                chosen, tries = _rejection_draw(cumulative, last, point, whitened, rng,
                                                max_proposals)
            accepted, proposed = accepted + (chosen >= 0), proposed + tries
            if chosen < 0:
                chosen = _exact_draw(log_weights[t], top, point, whitened, weights, sums,
                                     rng.random())
            out_index[t, m] = chosen
    return 0
