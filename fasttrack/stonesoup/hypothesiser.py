"""Stone Soup's ``stonesoup.hypothesiser``: the ``DistanceHypothesiser`` and
``PDAHypothesiser``, vectorised over the detections (see ``_scan``), and the
``GaussianMixtureHypothesiser`` and its kd-tree variant, vectorised over the components
too."""
import numpy as np
from scipy.spatial import KDTree
from stonesoup.dataassociator.tree import DetectionKDTreeMixIn
from stonesoup.hypothesiser import distance as ss_distance
from stonesoup.hypothesiser import gaussianmixture as ss_gaussianmixture
from stonesoup.hypothesiser import probability as ss_probability
from stonesoup.types.detection import MissedDetection
from stonesoup.types.multihypothesis import MultipleHypothesis
from stonesoup.types.prediction import (Prediction, TaggedWeightedGaussianStatePrediction,
                                        WeightedGaussianStatePrediction)
from stonesoup.types.state import TaggedWeightedGaussianState, WeightedGaussianState

from ._fallback import fall_back
from ._objects import builder
from ._pending import pending_groups
from ._recipe import vectorised
from ._scan import _scan

__all__ = ["DistanceHypothesiser", "GaussianMixtureHypothesiser",
           "GaussianMixtureKDTreeHypothesiser", "PDAHypothesiser"]


@vectorised("distance")
class DistanceHypothesiser(ss_distance.DistanceHypothesiser):
    """Stone Soup's ``DistanceHypothesiser``, vectorised over the detections.

    With a drop-in Kalman predictor and updater on recognised models and a ``Mahalanobis``
    (or ``Euclidean``) measure, ``hypothesise`` predicts the track and its measurement once
    (memoised as in Stone Soup) and scores every detection in one kernel call; the drop-in
    associators go further and hypothesise every track of a scan at once. Other
    configurations run Stone Soup's code.
    """

    def hypothesise(self, track, detections, timestamp, **kwargs):
        """The track's hypotheses: the missed detection at ``missed_distance`` and each
        detection closer than it (all with ``include_all``), best (closest) first.

        Parameters
        ----------
        track : stonesoup.types.track.Track
        detections : set of stonesoup.types.detection.Detection
        timestamp : datetime.datetime
            Prediction time (a detection's own timestamp is used for its hypothesis).

        Returns
        -------
        stonesoup.types.multihypothesis.MultipleHypothesis
            Of ``SingleDistanceHypothesis``.
        """
        scan = _scan(self, [track], detections, timestamp, kwargs, single=True)
        if isinstance(scan, str):
            fall_back(self, "hypothesise", scan)
            return super().hypothesise(track, detections, timestamp, **kwargs)
        return scan.hypotheses(0)


@vectorised("pda")
class PDAHypothesiser(ss_probability.PDAHypothesiser):
    """Stone Soup's ``PDAHypothesiser``, vectorised over the detections.

    With a drop-in Kalman predictor and updater on recognised models, ``hypothesise``
    predicts the track and its measurement once (memoised as in Stone Soup) and gates and
    weighs every detection in one kernel call; the drop-in associators hypothesise every
    track of a scan at once. Other configurations run Stone Soup's code.
    """

    def hypothesise(self, track, detections, timestamp, **kwargs):
        """The track's PDA hypotheses: the missed detection first, then each detection in
        the gate ``chi2.ppf(prob_gate, m)`` (all with ``include_all``), with Stone Soup's
        probabilities.

        Parameters
        ----------
        track : stonesoup.types.track.Track
        detections : set of stonesoup.types.detection.Detection
        timestamp : datetime.datetime
            Prediction time.

        Returns
        -------
        stonesoup.types.multihypothesis.MultipleHypothesis
            Of ``SingleProbabilityHypothesis``, normalised if ``normalise``.
        """
        scan = _scan(self, [track], detections, timestamp, kwargs, single=True)
        if isinstance(scan, str):
            fall_back(self, "hypothesise", scan)
            return super().hypothesise(track, detections, timestamp, **kwargs)
        return scan.hypotheses(0)


