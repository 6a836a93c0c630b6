"""Unscented Kalman filter: kernels against their NumPy mirrors, parity with Stone Soup 1.9.1's
UnscentedKalmanPredictor/Updater (bearing-range tutorial, bearings across +-pi), UKF = KF for
a linear sensor, and bad input."""
import datetime

import numpy as np
import pytest
from numba import njit

import fasttrack as ft
from fasttrack._jit import kalman as kalman_kernels
from fasttrack._jit import unscented as kernels
from fasttrack.scenarios import extended_kalman_tutorial

import reference.numeric
import reference.unscented
from user_models import bearing_range_from_50_0, coordinated_turn

START = datetime.datetime(2026, 1, 1)
SECOND = datetime.timedelta(seconds=1)
NOISE = np.diag([np.radians(0.2), 1.0])
PRIOR_COVAR = np.diag([1.5, 0.5, 1.5, 0.5])


def _stonesoup(transition_q=0.05, sensor="bearing-range", noise=NOISE, **parameters):
    """Stone Soup's models, UKF predictor and updater."""
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import UnscentedKalmanPredictor
    from stonesoup.updater.kalman import UnscentedKalmanUpdater

    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(transition_q)] * 2)
    if sensor == "bearing-range":
        model = CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=noise,
                                        translation_offset=np.array([[50], [0]]))
    else:
        model = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=noise)
    return (UnscentedKalmanPredictor(transition, **parameters),
            UnscentedKalmanUpdater(model, **parameters), model)


def _stonesoup_detection(z, timestamp, model, bearing=True):
    from stonesoup.types.angle import Bearing
    from stonesoup.types.array import StateVector
    from stonesoup.types.detection import Detection
    z = np.asarray(z, float).ravel()
    vector = StateVector([Bearing(z[0]), z[1]]) if bearing else StateVector(z)
    return Detection(vector, timestamp=timestamp, measurement_model=model)


def _run_stonesoup(predictor, updater, model, prior_mean, measurements, bearing=True):
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    state = GaussianState(np.reshape(prior_mean, (-1, 1)), PRIOR_COVAR, timestamp=START)
    states = []
    for k, z in enumerate(measurements):
        detection = _stonesoup_detection(z, START + k * SECOND, model, bearing)
        hypothesis = SingleHypothesis(predictor.predict(state, timestamp=detection.timestamp),
                                      detection)
        state = updater.update(hypothesis)
        states.append((state, hypothesis))
    return states


def _run_fasttrack(predictor, updater, prior_mean, measurements):
    state = ft.GaussianState(prior_mean, PRIOR_COVAR, timestamp=START)
    states = []
    for k, z in enumerate(measurements):
        detection = ft.Detection(z, timestamp=START + k * SECOND)
        hypothesis = ft.SingleHypothesis(predictor.predict(state, detection.timestamp), detection)
        state = updater.update(hypothesis)
        states.append((state, hypothesis))
    return states


def _relative(mine, theirs):
    theirs = np.asarray(theirs, float)
    difference = np.abs(np.asarray(mine, float) - theirs).max()
    scale = np.abs(theirs).max()
    return difference / scale if scale > 0 else difference


def _worst(ours, theirs):
    worst = 0.0
    for (a, ha), (b, hb) in zip(ours, theirs):
        ma, mb = ha.measurement_prediction, hb.measurement_prediction
        for mine, their in ((a.state_vector, b.state_vector), (a.covar, b.covar),
                            (ma.state_vector, mb.state_vector), (ma.covar, mb.covar),
                            (ma.cross_covar, mb.cross_covar)):
            worst = max(worst, _relative(mine, their))
    return worst


def _measurements(scenario):
    return [d.state_vector.reshape(-1, 1).copy() for d in scenario.detections]


# --- kernels against their mirrors ---------------------------------------------------------

def _random_covariance(rng, d):
    a = rng.normal(size=(d, d))
    return a @ a.T + 0.1 * np.eye(d)


@pytest.mark.parametrize("singular", [False, True])
def test_sigma_points_match_the_mirror(singular):
    rng = np.random.default_rng(1)
    x = rng.normal(size=(4, 1))
    covariance = np.diag([2.0, 0.0, 1.0, 0.0]) if singular else _random_covariance(rng, 4)
    outs = [(np.empty((4, 4)), np.empty((4, 9)), np.empty(9), np.empty(9)) for _ in range(2)]
    kernels.sigma_points(x, covariance, 0.5, 2.0, -1.0, *outs[0])
    reference.unscented.sigma_points(x, covariance, 0.5, 2.0, -1.0, *outs[1])
    for a, b in zip(*outs):
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-15)
    assert outs[0][2].sum() == pytest.approx(1.0)


def test_moments_match_the_mirror_with_an_angle_row():
    rng = np.random.default_rng(2)
    points = rng.normal(size=(4, 9))
    transformed = np.vstack([reference.numeric.wrap_angle(np.pi + 0.3 * rng.normal(size=9)),
                             rng.normal(10.0, 1.0, 9)])
    wm, wc = np.full(9, 0.1), np.full(9, 0.1)
    wm[0], wc[0] = 0.2, 1.95
    angles = np.array([True, False])
    outs = [(np.empty((2, 1)), np.empty((2, 2)), np.empty((4, 2))) for _ in range(2)]
    kernels.unscented_moments(points, transformed, wm, wc, angles, NOISE, *outs[0])
    reference.unscented.unscented_moments(points, transformed, wm, wc, angles, NOISE, *outs[1])
    for a, b in zip(*outs):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)
    assert abs(outs[0][0][0, 0]) > 3.0  # the circular mean, near +-pi, not near 0


