"""Kalman and extended Kalman filters: kernels against mirrors, Stone Soup parity, the batch
API, numerics and bad input."""
import datetime

import numpy as np
import pytest

import fasttrack as ft
from fasttrack._jit import jacobian as jac_kernels
from fasttrack._jit import kalman as kernels

import reference.jacobian
import reference.kalman
import reference.status
from conftest import stonesoup_tutorial
from user_models import bearing_range_from_50_0, coordinated_turn

START = datetime.datetime(2026, 1, 1)
NOISE = np.diag([np.radians(0.2), 1.0])
PRIOR_COVAR = np.diag([1.5, 0.5, 1.5, 0.5])


def _models():
    return (ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2),
            ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0]))


# --- Jacobians ---------------------------------------------------------------------------------

def _sensors():
    rotated = dict(translation_offset=[5.0, -3.0], rotation_offset=[0.0, 0.0, 0.6])
    return [ft.CartesianToBearingRange(4, (0, 2), NOISE, **rotated),
            ft.Cartesian2DToBearing(4, (2, 0), [[1e-4]], **rotated),
            ft.LinearGaussian(4, (0, 2), np.eye(2))]


@pytest.mark.parametrize("sensor", _sensors())
@pytest.mark.parametrize("x", [[1.3, 0.9, 2.2, 1.1], [-30.0, 1.0, 0.5, -1.0],
                               [-20.0, 0.0, -1e-9, 0.0]])  # the last sits on the +-pi cut
def test_jacobians_match_mirrors_and_each_other(sensor, x):
    x = np.array(x)
    results = {}
    for method in (jac_kernels.ANALYTIC, jac_kernels.FORWARD, jac_kernels.CENTRAL):
        got, want = np.empty((sensor.ndim_meas, 4)), np.empty((sensor.ndim_meas, 4))
        args = (sensor.kind, x, sensor.spec.mapping, sensor.spec.offset, sensor.spec.rotation, sensor.spec.angles,
                method)
        jac_kernels.measurement_jacobian(*args, got)
        reference.jacobian.measurement_jacobian(*args, want)
        # finite differences amplify the last bit of atan2 (NumPy's and libm's may differ)
        tolerance = 1e-12 if method == jac_kernels.ANALYTIC else 4e-16 * np.pi / 1e-8
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=tolerance)
        results[method] = got
    # central differences agree with the analytic derivative to O(step^2); forward to O(step)
    np.testing.assert_allclose(results[jac_kernels.CENTRAL], results[jac_kernels.ANALYTIC],
                               rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(results[jac_kernels.FORWARD], results[jac_kernels.ANALYTIC],
                               rtol=1e-4, atol=1e-6)


def test_forward_jacobian_is_stone_soups():
    nonlinear = pytest.importorskip("stonesoup.models.measurement.nonlinear")
    from stonesoup.types.state import State
    theirs = nonlinear.CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=NOISE,
                                              translation_offset=np.array([[50], [0]]))
    _, ours = _models()
    rng = np.random.default_rng(0)
    exact = 0
    for x in list(rng.normal(0, 30, (20, 4))) + [np.array([-10.0, 0.0, -1e-9, 0.0]) + [50, 0, 0, 0]]:
        got = np.empty((2, 4))
        jac_kernels.measurement_jacobian(ours.kind, x, ours.spec.mapping, ours.spec.offset, ours.spec.rotation,
                                         ours.spec.angles, jac_kernels.FORWARD, got)
        want = theirs.jacobian(State(x.reshape(-1, 1)))
        # the same steps, points and wrapping: equal up to one ulp of atan2 over the step
        steps = np.maximum(1e8 * np.spacing(x), 1e-8)
        assert np.all(np.abs(got - want) <= 2 * np.spacing(np.pi) / steps)
        exact += np.array_equal(got, want)
    assert exact >= 15


def test_user_function_jacobians_match_mirrors():
    x = np.array([3.0, 1.0, -4.0, 0.5])
    for central in (False, True):
        got, want = np.empty((2, 4)), np.empty((2, 4))
        angles = np.array([True, False])
        jac_kernels.measurement_jacobian_function(bearing_range_from_50_0, x, angles, central, got)
        reference.jacobian.measurement_jacobian_function(bearing_range_from_50_0, x, angles,
                                                         central, want)
        np.testing.assert_allclose(got, want, rtol=1e-12)
        got, want = np.empty((4, 4)), np.empty((4, 4))
        jac_kernels.transition_jacobian_function(coordinated_turn, 2.0, x, central, got)
        reference.jacobian.transition_jacobian_function(coordinated_turn, 2.0, x, central, want)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


# --- one-filter kernels against mirrors ----------------------------------------------------------

