"""Transition models built from a function (ConstantTurn, a user's function) in the batch
IMM and GPB filters and the IMM tracker: the extended Kalman filter's prediction, step for
step as the class pair; a function that is linear is the linear model; intervals that
differ between filters; a bad function named."""
import numba
import numpy as np
import pytest

import fasttrack as ft
from fasttrack.models.transition import EmbeddedTransitionModel
from fasttrack.scenarios import manoeuvring_target

CV = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1e-2)] * 2)
MODELS = [EmbeddedTransitionModel(CV, (0, 1, 2, 3), 5), ft.ConstantTurn([1e-2, 1e-2], 1e-6)]
SENSOR = ft.LinearGaussian(5, (0, 2), np.diag([0.725, 0.7025]))
MATRIX = np.array([[0.95, 0.05], [0.05, 0.95]])


@numba.njit
def _cv_function(states, dt):
    """Constant velocity in (x, vx, y, vy), as a function."""
    out = states.copy()
    out[0] += dt * states[1]
    out[2] += dt * states[3]
    return out


@numba.njit
def _nan_past_100(states, dt):
    out = states.copy()
    for c in range(states.shape[1]):
        if states[0, c] > 100.0:
            out[0, c] = np.nan
    return out


def _start(x, y):
    state = ft.WeightedGaussianState([x, -30.0, y, -30.0, 0.0],
                                     np.diag([1.0, 25.0, 1.0, 25.0, 1e-4]), weight=0.5,
                                     timestamp=0.0)
    return ft.GaussianMixture([state, state])


def test_each_batch_step_is_the_class_pairs_with_a_turn_model():
    """From the class pair's state at every step of the manoeuvring flight (through both
    turns), the batch's step is the pair's to rounding. (Whole runs drift apart by up to
    1e-5: Stone Soup's forward differences step 1e-8 in the turn rate, so the Jacobian
    carries the rounding of f times 1e8.)"""
    scenario = manoeuvring_target(seed=3)
    predictor = ft.IMMPredictor([ft.KalmanPredictor(MODELS[0]),
                                 ft.ExtendedKalmanPredictor(MODELS[1])], MATRIX)
    updater = ft.IMMUpdater([ft.KalmanUpdater(SENSOR)] * 2, MATRIX)
    batch = ft.BatchIMMFilter(MODELS, SENSOR, MATRIX)
    state = _start(*scenario.measurements[0])
    for t, z in enumerate(scenario.measurements[1:], 1):
        before = state.means[None], state.covars[None], np.exp(state.log_weights)[None]
        state = updater.update(ft.SingleHypothesis(
            predictor.predict(state, timestamp=float(t)),
            ft.Detection(z, timestamp=float(t), measurement_model=SENSOR)))
        if t % 25:
            continue
        means, covars, probs = batch.step(*before, np.asarray(z)[None], 1.0)
        np.testing.assert_allclose(means[0], state.means, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(covars[0], state.covars, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(probs[0], np.exp(state.log_weights), rtol=1e-9, atol=1e-12)
    assert abs(state.means[1, 4] - scenario.turn_rates[-1]) < 0.01  # the rate was estimated


@pytest.mark.parametrize("algorithm", ["imm", "gpb1", "gpb2"])
def test_a_linear_function_is_the_linear_model(algorithm):
    """A constant-velocity model given as a function, linearised by finite differences,
    steps as the linear model (to the forward differences' 1e-6), for many filters at once with
    intervals that differ between them."""
    noisy = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1.0)] * 2)
    linear = [CV, noisy]
    function = [CV, ft.NonlinearGaussianTransitionModel(_cv_function, noisy.covar, 4)]
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    rng = np.random.default_rng(4)
    k = 7
    means = rng.normal(size=(k, 2, 4)) * 10.0
    a = rng.normal(size=(k, 2, 4, 4))
    covars = a @ a.swapaxes(-1, -2) + np.eye(4)
    probs = rng.dirichlet(np.ones(2), size=k)
    z = rng.normal(size=(k, 2)) * 10.0
    intervals = np.array([1.0, 0.5, 1.0, 2.0, 0.5, 1.0, 1.0])
    results = []
    for models in (linear, function):
        kind = ft.BatchIMMFilter if algorithm == "imm" else ft.BatchGPBFilter
        extra = {} if algorithm == "imm" else {"order": int(algorithm[-1])}
        results.append(kind(models, sensor, MATRIX, **extra).step(means, covars, probs, z,
                                                                  intervals))
    for got, want in zip(*results):
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)
    assert np.abs(results[0][2] - probs).max() > 0.01  # the models were told apart


