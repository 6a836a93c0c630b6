"""Stone Soup's ``stonesoup.tracker``: the ``MultiTargetTracker``,
``MultiTargetMixtureTracker`` and ``PointProcessMultiTargetTracker``.

``MultiTargetTracker`` is Stone Soup's: it gets faster through the drop-in associators,
updaters, initiators and deleters it is given. ``MultiTargetMixtureTracker`` reduces each
track's mixture of hypotheses in float arithmetic on log weights (Stone Soup's reduction runs
on arrays of ``Probability`` objects, about 0.5 ms a track; with the drop-in JPDA that is
most of a step); weights it cannot read that way go through Stone Soup's reduction.
``PointProcessMultiTargetTracker`` reads its mixture's component list directly.
"""
import numpy as np
from stonesoup.functions import gm_reduce_single
from stonesoup.tracker import pointprocess as ss_pointprocess
from stonesoup.tracker import simple as ss_tracker
from stonesoup.types.array import CovarianceMatrix, StateVector, StateVectors
from stonesoup.types.numeric import Probability
from stonesoup.types.prediction import GaussianStatePrediction
from stonesoup.types.track import Track
from stonesoup.types.update import GaussianStateUpdate

from ..core.mixture import moment_match
from ._convert import mixture_components
from ._fallback import fall_back

__all__ = ["MultiTargetMixtureTracker", "MultiTargetTracker", "PointProcessMultiTargetTracker"]


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
    if not np.isfinite(log_weights.max()):  # no weight, or an infinite one: Stone Soup's code
        return None
    try:
        mean, covar, _, _ = moment_match(means.T.astype(np.float64),
                                         covars.astype(np.float64), log_weights)
    except ValueError:  # covariances it refuses: Stone Soup's code
        return None
    return StateVector(mean.reshape(d, 1)), CovarianceMatrix(covar[0])


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
                fall_back(self, "__next__", "a mixture of non-numeric states or weights "
                                            "that do not normalise (its reduction)")
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


class PointProcessMultiTargetTracker(ss_pointprocess.PointProcessMultiTargetTracker):
    """Stone Soup's ``PointProcessMultiTargetTracker`` (GM-PHD and GM-LCC): each step adds
    the birth component, hypothesises, updates and reduces the mixture, then extends the
    track of each component's tag (a new track for a tag whose component weighs more than
    ``extraction_threshold``) and ends the tracks whose tag has no component. It runs its
    components' code, so it gets faster with the drop-in ``GaussianMixtureHypothesiser``,
    ``PHDUpdater`` or ``LCCUpdater`` and ``GaussianMixtureReducer``; the tracks are kept
    from the mixture's component list directly (Stone Soup's code indexes the mixture
    component by component)."""

    def update_tracks(self):
        tracks = self.target_tracks
        for component in mixture_components(self.gaussian_mixture):
            tag = component.tag
            if tag == component.BIRTH:
                continue
            track = tracks.get(tag)
            if track is not None:
                track.states.append(component)
            elif component.weight > self.extraction_threshold:
                tracks[tag] = Track([component], id=tag)

    def end_tracks(self):
        tags = {component.tag for component in mixture_components(self.gaussian_mixture)}
        for tag in self.target_tracks.keys() - tags:
            del self.target_tracks[tag]

    @property
    def extracted_target_states(self):
        return [component for component in mixture_components(self.gaussian_mixture)
                if component.weight > self.extraction_threshold]

    @property
    def estimated_number_of_targets(self):
        if not self.gaussian_mixture:  # (an empty mixture, or None, as Stone Soup reads it)
            return 0
        return sum(component.weight for component in mixture_components(self.gaussian_mixture))
