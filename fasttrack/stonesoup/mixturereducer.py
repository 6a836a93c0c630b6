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
- A kd-tree gate (``kdtree_max_distance``), components that are not weighted Gaussian
  states of one dimension, and a subclass's own ``prune``, ``merge``, ``merge_components``
  or ``truncate`` run Stone Soup's code.
"""
import numpy as np
from stonesoup.mixturereducer import gaussianmixture as ss
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.state import TaggedWeightedGaussianState, WeightedGaussianState

from ..core import mixture as _mixture
from ..core.mixture_numpy import ordered_sum
from ._convert import mixture_components
from ._fallback import fall_back
from ._objects import builder, fresh_tags

__all__ = ["GaussianMixtureReducer"]

_OWN_METHODS = ("prune", "merge", "merge_components", "truncate")

_tagged_state = builder(TaggedWeightedGaussianState)
_weighted_state = builder(WeightedGaussianState)


class GaussianMixtureReducer(ss.GaussianMixtureReducer):
    """Stone Soup's ``GaussianMixtureReducer``, compiled."""

    def reduce(self, components_list):
        components = mixture_components(components_list)
        reason = self._reason(components)
        if reason:
            fall_back(self, "reduce", reason)
            return super().reduce(components_list)
        if not components:
            return components_list
        weights = np.array([c.weight for c in components], dtype=np.float64)
        if self.pruning:
            components, weights = _prune(components, weights, self.prune_threshold)
            if not components:
                return components
        means = np.array([c.state_vector for c in components], dtype=np.float64)[:, :, 0]
        covars = np.array([c.covar for c in components], dtype=np.float64)
        cap = self.max_number_components
        means, covars, weights, source, member = _mixture.reduce(
            means, covars, weights, "stonesoup", None, self.merge_threshold,
            cap if self.truncating and cap < len(components) else None, self.merging)
        alone = np.bincount(member[member >= 0], minlength=weights.size) == 1
        reduced = []
        weights = weights.tolist()
        for o, i in enumerate(source):
            heaviest = components[i]
            if alone[o]:
                heaviest.weight = weights[o]
                reduced.append(heaviest)
            elif isinstance(heaviest, TaggedWeightedGaussianState):
                reduced.append(_tagged_state(
                    state_vector=means[o][:, None].view(StateVector),
                    covar=covars[o].view(CovarianceMatrix), weight=weights[o],
                    timestamp=heaviest.timestamp, tag=heaviest.tag))
            else:
                reduced.append(_weighted_state(
                    state_vector=means[o][:, None].view(StateVector),
                    covar=covars[o].view(CovarianceMatrix), weight=weights[o],
                    timestamp=heaviest.timestamp))
        _rename_shared_tags(reduced)
        return reduced

    def _reason(self, components_list):
        """Why Stone Soup's code must reduce ``components_list``, or None."""
        if self.kdtree_max_distance is not None:
            return "a kd-tree gate (kdtree_max_distance)"
        own = [name for name in _OWN_METHODS
               if getattr(type(self), name) is not getattr(ss.GaussianMixtureReducer, name)]
        if own:
            return f"the subclass's own {', '.join(own)}"
        if not all(issubclass(kind, WeightedGaussianState)
                   for kind in set(map(type, components_list))):
            return "components that are not weighted Gaussian states"
        if len({c.state_vector.shape for c in components_list}) > 1:
            return "components of different dimensions"
        return None


def _prune(components, weights, threshold):
    """Stone Soup's ``prune`` of ``components`` of ``weights``: those of weight below
    ``threshold`` dropped, their total weight (summed in order) shared evenly by the others,
    whose ``weight`` is set; the kept components and their weights."""
    low = weights < threshold
    if not low.any():
        return components, weights
    kept = [c for c, dropped in zip(components, low.tolist()) if not dropped]
    if not kept:
        return kept, weights[:0]
    weights = weights[~low] + ordered_sum(weights[low]) / len(kept)
    for component, weight in zip(kept, weights.tolist()):
        component.weight = weight
    return kept, weights


def _rename_shared_tags(components):
    """Stone Soup's rule when every component is tagged: a tag on several components stays
    with the heaviest (the first of equals), the others get new uuids."""
    if not all(isinstance(c, TaggedWeightedGaussianState) for c in components):
        return
    heaviest, renamed = {}, []
    for c in components:
        kept = heaviest.get(c.tag)
        if kept is None:
            heaviest[c.tag] = c
        elif c.weight > kept.weight:
            renamed.append(kept)
            heaviest[c.tag] = c
        else:
            renamed.append(c)
    for c, tag in zip(renamed, fresh_tags(len(renamed))):
        c.tag = tag
