"""Interacting multiple models (IMM; Blom and Bar-Shalom 1988) on stacks: K filters, each a
bank of M Kalman filters of one state dimension, as means (K, M, d), covariances
(K, M, d, d) and mode probabilities (K, M). ``transition_matrix[i, j]`` is the probability
of switching from model i to model j; its rows sum to one.

One step mixes each filter's models (the interaction), predicts and updates each model
through the Kalman stack kernels (:mod:`fasttrack.core.kalman`), and weighs the models by
their measurement likelihoods in logs: a measurement far from every model leaves finite,
normalised mode probabilities. A model whose predicted probability is 0 keeps its own
state through the mixing (there is nothing to mix it from) and its probability stays 0.

:mod:`fasttrack.core.imm_smooth` is the fixed-interval smoother."""
import numpy as np

from .. import _jit, _validate
from .. import threads as _threads
from . import jpda as _jpda
from . import kalman as _kalman
from . import kalman_numpy as _kalman_numpy
from .kalman_numpy import wrap
from .kinds import SELECT
from .._jit.status import PRIOR_NOT_PSD, PRIOR_NOT_SYMMETRIC
from .._jit.tunables import SERIAL_BELOW_FILTERS

_imm = _jit.lazy("imm")

#: The :func:`~fasttrack._jit.numpy_first` units of one model of one filter on the general
#: path: about 280 us in NumPy, some eight one-filter Kalman steps.
NUMPY_WORK_PER_MODEL = 8

#: The multiple-model algorithms, in the order of :mod:`fasttrack._jit.imm`'s codes: the
#: interacting multiple model filter, and the generalised pseudo-Bayesian filters of first
#: and second order.
ALGORITHMS = ("imm", "gpb1", "gpb2")

#: How far a row of probabilities may sum from one.
SUM_TOLERANCE = 1e-9


def transition_matrix(matrix, models):
    """A validated (M, M) switching matrix for ``models`` models: finite, >= 0, each row
    summing to one."""
    matrix = _validate.finite_array(matrix, "transition_matrix", 2)
    if matrix.shape != (models, models):
        raise ValueError(f"transition_matrix must have shape ({models}, {models}) (one row "
                         f"and column a model), got {matrix.shape}")
    if (matrix < 0).any():
        raise ValueError("transition_matrix must have no negative entries")
    rows = np.flatnonzero(np.abs(matrix.sum(axis=1) - 1.0) > SUM_TOLERANCE)
    if rows.size:
        raise ValueError(f"each row of transition_matrix must sum to 1 (the probabilities of "
                         f"switching from one model); row {rows[0]} sums to "
                         f"{float(matrix[rows[0]].sum())!r}")
    return matrix.copy()  # (the caller's array stays theirs)


def mode_probabilities(probs, shape, name="mode_probs", values=True):
    """Validated mode probabilities of ``shape`` (..., M): finite, >= 0, each row summing
    to one (without ``values``, only a float64 array of that shape)."""
    probs = (_validate.finite_array if values else _validate.float_array)(probs, name,
                                                                          len(shape))
    if probs.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {probs.shape}")
    if not values:
        return probs
    if (probs < 0).any():
        raise ValueError(f"{name} must have no negative entries")
    sums = probs.sum(axis=-1)
    bad = np.abs(sums - 1.0) > SUM_TOLERANCE
    if bad.ndim == 0 and bad:
        raise ValueError(f"{name} must sum to 1; they sum to {float(sums)!r}")
    if bad.any():
        row = np.unravel_index(np.argmax(bad), bad.shape)
        raise ValueError(f"each row of {name} must sum to 1; row "
                         f"{', '.join(str(int(r)) for r in row)} sums to "
                         f"{float(sums[row])!r}")
    return probs


def values_valid(means, covars, mode_probs, measurements):
    """Whether the values of a step's validated (K, M, d), (K, M, d, d), (K, M) and (K, m)
    arrays are certainly valid: finite, each row of ``mode_probs`` >= 0 and summing to
    one, each covariance symmetric positive semi-definite. Checked by a kernel (in chunks
    on threads) once the process runs kernels; False before (the caller then runs the
    checks that say what is wrong: :func:`covariances` for the covariances)."""
    if not _jit.kernels_loaded():
        return False
    arrays = (means, covars, mode_probs, measurements)
    if mode_probs.size < SERIAL_BELOW_FILTERS:
        return bool(_imm.step_inputs_valid(*arrays, SUM_TOLERANCE))
    verdicts = []
    _threads.in_chunks(lambda lo, hi: verdicts.append(_imm.step_inputs_valid(
        *(a[lo:hi] for a in arrays), SUM_TOLERANCE)), means.shape[0], serial_below=0)
    return all(verdicts)


