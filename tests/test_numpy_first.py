"""A process's first small calls run in NumPy (``fasttrack._jit.numpy_first``): stacks of
Kalman predictions, gating, clusters, assignment, JPDA marginals, segment log-sum-exp,
mixture reductions, OSPA and the particle filter's steps give the kernels' results and errors, and small tracking and
particle-filter scripts never load Numba."""
import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import from_python

import fasttrack as ft
from fasttrack import _jit
from fasttrack.core.gating import gate_arrays
from fasttrack.association import (clusters, gate, global_nearest_neighbour, jpda_marginals,
                                   nearest_neighbour)
from fasttrack.core import akkf_numpy, kalman, particle, particle_numpy
from fasttrack.core.kinds import GAUSSIAN, MATRIX, SELECT
from fasttrack.core.mixture import reduce as reduce_mixture
from fasttrack.core.mixture import segment_logsumexp
from fasttrack.core.resample import ResidualMethod, draw


def _both(monkeypatch, call):
    """``call()`` with the kernels, then in NumPy."""
    results = []
    for first in (False, True):
        monkeypatch.setattr(_jit, "numpy_first", lambda work=1: first)
        results.append(call())
    return results


def _error(call):
    with pytest.raises(ValueError) as error:
        call()
    return str(error.value)


def _scan(seed, k, m, spread=30.0):
    """K tracks' predicted measurements and innovation covariances, M detections around
    them (2-D, a bearing-range layout when ``angles``)."""
    rng = np.random.default_rng(seed)
    z_hats = rng.uniform(-spread, spread, (k, 2))
    roots = rng.normal(size=(k, 2, 2))
    covars = roots @ roots.transpose(0, 2, 1) + np.eye(2)
    detections = rng.uniform(-spread, spread, (m, 2))
    return z_hats, covars, detections


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 6), st.integers(0, 9), st.booleans(),
       st.sampled_from([4.0, 16.0, np.inf]))
def test_gate_and_clusters_are_the_kernels(seed, k, m, angles, threshold):
    z_hats, covars, detections = _scan(seed, k, m)
    if angles:
        z_hats[:, 0] = np.remainder(z_hats[:, 0], 2 * np.pi) - np.pi
        detections[:, 0] = np.remainder(detections[:, 0], 2 * np.pi) - np.pi
    flags = np.array([angles, False])
    with pytest.MonkeyPatch.context() as monkeypatch:
        found = _both(monkeypatch, lambda: gate_arrays(
            z_hats, covars, detections, threshold, flags,
            np.array([1] if angles else [0, 1]) if np.isfinite(threshold)
            else np.empty(0, dtype=np.int64)))
        kernel, numpy = found
        np.testing.assert_array_equal(numpy.starts, kernel.starts)
        np.testing.assert_array_equal(numpy.detections, kernel.detections)
        np.testing.assert_allclose(numpy.distances2, kernel.distances2, rtol=1e-12,
                                   atol=1e-12)
        np.testing.assert_allclose(numpy.log_likelihoods, kernel.log_likelihoods,
                                   rtol=1e-12, atol=1e-12)
        groups = _both(monkeypatch, lambda: clusters(kernel))
    np.testing.assert_array_equal(groups[1].track_labels, groups[0].track_labels)
    np.testing.assert_array_equal(groups[1].detection_labels, groups[0].detection_labels)
    assert groups[1].n_clusters == groups[0].n_clusters


def test_gate_refuses_as_the_kernel_does(monkeypatch):
    z_hats, covars, detections = _scan(1, 3, 4)
    covars[1] = [[1.0, 2.0], [2.0, 1.0]]
    messages = _both(monkeypatch, lambda: _error(lambda: gate(z_hats, covars, detections,
                                                              9.0)))
    assert messages[0] == messages[1] == "innovation_covars[1] is not positive definite"


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 6), st.integers(0, 8),
       st.sampled_from([0.5, 2.0, np.inf]))