class GaussianMixtureHypothesiser(ss_gaussianmixture.GaussianMixtureHypothesiser):
    """Stone Soup's ``GaussianMixtureHypothesiser``: with a drop-in ``DistanceHypothesiser``
    or ``PDAHypothesiser``, every component is predicted and scored against every detection
    in one scan (the drop-in associators' path), and the hypotheses are grouped by detection
    in one pass; the same hypotheses as Stone Soup's, in the same order. Grouped by
    detection, the groups are built when first read (the drop-in ``PHDUpdater`` reads the
    scan's arrays instead; see ``_pending``). Another hypothesiser runs Stone Soup's code."""

    def generate_hypotheses(self, components, detections, timestamp, **kwargs):
        components = list(components)
        scan = _scan(self.hypothesiser, components, detections, timestamp, kwargs)
        if isinstance(scan, str):
            fall_back(self, "generate_hypotheses", scan)
            return super().generate_hypotheses(components, detections, timestamp, **kwargs)
        return {component: scan.hypotheses(k) for k, component in enumerate(components)}

    def hypothesise(self, components, detections, timestamp, **kwargs):
        if len({detection.timestamp for detection in detections}) > 1:
            raise ValueError("All detections must have the same timestamp")
        components, detections = list(components), list(detections)
        scan = None
        if type(self).generate_hypotheses is GaussianMixtureHypothesiser.generate_hypotheses:
            scan = _scan(self.hypothesiser, components, detections, timestamp, kwargs)
        if self.order_by_detection and scan is not None and not isinstance(scan, str) \
                and _PREDICTIONS.keys() >= set(map(type, components)):
            return _groups_when_read(scan, components)
        return self._groups(self._component_hypotheses(components, detections, timestamp,
                                                       kwargs, scan), detections)

    def _groups(self, component_hypotheses, detections):
        """Stone Soup's ``MultipleHypothesis`` list of the components' hypotheses: one per
        component, or with ``order_by_detection`` one per detection and the missed."""
        hypotheses = [_multiple_hypothesis(single_hypotheses=multiple)
                      for multiple in component_hypotheses if len(multiple) > 0]
        if not self.order_by_detection:
            return hypotheses
        return [_multiple_hypothesis(single_hypotheses=group)
                for group in _by_detection(hypotheses, detections)]

    def _component_hypotheses(self, components, detections, timestamp, kwargs, scan):
        """Each component's hypotheses, each with its own prediction of the component (as
        Stone Soup's ``hypothesise`` replaces the predictions ``generate_hypotheses``
        gives); from ``scan`` (None: a subclass's own ``generate_hypotheses``; a string:
        the reason Stone Soup's must run) built with them at once."""
        if scan is None:
            out = self.generate_hypotheses(components, detections, timestamp, **kwargs)
        elif not isinstance(scan, str):
            return [scan.hypotheses(k, predict=_predictor(
                component, *scan.predicted(k), scan.timestamp))
                for k, component in enumerate(components)]
        else:
            fall_back(self, "generate_hypotheses", scan)  # (not scanned a second time)
            out = ss_gaussianmixture.GaussianMixtureHypothesiser.generate_hypotheses(
                self, components, detections, timestamp, **kwargs)
        for component, multiple in out.items():
            for hypothesis in multiple:
                predicted = hypothesis.prediction
                hypothesis.prediction = _predictor(
                    component, predicted.state_vector, predicted.covar,
                    predicted.timestamp)(hypothesis.measurement)
        return out.values()


def _by_detection(hypotheses, detections):
    """The single hypotheses of ``hypotheses`` grouped by detection, in the order of
    ``detections``, then the missed ones."""
    by_detection = {id(detection): [] for detection in detections}
    missed = []
    for multiple in hypotheses:
        for hypothesis in multiple:
            if not hypothesis:
                missed.append(hypothesis)
            group = by_detection.get(id(hypothesis.measurement))
            if group is not None:
                group.append(hypothesis)
    return [by_detection[id(detection)] for detection in detections] + [missed]


def _groups_when_read(scan, components):
    """The detection-ordered groups of ``scan``, built when first read (see ``_pending``),
    from the components' weights and tags as they are now."""
    weights = [component.weight for component in components]
    tags = [getattr(component, "tag", None) for component in components]

    def build_all():
        return _by_detection(
            [scan.hypotheses(k, predict=_predictor(component, *scan.predicted(k),
                                                   scan.timestamp, weight, tag))
             for k, (component, weight, tag) in enumerate(zip(components, weights, tags))],
            scan.detections)

    return pending_groups(scan, weights, tags, build_all)


