"""Stone Soup's updaters, with fasttrack's kernels.

The fast paths cover Stone Soup's built-in measurement models (see ``_convert``); anything
else (another model, a regulariser, a constraint, keywords, a measurement prediction given
on the hypothesis) goes through Stone Soup's own code. Unlike Stone Soup, a measurement for
which every particle weight is zero or NaN is an error rather than NaN weights.
"""
import types
from functools import lru_cache

import numpy as np
from stonesoup.types.array import StateVectors
from stonesoup.types.prediction import MeasurementPrediction
from stonesoup.types.update import Update
from stonesoup.updater import kalman as ss_kalman
from stonesoup.updater import kernel as ss_kernel
from stonesoup.updater import particle as ss_particle

from .. import updater as ft_updater
from ..models import LinearGaussian
from .._jit import akkf as _akkf
from .._jit import weights as _weights
from ..predictor import check_weights
from ._convert import (fast_model, floats, global_rng, kernel_spec, stream_key,
                       typed_measurement, uncached)
from .resampler import _plain
from ..types import dense_kernel_covar
from .state import kernel_factors, remember_factors


def _measurement_model(updater, hypothesis):
    """The detection's own measurement model, else the updater's (as Stone Soup picks)."""
    return hypothesis.measurement.measurement_model or updater.measurement_model


class ParticleUpdater(ss_particle.ParticleUpdater):
    """Stone Soup's ``ParticleUpdater``, compiled for its built-in measurement models."""

    def update(self, hypothesis, **kwargs):
        prediction = hypothesis.prediction
        model = fast_model(_measurement_model(self, hypothesis))
        if (model is None or kwargs or self.constraint_func is not None
                or self.regulariser is not None or not _plain(prediction)):
            return ss_particle.ParticleUpdater.update(self, hypothesis, **kwargs)
        state = Update.from_state(state=prediction, hypothesis=hypothesis,
                                  timestamp=prediction.timestamp)
        z = model.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        log_w = np.empty(len(prediction))
        top = model.log_likelihood(z, floats(prediction.state_vector),
                                   floats(prediction.log_weight), log_w)
        if not np.isfinite(top):
            raise ValueError("no particle weight survives this measurement (all zero or NaN)")
        _weights.normalise_in_place(log_w, top)
        state.log_weight = log_w
        if self.resampler is not None:
            state = self.resampler.resample(state)
        return state


class _Kalman:
    """``predict_measurement`` and ``update`` through fasttrack's Kalman kernels (the
    extended updater with Stone Soup's forward-difference Jacobian rule)."""

    _stonesoup = ss_kalman.KalmanUpdater
    _native = ft_updater.KalmanUpdater

    def _fast(self, model):
        """The fasttrack updater for a Stone Soup model, or None."""
        fast = fast_model(model)
        if fast is None or self.force_positive_definite_covariance:
            return None
        if self._native is ft_updater.KalmanUpdater:
            if not isinstance(fast, LinearGaussian):
                return None
            return ft_updater.KalmanUpdater(fast, use_joseph_cov=self.use_joseph_cov)
        return ft_updater.ExtendedKalmanUpdater(fast, use_joseph_cov=self.use_joseph_cov,
                                                jacobian="forward")

    @staticmethod
    def _arrays(prediction):
        return types.SimpleNamespace(state_vector=floats(prediction.state_vector),
                                     covar=floats(prediction.covar))

    @lru_cache()
    def predict_measurement(self, predicted_state, measurement_model=None,
                            measurement_noise=True, **kwargs):
        model = self._check_measurement_model(measurement_model)
        native = self._fast(model)
        if native is None or kwargs:
            return uncached(self._stonesoup.predict_measurement)(
                self, predicted_state, model, measurement_noise, **kwargs)
        fast = native.measurement_model
        z = np.zeros((fast.ndim_meas, 1))  # any: only the measurement prediction is kept
        z_hat, s, cross = native._update(fast, self._arrays(predicted_state), z)[2:]
        if not measurement_noise:
            s = s - fast.noise_covar
        return MeasurementPrediction.from_state(predicted_state, typed_measurement(z_hat, fast),
                                                s, cross_covar=cross)

    def update(self, hypothesis, **kwargs):
        model = self._check_measurement_model(hypothesis.measurement.measurement_model)
        native = self._fast(model)
        if native is None or kwargs or hypothesis.measurement_prediction is not None:
            return self._stonesoup.update(self, hypothesis, **kwargs)
        fast = native.measurement_model
        prediction = hypothesis.prediction
        z = fast.measurement_column(hypothesis.measurement, "hypothesis.measurement")
        x, covar, z_hat, s, cross = native._update(fast, self._arrays(prediction), z)
        hypothesis.measurement_prediction = MeasurementPrediction.from_state(
            prediction, typed_measurement(z_hat, fast), s, cross_covar=cross)
        return Update.from_state(prediction, x, covar, timestamp=hypothesis.measurement.timestamp,
                                 hypothesis=hypothesis)


