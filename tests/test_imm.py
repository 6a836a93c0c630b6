"""IMM on stacks: the closed forms of the interacting multiple model filter (one model is the
Kalman filter; identical models keep the stationary mode distribution; an absorbing mode
halves each step), a model that fits winning, a far measurement leaving finite
probabilities, the batch against a step-by-step evaluation of the formulas, and bad input."""
import numpy as np
import pytest
from scipy.stats import multivariate_normal

import fasttrack as ft
from fasttrack.core import imm
from fasttrack._jit.tunables import FILTERS_PER_BLOCK

SENSOR = ft.LinearGaussian(4, (0, 2), np.diag([0.5, 0.5]))


def _cv(q):
    return ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)


def _priors(k, models, seed=0):
    rng = np.random.default_rng(seed)
    means = np.repeat(rng.normal(size=(k, 1, 4)) * [10.0, 1.0, 10.0, 1.0], models, axis=1)
    covars = np.broadcast_to(np.diag([4.0, 1.0, 4.0, 1.0]), (k, models, 4, 4)).copy()
    return means, covars


def test_one_model_is_the_kalman_filter():
    means, covars = _priors(5, 1)
    z = np.random.default_rng(1).normal(size=(5, 2)) * 10.0
    filt = ft.BatchIMMFilter([_cv(0.1)], SENSOR, [[1.0]])
    got = filt.step(means, covars, np.ones((5, 1)), z, 2.0)
    batch = ft.BatchExtendedKalmanFilter(_cv(0.1), SENSOR)
    want = batch.step(means[:, 0], covars[:, 0], z, 2.0)
    np.testing.assert_allclose(got[0][:, 0], want[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got[1][:, 0], want[1], rtol=1e-12, atol=1e-12)
    assert (got[2] == 1.0).all()


def test_identical_models_keep_the_stationary_mode_probabilities():
    matrix = np.array([[0.8, 0.2], [0.4, 0.6]])
    stationary = np.array([2.0, 1.0]) / 3.0  # the left eigenvector of the matrix
    filt = ft.BatchIMMFilter([_cv(0.1), _cv(0.1)], SENSOR, matrix)
    kalman = ft.BatchExtendedKalmanFilter(_cv(0.1), SENSOR)
    means, covars = _priors(3, 2)
    probs = np.tile(stationary, (3, 1))
    x, p = means[:, 0], covars[:, 0]
    rng = np.random.default_rng(2)
    for _ in range(20):
        z = rng.normal(size=(3, 2)) * 5.0
        means, covars, probs = filt.step(means, covars, probs, z, 1.0)
        x, p = kalman.step(x, p, z, 1.0)
        np.testing.assert_allclose(probs, np.tile(stationary, (3, 1)), rtol=1e-12)
        for j in range(2):
            np.testing.assert_allclose(means[:, j], x, rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(covars[:, j], p, rtol=1e-10, atol=1e-10)


def test_an_absorbing_mode_halves_the_other_each_step():
    filt = ft.BatchIMMFilter([_cv(0.1), _cv(0.1)], SENSOR, [[0.5, 0.5], [0.0, 1.0]])
    means, covars = _priors(1, 2)
    probs = np.array([[0.5, 0.5]])
    for i in range(1, 30):
        means, covars, probs = filt.step(means, covars, probs, [[float(i), 0.0]], 1.0)
        assert probs[0, 0] == pytest.approx(0.5 ** (i + 1), rel=1e-12)


def test_the_model_that_fits_wins_and_a_far_measurement_leaves_finite_probabilities():
    # the truth turns hard; a quiet constant-velocity model cannot follow, a noisy one can
    filt = ft.BatchIMMFilter([_cv(1e-4), _cv(5.0)], SENSOR, [[0.95, 0.05], [0.05, 0.95]])
    means, covars = _priors(1, 2)
    means[:] = 0.0
    probs = np.array([[0.5, 0.5]])
    wins = []
    for t in range(1, 40):
        z = [[10.0 * np.sin(0.3 * t) * t, 10.0 * np.cos(0.3 * t) * t]]
        means, covars, probs = filt.step(means, covars, probs, z, 1.0)
        wins.append(probs[0, 1])
    assert np.mean(wins[10:]) > 0.95
    means, covars, probs = filt.step(means, covars, probs, [[1e6, -1e6]], 1.0)  # 1e4 sigma
    assert np.isfinite(probs).all() and probs.sum() == pytest.approx(1.0, rel=1e-12)
    assert np.isfinite(means).all() and np.isfinite(covars).all()


@pytest.mark.parametrize("order", [None, 1, 2])
def test_a_measurement_beyond_every_likelihood_is_named(order):
    """At 1e160 every model's squared Mahalanobis distance is beyond the float range: no
    model can be weighed (NaN probabilities before); at 1e12 the weights stay finite."""
    models, matrix = [_cv(0.01), _cv(10.0)], [[0.95, 0.05], [0.05, 0.95]]
    filt = ft.BatchIMMFilter(models, SENSOR, matrix) if order is None \
        else ft.BatchGPBFilter(models, SENSOR, matrix, order=order)
    means, covars = np.zeros((2, 2, 4)), np.tile(np.eye(4), (2, 2, 1, 1))
    probs = np.full((2, 2), 0.5)
    assert np.isfinite(filt.step(means, covars, probs, [[0.0, 0.0], [1e12, 0.0]], 1.0)[2]).all()
    with pytest.raises(ValueError, match=r"measurements\[1\] lies so far from every model's "
                                         r"prediction that its likelihood rounds to 0"):
        filt.step(means, covars, probs, [[0.0, 0.0], [1e160, 0.0]], 1.0)


def test_a_measurement_that_is_not_finite_is_named_as_such_on_the_kernel_path():
    """The fused update left NaN weights for a NaN measurement (named 'so far from every
    model'): the general path, which names it, takes it."""
    from fasttrack.core import imm as core_imm
    means, covars = np.zeros((2, 2, 4)), np.tile(np.eye(4), (2, 2, 1, 1))
    predicted = np.full((2, 2), 0.5)
    assert core_imm.update(SENSOR, means, covars, predicted, np.array([[0.0, 0.0],
                                                                     [np.nan, 1.0]])) is None
    filt = ft.BatchIMMFilter([_cv(0.01), _cv(10.0)], SENSOR, [[0.95, 0.05], [0.05, 0.95]])
    with pytest.raises(ValueError, match="measurements contains NaN"):
        filt.step(means, covars, predicted, [[0.0, 0.0], [np.nan, 1.0]], 1.0)


@pytest.mark.parametrize("measurements, states", [((2, 1), 4), ((2, 3), 4), ((2, 2), 3)])
def test_the_fused_update_refuses_arrays_its_kernel_would_index_past(measurements, states):
    """A measurement of 1 value for a 2-value sensor was read past its end."""
    means, covars = np.zeros((2, 2, states)), np.tile(np.eye(states), (2, 2, 1, 1))
    with pytest.raises(ValueError, match=r"measurements must be 2 measurements of 2 values "
                                         r"of states of 4 \(the measurement model's\)"):
        imm.update(SENSOR, means, covars, np.full((2, 2), 0.5), np.zeros(measurements))


@pytest.mark.parametrize("updater", [ft.KalmanUpdater, ft.ExtendedKalmanUpdater,
                                     ft.UnscentedKalmanUpdater])
def test_the_pair_names_a_measurement_beyond_every_likelihood(updater):
    matrix = [[0.95, 0.05], [0.05, 0.95]]
    prior = ft.GaussianMixture([ft.WeightedGaussianState(np.zeros(4), np.eye(4), weight=0.5,
                                                         timestamp=0.0)] * 2)
    prediction = ft.IMMPredictor([ft.KalmanPredictor(_cv(0.01)), ft.KalmanPredictor(_cv(10.0))],
                                 matrix).predict(prior, 1.0)
    pair = ft.IMMUpdater([updater(SENSOR)] * 2, matrix)
    with pytest.raises(ValueError, match="hypothesis.measurement lies so far from every model"):
        pair.update(ft.SingleHypothesis(prediction, ft.Detection(
            [[1e160], [0.0]], timestamp=1.0, measurement_model=SENSOR)))


def _formulas(transition_models, matrix, means, covars, probs, z, dt):
    """One IMM step of one filter, formula by formula (Bar-Shalom, Li and Kirubarajan)."""
    m = len(transition_models)
    cbar = probs @ matrix
    out_means, out_covars, likelihoods = [], [], []
    h = np.zeros((2, 4))
    h[0, 0] = h[1, 2] = 1.0
    for j, model in enumerate(transition_models):
        w = matrix[:, j] * probs / cbar[j]
        x0 = sum(w[i] * means[i] for i in range(m))
        p0 = sum(w[i] * (covars[i] + np.outer(means[i] - x0, means[i] - x0)) for i in range(m))
        f, q = model.matrix(dt), model.covar(dt)
        x, p = f @ x0, f @ p0 @ f.T + q
        s = h @ p @ h.T + SENSOR.noise_covar
        k = p @ h.T @ np.linalg.inv(s)
        out_means.append(x + k @ (z - h @ x))
        i_kh = np.eye(4) - k @ h
        out_covars.append(i_kh @ p @ i_kh.T + k @ SENSOR.noise_covar @ k.T)
        likelihoods.append(multivariate_normal.pdf(z, h @ x, s))
    mu = cbar * np.array(likelihoods)
    return np.array(out_means), np.array(out_covars), mu / mu.sum()


@pytest.mark.parametrize("seed", range(3))
def test_the_batch_is_the_formulas_filter_by_filter(seed):
    models = [_cv(0.01), _cv(1.0), _cv(10.0)]
    rng = np.random.default_rng(seed)
    matrix = rng.dirichlet(np.ones(3) * 2, size=3)
    k = 7
    means = rng.normal(size=(k, 3, 4)) * 5.0
    a = rng.normal(size=(k, 3, 4, 4))
    covars = a @ a.swapaxes(-1, -2) + np.eye(4)
    probs = rng.dirichlet(np.ones(3), size=k)
    z = rng.normal(size=(k, 2)) * 5.0
    dt = rng.uniform(0.5, 2.0, k)
    got = ft.BatchIMMFilter(models, SENSOR, matrix).step(means, covars, probs, z, dt)
    for f in range(k):
        want = _formulas(models, matrix, means[f], covars[f], probs[f], z[f], dt[f])
        for a_, b_ in zip(got, want):
            np.testing.assert_allclose(a_[f], b_, rtol=1e-9, atol=1e-9)
    combined = ft.BatchIMMFilter.combine(*got)
    np.testing.assert_allclose(combined[0], np.einsum("kj,kjd->kd", got[2], got[0]))


def test_a_model_that_cannot_be_reached_keeps_its_state_and_probability_zero():
    filt = ft.BatchIMMFilter([_cv(0.1), _cv(1.0)], SENSOR, [[1.0, 0.0], [0.0, 1.0]])
    means, covars = _priors(2, 2)
    means[:, 1] += 3.0
    mixed = imm.mix(means, covars, np.array([[1.0, 0.0], [1.0, 0.0]]), filt.transition_matrix)
    np.testing.assert_array_equal(mixed[0], means)  # no mixing between the models
    out = filt.step(means, covars, [[1.0, 0.0], [1.0, 0.0]], [[0.0, 0.0], [1.0, 1.0]], 1.0)
    assert (out[2][:, 1] == 0.0).all() and np.isfinite(out[0]).all()


@pytest.mark.parametrize("change,error,message", [
    (dict(transition_matrix=[[0.5, 0.6], [0.5, 0.5]]), ValueError,
     r"each row of transition_matrix must sum to 1.*row 0 sums to 1.1"),
    (dict(transition_matrix=[[1.2, -0.2], [0.5, 0.5]]), ValueError, "no negative entries"),
    (dict(transition_matrix=np.eye(3)), ValueError, r"must have shape \(2, 2\)"),
    (dict(transition_models=[]), ValueError, "at least one model"),
    (dict(transition_models=[_cv(1.0), ft.ConstantVelocity(1.0)]), ValueError,
     r"transition model 1 \(ConstantVelocity\) has 2 state dimensions, the state 4: embed "
     r"a model of fewer in the state with EmbeddedTransitionModel"),
])
def test_bad_filters_are_refused_naming_the_argument(change, error, message):
    arguments = dict(transition_models=[_cv(1.0), _cv(2.0)], measurement_model=SENSOR,
                     transition_matrix=[[0.9, 0.1], [0.1, 0.9]])
    arguments.update(change)
    with pytest.raises(error, match=message):
        ft.BatchIMMFilter(**arguments)


@pytest.mark.parametrize("kernels", [True, False])
@pytest.mark.parametrize("change,message", [
    (dict(mode_probs=[[0.5, 0.6]]), r"each row of mode_probs must sum to 1; row 0"),
    (dict(mode_probs=[[1.5, -0.5]]), "mode_probs must have no negative entries"),
    (dict(mode_probs=[[np.nan, 0.5]]), "mode_probs contains NaN"),
    (dict(mode_probs=[[0.5, 0.5], [0.5, 0.5]]), r"mode_probs must have shape \(1, 2\)"),
    (dict(means=np.zeros((1, 3, 4))), r"means must have shape \(K, 2, 4\)"),
    (dict(means=np.full((1, 2, 4), np.nan)), "means contains NaN"),
    (dict(covars=np.full((1, 2, 4, 4), np.inf)), "covars contains infinite values"),
    (dict(covars=np.stack([np.eye(4), np.triu(np.ones((4, 4)))])[None]),
     r"covars\[0, 1\] is not symmetric"),
    (dict(covars=np.stack([np.diag([-1.0, 1.0, 1.0, 1.0]), np.eye(4)])[None]),
     r"covars\[0, 0\] is not positive semi-definite"),
    (dict(measurements=[[0.0, np.nan]]), "measurements contains NaN"),
    (dict(time_intervals=[1.0, 2.0]), r"time_intervals \(seconds\) must broadcast"),
    (dict(time_intervals=np.nan), "time_intervals contains NaN"),
])
@pytest.mark.parametrize("order", [0, 2])
def test_bad_steps_are_refused_naming_the_argument(change, message, kernels, order,
                                                   monkeypatch):
    """Whether the values are checked in a kernel (the process runs kernels) or in NumPy,
    for the IMM and GPB2 (an asymmetric covariance is not mixed away)."""
    from fasttrack import _jit
    if kernels:
        from fasttrack._jit import imm as _loaded  # noqa: F401 (loads the kernels)
    else:
        monkeypatch.setattr(_jit, "kernels_loaded", lambda: False)
    models, matrix = [_cv(1.0), _cv(2.0)], [[0.9, 0.1], [0.1, 0.9]]
    filt = ft.BatchGPBFilter(models, SENSOR, matrix, order=order) if order \
        else ft.BatchIMMFilter(models, SENSOR, matrix)
    means, covars = _priors(1, 2)
    arguments = dict(means=means, covars=covars, mode_probs=[[0.5, 0.5]],
                     measurements=[[0.0, 1.0]], time_intervals=1.0)
    arguments.update(change)
    with pytest.raises(ValueError, match=message):
        filt.step(**arguments)


def test_equals_filterpys_imm_estimator_every_step_of_a_manoeuvring_run():
    kalman = pytest.importorskip("filterpy.kalman")
    models = [_cv(0.01), _cv(1.0), _cv(20.0)]
    matrix = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.05, 0.15, 0.8]])
    h = np.zeros((2, 4))
    h[0, 0] = h[1, 2] = 1.0
    x0, p0 = np.array([0.0, 5.0, 0.0, 0.0]), np.diag([10.0, 2.0, 10.0, 2.0])
    filters = []
    for model in models:
        f = kalman.KalmanFilter(dim_x=4, dim_z=2)
        f.F, f.Q, f.H, f.R = model.matrix(1.0), model.covar(1.0), h, SENSOR.noise_covar
        f.x, f.P = x0.copy(), p0.copy()
        filters.append(f)
    mu0 = np.array([0.6, 0.3, 0.1])
    theirs = kalman.IMMEstimator(filters, mu0, matrix)
    ours = ft.BatchIMMFilter(models, SENSOR, matrix)
    means, covars = np.tile(x0, (1, 3, 1)), np.tile(p0, (1, 3, 1, 1))
    probs = mu0[None].copy()
    rng = np.random.default_rng(4)
    position, velocity = np.zeros(2), np.array([5.0, 0.0])
    quiet = []  # the quiet model's probability: high on the straight, low in the turn
    for t in range(60):
        if 20 <= t < 35:  # a hard turn
            velocity = np.array([[np.cos(0.2), -np.sin(0.2)], [np.sin(0.2), np.cos(0.2)]]) \
                @ velocity
        position = position + velocity
        z = position + rng.normal(size=2) * 0.7
        theirs.predict()
        theirs.update(z)
        means, covars, probs = ours.step(means, covars, probs, z[None], 1.0)
        np.testing.assert_allclose(probs[0], theirs.mu, rtol=1e-9, atol=1e-12)
        for j, f in enumerate(filters):
            np.testing.assert_allclose(means[0, j], f.x, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(covars[0, j], f.P, rtol=1e-9, atol=1e-9)
        x, p = ft.BatchIMMFilter.combine(means, covars, probs)
        np.testing.assert_allclose(x[0], theirs.x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(p[0], theirs.P, rtol=1e-9, atol=1e-9)
        quiet.append(probs[0, 0])
    assert max(quiet) > 0.9 and min(quiet) < 0.2  # the models switched: not a trivial run


def test_the_step_inputs_check_is_its_mirror():
    from fasttrack._jit import imm as kernels
    from reference import imm as mirror
    rng = np.random.default_rng(5)
    means, a = rng.normal(size=(6, 3, 4)), rng.normal(size=(6, 3, 4, 4))
    covars = a @ a.swapaxes(-1, -2)
    covars[2, 1] = 0.0
    covars[2, 1, :2, :2] = [[1.0, 0.5], [0.5, 2.0]]  # singular is legal
    probs, z = rng.dirichlet(np.ones(3), size=6), rng.normal(size=(6, 2))
    spoilt = [(0, (2, 1, 3), np.nan), (1, (5, 2, 0, 1), -np.inf), (3, (0, 1), np.inf),
              (2, (3, 1), np.nan), (2, (1, 0), -0.1), (2, (4, 2), 0.5),
              (1, (4, 0, 3, 1), 100.0), (1, (2, 1, 3, 3), -1e-3),
              (1, (2, 1, 0, 3), 1e-3)]  # (array, entry, value)
    verdicts = []
    for which, index, value in [(None, None, None)] + spoilt:
        arrays = [a.copy() for a in (means, covars, probs, z)]
        if which is not None:
            arrays[which][index] = value
        got = kernels.step_inputs_valid(*arrays, imm.SUM_TOLERANCE)
        assert got == mirror.step_inputs_valid(*arrays, imm.SUM_TOLERANCE)
        verdicts.append(got)
    assert verdicts == [True] + [False] * len(spoilt)


@pytest.mark.parametrize("algorithm", imm.ALGORITHMS)
@pytest.mark.parametrize("seed, k", [(0, 1), (1, 9), (2, 9), (3, FILTERS_PER_BLOCK + 3)])
def test_the_kernel_is_its_mirror_and_the_general_path(seed, k, algorithm):
    """One filter, a few, and more than a block of them (the last block part-full)."""
    from fasttrack._jit import imm as kernels
    from reference import imm as mirror
    rng = np.random.default_rng(seed)
    models = [_cv(0.01), _cv(1.0), _cv(10.0)]
    matrix = rng.dirichlet(np.ones(3) * 2, size=3)
    matrix[1:, 0] = 0.0  # model 0 is reached from itself only
    matrix /= matrix.sum(axis=1, keepdims=True)
    means = rng.normal(size=(k, 3, 4)) * 5.0
    a = rng.normal(size=(k, 3, 4, 4))
    covars = a @ a.swapaxes(-1, -2) + np.eye(4)
    probs = rng.dirichlet(np.ones(3), size=k)
    probs[0] = [0.0, 0.0, 1.0]  # nothing switches into model 0 for filter 0
    z = rng.normal(size=(k, 2)) * 5.0
    arguments = (imm.ALGORITHMS.index(algorithm), np.array([m.matrix(1.5) for m in models]),
                 np.array([m.covar(1.5) for m in models]), SENSOR.spec.mapping,
                 SENSOR.noise_covar, matrix, np.ones((3, 4), dtype=bool), means, covars, probs,
                 z)
    got = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
           np.zeros(k, dtype=np.int64)]
    want = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
            np.zeros(k, dtype=np.int64)]
    kernels.imm_linear_step(*arguments, *got)
    mirror.imm_linear_step(*arguments, *want)
    assert (got[3] == 0).all() and (want[3] == 0).all()
    for a_, b_ in zip(got[:3], want[:3]):
        np.testing.assert_allclose(a_, b_, rtol=1e-9, atol=1e-9)
    assert got[2][0, 0] == 0.0  # nothing switches into model 0 of filter 0
    filt = (ft.BatchIMMFilter(models, SENSOR, matrix) if algorithm == "imm"
            else ft.BatchGPBFilter(models, SENSOR, matrix, order=int(algorithm[-1])))
    fused = filt.step(means, covars, probs, z, 1.5)  # the kernel: one interval, a selection
    general = imm.general_step(models, SENSOR, matrix, means, covars, probs, z,
                               np.full(k, 1.5), algorithm)
    for a_, b_, c_ in zip(fused, general, got):
        np.testing.assert_allclose(a_, b_, rtol=1e-9, atol=1e-9)
        np.testing.assert_array_equal(a_, c_)


