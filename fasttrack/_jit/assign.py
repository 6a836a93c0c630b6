"""Assignment kernels: the rectangular linear sum assignment problem, and the GOSPA and OSPA
metrics that are built on it.

Linear sum assignment. Given an ``(nr, nc)`` cost matrix C, find the one-to-one assignment
of ``min(nr, nc)`` rows to columns minimising ``sum_i C[i, x(i)]``. The solver is the
shortest augmenting path method of Jonker and Volgenant in Crouse's rectangular form (D. F.
Crouse, "On implementing 2D rectangular assignment algorithms", IEEE Trans. AES 52(4),
2016), which SciPy's ``linear_sum_assignment`` also implements: rows are added one at a
time; for each, a Dijkstra search over reduced costs ``C[i, j] - u[i] - v[j]`` (dual
variables u, v kept feasible) finds the cheapest alternating path to a free column, then the
duals are updated and the path flipped. It is exact, O(nr^2 nc) in the worst case, and much
faster when the cheapest column of most rows is free (sparse-ish, well separated costs).

The kernels visit columns in the same order and break ties by the same rules as SciPy
(the free column among equally cheap ones; columns scanned from the last), in IEEE
arithmetic (``strict``), so they return the same assignment as SciPy on the same matrix,
ties included: Stone Soup's GNN and GOSPA results, which come from SciPy, are reproduced.
A matrix with more rows than columns is solved transposed, as SciPy does.

``+inf`` marks a forbidden pair. When no assignment of ``min(nr, nc)`` pairs uses only
finite entries the problem is *infeasible*: the kernels then return False and leave every
row unassigned (-1); the Python wrappers raise. Costs must not hold NaN or ``-inf``.

GOSPA (A. S. Rahmathullah, A. F. Garcia-Fernandez, L. Svensson, "Generalized optimal
sub-pattern assignment metric", 2017) between truths X (n points) and estimates Y (m points)
with cut-off c > 0, order 1 <= p < inf and 0 < alpha <= 2, for n <= m (symmetric
otherwise)::

    d = ( min over injections pi of  sum_i min(|x_i - y_pi(i)|, c)^p
          + c^p / alpha * (m - n) )^(1/p)

With alpha = 2 this equals the assignment form ``(localisation + missed + false)^(1/p)``:
pairs closer than c are localisation errors ``|x - y|^p``, a pair at the cut-off counts as a
missed truth plus a false estimate, each ``c^p / 2``, as in Stone Soup's ``GOSPAMetric``.
OSPA (Schuhmacher, Vo and Vo, 2008) is ``( (min sum min(d, c)^p + c^p |m - n|) / max(n, m)
)^(1/p)``, and for p = inf the smallest largest pair distance (c if n != m).
"""
import numpy as np

from .dispatch import jit
from .numeric import stable_argsort


@jit(strict=True)
def _shortest_paths(cost, col4row):
    """Solve the assignment of the ``nr <= nc`` rows of ``cost`` (2-D, C-contiguous):
    ``col4row[i]`` = the column of row i. Return True, or False (every row -1) if no
    assignment uses only finite costs."""
    nr, nc = cost.shape
    u = np.zeros(nr)
    v = np.zeros(nc)
    shortest = np.empty(nc)
    path = np.full(nc, -1, dtype=np.int64)
    row4col = np.full(nc, -1, dtype=np.int64)
    remaining = np.empty(nc, dtype=np.int64)
    seen_rows = np.zeros(nr, dtype=np.bool_)
    seen_cols = np.zeros(nc, dtype=np.bool_)
    for i in range(nr):
        col4row[i] = -1
    for current in range(nr):
        # Dijkstra search from row `current` for the cheapest path to a free column.
        for it in range(nc):
            remaining[it] = nc - it - 1
            seen_cols[it] = False
            shortest[it] = np.inf
        for r in range(nr):
            seen_rows[r] = False
        n_remaining = nc
        min_val = 0.0
        i = current
        sink = -1
        while sink == -1:
            index = -1
            lowest = np.inf
            seen_rows[i] = True
            row = cost[i]
            u_i = u[i]
            for it in range(n_remaining):
                j = remaining[it]
                reduced = min_val + row[j] - u_i - v[j]
                if reduced < shortest[j]:
                    path[j] = i
                    shortest[j] = reduced
                if shortest[j] < lowest or (shortest[j] == lowest and row4col[j] == -1):
                    lowest = shortest[j]
                    index = it
            min_val = lowest
            if min_val == np.inf:
                for r in range(nr):
                    col4row[r] = -1
                return False
            j = remaining[index]
            if row4col[j] == -1:
                sink = j
            else:
                i = row4col[j]
            seen_cols[j] = True
            n_remaining -= 1
            remaining[index] = remaining[n_remaining]
        # Keep the duals feasible, then flip the path.
        u[current] += min_val
        for r in range(nr):
            if seen_rows[r] and r != current:
                u[r] += min_val - shortest[col4row[r]]
        for j in range(nc):
            if seen_cols[j]:
                v[j] -= min_val - shortest[j]
        j = sink
        while True:
            i = path[j]
            row4col[j] = i
            previous = col4row[i]
            col4row[i] = j
            j = previous
            if i == current:
                break
    return True


