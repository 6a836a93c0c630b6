"""Model parameters assigned after construction are validated and honoured everywhere from
the next call; arrays are read-only, dimensions and functions fixed; strict types."""
import datetime

import numpy as np
import pytest

import fasttrack as ft
from fasttrack.core.particle import propagate

from user_models import bearing_range_from_50_0

NOISE = np.diag([np.radians(0.2), 1.0])
START = datetime.datetime(2026, 1, 1)
STATES = np.random.default_rng(0).normal(size=(4, 2000)) * 20 + np.array([[30], [1], [40], [1]])


def _everything(sensor, transition):
    """What a model's parameters reach: its function and logpdf, a particle filter step
    and an EKF step."""
    z = np.array([0.4, 45.0]) if sensor.ndim_meas == 2 else np.array([0.4])
    prior = ft.ParticleState(STATES.copy(), timestamp=START)
    later = START + datetime.timedelta(seconds=1)
    prediction = ft.ParticlePredictor(transition, rng=1).predict(prior, later)
    particles = ft.ParticleUpdater(sensor).update(ft.SingleHypothesis(
        prediction, ft.Detection(z, timestamp=later)))
    gaussian = ft.GaussianState(STATES[:, :1], np.eye(4) * 4, timestamp=0.0)
    ekf = ft.ExtendedKalmanUpdater(sensor).update(ft.SingleHypothesis(
        ft.ExtendedKalmanPredictor(transition).predict(gaussian, 1.0), ft.Detection(z)))
    return [sensor.function(STATES), sensor.logpdf(z, STATES), particles.log_weight,
            ekf.state_vector, ekf.covar]


def _assert_same(a, b):
    for x, y in zip(a, b):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12)


def _cv(q=0.05):
    return ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)


@pytest.mark.parametrize("kind", [ft.CartesianToBearingRange, ft.Cartesian2DToBearing])
def test_polar_sensor_parameters_are_honoured_everywhere(kind):
    noise = NOISE if kind is ft.CartesianToBearingRange else NOISE[:1, :1]
    moved = kind(4, (0, 2), noise, translation_offset=[50.0, 0.0])
    before = _everything(moved, _cv())
    moved.translation_offset = [10.0, -5.0]
    moved.rotation_offset = [0.0, 0.0, 0.3]
    moved.noise_covar = noise * 4
    moved.mapping = (2, 0)
    fresh = kind(4, (2, 0), noise * 4, translation_offset=[10.0, -5.0],
                 rotation_offset=[0.0, 0.0, 0.3])
    after = _everything(moved, _cv())
    _assert_same(after, _everything(fresh, _cv()))
    assert not np.allclose(before[0], after[0])
    np.testing.assert_array_equal(moved.translation_offset, [[10.0], [-5.0]])
    np.testing.assert_allclose(moved.rotation_matrix, fresh.rotation_matrix)


def test_linear_sensor_mapping_keeps_function_and_matrix_in_step():
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    sensor.mapping = (1, 3)
    np.testing.assert_array_equal(sensor.function(STATES), STATES[[1, 3]])
    np.testing.assert_array_equal(sensor.matrix() @ STATES, sensor.function(STATES))
    fresh = ft.LinearGaussian(4, (1, 3), np.eye(2))
    z = np.array([1.0, 1.0])
    prior = ft.GaussianState(STATES[:, :1], np.eye(4), timestamp=0.0)
    updates = [ft.KalmanUpdater(model).update(ft.SingleHypothesis(
        ft.KalmanPredictor(_cv()).predict(prior, 1.0), ft.Detection(z))) for model in (sensor, fresh)]
    np.testing.assert_allclose(updates[0].state_vector, updates[1].state_vector, rtol=1e-14)
    with pytest.raises(ValueError, match=r"mapping must keep 2 components"):
        sensor.mapping = (0, 1, 2)
    with pytest.raises(ValueError, match=r"mapping indices must lie in \[0, 4\)"):
        sensor.mapping = (0, 4)


