"""Stone Soup's updaters, with fasttrack's kernels.

The fast paths cover Stone Soup's built-in measurement models (see ``_convert``); anything
else (another model, a regulariser, a constraint, keywords) goes through Stone Soup's own
code. A Kalman update whose hypothesis carries a measurement prediction (as the
associators' hypotheses do) uses it, with Stone Soup's formulas. Unlike Stone Soup, a
measurement for which every particle weight is zero or NaN is an error rather than NaN
weights.
"""
from functools import lru_cache

import numpy as np
from stonesoup.models.base import GaussianModel
from stonesoup.types.angle import Bearing
from stonesoup.types.array import CovarianceMatrix, StateVector, StateVectors
from stonesoup.models.measurement.linear import LinearGaussian as SSLinearGaussian
from stonesoup.types.prediction import MeasurementPrediction, ParticleMeasurementPrediction
from stonesoup.types.state import TaggedWeightedGaussianState
from stonesoup.types.update import GaussianMixtureUpdate, Update
from stonesoup.updater import kalman as ss_kalman
from stonesoup.updater import kernel as ss_kernel
from stonesoup.updater import particle as ss_particle
from stonesoup.updater import pointprocess as ss_pointprocess

from ..core import akkf as ft_akkf
from ..core import kalman as ft_kalman
from ..core import particle as ft_particle
from ..core import unscented as ft_unscented
from ..models import LinearGaussian
from ..types import dense_kernel_covar
from ._convert import (all_real, angle_rows, fast_kernel, fast_model, fits, floats, global_rng,
                       kernel_filter_refusal, mod_bearing, plain_particles, sigma_parameters,
                       typed_measurement, uncached)
from ._fallback import fall_back, keywords, overridden, unknown_kernel, unknown_model
from ._objects import builder, fresh_tags, from_state
from ._pending import (PendingParticleMeasurement, PendingVectors, bearing_vectors, pending,
                       pending_mixture)
from .state import kernel_factors, remember_factors


def _measurement_model(updater, measurement):
    """The detection's own measurement model, else the updater's (as Stone Soup picks)."""
    return measurement.measurement_model or updater.measurement_model


