"""The IMM fixed-interval smoother: the kernel against its mirror, the closed forms (one
model, identical models and a switching matrix of no switches are Rauch-Tung-Striebel
smoothers), a manoeuvring run smoothed better than filtered, and bad input."""
import numpy as np
import pytest

import fasttrack as ft
from fasttrack.core import imm, imm_smooth

SENSOR = ft.LinearGaussian(4, (0, 2), np.diag([0.5, 0.5]))
MATRIX = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.05, 0.15, 0.8]])


def _cv(q):
    return ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)


def _filtered(filt, k, n, seed=0, interval=1.0):
    """K tracks of n filtered IMM steps of ``filt`` on noisy straight-line measurements."""
    rng = np.random.default_rng(seed)
    models = len(filt.transition_models)
    means = np.tile([0.0, 1.0, 0.0, -1.0], (k, models, 1))
    covars = np.tile(np.diag([4.0, 1.0, 4.0, 1.0]), (k, models, 1, 1))
    probs = np.full((k, models), 1.0 / models)
    out = [], [], []
    for t in range(n):
        z = np.stack([np.full(k, t * interval), np.full(k, -t * interval)], axis=1)
        z = z + rng.normal(size=(k, 2)) * 2.0
        means, covars, probs = filt.step(means, covars, probs, z, interval)
        for stack, value in zip(out, (means, covars, probs)):
            stack.append(value)
    return tuple(np.stack(stack, axis=1) for stack in out)


@pytest.mark.parametrize("seed", range(3))
def test_the_kernel_is_its_mirror(seed):
    from fasttrack._jit import imm_smooth as kernels
    from reference import imm_smooth as mirror
    rng = np.random.default_rng(seed)
    models = [_cv(0.01), _cv(1.0), _cv(10.0)]
    matrix = rng.dirichlet(np.ones(3) * 2, size=3)
    matrix[1:, 0] = 0.0  # model 0 is reached from itself only
    matrix /= matrix.sum(axis=1, keepdims=True)
    k, n = 4, 12
    means = rng.normal(size=(k, n, 3, 4)) * 5.0
    a = rng.normal(size=(k, n, 3, 4, 4))
    covars = a @ a.swapaxes(-1, -2) + 0.1 * np.eye(4)
    probs = rng.dirichlet(np.ones(3), size=(k, n))
    probs[0, 5] = [0.0, 0.0, 1.0]  # model 0 dies at one step of track 0
    intervals = rng.choice([0.5, 1.0, 2.0], size=n)
    values, step = np.unique(intervals, return_inverse=True)
    noises = np.array([[m.covar(dt) for m in models] for dt in values])
    # a linearisation of each model from each filtered state: F and an offset b
    transitions = np.array([m.matrix(1.0) for m in models])[None] \
        + 0.05 * rng.normal(size=(k * n * 3, 3, 4, 4))
    offsets = rng.normal(size=(k * n * 3, 3, 4))
    linearisation = rng.permutation(k * n * 3).reshape(k, n, 3)
    arguments = (transitions, offsets, noises, linearisation, step.astype(np.int64), matrix,
                 np.ones((3, 4), dtype=np.bool_), means, covars, probs)
    got = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
           np.ones(k, dtype=np.int64)]
    want = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
            np.ones(k, dtype=np.int64)]
    kernels.imm_smooth(*arguments, *got)
    mirror.imm_smooth(*arguments, *want)
    assert (got[3] == 0).all() and (want[3] == 0).all()
    for a_, b_ in zip(got[:3], want[:3]):
        np.testing.assert_allclose(a_, b_, rtol=1e-8, atol=1e-8)
    assert got[2][0, 5, 0] == 0.0 and got[2][0, 4, 0] > 0.0  # dead at 5, not before
    np.testing.assert_allclose(got[2].sum(axis=-1), 1.0, rtol=1e-12)


