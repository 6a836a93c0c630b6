"""Mirrors of ``fasttrack._jit.assign``: linear sum assignment (SciPy), GOSPA and OSPA from
their definitions."""
import numpy as np


def lsap(cost, row_to_col):
    """scipy.optimize.linear_sum_assignment; infeasible: every row -1 and False."""
    from scipy.optimize import linear_sum_assignment
    row_to_col[:] = -1
    try:
        rows, cols = linear_sum_assignment(cost)
    except ValueError:
        return False
    row_to_col[rows] = cols
    return True


def lsap_batch(costs, offsets, shapes, row_offsets, row_to_col, feasible):
    for q, (nr, nc) in enumerate(shapes):
        block = costs[offsets[q]:offsets[q + 1]].reshape(nr, nc)
        feasible[q] = lsap(block, row_to_col[row_offsets[q]:row_offsets[q + 1]])


def _capped(rows, cols, c):
    """min(|rows[i] - cols[j]|, c) for every pair."""
    d = np.sqrt(((rows[:, None, :] - cols[None, :, :]) ** 2).sum(axis=-1))
    return np.where(d < c, d, c)


def gospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, p, alpha, assignment,
                out):
    """GOSPA from its definition, step by step: scipy's pairs on min(d, c)^p (truth rows),
    then c^p/alpha per unassigned point; with alpha = 2 a pair at the cut-off is split
    into a missed truth and a false estimate."""
    from scipy.optimize import linear_sum_assignment
    cut = c ** p
    dummy = cut / alpha
    for k in range(truth_offsets.size - 1):
        x = truths[truth_offsets[k]:truth_offsets[k + 1]]
        y = estimates[estimate_offsets[k]:estimate_offsets[k + 1]]
        n, m = len(x), len(y)
        pairs = np.full(n, -1)
        loc = missed = false = 0.0
        if n and m:
            cost = _capped(x, y, c) ** p
            rows, cols = linear_sum_assignment(cost)
            pairs[rows] = cols
            at_cut = (cost[rows, cols] == cut) if alpha == 2 else np.zeros(len(rows), bool)
            loc = cost[rows, cols][~at_cut].sum()
            pairs[rows[at_cut]] = -1
            missed = dummy * (n - len(rows) + at_cut.sum())
            false = dummy * (m - len(rows) + at_cut.sum())
            total = cost[rows, cols].sum() + dummy * (n + m - 2 * len(rows))
        else:
            missed, false = dummy * n, dummy * m
            total = missed + false
        assignment[truth_offsets[k]:truth_offsets[k + 1]] = pairs
        out[k] = total ** (1 / p), loc, missed, false


def switching_loss(truth_ids, truth_offsets, estimate_offsets, assigned_ids, n_ids, out):
    """Stone Soup's _SwitchingLoss.add_associations on dicts, step by step."""
    record = {}
    for k in range(truth_offsets.size - 1):
        out[k] = 0.0
        if estimate_offsets[k + 1] == estimate_offsets[k]:
            continue  # Stone Soup's mapping is empty without estimates
        for t in range(truth_offsets[k], truth_offsets[k + 1]):
            truth = int(truth_ids[t])
            estimate = None if assigned_ids[t] == -1 else int(assigned_ids[t])
            if truth not in record:
                if estimate is not None:
                    record[truth] = estimate
            elif record[truth] != estimate:
                out[k] += 0.5 + 0.5 * (estimate is not None and record[truth] is not None)
                record[truth] = estimate


def _bottleneck(cost):
    """min over complete assignments of the largest entry: the least threshold at which
    scipy still finds an assignment."""
    from scipy.optimize import linear_sum_assignment
    for value in np.unique(cost):
        try:
            linear_sum_assignment(np.where(cost <= value, 0.0, np.inf))
        except ValueError:
            continue
        return value


def ospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, p, stonesoup, out):
    """OSPA from its definition (or, with ``stonesoup``, Stone Soup 1.9.1's computation:
    the square matrix of min(d, c) padded with c, scipy's pairs on it, then the powers)."""
    from scipy.optimize import linear_sum_assignment
    for k in range(truth_offsets.size - 1):
        x = truths[truth_offsets[k]:truth_offsets[k + 1]]
        y = estimates[estimate_offsets[k]:estimate_offsets[k + 1]]
        n, m = len(x), len(y)
        big = max(n, m)
        if big == 0:
            out[k] = 0.0
        elif p == np.inf:
            if n != m:
                out[k] = c
            elif stonesoup:
                cost = _capped(y, x, c)
                out[k] = cost[linear_sum_assignment(cost)].max()
            else:
                out[k] = _bottleneck(_capped(x, y, c))
        elif stonesoup:
            cost = np.full((big, big), float(c))
            cost[:m, :n] = _capped(y, x, c)
            out[k] = ((1 / big) * np.sum(cost[linear_sum_assignment(cost)] ** p)) ** (1 / p)
        else:
            cost = _capped(x, y, c) ** p
            total = cost[linear_sum_assignment(cost)].sum() + c ** p * (big - min(n, m))
            out[k] = (total / big) ** (1 / p)
