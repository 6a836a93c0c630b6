"""The multi-target scenario simulator and the array tracker, against Stone Soup's
MultiTargetTracker built from its own components on the same scans."""
import datetime

import numpy as np
import pytest

import fasttrack as ft
from fasttrack.simulate import multi_target
from fasttrack.tracker import MultiTargetTracker
from fasttrack.types.mixture import IMMTrackSet, TrackSet

TRANSITION = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
SENSOR = ft.LinearGaussian(4, (0, 2), np.eye(2))
PRIOR_COVAR = np.diag([0.0, 1.0, 0.0, 1.0])


def _scenario(n=10, steps=15, clutter=5.0, seed=3, spacing=25.0):
    rng = np.random.default_rng(seed)
    pos = np.c_[np.arange(n) % 4, np.arange(n) // 4] * spacing + rng.normal(0, 1, (n, 2))
    vel = rng.normal(0, 1, (n, 2))
    x0 = np.c_[pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]]
    return multi_target(TRANSITION, SENSOR, x0, steps, [[-30, -30], [130, 130]],
                        prob_detect=0.9, clutter_rate=clutter, rng=seed)


def _tracker(**options):
    settings = dict(prior_mean=np.zeros(4), prior_covar=PRIOR_COVAR, missed_distance=3.0,
                    min_points=3, delete_after_misses=3, tentative_misses=2)
    return MultiTargetTracker(TRANSITION, SENSOR, **{**settings, **options})


def test_simulated_scans_have_the_asked_detection_and_clutter_rates():
    scenario = multi_target(TRANSITION, SENSOR, np.zeros((200, 4)), 50, [[-50, -50], [50, 50]],
                            prob_detect=0.8, clutter_rate=30.0, rng=0)
    origins = np.concatenate(scenario.origins)
    assert (origins >= 0).sum() / (200 * 50) == pytest.approx(0.8, abs=0.01)
    assert (origins < 0).sum() / 50 == pytest.approx(30.0, rel=0.05)
    assert scenario.clutter_density == pytest.approx(30.0 / 1e4)
    for detections, found, truths, ids in zip(scenario.detections, scenario.origins,
                                              scenario.truths, scenario.truth_ids):
        clutter = detections[found < 0]
        assert np.all((clutter >= -50) & (clutter <= 50))
        index = {i: k for k, i in enumerate(ids)}
        rows = [index[i] for i in found[found >= 0]]
        residuals = detections[found >= 0] - truths[rows][:, [0, 2]]
        assert np.abs(residuals).max() < 6  # sensor noise R = I


def test_births_and_deaths_change_the_target_set():
    scenario = multi_target(TRANSITION, SENSOR, np.zeros((50, 4)), 40, [[-50, -50], [50, 50]],
                            prob_survive=0.97, birth_rate=2.0, birth_mean=np.zeros(4),
                            birth_covar=np.eye(4), rng=1)
    alive = [ids.size for ids in scenario.truth_ids]
    assert alive[0] == 50 and 40 < alive[-1] < 120
    assert np.unique(np.concatenate(scenario.truth_ids)).size > 100  # new identities


def test_tracker_finds_the_targets_with_few_false_tracks():
    scenario = _scenario(n=12, steps=25, clutter=3.0)
    tracker = _tracker()
    for t, detections in enumerate(scenario.detections):
        tracks = tracker.step(detections, float(t))
    truth = scenario.truths[-1][:, [0, 2]]
    error = np.linalg.norm(tracks.means[:, None, [0, 2]] - truth[None], axis=2)
    assert (error.min(axis=0) < 3).mean() >= 0.9  # targets held
    assert (error.min(axis=1) < 3).mean() >= 0.9  # tracks on targets
    assert np.unique(tracks.ids).size == len(tracks)


