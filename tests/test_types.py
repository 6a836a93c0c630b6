"""Particle and ParticleState, and the ownership of a filter's history."""
import datetime
import os

import numpy as np
import pytest

import fasttrack as ft
from fasttrack import Particle, ParticleState


def test_particle_state_arrays_and_derived_weights():
    x = np.arange(12.0).reshape(3, 4)
    state = ParticleState(x, weight=[1, 2, 3, 4], timestamp=2.5)
    assert state.state_vector.shape == (3, 4) and state.state_vector.dtype == np.float64
    assert len(state) == 4 and state.ndim == 3 and state.timestamp == 2.5
    np.testing.assert_allclose(state.log_weight, np.log([1, 2, 3, 4]))
    np.testing.assert_allclose(state.weight, [1, 2, 3, 4])
    assert state.weight.dtype == np.float64
    equal = ParticleState(x)
    np.testing.assert_allclose(equal.weight, 0.25)


def test_mean_and_covar_follow_stone_soup_formulas():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((4, 500)) * [[1], [10], [0.1], [3]] + 7
    log_w = rng.normal(size=500) * 2 - 900  # far from 0: needs the max shift
    state = ParticleState(x, log_weight=log_w)
    w = np.exp(log_w - log_w.max())
    np.testing.assert_allclose(state.mean, np.average(x, axis=1, weights=w)[:, None], rtol=1e-12)
    np.testing.assert_allclose(state.covar, np.cov(x, ddof=0, aweights=w), rtol=1e-10)
    assert state.mean.shape == (4, 1)
    state.fixed_covar = np.eye(4)
    assert np.array_equal(state.covar, np.eye(4))



@pytest.mark.parametrize("numpy_first", [False, True])
def test_moments_whose_sums_overflow_are_refused(monkeypatch, numpy_first):
    """Finite particles near float64's limit: a mean of 1e308 particles came back inf;
    spreads of 1e160 square beyond float64."""
    from fasttrack import _jit
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: numpy_first)
    for scale, attr in ((1e308, "mean"), (1e160, "covar")):
        state = ParticleState(np.full((2, 100), scale) * np.linspace(1, 0.5, 100))
        with pytest.raises(ValueError, match=r"weighted mean or covariance is beyond "
                                             r"float64's range"):
            getattr(state, attr)
    spread = np.sqrt(ParticleState(np.full((2, 100), 1e150)).covar.max())
    assert spread <= 1e150 * 1e-14  # (rounding of the mean)

def test_moments_are_recomputed_after_assignment():
    state = ParticleState(np.array([[0.0, 2.0]]))
    assert state.mean[0, 0] == 1.0
    state.weight = [3.0, 1.0]
    assert state.mean[0, 0] == pytest.approx(0.5)
    state.state_vector = np.array([[4.0, 8.0]])
    assert state.mean[0, 0] == pytest.approx(5.0)


def test_indexing():
    parent = ParticleState(np.arange(5.0)[None] + 100)
    state = ParticleState(np.arange(10.0).reshape(2, 5), log_weight=np.log(np.arange(1, 6.0)),
                          parent=parent, timestamp=datetime.datetime(2026, 1, 1))
    particle = state[2]
    assert isinstance(particle, Particle)
    np.testing.assert_array_equal(particle.state_vector, [[2.0], [7.0]])
    assert particle.weight == pytest.approx(3.0)
    assert particle.parent.state_vector[0, 0] == 102
    sub = state[np.array([4, 0, 4])]
    assert type(sub) is ParticleState and len(sub) == 3
    np.testing.assert_array_equal(sub.state_vector[0], [4, 0, 4])
    np.testing.assert_allclose(sub.weight, [5, 1, 5])
    np.testing.assert_array_equal(sub.parent.state_vector[0], [104, 100, 104])
    assert sub.parent.parent is None and sub.timestamp == state.timestamp
    assert len(state[1:3]) == 2 and len(state[np.array([True, False] * 2 + [True])]) == 3
    with pytest.raises(IndexError):
        state[np.array([], dtype=int)]


