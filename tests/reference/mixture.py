"""Mirrors of ``fasttrack._jit.mixture``: segment log-sum-exp, moment matching of
Gaussian mixture components grouped by CSR starts, and the components' Kalman gains."""
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



def _mahalanobis2(mean, centre, covar):
    return (mean - centre) @ np.linalg.solve(covar, mean - centre)


def reduce(means, covars, weights, mode, prune_threshold, merging, merge_threshold,
           max_components, axes, out_means, out_covars, out_weights, source, member):
    stonesoup = mode == 0
    keep = weights >= prune_threshold if stonesoup else weights > prune_threshold
    kept = np.flatnonzero(keep)
    work = weights[kept].astype(np.float64)
    if stonesoup and kept.size:
        work += sum(weights[~keep], 0.0) / kept.size
    m, p = means[kept], covars[kept]
    # [mean, covar, weight, heaviest, members], in kept positions
    merged = [[m[j], p[j], work[j], j, [j]] for j in range(kept.size)]
    if merging and kept.size > 1:
        for j in range(kept.size):
            if not np.allclose(p[j], p[j].T, rtol=0.0, atol=1e-9 * np.abs(p[j]).max()):
                return -(2 + 2 * kept[j])
            if not np.all(np.linalg.eigvalsh(p[j]) > 0.0):
                return -(1 + 2 * kept[j])
        merged, remaining = [], list(np.argsort(work, kind="stable"))
        while remaining:
            best = remaining.pop()
            mean, covar, weight, group = m[best], p[best], work[best], [best]
            for c in list(remaining):
                if stonesoup and _mahalanobis2(m[c], mean, p[c]) < merge_threshold:
                    total = weight + work[c]
                    w1, w2 = weight / total, work[c] / total
                    spread = np.outer(mean - m[c], mean - m[c])
                    mean, covar = mean * w1 + m[c] * w2, covar * w1 + p[c] * w2 + spread * w1 * w2
                    weight = min(total, 1.0)
                elif stonesoup or _mahalanobis2(m[c], m[best], p[best]) > merge_threshold:
                    continue
                remaining.remove(c)
                group.append(c)
            if not stonesoup:
                weight = work[group].sum()
                w = work[group] / weight
                mean = w @ m[group]
                spread = m[group] - mean
                covar = np.einsum("k,kij->ij", w, p[group]) + (spread.T * w) @ spread
            merged.append([mean, covar, weight, best, group])
    if len(merged) > max_components:
        order = sorted(range(len(merged)), key=lambda o: -merged[o][2])
        cut = sum((merged[o][2] for o in order[max_components:]), 0.0)
        total = sum((merged[o][2] for o in order[:max_components]), 0.0)
        merged = [merged[o] for o in order[:max_components]]
        for component in merged:
            component[2] = (component[2] + cut / max_components if stonesoup
                            else component[2] * ((total + cut) / total))
    member[:] = -1
    for o, (mean, covar, weight, best, group) in enumerate(merged):
        out_means[o], out_covars[o], out_weights[o], source[o] = mean, covar, weight, kept[best]
        member[kept[group]] = o
    return len(merged)


def component_gains(covars, cross, innovation, gains, updated):
    for k in range(cross.shape[0]):
        if np.linalg.eigvalsh(innovation[k]).min() <= 0.0:
            return k
        gains[k] = cross[k] @ np.linalg.inv(innovation[k])
        posterior = covars[k] - gains[k] @ cross[k].T
        updated[k] = np.tril(posterior) + np.tril(posterior, -1).T
    return -1