def test_kalman_kernels_match_mirrors():
    transition, sensor = _models()
    x = np.array([[1.0], [0.8], [2.0], [1.2]])
    covariance = PRIOR_COVAR + 0.1
    for dt in (1.0, 0.3, -2.0):
        kind, rates, matrix, covar = transition.spec(dt).kalman()
        outs = [(np.empty((4, 1)), np.empty((4, 4))) for _ in range(2)]
        assert kernels.predict_one(kind, rates, matrix, covar, dt, x, covariance, *outs[0]) == 0
        assert reference.kalman.predict_one(kind, rates, matrix, covar, dt, x, covariance,
                                            *outs[1]) == 0
        for a, b in zip(*outs):
            np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-15)
    z = np.array([[0.05], [48.0]])
    for method in (0, 1, 2):
        for joseph in (False, True):
            outs = [(np.empty((4, 1)), np.empty((4, 4)), np.empty((2, 1)), np.empty((2, 2)),
                     np.empty((4, 2))) for _ in range(2)]
            args = (*sensor.spec.sensor, method, joseph, x, covariance, z)
            assert (kernels.update_one(*args, *outs[0])
                    == reference.kalman.update_one(*args, *outs[1]) == 0)
            rtol = 1e-10 if method == 0 else 1e-7  # finite differences: see above
            for a, b in zip(*outs):
                np.testing.assert_allclose(a, b, rtol=rtol, atol=1e-12)
    outs = [(np.empty((4, 1)), np.empty((4, 4))) for _ in range(2)]
    q = np.eye(4) * 0.01
    assert kernels.predict_function(coordinated_turn, 1.0, q, False, x, covariance, *outs[0]) == 0
    reference.kalman.predict_function(coordinated_turn, 1.0, q, False, x, covariance, *outs[1])
    for a, b in zip(*outs):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)
    means = np.array([x[:, 0], x[:, 0] * 0.5, [np.nan] * 4])
    covariances = np.array([covariance, covariance * 2.0, covariance])
    outs = [(np.empty((3, 4)), np.empty((3, 4, 4)), np.empty(3, dtype=np.int64))
            for _ in range(2)]
    for module, out in zip((kernels, reference.kalman), outs):
        module.stack_predict_function(coordinated_turn, 1.0, q, True, means, covariances, *out)
    np.testing.assert_array_equal(outs[0][2], [0, 0, reference.status.FUNCTION_NOT_FINITE])
    np.testing.assert_array_equal(outs[1][2], outs[0][2])
    for a, b in zip(outs[0][:2], outs[1][:2]):
        np.testing.assert_allclose(a[:2], b[:2], rtol=1e-12, atol=1e-14)
    outs = [(np.empty((3, 4, 4)), np.empty((3, 4)), np.empty(3, dtype=np.int64))
            for _ in range(2)]
    for module, out in zip((kernels, reference.kalman), outs):
        module.stack_linearise_function(coordinated_turn, 2.0, False, means, *out)
    np.testing.assert_array_equal(outs[0][2], [0, 0, reference.status.FUNCTION_NOT_FINITE])
    np.testing.assert_array_equal(outs[1][2], outs[0][2])
    for a, b in zip(outs[0][:2], outs[1][:2]):
        np.testing.assert_allclose(a[:2], b[:2], rtol=1e-12, atol=1e-14)
    outs = [(np.empty((4, 1)), np.empty((4, 4)), np.empty((2, 1)), np.empty((2, 2)),
             np.empty((4, 2))) for _ in range(2)]
    z_ub = np.array([[0.05], [48.0]])
    args = (bearing_range_from_50_0, NOISE, np.array([True, False]), True, False, x, covariance, z_ub)
    assert (kernels.update_function(*args, *outs[0])
            == reference.kalman.update_function(*args, *outs[1]) == 0)
    for a, b in zip(*outs):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


# --- the EKF tutorial against Stone Soup ----------------------------------------------------------

def _stonesoup_ekf_run(exact_jacobian):
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import ExtendedKalmanUpdater

    class ExactBearingRange(CartesianToBearingRange):
        def jacobian(self, state, **kwargs):
            x = np.asarray(state.state_vector, float).ravel()
            dx, dy = x[0] - 50.0, x[2]
            rho2 = dx * dx + dy * dy
            out = np.zeros((2, 4))
            out[0, 0], out[0, 2] = -dy / rho2, dx / rho2
            out[1, 0], out[1, 2] = dx / np.sqrt(rho2), dy / np.sqrt(rho2)
            return out

    transition, sensor, _, detections = stonesoup_tutorial(
        1991, ExactBearingRange if exact_jacobian else None)
    predictor, updater = ExtendedKalmanPredictor(transition), ExtendedKalmanUpdater(sensor)
    prior = GaussianState([[0], [1], [0], [1]], PRIOR_COVAR, timestamp=START)
    states = []
    for detection in detections:
        prior = updater.update(SingleHypothesis(predictor.predict(prior, timestamp=detection.timestamp),
                                                detection))
        states.append(prior)
    return [np.asarray(d.state_vector, float) for d in detections], states


