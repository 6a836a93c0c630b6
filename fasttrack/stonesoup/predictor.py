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
from stonesoup.types.array import CovarianceMatrix, StateVector, StateVectors
from stonesoup.types import prediction as ss_prediction
from stonesoup.types import state as ss_state
from stonesoup.types import update as ss_update
from stonesoup.types.prediction import Prediction
from stonesoup.types.update import KernelParticleStateUpdate

from ..core import akkf as ft_akkf
from ..core import kalman as ft_kalman
from ..core import particle as ft_particle
from ..core import unscented as ft_unscented
from ..types import dense_kernel_covar
from ._convert import (fast_kernel, fast_model, fits, floats, kernel_filter_refusal,
                       model_rng, plain_particles, sigma_parameters, uncached, zero_control)
from ._fallback import fall_back, keywords, overridden, unknown_kernel, unknown_model
from ._objects import from_state
from .state import kernel_factors, remember_factors

#: Gaussian state types whose predictions the Kalman kernel builds, with the weight and tag
#: of a mixture component carried as Stone Soup carries them (not the square-root or other
#: specialised ones, which go through Stone Soup).
_GAUSSIAN_STATES = tuple(getattr(module, f"{kind}GaussianState{stage}")
                         for kind in ("", "Weighted", "TaggedWeighted")
                         for module, stage in ((ss_state, ""), (ss_prediction, "Prediction"),
                                               (ss_update, "Update")))


def _seconds(later, earlier):
    return (later - earlier).total_seconds()


def _timestamps(timestamp, prior):
    """The reason a prediction without both times needs Stone Soup's code, or None."""
    if timestamp is None or prior.timestamp is None:
        return "no timestamp (prediction or prior)"
    return None


class ParticlePredictor(ss_particle.ParticlePredictor):
    """Stone Soup's ``ParticlePredictor``, compiled for its built-in linear models."""

    _stonesoup = ss_particle.ParticlePredictor  # (bound here: a script may patch the module)

    def _refusal(self, prior, timestamp, kwargs):
        """Why Stone Soup's code must run this prediction, or None."""
        proposal = self.proposal
        if type(proposal) is not DynamicsProposal:
            return f"proposal {type(proposal).__name__}"
        if proposal.control_model is not None:
            return "a control model"
        if fast_model(proposal.transition_model) is None:
            return unknown_model(proposal.transition_model)
        if reason := keywords(kwargs, self):
            return reason
        if not plain_particles(prior):
            return f"prior {type(prior).__name__} indexes its particles its own way"
        return _timestamps(timestamp, prior)

    @predict_lru_cache()
    def predict(self, prior, timestamp=None, measurement=None, **kwargs):
        proposal = self.proposal
        if measurement is not None:
            timestamp = measurement.timestamp
        reason = self._refusal(prior, timestamp, kwargs)
        if reason:
            fall_back(self, "predict", reason)
            return uncached(self._stonesoup.predict)(
                self, prior, timestamp, measurement, **kwargs)
        model = fast_model(proposal.transition_model)
        state = ft_particle.predict(model, floats(prior.state_vector),
                                    _seconds(timestamp, prior.timestamp),
                                    model_rng(proposal.transition_model))
        return Prediction.from_state(prior, parent=prior, state_vector=StateVectors(state),
                                     timestamp=timestamp,
                                     transition_model=proposal.transition_model, prior=prior)


#: The methods of Stone Soup's Kalman predictors that the fast path computes itself: a
#: subclass that overrides one runs Stone Soup's code.
_HOOKS = ("_transition_matrix", "_transition_function", "_control_matrix",
          "_predict_over_interval", "_predicted_covariance")


class _Kalman:
    """``predict`` of the Kalman predictors through one of fasttrack's Gaussian kernels."""

    _stonesoup = ss_kalman.KalmanPredictor

    def _moments(self, model, dt, x, covar):
        """``(x, P)`` predicted by the kernel, or the reason Stone Soup's code must run."""
        return ft_kalman.predict(model, dt, x, covar)

    def _refusal(self, prior, timestamp, control_input, kwargs):
        """Why Stone Soup's code must run this prediction, or None."""
        model = fast_model(self.transition_model)
        if model is None:
            return unknown_model(self.transition_model)
        hook = overridden(self, self._stonesoup, _HOOKS)
        if hook:
            return hook
        if reason := keywords(kwargs, self):
            return reason
        if control_input is not None or not zero_control(self.control_model):
            return "a control input"
        if type(prior) not in _GAUSSIAN_STATES:
            return f"prior {type(prior).__name__}"
        if not fits(prior, model.ndim_state):
            return f"prior of the wrong shape for {model.ndim_state} dimensions"
        return _timestamps(timestamp, prior)

    @predict_lru_cache()
    def predict(self, prior, timestamp=None, control_input=None, **kwargs):
        reason = self._refusal(prior, timestamp, control_input, kwargs)
        moments = reason or self._moments(
            fast_model(self.transition_model), _seconds(timestamp, prior.timestamp),
            floats(prior.state_vector), floats(prior.covar))
        if isinstance(moments, str):
            fall_back(self, "predict", moments)
            return uncached(self._stonesoup.predict)(self, prior, timestamp, control_input,
                                                     **kwargs)
        mean, covar = moments
        return from_state(Prediction, prior, state_vector=mean.view(StateVector),
                          covar=covar.view(CovarianceMatrix), timestamp=timestamp,
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
    ``alpha**2 (ndim + kappa)`` outside [1e-12, 1e100]) and covariances without a Cholesky
    factor (for which Stone Soup regularises the factor) go through Stone Soup's code.
    """

    _stonesoup = ss_kalman.UnscentedKalmanPredictor
    # its own method object: the associators' batched path computes the Kalman ones only
    predict = predict_lru_cache()(uncached(_Kalman.predict))

    def _moments(self, model, dt, x, covar):
        parameters = sigma_parameters(self, x.shape[0])
        if parameters is None:
            return "sigma-point parameters outside fasttrack's range"
        try:
            return ft_unscented.predict(model, dt, x, covar, *parameters)
        except ValueError as error:  # no Cholesky factor, which Stone Soup regularises
            return f"refused by fasttrack ({error})"


class AdaptiveKernelKalmanPredictor(ss_kernel.AdaptiveKernelKalmanPredictor):
    """Stone Soup's ``AdaptiveKernelKalmanPredictor``, computed in fasttrack's factored form
    (see ``fasttrack.AdaptiveKernelKalmanPredictor``)."""

    _stonesoup = ss_kernel.AdaptiveKernelKalmanPredictor

    def _refusal(self, prior, timestamp, kwargs):
        """Why Stone Soup's code must run this prediction, or None."""
        if fast_model(self.transition_model) is None:
            return unknown_model(self.transition_model)
        if fast_kernel(self.kernel) is None:
            return unknown_kernel(self.kernel)
        return (keywords(kwargs, self) or _timestamps(timestamp, prior)
                or kernel_filter_refusal(self.lambda_predictor, "lambda_predictor",
                                         prior.weight))

    @predict_lru_cache()
    def predict(self, prior, timestamp=None, proposal=None, **kwargs):
        reason = self._refusal(prior, timestamp, kwargs)
        if reason:
            fall_back(self, "predict", reason)
            return uncached(self._stonesoup.predict)(
                self, prior, timestamp, proposal, **kwargs)
        model = fast_model(self.transition_model)
        kernel = fast_kernel(self.kernel)
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
