"""The Gaussian-mixture CPHD filter (Vo, Vo and Cantoni 2007) on arrays, in logs: the
intensity is a mixture as in :mod:`fasttrack.core.phd`, and the number of targets has a
distribution of its own, ``log_cardinality`` (N + 1,), the log probabilities of 0..N
targets (N the largest number the filter represents). Clutter is Poisson: ``clutter_rate``
detections a scan on average, spread with intensity ``clutter_intensity`` (per unit volume
of measurement space).

The update's terms are sums over the elementary symmetric functions (ESFs) of the
detections' weights, computed in logs (no overflow for any number of detections); the
ESFs with one detection left out come from the full ones in O(m^2) for all m detections, by
the forward or backward recursion, whichever subtracts less
(:func:`fasttrack._jit.cphd.log_esf_without`)."""
import numpy as np

from .. import _jit, _validate
from . import cphd_numpy as _numpy
from . import phd as _phd

_cphd = _jit.lazy("cphd")

#: The largest cardinality a distribution may carry (the recursions cost O(N^2) a scan:
#: 10,000 targets take about a second).
MAX_TARGETS = 10_000


def predict_cardinality(log_cardinality, prob_survival, birth_mean):
    """The predicted log cardinality: each of n targets survives with ``prob_survival``
    (binomial thinning) and a Poisson number of mean ``birth_mean`` is born; truncated to
    the same 0..N and normalised (the mass above N, which N is chosen to make negligible,
    is dropped).

    Parameters
    ----------
    log_cardinality : (N + 1,) array_like
        Log probabilities of 0..N targets, summing to one.
    prob_survival : float
        P_S in [0, 1].
    birth_mean : float
        The expected number of births, >= 0.

    Returns
    -------
    (N + 1,) ndarray
    """
    log_cardinality = cardinality(log_cardinality)
    p_s = _validate.probability(prob_survival, "prob_survival")
    birth_mean = _validate.non_negative(birth_mean, "birth_mean")
    with np.errstate(divide="ignore"):
        log_survive, log_die = np.log(p_s), np.log1p(-p_s)
    if _jit.numpy_first(_numpy.predict_work(log_cardinality.size)):
        return _numpy.predict_cardinality(log_cardinality, log_survive, log_die, birth_mean)
    out = np.empty(log_cardinality.size)
    _cphd.predict_cardinality(log_cardinality, log_survive, log_die, birth_mean, out)
    return out


def update(model, means, covars, log_weights, log_cardinality, detections, prob_detect,
           clutter_rate, clutter_intensity, gate_threshold=None, unscented=None):
    """The CPHD posterior of a predicted Gaussian mixture and cardinality given one scan,
    by a linear measurement model.

    The components are the PHD update's (:func:`fasttrack.core.phd.update`): missed ones
    with weights (1 - P_D) w_i <Upsilon^1[Z], p> / <Upsilon^0[Z], p>, and each gated
    (component, detection z) pair with weight P_D w_i N(z; H m_i, S_i) rate / kappa
    <Upsilon^1[Z minus z], p> / <Upsilon^0[Z], p>. The cardinality is
    Upsilon^0[Z](n) p(n) / <Upsilon^0[Z], p>. With a Poisson predicted cardinality of mean
    sum w_i, the weights are the PHD update's.

    Parameters
    ----------
    model, means, covars, log_weights, detections, prob_detect, gate_threshold, unscented
        As :func:`fasttrack.core.phd.update`.
    log_cardinality : (N + 1,) array_like
        Log probabilities of 0..N targets (-inf for 0), summing to one.
    clutter_rate : float
        Expected clutter detections a scan, > 0 (Poisson).
    clutter_intensity : float
        kappa: ``clutter_rate`` times the clutter's spatial density, > 0.

    Returns
    -------
    means, covars, log_weights, components, detections
        As :func:`fasttrack.core.phd.update`.
    log_cardinality : (N + 1,) ndarray
        The posterior's.

    Raises
    ------
    ValueError
        As :func:`fasttrack.core.phd.update`, and for a cardinality that is not a
        distribution or a clutter rate that is not finite and > 0, naming the argument.
    """
    scan = _phd.detections_of(model, detections)
    log_cardinality = cardinality(log_cardinality)
    log_rate = np.log(_validate.positive(clutter_rate, "clutter_rate"))
    log_clutter = np.log(_validate.positive(clutter_intensity, "clutter_intensity"))
    pairs = _phd.detected_pairs(model, means, covars, log_weights, scan, prob_detect,
                                gate_threshold, unscented)
    m, size = scan.shape[0], log_cardinality.size
    log_total = _numpy.logsumexp(pairs.predicted[2])
    if log_total == -np.inf and (log_cardinality[1:] > -np.inf).any():
        raise ValueError("log_weights are all -inf (no intensity to place targets by) while "
                         "log_cardinality gives targets a probability")
    with np.errstate(divide="ignore"):
        log_missed = np.log1p(-float(prob_detect))
    log_values = pairs.totals + log_rate - log_clutter  # Lambda_z
    if _jit.numpy_first(_numpy.work(m, size)):
        log_e = _numpy.log_esf(log_values)
        with np.errstate(invalid="ignore"):  # (NaN: checked below)
            posterior, missed, without = _numpy.update_sums(
                log_e, _numpy.log_esf_without(log_values, log_e), log_cardinality,
                log_missed, log_total, log_rate)
    else:
        log_e, esf_without = np.empty(m + 1), np.empty((m, m))
        _cphd.log_esf(log_values, log_e)
        _cphd.log_esf_without(log_values, log_e, esf_without)
        posterior, without = np.empty(size), np.empty(m)
        missed = _cphd.update_sums(log_e, esf_without, log_cardinality, log_missed, log_total,
                                   log_rate, posterior, without)
    if np.isnan(posterior).any():  # every cardinality's term is 0
        raise ValueError("the detections have probability 0 under log_cardinality and "
                         "prob_detect (e.g. prob_detect = 1 and fewer detections than the "
                         "fewest targets possible)")
    log_detected = pairs.log_detected + log_rate - log_clutter + without[pairs.detections]
    return (*pairs.components(log_missed + missed, log_detected), posterior)


def cardinality(log_cardinality, name="log_cardinality"):
    """A validated (N + 1,) log cardinality distribution: finite or -inf, summing to one
    (to 1e-9), of N <= :data:`MAX_TARGETS`."""
    values = _validate.float_array(log_cardinality, name, 1)
    if values.size == 0 or np.isnan(values).any() or (values == np.inf).any():
        raise ValueError(f"{name} must be N + 1 >= 1 log probabilities, not NaN or +inf")
    if values.size > MAX_TARGETS + 1:
        raise ValueError(f"{name} must hold at most {MAX_TARGETS + 1} probabilities (of "
                         f"0..N targets), got {values.size}")
    with np.errstate(over="ignore"):
        total = np.exp(values).sum()
    if abs(total - 1.0) > 1e-9:
        raise ValueError(f"{name} must sum to 1 as probabilities, got {total!r}")
    return values
