"""Bad input to the simulation, scenario, allocator, kernel and resampler faces: each error
names the argument (TypeError for a type, ValueError for a value), and legal edge cases
work."""
import datetime

import numpy as np
import pytest

import fasttrack as ft
from fasttrack.scenarios import grid_targets
from fasttrack.simulate import detections, ground_truth, multi_target

TRANSITION = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
SENSOR = ft.LinearGaussian(4, (0, 2), np.eye(2))
REGION = [[0.0, 0.0], [100.0, 100.0]]


@pytest.mark.parametrize("arguments, error, match", [
    (dict(n_targets=0), ValueError, "n_targets must be >= 1"),
    (dict(n_targets=2.5), TypeError, "n_targets must be an int"),
    (dict(n_targets=True), TypeError, "n_targets must be an int"),
    (dict(clutter_rate=np.inf), ValueError, "clutter_rate must be finite"),
    (dict(clutter_rate=1e30), ValueError, "clutter_rate must be at most 1e\\+07"),
    (dict(clutter_rate="20"), TypeError, "clutter_rate must be a real number"),
    (dict(spacing=-1.0), ValueError, "spacing must be finite and >= 0"),
    (dict(spacing=np.nan), ValueError, "spacing must be finite"),
    (dict(prob_detect="0.9"), TypeError, "prob_detect must be a real number"),
    (dict(prob_detect=1.5), ValueError, r"prob_detect must lie in \[0, 1\]"),
    (dict(seed=-1), ValueError, "seed must be a non-negative seed"),
    (dict(seed=1.5), TypeError, "seed must be None, an int seed"),
])
def test_grid_targets_names_a_bad_argument(arguments, error, match):
    with pytest.raises(error, match=match):
        grid_targets(**{"n_targets": 4, "steps": 3, **arguments})


@pytest.mark.parametrize("arguments, error, match", [
    (dict(birth_rate=1.0, birth_mean=np.zeros(4), birth_covar=np.diag([1.0, -1, 1, 1])),
     ValueError, "birth_covar is not positive semi-definite"),
    (dict(birth_rate=1.0, birth_mean=np.zeros(4), birth_covar=np.eye(4) + np.eye(4, k=1)),
     ValueError, "birth_covar must be symmetric"),
    (dict(birth_rate=1.0, birth_mean=np.zeros(4), birth_covar=np.eye(3)), ValueError,
     r"birth_covar must have shape \(4, 4\)"),
    (dict(birth_rate=1.0, birth_mean=np.zeros(4), birth_covar=np.full((4, 4), np.nan)),
     ValueError, "birth_covar contains NaN"),
    (dict(birth_rate=1.0, birth_mean=np.full(4, np.nan), birth_covar=np.eye(4)), ValueError,
     "birth_mean contains NaN"),
    (dict(birth_rate=1.0, birth_mean=np.zeros(3), birth_covar=np.eye(4)), ValueError,
     "birth_mean must have 4 components"),
    (dict(birth_rate=np.inf), ValueError, "birth_rate must be finite"),
    (dict(clutter_rate=1e12), ValueError, "clutter_rate must be at most"),
    (dict(prob_detect=True), TypeError, "prob_detect must be a real number, got bool"),
    (dict(time_interval="1"), TypeError, "time_interval must be a datetime.timedelta"),
    (dict(time_interval=0.0), ValueError, "time_interval must be > 0 seconds"),
    (dict(region=[[-1e308, -1e308], [1e308, 1e308]]), ValueError, "region's volume overflows"),
])
def test_multi_target_names_a_bad_argument(arguments, error, match):
    with pytest.raises(error, match=match):
        multi_target(TRANSITION, SENSOR, np.zeros((2, 4)), 3, **{"region": REGION,
                                                                 **arguments})


