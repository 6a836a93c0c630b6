"""Kernels and the adaptive kernel Kalman filter: Gram matrices and factors against the
reference, the factored filter against the contract's dense formulas and Stone Soup, and the
tutorial scenario at every size with every kernel."""
import numpy as np
import pytest

import fasttrack as ft
from fasttrack._jit import akkf, gram
from fasttrack.metrics import position_rmse
from fasttrack.scenarios import adaptive_kernel_tutorial

import reference.akkf
import reference.gram
from conftest import from_python, stream_key

KERNELS = {
    "linear": ft.LinearKernel(),
    "quadratic": ft.QuadraticKernel(c=1, ialpha=1),
    "quartic": ft.QuarticKernel(c=0.5, ialpha=3),
    "gaussian": ft.GaussianKernel(variance=0.7),
}


def _points(rng, d, n, scale=1.0):
    return rng.normal(size=(d, n)) * scale


def _reference_gram(kernel, x1, x2, angles=()):
    out = np.empty((x1.shape[1], x2.shape[1]))
    reference.gram.gram(kernel._kind, kernel._parameters(),
                        ft.Kernel.angle_mask(x1.shape[0], angles), x1, x2, out)
    return out


@pytest.mark.parametrize("name", KERNELS)
def test_gram_matches_reference(name):
    rng = np.random.default_rng(1)
    kernel = KERNELS[name]
    x1, x2 = _points(rng, 3, 17), _points(rng, 3, 9)
    k = kernel(x1, x2)
    assert k.shape == (17, 9)
    np.testing.assert_allclose(k, _reference_gram(kernel, x1, x2), rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("name", KERNELS)
def test_gram_is_symmetric_positive_semidefinite(name):
    kernel = KERNELS[name]
    x = _points(np.random.default_rng(2), 4, 40)
    k = kernel(x)
    np.testing.assert_allclose(k, k.T, rtol=1e-14)
    assert np.linalg.eigvalsh(k).min() >= -1e-12 * np.abs(k).max()


def test_kernel_formulas_and_defaults():
    x, y = np.array([[1.0], [2.0]]), np.array([[3.0], [-1.0]])
    assert ft.PolynomialKernel(3)(x, y)[0, 0] == pytest.approx((1 / 10 + 1) ** 3)
    assert ft.QuadraticKernel()(x, y)[0, 0] == pytest.approx((1 / 10 + 1) ** 2)
    assert ft.QuarticKernel(c=2, ialpha=4)(x, y)[0, 0] == pytest.approx((1 / 4 + 2) ** 4)
    assert ft.LinearKernel()(x, y)[0, 0] == pytest.approx(1.0)
    expected = np.exp(-13 / 20) / np.sqrt(20 * np.pi)
    assert ft.GaussianKernel(variance=10.0)(x, y)[0, 0] == pytest.approx(expected)


def test_kernel_accepts_states_and_defaults_second_argument():
    x = _points(np.random.default_rng(3), 4, 6)
    state = ft.KernelParticleState(x)
    kernel = KERNELS["quadratic"]
    np.testing.assert_array_equal(kernel(state), kernel(x, x))
    np.testing.assert_array_equal(kernel(state, ft.State(x[:, 0])), kernel(x, x[:, :1]))


def test_gaussian_kernel_wraps_angle_components():
    kernel = ft.GaussianKernel(variance=0.01)
    near_pi = kernel(np.array([[np.pi - 0.01]]), np.array([[-np.pi + 0.01]]), [0])
    near_zero = kernel(np.array([[0.0]]), np.array([[0.02]]), [0])
    assert near_pi[0, 0] == pytest.approx(near_zero[0, 0], rel=1e-9)
    assert kernel(np.array([[np.pi - 0.01]]), np.array([[-np.pi + 0.01]]))[0, 0] < 1e-100


def test_calling_a_kernel_never_changes_it():
    kernel = ft.GaussianKernel(variance=3.0)
    with pytest.raises(TypeError):
        kernel(np.ones((2, 2)), variance=5)
    assert kernel.variance == 3.0
    with pytest.raises(AttributeError):
        kernel.variance = 5


@pytest.mark.parametrize("make, message", [
    (lambda: ft.PolynomialKernel(0), "power"),
    (lambda: ft.PolynomialKernel(2.5), "power"),
    (lambda: ft.QuadraticKernel(ialpha=0), "ialpha"),
    (lambda: ft.QuarticKernel(c=-1), "c must"),
    (lambda: ft.GaussianKernel(variance=0), "variance"),
    (lambda: ft.GaussianKernel(variance=np.nan), "variance"),
])
def test_bad_kernel_parameters(make, message):
    with pytest.raises((ValueError, TypeError), match=message):
        make()


def test_kernel_input_errors():
    kernel = ft.QuadraticKernel()
    with pytest.raises(ValueError, match="same number of rows"):
        kernel(np.ones((2, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="NaN"):
        kernel(np.array([[np.nan]]))
    with pytest.raises(ValueError, match="angle_components"):
        ft.GaussianKernel()(np.ones((2, 3)), angle_components=[2])


@pytest.mark.parametrize("name", KERNELS)
def test_factor_matches_reference_and_reproduces_the_gram_matrix(name):
    kernel = KERNELS[name]
    x = _points(np.random.default_rng(4), 3, 50, scale=0.5)
    angles = ft.Kernel.angle_mask(3)
    f = gram.factor(kernel._kind, kernel._parameters(), angles, x)
    expected = reference.gram.factor(kernel._kind, kernel._parameters(), angles, x)
    assert f.shape == expected.shape
    np.testing.assert_allclose(f, expected, atol=1e-10 * np.abs(expected).max())
    k = kernel(x)
    np.testing.assert_allclose(f.T @ f, k, atol=1e-11 * np.abs(k).max())
    assert f.shape[0] <= {"linear": 3, "quadratic": 10, "quartic": 35}.get(name, 50)


def _dense_factors(s):
    return ft.KernelParticleState(np.zeros((1, s.shape[0])), kernel_covar=s)._factors


def _random_prior(rng, m, d=4, dense=False):
    x = _points(rng, d, m, scale=0.4)
    w = rng.uniform(-0.2, 1.0, m) / m
    if not dense:
        return x, w, ft.KernelParticleState(x, weight=w)._factors
    root = rng.normal(size=(m, m + 2)) / m
    return x, w, _dense_factors(root @ root.T)


@pytest.mark.parametrize("name", KERNELS)
@pytest.mark.parametrize("m", [12, 40])
@pytest.mark.parametrize("dense", [False, True])
def test_filter_kernels_match_dense_reference(name, m, dense):
    """Two filter cycles: each factored step against the contract's dense formulas on the
    same input (quartic at M = 12 has more features than particles, so the particle-space
    branch runs)."""
    kernel = KERNELS[name]
    kind, params = kernel._kind, kernel._parameters()
    rng = np.random.default_rng(5)
    x, w, factors = _random_prior(rng, m, dense=dense)
    proposal = x + _points(rng, 4, m, scale=0.1)
    lam = 1e-2
    state_angles, meas_angles = ft.Kernel.angle_mask(4), ft.Kernel.angle_mask(2, [0])
    for cycle in range(2):
        arguments = (kind, params, state_angles, proposal, x, w, *factors, lam)
        w, lt, v1t, v2t = akkf.predict_embedding(*arguments)
        w_ref, s_ref = reference.akkf.predict_embedding(*arguments)
        factors = (lt, 1.0 / m, v1t, v2t)
        _assert_close(w, w_ref)
        _assert_close(ft.types.dense_kernel_covar(factors), s_ref)
        _assert_close(akkf.sandwich(x, *factors), reference.akkf.sandwich(x, *factors))
        x = proposal + 0.05
        y = np.vstack([np.arctan2(x[2], x[0]), x[1]])
        z = np.array([[0.4], [0.1]])
        proposal, expected = np.empty_like(x), np.empty_like(x)
        arguments = (kind, params, meas_angles, y, z, w, *factors, lam, x, stream_key(cycle))
        w, lt, v1t, v2t = akkf.update_embedding(*arguments, proposal)
        w_ref, s_ref = reference.akkf.update_embedding(*arguments, expected)
        factors = (lt, 1.0 / m, v1t, v2t)
        _assert_close(w, w_ref)
        _assert_close(ft.types.dense_kernel_covar(factors), s_ref)
        np.testing.assert_allclose(proposal, expected, rtol=1e-7, atol=1e-9)
        again = np.empty_like(x)
        reference.akkf.draw_proposal(x, w, *factors, stream_key(cycle), again)
        np.testing.assert_allclose(proposal, again, rtol=1e-7, atol=1e-9)


def _assert_close(actual, expected, rtol=1e-7):
    np.testing.assert_allclose(actual, expected, atol=rtol * np.abs(expected).max())


def test_dense_kernel_covariance_of_factors():
    rng = np.random.default_rng(9)
    factors = (rng.normal(size=(3, 7)), 0.3, rng.normal(size=(2, 7)), rng.normal(size=(2, 7)))
    np.testing.assert_allclose(ft.types.dense_kernel_covar(factors),
                               reference.akkf.dense_covariance(*factors), rtol=1e-12, atol=1e-13)


def test_proposal_is_distributed_as_the_posterior_embedding():
    """Column draws have mean X w and variances diag(X S X^T)."""
    rng = np.random.default_rng(6)
    m = 20000
    x = rng.normal(size=(2, m))
    w = np.full(m, 1.0 / m)
    lt = rng.normal(size=(3, m)) / m
    factors = (lt, 0.5 / m, np.zeros((0, m)), np.zeros((0, m)))
    out = np.empty_like(x)
    akkf.draw_proposal(x, w, *factors, stream_key(7), out)
    variance = np.diag(akkf.sandwich(x, *factors))
    assert (np.abs(out.mean(axis=1) - x @ w) < 5 * np.sqrt(variance / m)).all()
    np.testing.assert_allclose(out.var(axis=1), variance, rtol=5 * np.sqrt(2 / m))


def test_kernel_particle_state_defaults_and_moments():
    x = _points(np.random.default_rng(8), 3, 5)
    state = ft.KernelParticleState(x, timestamp=2.0)
    np.testing.assert_array_equal(state.weight, np.full(5, 0.2))
    np.testing.assert_allclose(state.kernel_covar, np.eye(5) / 5, atol=1e-17)
    np.testing.assert_allclose(state.mean, x.mean(axis=1, keepdims=True), rtol=1e-14)
    np.testing.assert_allclose(state.covar, x @ x.T / 5, rtol=1e-13)
    assert (len(state), state.ndim, state.timestamp) == (5, 3, 2.0)
    s = np.diag([0.1, 0.2, 0.3, 0.4, 0.5])
    given = ft.KernelParticleState(x, weight=np.arange(5.0), kernel_covar=s)
    np.testing.assert_allclose(given.kernel_covar, s, atol=1e-15)
    np.testing.assert_allclose(given.covar, x @ s @ x.T, rtol=1e-13)
    np.testing.assert_allclose(given.mean[:, 0], x @ np.arange(5.0), rtol=1e-14)


@pytest.mark.parametrize("kwargs, message", [
    ({"weight": np.ones(4)}, "weight must have length 5"),
    ({"weight": np.array([1, 2, np.nan, 1, 1])}, "weight contains NaN"),
    ({"kernel_covar": np.eye(4)}, r"kernel_covar must have shape \(5, 5\)"),
    ({"kernel_covar": np.triu(np.ones((5, 5)))}, "symmetric"),
    ({"kernel_covar": np.eye(5) - 2 * np.ones((5, 5)) / 5}, "positive semi-definite"),
    ({"kernel_covar": np.ones((5, 5)) - np.eye(5)}, "positive semi-definite"),
    ({"timestamp": "now"}, "timestamp"),
])
def test_kernel_particle_state_errors(kwargs, message):
    with pytest.raises((ValueError, TypeError), match=message):
        ft.KernelParticleState(np.zeros((2, 5)), **kwargs)
    with pytest.raises(ValueError, match="NaN"):
        ft.KernelParticleState(np.full((2, 5), np.nan))



def test_kernel_particle_state_assignments_are_checked():
    """Particles or weights assigned later reached the moments unchecked (NumPy's matmul
    error, or NaN moments)."""
    state = ft.KernelParticleState(np.zeros((2, 5)), timestamp=0.0)
    with pytest.raises(ValueError, match="state_vector must hold the state's 5 particles"):
        state.state_vector = np.zeros((2, 6))
    with pytest.raises(ValueError, match="weight must have length 5"):
        state.weight = np.ones(3)
    with pytest.raises(ValueError, match="weight contains NaN"):
        state.weight = np.full(5, np.nan)
    state.state_vector, state.weight = np.ones((3, 5)), np.arange(5.0)
    np.testing.assert_allclose(state.mean, np.full((3, 1), 10.0))

def _tutorial_filter(kernel, scenario, rng=0):
    return (ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, kernel),
            ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, kernel, rng=rng))


_track = ft.run_filter


def test_filter_types_links_and_measurement_prediction():
    scenario = adaptive_kernel_tutorial(20, seed=1, steps=3)
    predictor, updater = _tutorial_filter(ft.QuadraticKernel(), scenario)
    detection = scenario.detections[1]
    prediction = predictor.predict(scenario.prior, detection.timestamp)
    assert isinstance(prediction, ft.KernelParticleStatePrediction)
    assert prediction.transition_model is scenario.transition_model
    assert prediction.timestamp == detection.timestamp
    hypothesis = ft.SingleHypothesis(prediction, detection)
    update = updater.update(hypothesis)
    assert isinstance(update, ft.KernelParticleStateUpdate)
    assert update.hypothesis is hypothesis and update.state_vector is prediction.state_vector
    assert update.proposal.shape == prediction.state_vector.shape
    measured = hypothesis.measurement_prediction
    assert isinstance(measured, ft.KernelParticleStateMeasurementPrediction)
    np.testing.assert_array_equal(
        measured.state_vector, scenario.measurement_model.function(prediction))
    again = updater.predict_measurement(prediction)
    np.testing.assert_array_equal(again.state_vector, measured.state_vector)
    following = predictor.predict(update, scenario.detections[2].timestamp)
    np.testing.assert_allclose(
        following.state_vector,
        scenario.transition_model.function(update.proposal, time_interval=1.0))


def test_filter_is_reproducible_for_a_seed():
    scenario = adaptive_kernel_tutorial(30, seed=2, steps=5)
    tracks = [_track(*_tutorial_filter(ft.QuadraticKernel(), scenario, rng=4), scenario.prior,
                     scenario.detections) for _ in range(2)]
    for a, b in zip(*tracks):
        np.testing.assert_array_equal(a.weight, b.weight)
        np.testing.assert_array_equal(a.proposal, b.proposal)


def test_filter_errors():
    scenario = adaptive_kernel_tutorial(10, seed=3, steps=2)
    predictor, updater = _tutorial_filter(ft.QuadraticKernel(), scenario)
    prior, detection = scenario.prior, scenario.detections[1]
    with pytest.raises(ValueError, match="lambda_predictor"):
        ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, lambda_predictor=0)
    with pytest.raises(ValueError, match="lambda_updater"):
        ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, lambda_updater=-1e-3)
    with pytest.raises(TypeError, match="kernel must be a Kernel"):
        ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, kernel=lambda x, y: x)
    with pytest.raises(TypeError, match="prior must be a KernelParticleState"):
        predictor.predict(ft.ParticleState(prior.state_vector, timestamp=prior.timestamp),
                          detection.timestamp)
    with pytest.raises(ValueError, match="4"):
        predictor.predict(ft.KernelParticleState(np.zeros((3, 10)), timestamp=prior.timestamp),
                          detection.timestamp)
    with pytest.raises(ValueError, match="no timestamp"):
        predictor.predict(ft.KernelParticleState(prior.state_vector), detection.timestamp)
    with pytest.raises(ValueError, match="proposal must have"):
        predictor.predict(prior, detection.timestamp, proposal=np.zeros((4, 9)))
    written = ft.KernelParticleState(prior.state_vector.copy(), timestamp=prior.timestamp)
    written.state_vector[0, 3] = np.nan
    with pytest.raises(ValueError, match="prior.state_vector contains NaN"):
        predictor.predict(written, detection.timestamp)
    prediction = predictor.predict(prior, detection.timestamp)
    corrupted = predictor.predict(prior, detection.timestamp)
    corrupted.state_vector[1, 0] = np.inf
    with pytest.raises(ValueError, match="the prediction's state_vector contains NaN"):
        updater.update(ft.SingleHypothesis(corrupted, detection))
    for bad, message in [([0.1, 0.2], "1 components"), ([np.nan], "NaN")]:
        with pytest.raises(ValueError, match=message):
            updater.update(ft.SingleHypothesis(
                prediction, ft.Detection(bad, timestamp=detection.timestamp)))
    with pytest.raises(ValueError, match="nothing to update"):
        updater.update(ft.SingleHypothesis(prediction, None))
    huge = ft.KernelParticleState(prior.state_vector * 1e80, timestamp=prior.timestamp)
    with pytest.raises(ValueError, match="not finite"):
        ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, ft.QuarticKernel()).predict(
            huge, detection.timestamp)


