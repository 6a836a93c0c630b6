"""Updaters: ``updater.update(hypothesis)``."""
import numpy as np

from . import _validate
from . import random as _random
from .core import akkf as _akkf
from .core import kalman as _kalman
from .core import particle as _particle
from .core import unscented as _unscented
from .models.base import check_model
from .models.measurement import LinearGaussian, MeasurementModel
from .kernel import as_kernel
from .resampler import Resampler
from .types import (GaussianMeasurementPrediction, GaussianState, GaussianStateUpdate,
                    KernelParticleState, KernelParticleStateMeasurementPrediction,
                    KernelParticleStateUpdate, ParticleState, ParticleStateUpdate,
                    SingleHypothesis, weak)


def _measurement_model(hypothesis, default):
    """The detection's own measurement model, else the updater's."""
    model = getattr(hypothesis.measurement, "measurement_model", None) or default
    if model is None:
        raise ValueError("no measurement model: give the updater one or set the "
                         "detection's measurement_model")
    check_model(model, MeasurementModel, "measurement model")
    return model


def _check_hypothesis(hypothesis):
    if not isinstance(hypothesis, SingleHypothesis):
        raise TypeError(f"hypothesis must be a SingleHypothesis, "
                        f"got {type(hypothesis).__name__}")
    if hypothesis.measurement is None:
        raise ValueError("hypothesis.measurement is None: nothing to update with")


class ParticleUpdater:
    """Weights particles by the likelihood of a measurement, then optionally resamples.

    Parameters
    ----------
    measurement_model : MeasurementModel, optional
        Used when the detection has none of its own.
    resampler : Resampler, optional
        Applied after the weights are updated (an :class:`~fasttrack.ESSResampler` resamples
        only when it decides to).
    """

    def __init__(self, measurement_model=None, resampler=None):
        if measurement_model is not None:
            check_model(measurement_model, MeasurementModel, "measurement_model")
        if resampler is not None and not isinstance(resampler, Resampler):
            raise TypeError(f"resampler must be a Resampler, got {type(resampler).__name__}")
        self.measurement_model = measurement_model
        self.resampler = resampler

    def update(self, hypothesis):
        """The posterior of ``hypothesis.prediction`` given ``hypothesis.measurement``:
        :meth:`weigh`, then the resampler.

        Parameters
        ----------
        hypothesis : SingleHypothesis
            The ``prediction`` (a :class:`~fasttrack.ParticleState`) and the
            ``measurement`` (a :class:`~fasttrack.Detection`, not None).

        Returns
        -------
        ParticleStateUpdate
            Sharing the prediction's ``state_vector`` (unless resampled), with ``hypothesis``,
            ``parent`` = the prediction's parent (its prior, a weak link), and the
            prediction's timestamp.
        """
        update = self.weigh(hypothesis)
        if self.resampler is None:
            return update
        resampled = self.resampler.resample(update)
        resampled.ess, resampled.resampled = update.ess, resampled is not update
        return resampled

    def weigh(self, hypothesis):
        """The posterior before resampling: ``log_weight += log p(z | particle)``,
        normalised with logsumexp.

        Parameters
        ----------
        hypothesis : SingleHypothesis
            The ``prediction`` (a :class:`~fasttrack.ParticleState`) and the
            ``measurement`` (a :class:`~fasttrack.Detection`, not None).

        Returns
        -------
        ParticleStateUpdate
            As :meth:`update` returns it without a resampler.
        """
        _check_hypothesis(hypothesis)
        prediction = hypothesis.prediction
        if not isinstance(prediction, ParticleState):
            raise TypeError(f"hypothesis.prediction must be a ParticleState, "
                            f"got {type(prediction).__name__}")
        model = _measurement_model(hypothesis, self.measurement_model)
        if model.ndim_state != prediction.ndim:
            raise ValueError(f"the measurement model expects {model.ndim_state} state "
                             f"dimensions, the prediction has {prediction.ndim}")
        z = model.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        log_w, ess = _particle.weigh(model, z, prediction.state_vector, prediction.log_weight)
        hypothesis._used()
        return ParticleStateUpdate._trusted(
            prediction.state_vector, log_w, timestamp=prediction.timestamp,
            parent=weak(prediction.parent), hypothesis=hypothesis,
            fixed_covar=prediction.fixed_covar, ess=ess)