class GaussianMixtureKDTreeHypothesiser(ss_gaussianmixture.GaussianMixtureKDTreeHypothesiser,
                                        GaussianMixtureHypothesiser):
    """Stone Soup's ``GaussianMixtureKDTreeHypothesiser``: with a drop-in
    ``DistanceHypothesiser`` whose predictor and updater are this hypothesiser's own,
    every component is scored in one scan, as by the drop-in ``GaussianMixtureHypothesiser``,
    and each keeps the detections that Stone Soup's kd-tree query of its predicted
    measurement returns (SciPy's ``KDTree``, as Stone Soup queries it); the same hypotheses
    as Stone Soup's, in the same order. Other configurations run Stone Soup's code."""

    def generate_hypotheses(self, components, detections, timestamp, **kwargs):
        components = list(components)
        if not components or not detections:
            return GaussianMixtureHypothesiser.generate_hypotheses(
                self, components, detections, timestamp, **kwargs)
        scan = _scan(self.hypothesiser, components, detections, timestamp, kwargs)
        reason = scan if isinstance(scan, str) else self._reason(scan)
        if reason:
            fall_back(self, "generate_hypotheses", reason)
            return DetectionKDTreeMixIn.generate_hypotheses(self, components, detections,
                                                            timestamp, **kwargs)
        near = self._near(scan)
        out = {}
        for k, component in enumerate(components):
            kept = [hypothesis for hypothesis in scan.hypotheses(k)
                    if not hypothesis or id(hypothesis.measurement) in near[k]]
            out[component] = _multiple_hypothesis(single_hypotheses=kept)
        return out

    def _reason(self, scan):
        """Why Stone Soup's code must run for this scan, or None."""
        if scan.recipe.kind != "distance":
            return "a hypothesiser that is not a DistanceHypothesiser"
        if self.predictor is not scan.recipe.predictor or self.updater is not scan.recipe.updater:
            return "a kd-tree predictor or updater other than the hypothesiser's"
        return None

    def _near(self, scan):
        """Per component, the ids of the detections Stone Soup's kd-tree query keeps."""
        points = np.array([d.state_vector[:, 0] for d in scan.detections], dtype=np.float64)
        tree = KDTree(points)
        limit = np.full(len(scan.tracks), float(self.max_distance))
        if self.max_distance_covariance_multiplier is not None:
            spread = np.max(np.diagonal(scan.innovation_covars, axis1=1, axis2=2), axis=1)
            limit = np.minimum(limit, spread * self.max_distance_covariance_multiplier)
        near = []
        for z_hat, radius in zip(scan.z_hats, limit):
            if self.number_of_neighbours is None:
                indexes = tree.query_ball_point(z_hat, r=radius)
            else:
                _, indexes = tree.query(z_hat, k=self.number_of_neighbours,
                                        distance_upper_bound=radius)
            near.append({id(scan.detections[i]) for i in np.atleast_1d(indexes)
                         if i != len(points)})
        return near


_multiple_hypothesis = builder(MultipleHypothesis)

#: The prediction type of each weighted state type, for the hypothesiser's predictions.
_PREDICTIONS = {TaggedWeightedGaussianState: builder(TaggedWeightedGaussianStatePrediction),
                WeightedGaussianState: builder(WeightedGaussianStatePrediction)}


def _predictor(component, mean, covar, timestamp, weight=None, tag=None):
    """A function of a hypothesis' measurement giving the component's prediction (``mean``,
    ``covar`` at ``timestamp``) on that hypothesis, as Stone Soup's hypothesiser makes it
    (``Prediction.from_state`` of the component) with the component's tag by Stone Soup's
    rule: a birth component keeps 'birth' when missed and gets a new tag when detected.
    Built directly for the two weighted state types, whose every property that call sets is
    given here, with the component's ``weight`` and ``tag`` (if None, as they are now)."""
    kind = _PREDICTIONS.get(type(component))
    values = dict(state_vector=mean, covar=covar, timestamp=timestamp)
    if kind is None:
        def build(**tag):
            return Prediction.from_state(component, **values, **tag)
    else:
        values["weight"] = component.weight if weight is None else weight

        def build(**tag):
            return kind(**values, **tag)
    if not isinstance(component, TaggedWeightedGaussianState):
        return lambda measurement: build()
    tag = component.tag if tag is None else tag
    if tag == component.BIRTH:
        return lambda measurement: build(
            tag=component.BIRTH if isinstance(measurement, MissedDetection) else None)
    return lambda measurement: build(tag=tag)
