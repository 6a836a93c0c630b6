"""Interacting multiple models (IMM): :class:`IMMPredictor` and :class:`IMMUpdater` on a
:class:`~fasttrack.types.GaussianMixture` of one component a model, with any Kalman-type
predictors and updaters as the models, and :class:`BatchIMMFilter` on stacks of filters
(see :mod:`fasttrack.core.imm`)."""
import numpy as np

from . import _validate
from ._states import step_intervals
from .batch import ModelSetSettings
from .core import imm as _imm
from .core import imm_smooth as _imm_smooth
from .core.mixture import check_covariances, check_finite_moments
from .models.measurement import LinearGaussian
from .predictor.base import Predictor
from .predictor.kalman import KalmanPredictor
from .types.gaussian import GaussianState
from .types.mixture import GaussianMixture
from .types.tracks import SingleHypothesis
from .updater.base import Updater
from .updater.kalman import KalmanUpdater

__all__ = ["BatchGPBFilter", "BatchIMMFilter", "IMMPredictor", "IMMUpdater"]


class _Models:
    """A list of per-model predictors or updaters and the switching matrix."""

    def __init__(self, models, transition_matrix, name, kind):
        self._models = _validate.instances(models, kind, name)
        if not self._models:
            raise ValueError(f"{name} must hold at least one model's")
        self.transition_matrix = transition_matrix

    #: The (M, M) switching matrix (a copy, checked when assigned, here or later).
    transition_matrix = _validate.Setting("_checked_matrix")

    def _checked_matrix(self, matrix, name):
        return _imm.transition_matrix(matrix, len(self._models))

    def _mixture(self, mixture, name):
        """``mixture`` checked: a GaussianMixture of one component a model; its mode
        probabilities (the weights, summing to one)."""
        if not isinstance(mixture, GaussianMixture):
            raise TypeError(f"{name} must be a GaussianMixture (one component a model), got "
                            f"{type(mixture).__name__}")
        if len(mixture) != len(self._models):
            raise ValueError(f"{name} must have {len(self._models)} components (one a model), "
                             f"got {len(mixture)}")
        probs = np.exp(mixture.log_weights)
        if abs(probs.sum() - 1.0) <= _imm.SUM_TOLERANCE:  # >= 0 and finite: exp of a mixture's
            return probs
        return _imm.mode_probabilities(probs, probs.shape, f"{name}'s weights")


class IMMPredictor(_Models):
    """The IMM's prediction: each model's prior mixed from all models' (the interaction),
    then predicted by that model's predictor.

    Parameters
    ----------
    predictors : sequence of M predictors
        E.g. ``[KalmanPredictor(model) for model in transition_models]`` (Kalman, extended
        or unscented), one a model, of the state's dimension (a model of fewer components
        embedded, as :class:`BatchIMMFilter` describes).
    transition_matrix : (M, M) array_like
        ``transition_matrix[i, j]``: the probability of switching from model i to model j;
        rows sum to one.
    """

    def __init__(self, predictors, transition_matrix):
        super().__init__(predictors, transition_matrix, "predictors", Predictor)
        self.predictors = self._models

    def predict(self, prior, timestamp):
        """The models' predictions.

        Parameters
        ----------
        prior : GaussianMixture
            One component a model, its weight the model's probability (weights summing to
            one), e.g. ``GaussianMixture([WeightedGaussianState(x, P, weight=mu, timestamp=t),
            ...])``.
        timestamp : datetime.datetime or float
            The time to predict to.

        Returns
        -------
        GaussianMixture
            Each model's prediction, weighted by its predicted probability
            ``c_j = sum_i p_ij mu_i``.
        """
        probs = self._mixture(prior, "prior")
        has = self._components(prior.means.shape[1])
        fast = self._kernel_prediction(prior, probs, timestamp, has)
        if fast is not None:
            return fast
        _imm.covariances(prior.covars, "prior.covars")  # named here: mixing would hide it
        means, covars, predicted = _imm.mix(prior.means[None], prior.covars[None], probs[None],
                                            self.transition_matrix, has)
        states = [predictor.predict(GaussianState(means[0, j], covars[0, j],
                                                  timestamp=prior.timestamp),
                                    timestamp=timestamp)
                  for j, predictor in enumerate(self.predictors)]
        return _stacked(states, predicted[0], timestamp)

    def _components(self, d):
        """:func:`fasttrack.core.imm.components` of the predictors' models in a state of
        dimension d (remembered for the models and d)."""
        models = [p.transition_model for p in self.predictors]
        key = (d, tuple(map(id, models)))
        if self.__dict__.get("_known", (None,))[0] != key:
            self._known = (key, _imm.components(models, d), models)
        return self._known[1]

    def _kernel_prediction(self, prior, probs, timestamp, has):
        """:meth:`predict` in one kernel call where every predictor is a
        :class:`~fasttrack.KalmanPredictor`; else None."""
        if any(type(p) is not KalmanPredictor for p in self.predictors):
            return None
        dt = Predictor._interval(prior, timestamp)
        out = _imm.predict([p.transition_model for p in self.predictors],
                           self.transition_matrix, prior.means[None], prior.covars[None],
                           probs[None], dt, has)
        return None if out is None else _stacked_arrays(out[0][0], out[1][0], out[2][0],
                                                        timestamp)