def test_assignments_are_the_kernels(seed, k, m, missed):
    z_hats, covars, detections = _scan(seed, k, m, spread=5.0)
    pairs = gate(z_hats, covars, detections, 25.0)
    with pytest.MonkeyPatch.context() as monkeypatch:
        greedy = _both(monkeypatch, lambda: nearest_neighbour(pairs, missed))
        np.testing.assert_array_equal(greedy[1], greedy[0])

        def best():
            try:
                return global_nearest_neighbour(pairs, missed)
            except ValueError as error:
                return str(error)
        found = _both(monkeypatch, best)
    if isinstance(found[0], str):
        assert found[1] == found[0]
    else:
        np.testing.assert_array_equal(found[1], found[0])


def test_an_infeasible_association_raises_as_the_kernels_do(monkeypatch):
    z_hats = np.zeros((2, 2))
    pairs = gate(z_hats, np.broadcast_to(np.eye(2), (2, 2, 2)), np.ones((1, 2)), 25.0)
    messages = _both(monkeypatch,
                     lambda: _error(lambda: global_nearest_neighbour(pairs, np.inf)))
    assert messages[0] == messages[1] and "2 tracks" in messages[0]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 5), st.integers(0, 5), st.floats(0, 0.6))
def test_jpda_marginals_are_the_kernels(seed, t, m, zeros):
    rng = np.random.default_rng(seed)
    weights = rng.uniform(0.1, 2.0, (t, m + 1)) * (rng.uniform(size=(t, m + 1)) >= zeros)
    with pytest.MonkeyPatch.context() as monkeypatch:
        def marginals():
            try:
                return jpda_marginals(weights), jpda_marginals([weights, weights[:1]])
            except ValueError as error:
                return str(error)
        found = _both(monkeypatch, marginals)
    if isinstance(found[0], str):
        assert found[1] == found[0]
        return
    np.testing.assert_allclose(found[1][0], found[0][0], rtol=1e-12, atol=1e-15)
    for numpy, kernel in zip(found[1][1], found[0][1]):
        np.testing.assert_allclose(numpy, kernel, rtol=1e-12, atol=1e-15)


def test_jpda_enumerates_only_small_clusters(monkeypatch):
    """A cluster of more joint events than an EHM net of ``max_nodes`` would hold is
    the kernels' (which refuse it), whatever the NumPy budget."""
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: True)
    weights = np.ones((4, 5))
    with pytest.raises(ValueError, match="max_nodes=3"):
        jpda_marginals(weights, max_nodes=3)


def test_segment_logsumexp_is_the_kernels(monkeypatch):
    values = np.array([0.5, -np.inf, 3.0, -np.inf, -np.inf, np.inf, 1.0, np.nan, 2.0, 700.0,
                       710.0])
    starts = np.array([0, 0, 3, 5, 7, 9, 11])
    found = _both(monkeypatch, lambda: segment_logsumexp(values, starts))
    np.testing.assert_allclose(found[1], found[0], rtol=1e-14)


@pytest.mark.parametrize("mode", ["stonesoup", "textbook"])
@pytest.mark.parametrize("cap", [None, 7])
def test_mixture_reductions_are_the_kernels(monkeypatch, mode, cap):
    rng = np.random.default_rng(3)
    centres = rng.uniform(-20.0, 20.0, (12, 4))
    means = centres[rng.integers(0, 12, 90)] + rng.normal(size=(90, 4))
    a = rng.standard_normal((90, 4, 4)) * 0.5
    covars = a @ a.transpose(0, 2, 1) + np.eye(4)
    weights = 10.0 ** rng.uniform(-9, 0, 90)
    found = _both(monkeypatch, lambda: reduce_mixture(means, covars, weights, mode, 1e-6, 4.0,
                                                      cap))
    assert 7 <= found[0][2].size < 60
    for got, want in zip(found[1], found[0]):
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("p", [1.0, 2.5, np.inf])
@pytest.mark.parametrize("stonesoup_pairs", [False, True])
def test_ospa_is_the_kernels(monkeypatch, p, stonesoup_pairs):
    rng = np.random.default_rng(4)
    truths = [rng.uniform(-10.0, 10.0, (n, 2)) for n in rng.integers(0, 6, 40)]
    estimates = [t[rng.permutation(len(t))] + rng.normal(0, 2.0, t.shape) if k % 3
                 else rng.uniform(-10.0, 10.0, (int(rng.integers(0, 6)), 2))
                 for k, t in enumerate(truths)]
    found = _both(monkeypatch, lambda: ft.metrics.ospa_over_time(
        truths, estimates, 5.0, p, stonesoup_pairs=stonesoup_pairs))
    np.testing.assert_allclose(found[1], found[0], rtol=1e-13, atol=1e-13)
    assert found[0].max() <= 5.0 + 1e-12 and np.count_nonzero(found[0]) > 30