@pytest.mark.parametrize("cv", [True, False])
def test_predict_kernel_matches_the_mirror(cv):
    rng = np.random.default_rng(3)
    x, covariance = rng.normal(size=(4, 1)), _random_covariance(rng, 4)
    model = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    kind, rates, matrix, noise = model.spec(1.5).kalman()
    if not cv:
        kind, matrix, noise = kalman_kernels.FIXED, model.matrix(1.5), model.covar(1.5)
    outs = [(np.empty((4, 1)), np.empty((4, 4))) for _ in range(2)]
    args = (kind, rates, matrix, noise, 1.5, 0.5, 2.0, -1.0, x, covariance)
    assert kernels.unscented_predict(*args, *outs[0]) == 0
    assert reference.unscented.unscented_predict(*args, *outs[1]) == 0
    for a, b in zip(*outs):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("joseph", [False, True])
@pytest.mark.parametrize("sensor", ["bearing-range", "bearing", "linear"])
def test_update_kernel_matches_the_mirror(sensor, joseph):
    rng = np.random.default_rng(4)
    x = np.array([[10.0], [1.0], [-0.5], [1.0]])
    covariance = _random_covariance(rng, 4)
    model = {"bearing-range": ft.CartesianToBearingRange(4, (0, 2), NOISE,
                                                         translation_offset=[50, 0]),
             "bearing": ft.Cartesian2DToBearing(4, (0, 2), NOISE[:1, :1]),
             "linear": ft.LinearGaussian(4, (0, 2), np.eye(2))}[sensor]
    m = model.ndim_meas
    z = np.array([[3.1], [40.0]])[:m] if sensor != "linear" else np.array([[9.0], [0.0]])
    outs = [(np.empty((4, 1)), np.empty((4, 4)), np.empty((m, 1)), np.empty((m, m)),
             np.empty((4, m))) for _ in range(2)]
    args = (*model.spec.sensor, 0.5, 2.0, -1.0, joseph, x, covariance, z)
    assert kernels.unscented_update(*args, *outs[0]) == 0
    assert reference.unscented.unscented_update(*args, *outs[1]) == 0
    for a, b in zip(*outs):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


# --- parity with Stone Soup ------------------------------------------------------------------

def test_ekf_tutorial_scenario_equals_stone_soup():
    """The bearing-range tutorial (the sensor at (50, 0) sees the target near bearing pi,
    so sigma-point bearings straddle the wrap), in Stone Soup's standard form: every
    posterior, predicted measurement, innovation and cross covariance equal to 1e-9."""
    pytest.importorskip("stonesoup")
    scenario = extended_kalman_tutorial()
    measurements = _measurements(scenario)
    theirs = _run_stonesoup(*_stonesoup(), [0, 1, 0, 1], measurements)
    predictor = ft.UnscentedKalmanPredictor(scenario.transition_model)
    updater = ft.UnscentedKalmanUpdater(scenario.measurement_model, use_joseph_cov=False)
    ours = _run_fasttrack(predictor, updater, [0, 1, 0, 1], measurements)
    assert _worst(ours, theirs) < 1e-9
    assert isinstance(ours[0][0], ft.GaussianStateUpdate)
    assert ours[-1][0].timestamp == START + 20 * SECOND


@pytest.mark.parametrize("parameters", [dict(alpha=1.0, beta=0.0, kappa=0.0),
                                        dict(alpha=0.1, beta=2.0, kappa=1.0),
                                        dict(alpha=1.3, beta=1.0)])
def test_other_sigma_point_parameters_equal_stone_soup(parameters):
    pytest.importorskip("stonesoup")
    scenario = extended_kalman_tutorial()
    measurements = _measurements(scenario)
    theirs = _run_stonesoup(*_stonesoup(**parameters), [0, 1, 0, 1], measurements)
    ours = _run_fasttrack(ft.UnscentedKalmanPredictor(scenario.transition_model, **parameters),
                          ft.UnscentedKalmanUpdater(scenario.measurement_model,
                                                    use_joseph_cov=False, **parameters),
                          [0, 1, 0, 1], measurements)
    assert _worst(ours, theirs) < 1e-9


def test_measurement_prediction_across_pi_equals_stone_soup():
    """A spread prediction behind the sensor: Stone Soup averages Bearing rows circularly;
    a plain average of the wrapped bearings would be near 0."""
    pytest.importorskip("stonesoup")
    from stonesoup.types.state import GaussianState
    _, updater, _ = _stonesoup()
    mean, covar = np.array([[30.0], [1.0], [0.0], [1.0]]), np.diag([4.0, 1.0, 25.0, 1.0])
    theirs = updater.predict_measurement(GaussianState(mean, covar, timestamp=START))
    sensor = ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    ours = ft.UnscentedKalmanUpdater(sensor).predict_measurement(
        ft.GaussianState(mean, covar, timestamp=START))
    for mine, their in ((ours.state_vector, theirs.state_vector), (ours.covar, theirs.covar),
                        (ours.cross_covar, theirs.cross_covar)):
        assert _relative(mine, their) < 1e-12
    assert abs(ours.state_vector[0, 0]) > 3.0
    assert isinstance(ours, ft.GaussianMeasurementPrediction)


def test_linear_sensor_equals_stone_soup_and_the_kalman_filter():
    """With a LinearGaussian sensor and a linear transition the unscented transform is exact:
    the UKF equals fasttrack's KalmanPredictor/KalmanUpdater (both covariance forms) and
    Stone Soup's UKF to 1e-9."""
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), [[0.5, 0.1], [0.1, 0.8]])
    truth = ft.ground_truth(transition, [0, 1, 0, 1], 30, start_time=START, rng=5)
    measurements = [d.state_vector.reshape(-1, 1).copy()
                    for d in ft.detections(truth, sensor, rng=6)]
    kf = _run_fasttrack(ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor),
                        [0, 1, 0, 1], measurements)
    for joseph in (False, True):
        ukf = _run_fasttrack(ft.UnscentedKalmanPredictor(transition),
                             ft.UnscentedKalmanUpdater(sensor, use_joseph_cov=joseph),
                             [0, 1, 0, 1], measurements)
        assert _worst(ukf, kf) < 1e-9
    pytest.importorskip("stonesoup")
    theirs = _run_stonesoup(*_stonesoup(0.1, "linear", np.array([[0.5, 0.1], [0.1, 0.8]])),
                            [0, 1, 0, 1], measurements, bearing=False)
    assert _worst(ukf, theirs) < 1e-9


