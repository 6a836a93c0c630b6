"""Hypotheses built when first read.

The drop-in ``GaussianMixtureHypothesiser`` returns its detection-ordered groups (one
``MultipleHypothesis`` per detection, then the missed one) as :class:`PendingHypotheses`
holding the scan's arrays, and the drop-in ``PHDUpdater`` updates from those arrays. Stone
Soup's hypothesis objects (some 10,000 a scan at 100 targets and 100 detections) are built
only when something reads a group: then every group of the scan is built at once, as the
hypothesiser would have built it, from the components' weights and tags as they were when
it was called.
"""
from stonesoup.types.multihypothesis import MultipleHypothesis

__all__ = ["PendingGroups", "PendingHypotheses", "pending"]


class PendingHypotheses(MultipleHypothesis):
    """A ``MultipleHypothesis`` whose ``single_hypotheses`` are built, with its sibling
    groups', when first read."""

    def __getattr__(self, name):
        groups = self.__dict__.get("_pending")
        if name != "_property_single_hypotheses" or groups is None:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        groups.build()
        return self.__dict__[name]

    def __getstate__(self):
        """The state with the hypotheses built (copies and pickles hold Stone Soup's objects,
        not the scan)."""
        self.single_hypotheses  # noqa: B018 - built by reading
        return dict(self.__dict__)


class PendingGroups:
    """The groups of one scan: ``groups`` (a :class:`PendingHypotheses` per detection of
    ``scan.detections``, then the missed group) and what the updater reads: the ``scan``,
    the components' ``weights`` (K,) and ``tags`` (K,) as they were. ``build_all()`` returns
    the groups' lists of hypotheses, in the same order."""

    def __init__(self, scan, weights, tags, build_all):
        self.scan, self.weights, self.tags = scan, weights, tags
        self._build_all = build_all
        self.groups = []
        for _ in range(len(scan.detections) + 1):
            group = PendingHypotheses.__new__(PendingHypotheses)
            group.__dict__.update(_property_normalise=False, _property_total_weight=1,
                                  _pending=self)
            self.groups.append(group)

    def build(self):
        """Build every group's hypotheses; the groups then hold only them."""
        for group, hypotheses in zip(self.groups, self._build_all()):
            state = group.__dict__
            rest = {key: value for key, value in state.items() if key != "_pending"}
            state.clear()
            state["_property_single_hypotheses"] = hypotheses
            state.update(rest)
        self._build_all = self.scan = None


def pending(hypotheses):
    """The :class:`PendingGroups` whose groups, none yet read, ``hypotheses`` is (the list
    the hypothesiser returned, in its order), or None."""
    if not isinstance(hypotheses, list) or not hypotheses \
            or type(hypotheses[0]) is not PendingHypotheses:
        return None
    groups = hypotheses[0].__dict__.get("_pending")
    if groups is None or len(hypotheses) != len(groups.groups) \
            or any(a is not b for a, b in zip(hypotheses, groups.groups)):
        return None
    return groups
