"""Mirror of ``fasttrack._jit.imm_smooth``: Kim's IMM smoother track by track, pair by
pair, with NumPy's linear algebra."""
import numpy as np


def _union(x, p, has, i, j):
    """Model i's state with what model j has and i lacks from model j, index by index."""
    ours, theirs = np.flatnonzero(has[i]), np.flatnonzero(has[j] & ~has[i])
    xu, pu = np.zeros(x.shape[1]), np.zeros(p.shape[1:])
    xu[ours], xu[theirs] = x[i, ours], x[j, theirs]
    pu[np.ix_(ours, ours)] = p[i][np.ix_(ours, ours)]
    pu[np.ix_(theirs, theirs)] = p[j][np.ix_(theirs, theirs)]
    return xu, pu


def imm_smooth(transitions, offsets, noises, linearisation, step, matrix, has, means, covars,
               probs, out_means, out_covars, out_probs, status):
    """Kim's smoother track by track, pair by pair, with explicit inverses; a pair's RTS
    step on model j's components (rows of the gain) seen by j, kept on model i's."""
    n_tracks, n_times, models, d = means.shape
    for k in range(n_tracks):
        status[k] = 0
        x, p, mu = means[k], covars[k], probs[k]
        xs, ps, mus = out_means[k], out_covars[k], out_probs[k]
        xs[-1], ps[-1], mus[-1] = x[-1], p[-1], mu[-1]
        for t in range(n_times - 2, -1, -1):
            q = noises[step[t]]
            predicted = mu[t] @ matrix
            ratio = np.divide(mus[t + 1], predicted, out=np.zeros(models),
                              where=predicted > 0)
            joint = mu[t][:, None] * matrix * ratio[None]  # P(model i at t, j at t + 1)
            mus[t] = joint.sum(axis=1) / joint.sum()
            for i in range(models):
                towards = matrix[i] * ratio
                if towards.sum() <= 0:
                    xs[t, i], ps[t, i] = x[t, i], p[t, i]
                    continue
                w = towards / towards.sum()
                f, b = transitions[linearisation[k, t, i]], offsets[linearisation[k, t, i]]
                pair_x, pair_p = np.zeros((models, d)), np.zeros((models, d, d))
                for j in np.flatnonzero(w):
                    xu, pu = _union(x[t], p[t], has, i, j)
                    seen = np.flatnonzero(has[j])
                    fj = f[j][seen]  # the prediction of model j's components
                    pp = fj @ pu @ fj.T + q[j][np.ix_(seen, seen)]
                    if np.linalg.eigvalsh(pp).min() <= 0:
                        status[k] = 1 + t
                        break
                    gain = pu @ fj.T @ np.linalg.inv(pp)
                    pair_x[j] = xu + gain @ (xs[t + 1, j][seen] - fj @ xu - b[j][seen])
                    pair_p[j] = pu + gain @ (ps[t + 1, j][np.ix_(seen, seen)] - pp) @ gain.T
                    pair_x[j][~has[i]] = 0.0
                    pair_p[j][~has[i]] = 0.0
                    pair_p[j][:, ~has[i]] = 0.0
                if status[k]:
                    break
                xs[t, i] = w @ pair_x
                spread = pair_x - xs[t, i]
                ps[t, i] = (np.einsum("j,jab->ab", w, pair_p)
                            + np.einsum("j,ja,jb->ab", w, spread, spread))
            if status[k]:
                break