@pytest.mark.parametrize("bad, message", [(-np.eye(4), "not positive definite"),
                                          (np.triu(np.ones((4, 4))), "not symmetric")])
def test_a_bad_covariance_in_a_reduction_is_named_as_the_kernel_names_it(monkeypatch, bad,
                                                                         message):
    covars = np.broadcast_to(np.eye(4), (6, 4, 4)).copy()
    covars[3] = bad
    errors = _both(monkeypatch, lambda: _error(
        lambda: reduce_mixture(np.zeros((6, 4)), covars, np.full(6, 0.5))))
    assert errors[0] == errors[1] == f"covars[3] is {message}"


@pytest.mark.parametrize("sensor", [
    ft.LinearGaussian(4, (0, 2), np.diag([2.0, 3.0])),
    ft.CartesianToBearingRange(4, (0, 2), np.diag([1e-4, 1.0]), translation_offset=[50, 0])])
@pytest.mark.parametrize("jacobian", ["analytic", "forward", "central"])
@pytest.mark.parametrize("intervals", [[1.0, 2.0, 1.0, 0.5, 3.0], [1.5] * 5])
def test_stack_predictions_are_the_kernels(monkeypatch, sensor, jacobian, intervals):
    """Mixed intervals, and one interval for all (with a linear sensor, one stacked pass)."""
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    rng = np.random.default_rng(4)
    means = rng.normal(0, 20, (5, 4))
    roots = rng.normal(size=(5, 4, 4))
    covars = roots @ roots.transpose(0, 2, 1) + np.eye(4)
    intervals = np.array(intervals)
    found = _both(monkeypatch, lambda: kalman.stack_predict(transition, sensor, intervals,
                                                            means, covars, jacobian))
    # finite differences turn an ulp of the predicted mean into more: Stone Soup's forward
    # steps (1e8 ulps) into 1e-6
    rtol = {"analytic": 1e-9, "central": 1e-7, "forward": 1e-5}[jacobian]
    rtol = 1e-9 if sensor.spec.kind == SELECT else rtol
    for numpy, kernel in zip(*found[::-1]):
        np.testing.assert_allclose(numpy, kernel, rtol=rtol, atol=1e-12)
    covars[3, 0, 0] = -1.0
    messages = _both(monkeypatch, lambda: _error(
        lambda: kalman.stack_predict(transition, sensor, intervals, means, covars, jacobian)))
    assert messages[0] == messages[1] and "filter 3" in messages[0]


_TRACKING = r"""
import json, sys
import numpy as np
import fasttrack as ft
from fasttrack import _jit
from fasttrack.association import clusters, gate, global_nearest_neighbour, jpda_marginals
from fasttrack.core import kalman
_jit._numpy_work = int(sys.argv[1])
transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
sensor = ft.LinearGaussian(4, (0, 2), np.diag([0.75, 0.75]))
means = np.array([[0.0, 1.0, 0.0, 1.0], [0.0, 1.0, 20.0, -1.0], [40.0, 0.0, 40.0, 0.0]])
covars = np.repeat(np.eye(4)[None], 3, axis=0)
rng = np.random.default_rng(7)
loaded, chosen = [], []
for k in range(1, 16):
    means, covars, z_hats, s = kalman.stack_predict(transition, sensor, np.ones(3), means,
                                                    covars)
    truth = np.array([[k, k], [k, 20.0 - k], [40.0, 40.0]])
    detections = np.vstack([truth + rng.normal(0, 0.8, truth.shape),
                            rng.uniform(0, 40, (2, 2))])
    pairs = gate(z_hats, s, detections, 16.0)
    assigned = global_nearest_neighbour(pairs, 4.0, clusters(pairs))
    jpda_marginals(np.hstack([np.full((3, 1), 0.1), np.exp(-0.5 * pairs.dense())]))
    for t in np.flatnonzero(assigned >= 0):
        x, covar = kalman.update(sensor, means[t, :, None], covars[t],
                                 detections[assigned[t], :, None])[:2]
        means[t], covars[t] = x[:, 0], covar
    chosen.append(assigned.tolist())
    loaded.append("numba" in sys.modules)
print(json.dumps({"loaded": loaded, "chosen": chosen, "means": means.ravel().tolist()}))
"""


