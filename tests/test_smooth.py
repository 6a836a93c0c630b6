"""Rauch-Tung-Striebel smoothers: the kernel against its mirror, parity with Stone Soup's
KalmanSmoother, the exact smoothing posterior of a linear-Gaussian model, the batched entry,
missed steps, the extended smoother and bad input."""
import datetime

import numpy as np
import pytest
from numba import njit

import fasttrack as ft
from fasttrack._jit import smooth as kernels

import reference.smooth
from conftest import from_python
from user_models import coordinated_turn

START = datetime.datetime(2025, 1, 1)
STEP = datetime.timedelta(seconds=1)
PRIOR_MEAN = np.array([0.0, 1.0, 0.0, 1.0])


def _models():
    return (ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2),
            ft.LinearGaussian(4, (0, 2), np.eye(2)))


def _measurements(n, seed=0):
    rng = np.random.default_rng(seed)
    return [np.array([[k + rng.normal()], [k + rng.normal()]]) for k in range(1, n + 1)]


def _ft_track(n, seed=0, missed=()):
    """run_filter's track (or, with ``missed`` steps, a track with predictions there)."""
    transition, sensor = _models()
    predictor, updater = ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor)
    prior = ft.GaussianState(PRIOR_MEAN, np.eye(4), timestamp=START)
    zs = _measurements(n, seed)
    if not missed:
        detections = [ft.Detection(z, timestamp=START + (k + 1) * STEP) for k, z in enumerate(zs)]
        return ft.run_filter(predictor, updater, prior, detections), prior
    track, state = ft.Track(), prior
    for k, z in enumerate(zs):
        prediction = predictor.predict(state, START + (k + 1) * STEP)
        if k in missed:
            state = prediction
        else:
            state = updater.update(ft.SingleHypothesis(prediction, ft.Detection(
                z, timestamp=prediction.timestamp)))
        track.append(state)
    return track, prior


def _ss_track(n, seed=0, missed=()):
    """The same track in Stone Soup (its prior first, as in stonesoup_mtt_baseline.ss_rts)."""
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater

    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05),
                                                        ConstantVelocity(0.05)])
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    predictor, updater = KalmanPredictor(transition), KalmanUpdater(sensor)
    track = Track([GaussianState(PRIOR_MEAN.reshape(-1, 1), np.eye(4), timestamp=START)])
    for k, z in enumerate(_measurements(n, seed)):
        prediction = predictor.predict(track[-1], timestamp=START + (k + 1) * STEP)
        if k in missed:
            track.append(prediction)
        else:
            detection = Detection(z, timestamp=prediction.timestamp, measurement_model=sensor)
            track.append(updater.update(SingleHypothesis(prediction, detection)))
    return track, transition


def _arrays(track):
    return (np.array([s.state_vector[:, 0] for s in track]),
            np.array([s.covar for s in track]))


# --- kernel against its mirror ---------------------------------------------------------------

def _random_problem(rng, k_tracks, n, d, given):
    a = rng.normal(size=(k_tracks, n, d, d))
    covar = a @ a.transpose(0, 1, 3, 2) + d * np.eye(d)
    x = rng.normal(size=(k_tracks, n, d))
    b = rng.normal(size=(k_tracks, n, d, d))
    covar_pred = b @ b.transpose(0, 1, 3, 2) + d * np.eye(d)
    x_pred = rng.normal(size=(k_tracks, n, d))
    matrix = np.eye(d) + 0.3 * rng.normal(size=(3, d, d))
    c = rng.normal(size=(3, d, d))
    noise = c @ c.transpose(0, 2, 1) + 0.1 * np.eye(d)
    step = rng.integers(0, 3, n).astype(np.int64)
    recompute = (rng.random(n) > given).astype(np.uint8)
    return x, covar, x_pred, covar_pred, recompute, matrix, noise, step


@pytest.mark.parametrize("k_tracks,n,d,given", [(1, 6, 4, 0.5), (3, 10, 2, 0.0), (2, 5, 5, 1.0),
                                                (1, 1, 3, 0.5), (2, 7, 1, 0.5), (2, 8, 6, 0.3)])
