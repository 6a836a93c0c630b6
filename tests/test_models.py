"""Models against Stone Soup 1.9.1 on the same inputs (where it is installed), their noise,
and their bad input."""
import datetime

import numpy as np
import pytest

import fasttrack as ft

try:
    from stonesoup.models.measurement import linear as ss_meas_linear
    from stonesoup.models.measurement import nonlinear as ss_nonlinear
    from stonesoup.models.transition import linear as ss_linear
    from stonesoup.types import array as ss_array
    from stonesoup.types import detection as ss_detection
    from stonesoup.types import state as ss_state
except ImportError:
    ss_linear = None

#: The comparisons with Stone Soup (the other tests run without it).
against_stonesoup = pytest.mark.skipif(ss_linear is None, reason="needs stonesoup")

RTOL = 1e-12
INTERVALS = [1.0, 0.25, 7.5, 0.0, -2.0]


def _td(seconds):
    return datetime.timedelta(seconds=seconds)


def _ss_states(x):
    return ss_state.State(ss_array.StateVectors(x)) if x.shape[1] > 1 else ss_state.State(x)


def _cv(q=0.05):
    return ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q),
                                                     ft.ConstantVelocity(2 * q)])


def _cv_pair(q=0.05):
    return _cv(q), ss_linear.CombinedLinearGaussianTransitionModel(
        [ss_linear.ConstantVelocity(q), ss_linear.ConstantVelocity(2 * q)])


@against_stonesoup
@pytest.mark.parametrize("dt", INTERVALS)
def test_transition_matrices_and_covariances_match(dt):
    ours, theirs = _cv_pair()
    np.testing.assert_allclose(ours.matrix(_td(dt)), theirs.matrix(time_interval=_td(dt)), rtol=RTOL)
    np.testing.assert_allclose(ours.covar(_td(dt)), theirs.covar(time_interval=_td(dt)), rtol=RTOL, atol=0)
    np.testing.assert_allclose(ours.matrix(dt), ours.matrix(_td(dt)))  # seconds or timedelta
    cv, ss_cv = ft.ConstantVelocity(0.3), ss_linear.ConstantVelocity(0.3)
    np.testing.assert_allclose(cv.covar(dt), ss_cv.covar(time_interval=_td(dt)), rtol=RTOL)


@against_stonesoup
@pytest.mark.parametrize("dt", [1.0, 0.25, 7.5, -2.0])
@pytest.mark.parametrize("rate", [0.01, -0.02634, 1.5])
def test_known_turn_rate_matches_stone_soup(dt, rate):
    ours = ft.KnownTurnRate([0.1, 0.3], rate)
    theirs = ss_linear.KnownTurnRate(turn_noise_diff_coeffs=np.array([0.1, 0.3]),
                                     turn_rate=rate)
    np.testing.assert_allclose(ours.matrix(dt), theirs.matrix(time_interval=_td(dt)),
                               rtol=RTOL, atol=1e-15)
    np.testing.assert_allclose(ours.covar(dt), theirs.covar(time_interval=_td(dt)), rtol=RTOL)
    x = np.random.default_rng(1).normal(size=(4, 3))
    np.testing.assert_allclose(ours.function(x, time_interval=dt),
                               theirs.function(_ss_states(x), time_interval=_td(dt)),
                               rtol=RTOL, atol=1e-12)


@against_stonesoup
@pytest.mark.parametrize("dt", [1.0, 0.25, 7.5, -2.0])
def test_constant_acceleration_matches_stone_soup(dt):
    ours = ft.CombinedLinearGaussianTransitionModel([ft.ConstantAcceleration(0.2),
                                                     ft.ConstantAcceleration(0.7)])
    theirs = ss_linear.CombinedLinearGaussianTransitionModel(
        [ss_linear.ConstantAcceleration(0.2), ss_linear.ConstantAcceleration(0.7)])
    np.testing.assert_allclose(ours.matrix(dt), theirs.matrix(time_interval=_td(dt)),
                               rtol=RTOL, atol=0)
    np.testing.assert_allclose(ours.covar(dt), theirs.covar(time_interval=_td(dt)), rtol=RTOL)
    x = np.random.default_rng(2).normal(size=(6, 3))
    np.testing.assert_allclose(ours.function(x, time_interval=dt),
                               theirs.function(_ss_states(x), time_interval=_td(dt)),
                               rtol=RTOL, atol=1e-12)