def _runs(script, switching_work):
    """``(short, switching, compiled)``: ``script`` in new processes with a NumPy budget
    that outlasts it, one that runs out on the way, and none; checks that Numba is loaded
    never, from a later step on, and from the first step."""
    runs = []
    for work in (100_000, switching_work, 0):
        done = subprocess.run([sys.executable, "-c", script, str(work)], capture_output=True,
                              text=True, timeout=600, check=True)
        runs.append(json.loads(done.stdout.splitlines()[-1]))
    short, switching, compiled = runs
    assert not any(short["loaded"]) and all(compiled["loaded"])
    assert not switching["loaded"][0] and switching["loaded"][-1]
    return runs


def test_a_small_tracking_script_leaves_numba_unloaded_then_the_kernels_take_over():
    short, switching, compiled = _runs(_TRACKING, 150)
    for run in (short, switching):
        assert run["chosen"] == compiled["chosen"]
        np.testing.assert_allclose(run["means"], compiled["means"], rtol=1e-10)


# -- the particle filter ----------------------------------------------------------------------

def test_the_stream_is_the_kernels():
    from fasttrack._jit import numeric
    counters = np.array([0, 1, 2, 3, 1000, 2**40, 2**62], dtype=np.int64)
    for key in (0, 1, 12345, 2**63 - 2):
        expected = [numeric.uniform(key, int(c)) for c in counters]
        np.testing.assert_array_equal(particle_numpy.uniforms(key, counters), expected)


@pytest.mark.parametrize("n", [1, 1000, 2500])
@pytest.mark.parametrize("transition", [
    ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2),
    ft.LinearGaussianTransitionModel(np.eye(3) + np.eye(3, k=1),
                                     np.diag([1.0, 0.5, 2.0]) + 0.1)])  # odd dimension
def test_propagation_draws_the_kernels_noise(monkeypatch, n, transition):
    x = np.random.default_rng(n).normal(0, 10, (transition.ndim_state, n))
    found = _both(monkeypatch, lambda: particle.predict(transition, x, 1.5, 99))
    np.testing.assert_allclose(found[1], found[0], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("sensor", [
    ft.LinearGaussian(4, (0, 2), np.diag([2.0, 3.0])),
    ft.CartesianToBearingRange(4, (0, 2), np.diag([1e-4, 1.0]), translation_offset=[50, 0]),
    ft.Cartesian2DToBearing(4, (0, 2), np.array([[1e-3]]), translation_offset=[5, -3])])
def test_weights_are_the_kernels(monkeypatch, sensor):
    rng = np.random.default_rng(2)
    x = rng.normal(0, 20, (4, 3000))
    z = sensor.measurement_vector(sensor.function(x[:, :1])[:, 0] + 0.1)
    log_weight = np.log(rng.uniform(0.1, 1.0, 3000))
    found = _both(monkeypatch, lambda: particle.weigh(sensor, z, x, log_weight))
    np.testing.assert_allclose(found[1][0], found[0][0], rtol=1e-12, atol=1e-12)
    assert found[1][1] == pytest.approx(found[0][1], rel=1e-12)
    measured = _both(monkeypatch, lambda: particle.measure(sensor.spec, x))
    np.testing.assert_allclose(measured[1], measured[0], rtol=1e-13, atol=1e-13)
    moments = _both(monkeypatch, lambda: (particle.mean(x, found[0][0]),
                                          *particle.mean_covar(x, found[0][0])))
    for numpy, kernel in zip(*moments[::-1]):
        np.testing.assert_allclose(numpy, kernel, rtol=1e-11, atol=1e-12)
    decisions = _both(monkeypatch, lambda: particle.resampling_decision(found[0][0], 1500.0))
    assert decisions[1][1] == decisions[0][1]
    assert decisions[1][0] == pytest.approx(decisions[0][0], rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 3000), st.integers(1, 3000),
       st.sampled_from(list(ResidualMethod)), st.floats(0, 0.9), st.booleans())