def covariances(covars, name="covars"):
    """A ValueError naming the first of the (..., d, d) ``covars`` that is not symmetric
    positive semi-definite (the kernels' rule), e.g. ``covars[3, 1]``."""
    d = covars.shape[-1]
    status = _kalman_numpy.covariance_statuses(covars.reshape(-1, d, d), PRIOR_NOT_SYMMETRIC,
                                               PRIOR_NOT_PSD)
    bad = np.flatnonzero(status)
    if bad.size:
        where = ", ".join(str(int(i)) for i in np.unravel_index(bad[0], covars.shape[:-2]))
        what = "symmetric" if status[bad[0]] == PRIOR_NOT_SYMMETRIC else \
            "positive semi-definite"
        raise ValueError(f"{name}[{where}] is not {what}")


def mix(means, covars, mode_probs, matrix, has=None):
    """The IMM interaction: ``(means, covars, predicted)``, each model's mixed prior
    (K, M, d) and (K, M, d, d) and the predicted mode probabilities c_j = sum_i p_ij mu_i
    (K, M). Model j's prior is the moment match of the models i (:func:`converted` into
    model j's components where ``has``, the (M, d) bool mask of each model's components,
    is given) with weights p_ij mu_i / c_j."""
    joint = mode_probs[:, :, None] * matrix[None]  # (K, i, j)
    predicted = joint.sum(axis=1)
    alive = predicted > 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        weights = np.where(alive[:, None, :], joint / predicted[:, None, :],
                           np.eye(matrix.shape[0])[None])
    return (*_matched(weights, *converted(means, covars, has)), predicted)


def converted(means, covars, has=None):
    """Each model i's state in each model j's components: ``(means, covars)`` (K, i, j, d)
    and (K, i, j, d, d). A component of j that i lacks takes model j's own mean, variance and
    covariances with the others i lacks (none with those i has); one that j lacks is 0.
    Without ``has`` (every model has every component), model i's state for every j."""
    models = means.shape[1]
    if has is None:
        shape = means.shape[:2] + (models,)
        return (np.broadcast_to(means[:, :, None], shape + means.shape[2:]),
                np.broadcast_to(covars[:, :, None], shape + covars.shape[2:]))
    from_i = has[:, None, :]  # (i, 1, d): where model i's own component is taken
    out_means = np.where(from_i, means[:, :, None], means[:, None, :]) * has[None, None]
    both = from_i[..., :, None] & from_i[..., None, :]
    neither = ~from_i[..., :, None] & ~from_i[..., None, :]
    out_covars = (np.where(both, covars[:, :, None], 0.0)
                  + np.where(neither, covars[:, None, :], 0.0))
    return out_means, out_covars * (has[:, :, None] & has[:, None, :])[None, None]


def _matched(weights, means, covars):
    """The moment match over i of (K, i, j, d) means and (K, i, j, d, d) covariances with
    weights (K, i, j): (K, j, d) and symmetric (K, j, d, d)."""
    mixed_means = np.einsum("kij,kijd->kjd", weights, means)
    spread = means - mixed_means[:, None]  # (K, i, j, d)
    mixed_covars = (np.einsum("kij,kijab->kjab", weights, covars)
                    + np.einsum("kij,kija,kijb->kjab", weights, spread, spread))
    return mixed_means, 0.5 * (mixed_covars + mixed_covars.swapaxes(-1, -2))


def combine(means, covars, mode_probs):
    """The moment match of each filter's models: ``(means, covars)`` (..., d) and
    (..., d, d) of means (..., M, d), covariances (..., M, d, d) and mode probabilities
    (..., M): ``x = sum_j mu_j x_j`` and ``P = sum_j mu_j (P_j + (x_j - x)(x_j - x)^T)``."""
    mean = np.einsum("...j,...jd->...d", mode_probs, means)
    spread = means - mean[..., None, :]
    covar = (np.einsum("...j,...jab->...ab", mode_probs, covars)
             + np.einsum("...j,...ja,...jb->...ab", mode_probs, spread, spread))
    return mean, 0.5 * (covar + covar.swapaxes(-1, -2))