def _stone_soup_tracks(scenario):
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.deleter.time import UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetTracker as SSTracker
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import KalmanUpdater

    start, step = datetime.datetime(2026, 1, 1), datetime.timedelta(seconds=1)
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    predictor = KalmanPredictor(CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(0.05), ConstantVelocity(0.05)]))
    updater = KalmanUpdater(sensor)
    associator = GNNWith2DAssignment(DistanceHypothesiser(predictor, updater, Mahalanobis(),
                                                          missed_distance=3.0))
    initiator = MultiMeasurementInitiator(
        GaussianState(np.zeros((4, 1)), PRIOR_COVAR), UpdateTimeStepsDeleter(2), associator,
        updater, measurement_model=sensor, min_points=3)
    scans = [(start + t * step, {Detection(z.reshape(2, 1), timestamp=start + t * step,
                                           measurement_model=sensor) for z in detections})
             for t, detections in enumerate(scenario.detections)]
    tracker = SSTracker(initiator, UpdateTimeStepsDeleter(3), iter(scans), associator, updater)
    return [np.array([np.ravel(track.state_vector) for track in tracks]).reshape(-1, 4)
            for _, tracks in tracker]


def test_tracker_equals_stone_soups_multi_target_tracker_scan_by_scan():
    pytest.importorskip("stonesoup")
    scenario = _scenario()
    tracker = _tracker()
    stone_soup = _stone_soup_tracks(scenario)
    confirmed = 0
    for t, (detections, theirs) in enumerate(zip(scenario.detections, stone_soup)):
        ours = tracker.step(detections, float(t)).means
        ours = np.array(sorted(ours, key=lambda x: tuple(x))).reshape(-1, 4)
        theirs = np.array(sorted(theirs, key=lambda x: tuple(x))).reshape(-1, 4)
        assert ours.shape == theirs.shape, f"scan {t}"
        np.testing.assert_allclose(ours, theirs, rtol=1e-9, atol=1e-9, err_msg=f"scan {t}")
        confirmed = max(confirmed, len(ours))
    assert confirmed >= 8


def test_tracker_memory_stays_flat_over_many_scans():
    import tracemalloc
    scenario = _scenario(n=40, steps=120, clutter=20.0)
    tracker = _tracker()
    for t, detections in enumerate(scenario.detections[:20]):
        tracker.step(detections, float(t))
    tracemalloc.start()
    for t, detections in enumerate(scenario.detections[20:], start=20):
        tracker.step(detections, float(t))
        if t == 40:
            early = tracemalloc.get_traced_memory()[0]
    late = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    assert late - early < 200_000  # bytes: no per-scan growth


def test_tracker_rejects_bad_input():
    with pytest.raises(TypeError, match="measurement_model must be a LinearGaussian"):
        MultiTargetTracker(TRANSITION, ft.CartesianToBearingRange(4, (0, 2), np.eye(2)),
                           np.zeros(4), PRIOR_COVAR)
    with pytest.raises(ValueError, match="prior_mean must have 4 components"):
        _tracker(prior_mean=np.zeros(3))
    with pytest.raises(ValueError, match="missed_distance must be finite and > 0"):
        _tracker(missed_distance=0)
    with pytest.raises(ValueError, match="association must be one of"):
        _tracker(association="jpda2")
    tracker = _tracker()
    tracker.step(np.zeros((1, 2)), 1.0)
    with pytest.raises(ValueError, match="time must be after the previous scan's"):
        tracker.step(np.zeros((1, 2)), 1.0)
    with pytest.raises(ValueError, match="detections contains NaN"):
        tracker.step(np.full((1, 2), np.nan), 2.0)
    with pytest.raises(ValueError, match="region must be"):
        multi_target(TRANSITION, SENSOR, np.zeros((2, 4)), 3, [[0, 0], [-1, 1]])