class ParticleUpdater(ss_particle.ParticleUpdater):
    """Stone Soup's ``ParticleUpdater``, compiled for its built-in measurement models."""

    _stonesoup = ss_particle.ParticleUpdater  # (bound here: a script may patch the module)

    def _refusal(self, model, prediction, kwargs):
        """Why Stone Soup's code must run this update, or None."""
        fast = fast_model(model)
        if fast is None:
            return unknown_model(model)
        if np.shape(prediction.state_vector)[0] != fast.ndim_state:
            return f"particles of other than the model's {fast.ndim_state} dimensions"
        if not np.size(prediction.state_vector):
            return "no particles"
        if reason := keywords(kwargs, self):
            return reason
        if self.constraint_func is not None:
            return "a constraint function"
        if self.regulariser is not None:
            return "a regulariser"
        if not plain_particles(prediction):
            return f"prediction {type(prediction).__name__} indexes its particles its own way"
        return None

    def update(self, hypothesis, **kwargs):
        prediction = hypothesis.prediction
        model = _measurement_model(self, hypothesis.measurement)
        reason = self._refusal(model, prediction, kwargs)
        if reason:
            fall_back(self, "update", reason)
            return self._stonesoup.update(self, hypothesis, **kwargs)
        model = fast_model(model)
        state = Update.from_state(state=prediction, hypothesis=hypothesis,
                                  timestamp=prediction.timestamp)
        z = model.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        state.log_weight = ft_particle.weigh(model, z, floats(prediction.state_vector),
                                             floats(prediction.log_weight))[0]
        if self.resampler is not None:
            state = self.resampler.resample(state)
        return state

    @lru_cache()
    def predict_measurement(self, predicted_state, measurement_model=None,
                            measurement_noise=True, **kwargs):
        """Stone Soup's particle measurement prediction: each particle measured by the
        model, plus a noise draw from the model's random state (Stone Soup's own draw)
        unless ``measurement_noise`` is False; angle rows as ``Bearing`` objects, computed
        on floats and made objects when first read (see ``_pending``)."""
        model = self.measurement_model if measurement_model is None else measurement_model
        fast = fast_model(model)
        reason = unknown_model(model) if fast is None else (
            keywords(kwargs, self)
            or (np.shape(predicted_state.state_vector)[0] != fast.ndim_state
                and f"particles of other than the model's {fast.ndim_state} dimensions")
            or (not isinstance(measurement_noise, bool) and "measurement noise given as values")
            or (not plain_particles(predicted_state)
                and f"prediction {type(predicted_state).__name__} indexes its particles its "
                    f"own way"))
        if reason:
            fall_back(self, "predict_measurement", reason)
            return uncached(self._stonesoup.predict_measurement)(
                self, predicted_state, model, measurement_noise, **kwargs)
        values = ft_particle.measure(fast.spec, floats(predicted_state.state_vector))
        angles = list(fast.angle_components)
        if measurement_noise:  # Stone Soup: Bearing(Bearing(n) + h(x)): wrapped twice
            noise = floats(GaussianModel.rvs(model, values.shape[1])).reshape(values.shape)
            noise[angles] = mod_bearing(noise[angles])
            values = values + noise
            values[angles] = mod_bearing(values[angles])
        prediction = MeasurementPrediction.from_state(
            predicted_state, state_vector=StateVectors(values),
            timestamp=predicted_state.timestamp)
        if angles and type(prediction) is ParticleMeasurementPrediction:
            prediction.__class__ = PendingParticleMeasurement
            del prediction.__dict__["_property_state_vector"]
            PendingVectors(prediction, values, angles)
        elif angles:
            prediction.state_vector = bearing_vectors(values, angles)
        return prediction


#: The methods of Stone Soup's Kalman updaters that the fast path computes itself: a
#: subclass that overrides one runs Stone Soup's code.
_HOOKS = ("_measurement_matrix", "_measurement_cross_covariance",
          "_innovation_covariance", "_posterior_mean", "_posterior_covariance")


