"""An interacting multiple model (IMM) predictor and updater on Stone Soup's types.

Stone Soup 1.9 has no IMM; these follow its call patterns (``predict(prior, timestamp)``,
``update(hypothesis)``) and take its ``GaussianMixture`` of ``WeightedGaussianState``
components (one a model, the weights the mode probabilities) and its Kalman predictors and
updaters as the models. The mixing is the textbook IMM's moment match (deterministic). Where
every model is a Kalman predictor (updater) of a built-in linear model, a step runs in one
fasttrack kernel call; otherwise each model's own predictor (updater) runs.
"""
import numpy as np
from stonesoup.predictor import kalman as ss_predictor
from stonesoup.predictor.base import Predictor
from stonesoup.types.array import StateVector
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.mixture import GaussianMixture
from stonesoup.types.prediction import GaussianStatePrediction, WeightedGaussianStatePrediction
from stonesoup.types.state import GaussianState
from stonesoup.types.update import WeightedGaussianStateUpdate
from stonesoup.updater import kalman as ss_updater
from stonesoup.updater.base import Updater

from .. import imm as ft_imm_classes
from ..core import imm as ft_imm
from ..core.mixture import check_covariances, check_finite_moments
from ..models.measurement import LinearGaussian
from . import predictor as ft_predictor
from . import updater as ft_updater
from ._convert import fast_model, floats, zero_control
from ._fallback import fall_back

__all__ = ["IMMPredictor", "IMMUpdater"]

_KALMAN_PREDICTORS = (ss_predictor.KalmanPredictor, ft_predictor.KalmanPredictor)
_KALMAN_UPDATERS = (ss_updater.KalmanUpdater, ft_updater.KalmanUpdater)


class _Models(ft_imm_classes._Models):
    """Per-model predictors or updaters and the switching matrix, on Stone Soup's
    mixtures."""

    def _mixture(self, mixture, name):
        """``(means, covars, probs)`` (M, d), (M, d, d), (M,) of a Stone Soup
        GaussianMixture of one component a model, weights summing to one."""
        if not isinstance(mixture, GaussianMixture):
            raise TypeError(f"{name} must be a Stone Soup GaussianMixture (one component a "
                            f"model), got {type(mixture).__name__}")
        if len(mixture) != len(self._models):
            raise ValueError(f"{name} must have {len(self._models)} components (one a model), "
                             f"got {len(mixture)}")
        components = mixture.components
        probs = ft_imm.mode_probabilities([float(c.weight) for c in components],
                                          (len(components),), f"{name}'s weights")
        means = np.array([floats(c.state_vector).ravel() for c in components])
        covars = np.array([floats(c.covar) for c in components])
        finite = np.isfinite(means).all(axis=1) & np.isfinite(covars).all(axis=(1, 2))
        if not finite.all():
            raise ValueError(f"{name}'s component {np.argmin(finite)} is not finite (its "
                             f"state vector or covariance holds NaN or inf)")
        check_covariances(covars, f"{name}'s covariances")  # (not symmetrised silently)
        return means, covars, probs


class IMMPredictor(_Models):
    """The IMM's prediction on Stone Soup's types: each model's prior mixed from all models'
    (the interaction), then predicted by that model's predictor.

    Parameters
    ----------
    predictors : sequence of M Stone Soup predictors
        Kalman-type (``KalmanPredictor``, ``ExtendedKalmanPredictor``,
        ``UnscentedKalmanPredictor``, from Stone Soup or ``fasttrack.stonesoup``), one a
        model, of one state dimension.
    transition_matrix : (M, M) array_like
        ``transition_matrix[i, j]``: the probability of switching from model i to model j;
        rows sum to one.
    """

    def __init__(self, predictors, transition_matrix):
        super().__init__(predictors, transition_matrix, "predictors", Predictor)
        self.predictors = self._models

    def predict(self, prior, timestamp=None, **kwargs):
        """The models' predictions.

        Parameters
        ----------
        prior : stonesoup.types.mixture.GaussianMixture
            One ``WeightedGaussianState`` a model, its weight the model's probability
            (weights summing to one), all at one time.
        timestamp : datetime.datetime
            The time to predict to.
        **kwargs : keyword arguments
            Passed to each model's predictor.

        Returns
        -------
        stonesoup.types.mixture.GaussianMixture
            ``WeightedGaussianStatePrediction`` components, one a model, weighted by the
            predicted mode probabilities ``c_j = sum_i p_ij mu_i``.
        """
        means, covars, probs = self._mixture(prior, "prior")
        then = prior.components[0].timestamp
        out = self._kernel_prediction(means, covars, probs, then, timestamp, kwargs)
        if out is None:
            with np.errstate(over="ignore", invalid="ignore"):
                mixed_means, mixed_covars, predicted = ft_imm.mix(means[None], covars[None],
                                                                  probs[None],
                                                                  self.transition_matrix)
            check_finite_moments(mixed_means, mixed_covars)  # (the models' mixed priors)
            states = [predictor.predict(GaussianState(StateVector(mixed_means[0, j]),
                                                      mixed_covars[0, j], timestamp=then),
                                        timestamp=timestamp, **kwargs)
                      for j, predictor in enumerate(self.predictors)]
            out = (np.array([floats(s.state_vector).ravel() for s in states]),
                   np.array([floats(s.covar) for s in states]), predicted[0])
        return GaussianMixture([
            WeightedGaussianStatePrediction(StateVector(out[0][j]), out[1][j],
                                            timestamp=timestamp, weight=out[2][j],
                                            transition_model=predictor.transition_model)
            for j, predictor in enumerate(self.predictors)])

    def _kernel_prediction(self, means, covars, probs, then, timestamp, kwargs):
        """``(means, covars, predicted)`` from one kernel call where every predictor is a
        Kalman predictor of a built-in linear model without control; else None."""
        reason = None
        models = [fast_model(p.transition_model) for p in self.predictors]
        if any(type(p) not in _KALMAN_PREDICTORS or not zero_control(p.control_model)
               for p in self.predictors):
            reason = "a predictor that is not a KalmanPredictor without control"
        elif any(m is None or not hasattr(m, "matrix") for m in models):
            reason = "a transition model fasttrack does not compute"
        elif kwargs or timestamp is None or then is None:
            reason = "keyword arguments or no timestamp"
        if reason is None:
            out = ft_imm.predict(models, self.transition_matrix, means[None], covars[None],
                                 probs[None], (timestamp - then).total_seconds())
            if out is not None:
                return out[0][0], out[1][0], out[2][0]
            reason = "the NumPy-first path or an undefined prediction"
        fall_back(self, "predict", reason)
        return None