def test_a_linear_function_smooths_as_the_linear_model():
    noisy = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1.0)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    rng = np.random.default_rng(6)
    k, n = 3, 15
    means = rng.normal(size=(k, n, 2, 4)) * 10.0
    a = rng.normal(size=(k, n, 2, 4, 4))
    covars = a @ a.swapaxes(-1, -2) + np.eye(4)
    probs = rng.dirichlet(np.ones(2), size=(k, n))
    intervals = rng.choice([0.5, 1.0], size=n - 1)
    results = [ft.BatchIMMFilter(models, sensor, MATRIX).smooth(means, covars, probs, intervals)
               for models in ([CV, noisy], [CV, ft.NonlinearGaussianTransitionModel(
                   _cv_function, noisy.covar, 4)])]
    for got, want in zip(*results):  # to the forward differences' error, of each's scale
        assert np.abs(got - want).max() <= 1e-6 * np.abs(want).max()
    assert np.abs(results[0][0] - means).max() > 1.0  # smoothing moved the states


def test_a_turning_flight_is_smoothed_better_than_filtered():
    """Straight flight (constant velocity, the turn rate carried) and ConstantTurn on the
    manoeuvring flight: the extended smoother's positions beat the filter's."""
    scenario = manoeuvring_target(seed=3)
    f = np.eye(5)
    f[0, 1] = f[2, 3] = 1.0
    q = np.zeros((5, 5))
    q[:4, :4] = CV.covar(1.0)
    q[4, 4] = 1e-8
    models = [ft.LinearGaussianTransitionModel(f, q), ft.ConstantTurn([1e-2, 1e-2], 1e-6)]
    batch = ft.BatchIMMFilter(models, SENSOR, MATRIX)
    x, y = scenario.measurements[0]
    means = np.tile([x, -30.0, y, -30.0, 0.0], (1, 2, 1))
    covars = np.tile(np.diag([1.0, 25.0, 1.0, 25.0, 1e-4]), (1, 2, 1, 1))
    probs = np.full((1, 2), 0.5)
    filtered = [], [], []
    for z in scenario.measurements[1:]:
        means, covars, probs = batch.step(means, covars, probs, np.asarray(z)[None], 1.0)
        for stack, value in zip(filtered, (means[0], covars[0], probs[0])):
            stack.append(value)
    filtered = [np.array(stack) for stack in filtered]
    smoothed = batch.smooth(*filtered, 1.0)
    truth = np.array(scenario.truths[1:])[:, [0, 2]]
    errors = [np.sqrt(np.mean(np.sum((batch.combine(*arrays)[0][:, [0, 2]] - truth) ** 2,
                                     axis=1))) for arrays in (filtered, smoothed)]
    # measured: 0.90 m filtered, 0.51 m smoothed
    assert errors[1] < 0.8 * errors[0]
    np.testing.assert_allclose(smoothed[2].sum(axis=1), 1.0, rtol=1e-12)


def test_many_filters_are_each_filter_alone():
    rng = np.random.default_rng(5)
    k = 40
    means = np.zeros((k, 2, 5))
    means[:, :, [0, 2]] = rng.normal(size=(k, 1, 2)) * 100.0
    means[:, :, [1, 3]] = rng.normal(size=(k, 1, 2)) * 10.0
    means[:, 1, 4] = rng.normal(size=k) * 0.05
    covars = np.broadcast_to(np.diag([1.0, 4.0, 1.0, 4.0, 1e-3]), (k, 2, 5, 5)).copy()
    covars[:, 0, 4, :] = covars[:, 0, :, 4] = 0.0  # the embedded model lacks the rate
    probs = rng.dirichlet(np.ones(2), size=k)
    z = means[:, 0, [0, 2]] + means[:, 0, [1, 3]] + rng.normal(size=(k, 2))
    for order in (None, 1, 2):
        batch = (ft.BatchIMMFilter(MODELS, SENSOR, MATRIX) if order is None
                 else ft.BatchGPBFilter(MODELS, SENSOR, MATRIX, order=order))
        whole = batch.step(means, covars, probs, z, 1.0)
        for i in (0, 17, 39):
            alone = batch.step(means[i:i + 1], covars[i:i + 1], probs[i:i + 1], z[i:i + 1], 1.0)
            for a, b in zip(whole, alone):
                np.testing.assert_array_equal(a[i], b[0])


