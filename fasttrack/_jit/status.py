"""Status codes that kernels return instead of raising (one table for every kernel; the
messages live in ``fasttrack._errors``)."""
import numpy as np

OK = np.int64(0)
#: A prior covariance that is not positive semi-definite.
PRIOR_NOT_PSD = np.int64(1)
#: An innovation covariance ``H P H^T + R`` that is not positive definite.
INNOVATION_NOT_PD = np.int64(2)
#: A measurement Jacobian that is undefined (a bearing taken at the sensor).
JACOBIAN_UNDEFINED = np.int64(3)
#: A measurement with NaN or infinite components.
MEASUREMENT_NOT_FINITE = np.int64(4)
#: A predicted covariance that is not positive semi-definite.
PREDICTION_NOT_PSD = np.int64(5)
#: A user's model function returned an array of the wrong shape.
FUNCTION_SHAPE = np.int64(6)
#: A user's model function returned NaN or infinite values.
FUNCTION_NOT_FINITE = np.int64(7)
#: A prior covariance that is not symmetric.
PRIOR_NOT_SYMMETRIC = np.int64(8)
#: A predicted covariance that is not symmetric.
PREDICTION_NOT_SYMMETRIC = np.int64(9)
#: An update in the standard form ``P - K S K^T`` that left a covariance that is not
#: positive semi-definite.
UPDATE_NOT_PSD = np.int64(10)
#: An unscented transform whose mean lies at a polar sensor, where its bearing is undefined.
MEAN_AT_SENSOR = np.int64(11)
#: A prior mean with a component beyond ``SIGMA_RESOLUTION`` standard deviations from 0:
#: its sigma points round to it.
PRIOR_UNRESOLVED = np.int64(12)
#: The same of a prediction's mean.
PREDICTION_UNRESOLVED = np.int64(13)
#: A prediction whose mean or covariance overflowed float64.
PREDICTION_OVERFLOW = np.int64(14)