@jit(strict=True)
def lsap(cost, row_to_col):
    """Minimum-cost assignment of an ``(nr, nc)`` float64 C-contiguous ``cost`` matrix
    (``+inf`` = forbidden; no NaN or ``-inf``).

    Writes ``row_to_col`` (nr,) int64: each row's column, -1 for a row left out (when
    nr > nc, or every row when infeasible). Returns True, or False if no assignment of
    ``min(nr, nc)`` pairs has a finite cost.
    """
    nr, nc = cost.shape
    for i in range(nr):
        row_to_col[i] = -1
    if nr == 0 or nc == 0:
        return True
    if nr <= nc:
        return _shortest_paths(cost, row_to_col)
    transposed = np.empty((nc, nr))
    for i in range(nr):
        for j in range(nc):
            transposed[j, i] = cost[i, j]
    col_to_row = np.empty(nc, dtype=np.int64)
    feasible = _shortest_paths(transposed, col_to_row)
    if feasible:
        for j in range(nc):
            row_to_col[col_to_row[j]] = j
    return feasible


@jit(strict=True)
def lsap_batch(costs, offsets, shapes, row_offsets, row_to_col, feasible):
    """Solve k problems in one call.

    Problem q's ``(shapes[q, 0], shapes[q, 1])`` matrix is ``costs[offsets[q]:offsets[q +
    1]]`` in row-major order (``costs`` 1-D float64, ``offsets`` (k + 1,) int64, ``shapes``
    (k, 2) int64); its rows' columns go to ``row_to_col[row_offsets[q]:row_offsets[q + 1]]``
    (``row_offsets`` (k + 1,), the running sums of the row counts), and ``feasible[q]``
    (bool) says whether it had a finite assignment, as for :func:`lsap`. The offsets are
    positions in ``costs`` and ``row_to_col``, so a slice of the problems (of ``offsets``,
    ``shapes``, ``row_offsets`` and ``feasible``) solves those problems alone.
    """
    for q in range(shapes.shape[0]):
        block = costs[offsets[q]:offsets[q + 1]]
        out = row_to_col[row_offsets[q]:row_offsets[q + 1]]
        feasible[q] = lsap(block.reshape((shapes[q, 0], shapes[q, 1])), out)


@jit(strict=True)
def _distance(a, i, b, j):
    """Euclidean distance between rows ``a[i]`` and ``b[j]``."""
    total = 0.0
    for k in range(a.shape[1]):
        delta = a[i, k] - b[j, k]
        total += delta * delta
    return np.sqrt(total)


@jit(strict=True)
def _power(x, p):
    """``x ** p``, without a call to ``pow`` for p = 1 or 2 (the same value wherever it is
    computed, so that a pair at the cut-off compares equal to ``c ** p``)."""
    if p == 1.0:
        return x
    if p == 2.0:
        return x * x
    return x ** p