def test_multi_target_takes_a_timedelta_interval():
    seconds = multi_target(TRANSITION, SENSOR, np.zeros((2, 4)), 3, REGION, rng=1)
    delta = multi_target(TRANSITION, SENSOR, np.zeros((2, 4)), 3, REGION, rng=1,
                         time_interval=datetime.timedelta(seconds=1))
    assert delta.time_interval == 1.0
    for a, b in zip(seconds.detections, delta.detections):
        np.testing.assert_array_equal(a, b)


def test_ground_truth_and_detections_name_a_bad_argument():
    for interval in (-1.0, 0.0):
        with pytest.raises(ValueError, match="time_interval must be > 0 seconds"):
            ground_truth(TRANSITION, [0, 1, 0, 1], 3, time_interval=interval)
    with pytest.raises(ValueError, match="time_interval of 1e\\+308 s overflows Q"):
        ground_truth(TRANSITION, [0, 1, 0, 1], 3, time_interval=1e308)
    with pytest.raises(ValueError, match="initial_state must have 4 components"):
        ground_truth(TRANSITION, [0, 1, 0], 3)
    with pytest.raises(TypeError, match="initial_state must be a numeric array"):
        ground_truth(TRANSITION, "start", 3)
    state = ft.GroundTruthState([0.0, 1.0, 0.0, 1.0], timestamp=0.0)  # a State is taken
    assert len(ground_truth(TRANSITION, state, 3, rng=0)) == 3
    with pytest.raises(TypeError, match="truth must be an iterable of states"):
        detections(np.zeros((3, 4)), SENSOR)
    with pytest.raises(TypeError, match="truth must be an iterable of states"):
        detections(5, SENSOR)


@pytest.mark.parametrize("arguments, error, match", [
    (dict(mmap_threshold_mb=-1), ValueError, "mmap_threshold_mb must be finite and >= 0"),
    (dict(mmap_threshold_mb=1e9), ValueError, "mmap_threshold_mb must be below 2048 MiB"),
    (dict(mmap_threshold_mb=np.nan), ValueError, "mmap_threshold_mb must be finite"),
    (dict(mmap_threshold_mb="64"), TypeError, "mmap_threshold_mb must be a real number"),
    (dict(trim_threshold_mb=-5), ValueError, "trim_threshold_mb must be finite and >= 0"),
    (dict(trim_threshold_mb=1e7), ValueError, "trim_threshold_mb must be below 2048 MiB"),
])
def test_tune_allocator_names_a_bad_size(arguments, error, match):
    with pytest.raises(error, match=match):
        ft.tune_allocator(**arguments)


@pytest.mark.parametrize("angles, error, match", [
    (0, TypeError, "angle_components must be a sequence of integer indices, got int"),
    ("0", TypeError, "angle_components must be a sequence of integer indices, got str"),
    ([True], TypeError, "angle_components must hold integer indices, got True"),
    ([1.0], TypeError, "angle_components must hold integer indices, got 1.0"),
    ([5], ValueError, r"angle_components indices must lie in \[0, 2\)"),
])
def test_kernel_angle_components_are_integer_rows(angles, error, match):
    x = np.random.default_rng(0).random((2, 5))
    with pytest.raises(error, match=match):
        ft.GaussianKernel()(x, x, angle_components=angles)
    np.testing.assert_array_equal(ft.GaussianKernel()(x, x, angle_components=None),
                                  ft.GaussianKernel()(x, x))


def test_kernel_values_that_overflow_are_refused():
    x = np.random.default_rng(0).normal(size=(2, 5)) * 1e300
    for kernel in (ft.GaussianKernel(), ft.QuadraticKernel()):
        with pytest.raises(ValueError, match="kernel values are not finite .* rescale state1"):
            kernel(x)


