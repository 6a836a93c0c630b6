"""Stacks of Gaussians: a mixture (components with log weights and labels) and a set of
tracks, as arrays: (K, d) means and (K, d, d) covariances."""
import dataclasses

import numpy as np

from .. import _validate
from ..core import imm as _imm
from ..core import mixture as _mixture

__all__ = ["GaussianMixture", "IMMTrackSet", "TrackSet"]


@dataclasses.dataclass(frozen=True)
class GaussianMixture:
    """K weighted Gaussian components.

    Also built from a list of :class:`~fasttrack.types.WeightedGaussianState` components
    of one time (``GaussianMixture(components)``): their means, covariances, the logs of
    their weights, and their time as :attr:`timestamp`.

    Parameters
    ----------
    means : (K, d) array_like, or a list of WeightedGaussianState
    covars : (K, d, d) array_like
        Symmetric positive semi-definite (checked, by the kernels' tolerance).
    log_weights : (K,) array_like, optional
        Unnormalised log weights, -inf for zero (default: equal weights).
    labels : (K,) array_like of int, optional
        A label per component (e.g. its track), default all 0.

    The mixture keeps copies of the arrays given (it is checked once, when made: edit a
    mixture by building a new one, not by writing into its arrays).
    """

    means: np.ndarray
    covars: np.ndarray = None
    log_weights: np.ndarray = None
    labels: np.ndarray = None

    def __post_init__(self):
        timestamp = None
        if self.covars is None:
            components, timestamp = _components(self.means)
            for name, value in (("means", np.array([c.state_vector[:, 0] for c in components])),
                                ("covars", np.array([c.covar for c in components])),
                                ("log_weights", _log([c.weight for c in components]))):
                object.__setattr__(self, name, value)
        object.__setattr__(self, "_timestamp", timestamp)
        means, covars = _mixture.stack(self.means, self.covars)
        _mixture.check_covariances(covars, "covars")
        k = means.shape[0]
        log_weights = np.zeros(k) if self.log_weights is None else \
            _mixture.log_weight_array(self.log_weights, k)
        labels = np.zeros(k, dtype=np.int64) if self.labels is None \
            else _mixture.label_array(self.labels, k)
        for name, value in (("means", means), ("covars", covars), ("log_weights", log_weights),
                            ("labels", labels)):  # (copies: the caller's arrays stay theirs)
            object.__setattr__(self, name, value.copy())

    @classmethod
    def _made(cls, means, covars, log_weights, labels, timestamp=None):
        """A mixture of arrays fasttrack made: C-contiguous float64 (K, d), (K, d, d), (K,)
        and int64 (K,) labels, not checked again."""
        out = object.__new__(cls)
        for name, value in (("means", means), ("covars", covars), ("log_weights", log_weights),
                            ("labels", labels), ("_timestamp", timestamp)):
            object.__setattr__(out, name, value)
        return out

    def __len__(self):
        return self.means.shape[0]

    def fields(self, name="mixture"):
        """``(means, covars, log_weights, labels)``, checked to be arrays of the mixture's
        kinds whose shapes agree (a mixture's fields can be replaced after it is made).

        Parameters
        ----------
        name : str
            The mixture's name in the errors (e.g. a tracker's ``"birth"``).

        Raises
        ------
        TypeError
            For a field that is not a float64 (labels: int64) ndarray, naming ``name``'s.
        ValueError
            For a field whose shape disagrees with the (K, d) means.
        """
        means = self.means
        _field_kind(name, "means", means, _FLOAT)
        if means.ndim != 2:
            raise ValueError(f"{name}.means must be 2-D (K, d), got shape {means.shape}")
        k, d = means.shape
        out = [means]
        for field, shape, kind in (("covars", (k, d, d), _FLOAT), ("log_weights", (k,), _FLOAT),
                                   ("labels", (k,), _INT)):
            value = getattr(self, field)
            _field_kind(name, field, value, kind)
            if value.shape != shape:
                raise ValueError(f"{name}.{field} must have shape {shape}, as its {k} means, "
                                 f"got {value.shape}")
            out.append(value)
        return tuple(out)

    @property
    def timestamp(self):
        """The components' time (None for a mixture built from arrays)."""
        return self._timestamp

    @property
    def components(self):
        """The components as :class:`~fasttrack.types.WeightedGaussianState` (new objects)."""
        from .gaussian import WeightedGaussianState
        means, covars, log_weights, _ = self.fields()
        with np.errstate(under="ignore", over="ignore"):
            weights = np.exp(log_weights)
        if np.isinf(weights).any():
            raise ValueError(f"log_weights beyond log(1.8e308) = 709.78 have no float64 weight "
                             f"for a component, got {log_weights.max()}")
        return [WeightedGaussianState(m, p, float(w), self._timestamp)
                for m, p, w in zip(means, covars, weights)]

    @property
    def mean(self):
        """The moment-matched mean (d, 1): the components' weighted mean (the weights
        normalised)."""
        return self._matched()[0][:, None]

    @property
    def covar(self):
        """The moment-matched covariance (d, d): the weighted covariances plus the spread
        of the means."""
        return self._matched()[1]

    def _matched(self):
        means, covars, log_weights, _ = self.fields()
        if len(self) == 0 or log_weights.max() == -np.inf:
            raise ValueError("a mixture of no components or of zero weight has no mean or "
                             "covariance")
        weights = np.exp(log_weights - log_weights.max())
        mean, covar = _imm.combine(means[None], covars[None], (weights / weights.sum())[None])
        _mixture.check_finite_moments(mean, covar)
        return mean[0], covar[0]

    def reduce(self):
        """The mixture with each label's components merged into one Gaussian of the same
        mean and covariance, weighted by their total (see
        :func:`fasttrack.core.mixture.moment_match`)."""
        return GaussianMixture(*_mixture.moment_match(self.means, self.covars,
                                                      self.log_weights, self.labels))