def test_from_particle_list_with_and_without_parents():
    particles = [Particle(np.array([i, -i]), weight=i + 1.0) for i in range(4)]
    state = ParticleState(particle_list=particles)
    np.testing.assert_array_equal(state.state_vector, [[0, 1, 2, 3], [0, -1, -2, -3]])
    np.testing.assert_allclose(state.weight, [1, 2, 3, 4])
    assert state.parent is None
    children = [Particle([[10.0 * i]], 1.0, parent=p) for i, p in enumerate(particles)]
    child_state = ParticleState(particle_list=children)
    np.testing.assert_array_equal(child_state.parent.state_vector[1], [0, -1, -2, -3])
    with pytest.raises(ValueError, match="every particle in particle_list has a parent"):
        ParticleState(particle_list=[children[0], Particle([[1.0]], 1.0)])
    with pytest.raises(ValueError, match="particle_list mixes state dimensions"):
        ParticleState(particle_list=[children[0], particles[1]])


@pytest.mark.parametrize("kwargs,error,message", [
    (dict(state_vector=[[0.0, np.nan]]), ValueError, "state_vector contains NaN"),
    (dict(state_vector=[[0.0, np.inf]]), ValueError, "state_vector contains infinite"),
    (dict(state_vector=[0.0, 1.0]), ValueError, "state_vector must be 2-D"),
    (dict(state_vector=np.zeros((0, 3))), ValueError, r"state_vector must have shape \(d, N\)"),
    (dict(state_vector=[["a"]]), TypeError, "state_vector must be a numeric array"),
    (dict(state_vector=np.zeros((1, 2)), weight=[1, -1]), ValueError, "weight contains negative"),
    (dict(state_vector=np.zeros((1, 2)), weight=[0, 0]), ValueError, "weight: all weights are zero"),
    (dict(state_vector=np.zeros((1, 2)), weight=[1, 2, 3]), ValueError, "weight must have length 2"),
    (dict(state_vector=np.zeros((1, 2)), log_weight=[0, np.nan]), ValueError, "log_weight contains NaN"),
    (dict(state_vector=np.zeros((1, 2)), weight=[1, 1], log_weight=[0, 0]), ValueError, "not both"),
    (dict(state_vector=np.zeros((1, 2)), timestamp="now"), TypeError, "timestamp must be None"),
    (dict(state_vector=np.zeros((1, 2)), parent=[1]), TypeError, "parent must be a ParticleState"),
    (dict(state_vector=np.zeros((2, 2)), fixed_covar=np.eye(3)), ValueError, r"fixed_covar must have shape \(2, 2\)"),
    (dict(), ValueError, "state_vector .or particle_list. is required"),
    (dict(particle_list=[]), ValueError, "particle_list is empty"),
    (dict(particle_list=[1, 2]), TypeError, "particle_list must hold Particle"),
])
def test_bad_input(kwargs, error, message):
    with pytest.raises(error, match=message):
        ParticleState(**kwargs)


@pytest.mark.parametrize("args,error,message", [
    (([0.0, 1.0], -1.0), ValueError, "weight must be finite and >= 0"),
    (([0.0, 1.0], np.nan), ValueError, "weight must be finite and >= 0"),
    (([0.0, 1.0], "1"), TypeError, "weight must be a real number"),
    (([[0.0, 1.0]], 1.0), ValueError, r"state_vector must have shape \(d,\) or \(d, 1\)"),
    (([np.nan], 1.0), ValueError, "state_vector contains NaN"),
])
def test_bad_particle(args, error, message):
    with pytest.raises(error, match=message):
        Particle(*args)


def test_caller_arrays_are_not_modified_or_aliased_for_weights():
    log_w = np.zeros(3)
    state = ParticleState(np.zeros((1, 3)), log_weight=log_w)
    state.log_weight[0] = -1.0
    assert log_w[0] == 0.0


def test_tracks_keep_time_order_and_proxy_the_last_state():
    import fasttrack as ft
    states = [ft.GaussianState([k, 0.0], np.eye(2), timestamp=float(k)) for k in (0, 2, 1, 3)]
    track = ft.Track(states)
    assert [s.timestamp for s in track] == [0.0, 1.0, 2.0, 3.0]
    assert track[-1] is states[3] and track.state is states[3]
    assert np.array_equal(track.mean, states[3].state_vector) and track.covar is states[3].covar
    assert len(track[1:3]) == 2 and isinstance(track[1:3], ft.Track)
    with pytest.raises(AttributeError, match="empty"):
        ft.Track().mean
    with pytest.raises(TypeError, match="mix of datetimes and numbers"):
        ft.Track([states[0], ft.GaussianState([0, 0], np.eye(2), timestamp=datetime.datetime(2026, 1, 1))])
    path = ft.GroundTruthPath([ft.GroundTruthState([1, 2], timestamp=5.0, metadata={"id": 1})])
    assert path.state.metadata == {"id": 1} and path.id
    fixed = ft.ParticleState(np.zeros((2, 3)), fixed_covar=np.eye(2))
    with pytest.raises(ValueError, match=r"state_vector must have 2 rows \(the dimension of "
                                         r"fixed_covar\), got 5"):
        fixed.state_vector = np.zeros((5, 3))
    numpy_times = ft.Track([ft.State([1.0], timestamp=t) for t in np.array([2.0, 1.0, 3.0])]
                           + [ft.State([1.0], timestamp=np.float32(1.5))])
    assert numpy_times.timestamps == [1.0, 1.5, 2.0, 3.0]  # (NumPy floats order too)
    with pytest.raises(TypeError, match="cannot order timestamps None and 0.5: a state "
                                        "without a timestamp"):
        ft.Track([ft.State([1.0], timestamp=t) for t in (None, 1.0, 0.5)])


