"""Multi-target association, one scan: predict every track, gate, solve the global nearest
neighbour assignment (``GNNWith2DAssignment`` + ``DistanceHypothesiser(Mahalanobis,
missed_distance=5)``), on targets on a jittered 20 m grid (CV 4-state, position sensor,
R = I), N tracks x N detections. fasttrack's arrays against the NumPy + SciPy reference
(dense cost matrix + ``linear_sum_assignment``) and Stone Soup in the same run. And a whole
tracker (N targets, N clutter per scan, P_D = 0.9) over the scans of a scenario."""
import datetime

import numpy as np
import pytest

import fasttrack as ft
from fasttrack.core.gating import gate
from fasttrack.core.assign import global_nearest_neighbour

PRIOR_COVAR = np.diag([1.0, 0.1, 1.0, 0.1])
MISSED = 5.0


def scenario(n, spacing=20.0, seed=0):
    """Prior means (n, 4) and one detection per target (n, 2)."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n)))
    gx, gy = np.meshgrid(np.arange(side), np.arange(side))
    pos = np.c_[gx.ravel(), gy.ravel()][:n] * spacing + rng.normal(0, 1, (n, 2))
    vel = rng.normal(0, 1, (n, 2))
    means = np.c_[pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]]
    return means, pos + vel + rng.normal(0, 1, (n, 2))


def _fasttrack_associate(n):
    means, detections = scenario(n)
    covars = np.broadcast_to(PRIOR_COVAR, (n, 4, 4)).copy()
    batch = ft.BatchExtendedKalmanFilter(
        ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2),
        ft.LinearGaussian(4, (0, 2), np.eye(2)))

    def associate():
        _, _, z_hats, innovation_covars = batch.predict(means, covars, 1.0)
        return global_nearest_neighbour(gate(z_hats, innovation_covars, detections,
                                             MISSED ** 2), MISSED)
    return associate


def _floor_associate(n):
    from scipy.optimize import linear_sum_assignment
    means, detections = scenario(n)
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    f, q = transition.matrix(time_interval=1.0), transition.covar(time_interval=1.0)
    h = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    covars = np.broadcast_to(PRIOR_COVAR, (n, 4, 4))

    def associate():
        x = means @ f.T
        p = f @ covars @ f.T + q
        s_inv = np.linalg.inv(h @ p @ h.T + np.eye(2))
        v = detections[None] - (x @ h.T)[:, None]
        cost = np.sqrt(np.einsum("tdi,tij,tdj->td", v, s_inv, v))
        augmented = np.full((n, 2 * n), np.inf)
        augmented[:, :n] = np.where(cost < MISSED, cost, np.inf)
        augmented[np.arange(n), n + np.arange(n)] = MISSED
        _, columns = linear_sum_assignment(augmented)
        return np.where(columns < n, columns, -1)
    return associate


@pytest.mark.parametrize("n", [100, 1000, 10_000])
def test_gnn_fasttrack(benchmark, n):
    benchmark.group = f"gnn-associate N={n}"
    associate = _fasttrack_associate(n)
    assert (associate() >= 0).mean() > 0.95
    benchmark.pedantic(associate, rounds=20 if n < 10_000 else 5, warmup_rounds=1)


@pytest.mark.parametrize("n", [100, 1000])
def test_gnn_numpy_reference(benchmark, n):
    benchmark.group = f"gnn-associate N={n}"
    associate = _floor_associate(n)
    np.testing.assert_array_equal(associate(), _fasttrack_associate(n)())  # same assignment
    benchmark.pedantic(associate, rounds=10 if n < 1000 else 3, warmup_rounds=1)


@pytest.mark.parametrize("n", [100])
def test_gnn_stonesoup(benchmark, n):
    pytest.importorskip("stonesoup")
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater

    benchmark.group = f"gnn-associate N={n}"
    start, step = datetime.datetime(2026, 1, 1), datetime.timedelta(seconds=1)
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    predictor = KalmanPredictor(CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(0.05), ConstantVelocity(0.05)]))
    hypothesiser = DistanceHypothesiser(predictor, KalmanUpdater(sensor), Mahalanobis(),
                                        missed_distance=MISSED)
    associator = GNNWith2DAssignment(hypothesiser)
    means, detections = scenario(n)

    def setup():  # fresh tracks: Stone Soup memoises predictions
        tracks = {Track([GaussianState(x.reshape(4, 1), PRIOR_COVAR, timestamp=start)])
                  for x in means}
        dets = {Detection(z.reshape(2, 1), timestamp=start + step, measurement_model=sensor)
                for z in detections}
        return (tracks, dets), {}

    benchmark.pedantic(lambda tracks, dets: associator.associate(tracks, dets, start + step),
                       setup=setup, rounds=3, warmup_rounds=0)


def _tracking_scenario(n, steps, seed=0):
    from fasttrack.simulate import multi_target
    means, _ = scenario(n, seed=seed)
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    side = 20.0 * np.ceil(np.sqrt(n))
    return transition, sensor, multi_target(transition, sensor, means, steps,
                                            [[-50, -50], [side + 50, side + 50]],
                                            prob_detect=0.9, clutter_rate=float(n), rng=seed)


def _track_all(transition, sensor, scans):
    from fasttrack.tracker import MultiTargetTracker
    tracker = MultiTargetTracker(transition, sensor, np.zeros(4), np.diag([0, 1.0, 0, 1.0]),
                                 missed_distance=3.0, min_points=3, delete_after_misses=3,
                                 tentative_misses=2)
    return [len(tracker.step(z, float(t))) for t, z in enumerate(scans)]


@pytest.mark.parametrize("n, steps", [(100, 5), (1000, 100)])
def test_tracker_fasttrack(benchmark, n, steps):
    """A whole scenario: n targets, n clutter per scan, P_D = 0.9."""
    benchmark.group = f"tracker-{steps}-scans N={n}"
    transition, sensor, simulated = _tracking_scenario(n, steps)
    confirmed = benchmark.pedantic(_track_all, args=(transition, sensor, simulated.detections),
                                   rounds=3 if n < 1000 else 1, warmup_rounds=0)
    assert confirmed[-1] > 0.8 * n if steps > 3 else True


@pytest.mark.parametrize("n, steps", [(100, 5)])
def test_tracker_stonesoup(benchmark, n, steps):
    pytest.importorskip("stonesoup")
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.deleter.time import UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetTracker
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import KalmanUpdater

    benchmark.group = f"tracker-{steps}-scans N={n}"
    _, _, simulated = _tracking_scenario(n, steps)
    start, step = datetime.datetime(2026, 1, 1), datetime.timedelta(seconds=1)
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    predictor = KalmanPredictor(CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(0.05), ConstantVelocity(0.05)]))
    updater = KalmanUpdater(sensor)
    associator = GNNWith2DAssignment(DistanceHypothesiser(predictor, updater, Mahalanobis(),
                                                          missed_distance=3.0))

    def track_all():
        initiator = MultiMeasurementInitiator(
            GaussianState(np.zeros((4, 1)), np.diag([0, 1.0, 0, 1.0])),
            UpdateTimeStepsDeleter(2), associator, updater, measurement_model=sensor,
            min_points=3)
        scans = [(start + t * step, {Detection(z.reshape(2, 1), timestamp=start + t * step,
                                               measurement_model=sensor) for z in scan})
                 for t, scan in enumerate(simulated.detections)]
        tracker = MultiTargetTracker(initiator, UpdateTimeStepsDeleter(3), iter(scans),
                                     associator, updater)
        return [len(tracks) for _, tracks in tracker]

    benchmark.pedantic(track_all, rounds=1, warmup_rounds=0)