class IMMUpdater(_Models):
    """The IMM's update: each model's prediction updated by its updater, and the models
    reweighed by their measurement likelihoods (in logs).

    Parameters
    ----------
    updaters : sequence of M updaters
        E.g. ``[KalmanUpdater(measurement_model)] * M`` (Kalman, extended or unscented),
        one a model.
    transition_matrix : (M, M) array_like
        The predictor's (checked: one row a model).
    """

    def __init__(self, updaters, transition_matrix):
        super().__init__(updaters, transition_matrix, "updaters", Updater)
        self.updaters = self._models

    def update(self, hypothesis):
        """The posterior mixture.

        Parameters
        ----------
        hypothesis : SingleHypothesis
            An :meth:`IMMPredictor.predict` result and a :class:`~fasttrack.Detection`.

        Returns
        -------
        GaussianMixture
            Each model's posterior, weighted by its posterior probability; ``mean`` and
            ``covar`` are the combined estimate.
        """
        if not isinstance(hypothesis, SingleHypothesis):
            raise TypeError(f"hypothesis must be a SingleHypothesis, got "
                            f"{type(hypothesis).__name__}")
        predicted = self._mixture(hypothesis.prediction, "hypothesis.prediction")
        check_covariances(hypothesis.prediction.covars, "hypothesis.prediction.covars")
        detection = hypothesis.measurement
        if detection is None:
            raise ValueError("hypothesis.measurement is None: an IMM update needs a detection")
        prediction = hypothesis.prediction
        fast = self._kernel_update(prediction, predicted, detection)
        if fast is not None:
            return fast
        states, log_likelihoods = [], np.empty(len(self.updaters))
        for j, updater in enumerate(self.updaters):
            single = SingleHypothesis(GaussianState(prediction.means[j], prediction.covars[j],
                                                    timestamp=prediction.timestamp), detection)
            states.append(updater.update(single))
            model = detection.measurement_model or updater.measurement_model
            z_hat = single.measurement_prediction
            log_likelihoods[j] = _imm.log_gaussian(
                model, detection.state_vector.T, z_hat.state_vector.T, z_hat.covar[None])[0]
        with np.errstate(divide="ignore"):
            log_posterior = np.log(predicted) + log_likelihoods
        with np.errstate(invalid="ignore"):
            log_posterior -= log_posterior.max()
            posterior = np.exp(log_posterior) / np.exp(log_posterior).sum()
        return _stacked(states, _imm.weighed(posterior, "hypothesis.measurement"),
                        detection.timestamp)


    def _kernel_update(self, prediction, predicted, detection):
        """:meth:`update` in one kernel call where every updater is a Joseph-form
        :class:`~fasttrack.KalmanUpdater` and all use one measurement model of the
        prediction's dimension; else None."""
        if any(type(u) is not KalmanUpdater or not u.use_joseph_cov for u in self.updaters):
            return None
        models = {id(detection.measurement_model or u.measurement_model): u
                  for u in self.updaters}
        if len(models) != 1:
            return None
        model = detection.measurement_model or self.updaters[0].measurement_model
        if not isinstance(model, LinearGaussian) \
                or model.ndim_state != prediction.means.shape[1]:
            return None
        z = model.measurement_column(detection, "hypothesis.measurement")
        out = _imm.update(model, prediction.means[None], prediction.covars[None],
                          predicted[None], z.T, "hypothesis.measurement")
        return None if out is None else _stacked_arrays(out[0][0], out[1][0], out[2][0],
                                                        detection.timestamp)


