"""The Rauch-Tung-Striebel smoother over a 1000-step CV 4-D track (linear position sensor),
fasttrack's KalmanSmoother.smooth(track) against Stone Soup 1.9.1's in the same run (the
track built by each library's Kalman predictor and updater from the same detections, as in
stonesoup_mtt_baseline.ss_rts); plus the array entry for that track and for 100 such tracks
in one call, and the forward-filter backward-simulation smoother (100 paths through a
100-step particle filter of N = 1000 on the same model), by rejection (the default) and by
the exact draw."""
import datetime

import numpy as np
import pytest

import fasttrack as ft

START = datetime.datetime(2025, 1, 1)
STEP = datetime.timedelta(seconds=1)
STEPS = 1000


def _measurements(n=STEPS):
    rng = np.random.default_rng(0)
    return [np.array([[k + rng.normal()], [k + rng.normal()]]) for k in range(1, n + 1)]


def _ft_track():
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    prior = ft.GaussianState([0.0, 1.0, 0.0, 1.0], np.eye(4), timestamp=START)
    detections = [ft.Detection(z, timestamp=START + (k + 1) * STEP)
                  for k, z in enumerate(_measurements())]
    track = ft.run_filter(ft.KalmanPredictor(transition), ft.KalmanUpdater(sensor), prior,
                          detections)
    return transition, track


def test_rts_1000_fasttrack(benchmark):
    benchmark.group = "rts-smoother N=1000"
    transition, track = _ft_track()
    smoother = ft.KalmanSmoother(transition)
    smoother.smooth(track)  # compile / load the kernel
    result = benchmark.pedantic(smoother.smooth, args=(track,), rounds=200, iterations=5,
                                warmup_rounds=5)
    assert len(result) == STEPS


def test_rts_1000_stonesoup(benchmark):
    pytest.importorskip("stonesoup")
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.smoother.kalman import KalmanSmoother
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater

    benchmark.group = "rts-smoother N=1000"
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05),
                                                        ConstantVelocity(0.05)])
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    predictor, updater = KalmanPredictor(transition), KalmanUpdater(sensor)
    track = Track([GaussianState(np.array([[0.], [1.], [0.], [1.]]), np.eye(4),
                                 timestamp=START)])
    for k, z in enumerate(_measurements()):
        detection = Detection(z, timestamp=START + (k + 1) * STEP, measurement_model=sensor)
        track.append(updater.update(SingleHypothesis(
            predictor.predict(track[-1], timestamp=detection.timestamp), detection)))
    smoother = KalmanSmoother(transition)
    result = benchmark.pedantic(smoother.smooth, args=(track,), rounds=5, iterations=1,
                                warmup_rounds=1)
    assert len(result) == STEPS + 1


def test_rts_1000_objects_floor(benchmark):
    """The floor of smooth(track) without smoothing: reading the 1000 states' arrays and
    timestamps and building the 999 new states that a smoothed track holds."""
    benchmark.group = "rts-smoother-floor"
    benchmark.extra_info["n"] = STEPS
    _, track = _ft_track()
    states = track.states

    def read_and_build():
        means = np.array([s.state_vector for s in states])
        covars = np.array([s.covar for s in states])
        origin = states[0].timestamp
        np.array([s.timestamp - origin for s in states])
        new = object.__new__
        out = []
        for state, mean, covar in zip(states[:-1], means, covars):
            attributes = state.__dict__.copy()
            attributes.update(state_vector=mean, covar=covar)
            built = new(type(state))
            built.__dict__ = attributes
            out.append(built)
        return out

    assert len(benchmark.pedantic(read_and_build, rounds=200, iterations=5,
                                  warmup_rounds=5)) == STEPS - 1


def _track_arrays(track):
    return np.array([s.state_vector[:, 0] for s in track]), np.array([s.covar for s in track])


def test_rts_arrays_1000_fasttrack(benchmark):
    """The same track given as arrays: the smoother's own cost, without reading and building
    1000 state objects."""
    benchmark.group = "rts-smoother-arrays N=1000"
    transition, track = _ft_track()
    means, covars = _track_arrays(track)
    smoother = ft.KalmanSmoother(transition)
    smoother.smooth_arrays(means, covars, STEP)
    xs, _ = benchmark.pedantic(smoother.smooth_arrays, args=(means, covars, STEP), rounds=200,
                               iterations=5, warmup_rounds=5)
    assert xs.shape == (STEPS, 4)


def test_rts_arrays_100_tracks_fasttrack(benchmark):
    benchmark.group = "rts-smoother-100-tracks N=1000"
    transition, track = _ft_track()
    means, covars = _track_arrays(track)
    means, covars = np.repeat(means[None], 100, 0), np.repeat(covars[None], 100, 0)
    smoother = ft.KalmanSmoother(transition)
    smoother.smooth_arrays(means, covars, STEP)
    xs, _ = benchmark.pedantic(smoother.smooth_arrays, args=(means, covars, STEP), rounds=30,
                               iterations=1, warmup_rounds=2)
    assert xs.shape == (100, STEPS, 4)


FFBS_STEPS, FFBS_PARTICLES, FFBS_PATHS = 100, 1000, 100


def _pf_track():
    """A bootstrap particle filter's posteriors over the first 100 detections."""
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    rng = np.random.default_rng(1)
    prior = ft.ParticleState(np.array([[0.0], [1.0], [0.0], [1.0]])
                             + rng.normal(size=(4, FFBS_PARTICLES)), timestamp=START)
    detections = [ft.Detection(z, timestamp=START + (k + 1) * STEP)
                  for k, z in enumerate(_measurements(FFBS_STEPS))]
    track = ft.run_filter(ft.ParticlePredictor(transition, rng=2),
                          ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=3)), prior,
                          detections)
    return transition, track


def _time_ffbs(benchmark, method, rounds):
    benchmark.group = f"ffbs N={FFBS_PARTICLES}"
    transition, track = _pf_track()
    ft.ffbs(track, transition, FFBS_PATHS, rng=4, method=method)  # compile / load the kernel
    paths = benchmark.pedantic(ft.ffbs, args=(track, transition, FFBS_PATHS),
                               kwargs={"rng": 4, "method": method}, rounds=rounds,
                               iterations=1, warmup_rounds=1)
    assert paths.shape == (FFBS_STEPS, 4, FFBS_PATHS)


def test_ffbs_1000_fasttrack(benchmark):
    """The default, rejection with the exact draw as fallback (report.py's target)."""
    _time_ffbs(benchmark, "rejection", rounds=30)


def test_ffbs_1000_exact(benchmark):
    _time_ffbs(benchmark, "exact", rounds=5)
