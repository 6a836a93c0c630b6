"""Mirror of ``fasttrack._jit.imm``: the IMM step of linear models, filter by filter and
model by model, with NumPy's linear algebra."""
import numpy as np

from .kalman import _covariance_status
from .status import INNOVATION_NOT_PD, OK


def step_inputs_valid(means, covars, probs, z, tolerance):
    arrays = (means, covars, probs, z)
    return bool(all(np.isfinite(a).all() for a in arrays) and (probs >= 0).all()
                and (np.abs(probs.sum(axis=1) - 1.0) <= tolerance).all()
                and all(_covariance_status(c, 1, 2) == OK
                        for c in covars.reshape(-1, *covars.shape[2:])))


def _kalman(f, q, h, noise, x0, p0, z):
    """One Kalman step and its log likelihood (None if S is not positive definite)."""
    x, p = f @ x0, f @ p0 @ f.T + q
    s = h @ p @ h.T + noise
    if np.linalg.eigvalsh(s).min() <= 0:
        return None
    gain = p @ h.T @ np.linalg.inv(s)
    v = z - h @ x
    a = np.eye(x.size) - gain @ h
    log_likelihood = -0.5 * v @ np.linalg.solve(s, v) - 0.5 * np.linalg.slogdet(2 * np.pi * s)[1]
    return x + gain @ v, a @ p @ a.T + gain @ noise @ gain.T, log_likelihood


def _converted(means, covars, has, i, j):
    """Model i's state in model j's components, entry by entry."""
    d = means.shape[1]
    x, p = np.zeros(d), np.zeros((d, d))
    for a in range(d):
        if has[j, a]:
            x[a] = means[i, a] if has[i, a] else means[j, a]
        for b in range(d):
            if has[j, a] and has[j, b]:
                if has[i, a] and has[i, b]:
                    p[a, b] = covars[i, a, b]
                elif not has[i, a] and not has[i, b]:
                    p[a, b] = covars[j, a, b]
    return x, p


def _merged(w, means, covars):
    w = w / w.sum()
    x = w @ means
    spread = means - x
    return x, np.einsum("i,iab->ab", w, covars) + np.einsum("i,ia,ib->ab", w, spread, spread)


def imm_linear_step(algorithm, transitions, noises, mapping, noise, matrix, has, means, covars,
                    probs, z, out_means, out_covars, out_probs, status):
    models, d = means.shape[1:]
    h = np.zeros((mapping.size, d))
    h[np.arange(mapping.size), mapping] = 1.0
    for k in range(means.shape[0]):
        predicted = probs[k] @ matrix
        log_posterior = np.full(models, -np.inf)
        status[k] = OK
        for j in range(models):
            if algorithm == 2:  # GPB2: model j from every model i's posterior
                pairs, log_w = [], np.full(models, -np.inf)
                for i in range(models):
                    step = _kalman(transitions[j], noises[j], h, noise,
                                   *_converted(means[k], covars[k], has, i, j), z[k])
                    if step is None:
                        status[k] = INNOVATION_NOT_PD
                        break
                    pairs.append(step)
                    if matrix[i, j] * probs[k, i] > 0:
                        log_w[i] = np.log(matrix[i, j] * probs[k, i]) + step[2]
                if status[k]:
                    break
                if np.isfinite(log_w).any():
                    w = np.exp(log_w - log_w.max())
                    out_means[k, j], out_covars[k, j] = _merged(
                        w, np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]))
                    log_posterior[j] = log_w.max() + np.log(w.sum())
                else:
                    out_means[k, j], out_covars[k, j] = pairs[j][:2]
                continue
            if algorithm == 1:  # GPB1: all models merged
                w = probs[k]
            else:
                w = matrix[:, j] * probs[k] if predicted[j] > 0 else np.eye(models)[j]
            sources = [_converted(means[k], covars[k], has, i, j) for i in range(models)]
            x0, p0 = _merged(w, np.array([x for x, _ in sources]),
                             np.array([p for _, p in sources]))
            step = _kalman(transitions[j], noises[j], h, noise, x0, p0, z[k])
            if step is None:
                status[k] = INNOVATION_NOT_PD
                break
            out_means[k, j], out_covars[k, j] = step[:2]
            if predicted[j] > 0:
                log_posterior[j] = np.log(predicted[j]) + step[2]
        if status[k] == OK:
            weights = np.exp(log_posterior - log_posterior.max())
            out_probs[k] = weights / weights.sum()


def imm_predict(transitions, noises, matrix, has, means, covars, probs, out_means, out_covars,
                out_predicted, status):
    models = means.shape[1]
    for k in range(means.shape[0]):
        status[k] = OK
        out_predicted[k] = probs[k] @ matrix
        for j in range(models):
            c = out_predicted[k, j]
            w = matrix[:, j] * probs[k] if c > 0 else np.eye(models)[j]
            sources = [_converted(means[k], covars[k], has, i, j) for i in range(models)]
            x0, p0 = _merged(w, np.array([x for x, _ in sources]),
                             np.array([p for _, p in sources]))
            out_means[k, j] = transitions[j] @ x0
            out_covars[k, j] = transitions[j] @ p0 @ transitions[j].T + noises[j]


def imm_update(mapping, noise, means, covars, predicted, z, out_means, out_covars, out_probs,
               status):
    d = means.shape[2]
    h = np.zeros((mapping.size, d))
    h[np.arange(mapping.size), mapping] = 1.0
    eye = np.eye(d)
    for k in range(means.shape[0]):
        status[k] = OK
        log_posterior = np.full(means.shape[1], -np.inf)
        for j in range(means.shape[1]):
            step = _kalman(eye, np.zeros((d, d)), h, noise, means[k, j], covars[k, j], z[k])
            if step is None:
                status[k] = INNOVATION_NOT_PD
                break
            out_means[k, j], out_covars[k, j] = step[:2]
            if predicted[k, j] > 0:
                log_posterior[j] = np.log(predicted[k, j]) + step[2]
        if status[k] == OK:
            weights = np.exp(log_posterior - log_posterior.max())
            out_probs[k] = weights / weights.sum()
