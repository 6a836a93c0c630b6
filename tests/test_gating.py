"""Gating, clustering and nearest-neighbour association against dense mirrors, and the
batched track prediction and update."""
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fasttrack as ft
from fasttrack.core.gating import Clusters, Gate, clusters, gate, gate_arrays
from fasttrack.core.assign import global_nearest_neighbour, nearest_neighbour
from fasttrack.core.jpda import pda_weights
from fasttrack._jit import gating as kernels
from fasttrack.core import stack
from fasttrack.core.kalman import JACOBIANS as ft_jacobians

import reference.gating
import reference.kalman


def _scenario(n_tracks, n_detections, spread, seed, m=2):
    rng = np.random.default_rng(seed)
    z_hats = rng.uniform(0, spread, (n_tracks, m))
    roots = rng.normal(0, 1, (n_tracks, m, m)) * rng.uniform(0.3, 2.0, (n_tracks, 1, 1))
    covars = roots @ roots.transpose(0, 2, 1) + 0.2 * np.eye(m)
    near = z_hats[rng.integers(0, n_tracks, n_detections)] + rng.normal(0, 1.5, (n_detections, m))
    far = rng.uniform(-5, spread + 5, (n_detections, m))
    detections = np.where(rng.random((n_detections, 1)) < 0.7, near, far)
    return z_hats, covars, detections


def _mirror_gate(z_hats, covars, detections, threshold, angles):
    d2, ll = reference.gating._dense_gate(z_hats, covars, detections, angles, threshold)
    return d2, np.where(np.isfinite(d2), ll, -np.inf)