def step(transition_models, measurement_model, matrix, means, covars, mode_probs,
         measurements, intervals, algorithm="imm", has=None):
    """One multiple-model step of K filters: each model's prior (by ``algorithm``),
    predicted ``intervals`` (K,) seconds ahead and updated with the filter's measurement
    (K, m), and the models weighed.

    Parameters
    ----------
    transition_models : sequence of M TransitionModel
        Linear, or built from a function (linearised by forward differences).
    measurement_model : MeasurementModel
        A built-in model.
    matrix : (M, M) ndarray
        The validated switching matrix (:func:`transition_matrix`).
    means, covars, mode_probs, measurements, intervals : ndarray
        Validated (K, M, d), (K, M, d, d), (K, M), (K, m) and (K,) arrays (C-contiguous
        float64).
    algorithm : {'imm', 'gpb1', 'gpb2'}
        One of :data:`ALGORITHMS`.
    has : (M, d) bool ndarray, optional
        Each model's state components (:func:`components`); None: all.

    Returns
    -------
    means, covars, mode_probs : (K, M, d), (K, M, d, d), (K, M) ndarray
        Each model's posterior and the posterior mode probabilities.

    Raises
    ------
    ValueError
        If a model's prediction or update is undefined, naming the filter and the model.
    """
    fused = _fused(transition_models, measurement_model, matrix, means, covars, mode_probs,
                   measurements, intervals, algorithm, has)
    if fused is None:  # (whose weighing is checked where it normalises)
        return general_step(transition_models, measurement_model, matrix, means, covars,
                            mode_probs, measurements, intervals, algorithm, has)
    weighed(fused[2])
    return fused


def weighed(mode_probs, name="measurements"):
    """``mode_probs`` (K, M) or (M,), each filter's posterior mode probabilities; a
    ValueError naming ``name[k]`` for a filter whose measurement every model's likelihood
    rounds to 0 (its squared Mahalanobis distances beyond the float range: NaN weights)."""
    bad = np.flatnonzero(~np.isfinite(mode_probs).all(axis=-1).reshape(-1))
    if bad.size:
        where = f"{name}[{bad[0]}]" if mode_probs.ndim == 2 and len(mode_probs) > 1 else name
        raise ValueError(f"{where} lies so far from every model's prediction that its "
                         f"likelihood rounds to 0 under each (a squared Mahalanobis distance "
                         f"beyond 1.8e308): the models cannot be weighed")
    return mode_probs


def general_step(transition_models, measurement_model, matrix, means, covars, mode_probs,
                 measurements, intervals, algorithm="imm", has=None):
    """:func:`step` for any models and intervals: priors, weighing and merging on arrays,
    each model's prediction and update through the Kalman stack kernels."""
    if algorithm == "gpb2":
        return _gpb2_step(transition_models, measurement_model, matrix, means, covars,
                          mode_probs, measurements, intervals, has)
    return updates(transition_models, measurement_model,
                   *predictions(transition_models, measurement_model, matrix, means, covars,
                                mode_probs, intervals, algorithm, has), measurements)


def predictions(transition_models, measurement_model, matrix, means, covars, mode_probs,
                intervals, algorithm="imm", has=None):
    """Each model's prior (the IMM's mixing, or GPB1's merging of all models; each model
    :func:`converted` into the components of the model it enters), predicted ``intervals``
    (K,) seconds ahead, and its predicted measurement.

    Returns
    -------
    means, covars, predicted, z_hats, innovations : ndarray
        (K, M, d) and (K, M, d, d) predictions, (K, M) predicted mode probabilities
        ``c_j = sum_i p_ij mu_i``, (K, M, m) predicted measurements and (K, M, m, m)
        innovation covariances.
    """
    models = mode_probs.shape[1]
    if algorithm == "gpb1":  # every model's prior from all models, weighed by mu_i
        *priors, _ = mix(means, covars, mode_probs, np.full((models, models), 1.0 / models),
                         has)
        predicted = mode_probs @ matrix
    else:
        *priors, predicted = mix(means, covars, mode_probs, matrix, has)
    out = [np.empty(means.shape), np.empty(covars.shape),
           np.empty(means.shape[:2] + (measurement_model.ndim_meas,)),
           np.empty(means.shape[:2] + (measurement_model.ndim_meas,) * 2)]
    for j, model in enumerate(transition_models):
        for whole, part in zip(out, _model_prediction(j, model, measurement_model,
                                                      priors[0][:, j], priors[1][:, j],
                                                      intervals)):
            whole[:, j] = part
    return out[0], out[1], predicted, out[2], out[3]