class _Kalman:
    """``predict_measurement`` and ``update`` through fasttrack's Kalman kernels (the
    extended updater with Stone Soup's forward-difference Jacobian rule)."""

    _stonesoup = ss_kalman.KalmanUpdater
    _linear_only = True

    def _fast(self, model):
        """The fasttrack model for a Stone Soup model, or the reason Stone Soup's code must
        run."""
        fast = fast_model(model)
        if fast is None:
            return unknown_model(model)
        hook = overridden(self, self._stonesoup, _HOOKS)
        if hook:
            return hook
        if self.force_positive_definite_covariance:
            return "force_positive_definite_covariance"
        if self._linear_only and not isinstance(fast, LinearGaussian):
            return f"{type(model).__name__} is not linear (the updater is Stone Soup's linear one)"
        return fast

    def _fast_for(self, model, prediction):
        """The fasttrack model if the kernel applies to ``prediction``, or the reason Stone
        Soup's code must run."""
        fast = self._fast(model)
        if isinstance(fast, str) or fits(prediction, fast.ndim_state):
            return fast
        return f"prediction of the wrong shape for {fast.ndim_state} dimensions"

    def _update(self, fast, prediction, z):
        """``(x, P, z_hat, S, cross)`` of the kernel's update, or the reason Stone Soup's
        code must run."""
        return ft_kalman.update(fast, floats(prediction.state_vector), floats(prediction.covar),
                                z, "forward", self.use_joseph_cov, strict=False)

    @lru_cache()
    def predict_measurement(self, predicted_state, measurement_model=None,
                            measurement_noise=True, **kwargs):
        model = self._check_measurement_model(measurement_model)
        fast = self._fast_for(model, predicted_state)
        moments = fast if isinstance(fast, str) else keywords(kwargs, self)
        if not moments:  # any z: only the measurement prediction is kept
            moments = self._update(fast, predicted_state, np.zeros((fast.ndim_meas, 1)))
        if isinstance(moments, str):
            fall_back(self, "predict_measurement", moments)
            return uncached(self._stonesoup.predict_measurement)(
                self, predicted_state, model, measurement_noise, **kwargs)
        z_hat, s, cross = moments[2:]
        if not measurement_noise:
            s = s - fast.noise_covar
        return from_state(MeasurementPrediction, predicted_state,
                          state_vector=typed_measurement(z_hat, fast),
                          covar=s.view(CovarianceMatrix), cross_covar=cross)

    def _update_given(self, model, fast, hypothesis):
        """Stone Soup's update from the hypothesis's own measurement prediction (its mean,
        innovation and cross covariances), or the reason Stone Soup's code must run (a
        measurement prediction without cross covariance, angles other than bearings, the
        Joseph form with a nonlinear model)."""
        prediction, measurement = hypothesis.prediction, hypothesis.measurement
        measurement_prediction = hypothesis.measurement_prediction
        cross = getattr(measurement_prediction, "cross_covar", None)
        covar = getattr(measurement_prediction, "covar", None)
        if cross is None or covar is None:
            return "a measurement prediction without covariances"
        if self.use_joseph_cov and not isinstance(fast, LinearGaussian):
            return "the Joseph form with a nonlinear model"
        z_sv, z_hat_sv = measurement.state_vector, measurement_prediction.state_vector
        m, d = fast.ndim_meas, fast.ndim_state
        if np.shape(z_sv) != (m, 1) or np.shape(z_hat_sv) != (m, 1) \
                or np.shape(covar) != (m, m) or np.shape(cross) != (d, m) \
                or np.shape(prediction.state_vector) != (d, 1):
            return "a measurement prediction of other shapes than the model's"
        wrapped = set()
        for vector in (z_sv, z_hat_sv):
            for row in angle_rows(np.asarray(vector)):
                if type(vector[row, 0]) is not Bearing:
                    return f"angles of type {type(vector[row, 0]).__name__}"
                wrapped.add(row)
        innovation = floats(z_sv) - floats(z_hat_sv)
        for row in wrapped:  # Stone Soup's Bearing arithmetic wraps the difference
            innovation[row, 0] = Bearing(innovation[row, 0])
        gain = floats(cross) @ np.linalg.inv(floats(covar))
        x = floats(prediction.state_vector) + gain @ innovation
        prior_covar = floats(prediction.covar)
        if self.use_joseph_cov:
            i_kh = np.identity(d) - gain @ floats(model.matrix())
            covar_out = i_kh @ prior_covar @ i_kh.T + gain @ floats(model.covar()) @ gain.T
        else:
            covar_out = prior_covar - gain @ floats(covar) @ gain.T
        if self.force_symmetric_covariance:
            covar_out = (covar_out + covar_out.T) / 2
        return from_state(Update, prediction, state_vector=x.view(StateVector),
                          covar=covar_out.view(CovarianceMatrix),
                          timestamp=measurement.timestamp, hypothesis=hypothesis)

    def _stonesoup_update(self, hypothesis, kwargs, reason):
        fall_back(self, "update", reason)
        return self._stonesoup.update(self, hypothesis, **kwargs)

    def update(self, hypothesis, **kwargs):
        model = self._check_measurement_model(hypothesis.measurement.measurement_model)
        fast = self._fast_for(model, hypothesis.prediction)
        reason = fast if isinstance(fast, str) else keywords(kwargs, self)
        if reason:
            return self._stonesoup_update(hypothesis, kwargs, reason)
        if hypothesis.measurement_prediction is not None:
            update = self._update_given(model, fast, hypothesis)
            if isinstance(update, str):
                return self._stonesoup_update(hypothesis, kwargs, update)
            return update
        prediction = hypothesis.prediction
        z = fast.measurement_column(hypothesis.measurement, "hypothesis.measurement")
        moments = self._update(fast, prediction, z)
        if isinstance(moments, str):
            return self._stonesoup_update(hypothesis, kwargs, moments)
        x, covar, z_hat, s, cross = moments
        hypothesis.measurement_prediction = from_state(
            MeasurementPrediction, prediction, state_vector=typed_measurement(z_hat, fast),
            covar=s.view(CovarianceMatrix), cross_covar=cross)
        return from_state(Update, prediction, state_vector=x.view(StateVector),
                          covar=covar.view(CovarianceMatrix),
                          timestamp=hypothesis.measurement.timestamp, hypothesis=hypothesis)