def test_a_changed_noise_rate_changes_the_step():
    quiet, loud = ft.ConstantVelocity(0.1), ft.ConstantVelocity(0.1)
    models = [ft.CombinedLinearGaussianTransitionModel([quiet] * 2),
              ft.CombinedLinearGaussianTransitionModel([loud] * 2)]
    filt = ft.BatchIMMFilter(models, SENSOR, [[0.9, 0.1], [0.1, 0.9]])
    means, covars = _priors(1, 2)
    before = filt.step(means, covars, [[0.5, 0.5]], [[3.0, -2.0]], 1.0)
    loud.noise_diff_coeff = 5.0  # the step's F and Q are remembered by interval and rates
    after = filt.step(means, covars, [[0.5, 0.5]], [[3.0, -2.0]], 1.0)
    np.testing.assert_array_equal(after[0][:, 0], before[0][:, 0])
    assert not np.allclose(after[1][:, 1], before[1][:, 1])
    want = imm.general_step(models, SENSOR, filt.transition_matrix, means, covars,
                            np.array([[0.5, 0.5]]), np.array([[3.0, -2.0]]), np.array([1.0]))
    for a_, b_ in zip(after, want):  # the general path builds F and Q afresh
        np.testing.assert_allclose(a_, b_, rtol=1e-9, atol=1e-12)