class IMMUpdater(_Models):
    """The IMM's update on Stone Soup's types: each model's prediction updated by its
    updater, and the models reweighed by their measurement likelihoods (in logs).

    Parameters
    ----------
    updaters : sequence of M Stone Soup updaters
        Kalman-type, one a model.
    transition_matrix : (M, M) array_like
        The predictor's (checked: one row a model).
    """

    def __init__(self, updaters, transition_matrix):
        super().__init__(updaters, transition_matrix, "updaters", Updater)
        self.updaters = self._models

    def update(self, hypothesis, **kwargs):
        """The posterior mixture.

        Parameters
        ----------
        hypothesis : stonesoup.types.hypothesis.SingleHypothesis
            An :meth:`IMMPredictor.predict` result and a ``Detection``.
        **kwargs : keyword arguments
            Passed to each model's updater.

        Returns
        -------
        stonesoup.types.mixture.GaussianMixture
            ``WeightedGaussianStateUpdate`` components, one a model, weighted by the
            posterior mode probabilities (``stonesoup.functions.gm_reduce_single`` of the
            components gives the combined estimate).
        """
        if not isinstance(hypothesis, SingleHypothesis):
            raise TypeError(f"hypothesis must be a Stone Soup SingleHypothesis, got "
                            f"{type(hypothesis).__name__}")
        detection = hypothesis.measurement
        if detection is None:
            raise ValueError("hypothesis.measurement is None: an IMM update needs a detection")
        means, covars, predicted = self._mixture(hypothesis.prediction, "hypothesis.prediction")
        singles = [SingleHypothesis(GaussianStatePrediction(c.state_vector, c.covar,
                                                            timestamp=c.timestamp), detection)
                   for c in hypothesis.prediction.components]
        out = self._kernel_update(means, covars, predicted, detection, kwargs)
        if out is None:
            states = [u.update(single, **kwargs) for u, single in zip(self.updaters, singles)]
            log_likelihoods = [_log_likelihood(u, single) for u, single in
                               zip(self.updaters, singles)]
            with np.errstate(divide="ignore"):
                log_posterior = np.log(predicted) + np.array(log_likelihoods)
            weights = np.exp(log_posterior - log_posterior.max())
            out = (np.array([floats(s.state_vector).ravel() for s in states]),
                   np.array([floats(s.covar) for s in states]), weights / weights.sum())
        return GaussianMixture([
            WeightedGaussianStateUpdate(StateVector(out[0][j]), out[1][j], hypothesis=single,
                                        timestamp=detection.timestamp, weight=out[2][j])
            for j, single in enumerate(singles)])

    def _kernel_update(self, means, covars, predicted, detection, kwargs):
        """``(means, covars, probs)`` from one kernel call where every updater is a Kalman
        updater and all use one built-in linear measurement model; else None."""
        models = {id(detection.measurement_model or u.measurement_model): u
                  for u in self.updaters}
        sensor = fast_model(detection.measurement_model or self.updaters[0].measurement_model)
        reason = None
        if any(type(u) not in _KALMAN_UPDATERS for u in self.updaters):
            reason = "an updater that is not a KalmanUpdater"
        elif len(models) != 1 or not isinstance(sensor, LinearGaussian):
            reason = "measurement models that are not one built-in LinearGaussian"
        elif kwargs:
            reason = "keyword arguments"
        elif means.shape[1] != sensor.ndim_state:
            reason = "components of another dimension than the measurement model's"
        if reason is None:
            z = sensor.measurement_vector(detection, "hypothesis.measurement")[None]
            out = ft_imm.update(sensor, means[None], covars[None], predicted[None], z)
            if out is not None:
                return out[0][0], out[1][0], out[2][0]
            reason = "the NumPy-first path or an undefined update"
        fall_back(self, "update", reason)
        return None


def _log_likelihood(updater, hypothesis):
    """log N(z; z_hat, S) of ``hypothesis``'s detection under ``updater``'s measurement
    prediction (Stone Soup's state vectors subtract angles modulo 2 pi)."""
    model = hypothesis.measurement.measurement_model or updater.measurement_model
    prediction = updater.predict_measurement(hypothesis.prediction, measurement_model=model)
    innovation = floats(hypothesis.measurement.state_vector - prediction.state_vector).ravel()
    lower = np.linalg.cholesky(floats(prediction.covar))
    whitened = np.linalg.solve(lower, innovation)
    return (-0.5 * whitened @ whitened - np.log(np.diagonal(lower)).sum()
            - 0.5 * innovation.size * np.log(2.0 * np.pi))