class KalmanUpdater(_Kalman, ss_kalman.KalmanUpdater):
    """Stone Soup's ``KalmanUpdater``, compiled for its ``LinearGaussian`` model."""


class ExtendedKalmanUpdater(_Kalman, ss_kalman.ExtendedKalmanUpdater):
    """Stone Soup's ``ExtendedKalmanUpdater``, compiled for its built-in models; the
    Jacobian of the polar sensors follows Stone Soup's forward-difference rule."""

    _stonesoup = ss_kalman.ExtendedKalmanUpdater
    _linear_only = False


class UnscentedKalmanUpdater(_Kalman, ss_kalman.UnscentedKalmanUpdater):
    """Stone Soup's ``UnscentedKalmanUpdater``, compiled for its built-in models (bearings
    averaged circularly, as Stone Soup's ``Bearing`` mean does).

    As in Stone Soup, ``use_joseph_cov`` takes the model's matrix ``H`` with the unscented
    gain, so it applies to ``LinearGaussian`` only (Stone Soup's own code runs, and fails,
    for a nonlinear model). Sigma-point parameters outside fasttrack's range and
    covariances without a Cholesky factor (which Stone Soup regularises) go through Stone
    Soup's code.
    """

    _stonesoup = ss_kalman.UnscentedKalmanUpdater
    _linear_only = False

    # its own method object: the associators' batched path computes the Kalman ones only
    predict_measurement = lru_cache()(uncached(_Kalman.predict_measurement))

    def _update(self, fast, prediction, z):
        parameters = sigma_parameters(self, fast.ndim_state)
        if parameters is None:
            return "sigma-point parameters outside fasttrack's range"
        try:
            return ft_unscented.update(fast, floats(prediction.state_vector),
                                       floats(prediction.covar), z, *parameters, strict=False)
        except ValueError as error:  # no Cholesky factor, which Stone Soup regularises
            return f"refused by fasttrack ({error})"

    def update(self, hypothesis, **kwargs):
        if (self.use_joseph_cov and hypothesis.measurement_prediction is None
                and not keywords(kwargs, self)):
            # the Joseph form from the measurement prediction, with the model's H
            model = self._check_measurement_model(hypothesis.measurement.measurement_model)
            if not isinstance(self._fast_for(model, hypothesis.prediction), LinearGaussian):
                return self._stonesoup_update(hypothesis, {}, "the Joseph form with a model "
                                              "other than LinearGaussian")
            hypothesis.measurement_prediction = self.predict_measurement(
                hypothesis.prediction, model)
        return super().update(hypothesis, **kwargs)


