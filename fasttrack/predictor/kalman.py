"""The Kalman and extended Kalman predictors."""
from .._validate import Setting
from ..core import kalman as _kalman
from ..types import GaussianState, GaussianStatePrediction, weak
from .base import Predictor

__all__ = ["ExtendedKalmanPredictor", "KalmanPredictor"]


class KalmanPredictor(Predictor):
    """Kalman prediction through a linear-Gaussian transition model:
    ``x = F x``, ``P = F P F^T + Q``.

    Parameters
    ----------
    transition_model : linear-Gaussian TransitionModel (with ``matrix``)
    """

    def __init__(self, transition_model):
        super().__init__(transition_model)
        self._check_model(transition_model)

    jacobian = "forward"

    def _check_model(self, model):
        if not hasattr(model, "matrix"):
            raise TypeError(f"{type(self).__name__} needs a linear transition model (with "
                            f"matrix); use ExtendedKalmanPredictor for "
                            f"{type(model).__name__}")

    def predict(self, prior, timestamp):
        """Predict ``prior`` (a :class:`~fasttrack.GaussianState`) to ``timestamp``.

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
            If the prior's mean is not finite, its covariance not positive semi-definite,
            or a user transition function returns a wrong shape or non-finite values.
        """
        model = self.transition_model
        self._check_prior(prior, GaussianState, model.ndim_state)
        self._check_finite(prior, "prior")
        dt = self._interval(prior, timestamp)
        x_out, covar_out = _kalman.predict(model, dt, prior.state_vector, prior.covar,
                                           self.jacobian)
        return GaussianStatePrediction._trusted(
            x_out, covar_out, timestamp, {"transition_model": model, "_prior": weak(prior)})


class ExtendedKalmanPredictor(KalmanPredictor):
    """Kalman prediction through any transition model, linearised at the prior: the exact
    matrix for linear models, a finite-difference Jacobian for models built from a Numba
    function.

    Parameters
    ----------
    transition_model : TransitionModel
    jacobian : {'forward', 'central'}
        Finite differences for function-built models (forward: Stone Soup's rule).
    """

    #: The Jacobian's method (checked when assigned, here or later).
    jacobian = Setting(_kalman.check_jacobian, allowed=("forward", "central"))

    def __init__(self, transition_model, jacobian="forward"):
        super().__init__(transition_model)
        self.jacobian = jacobian

    def _check_model(self, model):
        pass
