"""Stone Soup's predictors, with fasttrack's kernels.

Each ``predict`` is memoised as Stone Soup's is (the same prior and timestamp give the same
prediction object, and draw no new random numbers). A model, kernel, control input or
keyword the fast path does not know goes through Stone Soup's own code instead.
"""
from stonesoup.predictor import kalman as ss_kalman
from stonesoup.predictor import kernel as ss_kernel
from stonesoup.predictor import particle as ss_particle
from stonesoup.predictor._utils import predict_lru_cache
from stonesoup.proposal.simple import DynamicsProposal
from stonesoup.types.array import StateVectors
from stonesoup.types.prediction import GaussianStatePrediction, Prediction
from stonesoup.types.state import GaussianState
from stonesoup.types.update import GaussianStateUpdate, KernelParticleStateUpdate

from ..core import akkf as ft_akkf
from ..core import kalman as ft_kalman
from ..core import particle as ft_particle
from ..core import unscented as ft_unscented
from ..types import dense_kernel_covar
from ._convert import (fast_kernel, fast_model, fits, floats, model_rng, plain_particles,
                       sigma_parameters, uncached, zero_control)
from .state import kernel_factors, remember_factors

#: Gaussian state types whose predictions the Kalman kernel builds (not the square-root or
#: other specialised ones, which go through Stone Soup).
_GAUSSIAN_STATES = (GaussianState, GaussianStatePrediction, GaussianStateUpdate)


def _seconds(later, earlier):
    return (later - earlier).total_seconds()


class ParticlePredictor(ss_particle.ParticlePredictor):
    """Stone Soup's ``ParticlePredictor``, compiled for its built-in linear models."""

    @predict_lru_cache()
    def predict(self, prior, timestamp=None, measurement=None, **kwargs):
        proposal = self.proposal
        model = fast_model(proposal.transition_model) \
            if type(proposal) is DynamicsProposal and proposal.control_model is None else None
        if measurement is not None:
            timestamp = measurement.timestamp
        if (model is None or kwargs or not plain_particles(prior) or timestamp is None
                or prior.timestamp is None):
            return uncached(ss_particle.ParticlePredictor.predict)(
                self, prior, timestamp, measurement, **kwargs)
        state = ft_particle.predict(model, floats(prior.state_vector),
                                    _seconds(timestamp, prior.timestamp),
                                    model_rng(proposal.transition_model))
        return Prediction.from_state(prior, parent=prior, state_vector=StateVectors(state),
                                     timestamp=timestamp,
                                     transition_model=proposal.transition_model, prior=prior)


class _Kalman:
    """``predict`` of the Kalman predictors through one of fasttrack's Gaussian kernels."""

    _stonesoup = ss_kalman.KalmanPredictor

    def _moments(self, model, dt, x, covar):
        """``(x, P)`` predicted by the kernel, or None where Stone Soup's code must run."""
        return ft_kalman.predict(model, dt, x, covar)

    def _fast(self, prior, timestamp, control_input, kwargs):
        """The fasttrack transition model if the kernel applies to this call, else None."""
        model = fast_model(self.transition_model)
        if (model is None or kwargs or control_input is not None
                or not zero_control(self.control_model) or type(prior) not in _GAUSSIAN_STATES
                or timestamp is None or prior.timestamp is None
                or not fits(prior, model.ndim_state)):
            return None
        return model

    @predict_lru_cache()
    def predict(self, prior, timestamp=None, control_input=None, **kwargs):
        model = self._fast(prior, timestamp, control_input, kwargs)
        moments = None if model is None else self._moments(
            model, _seconds(timestamp, prior.timestamp), floats(prior.state_vector),
            floats(prior.covar))
        if moments is None:
            return uncached(self._stonesoup.predict)(self, prior, timestamp, control_input,
                                                     **kwargs)
        return Prediction.from_state(prior, *moments, timestamp=timestamp,
                                     transition_model=self.transition_model, prior=prior)


class KalmanPredictor(_Kalman, ss_kalman.KalmanPredictor):
    """Stone Soup's ``KalmanPredictor``, compiled for its built-in linear models."""


class ExtendedKalmanPredictor(_Kalman, ss_kalman.ExtendedKalmanPredictor):
    """Stone Soup's ``ExtendedKalmanPredictor``, compiled for its built-in linear models
    (whose Jacobian is their matrix)."""

    _stonesoup = ss_kalman.ExtendedKalmanPredictor


class UnscentedKalmanPredictor(_Kalman, ss_kalman.UnscentedKalmanPredictor):
    """Stone Soup's ``UnscentedKalmanPredictor``, compiled for its built-in linear models.

    Sigma-point parameters outside fasttrack's range (``alpha <= 0``, a spread
    ``alpha**2 (ndim + kappa) <= 0``) and covariances without a Cholesky factor (for which
    Stone Soup regularises the factor) go through Stone Soup's code.
    """

    _stonesoup = ss_kalman.UnscentedKalmanPredictor
    # its own method object: the associators' batched path computes the Kalman ones only
    predict = predict_lru_cache()(uncached(_Kalman.predict))

    def _moments(self, model, dt, x, covar):
        parameters = sigma_parameters(self, x.shape[0])
        if parameters is None:
            return None
        try:
            return ft_unscented.predict(model, dt, x, covar, *parameters)
        except ValueError:  # refused (no Cholesky factor, which Stone Soup regularises)
            return None


class AdaptiveKernelKalmanPredictor(ss_kernel.AdaptiveKernelKalmanPredictor):
    """Stone Soup's ``AdaptiveKernelKalmanPredictor``, computed in fasttrack's factored form
    (see ``fasttrack.AdaptiveKernelKalmanPredictor``)."""

    @predict_lru_cache()
    def predict(self, prior, timestamp=None, proposal=None, **kwargs):
        model = fast_model(self.transition_model)
        kernel = fast_kernel(self.kernel)
        if (model is None or kernel is None or kwargs or timestamp is None
                or prior.timestamp is None):
            return uncached(ss_kernel.AdaptiveKernelKalmanPredictor.predict)(
                self, prior, timestamp, proposal, **kwargs)
        if proposal is None:
            proposal = prior.proposal if isinstance(prior, KernelParticleStateUpdate) \
                else prior.state_vector
        proposal = floats(getattr(proposal, "state_vector", proposal))
        states, w, factors = ft_akkf.predict(
            model, kernel, _seconds(timestamp, prior.timestamp), proposal,
            floats(prior.state_vector), floats(prior.weight), kernel_factors(prior),
            self.lambda_predictor)
        prediction = Prediction.from_state(
            prior, state_vector=StateVectors(states), weight=w,
            kernel_covar=dense_kernel_covar(factors), timestamp=timestamp,
            transition_model=self.transition_model)
        return remember_factors(prediction, factors)