@pytest.mark.parametrize("numpy_first", [True, False])
def test_an_akkf_measurement_whose_kernel_value_overflows_is_named(numpy_first, monkeypatch):
    from fasttrack import _jit
    from fasttrack.scenarios import adaptive_kernel_tutorial
    monkeypatch.setattr(_jit, "numpy_first", lambda work: numpy_first)
    scenario = adaptive_kernel_tutorial(30, steps=2)
    model = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.01, 1.0]))
    detection = scenario.detections[1]
    prediction = ft.AdaptiveKernelKalmanPredictor(scenario.transition_model).predict(
        scenario.prior, detection.timestamp)
    updater = ft.AdaptiveKernelKalmanUpdater(model, ft.QuadraticKernel(), rng=0)
    z = ft.Detection(np.array([[0.1], [1e200]]), timestamp=detection.timestamp)
    with pytest.raises(ValueError, match=r"hypothesis.measurement \[0.1, 1e\+200\] is too "
                                         r"large for QuadraticKernel: its kernel value"):
        updater.update(ft.SingleHypothesis(prediction, z))
    z = ft.Detection(np.array([[0.1], [20.0]]), timestamp=detection.timestamp)
    assert np.isfinite(updater.update(ft.SingleHypothesis(prediction, z)).weight).all()


@pytest.mark.parametrize("threshold", [-5.0, 0.0, np.nan])
def test_ess_threshold_must_be_positive(threshold):
    with pytest.raises(ValueError, match="threshold must be finite(, got nan| and > 0)"):
        ft.ESSResampler(threshold=threshold)


def _identity(x, dt):
    return x


@pytest.mark.parametrize("predictor", [ft.ExtendedKalmanPredictor, ft.UnscentedKalmanPredictor,
                                       ft.ParticlePredictor])
def test_a_user_noise_that_is_not_psd_is_named_by_every_predictor(predictor):
    import numba
    model = ft.NonlinearGaussianTransitionModel(numba.njit(_identity), lambda dt: -2 * np.eye(4),
                                                4)
    prior = (ft.ParticleState(np.zeros((4, 10)), timestamp=0.0) if predictor is ft.ParticlePredictor
             else ft.GaussianState([10.0, 1.0, 10.0, 1.0], np.eye(4), 0.0))
    with pytest.raises(ValueError, match=r"covariance\(dt\) is not positive semi-definite"):
        predictor(model).predict(prior, 1.0)


def _detection(t):
    return ft.Detection(np.zeros((2, 1)), timestamp=t, measurement_model=SENSOR)


PRIOR = ft.GaussianState([0.0, 1.0, 0.0, 1.0], np.eye(4), 0.0)