@pytest.mark.parametrize("grid_axes", [None, (1,), (), (1, 0)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gate_equals_the_dense_mirror(seed, grid_axes):
    z_hats, covars, detections = _scenario(60, 150, 40.0, seed, m=3)
    result = gate(z_hats, covars, detections, 9.0, grid_axes=grid_axes)
    d2, ll = _mirror_gate(z_hats, covars, detections, 9.0, np.zeros(3, bool))
    assert np.isfinite(d2).sum() > 50
    np.testing.assert_array_equal(np.isfinite(result.dense()), np.isfinite(d2))
    np.testing.assert_allclose(result.dense()[np.isfinite(d2)], d2[np.isfinite(d2)],
                               rtol=1e-12)
    np.testing.assert_allclose(result.dense("log_likelihoods", -np.inf)[np.isfinite(d2)],
                               ll[np.isfinite(d2)], rtol=1e-12)
    for k in range(result.n_tracks):  # ascending detections per track
        assert np.all(np.diff(result.detections[result.starts[k]:result.starts[k + 1]]) > 0)


def test_gates_of_strided_arrays_run_the_kernels_of_contiguous_ones():
    """Views in another memory order (a tracker's transposed or sliced stacks) gate as
    their copies and compile nothing new."""
    from fasttrack._jit import compiles
    z_hats, covars, detections = _scenario(40, 90, 30.0, 0)
    want = gate_arrays(z_hats, covars, detections, 9.0, None, np.array([0, 1]))
    views = (np.asfortranarray(z_hats), covars.transpose(0, 2, 1)[:, ::1],
             np.asfortranarray(detections))
    with compiles() as found:
        got = gate_arrays(*views, 9.0, None, np.array([0, 1]))
    assert found == []
    for name in ("starts", "detections", "distances2", "log_likelihoods"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))


def test_gate_wraps_angles_and_handles_tracks_outside_the_detections():
    z_hats = np.array([[np.pi - 0.01, 10.0], [-np.pi + 0.02, 500.0], [0.0, -300.0]])
    covars = np.broadcast_to(np.diag([0.01, 4.0]), (3, 2, 2)).copy()
    covars[2] *= 1e6  # a gate wider than the whole grid
    detections = np.array([[-np.pi + 0.01, 10.5], [np.pi - 0.03, 499.0], [0.0, 10.0]])
    angles = np.array([True, False])
    result = gate(z_hats, covars, detections, 16.0, angles=angles)
    d2, _ = _mirror_gate(z_hats, covars, detections, 16.0, angles)
    np.testing.assert_array_equal(np.isfinite(result.dense()), np.isfinite(d2))
    assert result.dense()[0, 0] < 1 and result.dense()[1, 1] < 1  # across the +-pi seam
    assert list(result.detections[result.starts[2]:]) == [0, 1, 2]


def test_gate_kernels_match_their_mirrors():
    z_hats, covars, detections = _scenario(30, 80, 30.0, 5)
    axes, angles = np.array([0, 1]), np.zeros(2, bool)
    origin, cell, shape = np.array([-5.0, -5.0]), 2.5, np.array([16, 16])
    keys, want = np.empty(80, np.int64), np.empty(80, np.int64)
    kernels.cell_keys(detections, axes, origin, cell, shape, keys)
    reference.gating.cell_keys(detections, axes, origin, cell, shape, want)
    np.testing.assert_array_equal(keys, want)
    order = np.argsort(keys, kind="stable")
    grid = (z_hats, covars, detections, order, keys[order].copy(), axes, angles, origin, cell,
            shape, 9.0)
    none = np.empty(0, np.int64), np.empty(0), np.empty(0)
    starts, want_starts = np.empty(31, np.int64), np.empty(31, np.int64)
    status = np.empty(30, np.int64)
    kernels.gate(*grid, False, starts, *none, status)
    reference.gating.gate(*grid, False, want_starts, *none, status)
    np.testing.assert_array_equal(starts[1:], want_starts[1:])
    starts[0] = 0
    np.cumsum(starts, out=starts)
    n = starts[-1]
    got = np.empty(n, np.int64), np.empty(n), np.empty(n)
    ref = np.empty(n, np.int64), np.empty(n), np.empty(n)
    kernels.gate(*grid, True, starts, *got, status)
    reference.gating.gate(*grid, True, starts, *ref, status)
    np.testing.assert_array_equal(got[0], ref[0])
    np.testing.assert_allclose(got[1], ref[1], rtol=1e-12)
    np.testing.assert_allclose(got[2], ref[2], rtol=1e-12)



def test_the_gate_on_threads_is_the_gate_on_one():
    """Enough tracks for the gate's chunks to run on threads: the same gate, bit for bit."""
    import numba
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one thread")
    z_hats, covars, detections = _scenario(20_000, 3000, 400.0, 11)
    threaded = gate(z_hats, covars, detections, 9.0)
    try:
        ft.set_threads(1)
        alone = gate(z_hats, covars, detections, 9.0)
    finally:
        ft.set_threads(numba.config.NUMBA_NUM_THREADS)
    for name in ("starts", "detections", "distances2", "log_likelihoods"):
        np.testing.assert_array_equal(getattr(threaded, name), getattr(alone, name))
    assert threaded.starts[-1] > 20_000  # tracks with several candidates

@settings(max_examples=60, deadline=None)
@given(st.integers(1, 12), st.integers(0, 15), st.floats(2.0, 30.0), st.integers(0, 2**31))
def test_every_gated_pair_is_in_one_cluster_and_clusters_match_the_mirror(k, m, spread, seed):
    z_hats, covars, detections = _scenario(k, m, spread, seed)
    result = gate(z_hats, covars, detections, 9.0)
    groups = clusters(result)
    np.testing.assert_array_equal(groups.detection_labels[result.detections],
                                  groups.track_labels[result.tracks()])
    labels = np.empty(k + m, np.int64)
    n = reference.gating.clusters(result.starts, result.detections, m, labels)
    assert groups.n_clusters == n
    np.testing.assert_array_equal(np.r_[groups.track_labels, groups.detection_labels], labels)


def _total(assigned, distances, missed):
    return sum(distances[k, j] if j >= 0 else missed for k, j in enumerate(assigned))


def _brute_force(distances, missed):
    k, m = distances.shape
    best = np.inf
    for choice in itertools.product(range(-1, m), repeat=k):
        used = [j for j in choice if j >= 0]
        if len(used) == len(set(used)) and all(np.isfinite(distances[i, j])
                                               for i, j in enumerate(choice) if j >= 0):
            best = min(best, _total(choice, distances, missed))
    return best


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 5), st.integers(0, 5), st.floats(1.0, 8.0), st.integers(0, 2**31))
def test_global_nearest_neighbour_is_optimal_against_brute_force(k, m, spread, seed):
    z_hats, covars, detections = _scenario(k, m, spread, seed)
    result = gate(z_hats, covars, detections, 9.0)
    distances = np.sqrt(result.dense())
    assigned = global_nearest_neighbour(result, 2.5)
    assert len(set(assigned[assigned >= 0])) == (assigned >= 0).sum()
    assert all(np.isfinite(distances[i, j]) for i, j in enumerate(assigned) if j >= 0)
    assert _total(assigned, distances, 2.5) == pytest.approx(_brute_force(distances, 2.5))


