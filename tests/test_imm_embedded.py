"""Multiple models of different state components: a constant-velocity model embedded in a
constant-acceleration state by an explicit map. The kernels against their mirrors and the
general path, the conversion of one model into another's components, an accelerating
target filtered and smoothed, the smoother without switching, the class pair against the
batch, and bad maps."""
import numpy as np
import pytest

import fasttrack as ft
from fasttrack.core import imm
from fasttrack.models.transition import EmbeddedTransitionModel

CA_STATE = (0, 1, 3, 4)  # x, vx, y, vy in (x, vx, ax, y, vy, ay)
SENSOR = ft.LinearGaussian(6, (0, 3), np.diag([0.5, 0.5]))
MATRIX = np.array([[0.9, 0.1], [0.2, 0.8]])


def _models(q_cv=0.05, q_ca=0.5):
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q_cv)] * 2)
    ca = ft.CombinedLinearGaussianTransitionModel([ft.ConstantAcceleration(q_ca)] * 2)
    return [EmbeddedTransitionModel(cv, CA_STATE, 6), ca]


def _random_states(rng, k):
    """K filters' (CV, CA) states: the CV model's acceleration components 0."""
    means = rng.normal(size=(k, 2, 6)) * 3.0
    a = rng.normal(size=(k, 2, 6, 6))
    covars = a @ a.swapaxes(-1, -2) + np.eye(6)
    lacks = [2, 5]
    means[:, 0, lacks] = 0.0
    covars[:, 0, lacks, :] = 0.0
    covars[:, 0, :, lacks] = 0.0
    return means, covars, rng.dirichlet(np.ones(2), size=k)


def test_an_embedded_model_acts_on_its_components_and_carries_the_others():
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.3)] * 2)
    model = EmbeddedTransitionModel(cv, CA_STATE, 6)
    f, q = model.matrix(2.0), model.covar(2.0)
    np.testing.assert_array_equal(f[np.ix_(CA_STATE, CA_STATE)], cv.matrix(2.0))
    np.testing.assert_array_equal(q[np.ix_(CA_STATE, CA_STATE)], cv.covar(2.0))
    assert f[2, 2] == f[5, 5] == 1.0 and q[2].sum() == q[:, 5].sum() == 0.0
    assert imm.components(_models(), 6).tolist() == [[True, True, False, True, True, False],
                                                     [True] * 6]


