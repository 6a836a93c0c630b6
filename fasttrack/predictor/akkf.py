"""The adaptive kernel Kalman filter's predictor."""
from .. import _validate
from ..core import akkf as _akkf
from ..kernel import as_kernel
from ..types import KernelParticleState, KernelParticleStatePrediction
from .base import Predictor

__all__ = ["AdaptiveKernelKalmanPredictor"]


class AdaptiveKernelKalmanPredictor(Predictor):
    """Prediction of the adaptive kernel Kalman filter: the proposal particles are moved
    through the transition model (without noise) and the weights and kernel covariance
    carried over by the kernel embedding.

    Parameters
    ----------
    transition_model : TransitionModel
    kernel : Kernel, optional
        Kernel on states (default ``QuadraticKernel()``).
    lambda_predictor : float
        Regularisation of the kernel matrix inverse, > 0.
    """

    def __init__(self, transition_model, kernel=None, lambda_predictor=1e-3):
        super().__init__(transition_model)
        self.kernel = as_kernel(kernel)
        self.lambda_predictor = _validate.positive(lambda_predictor, "lambda_predictor")

    def predict(self, prior, timestamp, proposal=None):
        """Predict ``prior`` to ``timestamp``.

        Parameters
        ----------
        prior : KernelParticleState
        timestamp : datetime.datetime or float seconds
        proposal : (d, M) array_like, optional
            Proposal particles; by default the prior's ``proposal`` if it is an update, else
            its particles.

        Returns
        -------
        KernelParticleStatePrediction
            The propagated proposal as ``state_vector``, the predicted ``weight`` and kernel
            covariance, ``transition_model`` and ``timestamp``.
        """
        model = self.transition_model
        self._check_prior(prior, KernelParticleState, model.ndim_state)
        self._check_finite(prior, "prior")
        dt = self._interval(prior, timestamp)
        x = prior.state_vector
        if proposal is None:
            proposal = getattr(prior, "proposal", None)
            proposal = x if proposal is None else proposal
        else:
            proposal = _validate.state_array(proposal, "proposal")
            if proposal.shape != x.shape:
                raise ValueError(f"proposal must have the prior's shape {x.shape}, "
                                 f"got {proposal.shape}")
        states, w, factors = _akkf.predict(model, self.kernel, dt, proposal, x, prior.weight,
                                           prior._factors, self.lambda_predictor)
        return KernelParticleStatePrediction._trusted(states, w, factors, timestamp,
                                                      transition_model=model)