def test_global_nearest_neighbour_equals_one_dense_assignment_at_scale():
    from scipy.optimize import linear_sum_assignment
    z_hats, covars, detections = _scenario(400, 500, 300.0, 9)
    result = gate(z_hats, covars, detections, 25.0)
    distances = np.sqrt(result.dense())
    augmented = np.full((400, 900), np.inf)
    augmented[:, :500] = distances
    augmented[np.arange(400), 500 + np.arange(400)] = 5.0
    _, columns = linear_sum_assignment(augmented)
    want = np.where(columns < 500, columns, -1)
    assigned = global_nearest_neighbour(result, 5.0)
    assert clusters(result).n_clusters > 100
    np.testing.assert_array_equal(assigned, want)  # continuous costs: no ties


def test_gnn_kernels_match_their_mirrors():
    z_hats, covars, detections = _scenario(40, 60, 20.0, 3)
    result = gate(z_hats, covars, detections, 9.0)
    groups = clusters(result)
    labels = np.r_[groups.track_labels, groups.detection_labels]
    c, k, m = groups.n_clusters, 40, 60
    outs = [(np.empty((c, 2), np.int64), np.empty(c + 1, np.int64), np.empty(c + 1, np.int64),
             np.empty(k, np.int64), np.empty(m, np.int64)) for _ in range(2)]
    size = kernels.gnn_problems(labels, c, k, m, *outs[0])
    assert size == reference.gating.gnn_problems(labels, c, k, m, *outs[1])
    for a, b in zip(*outs):
        np.testing.assert_array_equal(a, b)
    shapes, offsets, row_offsets, rows, columns = outs[0]
    costs, missed = np.sqrt(result.distances2), np.full(k, 3.0)
    flat, want = np.empty(size), np.empty(size)
    kernels.gnn_fill(labels, result.starts, result.detections, costs, missed, shapes, offsets,
                     rows, columns, flat)
    reference.gating.gnn_fill(labels, result.starts, result.detections, costs, missed, shapes,
                              offsets, rows, columns, want)
    np.testing.assert_array_equal(flat, want)
    row_to_col = np.array([np.random.default_rng(q).integers(-1, shapes[c_, 1])
                           for c_ in range(c) for q in range(shapes[c_, 0])], np.int64)
    got, ref = np.empty(k, np.int64), np.empty(k, np.int64)
    kernels.gnn_assignments(labels, shapes, row_offsets, rows, columns, m, row_to_col, got)
    reference.gating.gnn_assignments(labels, shapes, row_offsets, rows, columns, m, row_to_col, ref)
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("seed", range(5))
def test_nearest_neighbour_matches_the_greedy_mirror(seed):
    z_hats, covars, detections = _scenario(30, 40, 10.0, seed)
    result = gate(z_hats, covars, detections, 16.0)
    assigned = nearest_neighbour(result, 3.0)
    want = np.empty(30, np.int64)
    reference.gating.greedy_assignments(result.starts, result.detections,
                                        np.sqrt(result.distances2), np.full(30, 3.0), 40, want)
    np.testing.assert_array_equal(assigned, want)
    greedy = _total(assigned, np.sqrt(result.dense()), 3.0)
    optimal = _total(global_nearest_neighbour(result, 3.0), np.sqrt(result.dense()), 3.0)
    assert optimal <= greedy + 1e-12