@pytest.mark.parametrize("algorithm", imm.ALGORITHMS)
def test_the_kernel_is_its_mirror_and_the_general_path(algorithm):
    from fasttrack._jit import imm as kernels
    from reference import imm as mirror
    rng = np.random.default_rng(3)
    models = _models()
    has = imm.components(models, 6)
    k = 6
    means, covars, probs = _random_states(rng, k)
    z = rng.normal(size=(k, 2)) * 3.0
    arguments = (imm.ALGORITHMS.index(algorithm), np.array([m.matrix(1.0) for m in models]),
                 np.array([m.covar(1.0) for m in models]), SENSOR.spec.mapping,
                 SENSOR.noise_covar, MATRIX, has, means, covars, probs, z)
    results = []
    for module in (kernels, mirror):
        out = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
               np.ones(k, dtype=np.int64)]
        module.imm_linear_step(*arguments, *out)
        assert not out[3].any()
        results.append(out[:3])
    general = imm.general_step(models, SENSOR, MATRIX, means, covars, probs, z, np.ones(k),
                               algorithm, has)
    for a_, b_, c_ in zip(*results, general):
        np.testing.assert_allclose(a_, b_, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(a_, c_, rtol=1e-9, atol=1e-9)
    assert np.all(results[0][0][:, 0, [2, 5]] == 0.0)  # what the CV model lacks stays 0
    assert np.all(results[0][1][:, 0, [2, 5], :] == 0.0)


def test_a_model_entering_another_brings_what_it_has_and_borrows_the_rest():
    rng = np.random.default_rng(5)
    means, covars, _ = _random_states(rng, 1)
    has = imm.components(_models(), 6)
    x, p = imm.converted(means, covars, has)
    into_ca = (x[0, 0, 1], p[0, 0, 1])  # the CV model's state in the CA model's components
    np.testing.assert_array_equal(into_ca[0][list(CA_STATE)], means[0, 0, list(CA_STATE)])
    np.testing.assert_array_equal(into_ca[0][[2, 5]], means[0, 1, [2, 5]])
    np.testing.assert_array_equal(into_ca[1][np.ix_(CA_STATE, CA_STATE)],
                                  covars[0, 0][np.ix_(CA_STATE, CA_STATE)])
    np.testing.assert_array_equal(into_ca[1][np.ix_([2, 5], [2, 5])],
                                  covars[0, 1][np.ix_([2, 5], [2, 5])])
    assert not into_ca[1][np.ix_(CA_STATE, [2, 5])].any()  # no invented correlation
    assert np.linalg.eigvalsh(into_ca[1]).min() > 0
    mixed = imm.mix(means, covars, np.array([[1.0, 0.0]]), np.array([[0.0, 1.0], [0.0, 1.0]]),
                    has)  # the CA model's prior from the CV model alone
    np.testing.assert_allclose(mixed[1][0, 1], into_ca[1], rtol=1e-12)


def _burn():
    """A target that accelerates for 20 s of 120: its states (120, 6) and position
    measurements (120, 2)."""
    rng = np.random.default_rng(7)
    x = np.array([0.0, 10.0, 0.0, 0.0, 5.0, 0.0])
    truths, scans = [], []
    for t in range(120):
        x = x.copy()
        x[[2, 5]] = [3.0, -2.0] if 40 <= t < 60 else [0.0, 0.0]  # a 20 s burn
        x = _models()[1].matrix(1.0) @ x
        truths.append(x)
        scans.append(x[[0, 3]] + rng.normal(size=2) * 0.7)
    return np.array(truths), np.array(scans)


def test_an_accelerating_target_is_followed_better_with_the_acceleration_model():
    truths, scans = _burn()

    def run(filt, models):
        m = len(models)
        means = np.tile([0.0, 10.0, 0.0, 0.0, 5.0, 0.0], (1, m, 1))
        covars = np.tile(np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 1.0]), (1, m, 1, 1))
        probs, errors, history = np.full((1, m), 1.0 / m), [], []
        for z, truth in zip(scans, truths):
            means, covars, probs = filt.step(means, covars, probs, z[None], 1.0)
            estimate = ft.BatchIMMFilter.combine(means, covars, probs)[0][0]
            errors.append(np.hypot(*(estimate[[0, 3]] - truth[[0, 3]])))
            history.append(probs[0, -1])
        return np.sqrt(np.mean(np.square(errors))), np.array(history)

    both = _models()
    imm_error, ca_prob = run(ft.BatchIMMFilter(both, SENSOR, MATRIX), both)
    cv_error, _ = run(ft.BatchIMMFilter(both[:1], SENSOR, [[1.0]]), both[:1])
    # measured: 0.71 m against 3.12 m; the CA model's probability 0.85 in the burn, 0.10 after
    assert imm_error < 0.5 * cv_error
    assert ca_prob[45:60].mean() > 0.8 > ca_prob[80:].mean()