def test_three_turn_models_follow_the_manoeuvres():
    from fasttrack.scenarios import MANOEUVRES, manoeuvring_target
    scenario = manoeuvring_target(seed=1)
    assert scenario.truths.shape == (sum(n for n, _ in MANOEUVRES), 4)
    rates = (0.02, 0.0, -0.02)
    imm_filter = ft.BatchIMMFilter([ft.KnownTurnRate([1e-3, 1e-3], w) for w in rates],
                                   scenario.measurement_model,
                                   np.full((3, 3), 0.05) + 0.85 * np.eye(3))
    first = scenario.measurements[0]
    means = np.tile([first[0], -30.0, first[1], -30.0], (1, 3, 1))
    covars = np.tile(np.diag([1.0, 25.0, 1.0, 25.0]), (1, 3, 1, 1))
    probs, history, errors = np.full((1, 3), 1 / 3), [], []
    for z, truth in zip(scenario.measurements[1:], scenario.truths[1:]):
        means, covars, probs = imm_filter.step(means, covars, probs, z[None], 1.0)
        history.append(probs[0])
        x = ft.BatchIMMFilter.combine(means, covars, probs)[0][0]
        errors.append(np.hypot(x[0] - truth[0], x[2] - truth[2]))
    history = np.array(history)
    flown = scenario.turn_rates[1:]
    # measured: 0.79-0.81 straight, 0.74 turning right, 0.91 turning left
    for rate, model in ((0.0, 1), (-0.01634, 2), (0.0232, 0)):
        turning = flown == rate
        assert history[turning, model].mean() > 0.6
    assert np.sqrt(np.mean(np.square(errors))) < 1.5  # measured 1.17 m (noise 0.85 m)


