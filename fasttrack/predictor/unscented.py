"""The unscented Kalman predictor."""
from .._sigma import SigmaPointSettings
from ..core import unscented as _unscented
from ..types import GaussianState, GaussianStatePrediction, weak
from .base import Predictor

__all__ = ["UnscentedKalmanPredictor"]


class UnscentedKalmanPredictor(SigmaPointSettings, Predictor):
    """Unscented Kalman prediction: the prior's sigma points moved through the transition
    model, their weighted mean and covariance plus the process noise Q (Stone Soup's
    ``UnscentedKalmanPredictor``, in one compiled kernel).

    Parameters
    ----------
    transition_model : TransitionModel
        A built-in linear-Gaussian transition model (``ConstantVelocity`` blocks or any
        model with ``matrix``) or a :class:`~fasttrack.NonlinearGaussianTransitionModel`
        (the sigma points go through its function).
    alpha : float
        Primary spread of the sigma points, > 0.
    beta : float
        Prior knowledge of the distribution (2 is optimal for a Gaussian).
    kappa : float, optional
        Secondary spread; None means ``3 - ndim_state``. ``alpha**2 * (ndim_state + kappa)``
        must lie in [1e-12, 1e100] (the sigma points' weights are its inverse).

    A prior whose mean has a component more than 1e12 times its standard deviation is
    refused (ValueError): its sigma points would round to the mean in float64.
    """

    def __init__(self, transition_model, alpha=0.5, beta=2.0, kappa=None):
        super().__init__(transition_model)
        _unscented.check_transition(transition_model)
        self.alpha, self.beta, self.kappa = alpha, beta, kappa
        # a transition model keeps its dimension (a combined model refuses a new model_list
        # of another size), and summing the parts' dimensions costs more than the kernel
        self._ndim = transition_model.ndim_state
        self._resolved_kappa(self._ndim)  # (the spread checked now)

    def predict(self, prior, timestamp):
        """Predict ``prior`` to ``timestamp`` by the unscented transform.

        Parameters
        ----------
        prior : GaussianState
        timestamp : datetime.datetime or float seconds
            Of the same kind as the prior's timestamp.

        Returns
        -------
        GaussianStatePrediction
            With ``transition_model``, ``prior`` (a weak link: see :mod:`fasttrack.types`)
            and ``timestamp``.

        Raises
        ------
        ValueError
            If the prior's mean is not finite, its covariance not symmetric positive
            semi-definite, or the user's transition function returns a wrong shape or
            non-finite values.
        """
        model = self.transition_model
        self._check_prior(prior, GaussianState, self._ndim)
        self._check_finite(prior, "prior")
        dt = self._interval(prior, timestamp)
        x_out, covar_out = _unscented.predict(model, float(dt), prior.state_vector,
                                              prior.covar, self.alpha, self.beta,
                                              self._resolved_kappa(self._ndim))
        return GaussianStatePrediction._trusted(
            x_out, covar_out, timestamp, {"transition_model": model, "_prior": weak(prior)})