@pytest.mark.parametrize("call, error, match", [
    (lambda: ft.KalmanUpdater(SENSOR, use_joseph_cov="no"), TypeError,
     "use_joseph_cov must be a bool, got str"),
    (lambda: ft.BatchExtendedKalmanFilter(TRANSITION, SENSOR, use_joseph_cov=None), TypeError,
     "use_joseph_cov must be a bool"),
    (lambda: ft.run_filter(ft.KalmanPredictor(TRANSITION), ft.KalmanUpdater(SENSOR), PRIOR,
                           [_detection(2.0), _detection(1.0)]), ValueError,
     r"detections must be in time order, after the prior: detections\[1\] is at 1.0"),
    (lambda: ft.run_filter(ft.KalmanPredictor(TRANSITION), ft.KalmanUpdater(SENSOR), PRIOR,
                           [_detection(-1.0)]), ValueError, r"detections\[0\] is at -1.0"),
    (lambda: ft.run_filter(None, ft.KalmanUpdater(SENSOR), PRIOR, [_detection(1.0)]), TypeError,
     "predictor must have a predict method"),
    (lambda: ft.run_filter(ft.KalmanPredictor(TRANSITION), None, PRIOR, [_detection(1.0)]),
     TypeError, "updater must have an update method"),
    (lambda: ft.run_filter(ft.KalmanPredictor(TRANSITION), ft.KalmanUpdater(SENSOR), PRIOR, 5),
     TypeError, "detections must be an iterable"),
    (lambda: ft.BatchExtendedKalmanFilter(TRANSITION, SENSOR).update(
        np.zeros((2, 4)), np.tile(np.eye(4), (2, 1, 1)), None), TypeError,
     "measurements must be a"),
    (lambda: ft.BatchExtendedKalmanFilter(TRANSITION, SENSOR).update(
        np.zeros((2, 4)), np.stack([np.eye(4), -np.eye(4)]), np.zeros((2, 2))), ValueError,
     r"1 of 2 filters failed; filter 1: covars\[1\] is not positive semi-definite"),
])
def test_filters_name_a_bad_argument(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_the_akkf_updater_names_a_bad_model_or_measurement_prediction():
    updater = ft.AdaptiveKernelKalmanUpdater(SENSOR)
    state = ft.KernelParticleState(np.random.default_rng(0).normal(size=(4, 20)), timestamp=1.0)
    with pytest.raises(TypeError, match="measurement_model must be a MeasurementModel"):
        updater.predict_measurement(state, "x")
    with pytest.raises(TypeError, match="measurement_model must be a MeasurementModel"):
        updater.predict_measurement(state, TRANSITION)
    hypothesis = ft.SingleHypothesis(state, _detection(1.0), measurement_prediction="x")
    with pytest.raises(TypeError, match="hypothesis.measurement_prediction must be a "
                                        "measurement prediction"):
        updater.update(hypothesis)


@pytest.mark.parametrize("value, error, match", [
    (10**400, ValueError, "merge_threshold must lie within the float range"),
    (-10**400, ValueError, "merge_threshold must lie within the float range"),
    ("16", TypeError, "merge_threshold must be a real number, got str"),
])
def test_a_number_beyond_the_float_range_is_named(value, error, match):
    with pytest.raises(error, match=match):
        ft.GaussianMixtureReducer(merge_threshold=value)


def test_a_fraction_is_a_real_number():
    from fractions import Fraction
    assert ft.GaussianMixtureReducer(prune_threshold=Fraction(1, 4)).prune_threshold == 0.25


def test_an_interval_beyond_the_float_range_is_named():
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1)] * 2)
    filt = ft.BatchIMMFilter([cv, cv], ft.LinearGaussian(4, (0, 2), np.eye(2)),
                             [[0.9, 0.1], [0.1, 0.9]])
    with pytest.raises(ValueError, match="time_intervals must lie within the float range"):
        filt.step(np.zeros((1, 2, 4)), np.tile(np.eye(4), (1, 2, 1, 1)), [[0.5, 0.5]],
                  [[0.0, 0.0]], 10**400)


def test_component_gains_refuse_stacks_that_do_not_match():
    from fasttrack.core import mixture
    with pytest.raises(ValueError, match=r"must have shapes \(J, d, d\), \(J, d, m\) and"):
        mixture.component_gains(np.tile(np.eye(4), (3, 1, 1)), np.zeros((2, 4, 2)),
                                np.tile(np.eye(2), (2, 1, 1)))


@pytest.mark.parametrize("numpy_first", [False, True])
def test_component_gains_refuse_a_nan_innovation_covariance(numpy_first, monkeypatch):
    """The NumPy twin returned NaN gains where the kernel refused."""
    from fasttrack import _jit
    from fasttrack.core import mixture
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: numpy_first)
    covars = np.tile(np.eye(2), (2, 1, 1))
    with pytest.raises(ValueError, match="innovation contains NaN"):
        mixture.component_gains(covars, covars[:, :, :1].copy(), np.full((2, 1, 1), np.nan))
    with pytest.raises(ValueError, match="innovation covariance of component 1 is not "
                                         "positive definite"):
        mixture.component_gains(covars, covars[:, :, :1].copy(), np.array([[[1.0]], [[-1.0]]]))


