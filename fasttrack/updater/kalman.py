"""The Kalman and extended Kalman updaters."""
import numpy as np

from .. import _validate
from .._validate import Setting
from ..core import kalman as _kalman
from ..models.base import check_model
from ..models.measurement import LinearGaussian, MeasurementModel
from ..predictor.base import check_gaussian
from ..types import (GaussianMeasurementPrediction, GaussianState, GaussianStateUpdate,
                     SingleHypothesis)
from .base import Updater

__all__ = ["ExtendedKalmanUpdater", "KalmanUpdater"]


class KalmanUpdater(Updater):
    """Kalman update with a linear-Gaussian measurement model.

    Parameters
    ----------
    measurement_model : MeasurementModel, optional
        Used when the detection has none of its own.
    force_symmetric_covariance : bool
        Accepted for compatibility: covariances are always computed exactly symmetric.
    use_joseph_cov : bool
        The Joseph form ``(I - K H) P (I - K H)^T + K R K^T`` (the default), which keeps the
        covariance positive semi-definite at any ratio of prediction and measurement
        noise; False for the standard form ``P - K S K^T`` (Stone Soup's default), which
        can lose it to cancellation (a zero or negative variance when P >> R).
    """

    jacobian = "analytic"

    def __init__(self, measurement_model=None, force_symmetric_covariance=False,
                 use_joseph_cov=True):
        super().__init__(measurement_model)
        self.force_symmetric_covariance = bool(force_symmetric_covariance)
        self.use_joseph_cov = _validate.flag(use_joseph_cov, "use_joseph_cov")

    def _check_model(self, model):
        if not isinstance(model, LinearGaussian):
            raise TypeError(f"{type(self).__name__} needs a LinearGaussian measurement model; "
                            f"use ExtendedKalmanUpdater for {type(model).__name__}")

    def _model(self, hypothesis_or_model, prediction):
        model = hypothesis_or_model
        if isinstance(hypothesis_or_model, SingleHypothesis):
            model = self._measurement_model(hypothesis_or_model)
        elif model is None:
            model = self.measurement_model
            if model is None:
                raise ValueError("no measurement model: give the updater one")
        self._check_model(model)
        self._check_prediction(prediction, GaussianState)
        check_gaussian(prediction, "hypothesis.prediction")
        self._check_dimensions(model, prediction)
        return model

    def predict_measurement(self, predicted_state, measurement_model=None):
        """The predicted measurement of ``predicted_state``: mean ``h(x)``, innovation
        covariance ``H P H^T + R`` and cross covariance ``P H^T``.

        Parameters
        ----------
        predicted_state : GaussianState
        measurement_model : MeasurementModel, optional
            Used instead of the updater's (a :class:`~fasttrack.LinearGaussian` for
            :class:`KalmanUpdater`).

        Returns
        -------
        GaussianMeasurementPrediction
        """
        model = self._model(measurement_model, predicted_state)
        z = np.zeros((model.ndim_meas, 1))  # any: only the measurement prediction is kept
        z_hat, s, cross = self._update(model, predicted_state, z, strict=False)[2:]
        return GaussianMeasurementPrediction._trusted(z_hat, s, predicted_state.timestamp,
                                                      {"cross_covar": cross})

    def _update(self, model, prediction, z, strict=True):
        """``(x, P, z_hat, S, cross)`` of one update (see :func:`fasttrack.core.kalman.update`)."""
        return _kalman.update(model, prediction.state_vector, prediction.covar, z,
                              self.jacobian, self.use_joseph_cov, strict)

    def update(self, hypothesis):
        """The posterior of ``hypothesis.prediction`` given ``hypothesis.measurement``.

        The innovation's angle components are wrapped. The measurement prediction is stored
        on the hypothesis as ``measurement_prediction``.

        Parameters
        ----------
        hypothesis : SingleHypothesis
            The ``prediction`` (a :class:`~fasttrack.GaussianState`) and the
            ``measurement`` (a :class:`~fasttrack.Detection`, not None).

        Returns
        -------
        GaussianStateUpdate
            With ``hypothesis``, timestamped at the measurement.

        Raises
        ------
        ValueError
            If the prediction's covariance is not positive semi-definite, the innovation
            covariance is singular, the Jacobian undefined, the standard form
            (``use_joseph_cov=False``) leaves a covariance that is not positive
            semi-definite, or a user measurement function returns a wrong shape or
            non-finite values.
        """
        self._check_hypothesis(hypothesis)
        prediction = hypothesis.prediction
        model = self._model(hypothesis, prediction)
        z = model.measurement_column(hypothesis.measurement, "hypothesis.measurement")
        x_out, covar_out, z_hat, s, cross = self._update(model, prediction, z)
        if not (np.isfinite(x_out).all() and np.isfinite(covar_out).all()):
            raise ValueError("the update overflowed: the posterior of this prediction and "
                             "hypothesis.measurement is beyond float64's range")
        timestamp = hypothesis.measurement.timestamp
        hypothesis.measurement_prediction = GaussianMeasurementPrediction._trusted(
            z_hat, s, timestamp, {"cross_covar": cross})
        hypothesis._used()
        return GaussianStateUpdate._trusted(x_out, covar_out, timestamp,
                                            {"hypothesis": hypothesis})


class ExtendedKalmanUpdater(KalmanUpdater):
    """Extended Kalman update: the measurement model linearised at the prediction.

    Parameters
    ----------
    measurement_model : MeasurementModel, optional
        Used when the detection has none of its own; any model (linearised at the
        prediction).
    force_symmetric_covariance : bool
        As :class:`KalmanUpdater`.
    use_joseph_cov : bool
        As :class:`KalmanUpdater`.
    jacobian : {'analytic', 'forward', 'central'}
        The built-in polar sensors' analytic Jacobian, or finite differences ('forward':
        Stone Soup's rule, bit for bit). Function-built models use finite differences
        ('analytic' means 'forward' for them).
    """

    #: The Jacobian's method (checked when assigned, here or later).
    jacobian = Setting(_kalman.check_jacobian)

    def __init__(self, measurement_model=None, force_symmetric_covariance=False,
                 use_joseph_cov=True, jacobian="analytic"):
        super().__init__(measurement_model, force_symmetric_covariance, use_joseph_cov)
        self.jacobian = jacobian

    def _check_model(self, model):
        check_model(model, MeasurementModel, "measurement model")