def test_constant_acceleration_moves_a_thrown_body_and_refuses_a_bad_rate():
    model = ft.ConstantAcceleration(0.0)
    np.testing.assert_allclose(model.matrix(2.0) @ [0.0, 3.0, -9.81], [6.0 - 19.62, 3.0 - 19.62,
                                                                       -9.81])
    assert model.covar(2.0).sum() == 0.0
    with pytest.raises(ValueError, match="noise_diff_coeff"):
        ft.ConstantAcceleration(-1.0)
    with pytest.raises(ValueError, match="overflows Q"):
        ft.ConstantAcceleration(1.0).covar(1e70)


@against_stonesoup
@pytest.mark.parametrize("dt", [1.0, 0.25, 7.5, -2.0])
def test_constant_turn_matches_stone_soup(dt):
    from stonesoup.models.transition.nonlinear import ConstantTurn
    ours = ft.ConstantTurn([0.1, 0.3], 0.02)
    theirs = ConstantTurn(linear_noise_coeffs=np.array([0.1, 0.3]), turn_noise_coeff=0.02)
    x = np.random.default_rng(3).normal(size=(5, 4))
    x[4] = [0.01, -0.3, 1.5, -0.02634]
    np.testing.assert_allclose(ours.function(x, time_interval=dt),
                               theirs.function(_ss_states(x), time_interval=_td(dt)),
                               rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(ours.covar(dt), theirs.covar(time_interval=_td(dt)), rtol=RTOL)


def test_constant_turn_draws_and_weighs_its_noise():
    """Its noise: draws with covariance Q(dt), densities of N(f(x), Q(dt)), and a particle
    filter's prediction (the noise once went missing: every use raised)."""
    from scipy.stats import multivariate_normal
    model = ft.ConstantTurn([0.1, 0.3], 0.02)
    x = np.array([0.0, 1.0, 0.0, 1.0, 0.1])
    draws = model.rvs(40000, time_interval=2.0, rng=5)
    np.testing.assert_allclose(np.cov(draws), model.covar(2.0), rtol=0.05, atol=0.02)
    moved = model.function(x, noise=True, time_interval=2.0, rng=5)
    assert moved.shape == (5, 1) and not np.allclose(moved[:, 0], model.function(
        x, time_interval=2.0)[:, 0])
    y = model.function(x, time_interval=2.0)[:, 0] + 0.1
    assert model.logpdf(y, x, time_interval=2.0) == pytest.approx(multivariate_normal(
        model.function(x, time_interval=2.0)[:, 0], model.covar(2.0)).logpdf(y), rel=1e-10)
    prior = ft.ParticleState(np.random.default_rng(0).normal(size=(5, 2000)) * 0.1
                             + x[:, None], timestamp=0.0)
    predicted = ft.ParticlePredictor(model, rng=0).predict(prior, 1.0)
    assert predicted.state_vector.shape == (5, 2000)
    assert np.isfinite(predicted.state_vector).all()


def test_constant_turn_is_its_mirror_turns_and_flies_straight_at_a_rate_of_zero():
    from reference import turn as mirror
    model = ft.ConstantTurn([0.0, 0.0], 0.0)
    x = np.random.default_rng(4).normal(size=(5, 6))
    x[4] = [0.0, 1e-12, -1e-9, 0.2, -1.0, 3.0]
    for dt in (1.0, 0.1, -4.0):
        np.testing.assert_allclose(model.function(x, time_interval=dt),
                                   mirror.constant_turn(x, dt), rtol=1e-10, atol=1e-12)
    quarter = model.function(np.array([[0.0], [1.0], [0.0], [0.0], [np.pi / 2]]),
                             time_interval=1.0)[:, 0]  # a quarter turn a second
    np.testing.assert_allclose(quarter, [2 / np.pi, 0.0, 2 / np.pi, 1.0, np.pi / 2],
                               atol=1e-15)
    straight = model.function(np.array([[1.0], [2.0], [3.0], [4.0], [0.0]]),
                              time_interval=0.5)[:, 0]
    np.testing.assert_array_equal(straight, [2.0, 2.0, 5.0, 4.0, 0.0])
    for tiny in (1e-310, -5e-324, 1e-300):  # subnormal rates: the straight line, not NaN
        nearly = model.function(np.array([[1.0], [2.0], [3.0], [4.0], [tiny]]),
                                time_interval=0.5)[:, 0]
        np.testing.assert_array_equal(nearly, [2.0, 2.0, 5.0, 4.0, tiny])
    with pytest.raises(ValueError, match="linear_noise_coeffs must be two numbers >= 0"):
        ft.ConstantTurn([0.1, -0.1], 0.0)
    with pytest.raises(ValueError, match="turn_noise_coeff"):
        ft.ConstantTurn([0.1, 0.1], -1.0)


def test_known_turn_rate_turns_and_its_zero_rate_is_constant_velocity():
    quarter = ft.KnownTurnRate([0.0, 0.0], np.pi / 2)  # a quarter turn a second
    np.testing.assert_allclose(quarter.matrix(1.0) @ [0.0, 1.0, 0.0, 0.0],
                               [2 / np.pi, 0.0, 2 / np.pi, 1.0], atol=1e-15)
    straight = ft.KnownTurnRate([0.1, 0.2], 0.0)  # the limit, not Stone Soup's 0 / 0
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1),
                                                   ft.ConstantVelocity(0.2)])
    np.testing.assert_array_equal(straight.matrix(2.5), cv.matrix(2.5))
    np.testing.assert_allclose(straight.covar(2.5), cv.covar(2.5), rtol=1e-15)
    with pytest.raises(ValueError, match="turn_noise_diff_coeffs must be two numbers >= 0"):
        ft.KnownTurnRate([0.1, -1.0], 0.1)
    with pytest.raises(ValueError, match="turn_rate must be finite"):
        ft.KnownTurnRate([0.1, 0.1], np.inf)
    with pytest.raises(TypeError, match="turn_rate must be a real number"):
        ft.KnownTurnRate([0.1, 0.1], "fast")
    straight.turn_rate = np.pi / 2  # F follows the new rate (not a remembered one)
    np.testing.assert_allclose(straight.matrix(1.0), quarter.matrix(1.0), atol=1e-15)
    prior = ft.GaussianState([0.0, 1.0, 0.0, 0.0], np.eye(4), timestamp=0.0)
    predicted = ft.KalmanPredictor(quarter).predict(prior, timestamp=1.0)
    np.testing.assert_allclose(predicted.state_vector.ravel(),
                               [2 / np.pi, 0.0, 2 / np.pi, 1.0], atol=1e-15)