class AdaptiveKernelKalmanUpdater(ss_kernel.AdaptiveKernelKalmanUpdater):
    """Stone Soup's ``AdaptiveKernelKalmanUpdater``, computed in fasttrack's factored form
    (see ``fasttrack.AdaptiveKernelKalmanUpdater``); the proposal is drawn from NumPy's
    global random state."""

    _stonesoup = ss_kernel.AdaptiveKernelKalmanUpdater

    @lru_cache()
    def predict_measurement(self, state_prediction, measurement_model=None, **kwargs):
        model = measurement_model or self.measurement_model
        fast = fast_model(model)
        if fast is None:
            fall_back(self, "predict_measurement", unknown_model(model))
            return uncached(self._stonesoup.predict_measurement)(
                self, state_prediction, measurement_model, **kwargs)
        y = fast.function(floats(state_prediction.state_vector))
        return MeasurementPrediction.from_state(state_prediction, state_vector=StateVectors(y))

    def update(self, hypothesis, **kwargs):
        prediction = hypothesis.prediction
        model = self._check_measurement_model(hypothesis.measurement.measurement_model)
        fast = fast_model(model)
        kernel = fast_kernel(self.kernel)
        reason = unknown_model(model) if fast is None \
            else unknown_kernel(self.kernel) if kernel is None else (
                keywords(kwargs, self) or kernel_filter_refusal(
                    self.lambda_updater, "lambda_updater", prediction.weight))
        if reason:
            fall_back(self, "update", reason)
            return self._stonesoup.update(self, hypothesis, **kwargs)
        if hypothesis.measurement_prediction is None:
            hypothesis.measurement_prediction = self.predict_measurement(
                prediction, measurement_model=model)
        z = fast.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        w, factors, proposal = ft_akkf.update(
            fast, kernel, floats(hypothesis.measurement_prediction.state_vector), z,
            floats(prediction.state_vector), floats(prediction.weight),
            kernel_factors(prediction), self.lambda_updater, global_rng())
        update = Update.from_state(
            prediction, state_vector=prediction.state_vector, proposal=StateVectors(proposal),
            weight=w, kernel_covar=dense_kernel_covar(factors),
            timestamp=hypothesis.measurement.timestamp, hypothesis=hypothesis)
        return remember_factors(update, factors)


_tagged_state = builder(TaggedWeightedGaussianState)
_EPS = np.finfo(float).eps  # Stone Soup's weight for a component of weight 0


#: The point-process updaters' numeric settings: (name, what it must be, the test).
_SETTINGS = (("prob_detection", "a probability in [0, 1]", lambda p: 0.0 <= p <= 1.0),
             ("prob_survival", "a probability in [0, 1]", lambda p: 0.0 <= p <= 1.0),
             ("clutter_spatial_density", "finite and >= 0", lambda c: 0.0 <= c < np.inf))


