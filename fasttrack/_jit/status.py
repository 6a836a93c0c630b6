"""Status codes that kernels return instead of raising (one table for every kernel; the
messages live in ``fasttrack._errors``)."""

OK = 0
#: A prior covariance that is not positive semi-definite.
PRIOR_NOT_PSD = 1
#: An innovation covariance ``H P H^T + R`` that is not positive definite.
INNOVATION_NOT_PD = 2
#: A measurement Jacobian that is undefined (a bearing taken at the sensor).
JACOBIAN_UNDEFINED = 3
#: A measurement with NaN or infinite components.
MEASUREMENT_NOT_FINITE = 4
#: A predicted covariance that is not positive semi-definite.
PREDICTION_NOT_PSD = 5
#: A user's model function returned an array of the wrong shape.
FUNCTION_SHAPE = 6
#: A user's model function returned NaN or infinite values.
FUNCTION_NOT_FINITE = 7
#: A prior covariance that is not symmetric.
PRIOR_NOT_SYMMETRIC = 8
#: A predicted covariance that is not symmetric.
PREDICTION_NOT_SYMMETRIC = 9