@jit(strict=True)
def _capped_costs(rows, cols, c, p):
    """The ``(len(rows), len(cols))`` matrix of ``min(|rows[i] - cols[j]|, c)^p``.

    A squared distance at or above ``c * c`` (rounded) has a root at or above c, so the
    far pairs (most of them, usually) skip the root and the power."""
    cut = _power(c, p)
    c2 = c * c
    cost = np.empty((rows.shape[0], cols.shape[0]))
    dim = rows.shape[1]
    for i in range(rows.shape[0]):
        a = rows[i]
        out = cost[i]
        for j in range(cols.shape[0]):
            b = cols[j]
            d2 = 0.0
            for k in range(dim):
                delta = a[k] - b[k]
                d2 += delta * delta
            if d2 >= c2:
                out[j] = cut
            else:
                d = np.sqrt(d2)
                out[j] = _power(d, p) if d < c else cut
    return cost


@jit(strict=True)
def _gospa_step(truths, estimates, c, p, alpha, assignment):
    """GOSPA of one step: ``(distance, localisation, missed, false)``; ``assignment`` (n,)
    gets each truth's estimate (-1 if none or, with alpha = 2, at the cut-off)."""
    n = truths.shape[0]
    m = estimates.shape[0]
    cut = _power(c, p)
    dummy = cut / alpha
    localisation = 0.0
    missed = 0.0
    false = 0.0
    for i in range(n):
        assignment[i] = -1
    if n == 0:
        false = m * dummy
        return false ** (1.0 / p), 0.0, 0.0, false
    if m == 0:
        missed = n * dummy
        return missed ** (1.0 / p), 0.0, missed, 0.0
    if n <= m:
        cost = _capped_costs(truths, estimates, c, p)
        _shortest_paths(cost, assignment)
    else:
        cost = _capped_costs(estimates, truths, c, p)
        truth_of = np.empty(m, dtype=np.int64)
        _shortest_paths(cost, truth_of)
        for j in range(m):
            assignment[truth_of[j]] = j
    total = (m - min(n, m)) * dummy
    false = total
    for i in range(n):
        j = assignment[i]
        if j == -1:
            total += dummy
            missed += dummy
            continue
        pair = cost[i, j] if n <= m else cost[j, i]
        total += pair
        if alpha == 2.0 and pair == cut:
            missed += dummy
            false += dummy
            assignment[i] = -1
        else:
            localisation += pair
    return total ** (1.0 / p), localisation, missed, false


@jit(strict=True)
def gospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, p, alpha, assignment,
                out):
    """GOSPA at every step.

    Step k's truths are ``truths[truth_offsets[k]:truth_offsets[k + 1]]`` of the stacked
    ``(N, d)`` truths, its estimates likewise; ``out`` (steps, 4) gets each step's distance,
    localisation, missed and false parts; ``assignment`` (N,) int64 each truth's estimate
    (its row within the step), -1 if unassigned (or at the cut-off, for alpha = 2). The
    offsets are positions in the stacked arrays, so a slice of the steps (of both offsets
    and ``out``) computes those steps alone.
    """
    for k in range(truth_offsets.size - 1):
        t0, t1 = truth_offsets[k], truth_offsets[k + 1]
        e0, e1 = estimate_offsets[k], estimate_offsets[k + 1]
        step_assignment = assignment[t0:t1]
        distance, localisation, missed, false = _gospa_step(
            truths[t0:t1], estimates[e0:e1], c, p, alpha, step_assignment)
        out[k, 0] = distance
        out[k, 1] = localisation
        out[k, 2] = missed
        out[k, 3] = false


