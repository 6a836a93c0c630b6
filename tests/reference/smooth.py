"""Mirrors of ``fasttrack._jit.smooth``: the Rauch-Tung-Striebel smoother and
forward-filter backward-simulation."""
import numpy as np


def rts(x, covar, x_pred, covar_pred, recompute, matrix, noise, step, x_out, covar_out):
    n_tracks, n_times, d = x.shape
    for k in range(n_tracks):
        for t in range(n_times):
            c = covar[k, t]
            if not (np.isfinite(c).all() and np.abs(c - c.T).max() <= 1e-9 * np.abs(c).max()
                    and np.linalg.eigvalsh(c).min() >= -1e-10 * max(c.diagonal().max(), 0)):
                return -(1 + k * n_times + t)
        x_out[k, -1] = x[k, -1]
        covar_out[k, -1] = covar[k, -1]
        for t in range(n_times - 2, -1, -1):
            f, q = matrix[step[t]], noise[step[t]]
            if recompute[t + 1] == 1:
                xp = f @ x[k, t]
                pp = f @ covar[k, t] @ f.T + q
            elif recompute[t + 1] == 2:
                xp, pp = x_out[k, t + 1], covar_out[k, t + 1]
            else:
                xp, pp = x_pred[k, t + 1], covar_pred[k, t + 1]
            if np.any(np.linalg.eigvalsh(pp) <= 0):
                return 1 + k * n_times + t + 1
            gain = covar[k, t] @ f.T @ np.linalg.inv(pp)
            x_out[k, t] = x[k, t] + gain @ (x_out[k, t + 1] - xp)
            c = covar[k, t] + gain @ (covar_out[k, t + 1] - pp) @ gain.T
            covar_out[k, t] = (c + c.T) / 2
    return 0


def _ffbs_categorical(logw, u):
    """The first index whose cumulative weight ``exp(logw - max)`` exceeds ``u`` times the
    total, or the last of positive weight."""
    w = np.exp(logw - logw.max())
    cumulative = np.cumsum(w)
    i = np.searchsorted(cumulative, u * cumulative[-1], side="right")
    return i if i < logw.size else np.flatnonzero(w > 0)[-1]


def ffbs(states, log_weights, mean_next, precision_root, rng, max_proposals,
         min_acceptance, out_index):
    n_times, n_paths = out_index.shape
    for m in range(n_paths):
        out_index[-1, m] = _ffbs_categorical(log_weights[-1], rng.random())
    for t in range(n_times - 2, -1, -1):
        accepted = proposed = 0
        for m in range(n_paths):
            diff = states[t + 1][:, [out_index[t + 1, m]]] - mean_next[t]
            quad = ((np.tril(precision_root[t]) @ diff) ** 2).sum(axis=0)
            i = None
            for _ in range(max_proposals if accepted + 1 >= proposed * min_acceptance else 0):
                proposed += 1
                proposal = _ffbs_categorical(log_weights[t], rng.random())
                if rng.random() < np.exp(-0.5 * quad[proposal]):
                    accepted, i = accepted + 1, proposal
                    break
            if i is None:
                i = _ffbs_categorical(log_weights[t] - 0.5 * quad, rng.random())
            out_index[t, m] = i
    return 0