@pytest.mark.parametrize("name", ["covars", "innovation"])
def test_component_gains_refuse_an_asymmetric_covariance(name):
    """The kernel reads lower triangles: an asymmetric S gave the gains of another."""
    from fasttrack.core import mixture
    stacks = dict(covars=np.tile(np.eye(4), (2, 1, 1)), innovation=np.tile(np.eye(2), (2, 1, 1)))
    stacks[name][1, 0, 1] = 0.9
    with pytest.raises(ValueError, match=rf"{name}\[1\] is not symmetric"):
        mixture.component_gains(stacks["covars"], np.zeros((2, 4, 2)), stacks["innovation"])


@pytest.mark.parametrize("call, error, message", [
    (lambda m, p: p.log_probability(-0.5, "prob_detect"), ValueError,
     r"prob_detect must lie in \[0, 1\], got -0.5"),
    (lambda m, p: p.log_probability(np.nan), ValueError, "value must be finite"),
    (lambda m, p: m.relabel([0.5, 0.5], [1.0, 2.0], 3), ValueError,
     "labels must be 2 integers, got float64"),
    (lambda m, p: m.relabel([0, 0, 1], [1.0, 2.0], 5), ValueError,
     r"weights must be 3 numbers \(not NaN\), one a label, got shape \(2,\)"),
    (lambda m, p: m.relabel([0, 0], [1.0, np.nan], 5), ValueError, "not NaN"),
    (lambda m, p: m.relabel([0, 0], [1.0, 2.0], -9), ValueError, "first_new must be >= 0"),
    (lambda m, p: m.relabel([0, 0], [1.0, 2.0], 2**63 - 2), ValueError,
     "first_new must be <= 9223372036854775805"),
    (lambda m, p: m.relabel([0, 0], [1.0, 2.0], 1.5), TypeError, "first_new must be an int"),
    (lambda m, p: m.groups([0.5, 0.5, 2.0]), ValueError, "labels must be 3 integers"),
    (lambda m, p: m.groups([[0, 1]]), ValueError,
     r"labels must be a 1-D array of integers, got int64 of shape \(1, 2\)"),
])
def test_array_layer_mixture_helpers_name_bad_arguments(call, error, message):
    from fasttrack.core import mixture, phd
    with pytest.raises(error, match=message):
        call(mixture, phd)


def test_relabel_renames_repeats_from_first_new():
    from fasttrack.core import mixture
    np.testing.assert_array_equal(mixture.relabel([4, 4, 2, 4], [1.0, 3.0, 1.0, 3.0], 10),
                                  [10, 4, 2, 11])


_CV = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
_LG = ft.LinearGaussian(4, (0, 2), np.eye(2))
_RADAR = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.01, 1.0]), translation_offset=[50, 0])
_UNTIMED = [ft.GaussianState([i, 0, i, 0], np.eye(4)) for i in range(3)]


_NAIVE = datetime.datetime(2026, 1, 1)
_AWARE = datetime.datetime(2026, 1, 1, 0, 0, 1, tzinfo=datetime.timezone.utc)


