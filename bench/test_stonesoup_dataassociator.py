"""Stone Soup data association through fasttrack.stonesoup (Stone Soup objects in and out)
against pure Stone Soup 1.9.1 and fasttrack's native arrays, in the same run:

- ``GNNWith2DAssignment`` + ``DistanceHypothesiser(Mahalanobis(), missed_distance=5)``,
  300 tracks x 300 detections on a jittered 20 m grid (the baseline's ``ss_gnn``);
- ``JPDAwithEHM`` + ``PDAHypothesiser(prob_detect=0.9, prob_gate=0.99)``, 100 targets on a
  jittered 6 m grid + 100 clutter points (the baseline's ``ss_jpda``).

CV 4-state tracks, position sensor R = I, one ``associate`` call (predict every track,
hypothesise, solve). Each round starts from fresh tracks (Stone Soup memoises predictions).
Targets: the drop-in at least 100x Stone Soup.
"""
import datetime

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.dataassociator.neighbour import GNNWith2DAssignment  # noqa: E402
from stonesoup.dataassociator.probability import JPDAwithEHM  # noqa: E402
from stonesoup.hypothesiser.distance import DistanceHypothesiser  # noqa: E402
from stonesoup.hypothesiser.probability import PDAHypothesiser  # noqa: E402
from stonesoup.measures import Mahalanobis  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor.kalman import KalmanPredictor  # noqa: E402
from stonesoup.types.detection import Clutter, Detection  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402
from stonesoup.updater.kalman import KalmanUpdater  # noqa: E402

import fasttrack as ft  # noqa: E402
import fasttrack.stonesoup as fss  # noqa: E402
from fasttrack.core.gating import clusters, gate  # noqa: E402
from fasttrack.core.jpda import jpda_marginals  # noqa: E402
from fasttrack.core.assign import global_nearest_neighbour  # noqa: E402

T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)
PRIOR_COVAR = np.diag([1.0, 0.1, 1.0, 0.1])
MISSED = 5.0
PROB_DETECT, PROB_GATE = 0.9, 0.99
IMPLEMENTATIONS = ["dropin", "stonesoup", "fasttrack"]