def _fasttrack_ekf_run(measurements, jacobian):
    transition, sensor = _models()
    predictor = ft.ExtendedKalmanPredictor(transition)
    updater = ft.ExtendedKalmanUpdater(sensor, jacobian=jacobian)
    prior = ft.GaussianState([0, 1, 0, 1], PRIOR_COVAR, timestamp=START)
    states = []
    for k, z in enumerate(measurements):
        detection = ft.Detection(z, timestamp=START + datetime.timedelta(seconds=k))
        prior = updater.update(ft.SingleHypothesis(predictor.predict(prior, detection.timestamp),
                                                   detection))
        states.append(prior)
    return states


def _worst(ours, theirs):
    worst = 0.0
    for a, b in zip(ours, theirs):
        for mine, their in ((a.state_vector, b.state_vector), (a.covar, b.covar)):
            their = np.asarray(their, float)
            worst = max(worst, np.abs(mine - their).max() / np.abs(their).max())
    return worst


def test_ekf_tutorial_equals_stone_soup():
    """With the exact Jacobian on both sides the filters agree to 1e-9 at every step; with
    Stone Soup's own finite differences (accurate to ~1e-6, and chaotic in the last bits of
    the state) they agree to that accuracy."""
    pytest.importorskip("stonesoup")
    measurements, theirs = _stonesoup_ekf_run(exact_jacobian=True)
    assert _worst(_fasttrack_ekf_run(measurements, "analytic"), theirs) < 1e-9
    measurements, theirs = _stonesoup_ekf_run(exact_jacobian=False)
    assert _worst(_fasttrack_ekf_run(measurements, "forward"), theirs) < 1e-5
    ours = _fasttrack_ekf_run(measurements, "forward")
    assert ours[0].hypothesis.measurement_prediction.cross_covar.shape == (4, 2)
    assert ours[-1].timestamp == START + datetime.timedelta(seconds=20)