def test_bad_gate_input_names_the_argument():
    z_hats, covars, detections = _scenario(3, 4, 10.0, 0)
    with pytest.raises(ValueError, match=r"innovation_covars must have shape \(3, 2, 2\)"):
        gate(z_hats, covars[:2], detections, 9.0)
    with pytest.raises(ValueError, match=r"detections must have shape \(M, 2\)"):
        gate(z_hats, covars, detections[:, :1], 9.0)
    for threshold in (0.0, np.inf, np.nan):
        with pytest.raises(ValueError, match="threshold must be finite"):
            gate(z_hats, covars, detections, threshold)
    with pytest.raises(TypeError, match="threshold must be a real number, got str"):
        gate(z_hats, covars, detections, "9")
    skew = covars.copy()
    skew[2, 0, 1] += 0.1
    with pytest.raises(ValueError, match=r"innovation_covars\[2\] is not symmetric"):
        gate(z_hats, skew, detections, 9.0)
    for angles in ([0, 5], ["no", "no"]):
        with pytest.raises(TypeError, match="angles must be a boolean array"):
            gate(z_hats, covars, detections, 9.0, angles=angles)
    for axes, error in (([0.7], TypeError), ([True], TypeError), ([0, 2], ValueError)):
        with pytest.raises(error, match="grid_axes"):
            gate(z_hats, covars, detections, 9.0, grid_axes=axes)
    with pytest.raises(ValueError, match=r"z_hats must have shape \(K, m\) with m >= 1"):
        gate(np.zeros((1, 0)), np.zeros((1, 0, 0)), np.zeros((2, 0)), 9.0)
    assert gate(z_hats, covars, [], 9.0).n_detections == 0
    with pytest.raises(ValueError, match="z_hats contains NaN"):
        gate(np.full((3, 2), np.nan), covars, detections, 9.0)
    bad = covars.copy()
    bad[1] = -np.eye(2)
    with pytest.raises(ValueError, match=r"innovation_covars\[1\] is not positive definite"):
        gate(z_hats, bad, detections, 9.0)
    with pytest.raises(ValueError, match="grid_axes must not be angle rows"):
        gate(z_hats, covars, detections, 9.0, angles=[True, False], grid_axes=(0,))
    result = gate(z_hats, covars, detections, 9.0)
    with pytest.raises(ValueError, match="missed_distance must be > 0"):
        global_nearest_neighbour(result, -1.0)


def _hand_built(**changes):
    """A gate of 2 tracks and 3 detections built by hand, with ``changes`` to its fields."""
    fields = dict(starts=[0, 2, 3], detections=[0, 2, 1], distances2=[1.0, 2.0, 3.0],
                  log_likelihoods=[-1.0, -2.0, -3.0], n_detections=3)
    fields.update(changes)
    return Gate(**fields)


@pytest.mark.parametrize("changes, error, match", [
    (dict(detections=[0, 5, 1]), ValueError, r"detections must be starts\[-1\] = 3 indices "
                                             r"in \[0, n_detections = 3\)"),
    (dict(detections=[0, -1, 1]), ValueError, "detections must be"),
    (dict(starts=[0, 2, 9]), ValueError, "detections must be starts"),
    (dict(starts=[1, 2, 3]), ValueError, "starts must be .* non-decreasing from 0"),
    (dict(starts=[0, 3, 2]), ValueError, "starts must be .* non-decreasing from 0"),
    (dict(starts=[0.0, 2.0, 3.0]), TypeError, "starts must be a 1-D array of integers"),
    (dict(detections=[2, 0, 1]), ValueError, "ascending .* within each track"),
    (dict(distances2=[1.0, np.nan, 3.0]), ValueError, "distances2 must be finite"),
    (dict(distances2=[1.0, np.inf, 3.0]), ValueError, "distances2 must be finite"),
    (dict(log_likelihoods=[1.0, np.inf, 3.0]), ValueError, "log_likelihoods must not be NaN"),
    (dict(distances2=[1.0, -2.0, 3.0]), ValueError, "distances2 must be finite and >= 0"),
    (dict(log_likelihoods=[1.0]), ValueError, "log_likelihoods must be starts"),
    (dict(n_detections=-1), ValueError, "n_detections must be >= 0"),
    (dict(n_detections=3.0), TypeError, "n_detections must be an int"),
])
def test_a_gate_built_by_hand_is_checked(changes, error, match):
    with pytest.raises(error, match=match):
        _hand_built(**changes)


