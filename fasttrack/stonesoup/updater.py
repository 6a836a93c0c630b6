"""Stone Soup's updaters, with fasttrack's kernels.

The fast paths cover Stone Soup's built-in measurement models (see ``_convert``); anything
else (another model, a regulariser, a constraint, keywords) goes through Stone Soup's own
code. A Kalman update whose hypothesis carries a measurement prediction (as the
associators' hypotheses do) uses it, with Stone Soup's formulas. Unlike Stone Soup, a
measurement for which every particle weight is zero or NaN is an error rather than NaN
weights. The point-process updaters are in ``pointprocess``.
"""
from functools import lru_cache

import numpy as np
from stonesoup.models.base import GaussianModel
from stonesoup.types.angle import Bearing
from stonesoup.types.array import CovarianceMatrix, StateVector, StateVectors
from stonesoup.types.prediction import MeasurementPrediction, ParticleMeasurementPrediction
from stonesoup.types.update import Update
from stonesoup.updater import kalman as ss_kalman
from stonesoup.updater import kernel as ss_kernel
from stonesoup.updater import particle as ss_particle

from ..core import akkf as ft_akkf
from ..core import kalman as ft_kalman
from ..core import particle as ft_particle
from ..core import unscented as ft_unscented
from ..models import LinearGaussian
from ..types import dense_kernel_covar
from ._convert import (angle_rows, fast_kernel, fast_model, fits, floats, global_rng,
                       kernel_filter_refusal, mod_bearing, plain_particles, sigma_parameters,
                       typed_measurement, uncached)
from ._fallback import fall_back, keywords, overridden, unknown_kernel, unknown_model
from ._objects import from_state
from ._pending import PendingParticleMeasurement, PendingVectors, bearing_vectors
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
