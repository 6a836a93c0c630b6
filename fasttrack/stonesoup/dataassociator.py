"""Stone Soup's ``stonesoup.dataassociator``: ``NearestNeighbour``,
``GlobalNearestNeighbour``, ``GNNWith2DAssignment``, ``PDA``, ``JPDA`` and ``JPDAwithEHM``,
each associating a whole scan at once.

With a drop-in hypothesiser on the vectorised path (see ``_scan``), ``associate`` predicts
every track in one batch call, gates, solves the association on arrays (nearest neighbour,
global nearest neighbour per cluster of the gate graph, exact JPDA marginals per cluster)
and only then builds Stone Soup's objects: the chosen hypotheses, or for the probabilistic
associators each track's ``MultipleHypothesis``. Anything else goes through Stone Soup's own
code. A JPDA cluster too large for exact association raises ``ValueError`` naming its size.

The mappings returned hold the same tracks and hypotheses as Stone Soup's, not necessarily
in Stone Soup's insertion order. Predictions made by the vectorised ``associate`` are not
entered in the predictor's memo (a later ``predictor.predict`` of the same track builds a
new, equal object).
"""
import numpy as np
from stonesoup.dataassociator import neighbour as ss_neighbour
from stonesoup.dataassociator import probability as ss_probability
from stonesoup.types.hypothesis import JointHypothesis

from ._fallback import fall_back, overridden
from ._scan import _scan

__all__ = ["GNNWith2DAssignment", "GlobalNearestNeighbour", "JPDA", "JPDAwithEHM",
           "NearestNeighbour", "PDA"]


class _Vectorised:
    """``generate_hypotheses`` and ``associate`` over every track of a scan in one pass.

    A subclass names the hypotheses it solves on (``_kind``: 'distance' or 'pda') and solves
    the association of a scan in ``_solve``.
    """

    _kind = None

    def generate_hypotheses(self, tracks, detections, timestamp, **kwargs):
        """``{track: hypothesiser.hypothesise(track, detections, timestamp)}``, computed
        for all tracks at once where the hypothesiser allows it.

        Parameters
        ----------
        tracks : set of stonesoup.types.track.Track
        detections : set of stonesoup.types.detection.Detection
        timestamp : datetime.datetime

        Returns
        -------
        dict
        """
        scan = _scan(self.hypothesiser, tracks, detections, timestamp, kwargs)
        if isinstance(scan, str):
            fall_back(self, "generate_hypotheses", scan)
            return super().generate_hypotheses(tracks, detections, timestamp, **kwargs)
        return {track: scan.hypotheses(k) for k, track in enumerate(scan.tracks)}

    def associate(self, tracks, detections, timestamp, **kwargs):
        """Associate tracks and detections.

        Parameters
        ----------
        tracks : set of stonesoup.types.track.Track
        detections : set of stonesoup.types.detection.Detection
        timestamp : datetime.datetime
            Time to predict to (and of the missed detections).

        Returns
        -------
        dict
            ``{track: hypothesis}`` as the Stone Soup class returns it (see the class).
        """
        scan = overridden(self, _Vectorised, ("generate_hypotheses",)) \
            or _scan(self.hypothesiser, tracks, detections, timestamp, kwargs, self._kind)
        associations = scan if isinstance(scan, str) else self._solve(scan)
        if isinstance(associations, str):
            fall_back(self, "associate", associations)
            return super().associate(tracks, detections, timestamp, **kwargs)
        return associations

    def _solve(self, scan):
        """The association of a vectorised scan, or the reason Stone Soup's code must
        run."""
        raise NotImplementedError


class NearestNeighbour(_Vectorised, ss_neighbour.NearestNeighbour):
    """Stone Soup's ``NearestNeighbour``: greedy association, closest pair first.

    Vectorised (see the module docstring) for a drop-in ``DistanceHypothesiser``; only the
    chosen hypotheses are built as Stone Soup objects. ``associate`` returns ``{track:
    SingleDistanceHypothesis}``.
    """

    _kind = "distance"

    def _solve(self, scan):
        return scan.chosen(scan.nearest())


