"""Stone Soup objects whose bulkiest properties are built when first read.

- The drop-in ``GaussianMixtureHypothesiser`` returns its detection-ordered groups (one
  ``MultipleHypothesis`` per detection, then the missed one) as :class:`PendingHypotheses`
  holding the scan's arrays, and the drop-in ``PHDUpdater`` updates from those arrays.
  Stone Soup's hypothesis objects (some 10,000 a scan at 100 targets and 100 detections)
  are built only when something reads a group: then every group of the scan at once, as
  the hypothesiser would have built them, from the components' weights and tags as they
  were when it was called.
- The drop-in ``ParticleUpdater.predict_measurement`` returns a
  :class:`PendingParticleMeasurement`: its particles' measurements as floats, their
  bearings made ``Bearing`` objects (one a particle, as Stone Soup holds them) when its
  state vectors are first read; the drop-in ``Mahalanobis`` reads the floats.
- The drop-in ``PHDUpdater`` returns its update of those arrays as a
  :class:`PendingMixtureUpdate`: the components' means, covariances, weights and tags as
  arrays, each component's ``TaggedWeightedGaussianState`` built when first read, and the
  drop-in ``GaussianMixtureReducer`` reduces the arrays, building only the components it
  returns unmerged.
"""
import copy
import threading
import weakref

from stonesoup.types.angle import Bearing
from stonesoup.types.array import CovarianceMatrix, StateVector, StateVectors
from stonesoup.types.multihypothesis import MultipleHypothesis
from stonesoup.types.prediction import ParticleMeasurementPrediction
from stonesoup.types.state import TaggedWeightedGaussianState
from stonesoup.types.update import GaussianMixtureUpdate

from ._objects import builder

__all__ = ["PendingComponents", "PendingGroups", "PendingHypotheses", "PendingMixtureUpdate",
           "PendingParticleMeasurement", "PendingVectors", "bearing_vectors", "pending",
           "pending_components", "pending_groups", "pending_mixture", "pending_values"]

_tagged_state = builder(TaggedWeightedGaussianState)

#: Held while an object is built (two threads reading at once build it once).
_BUILDING = threading.RLock()


class BuiltWhenRead:
    """Mixin (the last base) of a Stone Soup type (the first base) some of whose properties
    an instance builds when first read: ``self.__dict__["_pending"].build()`` sets them,
    removes ``_pending`` from every instance it serves and makes each of the Stone Soup
    type."""

    def __getattr__(self, name):
        pending = self.__dict__.get("_pending")
        if pending is None or not name.startswith("_property_"):
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        pending.build()
        if "_pending" in self.__dict__:  # (an object its pending builder does not know)
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        return getattr(self, name)

    def __reduce_ex__(self, protocol):
        """Copies and pickles of the built object (of the Stone Soup type), not of what
        builds it."""
        pending = self.__dict__.get("_pending")
        if pending is not None:
            pending.build()
        return object.__reduce_ex__(self, protocol)


class PendingHypotheses(MultipleHypothesis, BuiltWhenRead):
    """A ``MultipleHypothesis`` whose ``single_hypotheses`` are built, with its sibling
    groups', when first read."""


class PendingParticleMeasurement(ParticleMeasurementPrediction, BuiltWhenRead):
    """A ``ParticleMeasurementPrediction`` whose state vectors are built when first read."""


class PendingMixtureUpdate(GaussianMixtureUpdate, BuiltWhenRead):
    """A ``GaussianMixtureUpdate`` whose components are built when first read."""

    def __copy__(self):
        """A copy of the built mixture (Stone Soup's copy reads the component list
        directly)."""
        pending = self.__dict__.get("_pending")
        if pending is not None:
            pending.build()
        return copy.copy(self)


def _set_built(instance, name, value):
    """Set a built property in ``instance``'s dictionary, ``_pending`` removed, and make
    the instance of its Stone Soup type."""
    state = instance.__dict__
    del state["_pending"]
    state[f"_property_{name}"] = value
    instance.__class__ = type(instance).__bases__[0]


class PendingGroups:
    """What builds the groups of one scan (see :func:`pending_groups`) and what the updater
    reads: the ``scan``, the components' ``weights`` (K,) and ``tags`` (K,) as they were.
    ``build_all()`` returns the groups' lists of hypotheses, in their order."""

    def __init__(self, scan, weights, tags, build_all, groups):
        self.scan, self.weights, self.tags = scan, weights, tags
        self._build_all = build_all
        self._groups = [weakref.ref(group) for group in groups]  # (no cycle)
        for group in groups:
            group.__dict__.update(_property_normalise=False, _property_total_weight=1,
                                  _pending=self)

    def is_of(self, hypotheses):
        """Whether ``hypotheses`` is this scan's groups, in order."""
        return len(hypotheses) == len(self._groups) and all(
            group is ref() for group, ref in zip(hypotheses, self._groups))

    def build(self):
        """Build every group's hypotheses (once, whichever thread asks first)."""
        with _BUILDING:
            if self._build_all is None:
                return
            for ref, hypotheses in zip(self._groups, self._build_all()):
                group = ref()
                if group is not None:
                    _set_built(group, "single_hypotheses", hypotheses)
            self._build_all = self.scan = None


