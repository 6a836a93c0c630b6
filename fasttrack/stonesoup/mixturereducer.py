"""Stone Soup's ``stonesoup.mixturereducer``: the ``GaussianMixtureReducer``, its merge and
truncation in one compiled pass by Stone Soup's rules (:func:`fasttrack.core.mixture.reduce`,
mode "stonesoup"), gated by a grid instead of testing every pair.

- As Stone Soup does, the pruned mass is added to the kept components' weights in place,
  the cut mass likewise to the kept ones' after a truncation, and the components that no
  merge touched are returned themselves; a merge returns a new state of its heaviest
  component's class (tagged or not), tag and timestamp. A tag then left on several
  components stays with the heaviest, the others get new uuids.
- The order is the merges' (each one's heaviest first; by weight after a truncation). Stone
  Soup regroups its list by tag, in set order, when it renames duplicate tags: its order
  then differs from run to run.
- The drop-in ``PHDUpdater``'s update of the drop-in hypothesiser's groups holds its
  components as arrays: they are reduced from those, and only the components returned
  unmerged are built (the update's list, when read, is made of them and of the others with
  their pruned weights).
- A kd-tree gate (``kdtree_max_distance``), components that are not weighted Gaussian
  states of one dimension, the same component given twice, a subclass's own ``prune``,
  ``merge``, ``merge_components`` or ``truncate``, and whatever fasttrack's arrays refuse
  (a covariance that is singular or not symmetric, a weight that is not a finite number
  >= 0, a setting that is not a number or a bool) run Stone Soup's code, on the components
  as they were given.
"""
import numbers

import numpy as np
from stonesoup.mixturereducer import gaussianmixture as ss
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.state import TaggedWeightedGaussianState, WeightedGaussianState

from ..core import mixture as _mixture
from ..core.mixture_numpy import ordered_sum
from ._convert import all_real, mixture_components
from ._fallback import fall_back
from ._objects import builder, fresh_tags
from ._pending import pending_components

__all__ = ["GaussianMixtureReducer"]

_OWN_METHODS = ("prune", "merge", "merge_components", "truncate")

_tagged_state = builder(TaggedWeightedGaussianState)
_weighted_state = builder(WeightedGaussianState)


class GaussianMixtureReducer(ss.GaussianMixtureReducer):
    """Stone Soup's ``GaussianMixtureReducer``, compiled."""

    def reduce(self, components_list):
        if self.truncating and isinstance(self.max_number_components, numbers.Real) \
                and self.max_number_components < 1:
            raise ValueError(f"max_number_components must be >= 1, got "
                             f"{self.max_number_components}")
        source = pending_components(components_list)
        if source is None:
            components = mixture_components(components_list)
            reason = self._reason() or _reason(components)
        else:
            reason = self._reason()
        if not reason:
            source = _Objects(components) if source is None else _Arrays(source)
            try:
                return self._reduced(source, components_list)
            except (ValueError, TypeError) as error:  # input Stone Soup's code handles
                reason = f"refused by fasttrack ({error})"
        fall_back(self, "reduce", reason)
        return super().reduce(components_list)

    def _reduced(self, source, components_list):
        """The reduction of ``source`` (:class:`_Objects` or :class:`_Arrays`); the kept
        components' weights are set (pruned mass added) once the arrays are reduced, so that
        a refusal leaves them as they were."""
        if not source.weights.size:
            return components_list
        weights, kept = source.weights, np.arange(source.weights.size)
        if self.pruning:
            low = ~(weights >= self.prune_threshold)  # (Stone Soup keeps w >= it; NaN: none)
            if low.any():
                kept = np.flatnonzero(~low)
                if not kept.size:
                    return []
                weights = weights[kept] + ordered_sum(weights[low]) / kept.size
        cap = self.max_number_components if self.truncating else kept.size
        means, covars, merged_weights, heaviest, member = _mixture.reduce(
            *source.arrays(kept), weights, "stonesoup", None, self.merge_threshold,
            cap if cap < kept.size else None, bool(self.merging))
        if kept.size < source.weights.size:
            source.set_weights(kept, weights)
        alone = (np.bincount(member[member >= 0], minlength=merged_weights.size) == 1).tolist()
        heaviest = kept[heaviest].tolist()
        merged_weights = merged_weights.tolist()
        reduced = [source.kept(i, weight) if single else source.merged(i, mean, covar, weight)
                   for i, single, mean, covar, weight in zip(heaviest, alone, means, covars,
                                                             merged_weights)]
        tags = source.tags(heaviest)
        if tags is not None:
            renamed = _shared_tags(tags, merged_weights)
            for o, tag in zip(renamed, fresh_tags(len(renamed))):
                reduced[o].tag = tag
        return reduced

    def _reason(self):
        """Why Stone Soup's code must reduce, whatever the components, or None."""
        if self.kdtree_max_distance is not None:
            return "a kd-tree gate (kdtree_max_distance)"
        own = [name for name in _OWN_METHODS
               if getattr(type(self), name) is not getattr(ss.GaussianMixtureReducer, name)]
        if own:
            return f"the subclass's own {', '.join(own)}"
        return None