class GlobalNearestNeighbour(_Vectorised, ss_neighbour.GlobalNearestNeighbour):
    """Stone Soup's ``GlobalNearestNeighbour``: the joint hypothesis of least total
    distance, or of greatest product of probabilities.

    Stone Soup enumerates every joint hypothesis; with a drop-in ``DistanceHypothesiser``
    (or ``PDAHypothesiser``) this computes the same optimum as a two-dimensional assignment
    per cluster, on the distances (or minus the log probabilities). ``associate`` returns a
    ``DistanceJointHypothesis`` ``{track: SingleDistanceHypothesis}`` (or a
    ``ProbabilityJointHypothesis`` of ``SingleProbabilityHypothesis``).
    """

    _kind = None  # either

    def _solve(self, scan):
        assigned = scan.global_nearest(enumerated=True) if scan.tracks else None
        if assigned is None:
            return "no tracks, or no joint hypothesis of finite cost"
        return JointHypothesis(scan.chosen(assigned))


class GNNWith2DAssignment(_Vectorised, ss_neighbour.GNNWith2DAssignment):
    """Stone Soup's ``GNNWith2DAssignment``: global nearest neighbour by two-dimensional
    assignment.

    With a drop-in ``DistanceHypothesiser`` the assignment is solved per cluster of the
    gate graph by fasttrack's compiled solver (SciPy's algorithm); with probability
    hypotheses, or when no finite assignment exists (Stone Soup raises
    ``RuntimeError``), Stone Soup's code runs on the vectorised hypotheses. ``associate``
    returns ``{track: SingleDistanceHypothesis}``.
    """

    _kind = "distance"

    def _solve(self, scan):
        assigned = scan.global_nearest()
        if assigned is None:
            return "no assignment of finite distance (Stone Soup raises)"
        return scan.chosen(assigned)


class PDA(_Vectorised, ss_probability.PDA):
    """Stone Soup's ``PDA``: each track's PDA hypotheses, normalised; vectorised over the
    scan with a drop-in ``PDAHypothesiser``. ``associate`` returns ``{track:
    MultipleHypothesis}`` of ``SingleProbabilityHypothesis``, with probabilities
    normalised to total 1."""

    _kind = "pda"

    def _solve(self, scan):
        return {track: scan.hypotheses(k, normalised=True)
                for k, track in enumerate(scan.tracks)}


class _Joint(_Vectorised):
    """The JPDA associators: exact marginals per cluster (efficient hypothesis management,
    :func:`fasttrack.core.jpda.jpda_marginals`). ``associate`` returns ``{track:
    MultipleHypothesis}`` of ``SingleProbabilityHypothesis`` with the joint association
    probabilities, normalised."""

    _kind = "pda"
    _ehm = False

    def _solve(self, scan):
        if not np.isfinite(scan.missed_log_weight):
            return "a certain detection (prob_detect * prob_gate = 1)"
        # a cluster too big for exact association raises, naming its size (Stone Soup's
        # enumeration of it would not finish either)
        return scan.jpda_hypotheses(*scan.marginals(), ehm=self._ehm)


class JPDA(_Joint, ss_probability.JPDA):
    """Stone Soup's ``JPDA``: joint probabilistic data association.

    Stone Soup enumerates every joint hypothesis; with a drop-in ``PDAHypothesiser`` the
    same marginal probabilities are computed exactly per cluster by efficient hypothesis
    management.
    """


class JPDAwithEHM(_Joint, ss_probability.JPDAwithEHM):
    """Stone Soup's ``JPDAwithEHM``: JPDA by efficient hypothesis management, compiled and
    per cluster of the gate graph with a drop-in ``PDAHypothesiser``."""

    _ehm = True
