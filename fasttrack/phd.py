"""Gaussian-mixture PHD and CPHD trackers over scans (Vo and Ma 2006; Vo, Vo and Cantoni
2007), on arrays: the intensity is a :class:`~fasttrack.types.GaussianMixture` whose labels
follow each component's line (the heaviest child of a merge keeps its parent's), so the
estimates it extracts are tagged."""
import functools
import math

import numpy as np

from . import _validate
from .batch import ModelSettings
from .core import cphd as _cphd
from .core import kalman as _kalman
from .core import mixture as _mixture
from .core import phd as _phd
from .core.cphd_numpy import logsumexp
from .core.mixture_numpy import first_bad_covariance
from .mixturereducer import GaussianMixtureReducer
from .models.measurement import LinearGaussian
from .types.mixture import GaussianMixture

_LOG_LARGEST = math.log(np.finfo(np.float64).max)
#: Labels of a tracker's mixture stay below this, so that new labels above them fit int64.
_LABEL_LIMIT = 2 ** 62


@functools.lru_cache(maxsize=None)
def _first_row(d):
    """A sensor of the first of d state rows (for predictions whose measurements nobody
    reads)."""
    return LinearGaussian(d, (0,), np.eye(1))

class _IntensityTracker(ModelSettings):
    """What the PHD and CPHD trackers share: the models, the birth intensity, P_D, P_S,
    the clutter intensity, the gate and the reducer (see :class:`PHDTracker`), and the
    step: predict, add the births, update (:meth:`_update`), reduce, extract
    (:meth:`_extract`)."""

    def __init__(self, transition_model, measurement_model, birth, prob_detect, prob_survival,
                 clutter_intensity, gate_threshold, reducer, unscented):
        self.transition_model, self.measurement_model = transition_model, measurement_model
        self.unscented = unscented
        self.birth = birth
        self.prob_detect = prob_detect
        self.prob_survival = prob_survival
        self.clutter_intensity = clutter_intensity
        self.gate_threshold = gate_threshold
        self.reducer = GaussianMixtureReducer(1e-5, 4.0, 100) if reducer is None else reducer
        d = birth.means.shape[1]
        self._next_label = 0
        self.mixture = GaussianMixture(np.empty((0, d)), np.empty((0, d, d)), np.empty(0),
                                       np.empty(0, dtype=np.int64))
        self.time = None

    # Settings, checked when assigned (here or later).
    birth = _validate.Setting("_birth")
    unscented = _validate.Setting(_validate.optional(_phd.unscented_parameters))
    mixture = _validate.Setting("_mixture")
    time = _validate.Setting(_validate.optional(_validate.real))
    prob_detect = _validate.Setting(_validate.probability)
    prob_survival = _validate.Setting(_validate.probability)
    clutter_intensity = _validate.Setting(_validate.positive)
    gate_threshold = _validate.Setting(_validate.optional(_validate.positive))
    reducer = _validate.Setting("_reducer")

    def _intensity(self, mixture, name):
        """``mixture``, checked to be a mixture of the models' state, of fields that agree
        in length and a finite expected number of targets."""
        if not isinstance(mixture, GaussianMixture):
            raise TypeError(f"{name} must be a GaussianMixture, got {type(mixture).__name__}")
        means, _, log_weights, _ = mixture.fields(name)
        d = self.measurement_model.ndim_state
        if means.shape[1] != d:
            raise ValueError(f"{name} must have {d}-D components (the models' state), got "
                             f"means of shape {means.shape}")
        total = logsumexp(log_weights) if len(mixture) else -np.inf
        if total > _LOG_LARGEST:
            raise ValueError(f"{name}.log_weights must total at most {_LOG_LARGEST:.1f} in "
                             f"log (its expected number of targets, finite), got {total}")
        return mixture

    def _mixture(self, mixture, name):
        """``mixture``, checked as :meth:`_intensity`, its labels below 2**62 (room for
        new ones); the labels given later (births, merges) start above them."""
        self._intensity(mixture, name)
        if len(mixture):
            top = int(mixture.labels.max())
            if top >= _LABEL_LIMIT:
                raise ValueError(f"{name}.labels must be below 2**62 (new components are "
                                 f"labelled above them), got {top}")
            self._next_label = max(self._next_label, top + 1)
        return mixture

    def _birth(self, birth, name):
        """``birth``, checked: a mixture of the models' state (its expected number of
        births finite), its covariances positive definite (the reducer measures distances by
        their inverses), and (unless unscented) the sensor differentiable at its means."""
        self._intensity(birth, name)
        _mixture.check_covariances(birth.covars, f"{name}.covars")
        singular = first_bad_covariance(birth.covars) if len(birth) else -1
        if singular >= 0:
            raise ValueError(f"{name}.covars[{singular // 2}] must be positive definite (the "
                             f"reducer measures distances by its inverse)")
        if self.unscented is None:  # (each update linearises the sensor at the births' means)
            _phd.jacobians_at(self.measurement_model.spec, birth.means, f"{name}.means")
        return birth

    @staticmethod
    def _reducer(reducer, name):
        """``reducer``, checked to be a GaussianMixtureReducer that prunes, merges or
        truncates (with none of them, the intensity gains a component for each pair of
        component and detection every scan, without bound)."""
        _validate.instance(reducer, name, GaussianMixtureReducer)
        if not (reducer.pruning or reducer.merging or reducer.truncating):
            raise ValueError(f"{name} must prune, merge or truncate (a tracker's intensity "
                             f"multiplies its components by the detections + 1 every scan), "
                             f"got pruning, merging and truncating all False")
        return reducer

    def step(self, detections, time):
        """Process one scan.

        Parameters
        ----------
        detections : (M, m) array_like
            The scan (an empty one for none), finite. Bearings are wrapped to [-pi, pi)
            (within +-1e9 rad) and ranges taken as measured: the sensor's noise is additive,
            so a range measured near the sensor may be negative.
        time : float
            The scan's time in seconds, finite, after the previous scan's (the intensity is
            predicted over the difference).

        Returns
        -------
        GaussianMixture
            The estimates (:meth:`_extract`), labelled.
        """
        time, dt = _validate.scan_time(time, self.time)
        self._reducer(self.reducer, "reducer")  # (its settings may have changed since)
        predicted = self._predicted(dt)
        means, covars, log_weights, components = self._update(predicted, detections)
        updated = GaussianMixture._made(means, covars, log_weights, predicted.labels[components])
        self.mixture = self.reducer.reduce(updated, first_label=self._next_label)
        self.time = time
        return self._picked(self._extract())

    def run(self, scans, time_interval=1.0):
        """:meth:`step` through ``scans``, ``time_interval`` seconds apart (after the previous
        scan's time, or from 0).

        Parameters
        ----------
        scans : iterable of (M, m) array_like
        time_interval : float
            Seconds between scans, > 0.

        Returns
        -------
        list of GaussianMixture
            The estimates of each scan.
        """
        time_interval = _validate.positive(time_interval, "time_interval")
        start = 0.0 if self.time is None else self.time + time_interval
        return [self.step(scan, start + t * time_interval)
                for t, scan in enumerate(_validate.iterator(scans, "scans"))]

    def _picked(self, index):
        """The components ``index`` (a mask or indices) of the intensity."""
        return GaussianMixture._made(*(field[index] for field in self.mixture.fields("mixture")))

    def _predicted(self, dt):
        """The intensity ``dt`` seconds on, survival applied, with the births (new labels)."""
        means, covars, log_weights, labels = self.mixture.fields("mixture")
        birth = self.birth.fields("birth")  # (both may be written into or replaced since set)
        for name, values in (("mixture", log_weights), ("birth", birth[2])):
            if np.isnan(values).any() or (values == np.inf).any():
                raise ValueError(f"{name}.log_weights must not be NaN or +inf")
        k = means.shape[0]
        if birth[0].shape[1:] != means.shape[1:]:
            raise ValueError(f"birth must have components of the mixture's dimension "
                             f"{means.shape[1]}, got means of shape {birth[0].shape}")
        if k and dt > 0:  # (a sensor of one state row: the measurements are not used)
            means, covars, _, _ = _kalman.stack_predict(
                self.transition_model, _first_row(means.shape[1]), np.full(k, dt), means,
                covars)
        log_survive = _phd.log_probability(self.prob_survival, "prob_survival")
        births = birth[0].shape[0]
        labels = np.concatenate((labels, self._next_label + np.arange(births, dtype=np.int64)))
        self._next_label += births
        return GaussianMixture._made(np.concatenate((means, birth[0])),
                                     np.concatenate((covars, birth[1])),
                                     np.concatenate((log_weights + log_survive, birth[2])),
                                     labels)


