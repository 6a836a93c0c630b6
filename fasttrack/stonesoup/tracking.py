"""Stone Soup's deleters, initiators and multi-target trackers, with their checks over a
set of tracks done at once.

- ``UpdateTimeStepsDeleter`` walks each track's states backwards in place, only back to its
  last update (Stone Soup first copies every track into a new reversed sequence).
- ``CovarianceBasedDeleter`` takes the traces of all the tracks' covariances in one array
  operation.
- ``SimpleMeasurementInitiator`` inverts each linear measurement model once per call instead
  of once per detection; ``MultiMeasurementInitiator`` uses it as its default initiator.
- ``MultiTargetMixtureTracker`` reduces each track's mixture of hypotheses in float
  arithmetic on log weights (Stone Soup's reduction runs on arrays of ``Probability``
  objects, about 0.5 ms a track; with the drop-in JPDA that is most of a step).
- ``MultiTargetTracker`` is Stone Soup's: it gets faster through the drop-in associators,
  updaters, initiators and deleters it is given.

Each class is a subclass of the Stone Soup class of the same name, with its properties and
defaults, and gives Stone Soup's results; anything the fast path does not cover (ragged or
non-numeric covariances, angle-typed state vectors, a subclass overriding a check) goes
through Stone Soup's code.
"""
import numpy as np
from stonesoup.deleter import error as ss_error
from stonesoup.deleter import time as ss_time
from stonesoup.functions import gm_reduce_single
from stonesoup.initiator import simple as ss_initiator
from stonesoup.initiator.base import GaussianInitiator
from stonesoup.models.base import LinearModel, ReversibleModel
from stonesoup.tracker import simple as ss_tracker
from stonesoup.types.array import CovarianceMatrix, StateVector, StateVectors
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.numeric import Probability
from stonesoup.types.prediction import GaussianStatePrediction
from stonesoup.types.state import State, StateMutableSequence
from stonesoup.types.track import Track
from stonesoup.types.update import GaussianStateUpdate, Update

__all__ = ["CovarianceBasedDeleter", "MultiMeasurementInitiator", "MultiTargetMixtureTracker",
           "MultiTargetTracker", "SimpleMeasurementInitiator", "UpdateTimeStepsDeleter"]


# -- deleters --------------------------------------------------------------------------------

def _remove_last_predictions(tracks):
    """``delete_last_pred``: drop each track's last state (and its metadata) unless it is an
    update."""
    for track in tracks:
        if not isinstance(track[-1], Update):
            del track[-1]
            del track.metadatas[-1]


def _deleted(deleter, tracks):
    if deleter.delete_last_pred:
        _remove_last_predictions(tracks)
    return tracks


class UpdateTimeStepsDeleter(ss_time.UpdateTimeStepsDeleter):
    """Stone Soup's ``UpdateTimeStepsDeleter``: a track is deleted when more than
    ``time_steps_since_update`` distinct timestamps go back from its last state without
    reaching an update with a measurement; the states are read in place, newest first, and
    only back to that update."""

    def check_for_deletion(self, track, **kwargs):
        if type(track).__getitem__ is StateMutableSequence.__getitem__:
            newest_first = reversed(track.states)
        else:  # a sequence type with its own indexing: read it as Stone Soup does
            newest_first = track[::-1]
        limit = self.time_steps_since_update
        seen = set()
        for state in newest_first:
            seen.add(state.timestamp)
            if len(seen) > limit:
                return True
            if isinstance(state, Update) and state.hypothesis:
                return False
        return False

    def delete_tracks(self, tracks, **kwargs):
        check = self.check_for_deletion
        return _deleted(self, {track for track in tracks if check(track, **kwargs)})