class KalmanUpdater(_Kalman, ss_kalman.KalmanUpdater):
    """Stone Soup's ``KalmanUpdater``, compiled for its ``LinearGaussian`` model."""


class ExtendedKalmanUpdater(_Kalman, ss_kalman.ExtendedKalmanUpdater):
    """Stone Soup's ``ExtendedKalmanUpdater``, compiled for its built-in models; the
    Jacobian of the polar sensors follows Stone Soup's forward-difference rule."""

    _stonesoup = ss_kalman.ExtendedKalmanUpdater
    _native = ft_updater.ExtendedKalmanUpdater


class AdaptiveKernelKalmanUpdater(ss_kernel.AdaptiveKernelKalmanUpdater):
    """Stone Soup's ``AdaptiveKernelKalmanUpdater``, computed in fasttrack's factored form
    (see ``fasttrack.AdaptiveKernelKalmanUpdater``); the proposal is drawn from NumPy's
    global random state."""

    @lru_cache()
    def predict_measurement(self, state_prediction, measurement_model=None, **kwargs):
        model = measurement_model or self.measurement_model
        fast = fast_model(model)
        if fast is None:
            return uncached(ss_kernel.AdaptiveKernelKalmanUpdater.predict_measurement)(
                self, state_prediction, measurement_model, **kwargs)
        y = fast.function(floats(state_prediction.state_vector))
        return MeasurementPrediction.from_state(state_prediction, state_vector=StateVectors(y))

    def update(self, hypothesis, **kwargs):
        prediction = hypothesis.prediction
        model = self._check_measurement_model(hypothesis.measurement.measurement_model)
        fast = fast_model(model)
        spec = kernel_spec(self.kernel)
        if fast is None or spec is None or kwargs:
            return ss_kernel.AdaptiveKernelKalmanUpdater.update(self, hypothesis, **kwargs)
        if hypothesis.measurement_prediction is None:
            hypothesis.measurement_prediction = self.predict_measurement(
                prediction, measurement_model=model)
        x = floats(prediction.state_vector)
        z = fast.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        proposal = np.empty_like(x)
        predicted = kernel_factors(prediction)
        w, lt, v1t, v2t = _akkf.update_embedding(
            *spec, fast._angles, floats(hypothesis.measurement_prediction.state_vector),
            z.reshape(-1, 1), floats(prediction.weight), *predicted, self.lambda_updater, x,
            stream_key(global_rng()), proposal)
        check_weights(w, "updated")
        factors = (lt, predicted[1], v1t, v2t)
        update = Update.from_state(
            prediction, state_vector=prediction.state_vector, proposal=StateVectors(proposal),
            weight=w, kernel_covar=dense_kernel_covar(factors),
            timestamp=hypothesis.measurement.timestamp, hypothesis=hypothesis)
        return remember_factors(update, factors)
