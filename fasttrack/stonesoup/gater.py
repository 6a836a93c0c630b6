"""Stone Soup's ``stonesoup.gater``: the ``DistanceGater``, part of the vectorised scan
(see ``_scan``) when it wraps a drop-in hypothesiser with a Mahalanobis measure."""
from stonesoup.gater import distance as ss_gater

from ._fallback import fall_back
from ._recipe import vectorised
from ._scan import _scan

__all__ = ["DistanceGater"]


@vectorised("gate")
class DistanceGater(ss_gater.DistanceGater):
    """Stone Soup's ``DistanceGater``.

    Wrapping a drop-in hypothesiser with a ``Mahalanobis`` measure it is part of the
    vectorised path (its threshold gates the detections together with the hypothesiser's);
    otherwise it runs Stone Soup's code.
    """

    def hypothesise(self, track, detections, *args, **kwargs):
        """The wrapped hypothesiser's hypotheses whose measure is below ``gate_threshold``
        (and the missed detection), best first.

        Parameters
        ----------
        track : stonesoup.types.track.Track
        detections : set of stonesoup.types.detection.Detection
        *args, **kwargs
            Passed on to the wrapped hypothesiser (the timestamp).

        Returns
        -------
        stonesoup.types.multihypothesis.MultipleHypothesis
        """
        scan = "arguments other than a timestamp"
        if len(args) == 1 and not kwargs:
            scan = _scan(self, [track], detections, args[0], {}, single=True)
        elif not args and set(kwargs) == {"timestamp"}:
            scan = _scan(self, [track], detections, kwargs["timestamp"], {}, single=True)
        if isinstance(scan, str):
            fall_back(self, "hypothesise", scan)
            return super().hypothesise(track, detections, *args, **kwargs)
        return scan.hypotheses(0)
