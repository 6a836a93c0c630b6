"""GOSPA and OSPA: the kernels against their mirrors (SciPy's pairs on the definitions), the
public functions against Stone Soup 1.9.1's GOSPAMetric and OSPAMetric on the same states
(switching included), closed forms at the edges, input layouts, threads and bad input."""
import datetime
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import fasttrack as ft
from fasttrack import metrics
from fasttrack._jit import assign as kernels
from fasttrack.core import metric_numpy
from fasttrack.metrics import gospa, gospa_over_time, ospa, ospa_over_time, position_rmse

import reference.assign

T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)


def _scenario(seed, steps=25, n_truths=8, n_tracks=10, present=0.85, swap=0.15, spacing=6.0):
    """Per-step truths and estimates (4-D states) with their ids: truths on lines, tracks
    following a truth that changes now and then (switches), some appearing late or
    missing steps, two of them clutter. Every step has at least one truth."""
    rng = np.random.default_rng(seed)
    start = np.c_[np.arange(n_truths) * spacing, rng.normal(0, 1, n_truths),
                  rng.normal(0, 5, n_truths), rng.normal(0, 1, n_truths)]
    follows = rng.permutation(n_truths + 2)[:n_tracks] % (n_truths + 2)
    truths, estimates, truth_ids, estimate_ids = [], [], [], []
    for k in range(steps):
        x = start + k * np.c_[start[:, 1], np.zeros(n_truths), start[:, 3], np.zeros(n_truths)]
        seen = rng.random(n_truths) < present
        seen[rng.integers(n_truths)] = True
        if rng.random() < swap:
            a, b = rng.integers(n_tracks, size=2)
            follows[[a, b]] = follows[[b, a]]
        shown = rng.random(n_tracks) < present
        y = np.empty((n_tracks, 4))
        for j in range(n_tracks):
            if follows[j] < n_truths:
                y[j] = x[follows[j]] + rng.normal(0, 1.5, 4)
            else:
                y[j] = rng.uniform(-10, spacing * n_truths, 4)
        truths.append(x[seen])
        truth_ids.append(np.flatnonzero(seen))
        estimates.append(y[shown])
        estimate_ids.append(np.flatnonzero(shown))
    return truths, estimates, truth_ids, estimate_ids


def _stonesoup_objects(truths, estimates, truth_ids, estimate_ids):
    """Stone Soup GroundTruthPaths and Tracks (lists, so their ids are list positions)."""
    from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    n_truths = 1 + max(int(i.max(initial=-1)) for i in truth_ids)
    n_tracks = 1 + max(int(i.max(initial=-1)) for i in estimate_ids)
    paths = [GroundTruthPath() for _ in range(n_truths)]
    tracks = [Track() for _ in range(n_tracks)]
    for k, (x, y, xi, yi) in enumerate(zip(truths, estimates, truth_ids, estimate_ids)):
        for row, i in zip(x, xi):
            paths[i].append(GroundTruthState(row.reshape(-1, 1), timestamp=T0 + k * DT))
        for row, j in zip(y, yi):
            tracks[j].append(GaussianState(row.reshape(-1, 1), np.eye(row.size),
                                           timestamp=T0 + k * DT))
    return paths, tracks


def _stonesoup_gospa(paths, tracks, c, p, switching_penalty=0.0):
    from stonesoup.metricgenerator.ospametric import GOSPAMetric
    metric = GOSPAMetric(c=c, p=p, switching_penalty=switching_penalty)
    result = metric.compute_over_time(*metric.extract_states(tracks, True),
                                      *metric.extract_states(paths, True))
    return {key: np.array([m.value[key] for m in result.value], dtype=float)
            for key in ("distance", "localisation", "missed", "false", "switching")}


def _stonesoup_ospa(paths, tracks, c, p):
    from stonesoup.metricgenerator.ospametric import OSPAMetric
    metric = OSPAMetric(c=c, p=p)
    result = metric.compute_over_time(*metric.extract_states(tracks, True),
                                      *metric.extract_states(paths, True))
    return np.array([m.value for m in result.value], dtype=float)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("c, p", [(10.0, 1), (4.0, 2), (3.0, 1.5)])