def test_gaussian_state_detection_and_hypothesis():
    import fasttrack as ft
    g = ft.GaussianState([[1.0], [2.0]], [[2.0, 0.5], [0.5, 1.0]], timestamp=1.0)
    assert g.state_vector.shape == (2, 1) and g.mean is g.state_vector and g.ndim == 2
    with pytest.raises(ValueError, match="covar must be symmetric"):
        ft.GaussianState([0.0, 0.0], [[1.0, 0.2], [0.0, 1.0]])
    with pytest.raises(ValueError, match=r"covar must have shape \(2, 2\)"):
        ft.GaussianState([0.0, 0.0], np.eye(3))
    with pytest.raises(ValueError, match="state_vector contains NaN"):
        ft.GaussianState([np.nan, 0.0], np.eye(2))
    detection = ft.Detection([0.5, 10.0], timestamp=2.0)
    assert detection.state_vector.shape == (2, 1) and detection.measurement_model is None
    assert ft.SingleHypothesis(g, detection) and not ft.SingleHypothesis(g, None)


# --- ownership of history: a filter loop keeps only what the program keeps ------------------

def _pf_filter(n):
    from fasttrack.scenarios import particle_filter_tutorial
    scenario = particle_filter_tutorial(n, steps=2)
    predictor = ft.ParticlePredictor(scenario.transition_model, rng=1)
    updater = ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=2))
    return scenario, predictor, updater


def _ekf_filter():
    from fasttrack.scenarios import extended_kalman_tutorial
    scenario = extended_kalman_tutorial(steps=2)
    return (scenario, ft.ExtendedKalmanPredictor(scenario.transition_model),
            ft.ExtendedKalmanUpdater(scenario.measurement_model))


def _loop(scenario, predictor, updater, steps, track=None):
    """The ordinary filter loop, from scenario.prior: a new detection each step."""
    import datetime
    state, sensor, truth = scenario.prior, scenario.measurement_model, np.array([0.0, 1, 0, 1])
    for k in range(1, steps + 1):
        truth = truth + np.array([1.0, 0, 1, 0])
        timestamp = scenario.prior.timestamp + datetime.timedelta(seconds=k)
        prediction = predictor.predict(state, timestamp)
        state = updater.update(ft.SingleHypothesis(prediction, ft.Detection(
            sensor.function(truth), timestamp=timestamp)))
        if track is not None:
            track.append(state)
        yield state


@pytest.mark.parametrize("make", [lambda: _pf_filter(500), _ekf_filter])
def test_a_filter_loop_keeps_no_history_alive(make):
    import gc
    import weakref
    loop = _loop(*make(), 50)
    early = [weakref.ref(next(loop)) for _ in range(5)]
    last = None
    for last in loop:
        pass
    gc.collect()
    assert [ref() for ref in early] == [None] * 5
    assert last.hypothesis.prediction is None  # used, and nothing else held it
    assert last.hypothesis.measurement is not None  # the detection stays
    # a Track keeps the updates; holding the predictions too keeps them and their priors
    track, predictions = ft.Track(), []
    scenario, predictor, updater = make()
    states = list(_loop(scenario, predictor, updater, 5, track))
    assert all(a is b for a, b in zip(track, states))
    for update in track:
        predictions.append(update.hypothesis.prediction)
    assert predictions == [None] * 5
    kept, state = [scenario.prior], scenario.prior
    for detection in scenario.detections:
        prediction = predictor.predict(state, detection.timestamp)
        predictions.append(prediction)
        state = updater.update(ft.SingleHypothesis(prediction, detection))
        kept.append(state)
    assert [s.hypothesis.prediction for s in kept[1:]] == predictions[-2:]
    assert [p.prior for p in predictions[-2:]] == kept[:-1]