def test_transition_parameters_are_honoured_everywhere():
    sensor = ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50.0, 0.0])
    cv = ft.ConstantVelocity(0.05)
    combined = ft.CombinedLinearGaussianTransitionModel([cv, ft.ConstantVelocity(0.05)])
    _everything(sensor, combined)
    cv.noise_diff_coeff = 2.0
    _assert_same(_everything(sensor, combined), _everything(sensor, ft.CombinedLinearGaussianTransitionModel(
        [ft.ConstantVelocity(2.0), ft.ConstantVelocity(0.05)])))
    general = ft.LinearGaussianTransitionModel(np.eye(2), np.eye(2) * 0.1)
    mixed = ft.CombinedLinearGaussianTransitionModel([general, ft.ConstantVelocity(0.05)])
    x = STATES[:, :5]
    mixed.function(x, time_interval=1.0)  # memoises F
    general.transition_matrix = [[1.0, 2.0], [0.0, 1.0]]
    np.testing.assert_allclose(mixed.function(x, time_interval=1.0)[:2], [[1, 2], [0, 1]] @ x[:2])
    fresh = ft.CombinedLinearGaussianTransitionModel(
        [ft.LinearGaussianTransitionModel([[1.0, 2.0], [0.0, 1.0]], np.eye(2) * 0.1),
         ft.ConstantVelocity(0.05)])
    np.testing.assert_allclose(propagate(mixed.spec(1.0), x, 3), propagate(fresh.spec(1.0), x, 3))
    combined.model_list = [ft.ConstantVelocity(1.0), ft.ConstantVelocity(1.0)]
    np.testing.assert_allclose(combined.covar(1.0), _cv(1.0).covar(1.0))
    with pytest.raises(ValueError, match="model_list must keep 4 state dimensions"):
        combined.model_list = [ft.ConstantVelocity(1.0)]
    with pytest.raises(ValueError, match="noise_diff_coeff must be finite and >= 0"):
        cv.noise_diff_coeff = -1.0
    with pytest.raises(ValueError, match="covariance_matrix is not positive semi-definite"):
        general.covariance_matrix = [[1.0, 0.0], [0.0, -1.0]]


def test_arrays_are_read_only_and_dimensions_fixed():
    sensor = ft.CartesianToBearingRange(4, (0, 2), NOISE)
    for array in (sensor.noise_covar, sensor.translation_offset, sensor.rotation_offset,
                  sensor.rotation_matrix, sensor.covar()):
        with pytest.raises(ValueError, match="read-only"):
            array[0, 0] = 1.0
    general = ft.LinearGaussianTransitionModel(np.eye(2), np.eye(2))
    for array in (general.transition_matrix, general.covariance_matrix, general.matrix(),
                  general.covar()):
        with pytest.raises(ValueError, match="read-only"):
            array[0, 0] = 5.0
    for model, name in [(sensor, "ndim_state"), (sensor, "ndim_meas"), (general, "ndim_state"),
                        (ft.ConstantVelocity(1.0), "ndim_state")]:
        with pytest.raises(AttributeError):
            setattr(model, name, 3)
    user = ft.NonlinearGaussianMeasurement(bearing_range_from_50_0, 4, NOISE, angle_components=(0,))
    for name in ("measurement_function", "angle_components"):
        with pytest.raises(AttributeError):
            setattr(user, name, None)
    user.noise_covar = NOISE * 2  # the noise may change
    np.testing.assert_allclose(user.covar(), NOISE * 2)
    kernel = ft.GaussianKernel(1.0)
    for name, value in (("variance", 2.0), ("width", 3.0)):
        with pytest.raises(AttributeError):
            setattr(kernel, name, value)
    with pytest.raises(AttributeError):
        ft.QuadraticKernel().c = 2.0


@pytest.mark.parametrize("build, error, message", [
    (lambda: ft.LinearGaussian(4, (0.0, 2.0), np.eye(2)), TypeError, "mapping must hold integer"),
    (lambda: ft.LinearGaussian(4, (True, 2), np.eye(2)), TypeError, "mapping must hold integer"),
    (lambda: ft.LinearGaussian(4, "02", np.eye(2)), TypeError, "mapping must be a sequence"),
    (lambda: ft.LinearGaussian(4, 2, np.eye(1)), TypeError, "mapping must be a sequence"),
    (lambda: ft.CartesianToBearingRange(4, (0, 2, 3), NOISE), ValueError, "2 state indices"),
    (lambda: ft.NonlinearGaussianMeasurement(bearing_range_from_50_0, 4, NOISE,
                                             angle_components=(0.0,)), TypeError,
     "angle_components must hold integer"),
    (lambda: ft.LinearGaussian(4, (0, 2), np.eye(2) + 1j), TypeError, "noise_covar must be a numeric"),
    (lambda: ft.LinearGaussian(4, (0, 2), [["1", "0"], ["0", "1"]]), TypeError,
     "noise_covar must be a numeric"),
    (lambda: ft.LinearGaussian(4, (0, 2), np.eye(2, dtype=bool)), TypeError,
     "noise_covar must be a numeric"),
    (lambda: ft.LinearGaussian(4, (0, 2), [[1.0, 2.0], [2.0, 1.0]]), ValueError,
     "noise_covar is not positive semi-definite"),
    (lambda: ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=5.0), ValueError,
     "translation_offset must have 2 components"),
    (lambda: ft.ConstantVelocity(True), TypeError, "noise_diff_coeff must be a real number"),
    (lambda: ft.ConstantVelocity("1"), TypeError, "noise_diff_coeff must be a real number"),
    (lambda: ft.ParticleState(np.zeros((2, 3)) + 1j), TypeError, "state_vector must be a numeric"),
    (lambda: ft.ParticleState([["1", "2"]]), TypeError, "state_vector must be a numeric"),
    (lambda: ft.ParticleState(np.zeros((2, 3)), fixed_covar=[[1.0, 2.0], [0.0, 1.0]]),
     ValueError, "fixed_covar must be symmetric"),
    (lambda: ft.ParticleState(np.zeros((2, 3)), fixed_covar=[[1.0, 2.0], [2.0, 1.0]]),
     ValueError, "fixed_covar is not positive semi-definite"),
    (lambda: ft.Detection("1.5"), TypeError, "state_vector must be a numeric"),
    (lambda: ft.GaussianState([1.0, 2.0], np.eye(2) * (1 + 0j)), TypeError, "covar must be a numeric"),
    # scalars where arrays are expected
    (lambda: ft.systematic(0.5), ValueError, "log_weights must be 1-D, got 0-D"),
    (lambda: ft.ess(0.5), ValueError, "log_weights must be 1-D, got 0-D"),
    (lambda: ft.Detection(3.0), ValueError, r"state_vector must have shape \(d,\) or \(d, 1\)"),
    (lambda: ft.GaussianState(1.0, np.eye(1)), ValueError, "state_vector must have shape"),
    (lambda: ft.Particle(1.0, 1.0), ValueError, "state_vector must have shape"),
    (lambda: ft.GaussianKernel()(1.0), ValueError, "state1 must be a"),
    (lambda: ft.ParticleState(np.zeros((2, 3)), weight=1.0), ValueError, "weight must be 1-D"),
])
def test_strict_inputs(build, error, message):
    with pytest.raises(error, match=message):
        build()