SIZES = [30, 300, 1000]
TUTORIAL_KERNELS = {"quadratic": ft.QuadraticKernel(c=1, ialpha=1),
                    "quartic": ft.QuarticKernel(c=1, ialpha=1),
                    "gaussian": ft.GaussianKernel()}


@pytest.mark.parametrize("m", SIZES)
@pytest.mark.parametrize("name", TUTORIAL_KERNELS)
def test_tutorial_runs_to_the_end_for_ten_seeds(name, m):
    for seed in range(10):
        scenario = adaptive_kernel_tutorial(m, seed=seed)
        track = _track(*_tutorial_filter(TUTORIAL_KERNELS[name], scenario, rng=seed),
                       scenario.prior, scenario.detections)
        assert len(track) == 30
        for state in track:
            assert np.isfinite(state.mean).all()
            assert (np.diag(state.covar) >= 0).all()
            assert np.isfinite(state.proposal).all()
        assert position_rmse(track, scenario.truth) < 5.0


# --- kernel scale: sensible for the data, validated, and no positive-definiteness failure ------

def _scaled_tutorial(scale, m, seed=50):
    """The AKKF tutorial with every length multiplied by ``scale`` (the sensor stays at the
    origin, bearings are unchanged)."""
    from fasttrack.scenarios import START
    rng = np.random.default_rng(seed)
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1e-4 * scale**2)] * 2)
    sensor = ft.Cartesian2DToBearing(4, (0, 2), np.array([[0.005 ** 2]]))
    start = np.array([-0.3, 0.001, 0.7, -0.055]) * scale
    truth = ft.ground_truth(transition, start, 30, start_time=START, rng=rng)
    detections = ft.detections(truth, sensor, rng=rng)
    spread = np.array([0.1, 0.005, 0.1, 0.01]) * scale
    prior = ft.KernelParticleState(start[:, None] + spread[:, None] * rng.standard_normal((4, m)),
                                   timestamp=START)
    return transition, sensor, truth, detections, prior


