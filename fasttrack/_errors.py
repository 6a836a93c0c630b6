"""What the kernels' status codes (``fasttrack._jit.status``) mean: one message per code, and
the error raised for it."""
from ._jit import status as _status
from ._jit.tunables import SIGMA_RESOLUTION

#: The message of each status code that does not concern a user's function.
MESSAGES = {
    _status.PRIOR_NOT_PSD: "prior.covar is not positive semi-definite (or not finite)",
    _status.PREDICTION_NOT_PSD: "the prediction's covariance is not positive semi-definite "
                                "(or not finite)",
    _status.PRIOR_NOT_SYMMETRIC: "prior.covar is not symmetric (or not finite)",
    _status.PREDICTION_NOT_SYMMETRIC: "the prediction's covariance is not symmetric (or not "
                                      "finite)",
    _status.INNOVATION_NOT_PD: "the innovation covariance S (of the predicted measurement, "
                               "plus R) is not positive definite (singular)",
    _status.JACOBIAN_UNDEFINED: "the measurement Jacobian is undefined or not finite at the "
                                "predicted state (for a polar sensor: the target at the "
                                "sensor, or a state that is not finite or beyond float64's "
                                "range when squared)",
    _status.MEASUREMENT_NOT_FINITE: "hypothesis.measurement contains NaN or infinite values",
    _status.MEAN_AT_SENSOR: "the prediction's mean lies at the polar sensor, where its "
                            "bearing is undefined",
    _status.PRIOR_UNRESOLVED: "prior.state_vector has a component more than "
                              f"{SIGMA_RESOLUTION:.0e} times its standard deviation (the "
                              "square root of its variance): its sigma points would round to "
                              "it (float64 keeps 16 digits)",
    _status.PREDICTION_UNRESOLVED: "the prediction's mean has a component more than "
                                   f"{SIGMA_RESOLUTION:.0e} times its standard deviation "
                                   "(the square root of its variance): its sigma points would "
                                   "round to it (float64 keeps 16 digits)",
    _status.PREDICTION_OVERFLOW: "the prediction overflowed: its mean or covariance is beyond "
                                 "float64's range (the prior, the transition or the interval "
                                 "is too large)",
    _status.UPDATE_NOT_PSD: "the update by hypothesis.measurement left a covariance that is "
                            "not positive semi-definite (the standard form P - K S K^T; "
                            "use_joseph_cov=True keeps it)",
}

#: Codes that the array layer treats apart.
JACOBIAN_UNDEFINED, UPDATE_NOT_PSD = _status.JACOBIAN_UNDEFINED, _status.UPDATE_NOT_PSD

#: Codes of an update whose outputs are still Stone Soup's numbers, which a non-strict
#: update (a drop-in's, or a measurement prediction's) returns without an error.
LENIENT = (_status.UPDATE_NOT_PSD, _status.MEAN_AT_SENSOR)

#: Codes about the output of a user's model function.
FUNCTION_CODES = (_status.FUNCTION_SHAPE, _status.FUNCTION_NOT_FINITE)


def check(code, function=None, states=None, dt=None):
    """Raise the ValueError for a kernel status ``code`` (nothing for OK).

    Parameters
    ----------
    code : int
    function : fasttrack.models.base.UserFunction, optional
        The user function the kernel called, for codes about its output.
    states : (d, n) ndarray, optional
        The states it was called on.
    dt : float, optional
        The time interval it was called with (a transition).
    """
    if code == _status.OK:
        return
    if code in FUNCTION_CODES:
        raise function.error(code, states, dt)
    raise ValueError(MESSAGES[code])