def updates(transition_models, measurement_model, means, covars, predicted, z_hats,
            innovations, measurements):
    """Each model's prediction (:func:`predictions`'s outputs) updated with the filter's
    measurement (K, m), and the models weighed in logs: ``(means, covars, mode_probs)``."""
    out_means, out_covars = np.empty_like(means), np.empty_like(covars)
    log_posterior = np.empty(predicted.shape)
    for j, model in enumerate(transition_models):
        out_means[:, j], out_covars[:, j], log_likelihood = _model_update(
            j, model, measurement_model, means[:, j], covars[:, j], z_hats[:, j],
            innovations[:, j], measurements)
        with np.errstate(divide="ignore"):
            log_posterior[:, j] = np.log(predicted[:, j]) + log_likelihood
    return out_means, out_covars, _normalised(log_posterior)


def jpda_updates(measurement_model, means, covars, predicted, z_hats, innovations,
                 detections, gate, prob_detect, prob_gate, clutter_density,
                 max_nodes=_jpda.MAX_NODES):
    """IMM-JPDA: every track's models updated with the detections of its gate.

    The association uses the tracks' exact mode-mixture likelihoods: pair (t, j) weighs
    ``prob_detect * L_tj / clutter_density`` with ``L_tj = sum_m c_m N(z_j; z_m, S_m)``, the
    missed detection ``1 - prob_detect * prob_gate``, and the JPDA marginals ``beta_tj``
    follow (:func:`fasttrack.core.jpda.gate_marginals`). Given the marginals, the joint
    probability of detection j (0: none) and model m is ``beta_t0 c_m`` or
    ``beta_tj c_m N(z_j; z_m, S_m) / L_tj`` (exact for a track given its marginals; the
    probability of detection does not depend on the model): their sum over j is model m's
    posterior probability, and model m's state is the PDA combination of its own
    innovations with weights ``beta_jm`` (the joint probabilities over it):
    ``x = x_m + K_m sum_j beta_jm v_jm`` and ``P = P_m - (1 - beta_0m) K_m S_m K_m^T +
    K_m (sum_j beta_jm v_jm v_jm^T - v v^T) K_m^T``.

    Parameters
    ----------
    measurement_model : LinearGaussian
    means, covars, predicted, z_hats, innovations : ndarray
        :func:`predictions`' outputs for K tracks of M models.
    detections : (D, m) ndarray
    gate : Gate
        The candidate (track, detection) pairs (e.g. on the mode-combined predicted
        measurements).
    prob_detect, prob_gate, clutter_density : float
    max_nodes : int
        The most nodes of a cluster's EHM net (see :func:`fasttrack.core.jpda.jpda_marginals`).

    Returns
    -------
    means, covars, mode_probs : ndarray
        The updated (K, M, d), (K, M, d, d) and (K, M) arrays.
    marginal_missed : (K,) ndarray
        Each track's probability of no detection.
    """
    owners, chosen = gate.tracks(), gate.detections
    m = detections.shape[1]
    lower = np.linalg.cholesky(innovations)  # (K, M, m, m)
    v = detections[chosen][:, None, :] - z_hats[owners]  # (n, M, m)
    whitened = np.linalg.solve(lower[owners], v[..., None])[..., 0]
    log_det = np.log(np.diagonal(lower, axis1=-2, axis2=-1)).sum(axis=-1)  # (K, M)
    with np.errstate(divide="ignore"):
        log_joint = (np.log(predicted[owners]) - 0.5 * (whitened ** 2).sum(axis=-1)
                     - log_det[owners] - 0.5 * m * np.log(2.0 * np.pi))  # (n, M)
    top = log_joint.max(axis=1, keepdims=True)
    log_mixture = top[:, 0] + np.log(np.exp(log_joint - top).sum(axis=1))  # log L_tj
    marginal_missed, marginal = _jpda.gate_marginals(
        gate, np.log1p(-prob_detect * prob_gate),
        np.log(prob_detect) + log_mixture - np.log(clutter_density), max_nodes)
    pair_joint = marginal[:, None] * np.exp(log_joint - log_mixture[:, None])  # (n, M)
    missed_joint = marginal_missed[:, None] * predicted  # (K, M)
    probs = missed_joint.copy()
    np.add.at(probs, owners, pair_joint)
    alive = probs > 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        missed_weight = np.where(alive, missed_joint / probs, 1.0)
        pair_weight = np.where(alive[owners], pair_joint / probs[owners], 0.0)
    innovation = np.zeros(z_hats.shape)
    np.add.at(innovation, owners, pair_weight[..., None] * v)
    spread = np.zeros(innovations.shape)
    np.add.at(spread, owners, pair_weight[..., None, None] * v[..., :, None] * v[..., None, :])
    spread -= innovation[..., :, None] * innovation[..., None, :]
    cross = covars @ measurement_model.matrix().T  # P H^T (K, M, d, m)
    gain = np.linalg.solve(innovations, cross.swapaxes(-1, -2)).swapaxes(-1, -2)
    out_means = means + (gain @ innovation[..., None])[..., 0]
    out_covars = (covars - (1.0 - missed_weight)[..., None, None] * gain @ innovations
                  @ gain.swapaxes(-1, -2) + gain @ spread @ gain.swapaxes(-1, -2))
    out_covars = 0.5 * (out_covars + out_covars.swapaxes(-1, -2))
    return out_means, out_covars, probs / probs.sum(axis=1, keepdims=True), marginal_missed