def test_the_pair_equals_the_batch_with_embedded_models():
    models = _models()
    predictor = ft.IMMPredictor([ft.KalmanPredictor(m) for m in models], MATRIX)
    updater = ft.IMMUpdater([ft.KalmanUpdater(SENSOR)] * 2, MATRIX)
    batch = ft.BatchIMMFilter(models, SENSOR, MATRIX)
    rng = np.random.default_rng(9)
    means, covars, probs = _random_states(rng, 1)
    state = ft.GaussianMixture([ft.WeightedGaussianState(m, c, weight=w, timestamp=0.0)
                                for m, c, w in zip(means[0], covars[0], probs[0])])
    for t in range(1, 6):
        z = rng.normal(size=2) * 3.0
        prediction = predictor.predict(state, timestamp=float(t))
        state = updater.update(ft.SingleHypothesis(prediction, ft.Detection(
            z, timestamp=float(t), measurement_model=SENSOR)))
        means, covars, probs = batch.step(means, covars, probs, z[None], 1.0)
        np.testing.assert_allclose(state.means, means[0], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(state.covars, covars[0], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(np.exp(state.log_weights), probs[0], rtol=1e-9)


def test_the_smoother_kernel_is_its_mirror_with_embedded_models():
    from fasttrack._jit import imm_smooth as kernels
    from reference import imm_smooth as mirror
    rng = np.random.default_rng(11)
    models = _models()
    has = imm.components(models, 6)
    k, n = 3, 9
    means, covars, _ = _random_states(rng, k * n)
    means, covars = means.reshape(k, n, 2, 6), covars.reshape(k, n, 2, 6, 6)
    probs = rng.dirichlet(np.ones(2), size=(k, n))
    transitions = np.array([[m.matrix(1.0) for m in models]])
    noises = np.array([[m.covar(1.0) for m in models]])
    arguments = (transitions, np.zeros((1, 2, 6)), noises, np.zeros((k, n, 2), dtype=np.int64),
                 np.zeros(n, dtype=np.int64), MATRIX, has, means, covars, probs)
    results = []
    for module in (kernels, mirror):
        out = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
               np.ones(k, dtype=np.int64)]
        module.imm_smooth(*arguments, *out)
        assert not out[3].any()
        results.append(out[:3])
    for a_, b_ in zip(*results):
        np.testing.assert_allclose(a_, b_, rtol=1e-8, atol=1e-8)
    assert not results[0][0][..., 0, [2, 5]].any()  # what the CV model lacks stays 0
    assert not results[0][1][..., 0, [2, 5], :].any()
    assert np.abs(results[0][0] - means).max() > 0.1  # smoothing moved the states


def test_without_switching_each_embedded_model_is_its_own_smoother():
    """With no switching, the constant-velocity model embedded in the acceleration state
    smooths as the constant-velocity smoother on its own four components."""
    models = _models()
    batch = ft.BatchIMMFilter(models, SENSOR, np.eye(2))
    rng = np.random.default_rng(12)
    means, covars, probs = np.zeros((1, 2, 6)), np.tile(np.eye(6), (1, 2, 1, 1)), [[0.5, 0.5]]
    means[:, 0, [2, 5]] = 0.0
    covars[:, 0, [2, 5], [2, 5]] = 0.0
    filtered = [], [], []
    for t in range(20):
        means, covars, probs = batch.step(means, covars, probs, rng.normal(size=(1, 2)) * 3.0,
                                          1.0)
        for stack, value in zip(filtered, (means[0], covars[0], probs[0])):
            stack.append(value)
    filtered = [np.array(stack) for stack in filtered]
    smoothed = batch.smooth(*filtered, 1.0)
    cv = ft.BatchIMMFilter([models[0].model], ft.LinearGaussian(4, (0, 2), SENSOR.noise_covar),
                           [[1.0]])
    alone = cv.smooth(filtered[0][:, :1][..., list(CA_STATE)],
                      filtered[1][:, :1][..., CA_STATE, :][..., CA_STATE],
                      np.ones((20, 1)), 1.0)
    np.testing.assert_allclose(smoothed[0][:, 0][:, list(CA_STATE)], alone[0][:, 0],
                               rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(smoothed[1][:, 0][:, CA_STATE][..., CA_STATE], alone[1][:, 0],
                               rtol=1e-9, atol=1e-9)


def test_an_accelerating_target_is_smoothed_better_than_filtered():
    truths, scans = _burn()
    batch = ft.BatchIMMFilter(_models(), SENSOR, MATRIX)
    means = np.tile([0.0, 10.0, 0.0, 0.0, 5.0, 0.0], (1, 2, 1))
    covars = np.tile(np.eye(6), (1, 2, 1, 1))
    means[:, 0, [2, 5]] = 0.0
    covars[:, 0, [2, 5], [2, 5]] = 0.0
    probs, filtered = np.full((1, 2), 0.5), ([], [], [])
    for z in scans:
        means, covars, probs = batch.step(means, covars, probs, z[None], 1.0)
        for stack, value in zip(filtered, (means[0], covars[0], probs[0])):
            stack.append(value)
    filtered = [np.array(stack) for stack in filtered]
    smoothed = batch.smooth(*filtered, 1.0)
    errors = [np.sqrt(np.mean(np.sum((batch.combine(*arrays)[0][:, [0, 3]]
                                      - truths[:, [0, 3]]) ** 2, axis=1)))
              for arrays in (filtered, smoothed)]
    # measured: 0.71 m filtered, 0.47 m smoothed
    assert errors[1] < 0.8 * errors[0]
    assert not smoothed[0][:, 0, [2, 5]].any()


def test_bad_maps_are_refused():
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1)] * 2)
    for state_map in ((0, 1, 3), (0, 1, 3, 3), (0, 1, 3, 6), (0.0, 1.0, 3.0, 4.0)):
        with pytest.raises(ValueError, match=r"state_map must be 4 distinct indices in "
                                             r"\[0, 6\)"):
            EmbeddedTransitionModel(cv, state_map, 6)
    with pytest.raises(TypeError, match="model must be a linear transition model"):
        EmbeddedTransitionModel(ft.CartesianToBearingRange(4, (0, 2), np.eye(2)), CA_STATE, 6)


