"""The status codes of ``fasttrack._jit.status`` (plain ints), which mirrors of several
modules return."""

OK, PRIOR_NOT_PSD, INNOVATION_NOT_PD, JACOBIAN_UNDEFINED, MEASUREMENT_NOT_FINITE = 0, 1, 2, 3, 4
PREDICTION_NOT_PSD, FUNCTION_SHAPE, FUNCTION_NOT_FINITE = 5, 6, 7
PRIOR_NOT_SYMMETRIC, PREDICTION_NOT_SYMMETRIC = 8, 9