class KalmanUpdater:
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
        if measurement_model is not None:
            self._check_model(measurement_model)
        self.measurement_model = measurement_model
        self.force_symmetric_covariance = bool(force_symmetric_covariance)
        self.use_joseph_cov = bool(use_joseph_cov)

    def _check_model(self, model):
        if not isinstance(model, LinearGaussian):
            raise TypeError(f"{type(self).__name__} needs a LinearGaussian measurement model; "
                            f"use ExtendedKalmanUpdater for {type(model).__name__}")

    def _model(self, hypothesis_or_model, prediction):
        model = hypothesis_or_model
        if isinstance(hypothesis_or_model, SingleHypothesis):
            model = _measurement_model(hypothesis_or_model, self.measurement_model)
        elif model is None:
            model = self.measurement_model
            if model is None:
                raise ValueError("no measurement model: give the updater one")
        self._check_model(model)
        if not isinstance(prediction, GaussianState):
            raise TypeError(f"the prediction must be a GaussianState, "
                            f"got {type(prediction).__name__}")
        if model.ndim_state != prediction.state_vector.shape[0]:
            raise ValueError(f"the measurement model expects {model.ndim_state} state "
                             f"dimensions, the prediction has {prediction.ndim}")
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
        z_hat, s, cross = self._update(model, predicted_state, z)[2:]
        return GaussianMeasurementPrediction._trusted(z_hat, s, predicted_state.timestamp,
                                                      {"cross_covar": cross})

    def _update(self, model, prediction, z):
        """``(x, P, z_hat, S, cross)`` of one update (see :func:`fasttrack.core.kalman.update`)."""
        return _kalman.update(model, prediction.state_vector, prediction.covar, z,
                              self.jacobian, self.use_joseph_cov)

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
            covariance is singular, the Jacobian undefined, or a user measurement function
            returns a wrong shape or non-finite values.
        """
        _check_hypothesis(hypothesis)
        prediction = hypothesis.prediction
        model = self._model(hypothesis, prediction)
        z = model.measurement_column(hypothesis.measurement, "hypothesis.measurement")
        x_out, covar_out, z_hat, s, cross = self._update(model, prediction, z)
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

    def __init__(self, measurement_model=None, force_symmetric_covariance=False,
                 use_joseph_cov=True, jacobian="analytic"):
        super().__init__(measurement_model, force_symmetric_covariance, use_joseph_cov)
        self.jacobian = _kalman.check_jacobian(jacobian)

    def _check_model(self, model):
        check_model(model, MeasurementModel, "measurement model")


class UnscentedKalmanUpdater(KalmanUpdater):
    """Unscented Kalman update: the predicted measurement, innovation covariance and cross
    covariance from the prediction's sigma points through the measurement model (Stone
    Soup's ``UnscentedKalmanUpdater``, in one compiled kernel). Angle components (a
    bearing) are averaged circularly and wrapped in differences and the innovation.

    Parameters
    ----------
    measurement_model : MeasurementModel, optional
        Used when the detection has none of its own: a built-in model
        (:class:`~fasttrack.LinearGaussian` or a polar sensor) or a
        :class:`~fasttrack.NonlinearGaussianMeasurement` (the sigma points go through its
        function).
    alpha : float
        Primary spread of the sigma points, > 0.
    beta : float
        Prior knowledge of the distribution (2 is optimal for a Gaussian).
    kappa : float, optional
        Secondary spread; None means ``3 - ndim_state``. ``alpha**2 * (ndim_state + kappa)``
        must be > 0.
    use_joseph_cov : bool
        False (the default, Stone Soup's form): ``P - K S K^T``. True: the Joseph form
        ``(I - K H) P (I - K H)^T + K R K^T`` with the statistical linearisation
        ``H = C^T P^-1`` (C the cross covariance), which is exact for a linear sensor and
        keeps the covariance positive semi-definite; for a nonlinear sensor it differs
        from the standard form by the linearisation error.
    force_symmetric_covariance : bool
        Accepted for compatibility: covariances are always computed exactly symmetric.
    """

    def __init__(self, measurement_model=None, alpha=0.5, beta=2.0, kappa=None,
                 use_joseph_cov=False, force_symmetric_covariance=False):
        self.alpha, self.beta, self.kappa = _unscented.check_parameters(alpha, beta, kappa)
        self._kappas = {}  # the resolved kappa per state dimension
        self._checked = None  # the last model checked (its type and dimensions are fixed)
        super().__init__(measurement_model, force_symmetric_covariance, use_joseph_cov)

    def _check_model(self, model):
        if model is self._checked:
            return
        check_model(model, MeasurementModel, "measurement model")
        _unscented.check_measurement(model)
        d = model.ndim_state
        if d not in self._kappas:
            self._kappas[d] = _unscented.scaling(self.alpha, self.kappa, d)
        self._checked = model

    def predict_measurement(self, predicted_state, measurement_model=None):
        """The predicted measurement of ``predicted_state`` by the unscented transform:
        mean, innovation covariance (with the measurement noise) and cross covariance.

        Parameters
        ----------
        predicted_state : GaussianState
        measurement_model : MeasurementModel, optional
            Used instead of the updater's.

        Returns
        -------
        GaussianMeasurementPrediction
        """
        return super().predict_measurement(predicted_state, measurement_model)

    def _update(self, model, prediction, z):
        return _unscented.update(model, prediction.state_vector, prediction.covar, z,
                                 self.alpha, self.beta, self._kappas[model.ndim_state],
                                 self.use_joseph_cov)


class AdaptiveKernelKalmanUpdater:
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
        if measurement_model is not None:
            check_model(measurement_model, MeasurementModel, "measurement_model")
        self.measurement_model = measurement_model
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
        return self._measurement_prediction(model, predicted_state)

    @staticmethod
    def _measurement_prediction(model, prediction):
        if not isinstance(prediction, KernelParticleState):
            raise TypeError(f"the prediction must be a KernelParticleState, "
                            f"got {type(prediction).__name__}")
        if model.ndim_state != prediction.ndim:
            raise ValueError(f"the measurement model expects {model.ndim_state} state "
                             f"dimensions, the prediction has {prediction.ndim}")
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
        _check_hypothesis(hypothesis)
        prediction = hypothesis.prediction
        model = _measurement_model(hypothesis, self.measurement_model)
        z = model.measurement_vector(hypothesis.measurement, "hypothesis.measurement")
        if hypothesis.measurement_prediction is None:
            hypothesis.measurement_prediction = self._measurement_prediction(model, prediction)
        y = hypothesis.measurement_prediction.state_vector
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
