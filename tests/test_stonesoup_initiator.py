"""fasttrack.stonesoup.initiator: the ``SimpleMeasurementInitiator`` and
``MultiMeasurementInitiator`` drop-ins start the same tracks as Stone Soup 1.9.1's."""
import datetime

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.dataassociator.neighbour import GNNWith2DAssignment  # noqa: E402
from stonesoup.deleter.time import UpdateTimeStepsDeleter as SSUpdateTimeStepsDeleter  # noqa
from stonesoup.hypothesiser.distance import DistanceHypothesiser  # noqa: E402
from stonesoup.initiator import simple as ss_initiator  # noqa: E402
from stonesoup.measures import Mahalanobis  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.measurement.nonlinear import (  # noqa: E402
    Cartesian2DToBearing, CartesianToBearingRange)
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor.kalman import KalmanPredictor  # noqa: E402
from stonesoup.types.angle import Bearing  # noqa: E402
from stonesoup.types.array import StateVector  # noqa: E402
from stonesoup.types.detection import Clutter, Detection  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.updater.kalman import KalmanUpdater  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402

T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)
TOLERANCE = 1e-9


LINEAR = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([1.0, 2.0]))
OTHER_LINEAR = LinearGaussian(ndim_state=4, mapping=[2, 0], noise_covar=np.diag([3.0, 0.5]))
POLAR = CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([0.01, 1.0]))
BEARING = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([0.01]))
PRIOR = GaussianState([[0], [0], [0], [0]], np.diag([0, 1, 0, 1]))


def _initiator_detections(seed, models=(LINEAR, OTHER_LINEAR, POLAR, None)):
    rng = np.random.default_rng(seed)
    detections = set()
    for i in range(12):
        model = models[i % len(models)]
        if model is POLAR:
            vector = StateVector([Bearing(rng.uniform(-3, 3)), rng.uniform(1, 50)])
        else:
            vector = rng.normal(0, 10, (2, 1))
        detections.add(Detection(vector, timestamp=T0 + i * DT, measurement_model=model))
    return detections


def _by_detection(tracks):
    return {track.state.hypothesis.measurement: track for track in tracks}


def _assert_same_tracks_by_detection(mine, theirs, exact=True):
    mine, theirs = _by_detection(mine), _by_detection(theirs)
    assert mine.keys() == theirs.keys()
    for detection, track in theirs.items():
        a, b = mine[detection].state, track.state
        assert type(a) is type(b) and a.timestamp == b.timestamp
        assert type(a.state_vector) is type(b.state_vector)
        assert type(a.covar) is type(b.covar)
        assert a.hypothesis.prediction is None and len(mine[detection]) == len(track)
        if exact:
            assert np.array_equal(a.state_vector, b.state_vector)
            assert np.array_equal(a.covar, b.covar)
        else:
            np.testing.assert_allclose(np.asarray(a.state_vector, float),
                                       np.asarray(b.state_vector, float), atol=TOLERANCE)
            np.testing.assert_allclose(a.covar, b.covar, atol=TOLERANCE)


@pytest.mark.parametrize("diag_load", [0.0, 0.3])
def test_simple_measurement_initiator_equals_stonesoup(diag_load):
    detections = _initiator_detections(0)
    ours = fss.SimpleMeasurementInitiator(PRIOR, LINEAR, diag_load=diag_load)
    theirs = ss_initiator.SimpleMeasurementInitiator(PRIOR, LINEAR, diag_load=diag_load)
    _assert_same_tracks_by_detection(ours.initiate(detections, T0),
                                     theirs.initiate(detections, T0))
    with_bearing = detections | _initiator_detections(1, models=(BEARING,))
    for skip in (True, False):
        ours.skip_non_reversible = theirs.skip_non_reversible = skip
        if skip:
            _assert_same_tracks_by_detection(ours.initiate(with_bearing, T0),
                                             theirs.initiate(with_bearing, T0))
        else:
            for initiator in (ours, theirs):
                with pytest.raises(Exception, match="Invalid measurement model"):
                    initiator.initiate(with_bearing, T0)
    for initiator in (fss.SimpleMeasurementInitiator(PRIOR),
                      ss_initiator.SimpleMeasurementInitiator(PRIOR)):
        with pytest.raises(ValueError, match="No measurement model"):
            initiator.initiate(detections, T0)
    with pytest.raises(ValueError, match="diag_load"):
        fss.SimpleMeasurementInitiator(PRIOR, LINEAR, diag_load=-1)


