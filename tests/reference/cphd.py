"""Mirrors of ``fasttrack._jit.cphd``, in the linear domain with explicit loops (Vo, Vo and
Cantoni 2007): each ESF with one value left out computed afresh, the update's sums term by
term, and the cardinality prediction as a double sum; and :func:`weights`, the whole update
of a mixture's weights and cardinality. For small problems only (no care for overflow)."""
import math

import numpy as np


def _esf(values):
    """e_0..e_m of ``values``, by the product of (1 + v x)."""
    out = np.zeros(len(values) + 1)
    out[0] = 1.0
    for k, v in enumerate(values, start=1):
        out[1:k + 1] = out[1:k + 1] + v * out[:k].copy()
    return out


def _log(x):
    with np.errstate(divide="ignore"):
        return np.log(x)


def log_esf(log_values, out):
    out[:] = _log(_esf(np.exp(log_values)))


def log_esf_without(log_values, log_e, out):
    for z in range(log_values.size):
        out[z] = _log(_esf(np.exp(np.delete(log_values, z))))


def _falling(n, k):
    return math.factorial(n) / math.factorial(n - k) if n >= k else 0.0


def _upsilon(u, e, cardinality, p_d, total, rate):
    """Upsilon^u[w, Z](n) p(n) for n = 0..N, from the ESFs ``e`` of |Z| = len(e) - 1
    values."""
    m = len(e) - 1
    out = np.zeros(len(cardinality))
    for n, p in enumerate(cardinality):
        for j in range(min(m, n) + 1):
            if j + u > n:
                continue
            clutter = math.exp(-rate) * rate ** (m - j)  # (m - j)! p_K(m - j), Poisson
            out[n] += (clutter * _falling(n, j + u) * (1 - p_d) ** (n - j - u)
                       / total ** (j + u) * e[j]) * p
    return out


def update_sums(log_e, esf_without, log_cardinality, log_missed, log_total, log_rate,
                out_cardinality, out_without):
    cardinality, p_d = np.exp(log_cardinality), 1.0 - np.exp(log_missed)
    total, rate = np.exp(log_total), np.exp(log_rate)
    upsilon0 = _upsilon(0, np.exp(log_e), cardinality, p_d, total, rate)
    norm = upsilon0.sum()
    out_cardinality[:] = _log(upsilon0 / norm)
    for z in range(esf_without.shape[0]):
        out_without[z] = _log(_upsilon(1, np.exp(esf_without[z]), cardinality, p_d, total,
                                       rate).sum() / norm)
    return _log(_upsilon(1, np.exp(log_e), cardinality, p_d, total, rate).sum() / norm)


def predict_cardinality(log_cardinality, log_survive, log_die, birth_mean, out):
    cardinality, p_s = np.exp(log_cardinality), np.exp(log_survive)
    size = len(cardinality)
    survived = np.array([sum(math.comb(b, s) * p_s ** s * (1 - p_s) ** (b - s) * cardinality[b]
                             for b in range(s, size)) for s in range(size)])
    born = np.array([math.exp(-birth_mean) * birth_mean ** k / math.factorial(k)
                     for k in range(size)])
    total = np.array([sum(born[n - s] * survived[s] for s in range(n + 1))
                      for n in range(size)])
    out[:] = _log(total / total.sum())


def weights(weights, likelihoods, cardinality, p_d, rate, kappa):
    """The CPHD posterior of weights ``weights`` (J,) and likelihoods ``likelihoods`` (J, M),
    N(z; H m_i, S_i) (0 outside a gate): (missed (J,), detected (J, M), cardinality (N + 1,)),
    every leave-one-out ESF computed afresh."""
    total = weights.sum()
    values = rate / kappa * p_d * weights @ likelihoods
    upsilon0 = _upsilon(0, _esf(values), cardinality, p_d, total, rate)
    norm = upsilon0.sum()
    missed = (1 - p_d) * weights * _upsilon(1, _esf(values), cardinality, p_d, total,
                                            rate).sum() / norm
    detected = np.zeros_like(likelihoods)
    for z in range(likelihoods.shape[1]):
        rest = _esf(np.delete(values, z))
        detected[:, z] = (p_d * weights * likelihoods[:, z] * rate / kappa
                          * _upsilon(1, rest, cardinality, p_d, total, rate).sum() / norm)
    return missed, detected, upsilon0 / norm