@against_stonesoup
def test_transition_function_and_logpdf_match():
    ours, theirs = _cv_pair()
    rng = np.random.default_rng(0)
    x1, x2 = rng.normal(size=(4, 6)), rng.normal(size=(4, 6))
    dt = _td(1.5)
    np.testing.assert_allclose(ours.function(x2, time_interval=dt),
                               np.asarray(theirs.function(_ss_states(x2), time_interval=dt), float),
                               rtol=RTOL)
    np.testing.assert_allclose(
        ours.logpdf(x1, x2, time_interval=dt),
        theirs.logpdf(_ss_states(x1), _ss_states(x2), time_interval=dt), rtol=RTOL)
    one = ours.logpdf(x1[:, :1], x2[:, :1], time_interval=dt)
    assert isinstance(one, float)
    assert one == pytest.approx(theirs.logpdf(ss_state.State(x1[:, :1]), ss_state.State(x2[:, :1]),
                                              time_interval=dt), rel=RTOL)
    noise = rng.normal(size=(4, 6))
    np.testing.assert_allclose(ours.function(x2, noise=noise, time_interval=dt),
                               ours.function(x2, time_interval=dt) + noise)


def test_transition_noise_statistics():
    ours = _cv()
    draws = ours.rvs(200_000, time_interval=2.0, rng=1)
    assert draws.shape == (4, 200_000)
    np.testing.assert_allclose(np.cov(draws), ours.covar(2.0), rtol=0.02, atol=1e-3)
    moved = ours.function(np.zeros((4, 100_000)), noise=True, time_interval=2.0, rng=2)
    np.testing.assert_allclose(np.cov(moved), ours.covar(2.0), rtol=0.03, atol=1e-3)
    assert ours.rvs(time_interval=1.0, rng=3).shape == (4, 1)


def test_general_linear_gaussian_transition():
    f = np.array([[1.0, 0.5], [0.0, 0.9]])
    q = np.array([[0.2, 0.05], [0.05, 0.1]])
    model = ft.LinearGaussianTransitionModel(f, q)
    x = np.array([[1.0, -2.0], [3.0, 0.5]])
    np.testing.assert_allclose(model.function(x), f @ x)
    from scipy.stats import multivariate_normal
    y = x + 0.1
    np.testing.assert_allclose(model.logpdf(y, x),
                               multivariate_normal.logpdf((y - f @ x).T, cov=q), rtol=RTOL)
    assert np.array_equal(model.matrix(), f) and np.array_equal(model.covar(5.0), q)


