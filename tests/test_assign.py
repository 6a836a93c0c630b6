"""The compiled 2-D assignment solver against SciPy (same totals, and the same pairs, ties
included), brute force and its mirror; the batched kernel; GNN association against Stone
Soup's GNNWith2DAssignment; bad input."""
import datetime
import itertools
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

from fasttrack._jit import assign as kernels
from fasttrack.core.assign import assign2d, assign2d_batch, gnn_assign

import reference.assign


def _total(cost, rows, cols):
    return cost[rows, cols].sum()


def _check_like_scipy(cost, maximize=False):
    rows, cols = assign2d(cost, maximize=maximize)
    want_rows, want_cols = linear_sum_assignment(cost, maximize=maximize)
    assert rows.dtype == cols.dtype == np.int64
    assert np.isclose(_total(cost, rows, cols), _total(cost, want_rows, want_cols),
                      rtol=1e-12, atol=1e-12)
    # the same algorithm and tie-breaking as SciPy: the same pairs
    assert np.array_equal(rows, want_rows) and np.array_equal(cols, want_cols)


SHAPES = [(1, 1), (5, 5), (30, 30), (100, 100), (7, 40), (40, 7), (1, 9), (9, 1), (64, 65)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("seed", range(3))
def test_random_dense_matches_scipy(shape, seed):
    rng = np.random.default_rng(seed)
    _check_like_scipy(rng.random(shape))
    _check_like_scipy(rng.normal(0, 1e3, shape))
    _check_like_scipy(rng.random(shape), maximize=True)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("levels", [1, 2, 3, 10])
def test_tie_heavy_integer_costs_match_scipy(shape, levels):
    rng = np.random.default_rng(levels)
    for _ in range(3):
        _check_like_scipy(rng.integers(0, levels, shape).astype(float))
    _check_like_scipy(rng.integers(0, levels, shape))  # integer dtype accepted


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("forbidden", [0.2, 0.5, 0.8])
def test_forbidden_pairs_match_scipy_or_are_infeasible_like_scipy(shape, forbidden):
    rng = np.random.default_rng(int(forbidden * 10))
    for _ in range(5):
        cost = rng.random(shape)
        cost[rng.random(shape) < forbidden] = np.inf
        try:
            linear_sum_assignment(cost)
        except ValueError:
            with pytest.raises(ValueError, match="cost is infeasible"):
                assign2d(cost)
            out = np.zeros(shape[0], dtype=np.int64)
            assert not kernels.lsap(cost, out) and (out == -1).all()
            continue
        _check_like_scipy(cost)
        neg = -cost
        _check_like_scipy(neg, maximize=True)


def test_gated_tracking_matrix_matches_scipy():
    """The baseline's gated GNN matrix: separated targets, most pairs at a large cost."""
    rng = np.random.default_rng(0)
    n = 300
    side = int(np.ceil(np.sqrt(n)))
    grid = np.c_[np.meshgrid(np.arange(side), np.arange(side))[0].ravel(),
                 np.meshgrid(np.arange(side), np.arange(side))[1].ravel()][:n] * 20.0
    z = grid + rng.normal(0, 1, (n, 2))
    cost = ((z[None] - grid[:, None]) ** 2).sum(-1) / 3
    cost[cost > 25] = 1e6
    _check_like_scipy(cost)
    cost[cost == 1e6] = np.inf
    _check_like_scipy(cost)


def test_empty_and_degenerate_matrices():
    for shape in [(0, 0), (0, 4), (4, 0)]:
        rows, cols = assign2d(np.empty(shape))
        assert rows.size == cols.size == 0
    rows, cols = assign2d(np.full((3, 3), 7.0))  # constant: the identity, as SciPy
    assert rows.tolist() == cols.tolist() == [0, 1, 2]
    with pytest.raises(ValueError, match="infeasible"):
        assign2d([[np.inf, 1.0], [np.inf, 2.0]])


def test_kernel_equals_its_mirror():
    rng = np.random.default_rng(4)
    for _ in range(50):
        shape = tuple(rng.integers(0, 9, 2))
        cost = rng.integers(0, 4, shape).astype(float)
        cost[rng.random(shape) < 0.3] = np.inf
        got, want = np.empty(shape[0], np.int64), np.empty(shape[0], np.int64)
        assert kernels.lsap(cost, got) == reference.assign.lsap(cost, want)
        assert np.array_equal(got, want)


def _brute_force(cost):
    """The least total over all assignments of min(n, m) pairs (inf if none is finite)."""
    n, m = cost.shape
    if n > m:
        return _brute_force(cost.T)
    best = np.inf if n else 0.0
    for cols in itertools.permutations(range(m), n):
        best = min(best, cost[np.arange(n), list(cols)].sum())
    return best


@st.composite
def small_problems(draw):
    n, m = draw(st.integers(0, 6)), draw(st.integers(0, 6))
    kind = draw(st.sampled_from(["float", "integer", "forbidden", "constant"]))
    seed = draw(st.integers(0, 2**31))
    rng = np.random.default_rng(seed)
    if kind == "integer":
        cost = rng.integers(-3, 4, (n, m)).astype(float)
    elif kind == "constant":
        cost = np.full((n, m), draw(st.floats(-1e6, 1e6)))
    else:
        cost = rng.normal(0, draw(st.sampled_from([1e-3, 1.0, 1e6])), (n, m))
    if kind == "forbidden":
        cost[rng.random((n, m)) < draw(st.floats(0, 1))] = np.inf
    return cost


@settings(max_examples=400, deadline=None)
@given(cost=small_problems())
def test_the_assignment_is_optimal_against_brute_force(cost):
    best = _brute_force(cost)
    if best == np.inf:
        with pytest.raises(ValueError, match="infeasible"):
            assign2d(cost)
        return
    rows, cols = assign2d(cost)
    assert rows.size == min(cost.shape)
    assert np.unique(rows).size == rows.size and np.unique(cols).size == cols.size
    assert np.isfinite(cost[rows, cols]).all()
    scale = max(1.0, np.abs(cost[np.isfinite(cost)]).max(initial=0.0))
    assert abs(_total(cost, rows, cols) - best) <= 1e-9 * scale * max(cost.shape)


def _problems(rng, k):
    problems = []
    for q in range(k):
        shape = tuple(rng.integers(0, 12, 2))
        cost = rng.integers(0, 5, shape).astype(float) if q % 2 else rng.random(shape)
        if q % 3 == 0:
            cost[rng.random(shape) < 0.2] = np.inf
        problems.append(cost)
    return problems


def _packed(problems):
    shapes = np.array([c.shape for c in problems], dtype=np.int64).reshape(-1, 2)
    offsets = np.r_[0, np.cumsum(shapes[:, 0] * shapes[:, 1])].astype(np.int64)
    row_offsets = np.r_[0, np.cumsum(shapes[:, 0])].astype(np.int64)
    flat = np.concatenate([c.ravel() for c in problems] + [np.empty(0)])
    return flat, offsets, shapes, row_offsets


@pytest.mark.parametrize("k", [0, 1, 7, 400])
def test_the_batched_kernel_equals_the_problems_solved_one_by_one(k):
    rng = np.random.default_rng(k)
    problems = _problems(rng, k)
    flat, offsets, shapes, row_offsets = _packed(problems)
    got = np.full(row_offsets[-1], -7, dtype=np.int64)
    feasible = np.zeros(k, dtype=np.bool_)
    kernels.lsap_batch(flat, offsets, shapes, row_offsets, got, feasible)
    want = np.empty_like(got)
    want_feasible = np.zeros(k, dtype=np.bool_)
    reference.assign.lsap_batch(flat, offsets, shapes, row_offsets, want, want_feasible)
    assert np.array_equal(feasible, want_feasible)
    assert np.array_equal(got, want)
    for q, cost in enumerate(problems):
        one = np.empty(cost.shape[0], dtype=np.int64)
        assert kernels.lsap(cost, one) == feasible[q]
        assert np.array_equal(one, got[row_offsets[q]:row_offsets[q + 1]])


def test_the_batch_wrapper_returns_each_problems_columns():
    rng = np.random.default_rng(1)
    problems = [rng.random(tuple(rng.integers(0, 10, 2))) for _ in range(60)]
    for cost, row_to_col in zip(problems, assign2d_batch(problems)):
        rows, cols = linear_sum_assignment(cost)
        want = np.full(cost.shape[0], -1)
        want[rows] = cols
        assert np.array_equal(row_to_col, want)
    assert assign2d_batch([]) == []
    stacked = rng.random((5, 3, 4))
    assert [r.tolist() for r in assign2d_batch(stacked)] == [
        assign2d(c)[1].tolist() for c in stacked]
    with pytest.raises(ValueError, match=r"costs\[1\] is infeasible"):
        assign2d_batch([np.ones((2, 2)), [[np.inf, 1.0], [np.inf, 1.0]]])
    with pytest.raises(ValueError, match=r"costs\[0\] contains NaN"):
        assign2d_batch([[[np.nan]]])
    with pytest.raises(TypeError, match="costs must be a sequence"):
        assign2d_batch(3.0)
    arrays = [rng.random((4, 3)), rng.random((2, 5)), rng.random((3, 3))]
    arrays[2][1, 1] = np.nan
    with pytest.raises(ValueError, match=r"costs\[2\] contains NaN"):
        assign2d_batch(arrays)
    arrays[2][1, 1] = -np.inf
    with pytest.raises(ValueError, match=r"costs\[2\] contains -inf"):
        assign2d_batch(arrays)
    with pytest.raises(ValueError, match=r"costs\[2\] contains \+inf"):
        assign2d_batch([a.copy() for a in arrays[:2]] + [-arrays[2]], maximize=True)
    stacked[3, 0, 0] = np.nan
    with pytest.raises(ValueError, match=r"costs\[3\] contains NaN"):
        assign2d_batch(stacked)
    assert assign2d_batch(np.empty((0, 2, 2))) == []


def test_the_batch_wrapper_maximises_like_scipy():
    rng = np.random.default_rng(2)
    problems = [rng.random(tuple(rng.integers(1, 8, 2))) for _ in range(30)]
    problems[3] = problems[3].astype(np.float32)
    problems[4] = problems[4].tolist()
    for maximize in (False, True):
        problems[5][0, 0] = -np.inf if maximize else np.inf  # forbidden either way
        for cost, row_to_col in zip(problems, assign2d_batch(problems, maximize=maximize)):
            rows, cols = linear_sum_assignment(np.asarray(cost, dtype=float), maximize=maximize)
            want = np.full(len(cost), -1)
            want[rows] = cols
            assert np.array_equal(row_to_col, want)


_THREADS = r"""
import json, sys
import numpy as np
sys.path.insert(0, "tests")
from fasttrack.core.assign import assign2d_batch
rng = np.random.default_rng(5)
problems = [rng.integers(0, 4, (30, 30)).astype(float) for _ in range(300)]
print(json.dumps([r.tolist() for r in assign2d_batch(problems)]))
"""


def test_the_batched_kernel_does_not_depend_on_the_thread_count():
    results = []
    for threads in ("1", "2"):
        done = subprocess.run([sys.executable, "-c", _THREADS], capture_output=True, text=True,
                              env=dict(os.environ, NUMBA_NUM_THREADS=threads), timeout=600,
                              cwd=os.path.dirname(os.path.dirname(__file__)))
        assert done.returncode == 0, done.stderr
        results.append(json.loads(done.stdout))
    assert results[0] == results[1]


def test_kernels_run_with_the_jit_disabled():
    code = ("import numpy as np; from fasttrack._jit import assign as k; "
            "c = np.array([[4., 1, 3], [2, 0, 5], [3, 2, 2], [1, 1, 1]]); "
            "o = np.empty(4, np.int64); f = np.empty(1, bool); "
            "print(k.lsap(c, o), o.tolist()); "
            "k.lsap_batch(c.ravel(), np.array([0, 12]), np.array([[4, 3]]), np.array([0, 4]), "
            "o, f); print(f.tolist(), o.tolist())")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=dict(os.environ, NUMBA_DISABLE_JIT="1"), timeout=600)
    assert done.returncode == 0, done.stderr
    rows, cols = linear_sum_assignment(np.array([[4., 1, 3], [2, 0, 5], [3, 2, 2], [1, 1, 1]]))
    want = np.full(4, -1)
    want[rows] = cols
    assert done.stdout.split("\n")[:2] == [f"True {want.tolist()}",
                                           f"[True] {want.tolist()}"]


