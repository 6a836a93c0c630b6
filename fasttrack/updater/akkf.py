"""The adaptive kernel Kalman filter's updater."""
import numpy as np

from .. import _validate
from .. import random as _random
from ..core import akkf as _akkf
from ..core import particle as _particle
from ..kernel import as_kernel
from ..models.base import check_model
from ..models.measurement import MeasurementModel
from ..types import (KernelParticleState, KernelParticleStateMeasurementPrediction,
                     KernelParticleStateUpdate)
from .base import Updater

__all__ = ["AdaptiveKernelKalmanUpdater"]


class AdaptiveKernelKalmanUpdater(Updater):
    """Update of the adaptive kernel Kalman filter: kernel weights and covariance from the
    measurement's embedding, then new proposal particles drawn around the posterior.

    Parameters
    ----------
    measurement_model : MeasurementModel, optional
        Used when the detection has none of its own.
    kernel : Kernel, optional
        Kernel on measurements (default ``QuadraticKernel()``); the Gaussian kernel wraps the
        model's angle components.
    lambda_updater : float
        Regularisation, > 0.
    rng : None, int or numpy.random.Generator
        Source of the proposal draws.
    """

    def __init__(self, measurement_model=None, kernel=None, lambda_updater=1e-3, rng=None):
        super().__init__(measurement_model)
        self.kernel = as_kernel(kernel)
        self.lambda_updater = _validate.positive(lambda_updater, "lambda_updater")
        self.rng = _random.check_rng(rng)

    def predict_measurement(self, predicted_state, measurement_model=None):
        """Noise-free measurements of every predicted particle.

        Parameters
        ----------
        predicted_state : KernelParticleState
        measurement_model : MeasurementModel, optional
            Used instead of the updater's.

        Returns
        -------
        KernelParticleStateMeasurementPrediction
            ``state_vector`` (m, M), with the prediction's weights and kernel covariance.
        """
        model = measurement_model or self.measurement_model
        if model is None:
            raise ValueError("no measurement model: give the updater one")
        check_model(model, MeasurementModel, "measurement_model")
        return self._measurement_prediction(model, predicted_state)

    def _measurement_prediction(self, model, prediction):
        self._check_prediction(prediction, KernelParticleState)
        self._check_dimensions(model, prediction)
        if not np.isfinite(prediction.state_vector).all():
            raise ValueError("the prediction's state_vector contains NaN or infinite values")
        y = model.wrap(_particle.measure(model.spec, prediction.state_vector))
        return KernelParticleStateMeasurementPrediction._trusted(
            y, prediction.weight, prediction._factors, prediction.timestamp)

    def update(self, hypothesis):
        """The posterior of ``hypothesis.prediction`` given ``hypothesis.measurement``.

        The measurement prediction is computed unless the hypothesis has one, and stored on
        it.

        Parameters
        ----------
        hypothesis : SingleHypothesis
            The ``prediction`` (a :class:`~fasttrack.KernelParticleState`) and the
            ``measurement`` (a :class:`~fasttrack.Detection`, not None).

        Returns
        -------
        KernelParticleStateUpdate
            The predicted particles as ``state_vector``, the posterior ``weight`` and kernel
            covariance, the ``proposal`` particles for the next prediction, ``hypothesis``,
            timestamped at the measurement.
        """
        self._check_hypothesis(hypothesis)
        prediction = hypothesis.prediction
        model = self._measurement_model(hypothesis)
        z = model.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        if hypothesis.measurement_prediction is None:
            hypothesis.measurement_prediction = self._measurement_prediction(model, prediction)
        y = getattr(hypothesis.measurement_prediction, "state_vector", None)
        if not isinstance(y, np.ndarray):
            raise TypeError(f"hypothesis.measurement_prediction must be a measurement "
                            f"prediction (predict_measurement's), got "
                            f"{type(hypothesis.measurement_prediction).__name__}")
        x = prediction.state_vector
        if y.shape != (model.ndim_meas, x.shape[1]):
            raise ValueError(f"hypothesis.measurement_prediction must have shape "
                             f"{(model.ndim_meas, x.shape[1])}, got {y.shape}")
        w, factors, proposal = _akkf.update(model, self.kernel, y, z, x, prediction.weight,
                                            prediction._factors, self.lambda_updater, self.rng)
        hypothesis._used()
        return KernelParticleStateUpdate._trusted(
            x, w, factors, hypothesis.measurement.timestamp, hypothesis=hypothesis,
            proposal=proposal)