def _bearing_range_pair(**offsets):
    noise = np.diag([np.radians(0.2), 1.0])
    theirs_kwargs = {k: np.reshape(v, (-1, 1)) for k, v in offsets.items()}
    return (ft.CartesianToBearingRange(4, (0, 2), noise, **offsets),
            ss_nonlinear.CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=noise,
                                                 **theirs_kwargs))


@against_stonesoup
@pytest.mark.parametrize("offsets", [
    {}, {"translation_offset": [50.0, 0.0]},
    {"translation_offset": [-3.0, 7.0], "rotation_offset": [0.0, 0.0, 0.7]},
    {"rotation_offset": [0.2, -0.3, 1.1]},
])
def test_bearing_range_function_and_logpdf_match(offsets):
    ours, theirs = _bearing_range_pair(**offsets)
    rng = np.random.default_rng(1)
    x = rng.normal(0, 30, size=(4, 50))
    np.testing.assert_allclose(ours.function(x), np.asarray(theirs.function(_ss_states(x)), float),
                               rtol=RTOL, atol=1e-13)
    z = np.array([[3.1], [25.0]])  # a bearing near +pi: the innovation must wrap
    det = ss_detection.Detection(z, measurement_model=theirs)
    np.testing.assert_allclose(ours.logpdf(z, x), theirs.logpdf(det, _ss_states(x)), rtol=1e-10)
    assert ours.angle_components == (0,)


@against_stonesoup
def test_bearing_range_inverse_function_matches():
    ours, theirs = _bearing_range_pair(translation_offset=[5.0, -2.0], rotation_offset=[0, 0, 0.4])
    z = np.array([[0.3], [12.0]])
    det = ss_detection.Detection(z, measurement_model=theirs)
    np.testing.assert_allclose(ours.inverse_function(z), np.asarray(theirs.inverse_function(det), float),
                               rtol=RTOL, atol=1e-13)
    np.testing.assert_allclose(ours.function(ours.inverse_function(z)), z, atol=1e-12)
    tilted, _ = _bearing_range_pair(rotation_offset=[0.1, 0, 0])
    with pytest.raises(ValueError, match="without roll or pitch"):
        tilted.inverse_function(z)


@against_stonesoup
def test_bearing_only_and_linear_models_match():
    x = np.random.default_rng(2).normal(0, 5, size=(4, 20))
    noise = np.array([[0.005**2]])
    ours = ft.Cartesian2DToBearing(4, (0, 2), noise)
    theirs = ss_nonlinear.Cartesian2DToBearing(ndim_state=4, mapping=(0, 2), noise_covar=noise)
    np.testing.assert_allclose(ours.function(x), np.asarray(theirs.function(_ss_states(x)), float),
                               rtol=RTOL)
    z = np.array([[-3.13]])
    np.testing.assert_allclose(ours.logpdf(z, x), theirs.logpdf(
        ss_detection.Detection(z, measurement_model=theirs), _ss_states(x)), rtol=1e-10)
    noise2 = np.array([[2.0, 0.3], [0.3, 1.0]])
    ours = ft.LinearGaussian(4, (0, 2), noise2)
    theirs = ss_meas_linear.LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=noise2)
    np.testing.assert_allclose(ours.matrix(), theirs.matrix())
    np.testing.assert_allclose(ours.function(x), np.asarray(theirs.function(_ss_states(x)), float))
    z = np.array([[1.0], [2.0]])
    np.testing.assert_allclose(ours.logpdf(z, x), theirs.logpdf(
        ss_detection.Detection(z, measurement_model=theirs), _ss_states(x)), rtol=RTOL)


def test_measurement_noise_is_wrapped_and_sampled():
    model = ft.CartesianToBearingRange(4, (0, 2), np.diag([4.0, 1.0]))
    z = model.function(np.array([[-10.0], [0], [1e-9], [0]]), noise=True, rng=0)  # bearing ~ pi
    assert -np.pi <= z[0, 0] < np.pi
    draws = model.rvs(100_000, rng=1)
    np.testing.assert_allclose(np.cov(draws), model.noise_covar, rtol=0.03, atol=0.01)