@pytest.mark.parametrize("call, error, match", [
    (lambda: ft.KalmanUpdater(_LG).update(ft.SingleHypothesis(
        ft.KalmanPredictor(_CV).predict(ft.GaussianState(np.zeros(4), np.eye(4),
                                                         timestamp=0.0), 1.0),
        np.array([1.0, 1.0]))),
     TypeError, r"hypothesis.measurement must be a Detection \(a state_vector and a "
                r"timestamp\), got ndarray"),
    (lambda: ft.KalmanPredictor(_CV).predict(ft.GaussianState(np.zeros(4), np.eye(4),
                                                              timestamp=_NAIVE), _AWARE),
     TypeError, "must both have a time zone or both have none"),
    (lambda: ft.Track([ft.GaussianState(np.zeros(4), np.eye(4), timestamp=_NAIVE),
                       ft.GaussianState(np.zeros(4), np.eye(4), timestamp=_AWARE)]),
     TypeError, "one has a time zone, the other none"),
    (lambda: setattr(ft.WeightedGaussianState([1.0], np.eye(1)), "weight", "abc"),
     TypeError, "weight must be a real number, got str"),
    (lambda: setattr(ft.WeightedGaussianState([1.0], np.eye(1)), "weight", -1.0),
     ValueError, "weight must be finite and >= 0"),
    (lambda: setattr(ft.GaussianState([1.0], np.eye(1)), "state_vector", [1.0, 2.0]),
     ValueError, r"state_vector must have 1 components \(the covariance's dimension\)"),
    (lambda: setattr(ft.State([1.0]), "state_vector", [np.nan]),
     ValueError, "state_vector contains NaN"),
    (lambda: __import__("fasttrack.core.mixture").core.mixture.segment_logsumexp(None, [0, 1]),
     TypeError, "values must be a numeric array of real numbers, got NoneType"),
    (lambda: ft.BatchIMMFilter.combine(np.zeros((1, 2, 0)), np.zeros((1, 2, 0, 0)),
                                       np.full((1, 2), 0.5)),
     ValueError, r"means must have shape \(..., M, d\), d >= 1"),
    (lambda: ft.GaussianMixture(np.zeros((1, 1)), np.ones((1, 1, 1)), [800.0]).components,
     ValueError, r"log_weights beyond log\(1.8e308\) = 709.78 have no float64 weight"),
    (lambda: ft.NonlinearGaussianMeasurement(lambda x: x[:0], 4, np.zeros((0, 0))),
     ValueError, r"noise_covar must have at least one row and column"),
    (lambda: ft.KalmanSmoother(_CV).smooth_arrays(np.full((5, 4), 1e308),
                                                  np.tile(np.eye(4), (5, 1, 1)), 1.0),
     ValueError, r"the smoothed state\[0\] is not finite or has a negative variance"),
    (lambda: ft.KalmanSmoother(_CV).smooth_arrays(np.zeros((3, 4)), np.tile(np.eye(4), (3, 1, 1)),
                                                  10**400),
     ValueError, "time_intervals must lie within the float range"),
    (lambda: ft.KalmanPredictor(_CV).predict(ft.GaussianState(np.zeros(4), np.eye(4),
                                                               timestamp=0.0), 10**400),
     ValueError, "timestamp must lie within the float range"),
    (lambda: ft.metrics.position_rmse(_UNTIMED, _UNTIMED, pair="timestamp"), ValueError,
     r"pair='timestamp' needs timestamps: track\[0\] has none"),
    (lambda: ft.metrics.gospa([[0.0, 0.0]], [], 5.0, alpha=1e-320), ValueError,
     "c \\*\\* p / alpha, the cost of a target missed, must be at most 1e300"),
    (lambda: ft.association.gate(np.zeros((1, 2)), np.eye(2)[None], np.zeros((0, 5)), 9.0),
     ValueError, r"detections must have shape \(M, 2\), got \(0, 5\)"),
    (lambda: ft.MultiTargetTracker(_CV, _LG, np.zeros(4), np.eye(4)).step(np.zeros((0, 3)), 0.0),
     ValueError, r"detections must have shape \(M, 2\)"),
    (lambda: multi_target(_CV, _RADAR, [[0, 1, 0, 1.0]], 3, [[-100, 0], [100, 100]],
                          clutter_rate=5, rng=1),
     ValueError, r"region's row 0 holds angles \(radians\): it must lie within \[-pi, pi\]"),
    (lambda: ft.ESSResampler(threshold=10**400), ValueError,
     "threshold must lie within the float range"),
    (lambda: ft.seed(-1), ValueError, "n must be a non-negative seed"),
    (lambda: ft.seed(1.5), TypeError, "n must be an int seed or None, got float"),
    (lambda: ft.seed(True), TypeError, "n must be an int seed or None, got bool"),
])
def test_more_bad_input_is_named(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_edge_values_that_are_legal_still_work():
    from fractions import Fraction
    assert ft.ESSResampler(threshold=Fraction(5, 2)).threshold == 2.5
    assert len(ft.MultiTargetTracker(_CV, _LG, np.zeros(4), np.eye(4)).step([], 0.0)) == 0
    weights = ft.association.pda_weights(np.zeros((1, 400)), np.eye(400)[None],
                                         np.zeros((2, 400)))  # (Gamma(201) alone overflows)
    assert np.isfinite(weights).all()
    ft.seed(np.uint8(4))
    ft.seed(None)


def test_angles_beyond_what_float64_can_wrap_are_refused():
    """A bearing of 1e17 rad wrapped to [-pi, pi) keeps no digit (and 1e300 none of the
    wrap): it moved an EKF's state by 1e282 on the kernels and was ignored in NumPy."""
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    sensor = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.01, 1.0]))
    prediction = ft.KalmanPredictor(transition).predict(
        ft.GaussianState([10.0, 1.0, 10.0, 1.0], np.eye(4), timestamp=0.0), 1.0)
    message = r"hypothesis.measurement\[0\] is an angle of 1e\+17 rad: angles must lie within"
    for updater in (ft.ExtendedKalmanUpdater(sensor), ft.UnscentedKalmanUpdater(sensor)):
        with pytest.raises(ValueError, match=message):
            updater.update(ft.SingleHypothesis(prediction, ft.Detection([1e17, 14.0],
                                                                        timestamp=1.0)))
        assert updater.update(ft.SingleHypothesis(prediction, ft.Detection(
            [2 * np.pi * 1e6 + 0.8, 14.0], timestamp=1.0))).state_vector.shape == (4, 1)
    batch = ft.BatchUnscentedKalmanFilter(transition, sensor)
    with pytest.raises(ValueError, match=r"measurements must hold angles within \+-1e\+09 rad"):
        batch.update(np.ones((2, 4)), np.tile(np.eye(4), (2, 1, 1)), [[0.5, 10.0], [-1e300, 9.0]])