# --- close passes: the default update keeps the covariance positive semi-definite ---------

PASS_NOISE = np.diag([np.radians(1.0) ** 2, 4.0])  # 1 degree, 2 m


def _close_passes(n, steps=40):
    """n targets at 10 m/s passing 1 m from a bearing-range sensor at the origin: the
    transition, the sensor, the prior and each pass's (steps, 2) measurements."""
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1.0)] * 2)
    sensor = ft.CartesianToBearingRange(4, (0, 2), PASS_NOISE)
    start = np.array([-200.0, 10.0, 1.0, 0.0])
    z = np.empty((steps, n, 2))
    for i in range(n):
        rng = np.random.default_rng([1, i])
        truth = ft.ground_truth(transition, start, steps, rng=rng)
        z[:, i] = [d.state_vector[:, 0] for d in ft.detections(truth, sensor, rng=rng)]
    return transition, sensor, ft.GaussianState(start, np.diag([4.0, 1, 4, 1]), 0.0), z


def _filter(predictor, updater, prior, z):
    """The posteriors of one pass; raises where a step is undefined."""
    state, states = prior, []
    for t, measurement in enumerate(z, start=1):
        detection = ft.Detection(measurement, timestamp=float(t))
        state = updater.update(ft.SingleHypothesis(predictor.predict(state, t), detection))
        states.append(state)
    return states


def _positive_semi_definite(covar):
    values = np.linalg.eigvalsh(covar)
    return values.min() >= -1e-9 * values.max()


@pytest.mark.parametrize("kind", ["extended", "unscented"])
def test_close_passes_complete_with_every_default_gaussian_filter(kind):
    """100 passes 1 m from the sensor: one filter at a time and as a batch, every update is
    positive semi-definite and the batch agrees with the single filters."""
    transition, sensor, prior, z = _close_passes(100)
    if kind == "extended":
        step = ft.ExtendedKalmanPredictor(transition), ft.ExtendedKalmanUpdater(sensor)
        batch = ft.BatchExtendedKalmanFilter(transition, sensor)
    else:
        step = ft.UnscentedKalmanPredictor(transition), ft.UnscentedKalmanUpdater(sensor)
        batch = ft.BatchUnscentedKalmanFilter(transition, sensor)
    k = z.shape[1]
    means, covars = batch.run(np.tile(prior.state_vector[:, 0], (k, 1)),
                              np.tile(prior.covar, (k, 1, 1)), z, np.ones((z.shape[0], k)))
    for i in range(k):
        states = _filter(*step, prior, z[:, i])
        assert all(_positive_semi_definite(state.covar) for state in states)
        np.testing.assert_allclose(covars[:, i], [state.covar for state in states],
                                   rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(means[:, i], [state.state_vector[:, 0] for state in states],
                                   rtol=1e-8, atol=1e-8)


def test_the_standard_form_raises_at_the_update_where_stone_soup_loses_psd():
    """Pass 88 of the close passes: Stone Soup's UKF (standard form) leaves a covariance
    with a negative eigenvalue there and goes on silently, as its drop-in does; fasttrack's
    standard form equals it until then and raises at that update, the single filter and the
    batch."""
    pytest.importorskip("stonesoup")
    from stonesoup.predictor.kalman import UnscentedKalmanPredictor
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import UnscentedKalmanUpdater
    transition, sensor, prior, z = _close_passes(89)
    z = z[:, 88]
    _, _, their_sensor = _stonesoup(1.0, noise=PASS_NOISE)
    their_sensor.translation_offset = np.zeros((2, 1))
    predictor, updater = UnscentedKalmanPredictor(_stonesoup(1.0)[0].transition_model), \
        UnscentedKalmanUpdater(their_sensor)
    from fasttrack.stonesoup import UnscentedKalmanUpdater as DropIn

    def covariances(updater):
        state, out = GaussianState(prior.state_vector, prior.covar, timestamp=START), []
        for t, measurement in enumerate(z, start=1):
            detection = _stonesoup_detection(measurement, START + t * SECOND, their_sensor)
            state = updater.update(SingleHypothesis(
                predictor.predict(state, timestamp=detection.timestamp), detection))
            out.append(np.asarray(state.covar, float))
        return out

    theirs = covariances(updater)
    lost = next(t for t, covar in enumerate(theirs) if not _positive_semi_definite(covar))
    dropin = covariances(DropIn(their_sensor))  # Stone Soup's numbers, the indefinite one too
    for mine, their in zip(dropin[:lost + 1], theirs):
        assert _relative(mine, their) < 1e-9
    standard = (ft.UnscentedKalmanPredictor(transition),
                ft.UnscentedKalmanUpdater(sensor, use_joseph_cov=False))
    ours = _filter(*standard, prior, z[:lost])
    for mine, their in zip(ours, theirs):
        assert _relative(mine.covar, their) < 1e-9
    with pytest.raises(ValueError, match="the update by hypothesis.measurement left a "
                                         "covariance that is not positive semi-definite"):
        _filter(*standard, prior, z[:lost + 1])
    batch = ft.BatchUnscentedKalmanFilter(transition, sensor, use_joseph_cov=False)
    with pytest.raises(ValueError, match=f"filter 0 at step {lost}: the update by"):
        batch.run(prior.state_vector.T, prior.covar[None], z[:, None], np.ones((z.shape[0], 1)))


@pytest.mark.parametrize("spread", [0.0, 1.0])
def test_an_update_whose_mean_lies_at_the_sensor_is_refused_as_stone_soup_computes_it(spread):
    """The transform's central point has no bearing there: the native update, one filter
    or a batch, in NumPy or in the kernels, refuses it by name; the drop-in and the
    kernels' mirror give Stone Soup's numbers (its bearing atan2(0, 0) = 0)."""
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.prediction import GaussianStatePrediction
    from stonesoup.updater.kalman import UnscentedKalmanUpdater

    import fasttrack.stonesoup as dropin
    from fasttrack.core import kalman_numpy
    x, covar = np.array([[50.0], [1.0], [0.0], [-1.0]]), np.eye(4) * spread
    z = np.array([[0.3], [2.0]])
    message = "the prediction's mean lies at the polar sensor"
    native = ft.UnscentedKalmanUpdater(_sensor())
    prediction = ft.GaussianStatePrediction(x, covar, timestamp=START)
    with pytest.raises(ValueError, match=message):
        native.update(ft.SingleHypothesis(prediction, ft.Detection(z, timestamp=START)))
    with pytest.raises(ValueError, match=r"filter 1: means\[1\] lies at the polar sensor"):
        _batch().update(np.array([[0.0, 1.0, 2.0, 0.0], x[:, 0]]),
                        np.array([np.eye(4), covar]), np.array([[0.1, 50.0], z[:, 0]]))
    spec = _sensor().spec
    assert kalman_numpy.unscented_update(spec, 0.5, 2.0, -1.0, True, x, covar, z)[0] == 11
    outs = [(np.empty((4, 1)), np.empty((4, 4)), np.empty((2, 1)), np.empty((2, 2)),
             np.empty((4, 2))) for _ in range(2)]
    args = (*spec.sensor, 0.5, 2.0, -1.0, False, x, covar, z)
    assert kernels.unscented_update(*args, *outs[0]) == 11
    assert reference.unscented.unscented_update(*args, *outs[1]) == 11
    model = CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=np.array([[50], [0]]))
    hypothesis = SingleHypothesis(GaussianStatePrediction(x, covar, timestamp=START),
                                  Detection(z, timestamp=START, measurement_model=model))
    want = UnscentedKalmanUpdater(model).update(hypothesis)
    got = dropin.UnscentedKalmanUpdater(model).update(hypothesis)
    for a, b, c in zip(outs[0][:2], outs[1][:2], (want.state_vector, want.covar)):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(a, np.asarray(c, float), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.asarray(got.state_vector, float),
                               np.asarray(want.state_vector, float), rtol=1e-12)
    np.testing.assert_allclose(got.covar, want.covar, rtol=1e-12, atol=1e-12)