@pytest.mark.parametrize("bad, error, match", [
    (np.array([[1.0, np.nan]]), ValueError, "cost contains NaN"),
    (np.array([[1.0, -np.inf]]), ValueError, r"cost contains -inf"),
    (np.ones(3), ValueError, "cost must be 2-D"),
    (np.ones((2, 2, 2)), ValueError, "cost must be 2-D"),
    ("abc", TypeError, "cost must be"),
    (None, TypeError, "cost must be"),
    (np.ones((2, 2), dtype=complex), TypeError, "cost must be a numeric array of real"),
    (np.ones((2, 2), dtype=bool), TypeError, "cost must be a numeric array of real"),
    ([[1.0, "a"]], TypeError, "cost must be a numeric array of real"),
])
def test_bad_cost_matrices_are_rejected_naming_cost(bad, error, match):
    with pytest.raises(error, match=match):
        assign2d(bad)
    with pytest.raises(error, match=match):
        gnn_assign(bad, 1.0)


@pytest.mark.parametrize("maximize", ["no", 1, None, np.array([True])])
def test_maximize_must_be_a_bool(maximize):
    with pytest.raises(TypeError, match="maximize must be a bool"):
        assign2d(np.ones((2, 2)), maximize=maximize)
    with pytest.raises(TypeError, match="maximize must be a bool"):
        assign2d_batch([np.ones((2, 2))], maximize=maximize)