def _components(components):
    """``(components, timestamp)`` of a list of weighted Gaussian states of one time and
    dimension, else an error naming ``components``."""
    from .gaussian import WeightedGaussianState
    components = list(components) if isinstance(components, (list, tuple)) else None
    if not components or not all(isinstance(c, WeightedGaussianState) for c in components):
        raise TypeError("a GaussianMixture is built from arrays (means, covars) or from a "
                        "non-empty list of WeightedGaussianState components")
    if len({c.ndim for c in components}) > 1:
        raise ValueError("the components must all have the same dimension")
    times = {c.timestamp for c in components}
    if len(times) > 1:
        raise ValueError(f"the components must all have the same timestamp, got {len(times)}")
    return components, times.pop()


_FLOAT, _INT = np.dtype(np.float64), np.dtype(np.int64)


def _field_kind(name, field, value, kind):
    """TypeError naming ``name.field`` unless ``value`` is an ndarray of dtype ``kind``."""
    if not isinstance(value, np.ndarray) or value.dtype != kind:
        got = f"{value.dtype} array" if isinstance(value, np.ndarray) else type(value).__name__
        raise TypeError(f"{name}.{field} must be a {kind} ndarray, got {got}")


def _log(weights):
    with np.errstate(divide="ignore"):
        return np.log(np.asarray(weights, dtype=np.float64))