def _reason(components):
    """Why Stone Soup's code must reduce ``components``, or None."""
    if not all(issubclass(kind, WeightedGaussianState) for kind in set(map(type, components))):
        return "components that are not weighted Gaussian states"
    if len(set(map(id, components))) < len(components):
        return "a component given twice"  # (Stone Soup's merge counts it once)
    if not all_real(c.weight for c in components):
        return "a weight that is not a real number"  # (not read as one: Stone Soup's error)
    if len({c.state_vector.shape for c in components}) > 1:
        return "components of different dimensions"
    return None


class _Objects:
    """What the reducer reads and builds for a list of Stone Soup ``components``: their
    ``weights`` (J,) float64; the kept ones' weights set in place, as Stone Soup's prune
    sets them; a component returned unmerged is itself."""

    def __init__(self, components):
        self.components = components
        self.weights = np.array([c.weight for c in components], dtype=np.float64)

    def set_weights(self, kept, weights):
        for i, weight in zip(kept.tolist(), weights.tolist()):
            self.components[i].weight = weight

    def arrays(self, kept):
        components = [self.components[i] for i in kept.tolist()]
        return (np.array([c.state_vector for c in components], dtype=np.float64)[:, :, 0],
                np.array([c.covar for c in components], dtype=np.float64))

    def kept(self, i, weight):
        """Component i, unmerged, of ``weight``."""
        component = self.components[i]
        component.weight = weight
        return component

    def merged(self, i, mean, covar, weight):
        """A new state of component i's class (tagged or not), tag and timestamp: the
        merge whose heaviest is i."""
        heaviest = self.components[i]
        values = dict(state_vector=mean[:, None].view(StateVector),
                      covar=covar.view(CovarianceMatrix), weight=weight,
                      timestamp=heaviest.timestamp)
        if isinstance(heaviest, TaggedWeightedGaussianState):
            return _tagged_state(tag=heaviest.tag, **values)
        return _weighted_state(**values)

    def tags(self, index):
        """The tags of the components ``index``, or None unless every one is tagged."""
        components = [self.components[i] for i in index]
        if not all(isinstance(c, TaggedWeightedGaussianState) for c in components):
            return None
        return [c.tag for c in components]


class _Arrays(_Objects):
    """As :class:`_Objects`, for the components of a pending mixture update
    (:class:`~._pending.PendingComponents`), read from its arrays: a weight set on a
    component not built is set in the arrays (it is built with it), and only the
    components returned unmerged are built."""

    def __init__(self, pending):
        self.pending, self.weights = pending, pending.weights

    def set_weights(self, kept, weights):
        self.weights[kept] = weights

    def arrays(self, kept):
        return self.pending.means[kept], self.pending.covars[kept]

    def kept(self, i, weight):
        self.weights[i] = weight
        return self.pending.component(i)

    def merged(self, i, mean, covar, weight):
        return _tagged_state(tag=self.pending.tags[i], weight=weight,
                             state_vector=mean[:, None].view(StateVector),
                             covar=covar.view(CovarianceMatrix),
                             timestamp=self.pending.timestamp)

    def tags(self, index):
        return [self.pending.tags[i] for i in index]


def _shared_tags(tags, weights):
    """Stone Soup's rule when every component is tagged, on the components' ``tags`` and
    ``weights``: a tag on several stays with the heaviest (the first of equals); the
    positions of the others, which get new uuids."""
    heaviest, renamed = {}, []
    for o, (tag, weight) in enumerate(zip(tags, weights)):
        kept = heaviest.get(tag)
        if kept is None:
            heaviest[tag] = o
        elif weight > weights[kept]:
            renamed.append(kept)
            heaviest[tag] = o
        else:
            renamed.append(o)
    return renamed