def test_one_model_is_the_rts_smoother():
    filt = ft.BatchIMMFilter([_cv(0.5)], SENSOR, [[1.0]])
    means, covars, probs = _filtered(filt, 3, 30)
    intervals = np.linspace(0.5, 2.0, 29)
    got = filt.smooth(means, covars, probs, intervals)
    want = ft.KalmanSmoother(_cv(0.5)).smooth_arrays(means[:, :, 0], covars[:, :, 0],
                                                     intervals)
    np.testing.assert_allclose(got[0][:, :, 0], want[0], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(got[1][:, :, 0], want[1], rtol=1e-10, atol=1e-10)
    assert (got[2] == 1.0).all()


def test_identical_models_are_the_rts_smoother_and_keep_the_stationary_probabilities():
    matrix = np.array([[0.8, 0.2], [0.4, 0.6]])
    filt = ft.BatchIMMFilter([_cv(0.5), _cv(0.5)], SENSOR, matrix)
    means, covars, _ = _filtered(filt, 2, 25)
    stationary = np.broadcast_to([2.0 / 3.0, 1.0 / 3.0], (2, 25, 2))
    got = filt.smooth(means, covars, stationary, 1.0)
    want = ft.KalmanSmoother(_cv(0.5)).smooth_arrays(means[:, :, 0], covars[:, :, 0], 1.0)
    for j in range(2):
        np.testing.assert_allclose(got[0][:, :, j], want[0], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(got[1][:, :, j], want[1], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(got[2], stationary, rtol=1e-12)


def test_no_switching_smooths_each_model_alone_and_keeps_the_last_probabilities():
    models = [_cv(0.01), _cv(4.0)]
    filt = ft.BatchIMMFilter(models, SENSOR, np.eye(2))
    means, covars, probs = _filtered(filt, 2, 20, seed=3)
    got = filt.smooth(means, covars, probs, 1.0)
    for j, model in enumerate(models):
        want = ft.KalmanSmoother(model).smooth_arrays(means[:, :, j], covars[:, :, j], 1.0)
        np.testing.assert_allclose(got[0][:, :, j], want[0], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(got[1][:, :, j], want[1], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(got[2], np.broadcast_to(probs[:, -1:], probs.shape),
                               rtol=1e-12)


def test_one_track_is_the_batch_of_one():
    filt = ft.BatchIMMFilter([_cv(0.01), _cv(1.0), _cv(10.0)], SENSOR, MATRIX)
    means, covars, probs = _filtered(filt, 1, 15)
    single = filt.smooth(means[0], covars[0], probs[0], 1.0)
    batch = filt.smooth(means, covars, probs, 1.0)
    for a_, b_ in zip(single, batch):
        np.testing.assert_array_equal(a_, b_[0])


def test_a_manoeuvring_target_is_smoothed_better_than_filtered():
    # the models' process noise is the truth's (with less, the backward pass follows each
    # model's dynamics over long runs: see BatchIMMFilter.smooth)
    from fasttrack.scenarios import manoeuvring_target
    scenario = manoeuvring_target(seed=2)
    rates = (0.02, 0.0, -0.02)
    filt = ft.BatchIMMFilter([ft.KnownTurnRate([1e-2, 1e-2], w) for w in rates],
                             scenario.measurement_model,
                             np.full((3, 3), 0.05) + 0.85 * np.eye(3))
    first = scenario.measurements[0]
    means = np.tile([first[0], -30.0, first[1], -30.0], (1, 3, 1))
    covars = np.tile(np.diag([1.0, 25.0, 1.0, 25.0]), (1, 3, 1, 1))
    probs = np.full((1, 3), 1 / 3)
    history = []
    for z in scenario.measurements[1:]:
        means, covars, probs = filt.step(means, covars, probs, z[None], 1.0)
        history.append((means[0], covars[0], probs[0]))
    filtered = [np.array(a) for a in zip(*history)]
    smoothed = filt.smooth(*filtered, 1.0)
    truths, flown = scenario.truths[1:], scenario.turn_rates[1:]
    model_flown = np.select([flown > 0, flown < 0], [0, 2], 1)

    def position_rmse(means, covars, probs):
        x = ft.BatchIMMFilter.combine(means, covars, probs)[0]
        return np.sqrt(np.mean((x[:, 0] - truths[:, 0]) ** 2 + (x[:, 2] - truths[:, 2]) ** 2))

    def mode_accuracy(probs):
        return np.mean(probs.argmax(axis=1) == model_flown)

    assert np.isfinite(smoothed[2]).all()
    np.testing.assert_allclose(smoothed[2].sum(axis=1), 1.0, rtol=1e-12)
    # measured: 0.90 m filtered, 0.59 m smoothed; the flown model 94 % and 99.5 % of steps
    assert position_rmse(*smoothed) < 0.75 * position_rmse(*filtered)
    assert mode_accuracy(smoothed[2]) > mode_accuracy(filtered[2]) + 0.03


@pytest.mark.parametrize("change,error,message", [
    (dict(means=np.zeros((2, 5, 3, 3))), ValueError, r"means must have shape \(K, T, 3, 4\)"),
    (dict(covars=np.zeros((2, 5, 3, 4, 3))), ValueError,
     r"covars must have shape \(2, 5, 3, 4, 4\)"),
    (dict(mode_probs=np.full((2, 5, 3), 0.3)), ValueError,
     r"each row of mode_probs must sum to 1; row 0, 0 sums to 0.899"),
    (dict(time_intervals=[1.0, 1.0]), ValueError, r"time_intervals must hold T - 1 = 4"),
    (dict(time_intervals=[1.0, -1.0, 1.0, 1.0]), ValueError,
     r"time_intervals\[1\] must be >= 0 seconds"),
    (dict(means=np.zeros((2, 0, 3, 4)), covars=np.zeros((2, 0, 3, 4, 4)),
          mode_probs=np.zeros((2, 0, 3))), ValueError, "at least one time step"),
])
def test_bad_input_is_refused_naming_the_argument(change, error, message):
    filt = ft.BatchIMMFilter([_cv(0.01), _cv(1.0), _cv(10.0)], SENSOR, MATRIX)
    means, covars, probs = _filtered(filt, 2, 5)
    arguments = dict(means=means, covars=covars, mode_probs=probs, time_intervals=1.0)
    arguments.update(change)
    with pytest.raises(error, match=message):
        filt.smooth(**arguments)


def test_a_covariance_that_is_not_positive_semi_definite_is_named():
    filt = ft.BatchIMMFilter([_cv(0.01), _cv(1.0), _cv(10.0)], SENSOR, MATRIX)
    means, covars, probs = _filtered(filt, 2, 5)
    covars[1, 3, 2] = -np.eye(4)
    with pytest.raises(ValueError, match=r"covars\[1, 3, 2\] is not symmetric positive "
                                         r"semi-definite"):
        filt.smooth(means, covars, probs, 1.0)
    with pytest.raises(ValueError, match=r"covars\[3, 2\] is not symmetric"):
        filt.smooth(means[1], covars[1], probs[1], 1.0)


def test_a_prediction_that_is_not_positive_definite_is_named():
    static = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.0)] * 2)
    filt = ft.BatchIMMFilter([static, static], SENSOR, [[0.5, 0.5], [0.5, 0.5]])
    means, covars = np.zeros((3, 2, 4)), np.zeros((3, 2, 4, 4))  # exact, and no noise
    with pytest.raises(ValueError, match=r"prediction from step 1 to the next .* is not "
                                         r"positive definite"):
        filt.smooth(means, covars, np.full((3, 2), 0.5), 1.0)
    status = imm_smooth.smooth([static, static], np.full((2, 2), 0.5), means[None],
                               covars[None], np.full((1, 3, 2), 0.5), np.ones(2))[3]
    assert status.tolist() == [2]  # the array layer's status: 1 + the step


def test_filtered_probabilities_the_switching_matrix_cannot_reach_are_named():
    """Model 1 appears although nothing switches into it (the identity matrix): the smoother's
    ratio by its zero predicted probability is undefined (NaN probabilities before)."""
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    filt = ft.BatchIMMFilter([_cv(0.01), _cv(10.0)], sensor, np.eye(2))
    means, covars = np.zeros((3, 2, 4)), np.tile(np.eye(4), (3, 2, 1, 1))
    probs = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match=r"mode_probs\[2\] gives model 1 a probability, but no "
                                         r"model with a probability at mode_probs\[1\]"):
        filt.smooth(means, covars, probs, 1.0)
    with pytest.raises(ValueError, match=r"mode_probs\[1, 2\] gives model 1"):
        filt.smooth(np.stack([means] * 2), np.stack([covars] * 2),
                    np.stack([np.array([[1.0, 0.0]] * 3), probs]), 1.0)
    probs[:2] = [0.5, 0.5]  # model 1 there from the start: reachable, smoothed finitely
    assert np.isfinite(filt.smooth(means, covars, probs, 1.0)[2]).all()


def test_smoothed_states_beyond_float64_are_named():
    """Means of +-1e155 smoothed into NaN and inf covariances silently."""
    models = [ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)
              for q in (0.1, 10.0)]
    bank = ft.BatchIMMFilter(models, ft.LinearGaussian(4, (0, 2), np.eye(2)),
                            np.full((2, 2), 0.5))
    means = np.zeros((5, 2, 4))
    means[:, 0, 0], means[:, 1, 0] = 1e155, -1e155
    with pytest.raises(ValueError, match="the smoothed states are not finite"):
        bank.smooth(means, np.tile(np.eye(4), (5, 2, 1, 1)), np.full((5, 2), 0.5), 1.0)