class CovarianceBasedDeleter(ss_error.CovarianceBasedDeleter):
    """Stone Soup's ``CovarianceBasedDeleter``: a track is deleted when the trace of its
    last covariance (over ``mapping``, if given) exceeds ``covar_trace_thresh``; the traces
    of all the tracks are summed in one array operation."""

    def delete_tracks(self, tracks, **kwargs):
        if type(self).check_for_deletion is not ss_error.CovarianceBasedDeleter.check_for_deletion:
            return super().delete_tracks(tracks, **kwargs)  # a subclass's own check
        tracks = list(tracks)
        if not tracks:
            return set()
        covars = [track.state.covar for track in tracks]
        flags = self._exceeding(covars)
        if flags is None:  # ragged or non-numeric covariances: one at a time
            doomed = {track for track in tracks if self.check_for_deletion(track, **kwargs)}
        else:
            doomed = {track for track, flag in zip(tracks, flags.tolist()) if flag}
        return _deleted(self, doomed)

    def _exceeding(self, covars):
        """Whether each covariance's trace (over ``mapping``) exceeds the threshold, or None
        where the covariances do not stack into one numeric array."""
        try:
            stacked = np.array(covars)
        except (ValueError, TypeError):
            return None
        if stacked.ndim != 3 or stacked.shape[1] != stacked.shape[2] \
                or stacked.dtype.kind not in "fiub":
            return None
        diagonals = np.ascontiguousarray(np.diagonal(stacked, axis1=1, axis2=2))
        if self.mapping:
            # the same indexing (and errors) as on one diagonal
            rows = np.reshape(np.arange(diagonals.shape[1])[self.mapping], -1)
            diagonals = np.ascontiguousarray(diagonals[:, rows])
        return diagonals.sum(axis=1) > self.covar_trace_thresh


# -- initiators ------------------------------------------------------------------------------

class SimpleMeasurementInitiator(ss_initiator.SimpleMeasurementInitiator):
    """Stone Soup's ``SimpleMeasurementInitiator``: a track per detection, its state the
    prior with the measured components taken from the detection (through the model's
    pseudo-inverse, or its inverse function for a reversible model) and their covariance from
    the model's noise; the pseudo-inverse and the covariance of a linear model are computed
    once per call for all the detections that share it."""

    def _model(self, detection):
        if detection.measurement_model is not None:
            return detection.measurement_model
        if self.measurement_model is None:
            raise ValueError("No measurement model specified")
        return self.measurement_model

    def _start(self, model, inverse):
        """The prior's state vector with the measured components zeroed, and the new
        track's covariance (the model's noise mapped through ``inverse``, the prior's
        covariance outside the measured components, the diagonal load)."""
        mapped = model.mapping
        vector = self.prior_state.state_vector.copy()
        vector[mapped, :] = 0
        prior_covar = self.prior_state.covar.copy()
        prior_covar[mapped, :] = 0
        prior_covar[:, mapped] = 0
        covar = inverse @ model.covar() @ inverse.T
        covar = covar + prior_covar + np.diag(np.array([self.diag_load] * covar.shape[0]))
        return vector, covar

    def initiate(self, detections, timestamp, **kwargs):
        tracks = set()
        linear = {}  # id(model) -> (model, inverse, start vector, covariance)
        for detection in detections:
            model = self._model(detection)
            if isinstance(model, LinearModel):
                known = linear.get(id(model))
                if known is None:
                    inverse = np.linalg.pinv(model.matrix())
                    known = linear[id(model)] = (model, inverse) + self._start(model, inverse)
                _, inverse, vector, covar = known
                state_vector = inverse @ detection.state_vector
                covar = covar.copy()
            elif isinstance(model, ReversibleModel):
                try:
                    state_vector = model.inverse_function(detection)
                except NotImplementedError:
                    if self.skip_non_reversible:
                        continue
                    raise
                inverse = np.linalg.pinv(model.jacobian(State(state_vector)))
                vector, covar = self._start(model, inverse)
            elif self.skip_non_reversible:
                continue
            else:
                raise Exception("Invalid measurement model used. Must be instance of linear "
                                "or reversible.")
            tracks.add(Track([Update.from_state(
                self.prior_state, state_vector=vector + state_vector, covar=covar,
                hypothesis=SingleHypothesis(None, detection), timestamp=detection.timestamp)]))
        return tracks


