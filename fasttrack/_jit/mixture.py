"""Kernels on Gaussian mixtures stored as stacks: K components with (K, d) means, (K, d, d)
covariances and (K,) log weights, grouped into segments by CSR ``starts`` (segment s is
components ``starts[s]:starts[s + 1]``).

Weights are handled in log space: each segment's are shifted by their largest before they
are exponentiated, so no weight underflows to zero while a larger one is finite.
"""
import math

import numpy as np

from .dispatch import jit


@jit()
def _segment_peak(log_weights, lo, hi):
    """The largest of ``log_weights[lo:hi]`` (-inf for an empty segment)."""
    peak = -np.inf
    for i in range(lo, hi):
        if log_weights[i] > peak:
            peak = log_weights[i]
    return peak


@jit()
def segment_logsumexp(values, starts, out):
    """``out[s] = log sum exp values[starts[s]:starts[s + 1]]``: -inf for an empty segment
    or one of zero weights, +inf if a value is +inf, NaN if one is NaN."""
    for s in range(starts.size - 1):
        lo, hi = starts[s], starts[s + 1]
        peak = _segment_peak(values, lo, hi)
        shift = peak if abs(peak) <= 1.7976931348623157e308 else 0.0
        total = 0.0
        for i in range(lo, hi):
            total += math.exp(values[i] - shift)
        out[s] = -np.inf if total == 0.0 else math.log(total) + shift


@jit()
def moment_match(means, covars, log_weights, starts, out_means, out_covars, out_log_weights):
    """Each segment's components merged into the Gaussian of the same mean and covariance:
    ``m = sum w_i m_i``, ``P = sum w_i (P_i + (m_i - m)(m_i - m)^T)`` with the weights
    normalised within the segment; ``out_log_weights[s]`` is the segment's log total weight.
    Returns the first segment with no finite positive total weight (nothing written for it),
    or -1 if every segment was merged."""
    d = means.shape[1]
    failed = -1
    for s in range(starts.size - 1):
        lo, hi = starts[s], starts[s + 1]
        peak = _segment_peak(log_weights, lo, hi)
        if not abs(peak) <= 1.7976931348623157e308:
            if failed < 0:
                failed = s
            continue
        total = 0.0
        for i in range(lo, hi):
            total += math.exp(log_weights[i] - peak)
        mean = out_means[s]
        for r in range(d):
            mean[r] = 0.0
        for i in range(lo, hi):
            w = math.exp(log_weights[i] - peak) / total
            for r in range(d):
                mean[r] += w * means[i, r]
        covar = out_covars[s]
        for r in range(d):
            for c in range(d):
                covar[r, c] = 0.0
        for i in range(lo, hi):
            w = math.exp(log_weights[i] - peak) / total
            for r in range(d):
                spread_r = means[i, r] - mean[r]
                for c in range(d):
                    covar[r, c] += w * (covars[i, r, c] + spread_r * (means[i, c] - mean[c]))
        out_log_weights[s] = peak + math.log(total)
    return failed