def test_the_default_form_is_the_standard_one_less_the_unexplained_spread():
    """One update near the sensor: the Joseph form with the statistical linearisation
    H = C^T P^-1 equals P - K S K^T - K (P_zz - H P H^T) K^T, P_zz = S - R."""
    prediction = ft.GaussianStatePrediction([-3.0, 10.0, 1.0, 0.0], np.diag([4.0, 1, 4, 1]),
                                            timestamp=1.0)
    sensor = ft.CartesianToBearingRange(4, (0, 2), PASS_NOISE)
    detection = ft.Detection([2.8, 3.2], timestamp=1.0)
    standard = ft.UnscentedKalmanUpdater(sensor, use_joseph_cov=False).update(
        ft.SingleHypothesis(prediction, detection))
    default = ft.UnscentedKalmanUpdater(sensor).update(
        ft.SingleHypothesis(prediction, detection))
    s, cross = standard.hypothesis.measurement_prediction.covar, \
        standard.hypothesis.measurement_prediction.cross_covar
    gain = cross @ np.linalg.inv(s)
    unexplained = s - PASS_NOISE - cross.T @ np.linalg.solve(prediction.covar, cross)
    np.testing.assert_allclose(default.covar, standard.covar - gain @ unexplained @ gain.T,
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(default.state_vector, standard.state_vector, rtol=1e-14)
    assert np.abs(default.covar - standard.covar).max() > 1e-3  # a nonlinear sensor


def test_predictions_equal_stone_soup_and_keep_their_links():
    pytest.importorskip("stonesoup")
    from stonesoup.types.state import GaussianState
    predictor, _, _ = _stonesoup()
    mean = np.array([[1.0], [2.0], [-3.0], [0.5]])
    theirs = predictor.predict(GaussianState(mean, PRIOR_COVAR, timestamp=START),
                               timestamp=START + 2.5 * SECOND)
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    prior = ft.GaussianState(mean, PRIOR_COVAR, timestamp=START)
    ours = ft.UnscentedKalmanPredictor(transition).predict(prior, START + 2.5 * SECOND)
    assert _relative(ours.state_vector, theirs.state_vector) < 1e-12
    assert _relative(ours.covar, theirs.covar) < 1e-12
    assert isinstance(ours, ft.GaussianStatePrediction) and ours.prior is prior
    assert ours.transition_model is transition
    np.testing.assert_array_equal(ours.covar, ours.covar.T)


# --- bad input ---------------------------------------------------------------------------------

def _transition():
    return ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)


def _sensor():
    return ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])


@pytest.mark.parametrize("cls, model", [(ft.UnscentedKalmanPredictor, _transition),
                                        (ft.UnscentedKalmanUpdater, _sensor)])
@pytest.mark.parametrize("kwargs, error, name", [
    (dict(alpha=0.0), ValueError, "alpha"), (dict(alpha=-0.5), ValueError, "alpha"),
    (dict(alpha=np.nan), ValueError, "alpha"), (dict(alpha="0.5"), TypeError, "alpha"),
    (dict(alpha=True), TypeError, "alpha"), (dict(beta=np.inf), ValueError, "beta"),
    (dict(beta=None), TypeError, "beta"), (dict(kappa=np.nan), ValueError, "kappa"),
    (dict(kappa=[1.0]), TypeError, "kappa")])