def test_strict_inputs_of_calls():
    sensor = ft.CartesianToBearingRange(4, (0, 2), NOISE)
    with pytest.raises(TypeError, match="measurement must be a numeric"):
        sensor.logpdf(["0.1", "5"], np.zeros(4))
    with pytest.raises(TypeError, match="measurement must be a numeric"):
        sensor.logpdf([0.1 + 1j, 5.0], np.zeros(4))
    with pytest.raises(ValueError, match="noise must have shape"):
        sensor.function(np.zeros((4, 3)), noise=np.zeros((2, 5)))
    with pytest.raises(TypeError, match="nparts must be an int"):
        ft.systematic(np.zeros(4), nparts=4.0)
    with pytest.raises(ValueError, match=r"nparts must be <= 1099511627776"):
        ft.SystematicResampler().resample(ft.ParticleState(np.zeros((1, 4))), nparts=2**62)
    with pytest.raises(TypeError, match="log_weights must be a numeric"):
        ft.ess(np.array([True, False]))
    batch = ft.BatchExtendedKalmanFilter(_cv(), sensor)
    means, covars = np.zeros((2, 4)) + 10, np.stack([np.eye(4)] * 2)
    with pytest.raises(TypeError, match="time_intervals must be a numeric"):
        batch.step(means, covars, np.zeros((2, 2)), "1.0")
    covars[1, 0, 1] = 0.5
    with pytest.raises(ValueError, match=r"1 of 2 filters failed; filter 1: covars\[1\] is not "
                                         r"symmetric"):
        batch.step(means, covars, np.zeros((2, 2)), 1.0)


def test_empty_batches_give_empty_results():
    batch = ft.BatchExtendedKalmanFilter(_cv(), ft.CartesianToBearingRange(4, (0, 2), NOISE))
    means, covars = batch.step(np.zeros((0, 4)), np.zeros((0, 4, 4)), np.zeros((0, 2)), 1.0)
    assert means.shape == (0, 4) and covars.shape == (0, 4, 4)
    means, covars = batch.run(np.zeros((3, 4)) + 10, np.stack([np.eye(4)] * 3), np.zeros((0, 3, 2)),
                              1.0)
    assert means.shape == (0, 3, 4) and covars.shape == (0, 3, 4, 4)
    means, covars = batch.run(np.zeros((0, 4)), np.zeros((0, 4, 4)), np.zeros((5, 0, 2)), 1.0)
    assert means.shape == (5, 0, 4)


def test_f_and_q_are_remembered_for_a_few_intervals_at_once():
    from fasttrack.models import transition
    cv = ft.ConstantVelocity(0.05)
    for dt in [1.0, 0.0, 1.0, 2.5, 0.0, *np.linspace(3.0, 4.0, 20), 1.0]:
        np.testing.assert_array_equal(cv._matrix(dt), [[1.0, dt], [0.0, 1.0]])
        np.testing.assert_allclose(cv._covar(dt), 0.05 * np.array([[dt**3 / 3, dt**2 / 2],
                                                                   [dt**2 / 2, dt]]))
    assert 0 < len(cv.__dict__["_matrix_memo"]) <= transition.MEMO_INTERVALS
    assert 0 < len(cv.__dict__["_covar_memo"]) <= transition.MEMO_INTERVALS
