"""The Gaussian-mixture PHD update (Vo and Ma 2006) on arrays, in log weights, for linear
sensors and for polar ones linearised per component (as the extended or the unscented
Kalman filter linearises them): a mixture of J predicted components, (J, d) means,
(J, d, d) covariances and (J,) log weights, and a scan of M detections (M, m) give the
posterior mixture of the missed components and the detected (component, detection) pairs.
The innovation covariance, gain and updated covariance are computed once per component and
shared by its detections; the detections each component's gate holds come from
:func:`fasttrack.core.gating.gate`."""
import math

import numpy as np

from .. import _validate
from . import gating as _gating
from . import mixture as _mixture
from . import kalman_numpy as _kalman_numpy
from . import unscented as _unscented
from ..models.measurement import MeasurementModel
from .kinds import FUNCTION, SELECT

#: Below this many (component, detection) pairs the gate tests every pair: a grid costs more.
GRID_FROM_PAIRS = 4096


def update(model, means, covars, log_weights, detections, prob_detect, clutter_intensity,
           gate_threshold=None, unscented=None):
    """The PHD posterior of a predicted Gaussian mixture given one scan.

    Component i (mean m_i, covariance P_i, weight w_i) gives a missed component
    (m_i, P_i, (1 - P_D) w_i) and, for each detection z its gate holds, a detected one
    (m_i + K_i (z - h(m_i)), P_i - K_i S_i K_i^T,
    P_D w_i N(z; h(m_i), S_i) / (kappa + sum_j P_D w_j N(z; h(m_j), S_j))), the sum over the
    components whose gates hold z, with S_i = H_i P_i H_i^T + R and K_i = P_i H_i^T S_i^-1.
    For a linear sensor H_i = H; for a polar one H_i is the Jacobian at m_i (the extended
    Kalman filter's linearisation, the GM-PHD filter's EK form), or, with ``unscented``,
    h(m_i), P_i H_i^T and S_i are the moments of m_i's sigma points (the UK form); bearing
    innovations are wrapped to [-pi, pi). The weights are computed in logs: none
    underflows.

    Parameters
    ----------
    model : LinearGaussian, CartesianToBearingRange or Cartesian2DToBearing
        The measurement model (h and H; R its noise); a model of user functions is refused.
    means : (J, d) array_like
    covars : (J, d, d) array_like
        Symmetric positive semi-definite, with H P H^T + R positive definite.
    log_weights : (J,) array_like
        Log weights, -inf for zero.
    detections : (M, m) array_like
    prob_detect : float
        P_D in [0, 1].
    clutter_intensity : float
        kappa > 0: expected clutter detections per unit volume of measurement space.
    gate_threshold : float, optional
        Squared Mahalanobis distance within which a detection updates a component, finite
        and > 0 (default None: every pair).
    unscented : (alpha, beta, kappa), optional
        For a polar sensor, the unscented transform's parameters (the unscented Kalman
        filter's, e.g. Stone Soup's (0.5, 2, None); kappa None for 3 - d); default: the
        Jacobian at each component's mean.

    Returns
    -------
    means, covars, log_weights : (J + n, d), (J + n, d, d), (J + n,) ndarray
        The J missed components, then the n detected pairs, component by component.
    components : (J + n,) int64 ndarray
        The predicted component each came from.
    detections : (J + n,) int64 ndarray
        The detection that updated it, -1 for a missed component.

    Raises
    ------
    ValueError
        For shapes that do not match, non-finite values, P_D outside [0, 1], a clutter
        intensity that is not finite and > 0, an innovation covariance that is not
        positive definite, or a component at a polar sensor, naming the argument.
    """
    scan = detections_of(model, detections)
    log_clutter = np.log(_validate.positive(clutter_intensity, "clutter_intensity"))
    return posterior(detected_pairs(model, means, covars, log_weights, scan, prob_detect,
                                    gate_threshold, unscented), prob_detect, log_clutter)


