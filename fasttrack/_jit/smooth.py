"""Rauch-Tung-Striebel (Kalman) smoothing: the backward pass over a whole track, or over a
batch of K tracks of equal length, in one call."""
import numpy as np

from . import jit


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
    (through a Cholesky factor). Returns 0, or 1 + (k * T + t) for the first prediction
    (track k, time t) whose covariance is not positive definite (then the outputs are
    partial).
    """
    n_tracks, n_times, d = x.shape
    xp = np.empty(d)
    pp = np.empty((d, d))
    chol = np.empty((d, d))
    gain = np.empty((d, d))
    work = np.empty((d, d))
    cross = np.empty((d, d))
    diff = np.empty(d)
    inverse = np.empty(d)
    for k in range(n_tracks):
        last = n_times - 1
        for i in range(d):
            x_out[k, last, i] = x[k, last, i]
            for j in range(d):
                covar_out[k, last, i, j] = covar[k, last, i, j]
        for t in range(n_times - 2, -1, -1):
            u = step[t]
            f = matrix[u]
            q = noise[u]
            p = covar[k, t]
            xt = x[k, t]
            xs = x_out[k, t + 1]
            ps = covar_out[k, t + 1]
            # cross = P F^T (the gain's numerator; F cross + Q is the prediction)
            for i in range(d):
                for j in range(d):
                    acc = 0.0
                    for l in range(d):
                        acc += p[i, l] * f[j, l]
                    cross[i, j] = acc
            # the prediction at t + 1
            if recompute[t + 1] == 1:
                for i in range(d):
                    acc = 0.0
                    for l in range(d):
                        acc += f[i, l] * xt[l]
                    xp[i] = acc
                for i in range(d):
                    for j in range(d):
                        acc = 0.0
                        for l in range(d):
                            acc += f[i, l] * cross[l, j]
                        pp[i, j] = acc + q[i, j]
            elif recompute[t + 1] == 2:
                for i in range(d):
                    xp[i] = xs[i]
                    for j in range(d):
                        pp[i, j] = ps[i, j]
            else:
                for i in range(d):
                    xp[i] = x_pred[k, t + 1, i]
                    for j in range(d):
                        pp[i, j] = covar_pred[k, t + 1, i, j]
            # Cholesky factor of the predicted covariance (lower triangle of chol)
            for j in range(d):
                s = pp[j, j]
                for l in range(j):
                    s -= chol[j, l] * chol[j, l]
                if not s > 0.0:
                    return 1 + k * n_times + t + 1
                chol[j, j] = np.sqrt(s)
                inverse[j] = 1.0 / chol[j, j]
                for i in range(j + 1, d):
                    s = pp[i, j]
                    for l in range(j):
                        s -= chol[i, l] * chol[j, l]
                    chol[i, j] = s * inverse[j]
            # gain rows: solve pp g = (P F^T)[r, :] for each row r
            for r in range(d):
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
            # smoothed mean
            for j in range(d):
                diff[j] = xs[j] - xp[j]
            for i in range(d):
                acc = xt[i]
                for l in range(d):
                    acc += gain[i, l] * diff[l]
                x_out[k, t, i] = acc
            # smoothed covariance P + G (Ps - Pp) G^T, symmetric by construction
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
                    covar_out[k, t, i, j] = acc
                    covar_out[k, t, j, i] = acc
    return 0


@jit()
def ffbs(states, log_weights, mean_next, precision_root, uniforms, out_index):
    """Backward simulation (forward-filter backward-simulation) of M paths through T
    particle sets of N particles.

    ``states`` (T, d, N) and ``log_weights`` (T, N) are the filter's posteriors;
    ``mean_next`` (T - 1, d, N) the noise-free transition of each particle of time t to
    t + 1, and ``precision_root`` (T - 1, d, d) the inverse of a Cholesky factor of that
    step's noise covariance (``L^{-1}`` for ``Q = L L^T``), so that the transition density
    is proportional to ``exp(-|L^{-1} (x' - f(x))|^2 / 2)``. ``uniforms`` (T, M) in [0, 1)
    drive the draws; the particle index of path m at time t goes to ``out_index[t, m]``.
    A uniform at or beyond the last cumulative weight takes the last particle of nonzero
    weight, so rounding never indexes out of range.
    """
    n_times, d, n = states.shape
    n_paths = uniforms.shape[1]
    logw = np.empty(n)
    cumulative = np.empty(n)
    diff = np.empty(d)
    for m in range(n_paths):
        for t in range(n_times - 1, -1, -1):
            top = -np.inf
            if t == n_times - 1:
                for i in range(n):
                    logw[i] = log_weights[t, i]
                    if logw[i] > top:
                        top = logw[i]
            else:
                j = out_index[t + 1, m]
                for i in range(n):
                    if log_weights[t, i] == -np.inf:
                        logw[i] = -np.inf
                        continue
                    for r in range(d):
                        diff[r] = states[t + 1, r, j] - mean_next[t, r, i]
                    quad = 0.0
                    for r in range(d):
                        acc = 0.0
                        for c in range(r + 1):
                            acc += precision_root[t, r, c] * diff[c]
                        quad += acc * acc
                    logw[i] = log_weights[t, i] - 0.5 * quad
                    if logw[i] > top:
                        top = logw[i]
            total = 0.0
            last = 0
            for i in range(n):
                if logw[i] > -np.inf:
                    total += np.exp(logw[i] - top)
                    last = i
                cumulative[i] = total
            target = uniforms[t, m] * total
            chosen = last
            for i in range(n):
                if cumulative[i] > target:
                    chosen = i
                    break
            out_index[t, m] = chosen
    return 0