@pytest.mark.parametrize("switching_penalty", [0.0, 2.0])
def test_gospa_over_time_matches_stone_soup(seed, c, p, switching_penalty):
    pytest.importorskip("stonesoup")
    truths, estimates, truth_ids, estimate_ids = _scenario(seed)
    want = _stonesoup_gospa(*_stonesoup_objects(truths, estimates, truth_ids, estimate_ids),
                            c, p, switching_penalty)
    got = gospa_over_time(truths, estimates, c, p, switching_penalty=switching_penalty,
                          truth_ids=truth_ids, estimate_ids=estimate_ids)
    for key, values in want.items():
        assert np.allclose(getattr(got, key), values, rtol=1e-12, atol=1e-9), key
    if switching_penalty:
        assert got.switching.max() > 0  # the scenario does switch


def test_gospa_matches_stone_soup_on_the_baseline_workload():
    """/work/shared/stonesoup_mtt_baseline.py's ss_gospa: truths 20 m apart, tracks at unit
    noise in all four components, c = 10, p = 1 (Stone Soup's default Euclidean measure
    uses every component)."""
    pytest.importorskip("stonesoup")
    rng = np.random.default_rng(0)
    n, steps = 12, 15
    x = np.empty((steps, n, 4))
    y = np.empty((steps, n, 4))
    for i in range(n):
        for k in range(steps):
            x[k, i] = [i * 20.0 + k, 1.0, k * 1.0, 1.0]
            y[k, i] = x[k, i] + rng.normal(0, 1, 4)
    ids = [np.arange(n)] * steps
    want = _stonesoup_gospa(*_stonesoup_objects(list(x), list(y), ids, ids), 10, 1)
    got = gospa_over_time(x, y, 10, 1)
    for key, values in want.items():
        assert np.allclose(getattr(got, key), values, rtol=1e-12, atol=1e-9), key
    assert np.allclose(ospa_over_time(x, y, 10, 1),
                       _stonesoup_ospa(*_stonesoup_objects(list(x), list(y), ids, ids), 10, 1),
                       rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_one_step_gospa_reproduces_stone_soups_assignment_ties_included(seed):
    pytest.importorskip("stonesoup")
    from stonesoup.metricgenerator.ospametric import GOSPAMetric
    from stonesoup.types.groundtruth import GroundTruthState
    from stonesoup.types.state import State
    rng = np.random.default_rng(seed)
    for trial in range(20):
        n, m = rng.integers(0, 9, 2)
        if n == m == 0:
            continue  # Stone Soup needs a state for the timestamp
        x = rng.integers(0, 6, (n, 2)).astype(float)  # a grid: ties, pairs at the cut-off
        y = rng.integers(0, 6, (m, 2)).astype(float)
        c, p = float(rng.choice([1.0, 2.0, 3.0])), float(rng.choice([1, 2]))
        metric = GOSPAMetric(c=c, p=p)
        want, want_assignment = metric.compute_gospa_metric(
            [State(v.reshape(-1, 1), timestamp=T0) for v in y],
            [GroundTruthState(v.reshape(-1, 1), timestamp=T0) for v in x])
        got = gospa(x, y, c, p)
        for key in ("distance", "localisation", "missed", "false"):
            assert np.isclose(getattr(got, key), want.value[key], rtol=1e-12, atol=1e-12)
        if n and m:
            assert got.assignment.tolist() == list(want_assignment), trial
        else:
            assert (got.assignment == -1).all() and got.assignment.shape == (n,)


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("p", [1, 2, np.inf])
def test_ospa_matches_stone_soup(seed, p):
    pytest.importorskip("stonesoup")
    truths, estimates, truth_ids, estimate_ids = _scenario(seed, present=0.95)
    want = _stonesoup_ospa(*_stonesoup_objects(truths, estimates, truth_ids, estimate_ids),
                           5.0, p)
    got = ospa_over_time(truths, estimates, 5.0, p, stonesoup_pairs=True)
    assert np.allclose(got, want, rtol=1e-12, atol=1e-9)
    if p == 1:  # the same pairs either way
        assert np.allclose(ospa_over_time(truths, estimates, 5.0, p), want, rtol=1e-12,
                           atol=1e-9)
    else:  # the definition's pairs are never worse than Stone Soup's
        assert (ospa_over_time(truths, estimates, 5.0, p) <= want + 1e-9).all()


def _flat(steps):
    counts = [len(s) for s in steps]
    flat = np.concatenate([np.reshape(s, (-1, 4)) for s in steps])
    return flat, np.r_[0, np.cumsum(counts)].astype(np.int64)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("c, p, alpha", [(10.0, 1.0, 2.0), (3.0, 2.0, 2.0), (3.0, 1.0, 1.0),
                                         (2.0, 3.5, 0.5), (1.0, 1.0, 2.0)])
def test_gospa_kernel_equals_its_mirror(seed, c, p, alpha):
    truths, estimates, _, _ = _scenario(seed, steps=30, present=0.6)
    t, t_offsets = _flat(truths)
    e, e_offsets = _flat(estimates)
    got, want = np.empty((30, 4)), np.empty((30, 4))
    got_pairs, want_pairs = np.empty(len(t), np.int64), np.empty(len(t), np.int64)
    kernels.gospa_steps(t, t_offsets, e, e_offsets, c, p, alpha, got_pairs, got)
    reference.assign.gospa_steps(t, t_offsets, e, e_offsets, c, p, alpha, want_pairs, want)
    assert np.allclose(got, want, rtol=1e-12, atol=1e-12)
    assert np.array_equal(got_pairs, want_pairs)
    # the parts add up to distance^p
    assert np.allclose(got[:, 1:].sum(axis=1), got[:, 0] ** p, rtol=1e-12)


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("p", [1.0, 2.0, 3.0, np.inf])
@pytest.mark.parametrize("stonesoup", [False, True])
@pytest.mark.parametrize("implementation", ["kernel", "numpy"])
def test_ospa_kernel_and_its_numpy_twin_equal_the_mirror(seed, p, stonesoup, implementation):
    truths, estimates, _, _ = _scenario(seed, steps=30, present=0.7)
    truths[3] = truths[3][:0]
    estimates[3] = estimates[3][:0]  # a step with neither
    for k in range(0, 30, 4):  # some steps with as many estimates as truths (p = inf)
        estimates[k] = truths[k] + 1.0
    t, t_offsets = _flat(truths)
    e, e_offsets = _flat(estimates)
    got, want = np.empty(30), np.empty(30)
    ospa_steps = kernels.ospa_steps if implementation == "kernel" else metric_numpy.ospa_steps
    ospa_steps(t, t_offsets, e, e_offsets, 4.0, p, stonesoup, got)
    reference.assign.ospa_steps(t, t_offsets, e, e_offsets, 4.0, p, stonesoup, want)
    assert np.allclose(got, want, rtol=1e-12, atol=1e-12)


def test_switching_kernel_equals_its_mirror():
    rng = np.random.default_rng(2)
    steps = 200
    counts = rng.integers(0, 5, steps)
    offsets = np.r_[0, np.cumsum(counts)].astype(np.int64)
    estimate_offsets = np.r_[0, np.cumsum(rng.integers(0, 2, steps))].astype(np.int64)
    truth_ids = np.concatenate([rng.permutation(6)[:n] for n in counts]).astype(np.int64)
    assigned = rng.integers(-1, 4, offsets[-1]).astype(np.int64)
    got, want = np.empty(steps), np.empty(steps)
    kernels.switching_loss(truth_ids, offsets, estimate_offsets, assigned, 6, got)
    reference.assign.switching_loss(truth_ids, offsets, estimate_offsets, assigned, 6, want)
    assert np.array_equal(got, want) and got.max() >= 1.0


def test_edge_cases_have_their_closed_forms():
    none = np.empty((0, 2))
    one = np.array([[1.0, 2.0]])
    result = gospa(none, one, 3.0, 2)
    assert result == (pytest.approx(np.sqrt(4.5)), 0.0, 0.0, 4.5, 0.0, result.assignment)
    assert result.assignment.shape == (0,)
    result = gospa(one, none, 3.0, 1)
    assert result[:5] == (1.5, 0.0, 1.5, 0.0, 0.0) and result.assignment.tolist() == [-1]
    result = gospa(none, none, 3.0)
    assert result[:5] == (0.0, 0.0, 0.0, 0.0, 0.0)
    assert gospa([], [], 1.0).distance == 0.0
    far = np.array([[0.0, 0.0], [0.0, 100.0]])
    result = gospa(far, far + [50.0, 0.0], 4.0, 2)  # every pair at the cut-off
    assert result[:4] == (pytest.approx(np.sqrt(32.0)), 0.0, 16.0, 16.0)
    assert result.assignment.tolist() == [-1, -1]
    result = gospa(far, far + [50.0, 0.0], 4.0, 2, alpha=1)  # stays assigned
    assert result[:4] == (pytest.approx(np.sqrt(32.0)), 32.0, 0.0, 0.0)
    assert result.assignment.tolist() == [0, 1]
    result = gospa(far, far[::-1] + [0.5, 0.0], 4.0, 1)
    assert result[:4] == (pytest.approx(1.0), pytest.approx(1.0), 0.0, 0.0)
    assert result.assignment.tolist() == [1, 0]
    assert ospa(none, one, 3.0) == 3.0 and ospa(one, none, 3.0, np.inf) == 3.0
    assert ospa(none, none, 3.0) == 0.0 and ospa(none, none, 3.0, np.inf) == 0.0
    assert ospa(far, far[:1], 3.0, np.inf) == 3.0
    assert ospa(far, far + [0.0, 1.0], 3.0, np.inf) == 1.0
    assert ospa(far, far[:1], 4.0, 2) == pytest.approx(np.sqrt(16.0 / 2))


def test_one_step_functions_equal_a_step_over_time_and_layouts_agree():
    truths, estimates, truth_ids, estimate_ids = _scenario(5, steps=12, present=0.7)
    over = gospa_over_time(truths, estimates, 5.0, 2, switching_penalty=1.0,
                           truth_ids=truth_ids, estimate_ids=estimate_ids)
    for k in range(12):
        one = gospa(truths[k], estimates[k], 5.0, 2)
        assert one.localisation == over.localisation[k] and one.missed == over.missed[k]
        assert np.array_equal(one.assignment, over.assignment[k])
        assert ospa(truths[k], estimates[k], 5.0, 2) == ospa_over_time(
            truths, estimates, 5.0, 2)[k]
    # a padded array with counts: rows past the counts (NaN here) are ignored
    n = max(len(x) for x in truths)
    m = max(len(y) for y in estimates)
    padded_t = np.full((12, n, 4), np.nan)
    padded_e = np.full((12, m, 4), np.nan)
    ids_t = np.full((12, n), -1)
    ids_e = np.full((12, m), -1)
    for k in range(12):
        padded_t[k, :len(truths[k])] = truths[k]
        padded_e[k, :len(estimates[k])] = estimates[k]
        ids_t[k, :len(truths[k])] = truth_ids[k]
        ids_e[k, :len(estimates[k])] = estimate_ids[k]
    counts_t = [len(x) for x in truths]
    counts_e = [len(y) for y in estimates]
    padded = gospa_over_time(padded_t, padded_e, 5.0, 2, switching_penalty=1.0,
                             truth_ids=ids_t, estimate_ids=ids_e, truth_counts=counts_t,
                             estimate_counts=counts_e)
    for key in ("distance", "localisation", "missed", "false", "switching"):
        assert np.array_equal(getattr(padded, key), getattr(over, key)), key
    assert padded.assignment.shape == (12, n)
    for k in range(12):
        assert np.array_equal(padded.assignment[k, :counts_t[k]], over.assignment[k])
        assert (padded.assignment[k, counts_t[k]:] == -1).all()
    assert np.array_equal(ospa_over_time(padded_t, padded_e, 5.0, 2, truth_counts=counts_t,
                                         estimate_counts=counts_e),
                          ospa_over_time(truths, estimates, 5.0, 2))
    # without ids, row k of a padded array is object k throughout
    full = np.stack([x[:1] for x in truths])
    default = gospa_over_time(full, full[::-1] + 0.1, 5.0, switching_penalty=1.0)
    explicit = gospa_over_time(list(full), list(full[::-1] + 0.1), 5.0, switching_penalty=1.0,
                               truth_ids=[[0]] * 12, estimate_ids=[[0]] * 12)
    assert np.array_equal(default.distance, explicit.distance)


def test_inputs_are_not_modified_and_lists_of_lists_work():
    x = [[0.0, 0.0], [5.0, 5.0]]
    y = np.array([[0.5, 0.0], [5.0, 6.0], [20.0, 20.0]])
    before = y.copy()
    result = gospa(x, y, 3.0)
    assert np.array_equal(y, before)
    assert result.assignment.tolist() == [0, 1]
    assert result.false == 1.5 and result.localisation == pytest.approx(1.5)
    assert gospa_over_time([x, []], [y, []], 3.0).distance[1] == 0.0
    empty = gospa_over_time([], [], 3.0, switching_penalty=1.0)
    assert empty.distance.shape == (0,) and empty.assignment == []
    assert ospa_over_time([], [], 3.0).shape == (0,)
    assert gospa_over_time(np.empty((0, 3, 2)), np.empty((0, 1, 2)), 3.0).assignment.shape == (
        0, 3)


_THREADS = r"""
import json, sys
import numpy as np
from fasttrack.metrics import gospa_over_time, ospa_over_time
rng = np.random.default_rng(1)
x = rng.normal(0, 20, (400, 20, 2))
y = x[:, ::-1] + rng.normal(0, 2, (400, 20, 2))
counts = rng.integers(0, 21, 400)
r = gospa_over_time(x, y, 5.0, 2, truth_counts=counts, switching_penalty=1.0)
o = ospa_over_time(x, y, 5.0, 2, estimate_counts=counts)
print(json.dumps([r.distance.tolist(), r.assignment.tolist(), o.tolist()]))
"""


def test_results_do_not_depend_on_the_thread_count():
    results = []
    for threads in ("1", "2"):
        done = subprocess.run([sys.executable, "-c", _THREADS], capture_output=True, text=True,
                              env=dict(os.environ, NUMBA_NUM_THREADS=threads), timeout=600)
        assert done.returncode == 0, done.stderr
        results.append(json.loads(done.stdout))
    assert results[0] == results[1]


def test_kernels_run_with_the_jit_disabled():
    code = ("import numpy as np; from fasttrack.metrics import gospa, ospa; "
            "x = np.array([[0., 0], [4, 0], [9, 9]]); y = np.array([[1., 0], [4, 1]]); "
            "g = gospa(x, y, 3.0, 2); print(g.distance, g.assignment.tolist(), "
            "ospa(x, y, 3.0, 2), ospa(x, x + 1, 3.0, float('inf')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=dict(os.environ, NUMBA_DISABLE_JIT="1"), timeout=600)
    assert done.returncode == 0, done.stderr
    g = gospa([[0., 0], [4, 0], [9, 9]], [[1., 0], [4, 1]], 3.0, 2)
    want = [g.distance, g.assignment.tolist(), ospa([[0., 0], [4, 0], [9, 9]],
                                                   [[1., 0], [4, 1]], 3.0, 2),
            ospa(np.array([[0., 0], [4, 0], [9, 9]]), np.array([[1., 1], [5, 1], [10, 10]]),
                 3.0, np.inf)]
    assert done.stdout.split() == " ".join(str(v) for v in want).split()


@pytest.mark.parametrize("call, error, match", [
    (lambda: gospa([[np.nan, 0.0]], [[0.0, 0.0]], 1.0), ValueError, "truths contains NaN"),
    (lambda: gospa([[0.0, 0.0]], [[np.inf, 0.0]], 1.0), ValueError,
     "estimates contains NaN or infinite"),
    (lambda: gospa([[0.0, 0.0]], [[0.0, 0.0, 0.0]], 1.0), ValueError,
     "truths have 2 components and estimates 3"),
    (lambda: gospa([0.0, 0.0], [[0.0, 0.0]], 1.0), ValueError, r"truths must be a 2-D \(n, d\)"),
    (lambda: gospa("ab", [[0.0, 0.0]], 1.0), TypeError, "truths must be an"),
    (lambda: gospa([[1j]], [[0.0]], 1.0), TypeError, "truths must hold real numbers"),
    (lambda: gospa([[0.0]], [[0.0]], 0.0), ValueError, "c must be finite and > 0"),
    (lambda: gospa([[0.0]], [[0.0]], np.inf), ValueError, "c must be finite"),
    (lambda: gospa([[0.0]], [[0.0]], "1"), TypeError, "c must be a real number"),
    (lambda: gospa([[0.0]], [[0.0]], 1.0, p=0.5), ValueError, "p must be >= 1"),
    (lambda: gospa([[0.0]], [[0.0]], 1.0, p=np.inf), ValueError, "p must be finite"),
    (lambda: gospa([[0.0]], [[0.0]], 1.0, alpha=3), ValueError, r"alpha must lie in \(0, 2\]"),
    (lambda: gospa([[0.0]], [[0.0]], 1.0, alpha=0), ValueError, r"alpha must lie in \(0, 2\]"),
    (lambda: ospa([[0.0]], [[0.0]], 1.0, p=0.9), ValueError, r"p must be >= 1 \(or inf\)"),
    (lambda: ospa([[0.0]], [[0.0]], 1.0, stonesoup_pairs=1), TypeError,
     "stonesoup_pairs must be a bool"),
    (lambda: gospa_over_time([[[0.0]]], [[[0.0]], [[0.0]]], 1.0), ValueError,
     "truths have 1 steps and estimates 2"),
    (lambda: gospa_over_time([[[0.0, 1.0]], [[0.0]]], [[], []], 1.0), ValueError,
     r"truths\[1\] has 1 columns but truths\[0\] has 2"),
    (lambda: gospa_over_time([[[0.0]], [[np.nan]]], [[], []], 1.0), ValueError,
     r"truths contains NaN or infinite values \(step 1\)"),
    (lambda: gospa_over_time(np.zeros((2, 3, 2)), np.zeros((2, 3, 2)), 1.0,
                             truth_counts=[1, 4]), ValueError,
     r"truth_counts must lie in \[0, 3\]"),
    (lambda: gospa_over_time(np.zeros((2, 3, 2)), np.zeros((2, 3, 2)), 1.0,
                             estimate_counts=[1.0, 2.0]), TypeError,
     "estimate_counts must hold integers"),
    (lambda: gospa_over_time(np.zeros((2, 3, 2)), np.zeros((2, 3, 2)), 1.0,
                             estimate_counts=[1]), ValueError,
     "estimate_counts must be 2 integers"),
    (lambda: gospa([[0.0]], [[0.0]], 1e20, p=20), ValueError,
     r"c \*\* p must lie in \[1e-300, 1e300\].*c = 1e\+20, p = 20"),
    (lambda: gospa([[0.0]], [[0.0]], 10.0, p=400), ValueError,
     r"p must be at most 30, got 400: beyond it, the powers d \*\* p of distances under "
     r"1e-10 c underflow"),
    (lambda: gospa([[0.0]], [[0.0]], 1e200, p=2), ValueError, r"c \*\* p must lie in"),
    (lambda: gospa([[0.0]], [[0.0]], 1e-200, p=2), ValueError, r"c \*\* p must lie in"),
    (lambda: ospa([[0.0]], [[0.0]], 10.0, p=1e6), ValueError,
     r"p must be at most 30 \(or inf\), got 1e\+06"),
    (lambda: ospa([[1e300]], [[-1e300]], 1e-10), ValueError,
     r"truths lie too far out for the cut-off c = 1e-10"),
    (lambda: gospa_over_time([[[0.0]]], [[[0.0]]], 1.0, truth_counts=[1]), ValueError,
     "truth_counts is only for a padded"),
    (lambda: gospa_over_time(np.zeros((4, 2)), np.zeros((4, 2)), 1.0), TypeError,
     "truths must be a sequence of"),
    (lambda: gospa_over_time(5, [[]], 1.0), TypeError, "truths must be a sequence of"),
    (lambda: gospa_over_time([[[0.0]]], [[[0.0]]], 1.0, switching_penalty=-1), ValueError,
     "switching_penalty must be finite and >= 0"),
    (lambda: gospa_over_time([[[0.0], [1.0]]], [[[0.0]]], 1.0, switching_penalty=1,
                             truth_ids=[[3, 3]]), ValueError, "truth_ids repeats an id"),
    (lambda: gospa_over_time([[[0.0], [1.0]]], [[[0.0]]], 1.0, switching_penalty=1,
                             truth_ids=[[3]]), ValueError, "truth_ids must hold one id per"),
    (lambda: gospa_over_time([[[0.0]]], [[[0.0]]], 1.0, switching_penalty=1,
                             estimate_ids=[[0.5]]), TypeError, "estimate_ids must hold integers"),
    (lambda: gospa_over_time(np.zeros((2, 3, 1)), np.zeros((2, 3, 1)), 1.0,
                             truth_ids=np.zeros((2, 2), int)), ValueError,
     r"truth_ids must have shape \(2, 3\)"),
    (lambda: ospa_over_time([[[0.0]]], [[["a"]]], 1.0), TypeError,
     r"estimates\[0\] must hold real numbers"),
])
def test_bad_input_is_rejected_naming_the_argument(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_points_far_apart_are_at_the_cut_off():
    """A pair 2e200 apart (its squared distance overflows) costs c ** p, not inf."""
    far = gospa([[1e200, 0.0]], [[-1e200, 0.0]], 3.0, 2)
    assert far.distance == pytest.approx(np.sqrt(9.0))  # one missed and one false: 2 c^2 / 2
    assert far.assignment.tolist() == [-1]
    assert ospa([[1e200, 0.0]], [[-1e200, 0.0]], 3.0, 2) == pytest.approx(3.0)


def _states(vectors):
    return [ft.State(v, timestamp=float(k)) for k, v in enumerate(vectors)]


@pytest.mark.parametrize("change, error, match", [
    (dict(track_nan=True), ValueError, r"track\[1\] contains NaN or infinite values"),
    (dict(truth_nan=True), ValueError, r"truth\[1\] contains NaN or infinite values"),
    (dict(mapping=(0, 9)), ValueError, r"mapping indices must lie in \[0, 4\)"),
    (dict(mapping=(-1,)), ValueError, r"mapping indices must lie in \[0, 4\)"),
    (dict(mapping=()), ValueError, "mapping needs at least 1 indices"),
    (dict(mapping=(0, 0)), ValueError, "mapping must name distinct rows"),
    (dict(mapping=(0.0, 2.0)), TypeError, "mapping must hold integer indices"),
    (dict(truth=np.zeros((3, 2))), TypeError, r"truth\[0\] must be a state"),
    (dict(truth=_states(np.zeros((3, 2)))), ValueError, "the same dimension, got 4 and 2"),
])
def test_position_rmse_names_bad_input(change, error, match):
    track, truth = _states(np.zeros((3, 4))), _states(np.ones((3, 4)))
    if change.pop("track_nan", False):
        track[1].state_vector[0, 0] = np.nan
    if change.pop("truth_nan", False):
        truth[1].state_vector[2, 0] = np.inf
    with pytest.raises(error, match=match):
        position_rmse(track, change.pop("truth", truth), **change)


def test_position_rmse_of_huge_errors_does_not_overflow():
    track, truth = _states(np.full((3, 4), 1e200)), _states(np.zeros((3, 4)))
    assert position_rmse(track, truth) == pytest.approx(np.sqrt(2) * 1e200)
    assert position_rmse(truth, truth) == 0.0


def test_position_rmse_is_still_exported_and_the_module_lists_its_names():
    from fasttrack.metrics import position_rmse as again
    assert again is position_rmse
    assert set(metrics.__all__) >= {"gospa", "gospa_over_time", "ospa", "ospa_over_time",
                                    "position_rmse", "GOSPAResult"}


@pytest.mark.parametrize("numpy_first", [False, True])
@pytest.mark.parametrize("scale", [1e-250, 1e-190, 1.0, 1e150, 1e290])
def test_distances_are_exact_at_any_scale_of_the_points_and_cut_off(scale, numpy_first,
                                                                     monkeypatch):
    """Squared distances and c * c overflowed or underflowed at the ends of the float range:
    OSPA of points 2.8e154 apart with c = 1e300 was c, GOSPA of 5e-200 with c = 1e-190 was
    c; powers of distances under 1 underflowed to 0 at large p (OSPA 0 for 0.5 apart)."""
    from fasttrack import _jit
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: numpy_first)
    truths, estimates = np.array([[0.0, 0.0], [3.0, 0.0]]), np.array([[0.0, 0.4], [3.3, 0.0]])
    for p in [p for p in (1.0, 2.5, 30.0) if abs(p * np.log10(scale)) <= 300]:
        want = gospa(truths, estimates, 1.0, p)
        got = gospa(truths * scale, estimates * scale, scale, p)
        assert got.distance == pytest.approx(want.distance * scale, rel=1e-12)
        for part in ("localisation", "missed", "false"):
            assert getattr(got, part) == pytest.approx(getattr(want, part) * scale ** p,
                                                       rel=1e-12)
        np.testing.assert_array_equal(got.assignment, want.assignment)
        assert ospa(truths * scale, estimates * scale, scale, p) == pytest.approx(
            ospa(truths, estimates, 1.0, p) * scale, rel=1e-12)
    assert ospa(truths * scale, estimates * scale, scale, np.inf) == pytest.approx(
        0.4 * scale, rel=1e-12)
    assert gospa(truths, estimates, 1.0, 30.0).distance > 0.3  # (powers of 1e-16, 1e-12)
