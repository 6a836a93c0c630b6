"""Mirrors of ``fasttrack._jit.mixture``: segment log-sum-exp and moment matching of
Gaussian mixture components grouped by CSR starts."""
import numpy as np


def segment_logsumexp(values, starts, out):
    for s in range(starts.size - 1):
        segment = values[starts[s]:starts[s + 1]]
        peak = segment.max(initial=-np.inf)
        shift = peak if np.isfinite(peak) else 0.0
        with np.errstate(divide="ignore"):
            out[s] = np.log(np.sum(np.exp(segment - shift))) + shift


def moment_match(means, covars, log_weights, starts, out_means, out_covars, out_log_weights):
    failed = -1
    for s in range(starts.size - 1):
        lo, hi = starts[s], starts[s + 1]
        peak = log_weights[lo:hi].max(initial=-np.inf)
        if not np.isfinite(peak):
            failed = s if failed < 0 else failed
            continue
        w = np.exp(log_weights[lo:hi] - peak)
        out_log_weights[s] = peak + np.log(w.sum())
        w /= w.sum()
        out_means[s] = w @ means[lo:hi]
        spread = means[lo:hi] - out_means[s]
        out_covars[s] = np.einsum("k,kij->ij", w, covars[lo:hi]) + (spread.T * w) @ spread
    return failed