@pytest.mark.parametrize("predictor_class,updater_class", [
    (ft.KalmanPredictor, ft.KalmanUpdater),  # one kernel call each
    (ft.ExtendedKalmanPredictor, ft.ExtendedKalmanUpdater),  # each model's own
])
def test_the_predictor_and_updater_pair_equals_the_batch_filter(predictor_class, updater_class):
    models = [_cv(0.01), _cv(1.0), _cv(10.0)]
    matrix = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.05, 0.15, 0.8]])
    predictor = ft.IMMPredictor([predictor_class(m) for m in models], transition_matrix=matrix)
    updater = ft.IMMUpdater([updater_class(SENSOR) for _ in models], transition_matrix=matrix)
    batch = ft.BatchIMMFilter(models, SENSOR, matrix)
    x0, p0, mu0 = np.array([0.0, 5.0, 0.0, 0.0]), np.diag([10.0, 2.0, 10.0, 2.0]), (0.6, 0.3, 0.1)
    state = ft.GaussianMixture([ft.WeightedGaussianState(x0, p0, weight=mu, timestamp=0.0)
                                for mu in mu0])
    means, covars, probs = np.tile(x0, (1, 3, 1)), np.tile(p0, (1, 3, 1, 1)), np.array([mu0])
    rng = np.random.default_rng(6)
    for t in range(1, 25):
        z = np.array([5.0 * t, 0.3 * t * t]) + rng.normal(size=2)
        prediction = predictor.predict(state, timestamp=float(t))
        assert prediction.timestamp == float(t)
        state = updater.update(ft.SingleHypothesis(prediction, ft.Detection(
            z, timestamp=float(t), measurement_model=SENSOR)))
        means, covars, probs = batch.step(means, covars, probs, z[None], 1.0)
        np.testing.assert_allclose([c.weight for c in state.components], probs[0], rtol=1e-9)
        for j, component in enumerate(state.components):
            np.testing.assert_allclose(component.state_vector.ravel(), means[0, j], rtol=1e-9,
                                       atol=1e-9)
            np.testing.assert_allclose(component.covar, covars[0, j], rtol=1e-9, atol=1e-9)
        x, p = ft.BatchIMMFilter.combine(means, covars, probs)
        np.testing.assert_allclose(state.mean.ravel(), x[0], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(state.covar, p[0], rtol=1e-9, atol=1e-9)


def test_the_pair_takes_extended_kalman_models_of_a_radar():
    radar = ft.CartesianToBearingRange(4, (0, 2), np.diag([1e-4, 1.0]),
                                       translation_offset=[0.0, -100.0])
    models = [_cv(0.01), _cv(5.0)]
    predictor = ft.IMMPredictor([ft.ExtendedKalmanPredictor(m) for m in models],
                                [[0.95, 0.05], [0.05, 0.95]])
    updater = ft.IMMUpdater([ft.ExtendedKalmanUpdater(radar)] * 2, [[0.95, 0.05], [0.05, 0.95]])
    state = ft.GaussianMixture([ft.WeightedGaussianState([0.0, 1.0, 0.0, 0.0], np.eye(4),
                                                         weight=0.5, timestamp=0.0)] * 2)
    for t in range(1, 20):
        truth = ft.GaussianState([1.0 * t, 1.0, 3.0 * np.sin(t), 0.0], np.eye(4))
        z = radar.function(truth)
        state = updater.update(ft.SingleHypothesis(predictor.predict(state, float(t)),
                                                   ft.Detection(z, timestamp=float(t))))
    assert np.isfinite(state.mean).all() and abs(sum(c.weight for c in state.components) - 1) \
        < 1e-12
    assert state.components[1].weight > 0.5  # the weaving target: the noisier model


def test_mixtures_and_the_pair_refuse_what_they_cannot_use():
    component = ft.WeightedGaussianState([0.0, 1.0, 0.0, 1.0], np.eye(4), weight=0.5,
                                         timestamp=0.0)
    with pytest.raises(ValueError, match="weight must be finite and >= 0"):
        ft.WeightedGaussianState([0.0], [[1.0]], weight=-0.1)
    with pytest.raises(TypeError, match="non-empty list of WeightedGaussianState"):
        ft.GaussianMixture([])
    with pytest.raises(ValueError, match="of zero weight has no mean"):
        _ = ft.GaussianMixture([ft.WeightedGaussianState([0.0], [[1.0]], weight=0.0)]).mean
    with pytest.raises(ValueError, match="same timestamp"):
        ft.GaussianMixture([component, ft.WeightedGaussianState([0.0] * 4, np.eye(4),
                                                                timestamp=1.0)])
    predictor = ft.IMMPredictor([ft.KalmanPredictor(_cv(1.0))] * 2, [[0.9, 0.1], [0.1, 0.9]])
    with pytest.raises(ValueError, match=r"prior must have 2 components \(one a model\)"):
        predictor.predict(ft.GaussianMixture([component]), 1.0)
    heavy = ft.WeightedGaussianState([0.0] * 4, np.eye(4), weight=0.9, timestamp=0.0)
    with pytest.raises(ValueError, match="prior's weights must sum to 1; they sum to 1.4"):
        predictor.predict(ft.GaussianMixture([component, heavy]), 1.0)  # 0.5 + 0.9
    with pytest.raises(TypeError, match="prior must be a GaussianMixture"):
        predictor.predict(component, 1.0)
    indefinite = np.diag([1.0, -1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"^covars\[1\] is not positive semi-definite"):
        ft.GaussianMixture(np.zeros((2, 4)), np.stack([np.eye(4), indefinite]))
    with pytest.raises(ValueError, match=r"^covars\[0\] is not symmetric"):
        ft.GaussianMixture(np.zeros((1, 4)), (np.eye(4) + np.eye(4, k=1))[None])
    written = ft.GaussianMixture([component, component])
    written.covars[1] = indefinite  # (written into: the mixture checked them when made)
    for pair in (predictor, ft.IMMPredictor([ft.ExtendedKalmanPredictor(_cv(1.0))] * 2,
                                            [[0.9, 0.1], [0.1, 0.9]])):
        with pytest.raises(ValueError, match=r"prior.covars\[1\] is not positive semi-def"):
            pair.predict(written, 1.0)
    with pytest.raises(ValueError, match="predictors must hold at least one"):
        ft.IMMPredictor([], [[1.0]])
    updater = ft.IMMUpdater([ft.KalmanUpdater(SENSOR)] * 2, [[0.9, 0.1], [0.1, 0.9]])
    prediction = predictor.predict(ft.GaussianMixture([component, component]), 1.0)
    with pytest.raises(ValueError, match="hypothesis.measurement is None"):
        updater.update(ft.SingleHypothesis(prediction, None))
    with pytest.raises(TypeError, match="hypothesis must be a SingleHypothesis"):
        updater.update(prediction)


def test_the_prediction_and_update_kernels_are_their_mirrors():
    from fasttrack._jit import imm as kernels
    from reference import imm as mirror
    rng = np.random.default_rng(8)
    models = [_cv(0.01), _cv(1.0), _cv(10.0)]
    matrix = np.array([[0.9, 0.05, 0.05], [0.0, 0.8, 0.2], [0.0, 0.15, 0.85]])
    k = 5
    means = rng.normal(size=(k, 3, 4)) * 5.0
    a = rng.normal(size=(k, 3, 4, 4))
    covars = a @ a.swapaxes(-1, -2) + np.eye(4)
    probs = rng.dirichlet(np.ones(3), size=k)
    probs[0] = [0.0, 0.4, 0.6]  # nothing switches into model 0
    transitions = np.array([m.matrix(2.0) for m in models])
    noises = np.array([m.covar(2.0) for m in models])
    everything = np.ones((3, 4), dtype=bool)
    results = []
    for module in (kernels, mirror):
        predicted = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
                     np.ones(k, dtype=np.int64)]
        module.imm_predict(transitions, noises, matrix, everything, means, covars, probs,
                           *predicted)
        updated = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
                   np.ones(k, dtype=np.int64)]
        z = rng.normal(size=(k, 2)) * 5.0 if not results else results[0][1]
        module.imm_update(SENSOR.spec.mapping, SENSOR.noise_covar, *predicted[:3], z, *updated)
        assert not predicted[3].any() and not updated[3].any()
        results.append((predicted[:3] + updated[:3], z))
    for a_, b_ in zip(results[0][0], results[1][0]):
        np.testing.assert_allclose(a_, b_, rtol=1e-9, atol=1e-9)
    assert results[0][0][5][0, 0] == 0.0
    step = [np.empty_like(means), np.empty_like(covars), np.empty_like(probs),
            np.ones(k, dtype=np.int64)]
    kernels.imm_linear_step(0, transitions, noises, SENSOR.spec.mapping, SENSOR.noise_covar,
                            matrix, everything, means, covars, probs, results[0][1], *step)
    for a_, b_ in zip(step[:3], results[0][0][3:]):  # the two halves are the step
        np.testing.assert_array_equal(a_, b_)


@pytest.mark.parametrize("algorithm", imm.ALGORITHMS)
def test_the_step_on_threads_is_the_step_on_one(algorithm):
    """Enough filters for the step's chunks to run on threads: each filter's result is the
    one-thread result, bit for bit."""
    import numba
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one thread")
    models = [_cv(0.01), _cv(1.0), _cv(10.0)]
    matrix = np.full((3, 3), 0.05) + np.eye(3) * 0.85
    k = 3001
    means, covars = _priors(k, 3)
    rng = np.random.default_rng(1)
    probs = rng.dirichlet(np.ones(3), size=k)
    z = rng.normal(size=(k, 2)) * 5.0
    filt = (ft.BatchIMMFilter(models, SENSOR, matrix) if algorithm == "imm"
            else ft.BatchGPBFilter(models, SENSOR, matrix, order=int(algorithm[-1])))
    threaded = filt.step(means, covars, probs, z, 1.0)
    try:
        ft.set_threads(1)
        alone = filt.step(means, covars, probs, z, 1.0)
    finally:
        ft.set_threads(numba.config.NUMBA_NUM_THREADS)
    for a_, b_ in zip(threaded, alone):
        np.testing.assert_array_equal(a_, b_)