def posterior(pairs, prob_detect, log_clutter):
    """:func:`update`'s five arrays from the scan's :class:`DetectedPairs`, P_D and the log
    clutter intensity (validated)."""
    log_detected = pairs.log_detected - np.logaddexp(log_clutter,
                                                     pairs.totals[pairs.detections])
    return pairs.components(log_probability(1.0 - float(prob_detect)), log_detected)


def detections_of(model, detections):
    """The scan ``detections`` as a validated (M, m) float array for ``model`` (a built-in
    model, else an error naming its type)."""
    if not isinstance(model, MeasurementModel):
        raise TypeError(f"model must be a MeasurementModel, got {type(model).__name__}")
    spec = model.spec
    if spec.kind == FUNCTION:
        raise ValueError("the Gaussian-mixture updates take a built-in measurement model "
                         "(LinearGaussian, CartesianToBearingRange, Cartesian2DToBearing), "
                         f"got {type(model).__name__}")
    scan = _validate.finite_array(detections, "detections")
    scan = scan.reshape(0, spec.ndim_meas) if scan.shape == (0,) else scan  # (an empty list)
    if scan.ndim != 2 or scan.shape[1] != spec.ndim_meas:
        raise ValueError(f"detections must have shape (M, {spec.ndim_meas}), got {scan.shape}")
    model.check_angle_columns(scan, "detections")
    return scan


class DetectedPairs:
    """The (component, detection) pairs that a scan's gates hold, updated: ``means``,
    ``covars`` and ``log_detected`` (log P_D w_i N(z; H m_i, S_i)) of each pair, its
    ``pairs`` (component) and ``detections`` indices, and ``totals``, the log of the sum
    of ``exp(log_detected)`` over each detection's pairs (-inf for none); with the
    predicted mixture's validated ``means``, ``covars`` and ``log_weights`` as
    ``predicted``."""

    def __init__(self, predicted, means, covars, pairs, detections, log_detected, totals):
        self.predicted, self.means, self.covars = predicted, means, covars
        self.pairs, self.detections = pairs, detections
        self.log_detected, self.totals = log_detected, totals

    def components(self, log_missed, log_detected):
        """The posterior mixture of the missed components (the predicted log weights plus
        ``log_missed``) and the detected pairs (log weights ``log_detected``):
        :func:`update`'s five arrays."""
        means, covars, log_weights = self.predicted
        j = means.shape[0]
        return (np.concatenate((means, self.means)), np.concatenate((covars, self.covars)),
                np.concatenate((log_weights + log_missed, log_detected)),
                np.concatenate((np.arange(j), self.pairs)),
                np.concatenate((np.full(j, -1), self.detections)))


def detected_pairs(model, means, covars, log_weights, scan, prob_detect, gate_threshold=None,
                   unscented=None):
    """The :class:`DetectedPairs` of a predicted mixture and a validated scan (arguments
    as :func:`update`'s), validating the mixture, P_D and the threshold."""
    spec = model.spec
    means = _validate.finite_array(means, "means", 2)
    j, d = means.shape
    if d != spec.ndim_state:
        raise ValueError(f"means must have {spec.ndim_state} columns (the model's state), "
                         f"got {d}")
    covars = _validate.finite_array(covars, "covars", 3)
    if covars.shape != (j, d, d):
        raise ValueError(f"covars must have shape ({j}, {d}, {d}), got {covars.shape}")
    log_weights = _validate.float_array(log_weights, "log_weights", 1)
    if log_weights.shape != (j,) or np.isnan(log_weights).any() or (log_weights == np.inf).any():
        raise ValueError(f"log_weights must be {j} numbers, not NaN or +inf")
    log_detect = log_probability(prob_detect, "prob_detect")
    threshold = np.inf if gate_threshold is None else \
        _validate.positive(gate_threshold, "gate_threshold")
    _mixture.check_covariances(covars, "covars")
    if unscented is not None:  # (checked whatever the model: a linear one reads none)
        unscented = unscented_parameters(unscented)
    return gated_pairs(spec, means, covars, log_weights, scan, log_detect, threshold,
                       unscented)