def test_bad_parameters_name_the_argument(cls, model, kwargs, error, name):
    with pytest.raises(error, match=name):
        cls(model(), **kwargs)


def test_a_kappa_without_sigma_point_spread_is_refused():
    """alpha**2 (d + kappa) must be > 0: checked when the state dimension is known (at
    construction, or for an updater without a model at the first use of one)."""
    prior = ft.GaussianState([0, 1, 0, 1], PRIOR_COVAR, timestamp=0.0)
    with pytest.raises(ValueError, match="kappa"):
        ft.UnscentedKalmanPredictor(_transition(), kappa=-4.0)
    with pytest.raises(ValueError, match="kappa"):
        ft.UnscentedKalmanUpdater(_sensor(), kappa=-5.0)
    with pytest.raises(ValueError, match="kappa"):
        ft.UnscentedKalmanUpdater(kappa=-4.0).predict_measurement(prior, _sensor())
    for alpha in (1e200, 1e-9):  # a spread whose inverse weights lose every digit or overflow
        with pytest.raises(ValueError, match=r"alpha\*\*2 \* \(ndim \+ kappa\) must lie in "
                                             r"\[1e-12, 1e\+100\]"):
            ft.UnscentedKalmanPredictor(_transition(), alpha=alpha)
    with pytest.raises(ValueError, match="kappa must lie within the float range"):
        ft.UnscentedKalmanPredictor(_transition(), kappa=10**400)



def test_sigma_point_parameters_changed_later_are_checked_and_honoured():
    """A kappa assigned after construction was ignored (the resolved one was kept) and an
    alpha of 'x' accepted: both are settings now, for the predictor, updater, batch filter
    and smoother."""
    turn = ft.ConstantTurn([0.1, 0.1], 0.01)
    prior = ft.GaussianState([0.0, 1.0, 0.0, 1.0, 0.3], np.eye(5), timestamp=0.0)
    predictor = ft.UnscentedKalmanPredictor(turn)
    before = predictor.predict(prior, 1.0).covar
    predictor.kappa = 2.0
    after = predictor.predict(prior, 1.0).covar
    np.testing.assert_allclose(after, ft.UnscentedKalmanPredictor(turn, kappa=2.0).predict(
        prior, 1.0).covar, rtol=1e-12)
    assert not np.allclose(before, after)
    for owner in (predictor, ft.UnscentedKalmanUpdater(_sensor()), _batch(),
                  ft.UnscentedKalmanSmoother(_transition())):
        with pytest.raises(TypeError, match="alpha must be a real number, got str"):
            owner.alpha = "x"
        with pytest.raises(ValueError, match="beta must be finite"):
            owner.beta = np.inf
        assert owner.alpha == 0.5 and owner.beta == 2.0
    predictor.alpha = 1e-9  # (its spread is checked where it is next needed)
    with pytest.raises(ValueError, match=r"alpha\*\*2 \* \(ndim \+ kappa\) must lie in"):
        predictor.predict(prior, 1.0)