def _gpb2_step(transition_models, measurement_model, matrix, means, covars, mode_probs,
               measurements, intervals, has):
    """:func:`general_step` of GPB2: every model j updates every model i's posterior;
    the pairs are merged by ``p_ij mu_i`` times their likelihoods (a model that nothing
    switches into keeps its own posterior, updated, and probability 0)."""
    k, models, d = means.shape
    sources = converted(means, covars, has)  # (K, i, j, d), (K, i, j, d, d)
    pair_z, pair_intervals = (np.repeat(measurements, models, axis=0),
                              np.repeat(intervals, models))
    with np.errstate(divide="ignore"):
        log_prior = np.log(mode_probs[:, :, None] * matrix[None])  # (K, i, j)
    out_means, out_covars = np.empty_like(means), np.empty_like(covars)
    log_posterior = np.empty(mode_probs.shape)
    for j, model in enumerate(transition_models):
        pair_means, pair_covars, log_likelihood = _model_step(
            j, model, measurement_model, sources[0][:, :, j].reshape(k * models, d),
            sources[1][:, :, j].reshape(k * models, d, d), pair_z, pair_intervals)
        log_pair = log_prior[:, :, j] + log_likelihood.reshape(k, models)
        top = log_pair.max(axis=1)
        reached = np.isfinite(top)
        shift = np.where(reached, top, 0.0)[:, None]
        weights = np.where(reached[:, None], np.exp(log_pair - shift), np.eye(models)[j])
        total = weights.sum(axis=1)
        out_means[:, j], out_covars[:, j] = combine(pair_means.reshape(k, models, d),
                                                    pair_covars.reshape(k, models, d, d),
                                                    weights / total[:, None])
        log_posterior[:, j] = np.where(reached, top + np.log(total), -np.inf)
    return out_means, out_covars, _normalised(log_posterior)


def _model_step(j, model, measurement_model, means, covars, measurements, intervals):
    """Model j's prediction and update of the stacked priors (n, d), (n, d, d):
    ``(means, covars, log_likelihoods)``; a ValueError names the model."""
    return _model_update(j, model, measurement_model,
                         *_model_prediction(j, model, measurement_model, means, covars,
                                            intervals), measurements)


def _model_prediction(j, model, measurement_model, means, covars, intervals):
    """Model j's :func:`fasttrack.core.kalman.stack_predict` of stacked priors; a
    ValueError names the model."""
    try:
        return _kalman.stack_predict(model, measurement_model, intervals,
                                     np.ascontiguousarray(means), np.ascontiguousarray(covars),
                                     by_interval=True)
    except ValueError as error:
        raise ValueError(f"model {j} ({type(model).__name__}): {error}") from None


