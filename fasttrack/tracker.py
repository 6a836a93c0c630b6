"""A multi-target tracker on arrays: every track set is (K, d) means and (K, d, d)
covariances, advanced a scan at a time by batched predict, gate, assignment and update."""
import numpy as np

from . import _validate
from ._validate import Setting
from .association import gate, global_nearest_neighbour, nearest_neighbour
from .batch import ModelSetSettings, ModelSettings
from .core import imm as _imm
from .core import jpda as _jpda
from .core import kalman as _kalman
from .models.measurement import LinearGaussian
from .types.mixture import IMMTrackSet, TrackSet

_ASSOCIATORS = {"gnn": global_nearest_neighbour, "nn": nearest_neighbour}

#: The largest measurement value an IMMTracker takes: mixing its models squares the
#: differences of their states, which must stay finite.
LARGEST_IMM_MEASUREMENT = 1e150


class MultiTargetTracker(ModelSettings):
    """Track an unknown number of targets through scans of detections with clutter and
    missed detections (Stone Soup's ``MultiTargetTracker`` with a
    ``MultiMeasurementInitiator``, ``UpdateTimeStepsDeleter``, optionally
    ``CovarianceBasedDeleter``, and a ``DistanceHypothesiser(Mahalanobis)`` association).

    Each scan: the confirmed tracks are predicted, gated and assigned the detections
    (global nearest neighbour per cluster, or greedy nearest neighbour), updated, and deleted
    after ``delete_after_misses`` scans without a detection or when the trace of their
    covariance exceeds ``max_covar_trace``; then the tentative tracks do the same with the
    detections left, and become confirmed after ``min_points`` detections (M-of-N with
    ``confirm_within``: within their first N scans, else they are deleted), or are deleted
    after ``tentative_misses`` scans without one; every detection still left starts a
    tentative track.

    The settings (the parameters but the models and the prior) may be changed between
    scans; each assignment is checked as the constructor checks it.

    Parameters
    ----------
    transition_model : linear-Gaussian TransitionModel
    measurement_model : LinearGaussian
    prior_mean : (d,) array_like
        A new track's state in the components the sensor does not measure (the measured
        ones come from the detection, as Stone Soup's ``SimpleMeasurementInitiator``).
    prior_covar : (d, d) array_like
        Its covariance there (the measured block comes from the sensor noise), symmetric
        positive semi-definite.
    missed_distance : float
        Mahalanobis distance of the gate and of the missed-detection option, > 0 and
        below 1e154 (its square is the gate's threshold).
    min_points : int
        Detections that confirm a tentative track (the first included), >= 1: M.
    confirm_within : int, optional
        N of M-of-N confirmation: the scans (the first included) in which a tentative track
        must reach ``min_points`` detections, >= ``min_points``; None (the default, as
        Stone Soup's ``MultiMeasurementInitiator``) for no limit.
    delete_after_misses : int
        Scans without a detection that delete a confirmed track, >= 1.
    tentative_misses : int
        The same for a tentative track.
    max_covar_trace : float, optional
        Delete a confirmed track whose covariance trace exceeds it (> 0); None (or inf)
        for no limit.
    association : {'gnn', 'nn'}
        Global or greedy nearest neighbour.    """

    def __init__(self, transition_model, measurement_model, prior_mean, prior_covar,
                 missed_distance=3.0, min_points=2, delete_after_misses=3, tentative_misses=1,
                 max_covar_trace=None, association="gnn", confirm_within=None):
        self.transition_model = transition_model
        self.measurement_model = measurement_model
        d = transition_model.ndim_state
        mean = _validate.finite_array(prior_mean, "prior_mean")
        if mean.ndim == 2 and mean.shape[1] == 1:  # a (d, 1) column
            mean = mean[:, 0]
        if mean.ndim != 1:
            raise ValueError(f"prior_mean must be a (d,) vector, got shape {mean.shape}")
        if mean.shape != (d,):
            raise ValueError(f"prior_mean must have {d} components, got {mean.size}")
        covar = _validate.psd_covariance(prior_covar, "prior_covar", d)
        self._prior = mean.copy(), covar.copy()  # (the caller's arrays stay theirs)
        self.missed_distance = missed_distance
        self.min_points = min_points
        self.delete_after_misses = delete_after_misses
        self.tentative_misses = tentative_misses
        self.confirm_within = confirm_within
        self.max_covar_trace = max_covar_trace
        if not isinstance(association, str) or association not in _ASSOCIATORS:
            raise ValueError(f"association must be one of {sorted(_ASSOCIATORS)}, "
                             f"got {association!r}")
        self._associate = _ASSOCIATORS[association]
        self.confirmed = self._no_tracks()
        self.tentative = self._no_tracks()
        self.time = None
        self._next_id = 0

    # Settings, checked when assigned (here or later).
    missed_distance = Setting("_gate_distance")
    min_points = Setting("_confirming_points")
    confirm_within = Setting("_confirmation_scans")
    delete_after_misses = Setting(_validate.count)
    tentative_misses = Setting(_validate.count)
    max_covar_trace = Setting("_trace_limit")
    confirmed = Setting("_track_set")
    tentative = Setting("_track_set")
    time = Setting(_validate.optional(_validate.real))

    def _checked_measurement(self, model, name):
        if not isinstance(model, LinearGaussian):
            raise TypeError(f"{name} must be a LinearGaussian (tracks start from its inverse), "
                            f"got {type(model).__name__}")
        return super()._checked_measurement(model, name)

    @staticmethod
    def _gate_distance(value, name):
        value = _validate.positive(value, name)
        if not 1e-154 <= value < 1e154:
            raise ValueError(f"{name} must lie in [1e-154, 1e154) (its square, the gate "
                             f"threshold, a finite number > 0), got {value}")
        return value

    def _confirming_points(self, value, name):
        value = _validate.count(value, name)
        window = self.__dict__.get("confirm_within")
        if window is not None and value > window:
            raise ValueError(f"{name} must be <= confirm_within ({window}), got {value}")
        return value

    def _confirmation_scans(self, value, name):
        return None if value is None else _validate.count(value, name,
                                                          minimum=self.min_points)

    @staticmethod
    def _trace_limit(value, name):
        if value is None:
            return None
        value = float(_validate.float_array(value, name, 0))
        if not value > 0:
            raise ValueError(f"{name} must be > 0, got {value}")
        return value

    #: The kind of its track sets.
    _tracks = TrackSet

    def _no_tracks(self):
        """An empty track set of the tracker's kind."""
        return TrackSet.empty(self.transition_model.ndim_state)

    def _track_set(self, value, name):
        """``value``, checked to be a track set of the tracker's kind and dimension."""
        kind = self._tracks
        if not isinstance(value, kind):
            raise TypeError(f"{name} must be of type {kind.__name__}, got "
                            f"{type(value).__name__}")
        value.check(name, self.transition_model.ndim_state, self._models())
        return value

    def _models(self):
        """The number of models a track of this tracker holds (None: one filter)."""
        return None

    def _start(self):
        """:meth:`_initiation` of the current sensor, remembered until its spec changes
        (a new sensor, or a parameter assigned)."""
        spec = self.measurement_model.spec
        if self.__dict__.get("_started_from") is not spec:
            self._started = self._initiation(self.measurement_model, *self._prior)
            self._started_from = spec
        return self._started

    @staticmethod
    def _initiation(model, mean, covar):
        """The affine map from a detection to a new track: ``x = x0 + G z``, covariance
        ``P0 = G R G^T + prior_covar`` with the measured rows and columns of the prior
        zeroed."""
        gain = np.linalg.pinv(model.matrix())
        mapped = list(model.mapping)
        x0, p0 = mean.copy(), covar.copy()
        x0[mapped] = 0.0
        p0[mapped, :] = 0.0
        p0[:, mapped] = 0.0
        return x0, gain, gain @ model.covar() @ gain.T + p0

    def _advance(self, tracks, detections, dt, available):
        """Predict, associate with the ``available`` detections and update ``tracks``;
        returns the tracks and the mask of the detections they took."""
        taken = np.zeros(detections.shape[0], dtype=np.bool_)
        if len(tracks) == 0:
            return tracks, taken
        means, covars, z_hats, innovation = _kalman.stack_predict(
            self.transition_model, self.measurement_model, np.full(len(tracks), dt),
            tracks.means, tracks.covars)
        pool = np.flatnonzero(available)
        result = gate(z_hats, innovation, detections[pool], self.missed_distance ** 2)
        chosen = self._associate(result, self.missed_distance)
        hit = chosen >= 0
        if hit.any():
            means[hit], covars[hit] = _kalman.stack_update(
                self.measurement_model, means[hit], covars[hit], detections[pool[chosen[hit]]])
            taken[pool[chosen[hit]]] = True
        return TrackSet(tracks.ids, means, covars, tracks.updates + hit,
                        np.where(hit, 0, tracks.misses + 1), tracks.ages + 1), taken

    def _start_tracks(self, detections):
        x0, gain, p0 = self._start()
        n = detections.shape[0]
        ids = np.arange(self._next_id, self._next_id + n)
        self._next_id += n
        return TrackSet(ids, x0 + detections @ gain.T, np.broadcast_to(p0, (n,) + p0.shape).copy(),
                        np.ones(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
                        np.zeros(n, dtype=np.int64))

    def step(self, detections, time):
        """Process one scan.

        Parameters
        ----------
        detections : (M, m) array_like
            The scan's measurements, finite (an empty list for none).
        time : float
            The scan's time in seconds, finite, after the previous scan's.

        Returns
        -------
        TrackSet
            The confirmed tracks after the scan (a copy: the tracker's own is
            ``confirmed``).
        """
        detections = self._scan(detections)
        time, dt = _validate.scan_time(time, self.time)
        free = np.ones(detections.shape[0], dtype=np.bool_)
        confirmed, taken = self._advance(self.confirmed, detections, dt, free)
        free &= ~taken
        doomed = confirmed.misses >= self.delete_after_misses
        if self.max_covar_trace is not None:
            doomed |= np.trace(confirmed.covars, axis1=1, axis2=2) > self.max_covar_trace
        confirmed = confirmed.take(~doomed)
        tentative, taken = self._advance(self.tentative, detections, dt, free)
        free &= ~taken
        sure = tentative.updates >= self.min_points
        confirmed = TrackSet.concatenate(confirmed, tentative.take(sure))
        tentative = tentative.take(~sure)
        keep = tentative.misses < self.tentative_misses
        if self.confirm_within is not None:  # M of N: out of time to be confirmed
            keep &= tentative.ages < self.confirm_within - 1
        tentative = TrackSet.concatenate(tentative.take(keep),
                                         self._start_tracks(detections[free]))
        # (the scan's own arrays and checked time: stored without the settings' checks)
        self.__dict__.update(confirmed=confirmed, tentative=tentative, time=time)
        return confirmed.copy()

    def _scan(self, detections):
        """``detections`` as a finite (M, m) array."""
        m = self.measurement_model.ndim_meas
        scan = _validate.finite_array(detections, "detections")
        if scan.shape == (0,):  # (an empty list)
            return scan.reshape(0, m)
        if scan.ndim != 2 or scan.shape[1] != m:
            raise ValueError(f"detections must have shape (M, {m}) (the sensor measures {m} "
                             f"components), got shape {scan.shape}")
        return scan

    def run(self, scans, time_interval=1.0):
        """Process scans at ``time_interval`` seconds; the confirmed tracks after each.

        Parameters
        ----------
        scans : iterable of (M_t, m) array_like
            E.g. ``MultiTargetScenario.detections``.
        time_interval : float
            Seconds between scans.

        Returns
        -------
        list of TrackSet
        """
        time_interval = _validate.positive(time_interval, "time_interval")
        start = 0.0 if self.time is None else self.time + time_interval
        return [self.step(scan, start + t * time_interval)
                for t, scan in enumerate(_validate.iterator(scans, "scans"))]


class IMMTracker(MultiTargetTracker, ModelSetSettings):
    """:class:`MultiTargetTracker` whose tracks are interacting multiple model filters: each
    track a bank of M Kalman filters (one a transition model) with its mode probabilities.

    Each scan, every track's models are mixed and predicted (:func:`fasttrack.core.imm.
    predictions`); the track's predicted measurement for gating and assignment is the
    moment match of its models' (mean ``sum_j c_j z_j``, covariance ``sum_j c_j (S_j +
    spread)`` with ``c_j`` the predicted mode probabilities), so the gate and the
    Mahalanobis cost are those of the mode-combined Gaussian; a track given a detection
    updates each model with it and reweighs the models by their own likelihoods, a track
    given none keeps its predictions and predicted mode probabilities. Confirmation and
    deletion are :class:`MultiTargetTracker`'s. With one model it is that tracker, except
    that detections must lie within +-:data:`LARGEST_IMM_MEASUREMENT` (1e150).

    Parameters
    ----------
    transition_models : sequence of TransitionModel
        M models of the state's dimension, linear or built from a function (linearised as
        :class:`~fasttrack.BatchIMMFilter` describes; a model of fewer components
        embedded).
    measurement_model : LinearGaussian
    transition_matrix : (M, M) array_like
        ``transition_matrix[i, j]``: the probability of switching from model i to model j
        in one scan; rows sum to one.
    prior_mean : (d,) array_like
        As :class:`MultiTargetTracker`'s (every model of a new track starts there).
    prior_covar : (d, d) array_like
        As :class:`MultiTargetTracker`'s.
    mode_probs : (M,) array_like, optional
        A new track's mode probabilities (default: equal).
    association : {'gnn', 'nn', 'jpda'}
        Global or greedy nearest neighbour on the mode-combined predicted measurements, or
        IMM-JPDA: every track updated with every detection of its gate, weighed by the
        exact JPDA marginals of its mode-mixture likelihoods, each model by its own
        innovations (:func:`fasttrack.core.imm.jpda_updates`); a detection in any
        track's gate starts no track, and a track misses when its gate is empty.
    prob_detect : float
        With 'jpda': the probability of detection, in (0, 1].
    clutter_density : float, optional
        With 'jpda' (required): the clutter's expected number per unit measurement volume
        per scan, > 0.
    max_nodes : int
        With 'jpda': the most nodes of a cluster's EHM net (see
        :func:`fasttrack.core.jpda.jpda_marginals`); a larger cluster is an error.
    **options : keyword arguments
        :class:`MultiTargetTracker`'s other parameters (``missed_distance``: the gate,
        ``min_points``, ``delete_after_misses``, ...).

    Attributes
    ----------
    confirmed, tentative : IMMTrackSet
    """

    def __init__(self, transition_models, measurement_model, transition_matrix, prior_mean,
                 prior_covar, mode_probs=None, association="gnn", prob_detect=0.9,
                 clutter_density=None, max_nodes=_jpda.MAX_NODES, **options):
        self.measurement_model = measurement_model
        self.transition_models = transition_models
        models = self.transition_models
        if not isinstance(association, str) or association not in ("gnn", "jpda", "nn"):
            raise ValueError(f"association must be one of ['gnn', 'jpda', 'nn'], got "
                             f"{association!r}")
        self.jpda = association == "jpda"
        super().__init__(models[0], measurement_model, prior_mean, prior_covar,
                         association="gnn" if self.jpda else association, **options)
        self.prob_detect, self.clutter_density = prob_detect, clutter_density  # (read by JPDA)
        self.max_nodes = max_nodes
        self.transition_matrix = transition_matrix
        self.mode_probs = (np.full(len(models), 1.0 / len(models)) if mode_probs is None
                           else mode_probs)

    _nonlinear_transitions = True
    prob_detect = Setting("_detection_probability")
    clutter_density = Setting("_clutter")
    max_nodes = Setting(_validate.count)
    mode_probs = Setting("_initial_modes")
    _tracks = IMMTrackSet

    def _clutter(self, value, name):
        if value is None and self.jpda:
            raise ValueError(f"association='jpda' needs {name} (> 0)")
        return _validate.optional(_validate.positive)(value, name)

    def _detection_probability(self, value, name):
        value = _validate.probability(value, name)
        if self.jpda and not value > 0:
            raise ValueError(f"{name} must be > 0 for JPDA, got {value}")
        return value

    def _initial_modes(self, value, name):
        return _imm.mode_probabilities(value, (len(self.transition_models),), name).copy()

    @property
    def prob_gate(self):
        """With 'jpda': the probability that a detection of a track lies in its gate (of
        ``missed_distance``)."""
        from scipy.special import gammainc  # chi2.cdf, without scipy.stats' import
        return float(gammainc(self.measurement_model.ndim_meas / 2,
                              self.missed_distance ** 2 / 2))

    def _scan(self, detections):
        scan = super()._scan(detections)
        if scan.size and not np.abs(scan).max() < LARGEST_IMM_MEASUREMENT:
            raise ValueError(f"detections must lie within +-{LARGEST_IMM_MEASUREMENT:.0e} (the "
                             f"models' mixing squares differences of states), got "
                             f"{np.abs(scan).max():.3g}")
        return scan

    def _no_tracks(self):
        return IMMTrackSet.empty(self.transition_model.ndim_state, self._models())

    def _models(self):
        return len(self.transition_models)

    def _advance(self, tracks, detections, dt, available):
        taken = np.zeros(detections.shape[0], dtype=np.bool_)
        if len(tracks) == 0:
            return tracks, taken
        models, sensor = self.transition_models, self.measurement_model
        means, covars, predicted, z_hats, innovations = _imm.predictions(
            models, sensor, self.transition_matrix, tracks.model_means, tracks.model_covars,
            tracks.mode_probs, np.full(len(tracks), dt), has=self._has)
        pool = np.flatnonzero(available)
        result = gate(*_imm.combine(z_hats, innovations, predicted), detections[pool],
                      self.missed_distance ** 2)
        if self.jpda:
            return self._jpda_advance(tracks, detections[pool], pool, result, means, covars,
                                      predicted, z_hats, innovations, taken)
        chosen = self._associate(result, self.missed_distance)
        hit = chosen >= 0
        probs = predicted
        if hit.any():
            means[hit], covars[hit], probs[hit] = _imm.updates(
                models, sensor, means[hit], covars[hit], predicted[hit], z_hats[hit],
                innovations[hit], detections[pool[chosen[hit]]])
            taken[pool[chosen[hit]]] = True
        return IMMTrackSet(tracks.ids, *_imm.combine(means, covars, probs),
                           tracks.updates + hit, np.where(hit, 0, tracks.misses + 1),
                           tracks.ages + 1, means, covars, probs), taken

    def _jpda_advance(self, tracks, detections, pool, result, means, covars, predicted,
                      z_hats, innovations, taken):
        """:meth:`_advance`'s IMM-JPDA update of every track with its gate's detections."""
        means, covars, probs, _ = _imm.jpda_updates(
            self.measurement_model, means, covars, predicted, z_hats, innovations, detections,
            result, self.prob_detect, self.prob_gate, self.clutter_density, self.max_nodes)
        hit = np.diff(result.starts) > 0
        taken[pool[result.detections]] = True
        return IMMTrackSet(tracks.ids, *_imm.combine(means, covars, probs),
                           tracks.updates + hit, np.where(hit, 0, tracks.misses + 1),
                           tracks.ages + 1, means, covars, probs), taken

    def _start_tracks(self, detections):
        started = super()._start_tracks(detections)
        models = len(self.transition_models)
        return IMMTrackSet(*started._fields(),
                           np.repeat(started.means[:, None], models, axis=1),
                           np.repeat(started.covars[:, None], models, axis=1),
                           np.tile(self.mode_probs, (len(started), 1)))