def gated_pairs(spec, means, covars, log_weights, scan, log_detect, threshold,
                unscented=None):
    """:func:`detected_pairs` of validated arguments (a tracker's own intensity, checked
    where it was made): the model's ``spec``, log P_D and the gate ``threshold`` (inf for
    every pair)."""
    j = means.shape[0]
    z_hats, cross, innovation = _linearised(spec, means, covars, unscented)
    few = j * scan.shape[0] <= GRID_FROM_PAIRS  # test every pair, without a grid
    axes = np.empty(0, dtype=np.int64) if few or threshold == np.inf else \
        _gating.default_axes(spec.angles)
    gate = _gating.gate_arrays(z_hats, innovation, scan, threshold, spec.angles, axes)
    gains, updated = _mixture.component_gains(covars, cross, innovation)
    pairs = np.repeat(np.arange(j), np.diff(gate.starts))
    log_detected = log_detect + log_weights[pairs] + gate.log_likelihoods
    by_detection = np.argsort(gate.detections, kind="stable")
    starts = np.searchsorted(gate.detections[by_detection], np.arange(scan.shape[0] + 1))
    totals = _mixture.segment_logsumexp(log_detected[by_detection], starts)
    innovations = scan[gate.detections] - z_hats[pairs]
    innovations[:, spec.angles] = _kalman_numpy.wrap(innovations[:, spec.angles])
    detected_means = means[pairs] + np.einsum("kij,kj->ki", gains[pairs], innovations)
    return DetectedPairs((means, covars, log_weights), detected_means, updated[pairs], pairs,
                         gate.detections, log_detected, totals)


def _linearised(spec, means, covars, unscented=None):
    """``(z_hats, cross, S)``: each component's predicted measurement (J, m), P H^T
    (J, d, m) and H P H^T + R (J, m, m), H the measurement Jacobian at its mean (the
    extended Kalman filter's linearisation; exact for a linear sensor), or with
    ``unscented`` (alpha, beta, kappa) the moments of its sigma points."""
    if spec.kind == SELECT:
        cross = covars[:, :, spec.mapping]
        return means[:, spec.mapping], cross, cross[:, spec.mapping, :] + spec.noise_covar
    if unscented is not None:
        alpha, beta, kappa = unscented_parameters(unscented)
        kappa = _unscented.scaling(alpha, kappa, means.shape[1])
        moments = [_kalman_numpy.measurement_moments(spec, alpha, beta, kappa, mean[:, None],
                                                     covar)
                   for mean, covar in zip(means, covars)]
        j, m, d = means.shape[0], spec.ndim_meas, means.shape[1]
        return (np.array([z[:, 0] for z, _, _, _ in moments]).reshape(j, m),
                np.array([c for _, _, c, _ in moments]).reshape(j, d, m),
                np.array([s for _, s, _, _ in moments]).reshape(j, m, m))
    jacobians = jacobians_at(spec, means)
    cross = covars @ jacobians.transpose(0, 2, 1)
    return (_kalman_numpy.measure(spec, means.T).T, cross,
            jacobians @ cross + spec.noise_covar)


def jacobians_at(spec, means, name="means"):
    """The measurement Jacobians (J, m, d) of ``spec`` at ``means`` (J, d); a ValueError
    naming ``name[j]`` for a mean at a polar sensor, where they are undefined."""
    jacobians = _kalman_numpy.jacobians(spec, means.T)
    undefined = np.flatnonzero(np.isnan(jacobians).any(axis=(1, 2)))
    if undefined.size:
        raise ValueError(f"{name}[{undefined[0]}] lies at the sensor, where its bearing and "
                         f"the measurement Jacobian are undefined")
    return jacobians


def unscented_parameters(unscented, name="unscented"):
    """``unscented`` as a checked ``(alpha, beta, kappa)`` (see
    :func:`fasttrack.core.unscented.check_parameters`), else an error naming it."""
    try:
        alpha, beta, kappa = unscented
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be (alpha, beta, kappa), got {unscented!r}") from None
    return _unscented.check_parameters(alpha, beta, kappa)


def log_probability(value, name="value"):
    """log of a probability ``value`` (a real number in [0, 1], else an error naming
    ``name``), -inf for 0."""
    value = _validate.probability(value, name)
    return math.log(value) if value > 0.0 else -math.inf