@dataclasses.dataclass
class TrackSet:
    """Tracks as arrays.

    Attributes
    ----------
    ids : (K,) int64 ndarray
        Track identities, unique over the tracker's life.
    means : (K, d) float64 ndarray
    covars : (K, d, d) float64 ndarray
    updates : (K,) int64 ndarray
        Number of detections each track has been updated with (its first one included).
    misses : (K,) int64 ndarray
        Scans since each track's last detection.
    ages : (K,) int64 ndarray
        Scans since each track's first detection.
    """

    ids: np.ndarray
    means: np.ndarray
    covars: np.ndarray
    updates: np.ndarray
    misses: np.ndarray
    ages: np.ndarray

    @classmethod
    def empty(cls, d):
        """No tracks of dimension ``d``."""
        d = _validate.count(d, "d")
        none = np.empty(0, dtype=np.int64)
        return cls(none, np.empty((0, d)), np.empty((0, d, d)), none.copy(), none.copy(),
                   none.copy())

    def __len__(self):
        return self.ids.size

    def copy(self):
        """A copy holding copies of the arrays."""
        return type(self)(*[field.copy() for field in self._fields()])

    def take(self, keep):
        """The tracks selected by a boolean mask or index array."""
        return type(self)(*[field[keep] for field in self._fields()])

    @staticmethod
    def concatenate(first, second):
        """The tracks of both sets (of one type and dimension)."""
        if type(second) is not type(first):
            raise TypeError(f"second must be a {type(first).__name__}, as first is, got "
                            f"{type(second).__name__}")
        for a, b, field in zip(first._fields(), second._fields(), dataclasses.fields(first)):
            if a.shape[1:] != b.shape[1:]:
                raise ValueError(f"the track sets' {field.name} differ in shape: {a.shape} "
                                 f"and {b.shape}")
        return type(first)(*[np.concatenate((a, b)) for a, b in
                             zip(first._fields(), second._fields())])

    def _fields(self):
        """The arrays, in field order (not copied, unlike ``dataclasses.astuple``)."""
        return [getattr(self, field.name) for field in dataclasses.fields(self)]

    def check(self, name, d, models=None):
        """ValueError naming ``name.field`` unless every field is an ndarray of its shape
        for K tracks of dimension ``d`` (and ``models`` models, for an
        :class:`IMMTrackSet`), its floats finite."""
        k = np.shape(self.ids)[0] if np.ndim(self.ids) else -1
        for field, value in zip(dataclasses.fields(self), self._fields()):
            shape = self._shape(field.name, k, d, models)
            if not isinstance(value, np.ndarray) or value.shape != shape \
                    or value.dtype.kind != ("f" if field.name in _FLOAT_FIELDS else "i"):
                kind = "float64" if field.name in _FLOAT_FIELDS else "int64"
                raise ValueError(f"{name}.{field.name} must be a {kind} array of shape "
                                 f"{shape} ({k} tracks), got "
                                 f"{getattr(value, 'dtype', type(value).__name__)} of shape "
                                 f"{np.shape(value)}")
            if field.name in _FLOAT_FIELDS and not np.isfinite(value).all():
                raise ValueError(f"{name}.{field.name} must be finite")

    @staticmethod
    def _shape(field, k, d, models):
        return {"means": (k, d), "covars": (k, d, d), "model_means": (k, models, d),
                "model_covars": (k, models, d, d), "mode_probs": (k, models)}.get(field, (k,))


#: The fields of track sets that hold floats (the others hold integers).
_FLOAT_FIELDS = {"means", "covars", "model_means", "model_covars", "mode_probs"}


@dataclasses.dataclass
class IMMTrackSet(TrackSet):
    """Tracks that are IMM filters, as arrays: :class:`TrackSet`'s fields (``means`` and
    ``covars`` the combined estimates, the moment match of the models) and each model's.

    Attributes
    ----------
    model_means : (K, M, d) float64 ndarray
    model_covars : (K, M, d, d) float64 ndarray
    mode_probs : (K, M) float64 ndarray
        Each track's model probabilities (rows sum to one).
    """

    model_means: np.ndarray = None
    model_covars: np.ndarray = None
    mode_probs: np.ndarray = None

    @classmethod
    def empty(cls, d, models=1):
        """No tracks of dimension ``d`` and ``models`` models."""
        none = TrackSet.empty(d)
        models = _validate.count(models, "models")
        return cls(*none._fields(), np.empty((0, models, d)), np.empty((0, models, d, d)),
                   np.empty((0, models)))
