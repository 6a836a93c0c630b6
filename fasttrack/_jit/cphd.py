"""Kernels of the GM-CPHD filter (:mod:`fasttrack.core.cphd`): the elementary symmetric
functions (ESFs) of the detections' weights, with each detection left out, the update's sums
over them and the cardinality, and the cardinality's prediction, all in logs (-inf for 0).
"""
import math

import numpy as np

from .dispatch import jit

#: log(1/2): the leave-one-out recursions switch from forward to backward above it.
LOG_HALF = -0.6931471805599453


@jit()
def _add(a, b):
    """log(exp(a) + exp(b))."""
    if a < b:
        a, b = b, a
    if b == -np.inf or a == np.inf:
        return a
    return a + math.log1p(math.exp(b - a))


@jit()
def _times(a, b):
    """The log of a product of two factors given by their logs: -inf if either is 0."""
    if a == -np.inf or b == -np.inf:
        return -np.inf
    return a + b


@jit()
def _power(log_base, exponent):
    """``exponent * log_base`` for an integer exponent >= 0, with 0 ** 0 = 1."""
    return 0.0 if exponent == 0 else exponent * log_base


@jit()
def _one_minus(log_x):
    """log(1 - x) from log x (x >= 1 gives -inf)."""
    return math.log1p(-math.exp(min(log_x, 0.0)))


@jit()
def log_esf(log_values, out):
    """``out[j]`` = log e_j of the m values whose logs are ``log_values``, j = 0..m
    (``out`` of size m + 1)."""
    out[0] = 0.0
    for j in range(1, out.size):
        out[j] = -np.inf
    for k in range(log_values.size):
        value = log_values[k]
        for j in range(k + 1, 0, -1):
            out[j] = _add(out[j], _times(value, out[j - 1]))


@jit()
def log_esf_without(log_values, log_e, out):
    """``out[z, j]`` = log e_j of the values without value z, j = 0..m - 1, from
    ``log_e`` (:func:`log_esf`): (m, m) ``out``.

    With r_j = v_z e_{j-1}(without z) / e_j, which grows with j, the forward recursion
    e_j(without z) = e_j (1 - r_j) runs while r_j <= 1/2, and the backward one
    e_{j-1}(without z) = e_j r_j / v_z, from e_{n-1}(without z) = e_n / v_z (n values
    above 0), above it: each subtracts at most half of what it starts from, so rounding
    errors do not grow. A value of 0 leaves the ESFs as they are."""
    m = log_values.size
    live = 0
    for z in range(m):
        live += log_values[z] > -np.inf
    for z in range(m):
        row = out[z]
        value = log_values[z]
        if value == -np.inf:
            for j in range(m):
                row[j] = log_e[j]
            continue
        row[0] = 0.0
        for j in range(1, m):
            row[j] = -np.inf
        switch = live
        for j in range(1, live):
            log_r = value + row[j - 1] - log_e[j]
            if log_r > LOG_HALF:
                switch = j
                break
            row[j] = log_e[j] + _one_minus(log_r)
        if switch < live:
            row[live - 1] = log_e[live] - value
            for j in range(live - 1, switch, -1):
                row[j - 1] = log_e[j] + _one_minus(row[j] - log_e[j]) - value


@jit()
def _log_factorials(size):
    """log k! for k = 0..size - 1."""
    out = np.empty(size)
    for k in range(size):
        out[k] = math.lgamma(k + 1.0)
    return out


@jit()
def _term(u, count, n, j, log_p, log_missed, log_total, log_rate, log_factorial):
    """The log of Upsilon^u's term (n, j) for ``count`` detections, times p(n):
    (count - j)! p_K(count - j) P^n_{j+u} (1 - P_D)^(n - j - u) / <1, w>^(j + u) p(n), with
    Poisson clutter of rate exp(log_rate), less its factor exp(-rate), which every term has
    (it cancels in the update's ratios, and at a large rate it would swamp them); -inf
    where it is 0. ``log_factorial[k]`` = log k! for k <= n."""
    k = n - j - u
    if k < 0 or log_p == -np.inf or (k > 0 and log_missed == -np.inf):
        return -np.inf
    return (_power(log_rate, count - j) + log_factorial[n]
            - log_factorial[k] + _power(log_missed, k) - _power(log_total, j + u) + log_p)


@jit()
def update_sums(log_e, esf_without, log_cardinality, log_missed, log_total, log_rate,
                out_cardinality, out_without):
    """The CPHD update's sums for m detections: the posterior log cardinality
    Upsilon^0[Z](n) p(n) / <Upsilon^0[Z], p> into ``out_cardinality`` (N + 1,), each
    detection's log <Upsilon^1[Z without z], p> / <Upsilon^0[Z], p> into ``out_without``
    (m,), from ``log_e`` (m + 1,) and ``esf_without`` (m, m); returns
    log <Upsilon^1[Z], p> / <Upsilon^0[Z], p>."""
    m = esf_without.shape[0]
    log_factorial = _log_factorials(log_cardinality.size)
    norm = -np.inf
    missed = -np.inf
    for n in range(log_cardinality.size):
        upsilon = -np.inf
        for j in range(min(m, n) + 1):
            upsilon = _add(upsilon, _times(_term(0, m, n, j, log_cardinality[n], log_missed,
                                                 log_total, log_rate, log_factorial),
                                           log_e[j]))
            missed = _add(missed, _times(_term(1, m, n, j, log_cardinality[n], log_missed,
                                               log_total, log_rate, log_factorial),
                                         log_e[j]))
        out_cardinality[n] = upsilon
        norm = _add(norm, upsilon)
    for n in range(log_cardinality.size):
        out_cardinality[n] -= norm
    coefficients = np.empty(m)
    for j in range(m):
        total = -np.inf
        for n in range(j + 1, log_cardinality.size):
            total = _add(total, _term(1, m - 1, n, j, log_cardinality[n], log_missed,
                                      log_total, log_rate, log_factorial))
        coefficients[j] = total
    for z in range(m):
        total = -np.inf
        for j in range(m):
            total = _add(total, _times(coefficients[j], esf_without[z, j]))
        out_without[z] = total - norm
    return missed - norm


@jit()
def predict_cardinality(log_cardinality, log_survive, log_die, birth_mean, out):
    """The predicted log cardinality into ``out``: each target survives with probability
    exp(log_survive) (exp(log_die) = 1 minus it), a Poisson number of mean ``birth_mean`` is
    born; truncated to the same 0..N and normalised (the births' Poisson terms without
    their common factor exp(-mean), which the normalisation removes: a mean of 1e300 puts
    the mass at N, where the factor would have made every term zero)."""
    size = log_cardinality.size
    log_factorial = _log_factorials(size)
    survived = np.empty(size)
    for s in range(size):
        total = -np.inf
        for b in range(s, size):
            thinning = (log_factorial[b] - log_factorial[s] - log_factorial[b - s]
                        + _power(log_survive, s) + _power(log_die, b - s))
            total = _add(total, _times(thinning, log_cardinality[b]))
        survived[s] = total
    log_mean = math.log(birth_mean) if birth_mean > 0.0 else -np.inf
    norm = -np.inf
    for n in range(size):
        total = -np.inf
        for s in range(n + 1):  # (the Poisson terms without their common exp(-mean))
            born = _power(log_mean, n - s) - log_factorial[n - s]
            total = _add(total, _times(born, survived[s]))
        out[n] = total
        norm = _add(norm, total)
    for n in range(size):
        out[n] -= norm
