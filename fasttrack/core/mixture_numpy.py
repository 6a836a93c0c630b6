"""The mixture reducer and the components' gains in NumPy, for a process's first small calls
(see :func:`fasttrack._jit.numpy_first`): ``fasttrack._jit.mixture.reduce``'s and
``component_gains``' rules, arguments, outputs and status codes, the reducer's candidate
tests vectorised (each merge tests the live candidates against the merged mean at once,
resuming after the one merged; for a small mixture, Stone Soup's first tests of every pair
in one table, so that a component with no candidate near is kept without a merge)."""
import functools
import operator

import numpy as np

from .._jit.kinds import STONESOUP
from .._validate import asymmetric

#: The most components whose first merge tests are made at once (an n x n table).
NEAR_UP_TO = 64


def reduce_work(j, d):
    """The :func:`~fasttrack._jit.numpy_first` units of a reduction of j components of d
    dimensions: one a component for up to 2,048 components of d <= 4, as each merge test
    costs d^2 and a component that many merge take meets up to j tests (5,000 components of
    60-D merging into one took 79 s in NumPy, 1.6 s on the kernels; 8,000 4-D ones 2.4 s)."""
    return j * max(1, d * d // 16) * max(1, j // 2048)


def reduce(means, covars, weights, mode, prune_threshold, merging, merge_threshold,
           max_components, axes, out_means, out_covars, out_weights, source, member):
    """:func:`fasttrack._jit.mixture.reduce` (``axes``, the kernel's grid rows, unused)."""
    stonesoup = mode == STONESOUP
    keep = weights >= prune_threshold if stonesoup else weights > prune_threshold
    kept = np.flatnonzero(keep)
    work = weights[kept].astype(np.float64)
    if stonesoup and kept.size:
        work = work + ordered_sum(weights[~keep]) / kept.size
    means, covars = means[kept], covars[kept]
    n = kept.size
    local_member = np.arange(n)
    merged = {}  # output -> (mean, covariance, weight) of a merge of several
    if merging and n > 1:
        failed = first_bad_covariance(covars)
        if failed >= 0:
            j, kind = divmod(failed, 2)
            return -(1 + 2 * int(kept[j]) + kind)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            heads = _merge(means, covars, work, stonesoup, merge_threshold, local_member,
                           merged)
    else:
        heads = np.arange(n)
    count = heads.size
    out_means[:count], out_covars[:count], out_weights[:count] = \
        means[heads], covars[heads], work[heads]
    for o, (mean, covar, weight) in merged.items():
        out_means[o], out_covars[o], out_weights[o] = mean, covar, weight
    source[:count] = kept[heads]
    member[:] = -1
    member[kept] = local_member
    if count > max_components:
        count = _truncate(stonesoup, count, max_components, out_means, out_covars,
                          out_weights, source, member)
    return count


def ordered_sum(values):
    """The sum of a float array's ``values`` added in order (as the kernel, and Stone
    Soup's reducer, add them)."""
    return functools.reduce(operator.add, values.tolist(), 0.0)


def first_bad_covariance(covars):
    """``2 j + 1`` for the first covariance j not symmetric (to 1e-9 of its largest
    entry), ``2 j`` for one not positive definite, else -1."""
    bad = asymmetric(covars)
    if not bad.any():
        try:
            np.linalg.cholesky(covars)
            return -1
        except np.linalg.LinAlgError:
            pass
    for j in range(covars.shape[0]):
        if bad[j]:
            return 2 * j + 1
        try:
            np.linalg.cholesky(covars[j])
        except np.linalg.LinAlgError:
            return 2 * j
    return -1


def _merge(means, covars, weights, stonesoup, threshold, member, merged):
    """The greedy merges (the kernel's ``_merge`` rules), heaviest first: the (L,) heaviest
    component of each, in order; ``merged[o]`` set to merge o's (mean, covariance, weight)
    where it took others, ``member[j]`` to component j's merge. A component takes only
    lighter ones, so one with none near it (Stone Soup's first test) takes none, whatever
    merged before: only the others are visited."""
    precisions = np.linalg.inv(covars)
    by_rank = np.argsort(weights, kind="stable")
    descending = by_rank[::-1]
    rank = np.empty(weights.size, dtype=np.int64)
    rank[by_rank] = np.arange(weights.size)
    near = _near(means, precisions, threshold) if stonesoup else None
    takers = descending if near is None \
        else descending[(near & (rank[:, None] < rank[None, :])).any(axis=0)[descending]]
    alive = np.ones(weights.size, dtype=bool)  # not taken by a heavier one
    groups = []  # (heaviest, (mean, covariance, weight), taken) of each merge of several
    for b in takers.tolist():
        if not alive[b]:
            continue
        lighter = by_rank[:rank[b]]
        candidates = lighter[alive[lighter]]  # ascending weight
        if stonesoup:
            hits = None if near is None else near[candidates, b].nonzero()[0]
            *group, taken = _merge_running(means, covars, weights, precisions, b, candidates,
                                           threshold, hits)
        else:
            v = means[candidates] - means[b]
            taken = candidates[np.einsum("ki,ij,kj->k", v, precisions[b], v) <= threshold]
            members = np.r_[b, taken]
            total = ordered_sum(weights[members])
            w = weights[members] * _reciprocal(total)
            mean = w @ means[members]
            spread = means[members] - mean
            group = mean, np.einsum("k,kij->ij", w, covars[members]) \
                + (spread.T * w) @ spread, total
        if taken.size:
            alive[taken] = False
            groups.append((b, group, taken))
    heads = descending[alive[descending]]
    member[heads] = np.arange(heads.size)
    for b, group, taken in groups:
        o = int(member[b])
        merged[o] = group
        member[taken] = o
    return heads


def _near(means, precisions, threshold):
    """(n, n) bool: whether component c's covariance measures the mean of b within
    ``threshold`` (``<``), Stone Soup's first test of c against b; None for more than
    :data:`NEAR_UP_TO` components (the tests are then made merge by merge)."""
    if means.shape[0] > NEAR_UP_TO:
        return None
    v = means[None, :, :] - means[:, None, :]
    return np.einsum("cbj,cbj->cb", v @ precisions, v) < threshold


def _merge_running(means, covars, weights, precisions, b, candidates, threshold, hits=None):
    """Stone Soup's merge into component b: each candidate in turn (ascending weight)
    measured by its own covariance from the running merged mean, ``<``, merged pairwise
    (spread included, weight capped at 1); ``hits``, if given, the candidates' positions
    within the threshold of b's own mean. Returns the mean, covariance, weight and the
    candidates taken."""
    mean, covar, weight = means[b], covars[b], weights[b]
    pool_means, pool_precisions = means[candidates], precisions[candidates]
    taken, start = [], 0
    while start < candidates.size:
        if hits is None:  # positions (from ``start`` on) within the threshold of the mean
            v = pool_means[start:] - mean
            hits = start + (np.einsum("ki,kij,kj->k", v, pool_precisions[start:], v)
                            < threshold).nonzero()[0]
        if not hits.size:
            break
        start, hits = int(hits[0]), None
        c = int(candidates[start])
        total = weight + weights[c]
        inverse = _reciprocal(total)
        w1, w2 = weight * inverse, weights[c] * inverse
        diff = mean - means[c]
        mean = mean * w1 + means[c] * w2
        covar = covar * w1 + covars[c] * w2 + diff[:, None] * diff * (w1 * w2)
        weight = min(total, 1.0)
        taken.append(c)
        start += 1
    return mean, covar, weight, np.array(taken, dtype=np.int64)


def _reciprocal(total):
    """``1 / total`` as the kernels take it (they divide by multiplying with it): +inf for
    a total below 1 / 1.8e308, whose merge then has no finite mean."""
    return np.float64(1.0) / total


def _truncate(stonesoup, count, keep, means, covars, weights, source, member):
    """The kernel's ``_truncate``: the ``keep`` heaviest (ties: the earlier), heaviest
    first, in place; returns ``keep``."""
    order = np.argsort(-weights[:count], kind="stable")
    kept_mass = ordered_sum(weights[order[:keep]])
    cut_mass = ordered_sum(weights[order[keep:count]])
    first = order[:keep]
    new_weights = (weights[first] + cut_mass / keep if stonesoup
                   else weights[first] * ((kept_mass + cut_mass) / kept_mass))
    means[:keep], covars[:keep], source[:keep] = means[first], covars[first], source[first]
    weights[:keep] = new_weights
    position = np.full(count, -1)
    position[first] = np.arange(keep)
    inside = member >= 0
    member[inside] = position[member[inside]]
    return keep


def component_gains(covars, cross, innovation, gains, updated):
    """:func:`fasttrack._jit.mixture.component_gains` (the lower triangle of the posterior
    covariance mirrored, as the kernel's)."""
    bad = np.flatnonzero(~(np.linalg.eigvalsh(innovation)[:, 0] > 0.0)) if innovation.size \
        else np.empty(0, dtype=np.int64)
    if bad.size:
        return int(bad[0])
    gains[...] = np.linalg.solve(innovation, cross.transpose(0, 2, 1)).transpose(0, 2, 1)
    posterior = np.tril(covars - gains @ cross.transpose(0, 2, 1))
    updated[...] = posterior + np.tril(posterior, -1).transpose(0, 2, 1)
    return -1