@pytest.mark.parametrize("arguments, error, match", [
    (dict(missed_distance=np.inf), ValueError, "missed_distance must be finite, got inf"),
    (dict(missed_distance=np.nan), ValueError, "missed_distance must be finite"),
    (dict(missed_distance="3"), TypeError, "missed_distance must be a real number"),
    (dict(max_covar_trace=np.nan), ValueError, "max_covar_trace must be > 0, got nan"),
    (dict(max_covar_trace=-1.0), ValueError, "max_covar_trace must be > 0"),
    (dict(max_covar_trace="1"), TypeError, "max_covar_trace must be a numeric array"),
    (dict(missed_distance=1e200), ValueError, r"missed_distance must lie in \[1e-154, 1e154\)"),
    (dict(missed_distance=1e-300), ValueError, r"missed_distance must lie in \[1e-154, 1e154\)"),
    (dict(association=["gnn"]), ValueError, "association must be one of"),
    (dict(prior_covar=np.diag([1.0, -1.0, 1.0, 1.0])), ValueError,
     "prior_covar is not positive semi-definite"),
])
def test_tracker_names_a_bad_setting(arguments, error, match):
    with pytest.raises(error, match=match):
        _tracker(**arguments)


@pytest.mark.parametrize("name, value, error, match", [
    ("min_points", "a", TypeError, "min_points must be an int, got str"),
    ("min_points", 0, ValueError, "min_points must be >= 1, got 0"),
    ("delete_after_misses", 1.5, TypeError, "delete_after_misses must be an int"),
    ("tentative_misses", -1, ValueError, "tentative_misses must be >= 1"),
    ("confirm_within", 2, ValueError, "confirm_within must be >= 3, got 2"),
    ("missed_distance", np.inf, ValueError, "missed_distance must be finite"),
    ("max_covar_trace", np.nan, ValueError, "max_covar_trace must be > 0, got nan"),
    ("time", "x", TypeError, "time must be a real number, got str"),
    ("confirmed", None, TypeError, "confirmed must be of type TrackSet, got NoneType"),
    ("tentative", TrackSet.empty(6), ValueError, r"tentative.means must be a float64 array "
                                                 r"of shape \(0, 4\) \(0 tracks\), got "
                                                 r"float64 of shape \(0, 6\)"),
])
def test_tracker_settings_are_checked_when_changed(name, value, error, match):
    tracker = _tracker(confirm_within=5)
    tracker.step([[0.0, 0.0]], 0.0)
    before = getattr(tracker, name)
    with pytest.raises(error, match=match):
        setattr(tracker, name, value)
    assert getattr(tracker, name) is before  # the tracker unchanged
    with pytest.raises(ValueError, match="min_points must be <= confirm_within \\(5\\), got 6"):
        tracker.min_points = 6
    tracker.confirm_within, tracker.min_points = None, 6  # (no window: any M)
    assert len(tracker.step([[0.0, 0.0]], 1.0)) == 0


@pytest.mark.parametrize("detections, time, error, match", [
    (np.zeros((2, 3)), 1.0, ValueError, r"detections must have shape \(M, 2\).*\(2, 3\)"),
    (np.zeros(2), 1.0, ValueError, r"detections must have shape \(M, 2\).*\(2,\)"),
    (np.zeros((1, 1, 2)), 1.0, ValueError, "detections must have shape"),
    ([["a", "b"]], 1.0, TypeError, "detections must be a numeric array"),
    (np.zeros((1, 2)), np.nan, ValueError, "time must be finite"),
    (np.zeros((1, 2)), np.inf, ValueError, "time must be finite"),
    (np.zeros((1, 2)), None, TypeError, "time must be a real number, got NoneType"),
    (np.zeros((1, 2)), "1", TypeError, "time must be a real number, got str"),
    (np.zeros((1, 2)), datetime.datetime(2026, 1, 1), TypeError,
     "time must be a real number, got datetime"),
])
def test_tracker_step_names_a_bad_scan(detections, time, error, match):
    tracker = _tracker()
    tracker.step([[0.0, 0.0]], 0.0)
    with pytest.raises(error, match=match):
        tracker.step(detections, time)
    assert tracker.time == 0.0  # nothing changed
    assert len(tracker.tentative) == 1