def test_bad_states_models_and_measurements_are_refused():
    bad = np.diag([1.0, -1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="prior.covar is not positive semi-definite"):
        ft.UnscentedKalmanPredictor(_transition()).predict(
            ft.GaussianState([0, 1, 0, 1], bad, timestamp=0.0), 1.0)
    updater = ft.UnscentedKalmanUpdater(_sensor())
    with pytest.raises(ValueError, match="prediction's covariance"):
        updater.predict_measurement(ft.GaussianState([0, 1, 0, 1], bad, timestamp=0.0))
    prediction = ft.GaussianState([0, 1, 0, 1], PRIOR_COVAR, timestamp=1.0)
    sensor = _sensor()  # a NaN detection is refused by Detection; the kernel checks too
    outs = (np.empty((4, 1)), np.empty((4, 4)), np.empty((2, 1)), np.empty((2, 2)),
            np.empty((4, 2)))
    assert kernels.unscented_update(*sensor.spec.sensor, 0.5, 2.0, -1.0, False,
                                    prediction.state_vector, prediction.covar,
                                    np.array([[np.nan], [40.0]]), *outs) == 4
    with pytest.raises(TypeError, match="transition_model"):
        ft.UnscentedKalmanPredictor("not a model")
    with pytest.raises(TypeError, match="prior must be a GaussianState"):
        ft.UnscentedKalmanPredictor(_transition()).predict("x", 1.0)
    with pytest.raises(ValueError, match="timestamp"):
        ft.UnscentedKalmanPredictor(_transition()).predict(prediction, None)
    with pytest.raises(ValueError, match="no measurement model"):
        ft.UnscentedKalmanUpdater().update(
            ft.SingleHypothesis(prediction, ft.Detection([[0.1], [40.0]], timestamp=1.0)))
    with pytest.raises(ValueError, match="state dimensions"):
        updater.predict_measurement(ft.GaussianState([0, 1], np.eye(2), timestamp=1.0))


def test_a_mean_its_sigma_points_cannot_resolve_is_refused():
    """At 1e100 with unit variances the sigma points round to the mean and the moments are
    rounding errors (a covariance of 5e169 or -inf came back): refused by the kernels, the
    NumPy twins, the classes and the batch filter; 1e11 still resolves."""
    from fasttrack.core import kalman_numpy
    from fasttrack._jit.status import PREDICTION_UNRESOLVED, PRIOR_UNRESOLVED
    model, sensor = _transition(), _sensor()
    kind, rates, matrix, noise = model.spec(1.0).kalman()
    far = np.array([[1e100], [1.0], [0.0], [1.0]])
    outs = (np.empty((4, 1)), np.empty((4, 4)))
    for predict in (kernels.unscented_predict, reference.unscented.unscented_predict):
        assert predict(kind, rates, matrix, noise, 1.0, 0.5, 2.0, -1.0, far, np.eye(4),
                       *outs) == PRIOR_UNRESOLVED
    assert kalman_numpy.unscented_predict(model.spec(1.0), 0.5, 2.0, -1.0, far,
                                          np.eye(4))[0] == PRIOR_UNRESOLVED
    z = np.array([[0.1], [40.0]])
    outs = (np.empty((4, 1)), np.empty((4, 4)), np.empty((2, 1)), np.empty((2, 2)),
            np.empty((4, 2)))
    for update in (kernels.unscented_update, reference.unscented.unscented_update):
        assert update(*sensor.spec.sensor, 0.5, 2.0, -1.0, False, far, np.eye(4), z,
                      *outs) == PREDICTION_UNRESOLVED
    assert kalman_numpy.unscented_update(sensor.spec, 0.5, 2.0, -1.0, False, far,
                                         np.eye(4), z)[0] == PREDICTION_UNRESOLVED
    prior = ft.GaussianState(far, np.eye(4), timestamp=0.0)
    with pytest.raises(ValueError, match=r"prior.state_vector has a component more than "
                                         r"1e\+12 times its standard deviation"):
        ft.UnscentedKalmanPredictor(model).predict(prior, 1.0)
    with pytest.raises(ValueError, match="the prediction's mean has a component more than"):
        ft.UnscentedKalmanUpdater(sensor).update(ft.SingleHypothesis(
            prior, ft.Detection([0.1, 40.0], timestamp=0.0)))
    means, covars, z = _batch_inputs(300, np.random.default_rng(13))
    means[201, 0] = 1e100
    with pytest.raises(ValueError, match=r"filter 201: means\[201\] has a component more"):
        _batch().step(means, covars, z, 1.0)
    for negligible in (0.0, 1e-300):  # a state known exactly: its transform is f(x)
        exact = ft.GaussianState([0.0, 1.0, 12.0, 3.0], np.eye(4) * negligible, timestamp=0.0)
        np.testing.assert_allclose(ft.UnscentedKalmanPredictor(model).predict(
            exact, 1.0).state_vector[:, 0], [1.0, 1.0, 15.0, 3.0], rtol=1e-12)
    assert np.isfinite(_batch().step(np.array([[0.0, 1.0, 12.0, 3.0]] * 2),
                                     np.zeros((2, 4, 4)), np.array([[0.1, 40.0]] * 2),
                                     0.0)[0]).all()
    known = ft.GaussianState([1e11, 1.0, 5.0, 1.0], np.diag([1.0, 1.0, 0.0, 1.0]),
                             timestamp=0.0)  # (a component without variance has no spread)
    predicted = ft.UnscentedKalmanPredictor(model).predict(known, 1.0)
    np.testing.assert_allclose(predicted.covar, ft.KalmanPredictor(model).predict(
        known, 1.0).covar, rtol=1e-4, atol=1e-4)


def test_a_prediction_that_overflows_is_refused_where_it_starts():
    """Sigma points moved by F = 1e200 I have moments beyond float64 (an inf covariance came
    back, refused only at the next step): the kernels, the NumPy twin, the mirror, the
    predictor with a matrix or a user function, and the batch filter name it at the
    prediction."""
    from fasttrack.core import kalman_numpy
    from fasttrack._jit.status import PREDICTION_OVERFLOW

    @njit(cache=False)
    def huge(states, dt):
        return states * 1e200

    model = ft.LinearGaussianTransitionModel(np.eye(4) * 1e200, np.eye(4))
    x, covar = np.array([[0.0], [1.0], [0.0], [1.0]]), np.eye(4)
    outs = (np.empty((4, 1)), np.empty((4, 4)))
    for predict in (kernels.unscented_predict, reference.unscented.unscented_predict):
        assert predict(*model.spec(1.0).kalman(), 1.0, 0.5, 2.0, -1.0, x, covar,
                       *outs) == PREDICTION_OVERFLOW
    for predict in (kernels.unscented_predict_function,
                    reference.unscented.unscented_predict_function):
        assert predict(huge, 1.0, np.eye(4), 0.5, 2.0, -1.0, x, covar, *outs,
                       np.empty((0, 4))) == PREDICTION_OVERFLOW
    assert kalman_numpy.unscented_predict(model.spec(1.0), 0.5, 2.0, -1.0, x,
                                          covar)[0] == PREDICTION_OVERFLOW
    prior = ft.GaussianState(x, covar, timestamp=0.0)
    for transition in (model, ft.NonlinearGaussianTransitionModel(huge, np.eye(4), 4)):
        with pytest.raises(ValueError, match="the prediction overflowed"):
            ft.UnscentedKalmanPredictor(transition).predict(prior, 1.0)
    means, covars, z = _batch_inputs(300, np.random.default_rng(14))
    intervals = np.ones(300)
    intervals[201] = 1e300
    with pytest.raises(ValueError, match="filter 201: the prediction overflowed"):
        _batch().step(means, covars, z, intervals)


def test_exported():
    assert {"UnscentedKalmanPredictor", "UnscentedKalmanUpdater",
            "BatchUnscentedKalmanFilter"} <= set(ft.__all__)


# --- user models ---------------------------------------------------------------------------

def _user_models(q=0.05):
    """fasttrack's models from the user functions of tests/user_models.py and the Stone Soup
    models they equal: a turn at 0.05 rad/s (Stone Soup's KnownTurnRate, whose Q the user
    model takes) and bearing-range from (50, 0)."""
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.linear import KnownTurnRate
    turn = KnownTurnRate(turn_noise_diff_coeffs=[q, q], turn_rate=0.05)
    theirs = (turn, CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=NOISE,
                                            translation_offset=np.array([[50], [0]])))
    ours = (ft.NonlinearGaussianTransitionModel(
                coordinated_turn, lambda dt: turn.covar(time_interval=SECOND * dt), 4),
            ft.NonlinearGaussianMeasurement(bearing_range_from_50_0, 4, NOISE,
                                            angle_components=(0,)))
    return ours, theirs