@pytest.mark.parametrize("build", ["for_dimension", "any_dimension"])
def test_kernel_matches_mirror(k_tracks, n, d, given, build):
    args = _random_problem(np.random.default_rng(n * d), k_tracks, n, d, given)
    before = [a.copy() for a in args]
    outs = [(np.empty((k_tracks, n, d)), np.empty((k_tracks, n, d, d))) for _ in range(2)]
    kernel = kernels.rts_kernel(d) if build == "for_dimension" else kernels.rts
    assert (kernel is kernels.rts) == (build == "any_dimension" or
                                       d not in kernels.UNROLLED_DIMENSIONS)
    assert kernel(*args, *outs[0]) == 0
    assert reference.smooth.rts(*args, *outs[1]) == 0
    np.testing.assert_allclose(outs[0][0], outs[1][0], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(outs[0][1], outs[1][1], rtol=1e-10, atol=1e-10)
    for a, b in zip(args, before):
        np.testing.assert_array_equal(a, b)  # inputs untouched


@pytest.mark.parametrize("d", [3, 4])
def test_kernel_reports_non_pd_prediction_like_mirror(d):
    x, covar, x_pred, covar_pred, recompute, matrix, noise, step = _random_problem(
        np.random.default_rng(1), 2, 6, d, 1.0)
    covar_pred[1, 3] = -np.eye(d)
    args = (x, covar, x_pred, covar_pred, recompute, matrix, noise, step)
    outs = [(np.empty((2, 6, d)), np.empty((2, 6, d, d))) for _ in range(2)]
    code = kernels.rts_kernel(d)(*args, *outs[0])
    assert code == reference.smooth.rts(*args, *outs[1]) == 1 + 1 * 6 + 3


@pytest.mark.parametrize("d", [3, 4])
@pytest.mark.parametrize("bad", ["nan", "asymmetric", "indefinite"])
def test_kernel_reports_a_bad_filtered_covariance_like_mirror(d, bad):
    x, covar, x_pred, covar_pred, recompute, matrix, noise, step = _random_problem(
        np.random.default_rng(1), 2, 6, d, 1.0)
    if bad == "nan":
        covar[1, 2, 0, 0] = np.nan
    elif bad == "asymmetric":
        covar[1, 2, 0, 1] += 1e-3 * np.abs(covar[1, 2]).max()
    else:
        covar[1, 2] -= 2 * np.linalg.eigvalsh(covar[1, 2]).max() * np.eye(d) / d
        covar[1, 2] = np.diag(np.r_[-1.0, np.ones(d - 1)])
    args = (x, covar, x_pred, covar_pred, recompute, matrix, noise, step)
    outs = [(np.empty((2, 6, d)), np.empty((2, 6, d, d))) for _ in range(2)]
    code = kernels.rts_kernel(d)(*args, *outs[0])
    assert code == reference.smooth.rts(*args, *outs[1]) == -(1 + 1 * 6 + 2)


# --- Stone Soup parity -----------------------------------------------------------------------

def test_matches_stonesoup_kalman_smoother_1000_steps():
    pytest.importorskip("stonesoup")
    from stonesoup.smoother.kalman import KalmanSmoother

    n = 1000
    track, _ = _ft_track(n)
    ss_track, ss_transition = _ss_track(n)
    transition, _ = _models()
    filtered_ft, filtered_ss = _arrays(track), _arrays(ss_track[1:])
    np.testing.assert_allclose(filtered_ft[0], filtered_ss[0], rtol=0, atol=1e-9)
    smoothed = ft.KalmanSmoother(transition).smooth(track)
    ss_smoothed = KalmanSmoother(ss_transition).smooth(ss_track)
    assert len(smoothed) == n and len(ss_smoothed) == n + 1
    x, p = _arrays(smoothed)
    x_ss, p_ss = _arrays(ss_smoothed[1:])
    np.testing.assert_allclose(x, x_ss, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(p, p_ss, rtol=1e-9, atol=1e-9)
    # Stone Soup's semantics: same types, timestamps, hypotheses, id; last state reused
    assert smoothed.id == track.id and smoothed is not track
    assert smoothed[-1] is track[-1]
    for new, old in zip(smoothed, track):
        assert type(new) is type(old) is ft.GaussianStateUpdate
        assert new.timestamp == old.timestamp and new.hypothesis is old.hypothesis
    assert not np.allclose(x[0], filtered_ft[0][0])  # the first state did change


def test_matches_stonesoup_with_missed_steps_and_prior_first():
    pytest.importorskip("stonesoup")
    from stonesoup.smoother.kalman import KalmanSmoother

    missed = {3, 4, 10, 19}
    track, prior = _ft_track(20, seed=3, missed=missed)
    ss_track, ss_transition = _ss_track(20, seed=3, missed=missed)
    transition, _ = _models()
    with_prior = ft.Track([prior] + track.states)
    smoothed = ft.KalmanSmoother(transition, predictions="stonesoup").smooth(with_prior)
    ss_smoothed = KalmanSmoother(ss_transition).smooth(ss_track)
    assert smoothed[0] is prior  # not smoothed, as in Stone Soup
    for new, old, ss in zip(smoothed[1:], track, ss_smoothed[1:]):
        assert type(new) is type(old)
        assert type(ss).__name__ == type(old).__name__
        np.testing.assert_allclose(new.state_vector, ss.state_vector, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(new.covar, ss.covar, rtol=1e-9, atol=1e-9)
    assert isinstance(smoothed[4], ft.GaussianStatePrediction)
    assert smoothed[4].transition_model is track[3].transition_model
    # Stone Soup leaves the state before a prediction at its filtered value; the exact
    # smoother (the default) does not
    np.testing.assert_array_equal(smoothed[10].state_vector, track[9].state_vector)
    exact = ft.KalmanSmoother(transition).smooth(with_prior)
    assert not np.allclose(exact[10].state_vector, track[9].state_vector)
    np.testing.assert_allclose(exact[11].state_vector, smoothed[11].state_vector, rtol=1e-12)


def test_missed_steps_equal_exact_smoothing_posterior():
    transition, sensor = _models()
    rng = np.random.default_rng(7)
    n, missed = 10, {2, 3, 6, 9}
    dts = np.ones(n)
    prior_covar = np.diag([2.0, 0.5, 2.0, 0.5])
    predictor, updater = ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor)
    zs = [rng.normal(size=(2, 1)) * 3 for _ in range(n)]
    track, state = ft.Track(), ft.GaussianState(PRIOR_MEAN, prior_covar, timestamp=0.0)
    for t in range(n):
        prediction = predictor.predict(state, float(t + 1))
        state = prediction if t in missed else updater.update(
            ft.SingleHypothesis(prediction, ft.Detection(zs[t], timestamp=float(t + 1))))
        track.append(state)
    observed = [t not in missed for t in range(n)]
    mean, cov = _joint_posterior(transition, sensor, PRIOR_MEAN, prior_covar, zs, dts, observed)
    x, p = _arrays(ft.KalmanSmoother(transition).smooth(track))
    np.testing.assert_allclose(x, mean, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(p, cov, rtol=1e-8, atol=1e-9)


def test_held_predictions_are_used_as_given():
    """With the predictions still held (their links alive), the result is the same as with
    recomputed ones; a changed held prediction changes the result (it is really read)."""
    transition, sensor = _models()
    predictor, updater = ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor)
    state = ft.GaussianState(PRIOR_MEAN, np.eye(4), timestamp=START)
    track, held = ft.Track(), []
    for k, z in enumerate(_measurements(15)):
        prediction = predictor.predict(state, START + (k + 1) * STEP)
        held.append(prediction)
        state = updater.update(ft.SingleHypothesis(prediction, ft.Detection(
            z, timestamp=prediction.timestamp)))
        track.append(state)
    assert track[5].hypothesis.prediction is held[5]
    smoother = ft.KalmanSmoother(transition)
    given = _arrays(smoother.smooth(track))
    recomputed = smoother.smooth_arrays(*_arrays(track), 1.0)
    np.testing.assert_allclose(given[0], recomputed[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(given[1], recomputed[1], rtol=1e-12, atol=1e-12)
    held[7].state_vector = held[7].state_vector + 1.0
    moved = _arrays(smoother.smooth(track))
    assert not np.allclose(moved[0][6], given[0][6])


def test_a_held_prediction_s_model_of_another_dimension_is_named():
    transition, sensor = _models()
    predictor, updater = ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor)
    state = ft.GaussianState(PRIOR_MEAN, np.eye(4), timestamp=START)
    track, held = ft.Track(), []
    for k, z in enumerate(_measurements(6)):
        held.append(predictor.predict(state, START + (k + 1) * STEP))
        state = updater.update(ft.SingleHypothesis(held[-1], ft.Detection(
            z, timestamp=held[-1].timestamp)))
        track.append(state)
    held[3].transition_model = ft.CombinedLinearGaussianTransitionModel(
        [ft.ConstantVelocity(0.05)] * 3)
    with pytest.raises(ValueError, match=r"prediction of track\[3\] must have ndim_state 4, "
                                         r"got 6"):
        ft.KalmanSmoother(transition).smooth(track)


def test_the_kernel_built_for_a_dimension_refuses_arrays_of_another():
    args = _random_problem(np.random.default_rng(0), 1, 5, 3, 0.5)
    with pytest.raises(ValueError, match="this build's dimension"):
        kernels.rts_kernel(4)(*args, np.empty((1, 5, 3)), np.empty((1, 5, 3, 3)))


# --- exact smoothing posterior ---------------------------------------------------------------

def _joint_posterior(transition, sensor, prior_mean, prior_covar, zs, dts, observed=None):
    """Mean and covariance of (x_1..x_T) given the ``observed`` z_1..z_T (default all) by
    dense Gaussian conditioning."""
    d, m, n = 4, 2, len(zs)
    big_f = np.zeros((n * d, d))
    big_a = np.zeros((n * d, n * d))  # x = big_f x0 + big_a w
    big_q = np.zeros((n * d, n * d))
    phi = np.eye(d)
    mats = [transition.matrix(dt) for dt in dts]
    for t in range(n):
        phi = mats[t] @ phi
        big_f[t * d:(t + 1) * d] = phi
        big_q[t * d:(t + 1) * d, t * d:(t + 1) * d] = transition.covar(dts[t])
        for s in range(t + 1):
            block = np.eye(d)
            for r in range(s + 1, t + 1):
                block = mats[r] @ block
            big_a[t * d:(t + 1) * d, s * d:(s + 1) * d] = block
    mean_x = big_f @ prior_mean
    cov_x = big_f @ prior_covar @ big_f.T + big_a @ big_q @ big_a.T
    h = sensor.matrix()
    rows = np.eye(n)[np.ones(n, bool) if observed is None else np.array(observed)]
    big_h = np.kron(rows, h)
    big_r = np.kron(np.eye(len(rows)), sensor.covar())
    s = big_h @ cov_x @ big_h.T + big_r
    gain = cov_x @ big_h.T @ np.linalg.inv(s)
    z = np.concatenate([z.ravel() for t, z in enumerate(zs)
                        if observed is None or observed[t]])
    mean = mean_x + gain @ (z - big_h @ mean_x)
    cov = cov_x - gain @ big_h @ cov_x
    return mean.reshape(n, d), np.array([cov[t * d:(t + 1) * d, t * d:(t + 1) * d]
                                         for t in range(n)])


@pytest.mark.parametrize("seed", [0, 1])
def test_equals_exact_smoothing_posterior(seed):
    transition, sensor = _models()
    rng = np.random.default_rng(seed)
    n = 8
    dts = rng.uniform(0.5, 2.0, n)  # irregular steps: several transition matrices
    times = np.cumsum(dts)
    prior_covar = np.diag([2.0, 0.5, 2.0, 0.5])
    prior = ft.GaussianState(PRIOR_MEAN, prior_covar, timestamp=0.0)
    zs = [rng.normal(size=(2, 1)) * 3 for _ in range(n)]
    detections = [ft.Detection(z, timestamp=float(t)) for z, t in zip(zs, times)]
    track = ft.run_filter(ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor), prior,
                          detections)
    mean, cov = _joint_posterior(transition, sensor, PRIOR_MEAN, prior_covar, zs, dts)
    x, p = _arrays(ft.KalmanSmoother(transition).smooth(track))
    np.testing.assert_allclose(x, mean, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(p, cov, rtol=1e-8, atol=1e-9)
    # the filtered last state is the exact marginal too; the first is not
    np.testing.assert_allclose(track[-1].covar, cov[-1], rtol=1e-8, atol=1e-9)


# --- batched entry ---------------------------------------------------------------------------

def test_batched_arrays_match_single_tracks():
    transition, _ = _models()
    smoother = ft.KalmanSmoother(transition)
    tracks = [_ft_track(50, seed=s)[0] for s in range(4)]
    means = np.array([_arrays(t)[0] for t in tracks])
    covars = np.array([_arrays(t)[1] for t in tracks])
    xs, ps = smoother.smooth_arrays(means, covars, STEP)
    assert xs.shape == (4, 50, 4) and ps.shape == (4, 50, 4, 4)
    for k, track in enumerate(tracks):
        x, p = _arrays(smoother.smooth(track))
        np.testing.assert_allclose(xs[k], x, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(ps[k], p, rtol=1e-12, atol=1e-12)
    x1, p1 = smoother.smooth_arrays(means[2], covars[2], [1.0] * 49)
    np.testing.assert_array_equal(x1, xs[2])
    np.testing.assert_array_equal(p1, ps[2])


# --- extended smoother -----------------------------------------------------------------------

def test_extended_smoother_equals_kalman_smoother_on_linear_model():
    transition, _ = _models()
    track, _ = _ft_track(30)
    a = _arrays(ft.KalmanSmoother(transition).smooth(track))
    b = _arrays(ft.ExtendedKalmanSmoother(transition).smooth(track))
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


def test_extended_smoother_nonlinear_matches_numpy_rts():
    """Coordinated-turn track from the EKF classes: the smoother equals a NumPy RTS pass with
    the same forward-difference Jacobians and recomputed EKF predictions."""
    q = np.diag([0.1, 0.01, 0.1, 0.01])
    transition = ft.NonlinearGaussianTransitionModel(coordinated_turn, q, 4)
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    predictor, updater = ft.ExtendedKalmanPredictor(transition), ft.ExtendedKalmanUpdater(sensor)
    prior = ft.GaussianState(PRIOR_MEAN, np.diag([1.0, 0.1, 1.0, 0.1]), timestamp=0.0)
    rng = np.random.default_rng(5)
    detections = [ft.Detection(rng.normal(size=2) + [t, t], timestamp=float(t))
                  for t in range(1, 21)]
    track = ft.run_filter(predictor, updater, prior, detections)
    smoothed = ft.ExtendedKalmanSmoother(transition).smooth(track)
    x, p = _arrays(track)
    xs, ps = x.copy(), p.copy()
    for t in range(len(track) - 2, -1, -1):
        state = ft.GaussianState(x[t], p[t], timestamp=float(t + 1))
        pred = predictor.predict(state, float(t + 2))
        f = np.empty((4, 4))  # forward differences, fasttrack's (Stone Soup's) step rule
        base = coordinated_turn(x[t].reshape(4, 1).copy(), 1.0)[:, 0]
        for j in range(4):
            step = max(1e8 * np.spacing(x[t, j]), 1e-8)
            shifted = x[t].copy()
            shifted[j] += step
            f[:, j] = (coordinated_turn(shifted.reshape(4, 1), 1.0)[:, 0] - base) / step
        gain = p[t] @ f.T @ np.linalg.inv(pred.covar)
        xs[t] = x[t] + gain @ (xs[t + 1] - pred.state_vector[:, 0])
        ps[t] = p[t] + gain @ (ps[t + 1] - pred.covar) @ gain.T
    got = _arrays(smoothed)
    np.testing.assert_allclose(got[0], xs, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(got[1], ps, rtol=1e-6, atol=1e-6)
    with pytest.raises(TypeError, match="transition_model"):
        ft.KalmanSmoother(transition)
    with pytest.raises(TypeError, match="linear transition_model"):
        ft.ExtendedKalmanSmoother(transition).smooth_arrays(x, p, 1.0)



# --- unscented smoother ----------------------------------------------------------------------

@njit(cache=False)
def constant_turn(states, dt):
    """(x, vx, y, vy, turn rate): Stone Soup's ConstantTurn, term for term."""
    out = np.empty_like(states)
    for i in range(states.shape[1]):
        x, vx, y, vy, w = states[:, i]
        w = w if w != 0.0 else np.finfo(np.float64).eps
        c, s = np.cos(w * dt), np.sin(w * dt)
        out[0, i] = x + s / w * vx - vy / w * (1.0 - c)
        out[1, i] = vx * c - vy * s
        out[2, i] = vx / w * (1.0 - c) + y + vy * s / w
        out[3, i] = vx * s + vy * c
        out[4, i] = w
    return out


def _turn_tracks(n, missed=()):
    """A turning target (Stone Soup's ConstantTurn, bearing-range from (50, 0)) tracked by
    Stone Soup's UKF and by fasttrack's with the same model as a user function."""
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.nonlinear import ConstantTurn
    from stonesoup.predictor.kalman import UnscentedKalmanPredictor
    from stonesoup.types.angle import Bearing
    from stonesoup.types.array import StateVector
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import UnscentedKalmanUpdater

    noise = np.diag([np.radians(0.5), 1.0])
    turn = ConstantTurn(linear_noise_coeffs=[0.1, 0.1], turn_noise_coeff=1e-4)
    sensor = CartesianToBearingRange(ndim_state=5, mapping=(0, 2), noise_covar=noise,
                                     translation_offset=np.array([[50], [0]]))
    ours = ft.NonlinearGaussianTransitionModel(
        constant_turn, lambda dt: turn.covar(time_interval=STEP * dt), 5)
    our_sensor = ft.CartesianToBearingRange(5, (0, 2), noise, translation_offset=[50, 0])
    mean, covar = np.array([0.0, 2.0, 0.0, 1.0, 0.05]), np.diag([1.0, 0.1, 1.0, 0.1, 1e-3])
    rng = np.random.default_rng(4)
    truth = mean.reshape(5, 1)
    theirs, track = Track(), ft.Track()
    state, our_state = GaussianState(mean, covar, timestamp=START), ft.GaussianState(
        mean, covar, timestamp=START)
    predictor, updater = UnscentedKalmanPredictor(turn), UnscentedKalmanUpdater(sensor)
    our_predictor, our_updater = ft.UnscentedKalmanPredictor(ours), ft.UnscentedKalmanUpdater(
        our_sensor, use_joseph_cov=False)
    kept = []  # fasttrack's updates link their predictions weakly: keep them, as Stone Soup
    for k in range(n):
        truth = constant_turn(truth, 1.0)
        z = our_sensor.function(truth)[:, 0] + rng.normal(size=2) * np.sqrt(np.diag(noise))
        stamp = START + (k + 1) * STEP
        prediction = predictor.predict(state, timestamp=stamp)
        our_prediction = our_predictor.predict(our_state, stamp)
        kept.append(our_prediction)
        if k in missed:
            state, our_state = prediction, our_prediction
        else:
            detection = Detection(StateVector([Bearing(z[0]), z[1]]), timestamp=stamp,
                                  measurement_model=sensor)
            state = updater.update(SingleHypothesis(prediction, detection))
            our_state = our_updater.update(ft.SingleHypothesis(
                our_prediction, ft.Detection(z, timestamp=stamp)))
        theirs.append(state)
        track.append(our_state)
    return track, theirs, ours, turn, kept


@pytest.mark.parametrize("missed", [(), (7, 8, 20)])
def test_unscented_smoother_equals_stonesoup_on_a_turning_target(missed):
    """Stone Soup's UnscentedKalmanSmoother (its default kappa, 0) against fasttrack's on the
    same UKF track of a nonlinear (constant-turn) model; with missed steps, in Stone Soup's
    reading of predictions in a track."""
    pytest.importorskip("stonesoup")
    from stonesoup.smoother.kalman import UnscentedKalmanSmoother

    track, theirs, ours, turn, _ = _turn_tracks(40, missed)
    np.testing.assert_allclose(_arrays(track)[0], _arrays(theirs)[0], rtol=1e-9, atol=1e-9)
    expected = _arrays(UnscentedKalmanSmoother(turn).smooth(theirs))
    mode = "stonesoup" if missed else "exact"
    got = _arrays(ft.UnscentedKalmanSmoother(ours, kappa=0.0, predictions=mode).smooth(track))
    np.testing.assert_allclose(got[0], expected[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(got[1], expected[1], rtol=1e-9, atol=1e-9)
    assert not np.allclose(got[0][0], _arrays(track)[0][0])


def test_unscented_smoother_recomputes_lost_predictions_and_equals_kalman_when_linear():
    """With the predictions gone from the track, the unscented prediction is recomputed (with
    the smoother's parameters, here the filter's): the same result as with them. On a linear
    model the unscented smoother is the Kalman smoother."""
    pytest.importorskip("stonesoup")
    track, _, ours, _, kept = _turn_tracks(15)
    smoother = ft.UnscentedKalmanSmoother(ours)
    with_predictions = _arrays(smoother.smooth(track))
    del kept
    assert track[3].hypothesis.prediction is None
    without = _arrays(smoother.smooth(track))
    np.testing.assert_allclose(without[0], with_predictions[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(without[1], with_predictions[1], rtol=1e-9, atol=1e-9)
    transition, _ = _models()
    linear_track, _ = _ft_track(30)
    a = _arrays(ft.KalmanSmoother(transition).smooth(linear_track))
    b = _arrays(ft.UnscentedKalmanSmoother(transition).smooth(linear_track))
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    with pytest.raises(ValueError, match="alpha"):
        ft.UnscentedKalmanSmoother(transition, alpha=-1.0)
    with pytest.raises(TypeError, match="transition_model"):
        ft.UnscentedKalmanSmoother("model")

# --- edge cases and bad input ----------------------------------------------------------------

def test_short_tracks():
    transition, _ = _models()
    track, prior = _ft_track(1)
    smoother = ft.KalmanSmoother(transition)
    assert smoother.smooth(track).states == track.states
    assert smoother.smooth(ft.Track([prior])).states == [prior]
    two = smoother.smooth(ft.Track([prior, track[0]]))
    assert two[0] is prior and two[1] is track[0]



def test_a_smoothed_state_lost_to_cancellation_is_refused():
    """A track filtered from a prior variance of 1e300 beside variances of 1 smoothed into
    a variance of -7e283 (Stone Soup raises LinAlgError): named, for a track, for arrays
    and for a batch."""
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    rng = np.random.default_rng(2)
    truth = ft.ground_truth(transition, [0, 1, 0, 1], steps=10, start_time=0.0, rng=rng)
    prior = ft.GaussianState([0, 1, 0, 1], np.eye(4) * 1e300, timestamp=0.0)
    track = ft.run_filter(ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor), prior,
                          ft.detections(truth, sensor, rng=rng))
    smoother = ft.KalmanSmoother(transition)
    with pytest.raises(ValueError, match=r"the smoothed state of track\[0\] is not finite or "
                                         r"has a negative variance"):
        smoother.smooth(track)
    means = np.array([state.state_vector[:, 0] for state in track])
    covars = np.array([state.covar for state in track])
    with pytest.raises(ValueError, match=r"the smoothed state\[0\] is not finite"):
        smoother.smooth_arrays(means, covars, 1.0)
    with pytest.raises(ValueError, match=r"the smoothed state\[1, 0\] is not finite"):
        smoother.smooth_arrays(np.stack([means * 0, means]),
                               np.stack([np.tile(np.eye(4), (len(track), 1, 1)), covars]), 1.0)


def test_bad_input_names_the_argument():
    transition, _ = _models()
    smoother = ft.KalmanSmoother(transition)
    track, prior = _ft_track(5)
    with pytest.raises(TypeError, match="transition_model"):
        ft.KalmanSmoother("cv")
    with pytest.raises(TypeError, match="track must be a Track"):
        smoother.smooth(list(track))
    with pytest.raises(ValueError, match="track must hold"):
        smoother.smooth(ft.Track())
    with pytest.raises(TypeError, match=r"track\[2\]"):
        smoother.smooth(ft.Track(track.states[:2] + [prior.__class__(PRIOR_MEAN, np.eye(4),
                                                                     timestamp=START + 3 * STEP)]))
    wrong = ft.GaussianStateUpdate(np.zeros(2), np.eye(2), timestamp=START + 9 * STEP)
    with pytest.raises(ValueError, match=r"track\[5\]\.state_vector"):
        smoother.smooth(ft.Track(track.states + [wrong]))
    untimed = ft.GaussianStateUpdate(PRIOR_MEAN, np.eye(4))
    with pytest.raises(TypeError, match=r"track\[5\]\.timestamp"):
        smoother.smooth(ft.Track(track.states + [untimed]))
    seconds = ft.GaussianStateUpdate(PRIOR_MEAN, np.eye(4), timestamp=7.0)
    bad = ft.Track(track.states)
    bad.states.append(seconds)
    with pytest.raises(TypeError, match=r"track\[5\]\.timestamp"):
        smoother.smooth(bad)
    x, p = _arrays(track)
    with pytest.raises(ValueError, match="means"):
        smoother.smooth_arrays(x[:, :3], p, 1.0)
    with pytest.raises(ValueError, match="covars"):
        smoother.smooth_arrays(x, p[:4], 1.0)
    with pytest.raises(ValueError, match="means contains NaN"):
        smoother.smooth_arrays(np.full_like(x, np.nan), p, 1.0)
    with pytest.raises(TypeError, match="means"):
        smoother.smooth_arrays("x", p, 1.0)
    with pytest.raises(ValueError, match="time_intervals"):
        smoother.smooth_arrays(x, p, [1.0, 1.0])
    with pytest.raises(TypeError, match="time_intervals"):
        smoother.smooth_arrays(x, p, "1s")
    with pytest.raises(ValueError, match="together"):
        smoother.smooth_arrays(x, p, 1.0, predicted_means=x)
    np.testing.assert_array_equal(smoother.smooth_arrays(x, p, np.array(1.0))[0],
                                  smoother.smooth_arrays(x, p, 1.0)[0])
    indefinite = np.broadcast_to(-np.eye(4), p.shape)
    with pytest.raises(ValueError, match=r"predicted_covars\[4\] is not positive definite"):
        smoother.smooth_arrays(x, p, 1.0, predicted_means=x, predicted_covars=indefinite)
    with pytest.raises(ValueError, match=r"time_intervals must be >= 0 seconds, got -1.0"):
        smoother.smooth_arrays(x, p, -1.0)
    with pytest.raises(ValueError, match=r"time_intervals\[2\] must be >= 0 seconds"):
        smoother.smooth_arrays(x, p, [1.0, 1.0, -1.0, 1.0])
    for covar, what in ((np.diag([1.0, -1.0, 1.0, 1.0]), "indefinite"),
                        (np.eye(4) + np.triu(np.ones((4, 4)), 1), "asymmetric")):
        q = p.copy()
        q[3] = covar
        with pytest.raises(ValueError, match=r"covars\[3\] is not symmetric positive "
                                             r"semi-definite"):
            smoother.smooth_arrays(x, q, 1.0)
        with pytest.raises(ValueError, match=r"covars\[1, 3\] is not symmetric positive"):
            smoother.smooth_arrays(np.stack([x, x]), np.stack([p, q]), 1.0)
    written = _ft_track(5)[0]  # a NaN or a bad covariance written into a state
    written[2].state_vector[1, 0] = np.nan
    with pytest.raises(ValueError, match=r"track\[2\]\.state_vector contains NaN"):
        smoother.smooth(written)
    written = _ft_track(5)[0]
    written[3].covar[0, 0] = -1.0
    with pytest.raises(ValueError, match=r"track\[3\]\.covar is not symmetric positive"):
        smoother.smooth(written)
    written = _ft_track(5)[0]
    written[3].covar[0, 1] = 5.0
    with pytest.raises(ValueError, match=r"track\[3\]\.covar is not symmetric positive"):
        smoother.smooth(written)
    backwards = ft.Track(track.states[:2])  # a Track sorts its states; its list need not be
    backwards.states.append(track[0])
    with pytest.raises(ValueError, match=r"track\[2\]\.timestamp must be at or after "
                                         r"track\[1\]'s \(got an interval of -1.0 s\)"):
        smoother.smooth(backwards)
    with pytest.raises(ValueError, match="predicted_covars"):
        smoother.smooth_arrays(x, p, 1.0, predicted_means=x, predicted_covars=p[:, :2])
    with pytest.raises(ValueError, match="not positive definite"):
        smoother.smooth_arrays(x, p, 1.0, predicted_means=x, predicted_covars=-p)
    with pytest.raises(ValueError, match="predictions"):
        ft.KalmanSmoother(transition, predictions="ss")
    with pytest.raises(ValueError, match="jacobian"):
        ft.ExtendedKalmanSmoother(transition, jacobian="backward")


# --- forward-filter backward-simulation ------------------------------------------------------

@pytest.mark.parametrize("max_proposals, min_acceptance",
                         [(0, 0.0), (3, 0.0), (kernels.MAX_PROPOSALS, 0.0), (3, 0.4)])
def test_ffbs_kernel_matches_mirror(max_proposals, min_acceptance):
    """Equally seeded generators: the kernel and its mirror draw the same uniforms in the
    same order, so they choose the same indices, with exact draws only (0 proposals),
    rejections falling back to them (3), the default, and rejection stopping within a step
    (an acceptance rate of 0.4 required)."""
    rng = np.random.default_rng(3)
    t_len, d, n, m = 5, 2, 40, 30
    states = rng.normal(size=(t_len, d, n))
    log_weights = rng.normal(size=(t_len, n))
    log_weights[2, :5] = -np.inf
    mean_next = states[:-1] * 0.9
    roots = np.linalg.inv(np.linalg.cholesky(np.eye(d) * 0.5 + 0.1))[None].repeat(t_len - 1, 0)
    a, b = np.empty((t_len, m), np.int64), np.empty((t_len, m), np.int64)
    for mirror, out in ((kernels.ffbs, a), (reference.smooth.ffbs, b)):
        mirror(states, log_weights, mean_next, roots, np.random.default_rng(4), max_proposals,
               min_acceptance, out)
    np.testing.assert_array_equal(a, b)
    assert (a[2] >= 5).all() and a.max() < n


def test_ffbs_search_takes_the_last_positive_weight_beyond_the_total():
    cumulative = np.array([0.0, 1.0, 2.0, 2.0])
    search = from_python(kernels._search)
    assert search(cumulative, 2, 0.0) == 1
    assert search(cumulative, 2, 0.75) == 2
    assert search(cumulative, 2, 1.0) == 2  # rounding up to the total
    assert reference.smooth._ffbs_categorical(np.array([-np.inf, 0.0, 0.0, -np.inf]), 1.0) == 2
    weights = np.zeros(40)
    weights[[3, 20, 33]] = 1.0
    sums = np.empty(3)
    assert from_python(kernels._block_sums)(weights, sums) == 3.0
    block_search = from_python(kernels._block_search)
    assert [block_search(weights, sums, target) for target in (0.0, 1.5, 2.0, 3.0)] \
        == [3, 20, 33, 33]


@pytest.mark.parametrize("method", ["rejection", "exact"])
def test_ffbs_agrees_with_rts_on_linear_model(method):
    """A bootstrap particle filter on a 1-D random walk (N = 4000): the FFBS paths' mean and
    variance at each time agree with the exact (RTS) smoother within Monte Carlo error, for
    the rejection draw (the default) and the exact one."""
    q, r, n_times, n, m = 1.0, 1.0, 8, 4000, 2000
    transition = ft.LinearGaussianTransitionModel([[1.0]], [[q]])
    sensor = ft.LinearGaussian(1, (0,), [[r]])
    rng = np.random.default_rng(11)
    zs = np.cumsum(rng.normal(size=n_times)) + rng.normal(size=n_times)
    detections = [ft.Detection([z], timestamp=float(t + 1)) for t, z in enumerate(zs)]
    gaussian = ft.GaussianState([0.0], [[1.0]], timestamp=0.0)
    kalman = ft.run_filter(ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor), gaussian,
                           detections)
    x_rts, p_rts = _arrays(ft.KalmanSmoother(transition).smooth(kalman))
    prior = ft.ParticleState(rng.normal(size=(1, n)), timestamp=0.0)
    particles = ft.run_filter(ft.ParticlePredictor(transition, rng=1),
                              ft.ParticleUpdater(sensor, resampler=ft.SystematicResampler()),
                              prior, detections)
    paths = ft.ffbs(particles, transition, m, rng=2, method=method)
    assert paths.shape == (n_times, 1, m)
    mean, var = paths[:, 0].mean(axis=1), paths[:, 0].var(axis=1)
    sd = np.sqrt(p_rts[:, 0, 0])
    np.testing.assert_array_less(np.abs(mean - x_rts[:, 0]), 5 * sd / np.sqrt(m) + 0.05 * sd)
    np.testing.assert_allclose(var, p_rts[:, 0, 0], rtol=0.2)
    # reproducible from the seed
    np.testing.assert_array_equal(ft.ffbs(particles, transition, m, rng=2, method=method),
                                  paths)


def test_ffbs_tiny_noise_falls_back_to_the_exact_draw():
    """With noise of standard deviation 0.01 and each particle moved by 0.2, a proposal is
    accepted with probability exp(-200): every draw falls back to the exact one, which takes
    the particle each one came from (the next nearest is 0.8 away)."""
    transition = ft.LinearGaussianTransitionModel([[1.0]], [[1e-4]])
    start = np.random.default_rng(5).permutation(np.arange(50.0))[None]
    weights = np.log(np.linspace(1.0, 2.0, 50))
    states = [ft.ParticleState(start, log_weight=weights, timestamp=0.0),
              ft.ParticleState(start + 0.2, log_weight=weights, timestamp=1.0)]
    paths = ft.ffbs(states, transition, 500, rng=6)
    np.testing.assert_allclose(paths[1] - paths[0], 0.2)
    assert len(np.unique(paths[1])) > 40


def test_ffbs_bad_input():
    transition = ft.LinearGaussianTransitionModel([[1.0]], [[1.0]])
    states = [ft.ParticleState(np.zeros((1, 5)), timestamp=float(t)) for t in range(3)]
    with pytest.raises(ValueError, match="n_paths"):
        ft.ffbs(states, transition, 0)
    for method in ("mcmc", None, np.array(["exact"])):
        with pytest.raises(ValueError, match="method"):
            ft.ffbs(states, transition, 5, method=method)
    with pytest.raises(TypeError, match="transition_model"):
        ft.ffbs(states, "rw", 5)
    with pytest.raises(ValueError, match="particle_states"):
        ft.ffbs([], transition, 5)
    with pytest.raises(TypeError, match=r"particle_states\[1\]"):
        ft.ffbs([states[0], ft.GaussianState([0.0], [[1.0]], timestamp=1.0)], transition, 5)
    with pytest.raises(ValueError, match=r"particle_states\[2\]"):
        ft.ffbs(states[:2] + [ft.ParticleState(np.zeros((1, 4)), timestamp=2.0)], transition, 5)
    singular = ft.LinearGaussianTransitionModel([[1.0]], [[0.0]])
    with pytest.raises(ValueError, match="positive definite"):
        ft.ffbs(states, singular, 5)
    backwards = [states[0], states[2], states[1]]
    with pytest.raises(ValueError, match=r"particle_states\[2\]\.timestamp must be after "
                                         r"particle_states\[1\]'s \(got an interval of -1.0 s\)"):
        ft.ffbs(backwards, transition, 5)
    with pytest.raises(ValueError, match=r"particle_states\[1\]\.timestamp must be after"):
        ft.ffbs([states[0], states[0]], transition, 5)
    written = [ft.ParticleState(np.zeros((1, 5)), timestamp=float(t)) for t in range(3)]
    written[1].state_vector[0, 2] = np.inf
    with pytest.raises(ValueError, match=r"particle_states\[1\]\.state_vector contains NaN"):
        ft.ffbs(written, transition, 5)