def _model_update(j, model, measurement_model, means, covars, z_hats, innovations,
                  measurements):
    """Model j's update of stacked predictions with their measurements and the log
    likelihoods: ``(means, covars, log_likelihoods)``; a ValueError names the model."""
    try:
        out_means, out_covars = _kalman.stack_update(
            measurement_model, np.ascontiguousarray(means), np.ascontiguousarray(covars),
            measurements)
        return out_means, out_covars, log_gaussian(measurement_model, measurements, z_hats,
                                                   innovations)
    except ValueError as error:
        raise ValueError(f"model {j} ({type(model).__name__}): {error}") from None


def _normalised(log_weights):
    """(K, M) probabilities from log weights, each row's largest finite (checked by
    :func:`weighed`: a row of -inf has none)."""
    top = log_weights.max(axis=1, keepdims=True)
    with np.errstate(invalid="ignore"):
        weights = np.exp(log_weights - top)
        return weighed(weights / weights.sum(axis=1, keepdims=True))


def _fused(transition_models, measurement_model, matrix, means, covars, mode_probs,
           measurements, intervals, algorithm, has):
    """:func:`step` in one kernel call (:func:`fasttrack._jit.imm.imm_linear_step`) for
    linear models, a sensor that selects state components and one interval for every
    filter, once the process runs kernels; None where it does not apply or a filter's step
    is undefined (the general path then names the filter and the model)."""
    sensor = measurement_model.spec
    k, models = mode_probs.shape
    pairs = models if algorithm == "gpb2" else 1
    if sensor.kind != SELECT or np.count_nonzero(sensor.angles) \
            or not all(hasattr(model, "matrix") for model in transition_models) \
            or (k > 1 and (intervals != intervals[0]).any()) \
            or _jit.numpy_first(NUMPY_WORK_PER_MODEL * k * models * pairs):
        return None
    transitions, noises = _matrices(transition_models, float(intervals[0]))
    out = np.empty_like(means), np.empty_like(covars), np.empty_like(mode_probs)
    status = np.empty(k, dtype=np.int64)
    shared = (ALGORITHMS.index(algorithm), transitions, noises, sensor.mapping,
              sensor.noise_covar, matrix, _mask(has, means.shape[1:]))
    arrays = (means, covars, mode_probs, measurements, *out, status)
    serial_below = SERIAL_BELOW_FILTERS // (models * pairs)
    if k < serial_below:
        _imm.imm_linear_step(*shared, *arrays)
    else:
        _threads.in_chunks(lambda lo, hi: _imm.imm_linear_step(
            *shared, *(a[lo:hi] for a in arrays)), k, serial_below=serial_below)
    return out if not np.count_nonzero(status) else None


def predict(transition_models, matrix, means, covars, mode_probs, dt, has=None):
    """The IMM's prediction of K filters ``dt`` seconds ahead in one kernel call
    (:func:`fasttrack._jit.imm.imm_predict`): ``(means, covars, predicted)``, each model's
    prediction from its mixed prior and the predicted mode probabilities, for linear
    ``transition_models``; None where the process runs NumPy first, a prior is not
    positive semi-definite or a prediction is not finite (the caller's general path then
    reports it)."""
    k, models = mode_probs.shape
    if _jit.numpy_first(NUMPY_WORK_PER_MODEL * k * models):
        return None
    transitions, noises = _matrices(transition_models, dt)
    out = np.empty_like(means), np.empty_like(covars), np.empty_like(mode_probs)
    status = np.empty(k, dtype=np.int64)
    _imm.imm_predict(transitions, noises, matrix, _mask(has, means.shape[1:]), means, covars,
                     mode_probs, *out, status)
    if np.count_nonzero(status) or not all(np.isfinite(a).all() for a in out):
        return None
    return out