@jit(strict=True)
def switching_loss(truth_ids, truth_offsets, estimate_offsets, assigned_ids, n_ids, out):
    """Stone Soup's GOSPA switching count at every step (before the penalty and the power
    1/p): ``out[k]`` adds 0.5 for each truth whose estimate changed since it was last
    assigned, 0.5 more if both the old and the new estimate exist.

    ``truth_ids`` (N,) are the truths' ids in ``[0, n_ids)``, ``assigned_ids`` (N,) the ids
    of their estimates (-1 if none). A truth's first record is its first step with an
    estimate; a step with no estimates at all changes no record (as in Stone Soup).
    """
    last = np.full(n_ids, -2, dtype=np.int64)  # -2: no record yet
    for k in range(truth_offsets.size - 1):
        loss = 0.0
        if estimate_offsets[k + 1] > estimate_offsets[k]:
            for t in range(truth_offsets[k], truth_offsets[k + 1]):
                truth, estimate = truth_ids[t], assigned_ids[t]
                previous = last[truth]
                if previous == -2:
                    if estimate != -1:
                        last[truth] = estimate
                elif previous != estimate:
                    loss += 0.5
                    if estimate != -1 and previous != -1:
                        loss += 0.5
                    last[truth] = estimate
        out[k] = loss


@jit(strict=True)
def _bottleneck(cost):
    """The smallest largest entry over the complete assignments of a square ``cost``."""
    n = cost.shape[0]
    values = cost.ravel()
    order = stable_argsort(values)
    allowed = np.empty((n, n))
    scratch = np.empty(n, dtype=np.int64)
    lo, hi = 0, values.size - 1  # values[order[hi]] always admits an assignment
    while lo < hi:
        mid = (lo + hi) // 2
        bound = values[order[mid]]
        for i in range(n):
            for j in range(n):
                allowed[i, j] = 0.0 if cost[i, j] <= bound else np.inf
        if _shortest_paths(allowed, scratch):
            hi = mid
        else:
            lo = mid + 1
    return values[order[hi]]


@jit(strict=True)
def _ospa_step(truths, estimates, c, p, stonesoup):
    n = truths.shape[0]
    m = estimates.shape[0]
    big = max(n, m)
    if big == 0:
        return 0.0
    if p == np.inf:
        if n != m:
            return c
        if stonesoup:  # Stone Soup minimises the sum, then takes the largest pair
            cost = _capped_costs(estimates, truths, c, 1.0)
            pairs = np.empty(n, dtype=np.int64)
            _shortest_paths(cost, pairs)
            largest = 0.0
            for i in range(n):
                largest = max(largest, cost[i, pairs[i]])
            return largest
        return _bottleneck(_capped_costs(truths, estimates, c, 1.0))
    if stonesoup:  # Stone Soup: the square matrix of min(d, c) padded with c, then ^p
        cost = np.full((big, big), c)
        for i in range(m):
            for j in range(n):
                d = _distance(estimates, i, truths, j)
                if d < c:
                    cost[i, j] = d
        pairs = np.empty(big, dtype=np.int64)
        _shortest_paths(cost, pairs)
        total = 0.0
        for i in range(big):
            total += _power(cost[i, pairs[i]], p)
        return ((1.0 / big) * total) ** (1.0 / p)
    small = min(n, m)
    total = (big - small) * _power(c, p)
    if small > 0:
        cost = _capped_costs(truths, estimates, c, p) if n <= m else _capped_costs(
            estimates, truths, c, p)
        pairs = np.empty(small, dtype=np.int64)
        _shortest_paths(cost, pairs)
        for i in range(small):
            total += cost[i, pairs[i]]
    return (total / big) ** (1.0 / p)


@jit(strict=True)
def ospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, p, stonesoup, out):
    """OSPA at every step (layout, and slices, as :func:`gospa_steps`): ``out`` (steps,).
    ``stonesoup`` (bool) reproduces Stone Soup 1.9.1's ``OSPAMetric``, which chooses the
    pairs minimising ``sum min(d, c)`` rather than ``sum min(d, c)^p`` (the same for p = 1),
    and for p = inf the largest pair of that choice rather than the bottleneck.
    """
    for k in range(truth_offsets.size - 1):
        t0, t1 = truth_offsets[k], truth_offsets[k + 1]
        e0, e1 = estimate_offsets[k], estimate_offsets[k + 1]
        out[k] = _ospa_step(truths[t0:t1], estimates[e0:e1], c, p, stonesoup)
