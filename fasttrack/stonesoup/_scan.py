"""The vectorised scan behind the drop-ins of ``stonesoup.hypothesiser``,
``stonesoup.gater`` and ``stonesoup.dataassociator``.

A scan covers a drop-in hypothesiser (optionally wrapped in drop-in ``DistanceGater``s with a
Mahalanobis measure) whose predictor is a drop-in ``KalmanPredictor`` /
``ExtendedKalmanPredictor`` and whose updater is a drop-in ``KalmanUpdater`` /
``ExtendedKalmanUpdater``, on Stone Soup models fasttrack recognises (see
``_convert.fast_model``), with a ``Mahalanobis`` measure (or ``Euclidean`` for the distance
hypothesiser), every detection at the scan's timestamp and sharing one measurement model.
It stacks every track's state, predicts all of them in one
:func:`~fasttrack.core.kalman.stack_predict` call, gates the detections
(:func:`~fasttrack.core.gating.gate`), solves the association on arrays and builds
Stone Soup's objects only for what is returned. Anything else goes through Stone Soup's own
code.

Differences from Stone Soup, at the level of rounding: distances come from a Cholesky
factor rather than a pseudo-inverse, probabilities from the linear-domain exact marginals
rather than Stone Soup's log-domain sums, so values agree to about 1e-12 relative; exact ties
(equal distances or equal total costs) may be broken differently.
"""
import numpy as np
from scipy.special import gamma
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.detection import MissedDetection
from stonesoup.types.hypothesis import SingleDistanceHypothesis, SingleProbabilityHypothesis
from stonesoup.types.multihypothesis import MultipleHypothesis
from stonesoup.types.numeric import Probability
from stonesoup.types.prediction import (GaussianMeasurementPrediction, GaussianStatePrediction,
                                       Prediction)
from stonesoup.types.state import GaussianState, State, StateMutableSequence
from stonesoup.types.update import GaussianStateUpdate

from ..association import Gate, global_nearest_neighbour, nearest_neighbour
from ..core import kalman as ft_kalman
from ..core.gating import default_axes, gate_arrays
from ..core.jpda import gate_marginals
from ..core.mixture import segment_logsumexp
from ..models import LinearGaussian
from . import predictor as _predictor
from ._convert import floats, typed_measurement
from ._fallback import keywords
from ._objects import builder, from_state
from ._recipe import recipe_of


# -- the scan of a hypothesiser the vectorised path computes (see ``_recipe``) -------------

#: Priors whose prediction is a plain ``GaussianStatePrediction`` (built directly; a
#: weighted or tagged prior's through ``Prediction.from_state``, which carries them on).
_PLAIN_GAUSSIAN = (GaussianState, GaussianStatePrediction, GaussianStateUpdate)

_gaussian_prediction = builder(GaussianStatePrediction)
_measurement_prediction = builder(GaussianMeasurementPrediction)
_missed_detection = builder(MissedDetection)
_distance_hypothesis = builder(SingleDistanceHypothesis)
_probability_hypothesis = builder(SingleProbabilityHypothesis)
_multiple_hypothesis = builder(MultipleHypothesis)


class _NotFast(Exception):
    """Raised inside the vectorised path when the inputs need Stone Soup's code; its text
    is the reason."""


def _scan(hypothesiser, tracks, detections, timestamp, kwargs, kind=None, single=False):
    """The vectorised :class:`_Scan`, or the reason Stone Soup's code must run."""
    recipe = recipe_of(hypothesiser)
    if isinstance(recipe, str):
        return recipe
    if reason := keywords(kwargs, recipe.predictor, recipe.updater):  # they get them
        return reason
    if kind is not None and recipe.kind != kind:
        return f"{recipe.kind} hypotheses for a {kind} associator"
    try:
        return _Scan(recipe, tracks, detections, timestamp, single)
    except _NotFast as refusal:
        return str(refusal)


def _prior(track):
    """The state a predictor predicts from (a track's last state)."""
    if isinstance(track, StateMutableSequence) and not isinstance(track, State):
        return track.state
    return track


def _csr_filter(starts, keep):
    """Track offsets of the candidates kept (``keep`` (n,) bool) of a CSR ``starts``."""
    owners = np.repeat(np.arange(starts.size - 1), np.diff(starts))
    counts = np.bincount(owners[keep], minlength=starts.size - 1)
    out = np.zeros(starts.size, dtype=np.int64)
    np.cumsum(counts, out=out[1:])
    return out