@pytest.mark.parametrize("m", [10, 70, 300])
def test_default_gaussian_kernel_tracks_the_same_at_any_scale(m):
    results = {}
    for scale in (1.0, 100.0, 1e4):
        transition, sensor, truth, detections, prior = _scaled_tutorial(scale, m)
        predictor = ft.AdaptiveKernelKalmanPredictor(transition, ft.GaussianKernel())
        updater = ft.AdaptiveKernelKalmanUpdater(sensor, ft.GaussianKernel(), rng=1)
        track = _track(predictor, updater, prior, detections)
        results[scale] = (np.array([s.weight for s in track]),
                          np.array([s.mean[:, 0] for s in track]) / scale,
                          position_rmse(track, truth) / scale)
    for scale in (100.0, 1e4):
        np.testing.assert_allclose(results[scale][0], results[1.0][0], rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(results[scale][1], results[1.0][1], rtol=1e-6, atol=1e-9)
    assert results[1.0][2] < 1.0  # the track does not collapse to the sensor (at 0.76 .. 2)


def test_a_fixed_gaussian_variance_far_below_the_spread_is_an_error():
    transition, sensor, _, detections, prior = _scaled_tutorial(1e4, 100)
    predictor = ft.AdaptiveKernelKalmanPredictor(transition, ft.GaussianKernel(variance=10.0))
    with pytest.raises(ValueError, match=r"GaussianKernel\(variance=10.0\) is too narrow for "
                                         r"these points: their median squared distance is"):
        predictor.predict(prior, detections[0].timestamp)
    assert ft.GaussianKernel()(prior.state_vector).min() > 0.99  # the default suits them
    narrow = ft.GaussianKernel(variance=10.0)(prior.state_vector)  # a Gram matrix is allowed
    np.testing.assert_allclose(np.diag(narrow), 1 / np.sqrt(20 * np.pi))
    assert (narrow - np.diag(np.diag(narrow))).max() < 1e-80


def test_polynomial_kernel_far_from_the_origin_runs_without_positive_definiteness_failure():
    for seed in range(5):
        transition, sensor, truth, detections, prior = _scaled_tutorial(1e4, 10, seed)
        track = _track(ft.AdaptiveKernelKalmanPredictor(transition, ft.PolynomialKernel(3)),
                       ft.AdaptiveKernelKalmanUpdater(sensor, ft.PolynomialKernel(3), rng=seed),
                       prior, detections)
        assert len(track) == 30 and all(np.isfinite(s.mean).all() for s in track)


def test_ridge_map_is_accurate_where_the_normal_equations_break_down():
    rng = np.random.default_rng(1)
    for scale in (1.0, 1e10):
        f = rng.normal(size=(6, 40)) * scale
        f[5] = f[4] * (1 + 1e-9)  # nearly dependent rows
        got = from_python(akkf._ridge_map)(f, 1e-3)
        assert np.isfinite(got).all()
        # (F F^T + lam I) got = F, to rounding relative to |F F^T| |got|
        residual = (f @ f.T + 1e-3 * np.eye(6)) @ got - f
        assert np.abs(residual).max() <= 1e-9 * np.abs(f @ f.T).max() * np.abs(got).max()
    # at unit scale it is the textbook formula, by either route
    f = rng.normal(size=(3, 20))
    want = np.linalg.solve(f @ f.T + 0.5 * np.eye(3), f)
    for route in (akkf._ridge_map, akkf._lq_ridge_map):
        np.testing.assert_allclose(from_python(route)(f, 0.5), want, rtol=1e-12, atol=1e-14)


def test_weights_that_carry_nothing_are_an_error():
    from fasttrack.core.akkf import check_weights
    with pytest.raises(ValueError, match="predicted kernel weights are all zero"):
        check_weights(np.zeros(5), "predicted")
    with pytest.raises(ValueError, match="updated kernel weights are not finite"):
        check_weights(np.array([1.0, np.inf]), "updated")
    with pytest.raises(ValueError, match="updated kernel weights are not finite"):
        check_weights(np.array([np.nan, 1.0]), "updated")
    check_weights(np.array([1e-300, 0.0]), "predicted")  # tiny but informative: allowed
    check_weights(np.array([-2.0, 1e-300]), "updated")