def test_resampling_draws_the_kernels_ancestors(seed, n, nparts, method, zeros, compact):
    rng = np.random.default_rng(seed)
    log_w = rng.normal(0, 3, n)
    log_w[rng.uniform(size=n) < zeros] = -np.inf
    log_w[rng.integers(n)] = 0.0
    columns = rng.normal(size=(3, n))
    with pytest.MonkeyPatch.context() as monkeypatch:
        found = _both(monkeypatch, lambda: draw(log_w, nparts, method, rng=seed,
                                                columns=columns, compact=compact))
        np.testing.assert_array_equal(found[1][0], found[0][0])
        assert found[1][0].dtype == found[0][0].dtype
        np.testing.assert_array_equal(found[1][1], found[0][1])
        gathered = _both(monkeypatch, lambda: particle.gather(columns, found[0][0]))
    np.testing.assert_array_equal(gathered[1], gathered[0])


_PARTICLES = r"""
import json, sys
import numpy as np
import fasttrack as ft
from fasttrack import _jit
from fasttrack.core import particle
from fasttrack.core.resample import draw
_jit._numpy_work = int(sys.argv[1])
transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
sensor = ft.CartesianToBearingRange(4, (0, 2), np.diag([1e-3, 1.0]), translation_offset=[50, 0])
rng = np.random.default_rng(3)
x = rng.normal([[0.0], [1.0], [0.0], [1.0]], 1.0, (4, 1000))
log_w = np.full(1000, -np.log(1000))
loaded, ancestors = [], []
for k in range(1, 21):
    x = particle.predict(transition, x, 1.0, rng)
    z = sensor.measurement_vector([np.arctan2(k, k - 50.0), np.hypot(k - 50.0, k)])
    log_w, ess = particle.weigh(sensor, z, x, log_w)
    if particle.resampling_decision(log_w)[1]:
        idx, x = draw(log_w, rng=rng, columns=x)
        log_w = np.full(1000, -np.log(1000))
        ancestors.append(idx[::97].tolist())
    loaded.append("numba" in sys.modules)
print(json.dumps({"loaded": loaded, "ancestors": ancestors, "x": x.ravel().tolist()}))
"""


def test_a_small_particle_filter_leaves_numba_unloaded_then_the_kernels_take_over():
    short, switching, compiled = _runs(_PARTICLES, 40)
    assert compiled["ancestors"]  # the filter resampled
    for run in (short, switching):
        assert run["ancestors"] == compiled["ancestors"]
        np.testing.assert_allclose(run["x"], compiled["x"], rtol=1e-9, atol=1e-9)


# -- the adaptive kernel Kalman filter ----------------------------------------------------

_KERNELS = {"linear": ft.LinearKernel(), "quadratic": ft.QuadraticKernel(c=1, ialpha=1),
            "quartic": ft.QuarticKernel(c=0.5, ialpha=3),
            "gaussian": ft.GaussianKernel(variance=0.7)}


def _close(numpy, kernel, rtol=1e-8):
    np.testing.assert_allclose(numpy, kernel, atol=rtol * max(np.abs(kernel).max(), 1e-300))