def _kalman_components(module=None):
    """Stone Soup's (or the drop-ins') predictor, updater and GNN associator."""
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    predictor = (module.KalmanPredictor if module else KalmanPredictor)(transition)
    updater = (module.KalmanUpdater if module else KalmanUpdater)(LINEAR)
    hypothesiser = (module.DistanceHypothesiser if module else DistanceHypothesiser)(
        predictor, updater, measure=(module.Mahalanobis if module else Mahalanobis)(),
        missed_distance=3)
    return predictor, updater, (module.GNNWith2DAssignment if module
                                else GNNWith2DAssignment)(hypothesiser)


def _scans(seed, n_targets=5, steps=12, clutter=3):
    """Detections of targets moving at constant velocity, with misses and clutter."""
    rng = np.random.default_rng(seed)
    x = np.c_[rng.uniform(0, 60, n_targets), rng.normal(0, 1, n_targets),
              rng.uniform(0, 60, n_targets), rng.normal(0, 1, n_targets)]
    scans = []
    for k in range(steps):
        stamp = T0 + k * DT
        x[:, 0] += x[:, 1]
        x[:, 2] += x[:, 3]
        found = [Detection(row[[0, 2]].reshape(2, 1) + rng.normal(0, 1, (2, 1)),
                           timestamp=stamp, measurement_model=LINEAR)
                 for row in x if rng.random() < 0.9]
        found += [Clutter(rng.uniform(-10, 70, (2, 1)), timestamp=stamp,
                          measurement_model=LINEAR) for _ in range(rng.poisson(clutter))]
        scans.append((stamp, set(found)))
    return scans


def _summary(tracks):
    """Tracks as comparable rows, in an order independent of set iteration."""
    rows = [([s.timestamp for s in t], [type(s).__name__ for s in t],
             np.hstack([np.asarray(s.state_vector, float) for s in t]),
             np.stack([s.covar for s in t])) for t in tracks]
    return sorted(rows, key=lambda row: (row[0][0], tuple(np.round(row[2][:, 0], 6))))


def _assert_same_summaries(mine, theirs):
    assert len(mine) == len(theirs)
    for a, b in zip(mine, theirs):
        assert a[:2] == b[:2]
        np.testing.assert_allclose(a[2], b[2], atol=TOLERANCE, rtol=TOLERANCE)
        np.testing.assert_allclose(a[3], b[3], atol=TOLERANCE, rtol=TOLERANCE)


@pytest.mark.parametrize("updates_only", [True, False])
def test_multi_measurement_initiator_equals_stonesoup(updates_only):
    scans = _scans(3)

    def run(cls, deleter, components):
        _, updater, associator = components
        initiator = cls(prior_state=PRIOR, measurement_model=LINEAR, deleter=deleter,
                        data_associator=associator, updater=updater, min_points=3,
                        updates_only=updates_only)
        out = [_summary(initiator.initiate(detections, stamp)) for stamp, detections in scans]
        return initiator, out + [_summary(initiator.holding_tracks)]

    theirs, reference = run(ss_initiator.MultiMeasurementInitiator,
                            SSUpdateTimeStepsDeleter(2), _kalman_components())
    ours, mine = run(fss.MultiMeasurementInitiator, fss.UpdateTimeStepsDeleter(2),
                     _kalman_components())
    assert type(ours.initiator) is fss.SimpleMeasurementInitiator
    assert type(theirs.initiator) is ss_initiator.SimpleMeasurementInitiator
    assert (ours.initiator.prior_state, ours.initiator.measurement_model) == (PRIOR, LINEAR)
    for a, b in zip(mine, reference):
        _assert_same_summaries(a, b)
    _, fast = run(fss.MultiMeasurementInitiator, fss.UpdateTimeStepsDeleter(2),
                  _kalman_components(fss))
    for a, b in zip(fast, reference):
        _assert_same_summaries(a, b)
    own = ss_initiator.SimpleMeasurementInitiator(PRIOR, LINEAR)
    given = fss.MultiMeasurementInitiator(PRIOR, fss.UpdateTimeStepsDeleter(2),
                                          _kalman_components()[2], KalmanUpdater(LINEAR),
                                          initiator=own)
    assert given.initiator is own and given.holding_tracks == set()
    assert list(fss.MultiMeasurementInitiator.properties) == list(
        ss_initiator.MultiMeasurementInitiator.properties)