def test_an_infinite_covariance_trace_limit_deletes_nothing_and_long_gaps_are_named():
    scenario = _scenario(n=10, steps=8, clutter=5.0)
    unlimited, none = _tracker(max_covar_trace=np.inf), _tracker()
    for t, detections in enumerate(scenario.detections):
        a, b = unlimited.step(detections, float(t)), none.step(detections, float(t))
        np.testing.assert_array_equal(a.ids, b.ids)
    with pytest.raises(ValueError, match="time_interval of 1e\\+300 s overflows Q"):
        unlimited.step(scenario.detections[0], 1e300)


def test_tracker_takes_an_empty_scan_in_any_empty_shape():
    tracker = _tracker()
    for t, scan in enumerate([[], np.empty((0, 2)), np.empty(0)]):
        assert len(tracker.step(scan, float(t))) == 0


def test_track_sets_are_not_changed_by_later_scans():
    scenario = _scenario(n=10, steps=12, clutter=5.0)
    tracker = _tracker()
    kept = []
    for t, detections in enumerate(scenario.detections):
        tracks = tracker.step(detections, float(t))
        kept.append((tracks, [field.copy() for field in tracks._fields()]))
    assert len(kept[-1][0]) > 0
    for tracks, copies in kept:
        for field, copy in zip(tracks._fields(), copies):
            np.testing.assert_array_equal(field, copy)


@pytest.mark.parametrize("window, confirmed", [(None, True), (3, True), (2, False)])
def test_m_of_n_confirmation(window, confirmed):
    """One target detected at scans 0 and 2, missed at 1: 2 of 3 confirms it; with N = 2
    the track runs out of time after scan 1 (and scan 2's detection starts a new one)."""
    tracker = _tracker(min_points=2, tentative_misses=2, confirm_within=window)
    for t, scan in enumerate([[[0.0, 0.0]], [], [[0.0, 0.0]]]):
        tracks = tracker.step(np.array(scan).reshape(-1, 2), float(t))
    assert (len(tracks) == 1) is confirmed
    assert len(tracker.tentative) == (0 if confirmed else 1)
    if confirmed:
        assert tracks.ids[0] == 0 and tracks.updates[0] == 2 and tracks.ages[0] == 2


def test_m_of_n_window_must_allow_m_detections():
    with pytest.raises(ValueError, match="confirm_within must be >= 3"):
        _tracker(confirm_within=2)


def test_track_sets_of_different_kinds_do_not_join():
    with pytest.raises(ValueError, match=r"the track sets' means differ in shape: \(0, 4\) and "
                                         r"\(0, 6\)"):
        TrackSet.concatenate(TrackSet.empty(4), TrackSet.empty(6))
    with pytest.raises(TypeError, match="second must be a TrackSet, as first is, got "
                                        "IMMTrackSet"):
        TrackSet.concatenate(TrackSet.empty(4), IMMTrackSet.empty(4, 2))
    with pytest.raises(ValueError, match="d must be >= 1, got -1"):
        TrackSet.empty(-1)
    with pytest.raises(ValueError, match="models must be >= 1, got 0"):
        IMMTrackSet.empty(4, 0)
    assert len(TrackSet.concatenate(TrackSet.empty(4), TrackSet.empty(4))) == 0


def test_new_tracks_start_from_the_current_sensor():
    tracker = MultiTargetTracker(TRANSITION, ft.LinearGaussian(4, (0, 2), np.eye(2)),
                                 np.zeros(4), PRIOR_COVAR)
    tracker.step([[0.0, 0.0]], 0.0)
    first = tracker.tentative.covars[0].copy()
    tracker.measurement_model.noise_covar = 4.0 * np.eye(2)  # (a parameter assigned)
    tracker.step([[50.0, 50.0]], 1.0)
    np.testing.assert_allclose(tracker.tentative.covars[-1][[0, 2]][:, [0, 2]],
                               4.0 * first[[0, 2]][:, [0, 2]])
    tracker.measurement_model = ft.LinearGaussian(4, (0, 2), 9.0 * np.eye(2))  # (a new one)
    tracker.step([[-50.0, 50.0]], 2.0)
    np.testing.assert_allclose(tracker.tentative.covars[-1][[0, 2]][:, [0, 2]],
                               9.0 * first[[0, 2]][:, [0, 2]])
