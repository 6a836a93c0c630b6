"""Predictors: ``predictor.predict(prior, timestamp)``."""

from . import _validate
from . import random as _random
from .core import akkf as _akkf
from .core import kalman as _kalman
from .core import particle as _particle
from .core import unscented as _unscented
from .kernel import as_kernel
from .models.base import check_model
from .models.transition import TransitionModel
from .types import (GaussianState, GaussianStatePrediction, KernelParticleState,
                    KernelParticleStatePrediction, ParticleState, ParticleStatePrediction,
                    check_timestamp, time_interval, weak)


def _interval(prior, timestamp):
    """Seconds from the prior's timestamp to ``timestamp``, with clear errors."""
    check_timestamp(timestamp)
    if timestamp is None:
        raise ValueError("predict needs a timestamp")
    if prior.timestamp is None:
        raise ValueError("the prior has no timestamp, so the prediction interval is unknown")
    return time_interval(timestamp, prior.timestamp)


class ParticlePredictor:
    """Moves every particle through the transition model, with process noise.

    Parameters
    ----------
    transition_model : TransitionModel
    rng : None, int or numpy.random.Generator
        Source of the process noise (None: the package default generator).
    """

    def __init__(self, transition_model, rng=None):
        check_model(transition_model, TransitionModel, "transition_model")
        self.transition_model = transition_model
        self.rng = _random.check_rng(rng)

    def predict(self, prior, timestamp):
        """Propagate ``prior`` to ``timestamp``.

        Parameters
        ----------
        prior : ParticleState
        timestamp : datetime.datetime or float seconds
            Of the same kind as the prior's timestamp.

        Returns
        -------
        ParticleStatePrediction
            New (d, N) particles; the prior's ``log_weight`` array (shared, unchanged);
            ``parent`` and ``prior`` both the prior (weak links: see
            :mod:`fasttrack.types`); ``transition_model``; ``timestamp``.
        """
        if not isinstance(prior, ParticleState):
            raise TypeError(f"prior must be a ParticleState, got {type(prior).__name__}")
        if prior.ndim != self.transition_model.ndim_state:
            raise ValueError(f"prior has {prior.ndim} state dimensions, the transition model "
                             f"{self.transition_model.ndim_state}")
        dt = _interval(prior, timestamp)
        particles = _particle.predict(self.transition_model, prior.state_vector, dt, self.rng)
        link = weak(prior)
        return ParticleStatePrediction._trusted(
            particles, prior.log_weight, timestamp=timestamp, parent=link, _prior=link,
            transition_model=self.transition_model, fixed_covar=prior.fixed_covar)


def _gaussian_prior(prior, ndim):
    if not isinstance(prior, GaussianState):
        raise TypeError(f"prior must be a GaussianState, got {type(prior).__name__}")
    if prior.state_vector.shape[0] != ndim:
        raise ValueError(f"prior has {prior.ndim} state dimensions, the transition model {ndim}")


class KalmanPredictor:
    """Kalman prediction through a linear-Gaussian transition model:
    ``x = F x``, ``P = F P F^T + Q``.

    Parameters
    ----------
    transition_model : linear-Gaussian TransitionModel (with ``matrix``)
    """

    def __init__(self, transition_model):
        check_model(transition_model, TransitionModel, "transition_model")
        self._check_model(transition_model)
        self.transition_model = transition_model

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
            If the prior's covariance is not positive semi-definite, or a user transition
            function returns a wrong shape or non-finite values.
        """
        model = self.transition_model
        _gaussian_prior(prior, model.ndim_state)
        dt = _interval(prior, timestamp)
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

    def __init__(self, transition_model, jacobian="forward"):
        super().__init__(transition_model)
        self.jacobian = _kalman.check_jacobian(jacobian, ("forward", "central"))

    def _check_model(self, model):
        pass


class UnscentedKalmanPredictor:
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
        must be > 0.
    """

    def __init__(self, transition_model, alpha=0.5, beta=2.0, kappa=None):
        check_model(transition_model, TransitionModel, "transition_model")
        _unscented.check_transition(transition_model)
        self.transition_model = transition_model
        self.alpha, self.beta, self.kappa = _unscented.check_parameters(alpha, beta, kappa)
        # a transition model keeps its dimension (a combined model refuses a new model_list
        # of another size), and summing the parts' dimensions costs more than the kernel
        self._ndim = transition_model.ndim_state
        self._kappa = _unscented.scaling(self.alpha, self.kappa, self._ndim)

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
            If the prior's covariance is not symmetric positive semi-definite, or the
            user's transition function returns a wrong shape or non-finite values.
        """
        model = self.transition_model
        _gaussian_prior(prior, self._ndim)
        dt = _interval(prior, timestamp)
        x_out, covar_out = _unscented.predict(model, float(dt), prior.state_vector,
                                              prior.covar, self.alpha, self.beta, self._kappa)
        return GaussianStatePrediction._trusted(
            x_out, covar_out, timestamp, {"transition_model": model, "_prior": weak(prior)})


class AdaptiveKernelKalmanPredictor:
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
        check_model(transition_model, TransitionModel, "transition_model")
        self.transition_model = transition_model
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
        if not isinstance(prior, KernelParticleState):
            raise TypeError(f"prior must be a KernelParticleState, got {type(prior).__name__}")
        model = self.transition_model
        if prior.ndim != model.ndim_state:
            raise ValueError(f"prior has {prior.ndim} state dimensions, the transition model "
                             f"{model.ndim_state}")
        dt = _interval(prior, timestamp)
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