class _PointProcess:
    """Stone Soup's ``PointProcessUpdater.update``: the Kalman updates and likelihoods of
    every (component, detection) pair computed at once on arrays, for a ``KalmanUpdater``
    and one linear Gaussian measurement model, by Stone Soup's rules: P_S applied at the
    update to every component not tagged 'birth' (a detected birth component is given a new
    tag), a missed birth component dropped, the likelihoods in linear terms, a weight of 0
    set to eps; the missed components scaled by the filter's own update terms. As in Stone
    Soup, a pair's likelihood is of the updater's model, its Kalman update from the
    measurement prediction its hypothesis carries (the hypothesiser's, whose model may be
    another for detections without their own). The update
    of the drop-in hypothesiser's groups (P_D and P_S plain numbers) holds its components as
    arrays until they are read (a :class:`~._pending.PendingMixtureUpdate`, which the
    drop-in reducer reduces as arrays). Another updater or measurement model goes through
    Stone Soup's code."""

    def update(self, hypotheses):
        self._check_settings()
        groups = pending(hypotheses)
        if groups is not None and all(tag is not None for tag in groups.tags) \
                and all_real(groups.weights) and not self._reason(groups.scan.own_models) \
                and all(type(p) in (float, int, np.float64) for p in (self.prob_detection,
                                                                      self.prob_survival)):
            try:
                update = self._scan_update(groups, hypotheses)
            except _Indefinite:
                update = None  # (the hypotheses' own path finds it too)
            if update is not None:
                return update
        pairs = [hypothesis for multiple in hypotheses[:-1] for hypothesis in multiple]
        measurements = [hypothesis.measurement for hypothesis in pairs]
        reason = "no hypotheses" if not hypotheses else self._reason(
            {id(model): model for model in [m.measurement_model for m in measurements]}.values())
        if not reason and not all_real(hypothesis.prediction.weight
                                       for multiple in hypotheses for hypothesis in multiple):
            reason = "a weight that is not a real number"  # (Stone Soup's arithmetic raises)
        predicted = None
        if not reason:
            predicted = _carried_predictions(pairs)
            reason = predicted if isinstance(predicted, str) else None
        if reason:
            fall_back(self, "update", reason)
            return super().update(hypotheses)
        detection = np.repeat(np.arange(len(hypotheses) - 1),
                              [len(multiple) for multiple in hypotheses[:-1]])
        predictions = [p.prediction for p in pairs]
        tags = [prediction.tag for prediction in predictions]
        try:
            means, covars, weights, sums = self._detected(
                np.array([p.state_vector[:, 0] for p in predictions], dtype=np.float64),
                np.array([p.covar for p in predictions], dtype=np.float64),
                np.array([float(p.weight) for p in predictions]),
                np.array([tag == "birth" for tag in tags]), np.arange(len(pairs)),
                _rows(measurements),
                _measurement_model(self.updater, measurements[0]) if pairs else None,
                detection, len(hypotheses) - 1, predicted=predicted)
        except _Indefinite:
            fall_back(self, "update", "an innovation covariance that is not positive definite")
            return super().update(hypotheses)
        updated = [_tagged_state(tag=tag if tag != "birth" else None, weight=weight,
                                 state_vector=mean[:, None].view(StateVector),
                                 covar=covar.view(CovarianceMatrix), timestamp=m.timestamp)
                   for tag, mean, covar, weight, m in zip(
                       tags, means, covars, weights.tolist(), measurements)]
        missed = self._missed_factor(sums, hypotheses)
        updated += [_tagged_state(tag=p.tag, weight=p.weight * missed, state_vector=p.mean,
                                  covar=p.covar, timestamp=p.timestamp)
                    for p in (hypothesis.prediction for hypothesis in hypotheses[-1])
                    if p.tag != "birth"]
        for component in updated:
            if component.weight == 0:
                component.weight = _EPS
        return GaussianMixtureUpdate(hypothesis=hypotheses, components=updated)

    def _check_settings(self):
        """ValueError naming a probability outside [0, 1] or a clutter density that is
        negative or not finite (Stone Soup weighs with them: negative or NaN weights, which
        fail a step later, unnamed); a value that is not a number is Stone Soup's to read."""
        for name, expected, allowed in _SETTINGS:
            value = getattr(self, name)
            try:
                number = float(value)
            except (TypeError, ValueError):
                continue
            if not allowed(number):
                raise ValueError(f"{name} must be {expected}, got {value!r}")

    def _scan_update(self, groups, hypotheses):
        """The update of a drop-in hypothesiser's groups from its scan's arrays (the
        hypotheses not built), a :class:`~._pending.PendingMixtureUpdate`: the pair of
        component k and detection j has k's prediction, weight and tag (a new one for a
        detected birth component), in the groups' order (by detection, then component),
        then the missed components in the components' order. None if the hypotheses'
        measurement predictions, of another model than this updater's, are not arrays of
        the scan (Stone Soup's update uses them), or if a detection changed since the scan
        read it."""
        scan = groups.scan
        if not scan.detections_as_read():
            return None
        owners = np.repeat(np.arange(len(scan.tracks)), np.diff(scan.starts))
        order = np.argsort(scan.candidates, kind="stable")
        k, detection = owners[order], scan.candidates[order]
        model = _measurement_model(self.updater, scan.detections[0]) if k.size else None
        log_likelihoods = scan.log_likelihoods(model)  # (None: the scan's is another model)
        predicted = scan.carried_predictions()
        if k.size and log_likelihoods is None and predicted is None:
            return None
        tags = groups.tags
        pair_tags = [tags[i] for i in k.tolist()]
        born = [q for q, tag in enumerate(pair_tags) if tag == "birth"]
        for q, tag in zip(born, fresh_tags(len(born))):
            pair_tags[q] = tag
        prior = np.array(groups.weights, dtype=np.float64)
        means, covars, weights, sums = self._detected(
            scan.means, scan.covars, prior, np.zeros(prior.size, dtype=np.bool_), k,
            scan.measurements[detection], model, detection, len(scan.detections),
            None if log_likelihoods is None else log_likelihoods[order], predicted)
        kept = [i for i, tag in enumerate(tags) if tag != "birth"]
        weights = np.concatenate([weights, prior[kept] * self._missed_factor(sums, hypotheses)])
        weights[weights == 0] = _EPS
        return pending_mixture(hypotheses, np.concatenate([means, scan.means[kept]]),
                               np.concatenate([covars, scan.covars[kept]]), weights,
                               pair_tags + [tags[i] for i in kept], scan.timestamp)

    def _detected(self, means, covars, weights, born, component, z, model, detection,
                  n_detections, log_likelihoods=None, predicted=None):
        """The posterior means (n, d), covariances (n, d, d) and weights (n,) of the
        (prediction, detection) pairs, and the sum of their likelihood terms for each of
        the ``n_detections``: predicted ``means`` (K, d), ``covars`` (K, d, d), ``weights``
        (K,), ``born`` (K,) whether tagged 'birth', each pair's ``component`` (n,) of them,
        measurement ``z`` (n, m) of ``model``, ``detection`` (n,) number and, if known,
        Gaussian ``log_likelihoods`` (n,) and the measurement predictions the hypotheses
        carry (see :meth:`_pair_updates`)."""
        if not detection.size:
            return means[component], covars[component], np.zeros(0), np.zeros(n_detections)
        means, covars, weights = self._pair_updates(means, covars, weights, born, component,
                                                    z, model, log_likelihoods, predicted)
        sums = np.bincount(detection, weights, minlength=n_detections)
        if self.normalisation:
            weights = weights / (sums[detection] + self.clutter_spatial_density)
        return means, covars, weights, sums

    def _missed_factor(self, sums, hypotheses):
        """What scales a missed component's weight: ``(1 - P_D) l1 P_S``, ``l1`` the
        filter's own update term of the detections' likelihood ``sums``."""
        return (1 - self.prob_detection) * self._calculate_update_terms(list(sums),
                                                                        hypotheses) \
            * self.prob_survival

    def _pair_updates(self, means, covars, prior, born, component, z, model,
                      log_likelihoods=None, predicted=None):
        """Posterior means (n, d), covariances (n, d, d) and unnormalised weights
        ``P_D w q (P_S)`` of the pairs of predicted ``means`` (K, d), ``covars`` (K, d, d)
        of weights ``prior`` (K,) (``born`` (K,): tagged 'birth', no P_S), each pair's
        ``component`` (n,) of them and measurement ``z`` (n, m), as Stone Soup's PHD
        updater computes them: ``q`` from the linear Gaussian ``model`` (or the given
        ``log_likelihoods`` (n,)), the Kalman update from the measurement predictions the
        hypotheses carry, ``predicted`` = (z_hats (K, m), innovation covariances
        (K, m, m), cross covariances (K, d, m)), by default ``model``'s (its gain and
        posterior covariance once per component; the Joseph form with ``model``'s H and
        R, as Stone Soup's)."""
        k, joseph = component, self.updater.use_joseph_cov
        if log_likelihoods is None or predicted is None or joseph:
            h, r = floats(model.matrix()), floats(model.covar())
        if log_likelihoods is None or predicted is None:
            cross = covars @ h.T
            own = means @ h.T, h @ cross + r, cross
        if log_likelihoods is None:
            try:
                lower = np.linalg.cholesky(own[1])
            except np.linalg.LinAlgError:  # (Stone Soup's likelihood refuses it)
                raise _Indefinite from None
            whitened = np.linalg.solve(lower[k], (z - own[0][k])[..., None])[..., 0]
            log_likelihoods = -0.5 * (np.einsum("ki,ki->k", whitened, whitened)
                                      + z.shape[1] * np.log(2 * np.pi)) \
                - np.log(np.diagonal(lower, axis1=1, axis2=2)).sum(axis=1)[k]
        z_hats, innovation, cross = own if predicted is None else predicted
        z_hats = z_hats[k]
        gains = cross @ np.linalg.inv(innovation)
        if joseph:
            i_kh = np.eye(means.shape[1]) - gains @ h
            post = i_kh @ covars @ i_kh.transpose(0, 2, 1) + gains @ r @ gains.transpose(0, 2, 1)
        else:
            post = covars - gains @ innovation @ gains.transpose(0, 2, 1)
        q = np.exp(log_likelihoods)
        weights = self.prob_detection * prior[k] * q
        weights = np.where(born[k], weights, weights * self.prob_survival)
        return means[k] + np.einsum("kij,kj->ki", gains[k], z - z_hats), post[k], weights

    def _reason(self, own_models):
        """Why Stone Soup's code must update the pairs of detections whose own measurement
        models are ``own_models`` (distinct; None for the updater's), or None."""
        if type(self.updater) not in (ss_kalman.KalmanUpdater, KalmanUpdater):
            return f"an updater of type {type(self.updater).__name__}"
        models = {id(model): model for model in (own or self.updater.measurement_model
                                                 for own in own_models)}
        if len(models) > 1:
            return "detections of several measurement models"
        if models and type(next(iter(models.values()))) is not SSLinearGaussian:
            return f"a measurement model of type {type(next(iter(models.values()))).__name__}"
        return None