def test_gates_and_clusters_written_after_they_are_built_are_refused_on_use():
    """The association functions check the indices they follow on every call, so a gate or
    clusters whose arrays were written after they were built raise instead of crashing."""
    good = _hand_built()
    np.testing.assert_array_equal(global_nearest_neighbour(good, 3.0), [0, 1])
    for write in (lambda g: g.detections.__setitem__(1, 10**9),
                  lambda g: g.detections.__setitem__(0, -5),
                  lambda g: g.starts.__setitem__(2, 10**6),
                  lambda g: g.starts.__setitem__(1, 5),
                  lambda g: g.distances2.__setitem__(1, np.nan)):
        bad = _hand_built()
        write(bad)
        for call in (clusters, lambda g: global_nearest_neighbour(g, 3.0),
                     lambda g: nearest_neighbour(g, 3.0)):
            with pytest.raises(ValueError,
                               match=r"gate\.(detections|starts|distances2) must be"):
                call(bad)
    found = clusters(good)
    with pytest.raises(ValueError, match="track_labels must lie in"):
        Clusters(np.array([0, 5]), found.detection_labels, found.n_clusters)
    with pytest.raises(TypeError, match="detection_labels must be a 1-D array of integers"):
        Clusters(found.track_labels, np.array([0.0, 1.0, 0.0]), found.n_clusters)
    short = Clusters(found.track_labels, found.detection_labels[:2], found.n_clusters)
    with pytest.raises(ValueError, match="must label the gate's 2 tracks and 3 detections"):
        global_nearest_neighbour(good, 3.0, clusters=short)
    split = Clusters(np.array([0, 1]), np.array([1, 1, 0]), 2)  # detection 0 away from track 0
    with pytest.raises(ValueError, match="each gated .* pair in one cluster"):
        global_nearest_neighbour(good, 3.0, clusters=split)
    written = clusters(good)
    written.track_labels[0] = 99
    with pytest.raises(ValueError, match="track_labels must lie in"):
        global_nearest_neighbour(good, 3.0, clusters=written)
    with pytest.raises(TypeError, match="clusters must be Clusters, got tuple"):
        global_nearest_neighbour(good, 3.0, clusters=(0, 1))
    with pytest.raises(TypeError, match="gate must be a Gate, got dict"):
        nearest_neighbour({}, 3.0)
    with pytest.raises(ValueError, match="costs must be .* not NaN or -inf"):
        global_nearest_neighbour(good, 3.0, costs=[1.0, -np.inf, 2.0])


def test_every_pair_is_gated_without_angles():
    """The drop-in scan's "every pair" gate (an infinite threshold, no grid, no angle rows)."""
    z_hats, covars, detections = _scenario(3, 4, 10.0, 0)
    every = gate_arrays(z_hats, covars, detections, np.inf, None, np.empty(0, np.int64))
    np.testing.assert_array_equal(every.starts, [0, 4, 8, 12])


_REWRITTEN_GATE = """
import numpy as np
import fasttrack._jit
from fasttrack.association import Gate, clusters, global_nearest_neighbour, nearest_neighbour
fasttrack._jit.kernels_from_now()
for field, index, value in [("detections", 1, 10**9), ("detections", 0, -5),
                            ("starts", 2, 10**6), ("starts", 1, 5)]:
    gate = Gate([0, 2, 3], [0, 2, 1], [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], 3)
    getattr(gate, field)[index] = value
    for call in (clusters, lambda g: global_nearest_neighbour(g, 3.0),
                 lambda g: nearest_neighbour(g, 3.0)):
        try:
            call(gate)
        except ValueError as error:
            print("refused:", str(error).split(" must")[0])
for field in ("distances2", "log_likelihoods"):  # (a frozen field replaced by a shorter one)
    gate = Gate([0, 2, 3], [0, 2, 1], [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], 3)
    object.__setattr__(gate, field, np.zeros(1))
    for call in (clusters, lambda g: global_nearest_neighbour(g, 3.0),
                 lambda g: nearest_neighbour(g, 3.0)):
        try:
            call(gate)
        except ValueError as error:
            print("refused:", str(error).split(" must")[0])
"""


