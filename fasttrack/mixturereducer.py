"""The Gaussian mixture reducer, with Stone Soup's name and call pattern:
``reducer.reduce(mixture)``."""
import numpy as np

from . import _validate
from .core import mixture as _mixture
from .types.mixture import GaussianMixture


class GaussianMixtureReducer:
    """Prune, merge and cap a Gaussian mixture in one compiled pass (Stone Soup's
    ``GaussianMixtureReducer``; the rules are those of :func:`fasttrack.core.mixture.reduce`).

    Parameters
    ----------
    prune_threshold : float
        Components lighter than this are dropped, >= 0 (default 1e-9).
    merge_threshold : float
        Squared Mahalanobis distance within which components merge, >= 0 (default 16).
    max_number_components : int, optional
        Most components kept: the heaviest (default: no cap).
    merging, pruning, truncating : bool
        Whether to merge, prune and cap (default: all three).
    mode : {"textbook", "stonesoup"}
        Vo and Ma's rules (default; no weight lost or capped in a merge) or Stone Soup's,
        quirks included (merged weights capped at 1, pruned and cut mass spread evenly).
    """

    def __init__(self, prune_threshold=1e-9, merge_threshold=16.0, max_number_components=None,
                 merging=True, pruning=True, truncating=True, mode="textbook"):
        self.prune_threshold, self.merge_threshold = prune_threshold, merge_threshold
        self.max_number_components = max_number_components
        self.merging, self.pruning, self.truncating = merging, pruning, truncating
        self.mode = mode

    #: Checked when assigned (here or later), as the parameters.
    prune_threshold = _validate.Setting(_validate.non_negative)
    merge_threshold = _validate.Setting(_validate.threshold)
    max_number_components = _validate.Setting(_validate.count, default=_validate.MAX_COUNT)
    merging = _validate.Setting(_validate.flag)
    pruning = _validate.Setting(_validate.flag)
    truncating = _validate.Setting(_validate.flag)
    mode = _validate.Setting(_mixture.check_mode)

    def reduce(self, mixture, first_label=None):
        """The reduced ``mixture``.

        Each merge keeps the label of its heaviest component; where a label is then left on
        several components, the heaviest keeps it and the others get new labels, counting
        up from ``first_label``.

        Parameters
        ----------
        mixture : GaussianMixture
        first_label : int, optional
            The first new label, above every label of ``mixture`` (default: one above the
            largest).

        Returns
        -------
        GaussianMixture
            Each merge's heaviest first (heaviest first overall when capped).
        """
        if not isinstance(mixture, GaussianMixture):
            raise TypeError(f"mixture must be a GaussianMixture, got {type(mixture).__name__}")
        means, covars, log_weights, labels = mixture.fields()
        with np.errstate(over="ignore"):
            linear = np.exp(log_weights)
        if np.isinf(linear).any():
            raise ValueError(f"mixture.log_weights must lie below log(1.8e308) = 709.78 (the "
                             f"reducer works on weights), got {log_weights.max()}")
        above = int(labels.max()) + 1 if labels.size else 0
        means, covars, weights, source, _ = _mixture.reduce(
            means, covars, linear, self.mode,
            self.prune_threshold if self.pruning else None, self.merge_threshold,
            self.max_number_components if self.truncating else None, self.merging)
        if first_label is None:
            first_label = above
        elif not _validate.is_integer(first_label):
            raise TypeError(f"first_label must be an int, got {type(first_label).__name__}")
        elif int(first_label) < above:
            raise ValueError(f"first_label must be above every label of the mixture (>= "
                             f"{above}), got {first_label}")
        first_label = int(first_label)
        if first_label + len(weights) > np.iinfo(np.int64).max:
            raise ValueError(f"first_label leaves no room for new labels below 2**63, got "
                             f"{first_label}")
        labels = _mixture.relabel(labels[source], weights, first_label)
        with np.errstate(divide="ignore"):
            return GaussianMixture._made(means, covars, np.log(weights), labels)