def update(measurement_model, means, covars, predicted, measurements, name="measurements"):
    """The IMM's update of K filters' model predictions with their measurements (K, m) in
    one kernel call (:func:`fasttrack._jit.imm.imm_update`): ``(means, covars, probs)``;
    None where the sensor does not select state components, the process runs NumPy first,
    a measurement is not finite or an innovation covariance is not positive definite (the
    caller's general path then reports it); ``name``: the measurements' name in errors (see
    :func:`weighed`)."""
    sensor = measurement_model.spec
    k, models = predicted.shape
    m, d = measurement_model.ndim_meas, measurement_model.ndim_state
    if measurements.shape != (k, m) or means.shape != (k, models, d) \
            or covars.shape != (k, models, d, d):
        raise ValueError(f"{name} must be {k} measurements of {m} values of states of {d} "
                         f"(the measurement model's), got {measurements.shape} and states "
                         f"{means.shape[2:]}")
    if sensor.kind != SELECT or np.count_nonzero(sensor.angles) \
            or _jit.numpy_first(NUMPY_WORK_PER_MODEL * k * models) \
            or not np.isfinite(measurements).all():
        return None
    out = np.empty_like(means), np.empty_like(covars), np.empty_like(predicted)
    status = np.empty(k, dtype=np.int64)
    _imm.imm_update(sensor.mapping, sensor.noise_covar, means, covars, predicted,
                    measurements, *out, status)
    if np.count_nonzero(status):
        return None
    weighed(out[2], name)
    return out


def components(transition_models, d):
    """The (M, d) bool mask of each model's state components (an
    :class:`~fasttrack.EmbeddedTransitionModel`'s ``state_map``, else all d), or None if
    every model has every component; a ValueError names a model of another dimension."""
    has = np.ones((len(transition_models), d), dtype=np.bool_)
    for j, model in enumerate(transition_models):
        if model.ndim_state != d:
            raise ValueError(f"transition model {j} ({type(model).__name__}) has "
                             f"{model.ndim_state} state dimensions, the state {d}: embed a "
                             f"model of fewer in the state with EmbeddedTransitionModel(model, "
                             f"state_map, {d})")
        state_map = getattr(model, "state_map", None)
        if state_map is not None:
            has[j] = False
            has[j, state_map] = True
    return None if has.all() else has


def _mask(has, shape):
    """``has``, or every component of (M, d) ``shape``, for the kernels (writable, as
    they compile for: they only read it)."""
    if has is not None:
        return has
    found = _EVERYTHING.get(shape)
    if found is None:
        found = _EVERYTHING[shape] = np.ones(shape, dtype=np.bool_)
    return found


#: :func:`_mask`'s masks of every component, by shape.
_EVERYTHING = {}


def _matrices(transition_models, dt):
    """(M, d, d) F and Q of the models over ``dt`` seconds, remembered for banks of
    constant-velocity models, which the interval and their noise rates determine (a filter
    steps at few intervals; building Q costs more than the step)."""
    rates = tuple(model.cv_rates() for model in transition_models)
    key = (dt, rates) if None not in rates else None
    found = _CV_BANKS.get(key)
    if found is None:
        specs = [model.spec(dt) for model in transition_models]
        found = (np.array([spec.matrix for spec in specs]),
                 np.array([spec.noise for spec in specs]))
        if key is not None:
            if len(_CV_BANKS) >= 64:
                _CV_BANKS.clear()
            _CV_BANKS[key] = found
    return found


#: :func:`_matrices` of constant-velocity banks, by interval and rates.
_CV_BANKS = {}


def log_gaussian(measurement_model, measurements, z_hats, innovation):
    """log N(z_k; z_hat_k, S_k) for K measurements (K, m), predictions (K, m) and
    innovation covariances (K, m, m); bearing innovations wrapped. A ValueError names the
    first filter whose S is not positive definite."""
    v = measurements - z_hats
    angles = measurement_model.spec.angles
    v[:, angles] = wrap(v[:, angles])
    try:
        lower = np.linalg.cholesky(innovation)
    except np.linalg.LinAlgError:
        bad = next(k for k in range(innovation.shape[0])
                   if not np.all(np.linalg.eigvalsh(innovation[k]) > 0))
        raise ValueError(f"filter {bad}'s innovation covariance is not positive "
                         f"definite") from None
    whitened = np.linalg.solve(lower, v[..., None])[..., 0]
    log_det = np.log(np.diagonal(lower, axis1=1, axis2=2)).sum(axis=1)
    with np.errstate(over="ignore"):  # (-inf: a likelihood that rounds to 0)
        return (-0.5 * (whitened ** 2).sum(axis=1) - log_det
                - 0.5 * v.shape[1] * np.log(2 * np.pi))