class _Scan:
    """One scan of tracks and detections through fasttrack's kernels.

    Holds the predicted states (K, d), (K, d, d), measurements (K, m) and innovation
    covariances (K, m, m), the detections' ``measurements`` (M, m), and the candidate
    (track, detection) pairs that the hypothesiser keeps, in CSR form (``starts`` (K + 1,),
    ``candidates`` (n,) detection indices, ascending per track), with their distances
    (distance hypothesisers) or log weights (PDA). Stone Soup objects are built on
    request.

    ``single`` (one track, the hypothesiser's own ``hypothesise``) takes the prediction and
    measurement prediction from the predictor and updater, memoised as Stone Soup's are;
    otherwise every track is predicted in one batch call.

    Raises
    ------
    _NotFast
        If the inputs are outside the vectorised path.
    """

    def __init__(self, recipe, tracks, detections, timestamp, single):
        self.recipe = recipe
        self.tracks, self.detections = list(tracks), list(detections)
        for kind, given in (("track", self.tracks), ("detection", self.detections)):
            if len(set(map(id, given))) < len(given):
                raise _NotFast(f"a {kind} given twice")
        self.timestamp = timestamp
        if timestamp is None or any(d.timestamp != timestamp for d in self.detections):
            raise _NotFast("detections at other times than the scan's")
        self._model, self._fast = self._measurement_model()
        self._predictions = [None] * len(self.tracks)
        self._measurement_predictions = [None] * len(self.tracks)
        kinds = set(map(type, self.tracks))
        if kinds.issubset(_predictor._GAUSSIAN_STATES):  # states: their own priors
            self.priors = self.tracks
        else:
            try:
                self.priors = [_prior(track) for track in self.tracks]
            except (AttributeError, IndexError):
                raise _NotFast("a track without a last state") from None
            kinds = set(map(type, self.priors))
        self._stamps = [prior.timestamp for prior in self.priors]
        if not kinds.issubset(_predictor._GAUSSIAN_STATES) or None in self._stamps:
            raise _NotFast("a track whose last state is not a timed Gaussian state")
        try:
            if single:
                self._predict_one()
            else:
                self._predict_all()
            self.measurements = self._detection_array()
            self._candidates()
        except (ValueError, TypeError) as error:  # a kernel's, or input Stone Soup handles
            raise _NotFast(f"refused by fasttrack ({error})") from None

    # -- arrays ------------------------------------------------------------------------------

    def _measurement_model(self):
        """The one model of every detection (its own, else the updater's) and its fasttrack
        model; the updater's for no detections. Sets ``own_models``, the detections'
        distinct own models (None for those without)."""
        updater = self.recipe.updater
        self.own_models = tuple({id(model): model for model in
                                 [detection.measurement_model
                                  for detection in self.detections]}.values())
        models = {id(model): model for model in
                  (updater.measurement_model if own is None else own
                   for own in self.own_models)}
        if len(models) > 1:
            raise _NotFast("detections of several measurement models")
        model = models.popitem()[1] if models else updater.measurement_model
        fast = "no measurement model" if model is None else updater._fast(model)
        if isinstance(fast, str):
            raise _NotFast(fast)
        return model, fast

    def _predict_one(self):
        (track,) = self.tracks
        prediction = self.recipe.predictor.predict(track, timestamp=self.timestamp)
        self._predictions[0] = prediction
        self.means = floats(prediction.state_vector).reshape(1, -1)
        self.covars = floats(prediction.covar)[None]
        m = self._fast.ndim_meas
        if not self.detections:
            self.z_hats, self.innovation_covars = np.zeros((1, m)), np.zeros((1, m, m))
            return
        measurement_prediction = self.recipe.updater.predict_measurement(prediction,
                                                                         self._model)
        self._measurement_predictions[0] = measurement_prediction
        self.z_hats = floats(measurement_prediction.state_vector).reshape(1, m)
        self.innovation_covars = floats(measurement_prediction.covar).reshape(1, m, m)

    def _predict_all(self):
        transition, d = self.recipe.transition, self.recipe.transition.ndim_state
        k, m = len(self.priors), self._fast.ndim_meas
        if k == 0:
            self.means, self.covars = np.zeros((0, d)), np.zeros((0, d, d))
            self.z_hats, self.innovation_covars = np.zeros((0, m)), np.zeros((0, m, m))
            return
        means = np.array([prior.state_vector for prior in self.priors], dtype=np.float64)
        covars = np.array([prior.covar for prior in self.priors], dtype=np.float64)
        if means.shape != (k, d, 1) or covars.shape != (k, d, d) \
                or not (np.isfinite(means).all() and np.isfinite(covars).all()):
            raise _NotFast("ragged or non-finite track states")  # Stone Soup's arithmetic
        means = means.reshape(k, d)
        seconds = {stamp: (self.timestamp - stamp).total_seconds()
                   for stamp in set(self._stamps)}
        intervals = np.array([seconds[stamp] for stamp in self._stamps])
        self.means, self.covars, self.z_hats, self.innovation_covars = \
            ft_kalman.stack_predict(transition, self._fast, intervals, means, covars,
                                    "forward", by_interval=True)

    def _detection_array(self):
        m = self._fast.ndim_meas
        if not self.detections:
            return np.zeros((0, m))
        z = np.array([d.state_vector for d in self.detections], dtype=np.float64)
        if z.shape != (len(self.detections), m, 1):
            raise _NotFast("detections of another shape than the model's")
        if not np.isfinite(z).all():
            raise _NotFast("a detection that is not finite")
        return z.reshape(-1, m)

    def _gate(self, threshold, covars, angles):
        """Candidates with squared distance below ``threshold`` (+inf: every pair), of
        the scan's own predictions (symmetric ``covars``) and finite detections."""
        k, m = self.z_hats.shape
        if self.measurements.shape[0] == 0 or k == 0 or not threshold > 0:
            return Gate(np.zeros(k + 1, dtype=np.int64), np.zeros(0, dtype=np.int64),
                        np.zeros(0), np.zeros(0), self.measurements.shape[0])
        if not (np.isfinite(self.z_hats).all() and np.isfinite(covars).all()):
            raise _NotFast("a prediction that is not finite")
        angles = np.zeros(m, dtype=np.bool_) if angles is None else angles
        axes = default_axes(angles) if np.isfinite(threshold) else np.empty(0, dtype=np.int64)
        return gate_arrays(self.z_hats, covars, self.measurements, threshold, angles, axes)

    def _candidates(self):
        """The hypothesiser's candidates and their distances or log weights."""
        recipe, base = self.recipe, self.recipe.base
        angles = self._fast.spec.angles
        if recipe.kind == "distance" and recipe.measure == "euclidean":
            identity = np.broadcast_to(np.eye(self.z_hats.shape[1]),
                                       self.innovation_covars.shape)
            missed = float(base.missed_distance)
            threshold = np.inf if base.include_all else missed * missed  # (inf if it overflows)
            pairs = self._gate(np.nextafter(threshold, np.inf), np.ascontiguousarray(identity),
                               None)
            distances = np.sqrt(pairs.distances2)
            keep = np.ones(distances.size, dtype=np.bool_) if base.include_all \
                else distances < missed
            self._keep(pairs, keep, distances=distances)
            self._log_likelihoods = None  # of the Euclidean gate's identity covariances
            return
        gates = np.array(recipe.gates)
        if recipe.kind == "distance":
            missed = float(base.missed_distance)
            threshold = np.inf if base.include_all else missed * missed  # (inf if it overflows)
            threshold = min([threshold, *(g * g for g in recipe.gates)])
            pairs = self._gate(np.nextafter(threshold, np.inf), self.innovation_covars,
                               angles)
            distances = np.sqrt(pairs.distances2)
            keep = np.ones(distances.size, dtype=np.bool_) if base.include_all \
                else distances < missed
            for g in gates:
                keep &= distances < g
            self._keep(pairs, keep, distances=distances)
            return
        self._pda_candidates(gates, angles)

    def _pda_candidates(self, gates, angles):
        base = self.recipe.base
        m = self.z_hats.shape[1]
        gate_threshold = float(base._gate_threshold(base.prob_gate, m))
        density = base.clutter_spatial_density
        threshold = np.inf if base.include_all else gate_threshold
        if density is not None and not base.normalise and gates.size:  # (no count, no
            threshold = min(threshold, *(g * g for g in gates.tolist()))  # normaliser: no more)
        pairs = self._gate(np.nextafter(threshold, np.inf), self.innovation_covars, angles)
        distances2 = pairs.distances2
        inside = distances2 <= gate_threshold
        in_base = np.ones(distances2.size, dtype=np.bool_) if base.include_all else inside
        log_weights = pairs.log_likelihoods + Probability._log(base.prob_detect)
        if density is not None:
            log_weights = log_weights - Probability._log(density)
        else:  # Stone Soup's estimate: the gate volume over the detections inside it
            owners = np.repeat(np.arange(pairs.n_tracks), np.diff(pairs.starts))
            validated = np.bincount(owners[inside], minlength=pairs.n_tracks)
            c_z = np.pi**(m / 2) / gamma(m / 2 + 1)
            with np.errstate(divide="ignore", invalid="ignore"):
                volumes = c_z * gate_threshold**(m / 2) * np.sqrt(
                    np.linalg.det(self.innovation_covars))
                log_weights = log_weights + np.log(volumes / validated)[owners]
        missed = Probability(1 - base.prob_detect * base.prob_gate)
        self.missed_log_weight = float(missed.log_value)
        keep = in_base.copy()
        distances = np.sqrt(distances2)
        for g in gates:
            keep &= distances < g
        self._base_normaliser = None
        if base.normalise:  # over the hypothesiser's hypotheses: a gater does not renormalise
            self._base_normaliser = np.logaddexp(self.missed_log_weight, segment_logsumexp(
                log_weights[in_base], _csr_filter(pairs.starts, in_base)))
        self._keep(pairs, keep, log_weights=log_weights)
        self._final_normaliser = None

    def _keep(self, pairs, keep, distances=None, log_weights=None):
        if keep.all():
            self.starts, self.candidates = pairs.starts, pairs.detections
            self.distances, self.log_weights = distances, log_weights
            self._log_likelihoods = pairs.log_likelihoods
            return
        self.starts = _csr_filter(pairs.starts, keep)
        self.candidates = np.ascontiguousarray(pairs.detections[keep])
        self.distances = None if distances is None else np.ascontiguousarray(distances[keep])
        self.log_weights = None if log_weights is None \
            else np.ascontiguousarray(log_weights[keep])
        self._log_likelihoods = pairs.log_likelihoods[keep]

    def carried_predictions(self):
        """The measurement predictions its hypotheses carry, as arrays: z_hats (K, m),
        innovation covariances (K, m, m) and cross covariances (K, d, m) (those of
        :meth:`measurement_prediction`); None unless the scan's model is linear."""
        if not isinstance(self._fast, LinearGaussian):
            return None
        return self.z_hats, self.innovation_covars, self.covars[:, :, self._fast.spec.mapping]

    def detections_as_read(self):
        """Whether the detections still hold the state vectors the scan read (Stone Soup's
        updaters read them when they update): bit for bit, else (another type) by value."""
        if b"".join([d.state_vector.tobytes() for d in self.detections]) \
                == self.measurements.tobytes():
            return True
        try:
            return np.array_equal(self._detection_array(), self.measurements)
        except _NotFast:
            return False

    def log_likelihoods(self, model):
        """The candidates' Gaussian log-likelihoods (n,) under the Stone Soup measurement
        ``model``, or None unless the scan gated with its innovation covariances."""
        return self._log_likelihoods if model is self._model else None

    # -- Stone Soup objects ------------------------------------------------------------------

    def prediction(self, k):
        """Track k's prediction, as the drop-in predictor makes it (a
        ``GaussianStatePrediction``, or the prediction type of a weighted or tagged prior,
        with its weight and tag)."""
        prediction = self._predictions[k]
        if prediction is None:
            mean, covar = self.predicted(k)
            prior, model = self.priors[k], self.recipe.predictor.transition_model
            values = dict(state_vector=mean, covar=covar, timestamp=self.timestamp,
                          transition_model=model, prior=prior)
            prediction = _gaussian_prediction(**values) if type(prior) in _PLAIN_GAUSSIAN \
                else from_state(Prediction, prior, **values)
            self._predictions[k] = prediction
        return prediction

    def predicted(self, k):
        """Track k's predicted mean (d, 1) ``StateVector`` and covariance (d, d)
        ``CovarianceMatrix``: views of the scan's own arrays."""
        return self.means[k, :, None].view(StateVector), self.covars[k].view(CovarianceMatrix)

    def measurement_prediction(self, k):
        """Track k's ``GaussianMeasurementPrediction`` with its cross covariance (as the
        drop-in updater's ``predict_measurement`` makes it)."""
        measurement_prediction = self._measurement_predictions[k]
        if measurement_prediction is None:
            fast = self._fast
            if isinstance(fast, LinearGaussian):  # H selects rows: P H^T selects columns
                z_hat = self.z_hats[k, :, None]
                covar = self.innovation_covars[k].view(CovarianceMatrix)
                cross = self.covars[k][:, fast.spec.mapping]
            else:
                x = self.means[k].reshape(-1, 1).copy()
                z_hat, covar, cross = ft_kalman.update(
                    fast, x, self.covars[k].copy(), np.zeros((fast.ndim_meas, 1)), "forward",
                    self.recipe.updater.use_joseph_cov, strict=False)[2:]
                covar = covar.view(CovarianceMatrix)
            measurement_prediction = _measurement_prediction(
                state_vector=typed_measurement(z_hat, fast), covar=covar,
                timestamp=self.timestamp, cross_covar=cross)
            self._measurement_predictions[k] = measurement_prediction
        return measurement_prediction

    def _measurement(self, j):
        """Detection j, or for -1 a new missed detection."""
        return _missed_detection(timestamp=self.timestamp) if j < 0 else self.detections[j]

    def _single(self, prediction, measurement, score, measurement_prediction=None):
        """A hypothesis of the recipe's kind: ``score`` its distance, or the log of its
        probability."""
        if self.recipe.kind == "distance":
            return _distance_hypothesis(prediction=prediction, measurement=measurement,
                                        distance=score,
                                        measurement_prediction=measurement_prediction)
        return _probability_hypothesis(prediction=prediction, measurement=measurement,
                                       probability=Probability(score, log_value=True),
                                       measurement_prediction=measurement_prediction)

    def hypotheses(self, k, normalised=False, predict=None):
        """Track k's ``MultipleHypothesis``, as the hypothesiser (and its gaters) return
        it; ``normalised``: its probabilities then normalised to total 1 (as ``PDA``
        does); ``predict``: a function of a hypothesis' measurement giving the hypothesis'
        prediction (by default all take the track's :meth:`prediction`)."""
        lo, hi = self.starts[k], self.starts[k + 1]
        if predict is None:
            def predict(_, prediction=self.prediction(k)):
                return prediction
        measurement_prediction = self.measurement_prediction(k) if hi > lo else None
        base = self.recipe.base
        distance = self.recipe.kind == "distance"
        scores = np.empty(hi - lo + 1)
        if distance:
            scores[0], scores[1:] = base.missed_distance, self.distances[lo:hi]
            order = np.argsort(scores, kind="stable").tolist()
        else:
            scores[0], scores[1:] = self.missed_log_weight, self.log_weights[lo:hi]
            if normalised:
                scores = scores - self.final_normaliser()[k]
            elif base.normalise:
                scores = scores - self._base_normaliser[k]
            # ungated, normalised here as MultipleHypothesis(normalise=True) normalises;
            # the gaters sort by probability (stable)
            order = np.argsort(-scores, kind="stable").tolist() if self.recipe.gates \
                else range(hi - lo + 1)
        hypotheses = []
        for i in order:
            if i == 0:
                measurement = self._measurement(-1)
                hypotheses.append(self._single(
                    predict(measurement), measurement,
                    base.missed_distance if distance else scores[0]))
            else:
                measurement = self._measurement(self.candidates[lo + i - 1])
                hypotheses.append(self._single(predict(measurement), measurement, scores[i],
                                               measurement_prediction))
        return _multiple(hypotheses, normalise=not distance and not self.recipe.gates
                         and base.normalise)

    def final_normaliser(self):
        """Per track, ``log`` of the total weight of its hypotheses (after the gaters)."""
        if self._final_normaliser is None:
            self._final_normaliser = np.logaddexp(
                self.missed_log_weight, segment_logsumexp(self.log_weights, self.starts))
        return self._final_normaliser

    def _hypothesis(self, k, j):
        """The hypothesis of track k taking detection j (-1: missed), as the hypothesiser
        returns it (a probability normalised as :meth:`hypotheses` normalises it)."""
        prediction = self.prediction(k)
        lo, hi = self.starts[k], self.starts[k + 1]
        q = lo + np.searchsorted(self.candidates[lo:hi], j)
        measurement_prediction = None if j < 0 else self.measurement_prediction(k)
        if self.recipe.kind == "distance":
            score = self.recipe.base.missed_distance if j < 0 else self.distances[q]
        else:
            score = self.missed_log_weight if j < 0 else self.log_weights[q]
            if self.recipe.base.normalise:
                score -= self._base_normaliser[k]
        return self._single(prediction, self._measurement(j), score, measurement_prediction)

    def chosen(self, assigned):
        """``{track: hypothesis}`` of an assignment (K,) of detection indices (-1 missed)."""
        return {track: self._hypothesis(k, j)
                for k, (track, j) in enumerate(zip(self.tracks, assigned))}

    # -- solvers -----------------------------------------------------------------------------

    def _costs(self):
        """The candidates' costs (n,): distances, or minus the log weights of probability
        hypotheses (the most probable joint hypothesis has the least total)."""
        return self.distances if self.recipe.kind == "distance" else -self.log_weights

    def _missed_costs(self):
        missed = self.recipe.base.missed_distance if self.recipe.kind == "distance" \
            else -self.missed_log_weight
        return np.full(len(self.tracks), float(missed))

    def _unopposed(self):
        """Tracks with no candidate detection."""
        return np.diff(self.starts) == 0

    def nearest(self):
        """Stone Soup's ``NearestNeighbour`` assignment (K,)."""
        return nearest_neighbour(self._pairs(), self._missed_costs(), costs=self.distances)

    def global_nearest(self, enumerated=False):
        """The minimum-total-cost assignment (K,) (Stone Soup's global nearest neighbour:
        least total distance, or greatest product of probabilities), solved per cluster of
        the gate graph; None if some cluster has no finite assignment (a missed cost of
        ``inf``).

        A track with no candidate is missed outright, as ``GNNWith2DAssignment`` does;
        ``enumerated`` (``GlobalNearestNeighbour``, whose joint hypotheses all cost ``inf``
        then) gives None instead when the missed distance is ``inf``.
        """
        missed = self._missed_costs()
        if enumerated and np.isinf(missed).any() and self._unopposed().any():
            return None
        try:
            return global_nearest_neighbour(self._pairs(), missed, costs=self._costs())
        except ValueError:  # no finite assignment: Stone Soup's code says so
            return None

    def _pairs(self):
        return Gate(self.starts, self.candidates, np.zeros(self.candidates.size),
                    np.zeros(self.candidates.size), len(self.detections))

    def marginals(self):
        """Exact JPDA marginal probabilities: of each track's missed detection (K,) and of
        each candidate (n,)."""
        return gate_marginals(self._pairs(), self.missed_log_weight, self.log_weights)

    def jpda_hypotheses(self, marginal_missed, marginal, ehm):
        """``{track: MultipleHypothesis}`` of the JPDA marginals as Stone Soup's ``JPDA``
        (``ehm`` False: a new missed detection first) or ``JPDAwithEHM`` (the hypothesiser's
        order) build them, normalised to total 1 in log space as Stone Soup normalises."""
        out = {}
        gated = bool(self.recipe.gates)
        with np.errstate(divide="ignore"):
            log_missed, log_marginal = np.log(marginal_missed), np.log(marginal)
        normaliser = np.logaddexp(log_missed, segment_logsumexp(log_marginal, self.starts))
        log_missed = log_missed - normaliser
        log_marginal = log_marginal - np.repeat(normaliser, np.diff(self.starts))
        for k, track in enumerate(self.tracks):
            lo, hi = self.starts[k], self.starts[k + 1]
            prediction = self.prediction(k)
            measurement_prediction = self.measurement_prediction(k) if hi > lo else None
            hypotheses = [self._single(prediction, self._measurement(-1), log_missed[k])]
            hypotheses += [self._single(prediction, self.detections[j], log_p,
                                        measurement_prediction)
                           for j, log_p in zip(self.candidates[lo:hi], log_marginal[lo:hi])]
            if gated:  # the hypothesiser's order: the gaters sort by probability
                order = list(np.argsort(-np.r_[self.missed_log_weight,
                                               self.log_weights[lo:hi]], kind="stable"))
                if not ehm:  # JPDA: the missed detection first, with the first hypothesis's
                    # measurement prediction
                    if order[0] != 0:
                        hypotheses[0].measurement_prediction = measurement_prediction
                    order = [0] + [i for i in order if i != 0]
                hypotheses = [hypotheses[i] for i in order]
            out[track] = _multiple(hypotheses, normalise=True)
        return out


def _multiple(hypotheses, normalise):
    """``MultipleHypothesis(hypotheses, normalise, 1)`` of hypotheses whose probabilities
    are already normalised (Stone Soup's ``Probability`` arithmetic would only repeat the
    log-sum-exp, at a few microseconds a hypothesis)."""
    multiple = _multiple_hypothesis(single_hypotheses=hypotheses, total_weight=1)
    if normalise:  # marked only: normalising again would change nothing
        multiple.normalise = True
    return multiple
