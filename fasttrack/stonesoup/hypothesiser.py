"""Stone Soup's ``stonesoup.hypothesiser``: the ``DistanceHypothesiser`` and
``PDAHypothesiser``, vectorised over the detections (see ``_scan``)."""
from stonesoup.hypothesiser import distance as ss_distance
from stonesoup.hypothesiser import probability as ss_probability

from ._fallback import fall_back
from ._scan import _scan, vectorised

__all__ = ["DistanceHypothesiser", "PDAHypothesiser"]


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