def _stacked(states, weights, timestamp):
    """A GaussianMixture of Gaussian ``states`` with ``weights`` at ``timestamp``."""
    return _stacked_arrays(np.array([s.state_vector[:, 0] for s in states]),
                           np.array([s.covar for s in states]), weights, timestamp)


def _stacked_arrays(means, covars, weights, timestamp):
    """A GaussianMixture of means (M, d), covariances (M, d, d) and ``weights`` (M,) at
    ``timestamp``."""
    if weights.min() > 0.0:
        log_weights = np.log(weights)
    else:
        with np.errstate(divide="ignore"):
            log_weights = np.log(weights)
    return GaussianMixture._made(means, covars, log_weights,
                                 np.zeros(len(weights), dtype=np.int64), timestamp)


class BatchIMMFilter(ModelSetSettings):
    """K independent IMM filters, each a bank of M Kalman filters (one a transition model)
    sharing a measurement model: mix, predict and update each model, weigh the models by
    their measurement likelihoods (in logs), and combine.

    Parameters
    ----------
    transition_models : sequence of TransitionModel
        M models of the state's dimension d (e.g. constant velocity with two noise levels,
        or constant velocity and :class:`~fasttrack.ConstantTurn`): linear-Gaussian, or
        built from a function and then linearised at each model's mixed prior mean by
        forward finite differences (the extended Kalman filter's prediction, as
        :class:`~fasttrack.ExtendedKalmanPredictor`). A model of fewer components sits in
        the state through an explicit map,
        :class:`~fasttrack.models.transition.EmbeddedTransitionModel` (e.g. constant
        velocity (x, vx, y, vy) in a constant-acceleration state (x, vx, ax, y, vy, ay)
        with ``state_map=(0, 1, 3, 4)``): a model entering another's prior brings the
        components it has, and the other model's own mean, variance and covariances stand
        for those it lacks (so no variance is lost or invented); a model's components that
        it lacks are 0 in its arrays, and :meth:`combine` counts them as 0 (a
        constant-velocity model's acceleration).
    measurement_model : MeasurementModel
        A built-in model (linear, or polar through the extended Kalman filter).
    transition_matrix : (M, M) array_like
        ``transition_matrix[i, j]``: the probability of switching from model i to model j
        in one step; rows sum to one. One model (a 1 x 1 matrix) is the Kalman filter.

    Examples
    --------
    >>> import numpy as np, fasttrack as ft
    >>> models = [ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)
    ...           for q in (0.01, 10.0)]
    >>> imm = ft.BatchIMMFilter(models, ft.LinearGaussian(4, (0, 2), np.eye(2)),
    ...                         [[0.95, 0.05], [0.05, 0.95]])
    >>> means, covars = np.zeros((1, 2, 4)), np.broadcast_to(np.eye(4), (1, 2, 4, 4))
    >>> means, covars, probs = imm.step(means, covars, [[0.5, 0.5]], [[1.0, 0.0]], 1.0)
    >>> probs.shape
    (1, 2)
    """

    @property
    def algorithm(self):
        """The multiple-model algorithm of :meth:`step` (one of ``core.imm.ALGORITHMS``)."""
        return "imm"

    def __init__(self, transition_models, measurement_model, transition_matrix):
        self.measurement_model = measurement_model
        self.transition_models = transition_models
        self.transition_matrix = transition_matrix

    def step(self, means, covars, mode_probs, measurements, time_intervals):
        """One IMM step of every filter.

        Parameters
        ----------
        means : (K, M, d) array_like
            Each filter's model means.
        covars : (K, M, d, d) array_like
            Positive semi-definite.
        mode_probs : (K, M) array_like
            Each filter's mode probabilities (rows sum to one).
        measurements : (K, m) array_like
        time_intervals : float or (K,) array_like
            Seconds from each filter's state to its measurement.

        Returns
        -------
        means, covars, mode_probs : (K, M, d), (K, M, d, d), (K, M) ndarray
            Each model's posterior and the posterior mode probabilities.

        Raises
        ------
        ValueError
            For arrays of the wrong shape or values, or a step that is undefined (naming
            the filter and the model).
        """
        means, covars, mode_probs = self._stacks(means, covars, mode_probs, "(K, ",
                                                 values=False)
        k = means.shape[0]
        m = self.measurement_model.ndim_meas
        measurements = _validate.float_array(measurements, "measurements", 2)
        if measurements.shape != (k, m):
            raise ValueError(f"measurements must have shape ({k}, {m}), got "
                             f"{measurements.shape}")
        if not _imm.values_valid(means, covars, mode_probs, measurements):
            self._stacks(means, covars, mode_probs, "(K, ")  # raises, naming the argument
            _validate.finite_array(measurements, "measurements", 2)
            _imm.covariances(covars)
        self.measurement_model.check_angle_columns(measurements, "measurements")
        intervals = _validate.intervals(time_intervals, (k,))
        if k == 0:
            return means.copy(), covars.copy(), mode_probs.copy()
        return _imm.step(self.transition_models, self.measurement_model,
                         self.transition_matrix, means, covars, mode_probs, measurements,
                         intervals, self.algorithm, self._has)

    def smooth(self, means, covars, mode_probs, time_intervals):
        """The fixed-interval IMM smoother of Kim (1994): each track's states and mode
        probabilities given all its measurements, from the filtered ones (:meth:`step`'s
        outputs, in time order).

        Backwards from the last step, with ``c_j = sum_i p_ij mu_i(t)`` the predicted
        probability of model j at t + 1, model i's smoothed probability at t is
        ``mu_i(t|T) = mu_i(t) sum_j p_ij mu_j(t+1|T) / c_j``, and its smoothed state the
        moment match over j (weights proportional to ``p_ij mu_j(t+1|T) / c_j``) of one
        Rauch-Tung-Striebel step from model i's filtered state through model j's dynamics
        to model j's smoothed state. With one model (or identical models) this is the RTS
        smoother. A model built from a function is linearised at model i's filtered mean
        (forward differences, as :meth:`step` predicts it): the extended smoother. Models
        of different components: the step from model i through model j starts from model
        i's state with the components it lacks taken from model j (as the mixing takes
        them), learns from model j's smoothed components only, and keeps model i's.

        The smoother takes the model at t + 1 to be independent of the state at t given the
        models' probabilities, so a model's smoothed state follows that model's dynamics
        back over the runs the switching matrix makes likely. With process noise well below
        the motion's (q = 1e-3 for a target of q = 1e-2), unlikely turn models then drift
        and the smoothed estimate can be worse than the filtered one; with the motion's own
        noise it is better (0.59 m against 0.90 m on the manoeuvring scenario).

        Parameters
        ----------
        means : (T, M, d) or (K, T, M, d) array_like
            Filtered model means of one track, or of K tracks on the same time steps.
        covars : (T, M, d, d) or (K, T, M, d, d) array_like
            Filtered covariances, symmetric positive semi-definite.
        mode_probs : (T, M) or (K, T, M) array_like
            Filtered mode probabilities (rows sum to one).
        time_intervals : float, datetime.timedelta or (T - 1,) sequence
            Seconds from each step to the next.

        Returns
        -------
        means, covars, mode_probs : ndarray
            The smoothed arrays, of the inputs' shapes (combine them with :meth:`combine`).

        Raises
        ------
        ValueError
            For arrays of the wrong shape or values, or a step that cannot be smoothed
            (naming the track, the time and the model).
        """
        single = np.ndim(means) == 3
        means, covars, mode_probs = self._stacks(means, covars, mode_probs,
                                                 "(T, " if single else "(K, T, ")
        if single:
            means, covars, mode_probs = means[None], covars[None], mode_probs[None]
        n = means.shape[1]
        if n == 0:
            raise ValueError("means must hold at least one time step, got T = 0")
        intervals = step_intervals(time_intervals, n)
        out_means, out_covars, out_probs, status = _imm_smooth.smooth(
            self.transition_models, self.transition_matrix, means, covars, mode_probs,
            intervals, self._has, single)
        failed = np.flatnonzero(status)
        if failed.size:
            track, code = failed[0], status[failed[0]]
            where = "" if single else f"{track}, "
            if code < 0:
                t, i = divmod(-code - 1, len(self.transition_models))
                raise ValueError(f"covars[{where}{t}, {i}] is not symmetric positive "
                                 f"semi-definite")
            raise ValueError(f"the prediction from step {where}{code - 1} to the next (from "
                             f"one model through another) is not positive definite: cannot "
                             f"form the smoothing gain")
        if not all(np.isfinite(a).all() for a in (out_means, out_covars, out_probs)):
            raise ValueError("the smoothed states are not finite: the states' magnitudes (or "
                             "their differences between models, squared) overflow float64 "
                             "(means beyond about 1e150)")
        if single:
            return out_means[0], out_covars[0], out_probs[0]
        return out_means, out_covars, out_probs

    def _stacks(self, means, covars, mode_probs, lead, values=True):
        """``(means, covars, mode_probs)`` validated: (..., M, d), (..., M, d, d) and
        (..., M) of equal leading shape (``lead`` names it: '(K, ' or '(K, T, '), and with
        ``values`` their values (finite; mode probabilities >= 0, rows summing to one)."""
        models, d = len(self.transition_models), self.measurement_model.ndim_state
        ndim = lead.count(",") + 2
        array = _validate.finite_array if values else _validate.float_array
        means = array(means, "means", ndim)
        head = means.shape[:-2]
        if means.shape[-2:] != (models, d):
            raise ValueError(f"means must have shape {lead}{models}, {d}), got {means.shape}")
        covars = array(covars, "covars", ndim + 1)
        if covars.shape != head + (models, d, d):
            raise ValueError(f"covars must have shape {head + (models, d, d)}, got "
                             f"{covars.shape}")
        return means, covars, _imm.mode_probabilities(mode_probs, head + (models,),
                                                      values=values)

    @staticmethod
    def combine(means, covars, mode_probs):
        """Each filter's combined estimate, the moment match of its models.

        Parameters
        ----------
        means : (..., M, d) array_like
            E.g. (K, M, d) from :meth:`step` or (K, T, M, d) from :meth:`smooth`.
        covars : (..., M, d, d) array_like
        mode_probs : (..., M) array_like

        Returns
        -------
        means, covars : (..., d), (..., d, d) ndarray
        """
        means = _validate.finite_array(means, "means")
        if means.ndim < 2 or not means.shape[-1]:
            raise ValueError(f"means must have shape (..., M, d), d >= 1, got {means.shape}")
        covars = _validate.finite_array(covars, "covars")
        if covars.shape != means.shape + means.shape[-1:]:
            raise ValueError(f"covars must have shape {means.shape + means.shape[-1:]}, got "
                             f"{covars.shape}")
        _imm.covariances(covars)
        mode_probs = _imm.mode_probabilities(mode_probs, means.shape[:-1])
        mean, covar = _imm.combine(means, covars, mode_probs)
        check_finite_moments(mean, covar)
        return mean, covar