class _Indefinite(Exception):
    """An innovation covariance of the updater's own model that is not positive definite
    (Stone Soup's code then decides)."""


def _carried_predictions(pairs):
    """The measurement predictions the hypotheses ``pairs`` carry, as arrays (z_hats
    (n, m), innovation covariances (n, m, m), cross covariances (n, d, m)); None if none
    carries one (the updater's model then makes them, as Stone Soup's would); the reason
    Stone Soup's code must run if only some do, or one has no cross covariance."""
    carried = [hypothesis.measurement_prediction for hypothesis in pairs]
    if all(prediction is None for prediction in carried):
        return None
    if any(getattr(prediction, "cross_covar", None) is None for prediction in carried):
        return "hypotheses without a measurement prediction with a cross covariance"
    return (floats(np.array([p.state_vector for p in carried], dtype=np.float64))[:, :, 0],
            floats(np.array([p.covar for p in carried], dtype=np.float64)),
            floats(np.array([p.cross_covar for p in carried], dtype=np.float64)))


def _rows(measurements):
    """The measurements' state vectors as rows (n, m), each measurement read once."""
    unique = {id(m): m for m in measurements}
    if not unique:
        return np.zeros((0, 0))
    rows = dict(zip(unique, np.array([m.state_vector for m in unique.values()],
                                     dtype=np.float64)[:, :, 0]))
    return np.array([rows[id(m)] for m in measurements])


class PHDUpdater(_PointProcess, ss_pointprocess.PHDUpdater):
    __doc__ = "Stone Soup's ``PHDUpdater``, its update on arrays. " + _PointProcess.__doc__


class LCCUpdater(_PointProcess, ss_pointprocess.LCCUpdater):
    __doc__ = ("Stone Soup's ``LCCUpdater`` (its cumulant terms as Stone Soup computes them), "
               "its update on arrays. " + _PointProcess.__doc__)