def test_an_ekf_imm_of_straight_flight_and_a_turn_estimates_the_turn_rate():
    """A constant-velocity model embedded in a constant-turn state (x, vx, y, vy, w) and
    the turn model through the extended Kalman filter, on the multiple-model tutorial's
    flight: the turn model's rate follows the turns flown."""
    from fasttrack.scenarios import manoeuvring_target
    scenario = manoeuvring_target(seed=3)
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1e-2)] * 2)
    models = [EmbeddedTransitionModel(cv, (0, 1, 2, 3), 5), ft.ConstantTurn([1e-2, 1e-2], 1e-6)]
    sensor = ft.LinearGaussian(5, (0, 2), np.diag([0.725, 0.7025]))
    matrix = np.array([[0.95, 0.05], [0.05, 0.95]])
    predictor = ft.IMMPredictor([ft.KalmanPredictor(models[0]),
                                 ft.ExtendedKalmanPredictor(models[1])], matrix)
    updater = ft.IMMUpdater([ft.KalmanUpdater(sensor)] * 2, matrix)
    x, y = scenario.measurements[0]
    start = [ft.WeightedGaussianState([x, -30.0, y, -30.0, 0.0],
                                      np.diag([1.0, 25.0, 1.0, 25.0, 1e-4]), weight=0.5,
                                      timestamp=0.0)] * 2
    state, rates, turn_probs, errors = ft.GaussianMixture(start), [], [], []
    for t, (z, truth) in enumerate(zip(scenario.measurements[1:], scenario.truths[1:]), 1):
        prediction = predictor.predict(state, timestamp=float(t))
        state = updater.update(ft.SingleHypothesis(prediction, ft.Detection(
            z, timestamp=float(t), measurement_model=sensor)))
        rates.append(state.means[1, 4])
        turn_probs.append(np.exp(state.log_weights[1]))
        errors.append(np.hypot(*(state.mean[[0, 2], 0] - truth[[0, 2]])))
    rates, turn_probs, flown = np.array(rates), np.array(turn_probs), scenario.turn_rates[1:]
    right, left = slice(200, 340), slice(420, 545)  # well inside the turns
    # measured: rates -0.01640 and 0.02313 rad/s (flown -0.01634, 0.0232); the turn model's
    # probability 0.89 in the right turn, 0.40 on the straight (a turn of rate 0 is
    # straight flight too); 0.82 m position RMSE
    assert abs(np.median(rates[right]) - flown[250]) < 0.002
    assert abs(np.median(rates[left]) - flown[450]) < 0.002
    assert turn_probs[right].mean() > 0.7 and turn_probs[60:140].mean() < 0.5
    assert np.sqrt(np.mean(np.square(errors))) < 1.2