class BatchGPBFilter(BatchIMMFilter):
    """K independent generalised pseudo-Bayesian (GPB) filters, each a bank of M Kalman
    filters (one a transition model) sharing a measurement model: :class:`BatchIMMFilter`'s
    arrays and methods, with another prior for each model.

    - ``order=1`` (GPB1): every model starts from the moment match of all the filter's
      models (one Gaussian), then is predicted, updated and weighed.
    - ``order=2`` (GPB2): every model j predicts and updates every model i's posterior
      (M^2 Kalman steps a filter); model j's posterior is the moment match of the M pairs,
      weighted by ``p_ij mu_i`` times their measurement likelihoods, which sum to its
      probability (in logs). A model that nothing switches into (``p_ij mu_i = 0`` for
      every i) keeps its own posterior, updated, and probability 0.

    Parameters
    ----------
    transition_models : sequence of TransitionModel
        As :class:`BatchIMMFilter`'s.
    measurement_model : MeasurementModel
        As :class:`BatchIMMFilter`'s.
    transition_matrix : (M, M) array_like
        As :class:`BatchIMMFilter`'s.
    order : {1, 2}
        The length of the model histories kept before merging.
    """

    def __init__(self, transition_models, measurement_model, transition_matrix, order=2):
        self.order = order
        super().__init__(transition_models, measurement_model, transition_matrix)

    #: Checked when assigned (here or later).
    order = _validate.Setting("_checked_order")

    @staticmethod
    def _checked_order(order, name):
        if not _validate.is_integer(order):
            raise TypeError(f"{name} must be an int, 1 or 2 (GPB1 or GPB2), got "
                            f"{type(order).__name__}")
        if order not in (1, 2):
            raise ValueError(f"{name} must be 1 or 2 (GPB1 or GPB2), got {order!r}")
        return int(order)

    @property
    def algorithm(self):
        """The multiple-model algorithm of :meth:`step`: 'gpb1' or 'gpb2'."""
        return f"gpb{self.order}"