class PHDTracker(_IntensityTracker):
    """The GM-PHD filter, scan by scan: predict the intensity (weights times P_S), add the
    birth components, update with the scan (:func:`fasttrack.core.phd.update`), reduce, and
    extract the components heavier than ``extraction_threshold``.

    The settings (the parameters but the models) may be changed between scans; each
    assignment is checked as the constructor checks it.

    Parameters
    ----------
    transition_model : TransitionModel
        Linear (e.g. :class:`~fasttrack.CombinedLinearGaussianTransitionModel`).
    measurement_model : LinearGaussian, CartesianToBearingRange or Cartesian2DToBearing
    birth : GaussianMixture
        The intensity born each scan (its weights: expected births a scan, by component).
    prob_detect, prob_survival : float
        P_D and P_S, in [0, 1].
    clutter_intensity : float
        Expected clutter detections per unit volume of measurement space, > 0.
    gate_threshold : float, optional
        Squared Mahalanobis distance within which a detection updates a component, finite
        and > 0 (default None: every pair).
    reducer : ~fasttrack.mixturereducer.GaussianMixtureReducer, optional
        Default: prune 1e-5, merge 4, at most 100 components (Vo's), textbook rules. It
        must prune, merge or truncate (checked at each step).
    extraction_threshold : float
        Components heavier than this are the estimates (default 0.5).
    unscented : (alpha, beta, kappa), optional
        For a polar sensor, update by the unscented transform with these parameters instead
        of the Jacobian (see :func:`fasttrack.core.phd.update`).
    Attributes
    ----------
    mixture : GaussianMixture
        The current intensity; the sum of its weights is the expected number of targets.
        A mixture assigned to it is checked as the birth is, its labels below 2**62; the
        components the tracker labels later are labelled above them.
    time : float or None
        The last scan's time in seconds (None before the first).
    """

    def __init__(self, transition_model, measurement_model, birth, prob_detect, prob_survival,
                 clutter_intensity, gate_threshold=None, reducer=None,
                 extraction_threshold=0.5, unscented=None):
        super().__init__(transition_model, measurement_model, birth, prob_detect,
                         prob_survival, clutter_intensity, gate_threshold, reducer, unscented)
        self.extraction_threshold = extraction_threshold

    extraction_threshold = _validate.Setting(_validate.non_negative)

    @property
    def expected_number(self):
        """The expected number of targets: the sum of the intensity's weights."""
        return float(np.exp(self.mixture.log_weights).sum())

    def _update(self, predicted, detections):
        """:func:`fasttrack.core.phd.update` of the tracker's own intensity (made from
        checked births by the kernels: its arrays are not checked again)."""
        model = self.measurement_model
        prob_detect = self.prob_detect
        threshold = np.inf if self.gate_threshold is None else self.gate_threshold
        pairs = _phd.gated_pairs(model.spec, predicted.means, predicted.covars,
                                 predicted.log_weights, _phd.detections_of(model, detections),
                                 _phd.log_probability(prob_detect, "prob_detect"),
                                 threshold, self.unscented)
        means, covars, log_weights, components, _ = _phd.posterior(
            pairs, prob_detect,
            math.log(self.clutter_intensity))
        return means, covars, log_weights, components

    def _extract(self):
        """The components heavier than ``extraction_threshold``."""
        if self.extraction_threshold == 0:
            return np.arange(len(self.mixture))
        return self.mixture.log_weights > np.log(self.extraction_threshold)