class MultiMeasurementInitiator(ss_initiator.MultiMeasurementInitiator):
    """Stone Soup's ``MultiMeasurementInitiator``; its default ``initiator`` is the drop-in
    :class:`SimpleMeasurementInitiator` (on ``prior_state`` and ``measurement_model``).
    Pass the drop-in associator, updater and deleter to make its holding tracks fast."""

    def __init__(self, *args, **kwargs):
        # Stone Soup's own initialiser would build Stone Soup's SimpleMeasurementInitiator
        GaussianInitiator.__init__(self, *args, **kwargs)
        self.holding_tracks = set()
        if self.initiator is None:
            self.initiator = SimpleMeasurementInitiator(self.prior_state, self.measurement_model)


# -- trackers --------------------------------------------------------------------------------

class MultiTargetTracker(ss_tracker.MultiTargetTracker):
    """Stone Soup's ``MultiTargetTracker``: each step associates the tracks with the
    detections, updates the associated tracks (the others take their prediction), deletes
    tracks, and initiates tracks from the detections left. It runs its components' code, so
    it gets faster with the drop-in associators, updaters, initiators and deleters."""


def _log_weight(probability):
    if isinstance(probability, Probability):
        return probability.log_value
    with np.errstate(divide="ignore"):
        return float(np.log(float(probability)))


def _reduce(states, probabilities):
    """Stone Soup's ``gm_reduce_single`` of Gaussian states with these weights: the mean and
    covariance of the mixture (weights normalised in log space), or None where Stone Soup's
    code must do it."""
    vectors = [state.state_vector for state in states]
    covars = [state.covar for state in states]
    try:
        log_weights = np.array([_log_weight(p) for p in probabilities], dtype=np.float64)
        means = np.concatenate(vectors, axis=1)
        covars = np.array(covars)
    except (TypeError, ValueError):
        return None
    d = means.shape[0]
    if means.dtype.kind not in "fiu" or covars.dtype.kind not in "fiu" \
            or covars.shape != (len(states), d, d):
        return None
    top = log_weights.max()
    if not np.isfinite(top):  # every weight zero (or one infinite): Stone Soup's arithmetic
        return None
    weights = np.exp(log_weights - top)
    weights /= weights.sum()
    means = means.astype(np.float64)
    mean = means @ weights
    spread = means - mean[:, np.newaxis]
    covar = np.einsum("kij,k->ij", covars.astype(np.float64), weights) \
        + (spread * weights) @ spread.T
    return StateVector(mean[:, np.newaxis]), CovarianceMatrix(covar)


class MultiTargetMixtureTracker(ss_tracker.MultiTargetMixtureTracker):
    """Stone Soup's ``MultiTargetMixtureTracker``: each track's state becomes the single
    Gaussian of the mixture of its hypotheses (missed detection: the prediction; others:
    the update), an update if some detection outweighs the missed detection, else a
    prediction; detections no track weighs above its missed detection start new tracks. The
    mixture is reduced in float arithmetic (the same values as Stone Soup's
    ``gm_reduce_single`` to rounding)."""

    def __next__(self):
        time, detections = next(self.detector_iter)
        associations = self.data_associator.associate(self.tracks, detections, time)
        unassociated = set(detections)
        for track, multihypothesis in associations.items():
            posteriors = [self.updater.update(hypothesis) if hypothesis
                          else hypothesis.prediction for hypothesis in multihypothesis]
            probabilities = [hypothesis.probability for hypothesis in multihypothesis]
            reduced = _reduce(posteriors, probabilities)
            if reduced is None:
                reduced = gm_reduce_single(
                    StateVectors([state.state_vector for state in posteriors]),
                    np.stack([state.covar for state in posteriors], axis=2),
                    np.asarray(probabilities))
            mean, covar = reduced
            missed_weight = next(hyp.weight for hyp in multihypothesis if not hyp)
            if any(hypothesis.weight > missed_weight for hypothesis in multihypothesis):
                track.append(GaussianStateUpdate(mean, covar, multihypothesis,
                                                 multihypothesis[0].measurement.timestamp))
            else:
                track.append(GaussianStatePrediction(mean, covar,
                                                     multihypothesis[0].prediction.timestamp))
            for hypothesis in multihypothesis:
                if hypothesis.weight > missed_weight:
                    unassociated.discard(hypothesis.measurement)
        self._tracks -= self.deleter.delete_tracks(self.tracks)
        self._tracks |= self.initiator.initiate(unassociated, time)
        return time, self.tracks