@pytest.mark.parametrize("build,error,message", [
    (lambda: ft.ConstantVelocity("fast"), TypeError, "noise_diff_coeff must be a real number"),
    (lambda: ft.ConstantVelocity(-1.0), ValueError, "noise_diff_coeff must be finite and >= 0"),
    (lambda: ft.CombinedLinearGaussianTransitionModel([]), ValueError, "model_list is empty"),
    (lambda: ft.CombinedLinearGaussianTransitionModel([1]), TypeError, "model_list must hold"),
    (lambda: ft.LinearGaussianTransitionModel(np.eye(2), [[1, 2], [3, 4]]), ValueError, "symmetric"),
    (lambda: ft.LinearGaussianTransitionModel(np.eye(2), [[1, 0], [0, -1]]), ValueError,
     "not positive semi-definite"),
    (lambda: ft.LinearGaussianTransitionModel(np.eye(2), np.eye(3)), ValueError, r"shape \(2, 2\)"),
    (lambda: ft.LinearGaussian(4, (0, 5), np.eye(2)), ValueError, r"mapping indices must lie in \[0, 4\)"),
    (lambda: ft.LinearGaussian(4, (0, 2), np.eye(3)), ValueError, r"noise_covar must have shape \(2, 2\)"),
    (lambda: ft.CartesianToBearingRange(4, (0,), np.eye(2)), ValueError, "must give the 2 state indices"),
    (lambda: ft.CartesianToBearingRange(4, (0, 2), np.eye(2), translation_offset=[1, 2, 3]),
     ValueError, "translation_offset must have 2 components"),
    (lambda: ft.CartesianToBearingRange(4, (0, 2), np.eye(2), rotation_offset=[1, 2]),
     ValueError, "rotation_offset must have 3 angles"),
    (lambda: ft.Cartesian2DToBearing(4, (0, 2), [[np.nan]]), ValueError, "noise_covar contains NaN"),
    (lambda: ft.NonlinearGaussianTransitionModel(lambda x, dt: x, np.eye(2), 2), TypeError,
     "numba.njit function"),
])
def test_bad_model_construction(build, error, message):
    with pytest.raises(error, match=message):
        build()


def test_bad_model_calls():
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1.0)] * 2)
    with pytest.raises(TypeError, match="needs a time_interval"):
        cv.matrix(None)
    with pytest.raises(TypeError, match="time_interval must be a datetime.timedelta, numpy.timedelta64 or a number"):
        cv.function(np.zeros(4), time_interval="1s")
    with pytest.raises(ValueError, match="state must have 4 rows"):
        cv.function(np.zeros(3), time_interval=1.0)
    sensor = ft.CartesianToBearingRange(4, (0, 2), np.eye(2))
    with pytest.raises(ValueError, match="measurement must have 2 components"):
        sensor.logpdf([1.0, 2.0, 3.0], np.zeros(4))
    with pytest.raises(ValueError, match="measurement contains NaN"):
        sensor.logpdf([np.nan, 2.0], np.zeros(4))
    with pytest.raises(ValueError, match="state contains NaN"):
        sensor.function(np.full(4, np.nan))


@against_stonesoup
def test_a_stone_soup_model_in_a_native_class_points_to_the_drop_ins():
    with pytest.raises(TypeError, match=r"transition_model must be a TransitionModel of "
                                        r"fasttrack.models, got stonesoup\..*fasttrack.stonesoup"):
        ft.ParticlePredictor(ss_linear.ConstantVelocity(0.1))
    sensor = ss_nonlinear.CartesianToBearingRange(ndim_state=4, mapping=(0, 2),
                                                  noise_covar=np.eye(2))
    with pytest.raises(TypeError, match="measurement_model must be a MeasurementModel.*drop-in"):
        ft.ParticleUpdater(sensor)


def test_a_remembered_q_follows_every_noise_parameter():
    cv = ft.ConstantVelocity(0.1)
    turn = ft.KnownTurnRate([0.1, 0.2], 0.05)
    combined = ft.CombinedLinearGaussianTransitionModel([cv, ft.ConstantAcceleration(0.3)])
    embedded = ft.EmbeddedTransitionModel(turn, (0, 1, 3, 4), 6)
    for model, change in ((cv, lambda: setattr(cv, "noise_diff_coeff", 0.7)),
                          (turn, lambda: setattr(turn, "turn_noise_diff_coeffs", [0.4, 0.2])),
                          (combined, lambda: setattr(combined.model_list[0],
                                                     "noise_diff_coeff", 2.0)),
                          (embedded, lambda: setattr(turn, "turn_noise_diff_coeffs", [1, 1])),
                          (combined, lambda: setattr(combined, "model_list", [
                              ft.ConstantVelocity(5.0), ft.ConstantAcceleration(0.3)]))):
        before = model.spec(2.0).noise.copy()
        change()
        after = model.spec(2.0).noise
        np.testing.assert_array_equal(after, model.covar(2.0))
        assert not np.array_equal(before, after)