def test_user_function_models_equal_stone_soup():
    """Sigma points through the user's own functions (a turning target, bearing-range):
    every posterior and measurement prediction equal to Stone Soup's UKF with its models."""
    pytest.importorskip("stonesoup")
    from stonesoup.predictor.kalman import UnscentedKalmanPredictor
    from stonesoup.updater.kalman import UnscentedKalmanUpdater
    (transition, sensor), (turn, their_sensor) = _user_models()
    measurements = _measurements(extended_kalman_tutorial())
    theirs = _run_stonesoup(UnscentedKalmanPredictor(turn), UnscentedKalmanUpdater(their_sensor),
                            their_sensor, [0, 1, 0, 1], measurements)
    ours = _run_fasttrack(ft.UnscentedKalmanPredictor(transition),
                          ft.UnscentedKalmanUpdater(sensor, use_joseph_cov=False),
                          [0, 1, 0, 1], measurements)
    assert _worst(ours, theirs) < 1e-9


def test_user_function_kernels_match_their_mirrors():
    rng = np.random.default_rng(11)
    x = np.array([[30.0], [1.0], [-5.0], [0.5]])
    covariance = _random_covariance(rng, 4)
    q = _random_covariance(rng, 4) * 0.1
    for rows in (0, 4):
        outs = [(np.empty((4, 1)), np.empty((4, 4)), np.empty((rows, 4))) for _ in range(2)]
        args = (coordinated_turn, 2.0, q, 0.5, 2.0, -1.0, x, covariance)
        assert kernels.unscented_predict_function(*args, *outs[0]) == 0
        assert reference.unscented.unscented_predict_function(*args, *outs[1]) == 0
        for a, b in zip(*outs):
            np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)
    for joseph in (False, True):
        outs = [(np.empty((4, 1)), np.empty((4, 4)), np.empty((2, 1)), np.empty((2, 2)),
                 np.empty((4, 2))) for _ in range(2)]
        args = (bearing_range_from_50_0, NOISE, np.array([True, False]), 0.5, 2.0, -1.0,
                joseph, x, covariance, np.array([[3.1], [25.0]]))
        assert kernels.unscented_update_function(*args, *outs[0]) == 0
        assert reference.unscented.unscented_update_function(*args, *outs[1]) == 0
        for a, b in zip(*outs):
            np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


def test_bad_user_function_outputs_name_the_function():
    @njit(cache=False)
    def blows_up(states, dt):  # finite at the construction probe, infinite far away
        out = states.copy()
        out[0] = np.where(np.abs(states[0]) > 100.0, np.inf, states[0])
        return out

    @njit(cache=False)
    def right_at_probe(states):  # 2 rows for the probe's 3 states, 1 for 9 sigma points
        return np.zeros((2 if states.shape[1] == 3 else 1, states.shape[1]))

    far = ft.GaussianState([500.0, 1.0, 0.0, 1.0], PRIOR_COVAR, timestamp=0.0)
    transition = ft.NonlinearGaussianTransitionModel(blows_up, np.eye(4) * 0.01, 4)
    with pytest.raises(ValueError, match="transition function 'blows_up' returned NaN or "
                                         r"infinite values for states of shape \(4, 9\)"):
        ft.UnscentedKalmanPredictor(transition).predict(far, 1.0)
    sensor = ft.NonlinearGaussianMeasurement(right_at_probe, 4, NOISE)
    with pytest.raises(ValueError, match=r"'right_at_probe' returned an array of shape \(1, 9\) "
                                         r"for states of shape \(4, 9\); expected \(2, 9\)"):
        ft.UnscentedKalmanUpdater(sensor).predict_measurement(far)


# --- many filters at once ----------------------------------------------------------------------

def _batch_inputs(k, rng):
    means = rng.normal(size=(k, 4)) * [20.0, 1.0, 20.0, 1.0]
    covars = np.array([_random_covariance(rng, 4) for _ in range(k)])
    bearing = np.arctan2(means[:, 2], means[:, 0] - 50.0)
    ranges = np.hypot(means[:, 0] - 50.0, means[:, 2])
    z = np.stack([wrap(bearing + 0.01), ranges + 0.5], axis=1)
    return means, covars, z


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize("stages", [kernels.PREDICT | kernels.UPDATE,
                                    kernels.PREDICT | kernels.MEASURE, kernels.UPDATE])
@pytest.mark.parametrize("sensor", ["bearing-range", "linear"])
def test_batch_kernel_matches_the_mirror(stages, sensor):
    """300 filters (three blocks, the last partial), a CV transition with an interval per
    filter, two bad covariances: outputs of the good filters and every status equal."""
    rng = np.random.default_rng(5)
    k = 300
    means, covars, z = _batch_inputs(k, rng)
    covars[17, 0, 1] += 1.0  # not symmetric
    covars[250] = np.diag([1.0, -1.0, 1.0, 1.0])  # indefinite
    model = _sensor() if sensor == "bearing-range" else ft.LinearGaussian(4, (0, 2), NOISE)
    spec = _transition().spec(1.0).kalman()
    dts = rng.uniform(0.5, 2.0, k)
    outs = [(np.empty((k, 4)), np.empty((k, 4, 4)), np.empty((k, 2)), np.empty((k, 2, 2)),
             np.zeros(k, np.int64)) for _ in range(2)]
    args = (*spec, dts, *model.spec.sensor, 0.5, 2.0, -1.0, False, stages, means, covars, z)
    kernels.batch_unscented(*args, *outs[0])
    reference.unscented.batch_unscented(*args, *outs[1])
    np.testing.assert_array_equal(outs[0][4], outs[1][4])
    good = outs[1][4] == 0
    assert good.sum() == k - 2
    written = (0, 1, 2, 3) if stages & kernels.MEASURE else (0, 1)
    for i in written:
        np.testing.assert_allclose(outs[0][i][good], outs[1][i][good], rtol=1e-9, atol=1e-10)