def test_rewritten_gates_are_refused_in_a_process_of_their_own():
    """The compiled association kernels never see a rewritten gate: the process lives."""
    import subprocess
    import sys
    done = subprocess.run([sys.executable, "-c", _REWRITTEN_GATE], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("refused:") == 18


def test_detections_spanning_the_float_range_gate_as_the_dense_mirror():
    """An extent of 2e308 overflows the grid: every track tests every detection instead."""
    z_hats = np.array([[0.0, 0.0], [1e308, -1e308]])
    covars = np.broadcast_to(np.eye(2), (2, 2, 2)).copy()
    detections = np.array([[0.5, 0.0], [-1e308, 1e308], [1e308, -1e308], [0.0, 1.0]])
    result = gate(z_hats, covars, detections, 9.0)
    np.testing.assert_array_equal(np.isfinite(result.dense()),
                                  [[True, False, False, True], [False, False, True, False]])


@pytest.mark.parametrize("scale", [1e35, 1e40, 1e300])
def test_a_gate_box_wider_than_int64_cells_gates_as_the_dense_mirror(scale):
    """A track of innovation variance 1e40 among ordinary ones lost its candidates: its
    gate box spans more grid cells than an int64 counts, and the cell index overflowed."""
    z_hats, covars, detections = _scenario(20, 60, 40.0, 3)
    covars[4] = np.eye(2) * scale
    result = gate(z_hats, covars, detections, 9.0)
    d2, _ = _mirror_gate(z_hats, covars, detections, 9.0, np.zeros(2, bool))
    np.testing.assert_array_equal(np.isfinite(result.dense()), np.isfinite(d2))
    assert result.starts[5] - result.starts[4] == 60  # every detection, in ascending order
    assert list(result.detections[result.starts[4]:result.starts[5]]) == list(range(60))


def test_a_gate_box_of_more_cell_rows_than_detections_tests_each_detection_once():
    """Detections 1e6 gates apart: a wide gate's box covers ~1e6 cell rows; it tests the
    200 detections directly instead of searching every row."""
    rng = np.random.default_rng(7)
    detections = rng.uniform(0, 1e6, (200, 2))
    z_hats = np.vstack([detections[:30] + 0.1, [[5e5, 5e5]]])
    covars = np.tile(np.eye(2) * 0.01, (31, 1, 1))
    covars[30] = np.eye(2) * 1e11
    result = gate(z_hats, covars, detections, 9.0)
    d2, _ = _mirror_gate(z_hats, covars, detections, 9.0, np.zeros(2, bool))
    np.testing.assert_array_equal(np.isfinite(result.dense()), np.isfinite(d2))
    assert result.starts[31] - result.starts[30] > 50


def test_no_tracks_or_no_detections():
    z_hats, covars, detections = _scenario(3, 4, 10.0, 0)
    empty = gate(z_hats, covars, np.empty((0, 2)), 9.0)
    assert list(global_nearest_neighbour(empty, 3.0)) == [-1, -1, -1]
    none = gate(np.empty((0, 2)), np.empty((0, 2, 2)), detections, 9.0)
    assert global_nearest_neighbour(none, 3.0).size == 0
    assert clusters(none).n_clusters == 4


def _cv_batch():
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    return ft.BatchExtendedKalmanFilter(transition, ft.LinearGaussian(4, (0, 2), np.eye(2)))


def test_batch_predict_then_update_equals_step():
    rng = np.random.default_rng(4)
    means = rng.normal(0, 10, (300, 4))
    covars = np.broadcast_to(np.diag([1.0, 0.1, 1.0, 0.1]), (300, 4, 4)).copy()
    measurements = rng.normal(0, 10, (300, 2))
    batch = _cv_batch()
    x, p, z_hats, s = batch.predict(means, covars, 1.0)
    np.testing.assert_allclose(z_hats, x[:, [0, 2]])
    np.testing.assert_allclose(s, p[:, [0, 2]][:, :, [0, 2]] + np.eye(2), rtol=1e-12)
    posterior = batch.update(x, p, measurements)
    for got, want in zip(posterior, batch.step(means, covars, measurements, 1.0)):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_batch_predict_kernel_matches_its_mirror():
    from fasttrack._jit import kalman
    rng = np.random.default_rng(1)
    batch = ft.BatchExtendedKalmanFilter(
        ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2),
        ft.CartesianToBearingRange(4, (0, 2), np.diag([1e-4, 1.0])))
    means = rng.normal(0, 10, (5, 4)) + np.array([30.0, 0, 30, 0])
    covars = np.broadcast_to(np.eye(4), (5, 4, 4)).copy()
    dts = np.full(5, 1.0)
    spec = stack.transition(batch.transition_model, dts)
    model = batch.measurement_model
    m_spec = (model.kind, model.spec.mapping, model.spec.offset, model.spec.rotation, model.spec.noise_covar,
              ft_jacobians[batch.jacobian])
    outs = [(np.empty((5, 4)), np.empty((5, 4, 4)), np.empty((5, 2)), np.empty((5, 2, 2)),
             np.zeros(5, np.int64)) for _ in range(2)]
    kalman.batch_predict(*spec, dts, *m_spec, means, covars, *outs[0])
    reference.kalman.batch_predict(*spec, dts, *m_spec, means, covars, *outs[1])
    for a, b in zip(*outs):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("joseph", [True, False])