def test_maximising_rejects_plus_inf_and_the_input_is_not_modified():
    with pytest.raises(ValueError, match=r"cost contains \+inf"):
        assign2d([[1.0, np.inf]], maximize=True)
    cost = np.random.default_rng(0).random((6, 4))
    before = cost.copy()
    assign2d(cost, maximize=True)
    gnn_assign(cost, 0.5)
    assert np.array_equal(cost, before)


# --- GNN -----------------------------------------------------------------------------------


def _gnn_reference(cost, missed):
    """Stone Soup's GNNWith2DAssignment matrix, solved by SciPy."""
    n, m = cost.shape
    missed = np.broadcast_to(missed, (n,))
    out = np.full(n, -1)
    rows = np.flatnonzero(np.isfinite(cost).any(axis=1))
    if rows.size == 0:
        return out
    matrix = np.full((rows.size, m + rows.size), np.inf)
    matrix[:, :m] = cost[rows]
    matrix[np.arange(rows.size), m + np.arange(rows.size)] = missed[rows]
    r, c = linear_sum_assignment(matrix)
    out[rows[r]] = np.where(c < m, c, -1)
    return out


def _gnn_cost(rng, n, m, ties=False, gate=0.5):
    cost = rng.integers(0, 4, (n, m)).astype(float) if ties else rng.random((n, m)) * 10
    cost[rng.random((n, m)) < gate] = np.inf
    return cost