def _batch(**kwargs):
    return ft.BatchUnscentedKalmanFilter(_transition(), _sensor(), **kwargs)


@pytest.mark.parametrize("kwargs", [{}, dict(alpha=1.0, beta=0.0, kappa=0.0),
                                    dict(use_joseph_cov=False)])
def test_batch_filter_equals_one_filter_at_a_time(kwargs):
    """``run`` over 12 steps of 200 filters with per-filter intervals equals each filter
    through UnscentedKalmanPredictor/Updater; ``predict`` gives their measurement
    predictions and ``update`` their posteriors."""
    rng = np.random.default_rng(8)
    k, steps = 200, 12
    means, covars, _ = _batch_inputs(k, rng)
    intervals = rng.uniform(0.5, 1.5, (steps, k))
    truth = means[None] + np.cumsum(intervals, 0)[..., None] * means[None, :, [1, 1, 3, 3]] \
        * [1, 0, 1, 0]
    z = np.stack([wrap(np.arctan2(truth[..., 2], truth[..., 0] - 50.0) + 0.01),
                  np.hypot(truth[..., 0] - 50.0, truth[..., 2]) + 0.3], axis=-1)
    batch = _batch(**kwargs)
    run_means, run_covars = batch.run(means, covars, z, intervals)
    joseph = kwargs.get("use_joseph_cov", True)
    sigma = {key: value for key, value in kwargs.items() if key != "use_joseph_cov"}
    predictor = ft.UnscentedKalmanPredictor(_transition(), **sigma)
    updater = ft.UnscentedKalmanUpdater(_sensor(), use_joseph_cov=joseph, **sigma)
    for f in (0, 77, 199):
        state = ft.GaussianState(means[f], covars[f], timestamp=0.0)
        for t in range(steps):
            prediction = predictor.predict(state, state.timestamp + intervals[t, f])
            detection = ft.Detection(z[t, f], timestamp=prediction.timestamp)
            state = updater.update(ft.SingleHypothesis(prediction, detection))
            np.testing.assert_allclose(run_means[t, f], state.state_vector[:, 0],
                                       rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(run_covars[t, f], state.covar, rtol=1e-10, atol=1e-12)
    predicted = batch.predict(means, covars, intervals[0])
    posterior = batch.update(predicted[0], predicted[1], z[0])
    np.testing.assert_allclose(posterior[0], run_means[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(posterior[1], run_covars[0], rtol=1e-12, atol=1e-12)
    prior = ft.GaussianState(means[5], covars[5], timestamp=0.0)
    one = updater.predict_measurement(predictor.predict(prior, intervals[0, 5]))
    np.testing.assert_allclose(predicted[2][5], one.state_vector[:, 0], rtol=1e-12)
    np.testing.assert_allclose(predicted[3][5], one.covar, rtol=1e-12)


def test_batch_filter_names_the_failing_filter_and_bad_arguments():
    rng = np.random.default_rng(9)
    means, covars, z = _batch_inputs(50, rng)
    covars[31] = -np.eye(4)
    batch = _batch()
    with pytest.raises(ValueError, match=r"1 of 50 filters failed; filter 31: covars\[31\] is not positive"):
        batch.step(means, covars, z, 1.0)
    with pytest.raises(ValueError, match="filter 31 at step 0"):
        batch.run(means, covars, z[None], 1.0)
    with pytest.raises(ValueError, match=r"filter 31: covars\[31\] is not"):
        batch.update(means, covars, z)
    with pytest.raises(ValueError, match=r"means must have shape \(K, 4\)"):
        batch.step(means[:, :3], covars, z, 1.0)
    with pytest.raises(ValueError, match="measurements must have shape"):
        batch.step(means, covars, z[:, :1], 1.0)
    with pytest.raises(ValueError, match="time_intervals"):
        batch.predict(means, covars, np.ones(7))
    with pytest.raises(TypeError, match="measurement_model"):
        ft.BatchUnscentedKalmanFilter(_transition(), ft.NonlinearGaussianMeasurement(
            bearing_range_from_50_0, 4, NOISE))
    with pytest.raises(ValueError, match="alpha"):
        _batch(alpha=0.0)
    with pytest.raises(ValueError, match="kappa"):
        _batch(kappa=-4.0)
    empty = batch.step(np.empty((0, 4)), np.empty((0, 4, 4)), np.empty((0, 2)), 1.0)
    assert empty[0].shape == (0, 4) and empty[1].shape == (0, 4, 4)


def test_long_loops_run_in_flat_memory():
    """A filter loop keeping only the latest posterior, and repeated batch steps: traced
    memory does not grow with the number of steps."""
    import tracemalloc
    predictor, updater = ft.UnscentedKalmanPredictor(_transition()), ft.UnscentedKalmanUpdater(
        _sensor())
    batch = _batch()
    means, covars, z = _batch_inputs(2000, np.random.default_rng(12))
    state = ft.GaussianState([0.0, 1.0, 0.0, 1.0], PRIOR_COVAR, timestamp=0.0)

    def steps(state, first, last):
        for t in range(first, last):
            prediction = predictor.predict(state, float(t))
            state = updater.update(ft.SingleHypothesis(
                prediction, ft.Detection([[3.1], [49.0 - 0.01 * t]], timestamp=float(t))))
            batch.step(means, covars, z, 1.0)
        return state

    state = steps(state, 1, 20)
    tracemalloc.start()
    state = steps(state, 20, 60)
    early = tracemalloc.get_traced_memory()[0]
    state = steps(state, 60, 300)
    late = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    assert late - early < 100_000  # bytes