def test_kalman_filter_matches_the_textbook():
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), [[0.5, 0.1], [0.1, 0.8]])
    predictor, updater = ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor)
    state = ft.GaussianState([0, 1, 0, 1], PRIOR_COVAR, timestamp=0.0)
    x, p = state.state_vector.copy(), state.covar.copy()
    rng = np.random.default_rng(2)
    for k in range(1, 30):
        z = rng.normal(k, 1.0, (2, 1))
        prediction = predictor.predict(state, float(k))
        hypothesis = ft.SingleHypothesis(prediction, ft.Detection(z, timestamp=float(k)))
        assert isinstance(prediction, ft.GaussianStatePrediction) and prediction.prior is state
        state = updater.update(hypothesis)
        f, q, h, r = transition.matrix(1.0), transition.covar(1.0), sensor.matrix(), sensor.noise_covar
        x, p = f @ x, f @ p @ f.T + q
        s = h @ p @ h.T + r
        gain = p @ h.T @ np.linalg.inv(s)
        x, p = x + gain @ (z - h @ x), p - gain @ s @ gain.T
        np.testing.assert_allclose(state.state_vector, x, rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(state.covar, p, rtol=1e-11, atol=1e-13)
        assert isinstance(state, ft.GaussianStateUpdate) and state.hypothesis is hypothesis
        np.testing.assert_allclose(hypothesis.measurement_prediction.covar, s, rtol=1e-11)
    mp = updater.predict_measurement(prediction)
    assert isinstance(mp, ft.GaussianMeasurementPrediction) and mp.state_vector.shape == (2, 1)


def test_joseph_form_agrees_and_stays_positive_definite():
    transition, sensor = _models()
    measurements = ft.detections(ft.ground_truth(transition, [0, 1, 0, 1], 50, rng=3), sensor, rng=4)
    states = {}
    for joseph in (False, True):
        predictor = ft.ExtendedKalmanPredictor(transition)
        updater = ft.ExtendedKalmanUpdater(sensor, use_joseph_cov=joseph)
        state = ft.GaussianState([0, 1, 0, 1], PRIOR_COVAR, timestamp=0.0)
        for detection in measurements:
            state = updater.update(ft.SingleHypothesis(predictor.predict(state, detection.timestamp),
                                                       detection))
        states[joseph] = state
    np.testing.assert_allclose(states[True].covar, states[False].covar, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(states[True].state_vector, states[False].state_vector, rtol=1e-9)


def test_covariance_stays_symmetric_positive_definite_over_ten_thousand_steps():
    transition, sensor = _models()
    batch = ft.BatchExtendedKalmanFilter(transition, sensor)
    truth = ft.ground_truth(transition, [0, 1, 0, 1], 10_000, rng=5)
    z = np.hstack([d.state_vector for d in ft.detections(truth, sensor, rng=6)]).T[1:, None, :]
    means, covars = batch.run(np.array([[0, 1, 0, 1.0]]), PRIOR_COVAR[None], z, 1.0)
    covars = covars[:, 0]
    assert np.array_equal(covars, np.swapaxes(covars, 1, 2))
    assert np.linalg.eigvalsh(covars).min() > 0 and np.isfinite(means).all()
    # near the sensor the filter is consistent: position errors match its covariance (NEES ~ 2)
    errors = means[:500, 0, [0, 2]] - np.array([s.state_vector[[0, 2], 0] for s in truth][1:501])
    position = covars[:500, [0, 2]][:, :, [0, 2]]
    nees = np.einsum("ti,tij,tj->t", errors, np.linalg.inv(position), errors)
    assert 1.0 < nees.mean() < 4.0


# --- the batch API --------------------------------------------------------------------------------

def _batch_inputs(k, seed=0):
    rng = np.random.default_rng(seed)
    means = np.array([0, 1, 0, 1.0]) + rng.normal(0, 1, (k, 4))
    covars = np.array([PRIOR_COVAR + np.diag(rng.uniform(0, 1, 4)) for _ in range(k)])
    measurements = np.column_stack([rng.normal(0.0, 0.1, k), rng.normal(49.0, 1.0, k)])
    return means, covars, measurements, rng.uniform(0.5, 1.5, k)


@pytest.mark.parametrize("joseph", [False, True])
def test_batch_step_equals_the_class_api_and_its_mirror(joseph):
    transition, sensor = _models()
    means, covars, measurements, intervals = _batch_inputs(300)
    got_means, got_covars = ft.BatchExtendedKalmanFilter(transition, sensor, use_joseph_cov=joseph).step(
        means, covars, measurements, intervals)
    predictor, updater = ft.ExtendedKalmanPredictor(transition), ft.ExtendedKalmanUpdater(
        sensor, use_joseph_cov=joseph)
    for k in range(300):
        prior = ft.GaussianState(means[k], covars[k], timestamp=0.0)
        state = updater.update(ft.SingleHypothesis(predictor.predict(prior, intervals[k]),
                                                   ft.Detection(measurements[k], timestamp=intervals[k])))
        np.testing.assert_allclose(got_means[k], state.state_vector[:, 0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(got_covars[k], state.covar, rtol=1e-12, atol=1e-13)
    want_means, want_covars, status = np.empty_like(means), np.empty_like(covars), np.empty(300, int)
    reference.kalman.batch_step(*transition.spec(1.0).kalman(), intervals, *sensor.spec.sensor, 0,
                                joseph, means, covars, measurements, want_means, want_covars,
                                status)
    np.testing.assert_allclose(got_means, want_means, rtol=1e-10)
    np.testing.assert_allclose(got_covars, want_covars, rtol=1e-10, atol=1e-12)


def test_batch_run_equals_stepping_and_its_mirror():
    transition, sensor = _models()
    means, covars, _, _ = _batch_inputs(130, seed=1)
    rng = np.random.default_rng(2)
    steps = 7
    measurements = np.stack([np.column_stack([rng.normal(0, 0.1, 130), rng.normal(49, 1, 130)])
                             for _ in range(steps)])
    intervals = rng.uniform(0.5, 1.5, (steps, 130))
    batch = ft.BatchExtendedKalmanFilter(transition, sensor)
    run_means, run_covars = batch.run(means, covars, measurements, intervals)
    m, p = means, covars
    for t in range(steps):
        m, p = batch.step(m, p, measurements[t], intervals[t])
        np.testing.assert_allclose(run_means[t], m, rtol=1e-13)
        np.testing.assert_allclose(run_covars[t], p, rtol=1e-13)
    want_means, want_covars = np.empty_like(run_means), np.empty_like(run_covars)
    status = [None] * 130
    reference.kalman.batch_run(*transition.spec(1.0).kalman(), intervals, *sensor.spec.sensor, 0,
                               False, means, covars, measurements, want_means, want_covars, status)
    np.testing.assert_allclose(run_means, want_means, rtol=1e-9)
    np.testing.assert_allclose(run_covars, want_covars, rtol=1e-9, atol=1e-12)
    same = batch.run(means, covars, measurements, 1.0)  # one interval for all
    assert same[0].shape == (steps, 130, 4)


# --- user models and bad input ------------------------------------------------------------------

def test_user_njit_models_through_the_ekf():
    turn = ft.NonlinearGaussianTransitionModel(coordinated_turn, np.eye(4) * 0.01, 4)
    user_sensor = ft.NonlinearGaussianMeasurement(bearing_range_from_50_0, 4, NOISE, angle_components=(0,))
    _, sensor = _models()
    truth = ft.ground_truth(turn, [0, 1, 0, 1], 30, rng=7)
    measurements = ft.detections(truth, sensor, rng=8)
    results = {}
    for name, model in (("user", user_sensor), ("built-in", sensor)):
        predictor = ft.ExtendedKalmanPredictor(turn, jacobian="central")
        updater = ft.ExtendedKalmanUpdater(model, jacobian="central")
        state = ft.GaussianState([0, 1, 0, 1], PRIOR_COVAR, timestamp=0.0)
        for detection in measurements:
            d = ft.Detection(detection.state_vector, timestamp=detection.timestamp)
            state = updater.update(ft.SingleHypothesis(predictor.predict(state, d.timestamp), d))
        results[name] = state
    np.testing.assert_allclose(results["user"].state_vector, results["built-in"].state_vector, rtol=1e-6)
    assert np.linalg.norm(results["user"].state_vector[[0, 2], 0] - truth[-1].state_vector[[0, 2], 0]) < 3


def test_bad_input_is_a_clear_error():
    transition, sensor = _models()
    predictor, updater = ft.ExtendedKalmanPredictor(transition), ft.ExtendedKalmanUpdater(sensor)
    with pytest.raises(ValueError, match="prior.covar is not positive semi-definite"):
        predictor.predict(ft.GaussianState([0, 1, 0, 1], np.diag([1, -1, 1, 1.0]), timestamp=0.0), 1.0)
    prediction = predictor.predict(ft.GaussianState([50, 0, 0, 0], PRIOR_COVAR, timestamp=0.0), 1e-9)
    with pytest.raises(ValueError, match="Jacobian is undefined"):
        updater.update(ft.SingleHypothesis(prediction, ft.Detection([0.0, 1.0], timestamp=1.0)))
    prediction = predictor.predict(ft.GaussianState([0, 1, 0, 1], PRIOR_COVAR, timestamp=0.0), 1.0)
    detection = ft.Detection([0.0, 1.0], timestamp=1.0)
    detection.state_vector[0, 0] = np.nan  # corrupted after construction
    with pytest.raises(ValueError, match="measurement contains NaN"):
        updater.update(ft.SingleHypothesis(prediction, detection))
    singular = ft.KalmanUpdater(ft.LinearGaussian(4, (0, 2), np.zeros((2, 2))))
    flat = ft.GaussianState([0, 1, 0, 1], np.diag([0, 1, 0, 1.0]), timestamp=1.0)
    with pytest.raises(ValueError, match="innovation covariance .* not positive definite"):
        singular.update(ft.SingleHypothesis(flat, ft.Detection([0.0, 0.0], timestamp=1.0)))
    with pytest.raises(ValueError, match="must have 2 components"):
        updater.update(ft.SingleHypothesis(prediction, ft.Detection([0.0, 1.0, 2.0], timestamp=1.0)))
    with pytest.raises(TypeError, match="needs a LinearGaussian measurement model"):
        ft.KalmanUpdater(sensor)
    with pytest.raises(TypeError, match="needs a linear transition model"):
        ft.KalmanPredictor(ft.NonlinearGaussianTransitionModel(coordinated_turn, np.eye(4), 4))
    with pytest.raises(TypeError, match="prior must be a GaussianState"):
        predictor.predict(ft.ParticleState(np.zeros((4, 3)), timestamp=0.0), 1.0)
    with pytest.raises(ValueError, match="jacobian must be one of"):
        ft.ExtendedKalmanUpdater(sensor, jacobian="symbolic")
    batch = ft.BatchExtendedKalmanFilter(transition, sensor)
    means, covars, measurements, intervals = _batch_inputs(5)
    covars[3] = np.diag([1, -1, 1, 1.0])
    with pytest.raises(ValueError, match=r"1 of 5 filters failed; filter 3: covars\[3\] is not positive"):
        batch.step(means, covars, measurements, intervals)
    with pytest.raises(ValueError, match=r"covars must have shape \(5, 4, 4\)"):
        batch.step(means, covars[:, :3], measurements, intervals)
    with pytest.raises(ValueError, match="time_intervals .* must broadcast"):
        batch.step(means, covars, measurements, np.ones(4))
    with pytest.raises(TypeError, match="built-in MeasurementModel"):
        ft.BatchExtendedKalmanFilter(transition, ft.NonlinearGaussianMeasurement(
            bearing_range_from_50_0, 4, NOISE))


@pytest.mark.parametrize("jacobian", ["analytic", "forward", "central"])
def test_an_update_at_the_sensor_is_refused_by_every_jacobian(jacobian):
    """At the sensor a bearing has no derivative: every linearisation of the updater refuses
    (in NumPy and in the kernels), and the batch's analytic and central ones. Forward
    differences, Stone Soup's rule, give numbers there, which its drop-ins return."""
    transition, sensor = _models()
    prediction = ft.GaussianStatePrediction([50, 0, 0, 0], PRIOR_COVAR, timestamp=1.0)
    updater = ft.ExtendedKalmanUpdater(sensor, jacobian=jacobian)
    with pytest.raises(ValueError, match="Jacobian is undefined"):
        updater.update(ft.SingleHypothesis(prediction, ft.Detection([0.0, 1.0], timestamp=1.0)))
    from fasttrack.core import kalman, kalman_numpy
    undefined = jacobian != "forward"
    if undefined:
        with pytest.raises(ValueError, match="filter 0: the measurement Jacobian is undefined"):
            ft.BatchExtendedKalmanFilter(transition, sensor, jacobian=jacobian).update(
                np.array([[50.0, 0, 0, 0]]), PRIOR_COVAR[None], np.array([[0.0, 1.0]]))
    assert np.isnan(kalman_numpy.jacobian(sensor.spec, kalman.JACOBIANS[jacobian],
                                          prediction.state_vector)).all() == undefined
    args = (sensor.kind, prediction.state_vector[:, 0].copy(), sensor.spec.mapping,
            sensor.spec.offset, sensor.spec.rotation, sensor.spec.angles,
            kalman.JACOBIANS[jacobian])
    for function in (jac_kernels.measurement_jacobian, reference.jacobian.measurement_jacobian):
        out = np.zeros((2, 4))
        function(*args, out)
        assert np.isnan(out).all() == undefined


def test_values_written_into_states_and_overflowing_updates_are_refused():
    transition, sensor = _models()
    linear = ft.LinearGaussian(4, (0, 2), np.eye(2))
    for predictor in (ft.KalmanPredictor(transition), ft.ExtendedKalmanPredictor(transition),
                      ft.UnscentedKalmanPredictor(transition)):
        prior = ft.GaussianState([0, 1, 0, 1], PRIOR_COVAR, timestamp=0.0)
        prior.state_vector[1, 0] = np.nan
        with pytest.raises(ValueError, match="prior.state_vector contains NaN"):
            predictor.predict(prior, 1.0)
    for updater in (ft.KalmanUpdater(linear), ft.ExtendedKalmanUpdater(sensor),
                    ft.UnscentedKalmanUpdater(sensor)):
        prediction = ft.GaussianStatePrediction([10, 1, 10, 1], PRIOR_COVAR, timestamp=1.0)
        prediction.state_vector[0, 0] = np.inf
        with pytest.raises(ValueError, match="hypothesis.prediction.state_vector contains NaN"):
            updater.update(ft.SingleHypothesis(prediction, ft.Detection([0.5, 14.0],
                                                                        timestamp=1.0)))
    huge = ft.GaussianStatePrediction([1e308, 0, -1e308, 0], PRIOR_COVAR, timestamp=1.0)
    with pytest.raises(ValueError, match="the update overflowed"):
        ft.KalmanUpdater(linear).update(ft.SingleHypothesis(huge, ft.Detection(
            [-1e308, 1e308], timestamp=1.0)))


# --- covariance checks where they belong, and an update that stays PSD ---------------------------

def test_singular_priors_are_accepted_and_indefinite_ones_rejected():
    transition, sensor = _models()
    # Stone Soup's MultiMeasurementInitiator starts tracks with zero velocity variance
    singular = ft.GaussianState([0, 1, 0, 1], np.diag([1.0, 0.0, 1.0, 0.0]), timestamp=0.0)
    for predictor in (ft.KalmanPredictor(transition), ft.ExtendedKalmanPredictor(transition)):
        prediction = predictor.predict(singular, 1.0)
        assert np.linalg.eigvalsh(prediction.covar).min() > 0
    zero = ft.GaussianState([0, 1, 0, 1], np.zeros((4, 4)), timestamp=0.0)
    np.testing.assert_allclose(ft.KalmanPredictor(transition).predict(zero, 1.0).covar,
                               transition.covar(1.0))
    batch = ft.BatchExtendedKalmanFilter(transition, sensor)
    means, covars = batch.step(np.array([[0, 1, 0, 1.0]]), singular.covar[None],
                               np.array([[0.0, 50.0]]), 1.0)
    assert np.isfinite(means).all()
    indefinite = ft.GaussianState([0, 1, 0, 1], np.diag([1.0, -1e-3, 1.0, 1.0]), timestamp=0.0)
    with pytest.raises(ValueError, match="prior.covar is not positive semi-definite"):
        ft.KalmanPredictor(transition).predict(indefinite, 1.0)
    # an off-diagonal entry where a variance is zero is indefinite too
    with pytest.raises(ValueError, match="prior.covar is not positive semi-definite"):
        ft.KalmanPredictor(ft.LinearGaussianTransitionModel(np.eye(2), np.eye(2))).predict(
            ft.GaussianState([0.0, 0.0], [[0.0, 1.0], [1.0, 1.0]], timestamp=0.0), 1.0)


def test_updaters_reject_an_indefinite_prediction():
    sensor = ft.LinearGaussian(2, (0, 1), np.eye(2))
    prediction = ft.GaussianStatePrediction([0.0, 0.0], [[1.0, 2.0], [2.0, 1.0]], timestamp=1.0)
    for updater in (ft.KalmanUpdater(sensor), ft.ExtendedKalmanUpdater(sensor),
                    ft.KalmanUpdater(sensor, use_joseph_cov=False)):
        with pytest.raises(ValueError, match="prediction's covariance is not positive "
                                             "semi-definite"):
            updater.update(ft.SingleHypothesis(prediction, ft.Detection([0.0, 0.0])))


def test_default_update_keeps_the_covariance_positive_at_extreme_noise_ratios():
    sensor = ft.LinearGaussian(2, (0, 1), np.eye(2) * 1e-12)
    prediction = ft.GaussianStatePrediction([0.0, 0.0], np.eye(2) * 1e12, timestamp=1.0)
    standard = ft.KalmanUpdater(sensor, use_joseph_cov=False).update(
        ft.SingleHypothesis(prediction, ft.Detection([1.0, 1.0], timestamp=1.0)))
    joseph = ft.KalmanUpdater(sensor).update(
        ft.SingleHypothesis(prediction, ft.Detection([1.0, 1.0], timestamp=1.0)))
    assert np.linalg.eigvalsh(standard.covar).min() <= 0  # the standard form loses it
    np.testing.assert_allclose(np.diag(joseph.covar), 1e-12, rtol=1e-6)
    transition = ft.LinearGaussianTransitionModel(np.eye(2), np.eye(2) * 1e-12)
    ft.KalmanPredictor(transition).predict(joseph, 2.0)  # and the next step goes on


@pytest.mark.parametrize("q, r", [(1e-12, 1e12), (1e12, 1e-12), (1e-12, 1e-12), (1e12, 1e12),
                                  (1e6, 1e-6)])
def test_ten_thousand_steps_stay_positive_semi_definite_at_any_noise_ratio(q, r):
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)
    batch = ft.BatchExtendedKalmanFilter(transition, ft.LinearGaussian(4, (0, 2), np.eye(2) * r))
    z = np.random.default_rng(7).normal(0, np.sqrt(r), (10_000, 1, 2)) \
        + np.arange(10_000)[:, None, None]
    means, covars = batch.run(np.array([[0, 1, 0, 1.0]]), np.eye(4)[None] * 1e6, z, 1.0)
    covars = covars[:, 0]
    assert np.isfinite(means).all() and np.array_equal(covars, np.swapaxes(covars, 1, 2))
    values = np.linalg.eigvalsh(covars)
    assert (values.min(axis=1) >= -1e-10 * values.max(axis=1)).all()


def test_covariance_checks_of_the_kernels_match_the_mirror():
    transition, sensor = _models()
    means, covars, measurements, intervals = _batch_inputs(8)
    covars[1] = np.diag([1.0, 0.0, 1.0, 0.0])  # singular: fine
    covars[2] = np.diag([1.0, -1e-3, 1.0, 1.0])  # indefinite
    covars[3, 0, 1] += 0.5  # not symmetric
    covars[4] = np.zeros((4, 4))  # zero: fine
    covars[5] = [[1.0, 1.0, 0, 0], [1.0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]]  # rank 3: fine
    covars[6] = [[0.0, 1e-3, 0, 0], [1e-3, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]]  # indefinite
    args = (*transition.spec(1.0).kalman(), intervals, *sensor.spec.sensor, 0, True, means, covars,
            measurements)
    got, want = np.empty(8, dtype=np.int64), np.empty(8, dtype=np.int64)
    kernels.batch_step(*args, np.empty_like(means), np.empty_like(covars), got)
    reference.kalman.batch_step(*args, np.empty_like(means), np.empty_like(covars), want)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got, [0, 0, reference.status.PRIOR_NOT_PSD,
                                        reference.status.PRIOR_NOT_SYMMETRIC, 0, 0,
                                        reference.status.PRIOR_NOT_PSD, 0])


def test_a_jacobian_method_or_covariance_assigned_later_is_checked_when_assigned():
    """'bogus' raised a KeyError at the next step, a list or a covariance of another size a
    matmul error."""
    model = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    for owner in (ft.ExtendedKalmanPredictor(model), ft.ExtendedKalmanSmoother(model)):
        with pytest.raises(ValueError, match="jacobian must be one of 'forward', 'central', "
                                             "got 'bogus'"):
            owner.jacobian = "bogus"
        assert owner.jacobian == "forward"
    updater = ft.ExtendedKalmanUpdater(ft.LinearGaussian(4, (0, 2), np.eye(2)))
    with pytest.raises(ValueError, match="jacobian must be one of 'analytic'"):
        updater.jacobian = "bogus"
    state = ft.GaussianState([0.0, 1.0, 0.0, 1.0], np.eye(4), timestamp=0.0)
    with pytest.raises(ValueError, match=r"covar must have shape \(4, 4\)"):
        state.covar = np.eye(3)
    with pytest.raises(ValueError, match="covar must be symmetric"):
        state.covar = np.triu(np.ones((4, 4)))
    state.covar = np.eye(4).tolist()  # (stored as a float64 array)
    assert type(state.covar) is np.ndarray and state.covar.dtype == np.float64
    assert ft.KalmanPredictor(model).predict(state, 1.0).covar.shape == (4, 4)


def test_a_prediction_that_overflows_is_refused_where_it_starts():
    """A prior of 1e307 over 10 s (F P F^T beyond float64) came back as an inf covariance,
    refused only at the next step: the kernels, their NumPy twin, the mirror, one filter and
    a batch name it at the prediction."""
    from fasttrack._jit import kalman as kernels
    from fasttrack._jit.status import PREDICTION_OVERFLOW
    from fasttrack.core import kalman_numpy
    import reference.kalman
    model = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    x, huge = np.array([[0.0], [1.0], [0.0], [1.0]]), np.eye(4) * 1e307
    kind, rates, matrix, noise = model.spec(10.0).kalman()
    for predict in (kernels.predict_one, reference.kalman.predict_one):
        assert predict(kind, rates, matrix, noise, 10.0, x, huge, np.empty((4, 1)),
                       np.empty((4, 4))) == PREDICTION_OVERFLOW
    assert kalman_numpy.predict(model.spec(10.0), x, huge)[0] == PREDICTION_OVERFLOW
    for predictor in (ft.KalmanPredictor(model), ft.ExtendedKalmanPredictor(model)):
        with pytest.raises(ValueError, match="the prediction overflowed"):
            predictor.predict(ft.GaussianState(x, huge, timestamp=0.0), 10.0)
        with pytest.raises(ValueError, match="the prediction overflowed"):
            predictor.predict(ft.GaussianState([1e308, 1e308, 0.0, 0.0], np.eye(4),
                                               timestamp=0.0), 1.0)
    batch = ft.BatchExtendedKalmanFilter(model, ft.LinearGaussian(4, (0, 2), np.eye(2)))
    means = np.zeros((3, 4))
    means[1] = [1e308, 1e308, 0.0, 0.0]
    with pytest.raises(ValueError, match="filter 1: the prediction overflowed"):
        batch.predict(means, np.tile(np.eye(4), (3, 1, 1)), 1.0)


@pytest.mark.parametrize("numpy_first", [False, True])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_a_prior_mean_that_is_not_finite_is_named_not_called_an_overflow(value, numpy_first,
                                                                         monkeypatch):
    """A Stone Soup prior of NaN or inf reaches the drop-in predictor unchecked: it was
    called 'the prediction overflowed'."""
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.types.state import GaussianState
    from fasttrack import _jit
    from fasttrack.stonesoup import KalmanPredictor
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: numpy_first)
    model = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.3)] * 2)
    start = datetime.datetime(2025, 1, 1)
    prior = GaussianState([[value], [0.0], [0.0], [0.0]], np.eye(4), timestamp=start)
    with pytest.raises(ValueError, match="prior.state_vector is not finite"):
        KalmanPredictor(model).predict(prior, timestamp=start + datetime.timedelta(seconds=1))