def test_linear_kernels_match_their_mirrors(joseph):
    from fasttrack._jit import kalman
    rng = np.random.default_rng(2)
    batch = _cv_batch()
    means = rng.normal(0, 10, (7, 4))
    roots = rng.normal(0, 1, (7, 4, 4))
    covars = roots @ roots.transpose(0, 2, 1) + np.eye(4)
    model = batch.measurement_model
    f = batch.transition_model.matrix(time_interval=1.5)
    q = batch.transition_model.covar(time_interval=1.5)
    outs = [(np.empty((7, 4)), np.empty((7, 4, 4)), np.empty((7, 2)), np.empty((7, 2, 2)),
             np.zeros(7, np.int64)) for _ in range(2)]
    kalman.linear_predict(f, q, model.spec.mapping, model.spec.noise_covar, means, covars, *outs[0])
    reference.kalman.linear_predict(f, q, model.spec.mapping, model.spec.noise_covar, means, covars,
                                    *outs[1])
    for a, b in zip(*outs):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)
    z = rng.normal(0, 10, (7, 2))
    updated = [(np.empty((7, 4)), np.empty((7, 4, 4)), np.zeros(7, np.int64)) for _ in range(2)]
    args = (model.spec.mapping, model.spec.noise_covar, model.spec.angles, joseph, outs[0][0], outs[0][1],
            z)
    kalman.linear_update(*args, *updated[0])
    reference.kalman.linear_update(*args, *updated[1])
    for a, b in zip(*updated):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
    assert not updated[0][2].any()
    covars = outs[0][1].copy()
    covars[3, 1, 1] = -covars[3, 1, 1]  # an indefinite prediction
    covars[5, 0, 1] += 1.0  # an asymmetric one
    args = args[:5] + (covars, z)
    kalman.linear_update(*args, *updated[0])
    reference.kalman.linear_update(*args, *updated[1])
    np.testing.assert_array_equal(updated[0][2], updated[1][2])
    assert updated[0][2][3] == kalman.PREDICTION_NOT_PSD
    assert updated[0][2][5] == kalman.PREDICTION_NOT_SYMMETRIC


def test_batch_update_of_a_nonlinear_sensor_equals_step():
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    batch = ft.BatchExtendedKalmanFilter(
        transition, ft.CartesianToBearingRange(4, (0, 2), np.diag([1e-4, 1.0])))
    rng = np.random.default_rng(3)
    means = rng.normal(0, 10, (20, 4)) + np.array([40.0, 0, 40, 0])
    covars = np.broadcast_to(np.eye(4), (20, 4, 4)).copy()
    measurements = np.column_stack([rng.uniform(0.6, 0.9, 20), rng.uniform(50, 60, 20)])
    x, p, _, _ = batch.predict(means, covars, 1.0)
    for got, want in zip(batch.update(x, p, measurements),
                         batch.step(means, covars, measurements, 1.0)):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_batch_predict_and_update_name_a_bad_filter():
    batch = _cv_batch()
    covars = np.broadcast_to(np.eye(4), (3, 4, 4)).copy()
    covars[2, 0, 0] = -1.0
    with pytest.raises(ValueError, match=r"filter 2: covars\[2\] is not positive"):
        batch.predict(np.zeros((3, 4)), covars, 1.0)
    covars[2, 0, 0], covars[2, 2, 2] = 1.0, -2.0  # S = -1, from the prediction named
    with pytest.raises(ValueError, match=r"filter 2: covars\[2\] is not positive semi-def"):
        batch.update(np.zeros((3, 4)), covars, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="measurements contains NaN"):
        batch.update(np.zeros((3, 4)), np.broadcast_to(np.eye(4), (3, 4, 4)),
                     np.full((3, 2), np.nan))
    covars[2, 2, 2], covars[2, 1, 1] = 1.0, -1.0  # an unmeasured velocity: S is fine
    for joseph in (True, False):
        with pytest.raises(ValueError, match=r"filter 2: covars\[2\] is not "
                                             "positive semi-definite"):
            ft.BatchExtendedKalmanFilter(batch.transition_model, batch.measurement_model,
                                         use_joseph_cov=joseph).update(
                np.zeros((3, 4)), covars, np.zeros((3, 2)))