def test_links_are_weak_when_filters_make_them_and_strong_when_given():
    scenario, predictor, updater = _pf_filter(200)
    prior = scenario.prior
    prediction = predictor.predict(prior, prior.timestamp)
    assert prediction.prior is prior and prediction.parent is prior
    update = updater.update(ft.SingleHypothesis(prediction, scenario.detections[0]))
    assert len(update.parent) == 200 and update.parent.parent is None  # indexed, detached
    assert getattr(update.parent, "hypothesis", None) is None
    del scenario, prior
    import gc
    gc.collect()
    assert prediction.prior is None and prediction.parent is None
    assert len(update.parent) == 200  # the resampler's indexed copy is the update's own
    parent = ft.ParticleState(np.zeros((1, 3)))
    assert ft.ParticleState(np.ones((1, 3)), parent=ft.ParticleState(np.zeros((1, 3)))).parent \
        is not None  # a constructor argument is held
    assert ft.ParticleStatePrediction(np.ones((1, 3)), prior=parent).prior is parent


def _rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs /proc")
@pytest.mark.parametrize("make, steps", [(lambda: _pf_filter(100_000), 300),
                                         (_ekf_filter, 30_000)])
def test_long_loops_run_in_flat_memory(make, steps):
    loop = _loop(*make(), steps)
    for _ in range(50):
        next(loop)
    before = _rss_mb()
    for _ in loop:
        pass
    assert _rss_mb() - before < 50  # a particle filter at 1e5 used to grow 7 MB a step


def test_run_filter_is_the_loop_a_user_writes():
    from fasttrack.scenarios import extended_kalman_tutorial
    scenario = extended_kalman_tutorial(steps=6)
    predictor = ft.ExtendedKalmanPredictor(scenario.transition_model)
    updater = ft.ExtendedKalmanUpdater(scenario.measurement_model)
    track = ft.run_filter(predictor, updater, scenario.prior, scenario.detections)
    state, by_hand = scenario.prior, []
    for detection in scenario.detections:
        state = updater.update(ft.SingleHypothesis(predictor.predict(state, detection.timestamp),
                                                   detection))
        by_hand.append(state)
    assert isinstance(track, ft.Track) and len(track) == len(by_hand)
    for ours, theirs in zip(track, by_hand):
        assert np.array_equal(ours.state_vector, theirs.state_vector)
        assert np.array_equal(ours.covar, theirs.covar)
    assert [update.hypothesis.measurement for update in track] == scenario.detections
    with pytest.raises(TypeError, match=r"detections\[1\] must be a Detection, got ndarray"):
        ft.run_filter(predictor, updater, scenario.prior,
                      [scenario.detections[0], np.zeros(2)])


def test_position_rmse_pairs_by_order_or_by_timestamp():
    from fasttrack.metrics import position_rmse
    truth = [ft.GroundTruthState([k, 0, 0, 0], timestamp=float(k)) for k in range(5)]
    track = [ft.GaussianState([k + 1, 0, 0, 0], np.eye(4), timestamp=float(k))
             for k in (1, 3)]
    assert position_rmse(track, truth, pair="timestamp") == pytest.approx(1.0)
    with pytest.raises(ValueError, match="pair='timestamp' matches them by time"):
        position_rmse(track, truth)
    with pytest.raises(ValueError, match=r"truth has no state at the track's timestamps \[9.0\]"):
        position_rmse([ft.GaussianState([0, 0, 0, 0], np.eye(4), timestamp=9.0)], truth,
                      pair="timestamp")
    with pytest.raises(ValueError, match="pair must be"):
        position_rmse(track, truth, pair="time")


@pytest.mark.parametrize("state", [
    lambda: ft.WeightedGaussianState([0.0, 0.0], np.eye(2), 0.5, 1.0),
    lambda: ft.Detection([0.0], timestamp=1.0),
    lambda: ft.ParticleState(np.zeros((2, 3)), timestamp=1.0),
    lambda: ft.KernelParticleState(np.zeros((2, 3)), timestamp=1.0)])
def test_a_timestamp_set_later_is_checked_as_the_constructor_checks_it(state):
    """A NaN timestamp assigned after construction was kept (the constructor refuses it)."""
    state = state()
    with pytest.raises(ValueError, match="timestamp must be finite, got nan"):
        state.timestamp = np.nan
    with pytest.raises(TypeError, match="timestamp must be None, a datetime"):
        state.timestamp = "now"
    state.timestamp = 2.0
    assert state.timestamp == 2.0