@pytest.mark.parametrize("n, m", [(0, 0), (0, 3), (3, 0), (1, 1), (5, 8), (8, 5), (40, 40)])
@pytest.mark.parametrize("ties", [False, True])
def test_gnn_equals_stone_soups_matrix_solved_by_scipy(n, m, ties):
    rng = np.random.default_rng(n * 100 + m)
    for _ in range(10):
        cost = _gnn_cost(rng, n, m, ties)
        for missed in (2.0, rng.random(n) * 6, np.inf):
            try:
                want = _gnn_reference(cost, missed)
            except ValueError:
                with pytest.raises(ValueError, match="no feasible association"):
                    gnn_assign(cost, missed)
                continue
            got = gnn_assign(cost, missed)
            assert got.shape == (n,) and got.dtype == np.int64
            assert np.array_equal(got, want)
            used = got[got >= 0]
            assert np.unique(used).size == used.size


@settings(max_examples=300, deadline=None)
@given(n=st.integers(0, 5), m=st.integers(0, 5), seed=st.integers(0, 2**31),
       missed=st.floats(0, 5))
def test_gnn_is_optimal_against_brute_force(n, m, seed, missed):
    rng = np.random.default_rng(seed)
    cost = _gnn_cost(rng, n, m, ties=bool(seed % 2), gate=0.3)
    got = gnn_assign(cost, missed)
    total = sum(cost[i, j] if j >= 0 else missed for i, j in enumerate(got))
    best = np.inf
    for choice in itertools.product(range(-1, m), repeat=n):  # -1: missed
        used = [j for j in choice if j >= 0]
        if len(set(used)) == len(used):
            best = min(best, sum(cost[i, j] if j >= 0 else missed for i, j in enumerate(choice)))
    assert np.isclose(total, best, rtol=1e-12, atol=1e-12)