def test_a_gate_edited_after_it_was_built_is_checked_where_it_is_used():
    from fasttrack.association import Gate, clusters, global_nearest_neighbour
    for field, index, value, match in [("distances2", 1, -2.0, "finite and >= 0"),
                                       ("detections", 1, 0, "ascending")]:
        gate = Gate([0, 2, 3], [0, 2, 1], [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], 3)
        getattr(gate, field)[index] = value
        with pytest.raises(ValueError, match=match):
            global_nearest_neighbour(gate, 3.0)
    found = clusters(Gate([0, 2, 3], [0, 2, 1], [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], 3))
    with pytest.raises(ValueError, match=r"c must lie in \[0, n_clusters = 2\), got 99"):
        found.members(99)
    with pytest.raises(TypeError, match="c must be an int cluster number, got str"):
        found.members("a")


@pytest.mark.parametrize("field, value, error, match", [
    ("distances2", np.array([1.0]), ValueError,
     r"gate.distances2 must be starts\[-1\] = 3 numbers, got shape \(1,\)"),
    ("log_likelihoods", np.zeros(5), ValueError, "gate.log_likelihoods must be starts"),
    ("starts", np.array([0.0, 2.0, 3.0]), TypeError,
     "gate.starts must be a C-contiguous int64 ndarray, got an array of dtype float64"),
    ("detections", [0, 2, 1], TypeError, "gate.detections must be a C-contiguous int64"),
    ("distances2", np.array([1.0, 2.0, 3.0, 4.0])[::-1][1:], TypeError,
     "gate.distances2 must be a C-contiguous float64"),
    ("n_detections", 1.5, TypeError, "gate.n_detections must be an int"),
    ("n_detections", -1, ValueError, "gate.n_detections must be >= 0"),
])
def test_a_gate_whose_fields_were_replaced_is_refused_where_it_is_used(field, value, error,
                                                                        match):
    """A gate's distances2 replaced by a shorter array (its frozen field set by hand): the
    kernels read past its end and returned an assignment of whatever lay there."""
    gate = _hand_built()
    object.__setattr__(gate, field, value)
    for use in (clusters, lambda g: global_nearest_neighbour(g, 3.0),
                lambda g: nearest_neighbour(g, 3.0), lambda g: g.dense()):
        with pytest.raises(error, match=match):
            use(gate)


def test_a_gate_reads_only_its_own_values_densely_and_takes_an_empty_list():
    with pytest.raises(ValueError, match="value must be 'distances2' or 'log_likelihoods', "
                                         "got 'starts'"):
        _hand_built().dense("starts")
    empty = Gate([0], [], [], [], 3)
    assert empty.detections.dtype == np.int64 and empty.dense().shape == (0, 3)


@pytest.mark.parametrize("call", [
    lambda z, d: gate(z, np.eye(2)[None], d, 9.0, angles=[True, False]),
    lambda z, d: pda_weights(z, np.eye(2)[None], d, angles=[True, False]),
])
def test_angles_beyond_their_digits_are_refused_as_the_updaters_refuse_them(call):
    """Angles of 1e17 rad were gated (the wrapped innovation kept no digit; the NumPy path
    and the kernels disagreed)."""
    for z_hat, detection, name in (([[1e17, 0.0]], [[0.5, 0.0]], "z_hats|means"),
                                   ([[0.5, 0.0]], [[-1e300, 0.0]], "detections")):
        with pytest.raises(ValueError, match=rf"({name}) must hold angles within \+-1e\+09"):
            call(np.array(z_hat), np.array(detection))
    call(np.array([[1e9, 0.0]]), np.array([[-1e9, 0.0]]))  # (the limit itself is taken)


def test_a_gate_of_probability_zero_holds_no_volume():
    """prob_gate = 0 (documented in [0, 1]) failed with 'math domain error'."""
    weights = pda_weights(np.zeros((1, 2)), np.eye(2)[None], np.array([[0.5, 0.0]]),
                          prob_gate=0.0, clutter_spatial_density=1e-3)
    np.testing.assert_array_equal(weights, [[1.0, 0.0]])  # (nothing inside a gate of d2 <= 0)
