"""NumPy twins of the GM-CPHD kernels (:mod:`fasttrack._jit.cphd`): a process's first small
updates run here (:func:`fasttrack._jit.numpy_first`), with the kernels' formulas."""
import numpy as np
from scipy.special import gammaln


def work(m, size):
    """The :func:`~fasttrack._jit.numpy_first` units of an update with m detections and a
    cardinality of ``size`` numbers (a few dozen vectorised passes, and two a detection)."""
    return 6 + m // 5 + size // 64


def predict_work(size):
    """The :func:`~fasttrack._jit.numpy_first` units of a cardinality prediction of ``size``
    numbers (its NumPy twin builds (size, size) tables: a large one takes the kernel)."""
    return 6 + size * size // 1024


def logsumexp(logs, axis=None):
    """log sum exp over ``axis`` (all, by default), -inf for an empty or all -inf sum."""
    logs = np.asarray(logs, dtype=float)
    if logs.size == 0:
        return np.sum(logs, axis=axis) - np.inf
    peak = np.max(logs, axis=axis, keepdims=True)
    shift = np.where(np.isfinite(peak), peak, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.sum(np.exp(logs - shift), axis=axis, keepdims=True)) + shift
    return out.squeeze(axis=axis) if axis is not None else out.reshape(())[()]


def log_esf(log_values):
    """The log elementary symmetric functions e_0..e_m of m values given by their logs:
    ``out[j] = log sum over j-subsets of the product of their values`` (-inf for 0)."""
    out = np.full(log_values.size + 1, -np.inf)
    out[0] = 0.0
    for k, value in enumerate(log_values, start=1):
        out[1:k + 1] = np.logaddexp(out[1:k + 1], value + out[:k])
    return out


def log_esf_without(log_values, log_e):
    """The log ESFs of the m values with each one left out, (m, m): the kernel's
    recursions, both run for every value, each taken where the kernel takes it."""
    m = log_values.size
    out = np.full((m, m), -np.inf)
    if m == 0:
        return out
    out[:, :] = log_e[None, :m]  # a value of 0 changes nothing
    live = np.flatnonzero(log_values > -np.inf)
    n = live.size  # e_j > 0 exactly for j <= n, and e_j(without z) for j < n, z live
    if n == 0:
        return out
    values = log_values[live][:, None]
    forward = np.full((live.size, n), -np.inf)
    forward[:, 0] = 0.0
    switch = np.full(live.size, n)  # the first j whose r_j exceeds 1/2 (n: none)
    with np.errstate(divide="ignore", invalid="ignore"):
        for j in range(1, n):
            log_r = values[:, 0] + forward[:, j - 1] - log_e[j]
            forward[:, j] = log_e[j] + np.log1p(-np.exp(np.minimum(log_r, 0.0)))
            switch = np.where((switch == n) & (log_r > np.log(0.5)), j, switch)
        backward = np.full((live.size, n), -np.inf)
        backward[:, n - 1] = log_e[n] - values[:, 0]
        for j in range(n - 1, 0, -1):
            log_s = backward[:, j] - log_e[j]  # 1 - r_j
            backward[:, j - 1] = (log_e[j] + np.log1p(-np.exp(np.minimum(log_s, 0.0)))
                                  - values[:, 0])
    columns = np.arange(n)[None, :]
    out[live, :n] = np.where(columns < switch[:, None], forward, backward)
    out[live, n:] = -np.inf
    return out


def _log_falling(n, k):
    """log n! / (n - k)! for arrays n >= k >= 0 (broadcast), -inf where n < k."""
    with np.errstate(invalid="ignore"):
        return np.where(n >= k, gammaln(n + 1.0) - gammaln(np.maximum(n - k, 0) + 1.0),
                        -np.inf)


def _log_power(log_base, exponent):
    """exponent * log_base for integer exponents >= 0, with 0 ** 0 = 1 (log 0)."""
    with np.errstate(invalid="ignore"):
        return np.where(exponent == 0, 0.0, exponent * log_base)


def _upsilon_terms(u, m, log_cardinality, log_missed, log_total, log_rate):
    """The (N + 1, m + 1) logs of Upsilon^u's terms times the cardinality, at (n, j):
    (m - j)! p_K(m - j) P^n_{j+u} (1 - P_D)^(n - j - u) / <1, w>^(j + u) p(n), without
    e_j; for Poisson clutter (m - j)! p_K(m - j) = exp(-rate) rate^(m - j), taken without
    exp(-rate), as the kernel."""
    n = np.arange(log_cardinality.size)[:, None]
    j = np.arange(m + 1)[None, :]
    return _product(_log_power(log_rate, m - j), _log_falling(n, j + u),
                    _log_power(log_missed, n - j - u), -_log_power(log_total, j + u),
                    log_cardinality[:, None])


def _product(*logs):
    """The log of a product of factors given by their logs (broadcast): -inf where any
    factor is 0, whatever the others (an infinite one among them included)."""
    with np.errstate(invalid="ignore"):
        total = sum(logs)
    zero = np.zeros(np.shape(total), dtype=bool)
    for factor in logs:
        zero |= np.asarray(factor) == -np.inf
    return np.where(zero, -np.inf, total)


def predict_cardinality(log_cardinality, log_survive, log_die, birth_mean):
    """The predicted log cardinality (the kernel's arguments, returned)."""
    size = log_cardinality.size
    survivors = np.arange(size)[:, None]
    before = np.arange(size)[None, :]
    thinning = (gammaln(before + 1.0) - gammaln(survivors + 1.0)
                - gammaln(np.maximum(before - survivors, 0) + 1.0)
                + _log_power(log_survive, survivors) + _log_power(log_die, before - survivors))
    thinning = np.where(before >= survivors, thinning, -np.inf)
    survived = logsumexp(thinning + log_cardinality[None, :], axis=1)
    with np.errstate(divide="ignore"):
        log_birth = _log_power(np.log(birth_mean), np.arange(size)) \
            - gammaln(np.arange(size) + 1.0)  # (without exp(-mean), as the kernel)
    born = np.arange(size)[:, None] - np.arange(size)[None, :]  # n - survivors
    terms = np.where(born >= 0, log_birth[np.maximum(born, 0)], -np.inf) + survived[None, :]
    predicted = logsumexp(terms, axis=1)
    return predicted - logsumexp(predicted)


def update_sums(log_e, esf_without, log_cardinality, log_missed, log_total, log_rate):
    """``(log cardinality, missed, without)``: the kernel's sums, returned."""
    m = esf_without.shape[0]
    terms = [_upsilon_terms(u, m, log_cardinality, log_missed, log_total, log_rate)
             for u in (0, 1)]
    upsilon0 = logsumexp(_product(terms[0], log_e[None, :]), axis=1)  # (N + 1,), times p(n)
    norm = logsumexp(upsilon0)
    missed = logsumexp(_product(terms[1], log_e[None, :])) - norm
    left_out = _upsilon_terms(1, m - 1, log_cardinality, log_missed, log_total, log_rate) \
        if m else np.empty((log_cardinality.size, 0))
    coefficients = logsumexp(left_out, axis=0)  # (m,), over n
    without = logsumexp(_product(coefficients[None, :], esf_without), axis=1) - norm
    return upsilon0 - norm, missed, without