class PendingVectors:
    """The (m, N) float ``values`` of the particle measurements of ``prediction`` (a
    :class:`PendingParticleMeasurement`, its ``state_vector`` not yet set), ``angles`` the
    rows of bearings."""

    def __init__(self, prediction, values, angles):
        self.values, self.angles = values, angles
        prediction.__dict__["_pending"] = self
        self._prediction = weakref.ref(prediction)  # (no cycle)

    def build(self):
        """Set the prediction's state vectors (:func:`bearing_vectors`), once."""
        with _BUILDING:
            prediction = self._prediction()
            if prediction is not None and "_pending" in prediction.__dict__:
                _set_built(prediction, "state_vector",
                           bearing_vectors(self.values, self.angles))


class PendingComponents:
    """The components of one :class:`PendingMixtureUpdate`, all tagged and at
    ``timestamp``, as what the drop-in reducer reads: ``means`` (n, d), ``covars`` (n, d, d),
    ``weights`` (n,) float64 and ``tags`` (n,) a list. ``component(i)`` is component i's
    ``TaggedWeightedGaussianState``, built once (``built`` holds those built); the mixture's
    list, when first read, is made of them."""

    def __init__(self, mixture, means, covars, weights, tags, timestamp):
        self.means, self.covars, self.weights = means, covars, weights
        self.tags, self.timestamp = tags, timestamp
        self.built = {}
        mixture.__dict__["_pending"] = self
        self._mixture = weakref.ref(mixture)  # (no cycle)

    def component(self, i):
        """Component i's state (weight, tag: as the arrays hold them when first built)."""
        with _BUILDING:
            state = self.built.get(i)
            if state is None:
                state = self.built[i] = _tagged_state(
                    tag=self.tags[i], weight=float(self.weights[i]),
                    state_vector=self.means[i, :, None].view(StateVector),
                    covar=self.covars[i].view(CovarianceMatrix), timestamp=self.timestamp)
            return state

    def build(self):
        """Set the mixture's components (once)."""
        with _BUILDING:
            mixture = self._mixture()
            if mixture is not None and "_pending" in mixture.__dict__:
                _set_built(mixture, "components",
                           [self.component(i) for i in range(len(self.tags))])


def pending_mixture(hypothesis, means, covars, weights, tags, timestamp):
    """A :class:`PendingMixtureUpdate` of ``hypothesis`` whose components are those of
    the arrays (see :class:`PendingComponents`)."""
    mixture = PendingMixtureUpdate.__new__(PendingMixtureUpdate)
    mixture.__dict__["_property_hypothesis"] = hypothesis
    PendingComponents(mixture, means, covars, weights, tags, timestamp)
    return mixture


def pending_components(mixture):
    """The :class:`PendingComponents` of a :class:`PendingMixtureUpdate` whose components
    are not yet read, none built, or None."""
    if type(mixture) is not PendingMixtureUpdate:
        return None
    components = mixture.__dict__.get("_pending")
    return components if components is not None and not components.built else None


def bearing_vectors(values, angles):
    """``StateVectors`` of the (m, N) float ``values``, the rows ``angles`` ``Bearing``
    objects."""
    if not angles:
        return StateVectors(values)
    vectors = values.astype(object)
    for row in angles:
        vectors[row] = [Bearing(value) for value in values[row]]
    return StateVectors(vectors)


def pending_groups(scan, weights, tags, build_all):
    """A :class:`PendingHypotheses` for each detection of ``scan.detections``, then the
    missed group (their :class:`PendingGroups` of these arguments)."""
    groups = [PendingHypotheses.__new__(PendingHypotheses)
              for _ in range(len(scan.detections) + 1)]
    PendingGroups(scan, weights, tags, build_all, groups)
    return groups


def pending(hypotheses):
    """The :class:`PendingGroups` whose groups, none yet read, ``hypotheses`` is (the list
    the hypothesiser returned, in its order), or None."""
    if not isinstance(hypotheses, list) or not hypotheses \
            or type(hypotheses[0]) is not PendingHypotheses:
        return None
    groups = hypotheses[0].__dict__.get("_pending")
    return groups if groups is not None and groups.is_of(hypotheses) else None


def pending_values(state):
    """The :class:`PendingVectors` of a particle measurement prediction whose state vectors
    are not yet built, or None."""
    pending_vectors = state.__dict__.get("_pending") if isinstance(
        state, PendingParticleMeasurement) else None
    return pending_vectors if isinstance(pending_vectors, PendingVectors) else None