def scenario(n, spacing, seed=0):
    """Initial states (n, 4) on a jittered grid and one detection (n, 2) per target a
    second later (as /work/shared/stonesoup_mtt_baseline.py)."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n)))
    gx, gy = np.meshgrid(np.arange(side), np.arange(side))
    pos = np.c_[gx.ravel(), gy.ravel()][:n] * spacing + rng.normal(0, 1, (n, 2))
    vel = rng.normal(0, 1, (n, 2))
    return np.c_[pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]], pos + vel + rng.normal(0, 1, (n, 2))


def _stone_soup_models():
    return (CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2),
            LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2)))


def _native_models():
    return (ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2),
            ft.LinearGaussian(4, (0, 2), np.eye(2)))


def _objects(x0, points, clutter, sensor):
    """Fresh Stone Soup tracks and detections (the set-up of a round, not timed)."""
    tracks = {Track([GaussianState(x.reshape(4, 1), PRIOR_COVAR, timestamp=T0)]) for x in x0}
    detections = {Detection(z.reshape(2, 1), timestamp=T0 + DT, measurement_model=sensor)
                  for z in points}
    detections |= {Clutter(z.reshape(2, 1), timestamp=T0 + DT, measurement_model=sensor)
                   for z in clutter}
    return (tracks, detections), {}


def _run(benchmark, implementation, associate, setup):
    slow = implementation == "stonesoup"
    benchmark.pedantic(associate, setup=setup, rounds=3 if slow else 15,
                       warmup_rounds=0 if slow else 1)


@pytest.mark.parametrize("implementation", IMPLEMENTATIONS)
def test_gnn_associate(benchmark, implementation):
    n = 300
    benchmark.group = f"dropin-gnn-associate N={n}"
    x0, points = scenario(n, spacing=20.0)
    if implementation == "fasttrack":
        covars = np.broadcast_to(PRIOR_COVAR, (n, 4, 4)).copy()
        batch = ft.BatchExtendedKalmanFilter(*_native_models())

        def associate():
            _, _, z_hats, s = batch.predict(x0, covars, 1.0)
            return global_nearest_neighbour(gate(z_hats, s, points, MISSED**2), MISSED)

        _run(benchmark, implementation, associate, None)
        return
    classes = (fss.KalmanPredictor, fss.KalmanUpdater, fss.DistanceHypothesiser,
               fss.Mahalanobis, fss.GNNWith2DAssignment) if implementation == "dropin" else (
        KalmanPredictor, KalmanUpdater, DistanceHypothesiser, Mahalanobis, GNNWith2DAssignment)
    transition, sensor = _stone_soup_models()
    predictor, updater, hypothesiser, measure, associator = classes
    associator = associator(hypothesiser(predictor(transition), updater(sensor), measure(),
                                         missed_distance=MISSED))

    def associate(tracks, detections):
        associations = associator.associate(tracks, detections, T0 + DT)
        assert len(associations) == n and sum(map(bool, associations.values())) > 0.95 * n

    _run(benchmark, implementation, associate,
         lambda: _objects(x0, points, np.zeros((0, 2)), sensor))


@pytest.mark.parametrize("implementation", IMPLEMENTATIONS)
def test_jpda_ehm_associate(benchmark, implementation):
    n = 100
    benchmark.group = f"dropin-jpda-ehm N={n}"
    x0, points = scenario(n, spacing=6.0)
    lo, hi = points.min(0) - 10, points.max(0) + 10
    clutter = np.random.default_rng(1).uniform(lo, hi, (n, 2))
    density = n / float(np.prod(hi - lo))
    if implementation == "fasttrack":
        covars = np.broadcast_to(PRIOR_COVAR, (n, 4, 4)).copy()
        batch = ft.BatchExtendedKalmanFilter(*_native_models())
        everything = np.r_[points, clutter]
        from scipy.stats import chi2
        threshold = chi2.ppf(PROB_GATE, 2)

        def associate():
            _, _, z_hats, s = batch.predict(x0, covars, 1.0)
            pairs = gate(z_hats, s, everything, threshold)
            groups = clusters(pairs)
            weights = np.exp(pairs.log_likelihoods) * PROB_DETECT / density
            owners = pairs.tracks()
            matrices = []
            for c in range(groups.n_clusters):
                tracks, dets = groups.members(c)
                if tracks.size == 0:
                    continue
                column = np.zeros(everything.shape[0], dtype=np.int64)
                column[dets] = np.arange(1, dets.size + 1)
                row = np.zeros(n, dtype=np.int64)
                row[tracks] = np.arange(tracks.size)
                matrix = np.zeros((tracks.size, dets.size + 1))
                matrix[:, 0] = 1 - PROB_DETECT * PROB_GATE
                mine = groups.track_labels[owners] == c
                matrix[row[owners[mine]], column[pairs.detections[mine]]] = weights[mine]
                matrices.append(matrix)
            return jpda_marginals(matrices)

        _run(benchmark, implementation, associate, None)
        return
    classes = (fss.KalmanPredictor, fss.KalmanUpdater, fss.PDAHypothesiser,
               fss.JPDAwithEHM) if implementation == "dropin" else (
        KalmanPredictor, KalmanUpdater, PDAHypothesiser, JPDAwithEHM)
    transition, sensor = _stone_soup_models()
    predictor, updater, hypothesiser, associator = classes
    associator = associator(hypothesiser(predictor(transition), updater(sensor),
                                         clutter_spatial_density=density,
                                         prob_detect=PROB_DETECT, prob_gate=PROB_GATE))

    def associate(tracks, detections):
        associations = associator.associate(tracks, detections, T0 + DT)
        assert len(associations) == n

    _run(benchmark, implementation, associate, lambda: _objects(x0, points, clutter, sensor))