def test_warmup_and_position_mapping_arguments_are_checked():
    for kwargs, error, match in [
            (dict(load="no"), TypeError, "load must be a bool, got str"),
            (dict(report="x"), TypeError, "report must be callable"),
            (dict(families="kalman"), TypeError, "families must be an iterable of family "
                                                 "names, not one string")]:
        with pytest.raises(error, match=match):
            ft.warmup(**kwargs)
    from fasttrack.montecarlo.metrics import _check_mapping
    with pytest.raises(TypeError, match=r"position_mapping must hold integer indices, got "
                                        r"True \(bool\) in \(True, 2\)"):
        _check_mapping((True, 2))
    with pytest.raises(ValueError, match=r"position_mapping must be distinct state indices, "
                                         r"got \(2, 2\)"):
        _check_mapping((2, 2))
    assert _check_mapping((np.int64(1), 2)) == [1, 2]


def test_metadata_priors_and_numpy_intervals():
    with pytest.raises(TypeError, match="metadata must be a mapping"):
        ft.Detection([1.0, 2.0], metadata=5)
    assert ft.GroundTruthState([1.0], metadata=[("id", 3)]).metadata == {"id": 3}
    model = ft.ConstantVelocity(0.1)
    with pytest.raises(TypeError, match="prior must be a state"):
        ft.run_filter(ft.KalmanPredictor(model), ft.KalmanUpdater(
            ft.LinearGaussian(2, (0,), np.eye(1))), None, [])
    np.testing.assert_allclose(model.covar(np.timedelta64(1500, "ms")), model.covar(1.5))
    with pytest.raises(ValueError, match="time_interval must be finite"):
        model.covar(np.timedelta64("NaT"))
    prior = ft.GaussianState([0.0, 1.0], np.eye(2), timestamp=0.0)
    with pytest.raises(TypeError, match="mix of datetimes and numbers"):
        ft.run_filter(ft.KalmanPredictor(model), ft.KalmanUpdater(
            ft.LinearGaussian(2, (0,), np.eye(1))), prior,
            [ft.Detection([1.0], timestamp=datetime.datetime(2026, 1, 1))])