def test_a_bad_function_output_is_named():
    model = ft.NonlinearGaussianTransitionModel(_nan_past_100, np.eye(4), 4)
    batch = ft.BatchIMMFilter([CV, model], ft.LinearGaussian(4, (0, 2), np.eye(2)), MATRIX)
    means = np.zeros((3, 2, 4))
    means[2, :, 0] = 150.0
    covars = np.broadcast_to(np.eye(4), (3, 2, 4, 4))
    with pytest.raises(ValueError, match="model 1 .*filter 2: transition function '_nan_past_100' returned NaN"):
        batch.step(means, covars, np.full((3, 2), 0.5), np.zeros((3, 2)), 1.0)
    with pytest.raises(ValueError, match=r"model 1 \(NonlinearGaussianTransitionModel\) at "
                                         r"means\[2, 0\]: transition function "
                                         r"'_nan_past_100' returned NaN"):
        batch.smooth(means, covars, np.full((3, 2), 0.5), 1.0)  # one track of 3 steps
    with pytest.raises(ValueError, match=r"at means\[1, 2, 0\]: transition function"):
        batch.smooth(np.stack([means * 0, means]), np.stack([covars] * 2),
                     np.full((2, 3, 2), 0.5), 1.0)


def test_the_imm_tracker_keeps_turning_targets_with_a_turn_model():
    """Straight flight (constant velocity embedded in the turn state) and a constant turn
    through the extended Kalman filter, on targets turning at 0.2 rad/s."""
    from fasttrack.simulate import multi_target
    from fasttrack.tracker import IMMTracker, MultiTargetTracker
    sensor4 = ft.LinearGaussian(4, (0, 2), np.eye(2))
    rng = np.random.default_rng(5)
    n = 12
    pos = np.c_[np.arange(n) % 4, np.arange(n) // 4] * 40.0 + rng.normal(0, 1, (n, 2))
    vel = rng.normal(0, 3.0, (n, 2))
    scenario = multi_target(ft.KnownTurnRate([0.05, 0.05], 0.2), sensor4,
                            np.c_[pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]], 30,
                            [[-60, -60], [180, 180]], prob_detect=0.9, clutter_rate=5.0,
                            rng=5)
    settings = dict(missed_distance=3.0, min_points=3, delete_after_misses=3,
                    tentative_misses=2)
    sensor = ft.LinearGaussian(5, (0, 2), np.eye(2))
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    imm = IMMTracker([EmbeddedTransitionModel(cv, (0, 1, 2, 3), 5),
                      ft.ConstantTurn([0.05, 0.05], 1e-4)], sensor, MATRIX,
                     prior_mean=np.zeros(5), prior_covar=np.diag([0.0, 9.0, 0.0, 9.0, 0.1]),
                     **settings)
    plain = MultiTargetTracker(cv, sensor4, prior_mean=np.zeros(4),
                               prior_covar=np.diag([0.0, 9.0, 0.0, 9.0]), **settings)
    held = {"imm": [], "plain": []}
    for t, (scan, truths) in enumerate(zip(scenario.detections, scenario.truths)):
        for name, tracker in (("imm", imm), ("plain", plain)):
            tracks = tracker.step(scan, float(t))
            gaps = (np.hypot(truths[:, None, 0] - tracks.means[None, :, 0],
                             truths[:, None, 2] - tracks.means[None, :, 2]).min(axis=1)
                    if len(tracks) else np.full(len(truths), np.inf))
            held[name].append(np.mean(gaps < 3.0))
    imm_held, plain_held = np.mean(held["imm"][5:]), np.mean(held["plain"][5:])
    # measured: 98 % of the targets within 3 m of a confirmed IMM track, 61 % of a CV one;
    # the turn model's median rate 0.209 rad/s
    assert imm_held > 0.9 and imm_held > plain_held + 0.2
    assert abs(np.median(imm.confirmed.model_means[:, 1, 4]) - 0.2) < 0.03