@pytest.mark.parametrize("name", _KERNELS)
@pytest.mark.parametrize("m", [12, 40])
def test_akkf_steps_are_the_kernels(name, m):
    """Two cycles of predict and update, NumPy's factored steps against the kernels' on the
    same input (quartic at M = 12: more features than particles); the weights, the kernel
    covariance the factors stand for, and the proposal drawn from the same stream."""
    from fasttrack._jit import akkf as kernels, gram
    from fasttrack.types import dense_kernel_covar
    kernel = _KERNELS[name]
    kind, params = kernel._kind, kernel._parameters()
    rng = np.random.default_rng(5)
    x = rng.normal(size=(4, m)) * 0.4
    w = rng.uniform(-0.2, 1.0, m) / m
    root = rng.normal(size=(m, m + 2)) / m
    covar = root @ root.T
    lt = akkf_numpy.factor(MATRIX, None, None, covar)
    _close(lt.T @ lt, gram.factor(MATRIX, np.empty(0), np.zeros(0, np.bool_), covar).T
           @ gram.factor(MATRIX, np.empty(0), np.zeros(0, np.bool_), covar))
    factors = (lt, 0.0, np.zeros((0, m)), np.zeros((0, m)))
    proposal = x + rng.normal(size=(4, m)) * 0.1
    state_angles, meas_angles = np.zeros(4, np.bool_), np.array([True, False])
    for cycle in range(2):
        arguments = (kind, params, state_angles, proposal, x, w, *factors, 1e-2)
        numpy = akkf_numpy.predict_embedding(*arguments)
        compiled = kernels.predict_embedding(*arguments)
        _close(numpy[0], compiled[0])
        ours, theirs = ((out[1], 1.0 / m, out[2], out[3]) for out in (numpy, compiled))
        _close(dense_kernel_covar(ours), dense_kernel_covar(theirs))
        _close(akkf_numpy.sandwich(x, *ours), kernels.sandwich(x, *theirs))
        w, factors = compiled[0], theirs
        x = proposal + 0.05
        y = np.vstack([np.arctan2(x[2], x[0]), x[1]])
        z = np.array([[0.4], [0.1]])
        arguments = (kind, params, meas_angles, y, z, w, *factors, 1e-2, x, 77 + cycle)
        numpy = akkf_numpy.update_embedding(*arguments)
        proposal = np.empty_like(x)
        compiled = kernels.update_embedding(*arguments, proposal)
        _close(numpy[0], compiled[0])
        ours, theirs = ((out[1], factors[1], out[2], out[3]) for out in (numpy, compiled))
        _close(dense_kernel_covar(ours), dense_kernel_covar(theirs))
        np.testing.assert_allclose(numpy[4], proposal, rtol=1e-7, atol=1e-9)
        w, factors = compiled[0], theirs


@pytest.mark.parametrize("n", [1, 2, 20, 40])
def test_the_median_length_scale_is_the_kernels(n):
    from fasttrack._jit import gram
    x = np.random.default_rng(n).normal(size=(3, n))
    angles = np.array([False, True, False])
    assert akkf_numpy.median_variance(angles, x) == pytest.approx(
        gram.median_variance(angles, x), rel=1e-12)
    params = ft.GaussianKernel(width=1.5)._parameters()
    np.testing.assert_allclose(akkf_numpy.resolve(GAUSSIAN, params, angles, x, x[:, :1]),
                               gram.resolve(GAUSSIAN, params, angles, x, x[:, :1]),
                               rtol=1e-12)


def test_ridge_map_takes_either_route_as_the_kernels_do():
    from fasttrack._jit import akkf as kernels
    rng = np.random.default_rng(2)
    for scale in (1.0, 1e10):  # Cholesky, then the QR route of an ill-conditioned F
        f = rng.normal(size=(5, 9)) * scale
        expected = from_python(kernels._ridge_map)(f, 1e-3)
        _close(akkf_numpy.ridge_map(f, 1e-3), expected, rtol=1e-6)


_AKKF = r"""
import json, sys
import numpy as np
import fasttrack as ft
from fasttrack import _jit
from fasttrack.scenarios import adaptive_kernel_tutorial
_jit._numpy_work = int(sys.argv[1])
s = adaptive_kernel_tutorial(30, seed=3)
predictor = ft.AdaptiveKernelKalmanPredictor(s.transition_model, ft.QuadraticKernel())
updater = ft.AdaptiveKernelKalmanUpdater(s.measurement_model, ft.QuadraticKernel(), rng=4)
state, loaded = s.prior, []
for detection in s.detections[1:]:
    state = updater.update(ft.SingleHypothesis(predictor.predict(state, detection.timestamp),
                                               detection))
    loaded.append("numba" in sys.modules)
print(json.dumps({"loaded": loaded, "mean": state.mean.ravel().tolist()}))
"""


def test_a_small_akkf_leaves_numba_unloaded_then_the_kernels_take_over():
    short, switching, compiled = _runs(_AKKF, 100)
    for run in (short, switching):
        np.testing.assert_allclose(run["mean"], compiled["mean"], rtol=1e-6, atol=1e-6)
