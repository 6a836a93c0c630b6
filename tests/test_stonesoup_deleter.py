"""fasttrack.stonesoup.deleter: the ``UpdateTimeStepsDeleter`` and ``CovarianceBasedDeleter``
drop-ins delete the same tracks as Stone Soup 1.9.1's, and raise where they raise."""
import copy
import datetime

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.deleter.error import CovarianceBasedDeleter as SSCovarianceBasedDeleter  # noqa
from stonesoup.deleter.time import UpdateTimeStepsDeleter as SSUpdateTimeStepsDeleter  # noqa
from stonesoup.types.detection import Detection, MissedDetection  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.prediction import GaussianStatePrediction, StatePrediction  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402
from stonesoup.types.update import GaussianStateUpdate, StateUpdate  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402

T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)


def _deleter_tracks(seed, n=40):
    """Tracks of updates with and without measurements, predictions and repeated
    timestamps."""
    rng = np.random.default_rng(seed)
    tracks = []
    for _ in range(n):
        states, k = [], 0
        for _ in range(int(rng.integers(1, 9))):
            k += int(rng.integers(0, 2))  # a step of 0 repeats the timestamp
            kind = rng.integers(4)
            stamp = T0 + k * DT
            if kind == 0:
                states.append(StateUpdate([[k]], SingleHypothesis(None, Detection([[k]])),
                                          timestamp=stamp))
            elif kind == 1:
                states.append(StateUpdate([[k]], SingleHypothesis(
                    None, MissedDetection(timestamp=stamp)), timestamp=stamp))
            else:
                states.append(StatePrediction([[k]], timestamp=stamp))
        tracks.append(Track(states))
    return tracks


@pytest.mark.parametrize("steps", [0, 1, 2, 3, 5])
def test_update_time_steps_deleter_equals_stonesoup(steps):
    tracks = _deleter_tracks(steps)
    ours = fss.UpdateTimeStepsDeleter(time_steps_since_update=steps)
    theirs = SSUpdateTimeStepsDeleter(time_steps_since_update=steps)
    assert [ours.check_for_deletion(t) for t in tracks] == [theirs.check_for_deletion(t)
                                                            for t in tracks]
    assert ours.delete_tracks(set(tracks)) == theirs.delete_tracks(set(tracks))
    assert not ours.check_for_deletion(Track()) and ours.delete_tracks(set()) == set()
    mine, reference = copy.deepcopy(tracks), copy.deepcopy(tracks)
    ours.delete_last_pred = theirs.delete_last_pred = True
    deleted = ours.delete_tracks(set(mine))
    assert {mine.index(t) for t in deleted} == {reference.index(t) for t in
                                               theirs.delete_tracks(set(reference))}
    assert [(len(a), len(a.metadatas)) for a in mine] == [(len(b), len(b.metadatas))
                                                          for b in reference]


def _covariance_tracks(seed, n=30, dim=4):
    rng = np.random.default_rng(seed)
    tracks = []
    for i in range(n):
        covar = np.diag(rng.uniform(0, 3, dim))
        if i % 3 == 0:
            covar = np.round(covar).astype(int)
        kind = GaussianStateUpdate if i % 2 else GaussianStatePrediction
        extra = {"hypothesis": SingleHypothesis(None, Detection(np.zeros((2, 1))))} \
            if kind is GaussianStateUpdate else {}
        tracks.append(Track([GaussianState(np.zeros((dim, 1)), np.eye(dim), timestamp=T0),
                             kind(np.zeros((dim, 1)), covar, timestamp=T0 + DT, **extra)]))
    return tracks


@pytest.mark.parametrize("mapping", [None, [0, 2], np.array([1]), []])
@pytest.mark.parametrize("threshold", [2.0, 6, 9.5])
def test_covariance_based_deleter_equals_stonesoup(threshold, mapping):
    tracks = _covariance_tracks(int(threshold * 10))
    ours = fss.CovarianceBasedDeleter(covar_trace_thresh=threshold, mapping=mapping)
    theirs = SSCovarianceBasedDeleter(covar_trace_thresh=threshold, mapping=mapping)
    assert ours.delete_tracks(set(tracks)) == theirs.delete_tracks(set(tracks))
    ragged = tracks[:10] + _covariance_tracks(1, n=10, dim=3)
    assert ours.delete_tracks(ragged) == theirs.delete_tracks(ragged)
    mine, reference = copy.deepcopy(tracks), copy.deepcopy(tracks)
    ours.delete_last_pred = theirs.delete_last_pred = True
    deleted = ours.delete_tracks(set(mine))
    assert {mine.index(t) for t in deleted} == {reference.index(t) for t in
                                               theirs.delete_tracks(set(reference))}
    assert [len(a) for a in mine] == [len(b) for b in reference]


def test_covariance_based_deleter_raises_as_stonesoup():
    tracks = _covariance_tracks(3)
    for mapping, error in (((0, 2), IndexError), (np.array([0, 2]), ValueError)):
        for cls in (fss.CovarianceBasedDeleter, SSCovarianceBasedDeleter):
            with pytest.raises(error):
                cls(covar_trace_thresh=1.0, mapping=mapping).delete_tracks(set(tracks))
    assert fss.CovarianceBasedDeleter(1.0).delete_tracks(set()) == set()