class CPHDTracker(_IntensityTracker):
    """The GM-CPHD filter, scan by scan: as :class:`PHDTracker`, with a distribution of the
    number of targets besides the intensity (:mod:`fasttrack.core.cphd`), Poisson clutter,
    and as estimates the most probable number of targets' heaviest components.

    The settings may be changed between scans, as :class:`PHDTracker`'s.

    Parameters
    ----------
    transition_model : TransitionModel
        Linear.
    measurement_model : LinearGaussian, CartesianToBearingRange or Cartesian2DToBearing
    birth : GaussianMixture
        The intensity born each scan; the number born is Poisson, of mean its weights' sum.
    prob_detect, prob_survival : float
        P_D and P_S, in [0, 1].
    clutter_intensity : float
        Expected clutter detections per unit volume of measurement space, > 0.
    clutter_rate : float
        Expected clutter detections a scan, > 0 (``clutter_intensity`` times the volume
        observed).
    max_targets : int
        N: the largest number of targets represented, at most 10,000 (default 100); the
        predicted probability above N is dropped.
    gate_threshold : float, optional
        As :class:`PHDTracker`'s.
    reducer : ~fasttrack.mixturereducer.GaussianMixtureReducer, optional
        As :class:`PHDTracker`'s.
    unscented : (alpha, beta, kappa), optional
        As :class:`PHDTracker`'s.
    Attributes
    ----------
    mixture : GaussianMixture
        The current intensity (assigned as :class:`PHDTracker`'s).
    log_cardinality : (N + 1,) ndarray
        Log probabilities of 0..N targets (at first, no target); read-only, checked when
        assigned.
    time : float or None
        The last scan's time in seconds (None before the first).
    """

    def __init__(self, transition_model, measurement_model, birth, prob_detect, prob_survival,
                 clutter_intensity, clutter_rate, max_targets=100, gate_threshold=None,
                 reducer=None, unscented=None):
        super().__init__(transition_model, measurement_model, birth, prob_detect,
                         prob_survival, clutter_intensity, gate_threshold, reducer, unscented)
        self.clutter_rate = clutter_rate
        most = _validate.count(max_targets, "max_targets", maximum=_cphd.MAX_TARGETS)
        none = np.full(most + 1, -np.inf)
        none[0] = 0.0
        self.log_cardinality = none

    clutter_rate = _validate.Setting(_validate.positive)
    log_cardinality = _validate.Setting("_cardinality")

    @staticmethod
    def _cardinality(value, name):
        """A read-only copy of a valid log cardinality distribution ``value`` (of at most
        :data:`~fasttrack.core.cphd.MAX_TARGETS` targets)."""
        values = _cphd.cardinality(value, name).copy()
        values.flags.writeable = False
        return values

    @property
    def expected_number(self):
        """The expected number of targets: the cardinality distribution's mean."""
        return float(np.exp(self.log_cardinality) @ np.arange(self.log_cardinality.size))

    @property
    def most_probable_number(self):
        """The most probable number of targets (the cardinality's mode)."""
        return int(np.argmax(self.log_cardinality))

    def _update(self, predicted, detections):
        birth_mean = float(np.exp(self.birth.log_weights).sum())
        log_cardinality = _cphd.predict_cardinality(self.log_cardinality, self.prob_survival,
                                                    birth_mean)
        means, covars, log_weights, components, _, self.log_cardinality = _cphd.update(
            self.measurement_model, predicted.means, predicted.covars, predicted.log_weights,
            log_cardinality, detections, self.prob_detect, self.clutter_rate,
            self.clutter_intensity, self.gate_threshold, self.unscented)
        return means, covars, log_weights, components

    def _extract(self):
        """The :attr:`most_probable_number` heaviest components (all, if fewer)."""
        order = np.argsort(-self.mixture.log_weights, kind="stable")
        return np.sort(order[:self.most_probable_number])