def test_gnn_missed_cost_checks():
    cost = np.ones((3, 2))
    with pytest.raises(ValueError, match=r"missed_cost must be a number or have shape \(3,\)"):
        gnn_assign(cost, [1.0, 2.0])
    with pytest.raises(ValueError, match="missed_cost contains NaN or -inf"):
        gnn_assign(cost, np.nan)
    with pytest.raises(ValueError, match="missed_cost contains NaN or -inf"):
        gnn_assign(cost, [1.0, -np.inf, 1.0])
    with pytest.raises(TypeError, match="missed_cost must be a numeric array"):
        gnn_assign(cost, "1")
    with pytest.raises(ValueError, match="no feasible association: 3 tracks"):
        gnn_assign(cost, np.inf)  # 3 tracks must each take one of 2 detections
    assert gnn_assign(np.full((2, 2), np.inf), np.inf).tolist() == [-1, -1]


class _MatrixHypothesiser:
    """A Stone Soup hypothesiser whose distances come from a matrix: the missed-detection
    hypothesis at ``missed[i]``, one hypothesis per finite entry (as DistanceHypothesiser
    with ``include_all``)."""

    def __init__(self, cost, missed, tracks, detections):
        self.cost, self.missed = cost, missed
        self.row = {id(t): i for i, t in enumerate(tracks)}
        self.col = {id(d): j for j, d in enumerate(detections)}

    def hypothesise(self, track, detections, timestamp, **kwargs):
        from stonesoup.types.detection import MissedDetection
        from stonesoup.types.hypothesis import SingleDistanceHypothesis
        from stonesoup.types.multihypothesis import MultipleHypothesis
        from stonesoup.types.prediction import GaussianStatePrediction
        i = self.row[id(track)]
        prediction = GaussianStatePrediction(track.state_vector, track.covar,
                                             timestamp=timestamp)
        hypotheses = [SingleDistanceHypothesis(prediction, MissedDetection(timestamp=timestamp),
                                               self.missed[i])]
        for detection in detections:
            distance = self.cost[i, self.col[id(detection)]]
            if np.isfinite(distance):
                hypotheses.append(SingleDistanceHypothesis(prediction, detection, distance))
        return MultipleHypothesis(sorted(hypotheses, reverse=True))


@pytest.mark.parametrize("ties", [False, True])
def test_gnn_reproduces_stone_soups_gnn_with_2d_assignment(ties):
    pytest.importorskip("stonesoup")
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    t0 = datetime.datetime(2025, 1, 1)
    rng = np.random.default_rng(3)
    for trial in range(20):
        n, m = rng.integers(1, 9, 2)
        cost = _gnn_cost(rng, n, m, ties, gate=0.4)
        missed = rng.integers(1, 4, n).astype(float) if ties else rng.random(n) * 8
        tracks = [Track([GaussianState(np.zeros((2, 1)), np.eye(2), timestamp=t0)])
                  for _ in range(n)]
        detections = [Detection(np.zeros((2, 1)), timestamp=t0) for _ in range(m)]
        associator = GNNWith2DAssignment(_MatrixHypothesiser(cost, missed, tracks, detections))
        result = associator.associate(tracks, detections, t0)
        want = [detections.index(result[t].measurement) if result[t] else -1 for t in tracks]
        assert gnn_assign(cost, missed).tolist() == want, trial
