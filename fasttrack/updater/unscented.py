"""The unscented Kalman updater."""
from .._sigma import SigmaPointSettings
from ..core import unscented as _unscented
from ..models.base import check_model
from ..models.measurement import MeasurementModel
from .kalman import KalmanUpdater

__all__ = ["UnscentedKalmanUpdater"]


class UnscentedKalmanUpdater(SigmaPointSettings, KalmanUpdater):
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
        must lie in [1e-12, 1e100] (the sigma points' weights are its inverse).
    use_joseph_cov : bool
        True (the default): the Joseph form ``(I - K H) P (I - K H)^T + K R K^T`` with the
        statistical linearisation ``H = C^T P^-1`` (C the cross covariance), which keeps
        the covariance positive semi-definite. For a linear sensor it equals the standard
        form; for a nonlinear one it is the standard form less ``K (P_zz - H P H^T) K^T``
        (``P_zz`` the sigma points' measurement spread), the part of the spread that no
        linear sensor explains. False: Stone Soup's standard form ``P - K S K^T``, which
        can lose positive semi-definiteness close to a polar sensor, where the sigma
        points' negative centre weight makes their joint spread indefinite; an update that
        does raises a ValueError.
    force_symmetric_covariance : bool
        Accepted for compatibility: covariances are always computed exactly symmetric.

    A prediction whose mean has a component more than 1e12 times its standard deviation is
    refused (ValueError): its sigma points would round to the mean in float64.
    """

    def __init__(self, measurement_model=None, alpha=0.5, beta=2.0, kappa=None,
                 use_joseph_cov=True, force_symmetric_covariance=False):
        self.alpha, self.beta, self.kappa = alpha, beta, kappa
        self._checked = None  # the last model checked (its type and dimensions are fixed)
        super().__init__(measurement_model, force_symmetric_covariance, use_joseph_cov)

    def _check_model(self, model):
        if model is self._checked:
            return
        check_model(model, MeasurementModel, "measurement model")
        _unscented.check_measurement(model)
        self._resolved_kappa(model.ndim_state)  # (the spread checked at a model's first use)
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

    def _update(self, model, prediction, z, strict=True):
        return _unscented.update(model, prediction.state_vector, prediction.covar, z,
                                 self.alpha, self.beta, self._resolved_kappa(model.ndim_state),
                                 self.use_joseph_cov, strict)
