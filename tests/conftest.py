import numpy as np
import pytest

import fasttrack
from fasttrack import _jit

# The unit tests test the kernels from the first call on; the NumPy calls that precede a
# process's first kernel (fasttrack._jit.numpy_first) have tests of their own.
_jit.kernels_from_now()


@pytest.fixture(autouse=True)
def _seeded():
    """Every test starts from the same package default generator."""
    fasttrack.seed(12345)
    np.random.seed(12345)


def stream_key(seed):
    """The stream key that ``rng=seed`` gives the kernels (see fasttrack.random)."""
    return int(np.random.default_rng(seed).integers(0, 2**63 - 1))


def stonesoup_tutorial(seed, sensor_class=None):
    """The particle-filter and EKF tutorials' scenario built with Stone Soup itself, from
    ``np.random.seed(seed)``: ``(transition, sensor, truth, detections)``; ``sensor_class``
    replaces Stone Soup's CartesianToBearingRange."""
    import datetime

    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.types.detection import Detection
    from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState

    start, second = datetime.datetime(2026, 1, 1), datetime.timedelta(seconds=1)
    np.random.seed(seed)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    truth = GroundTruthPath([GroundTruthState([0, 1, 0, 1], timestamp=start)])
    for k in range(1, 21):
        truth.append(GroundTruthState(transition.function(truth[k - 1], noise=True,
                                                          time_interval=second),
                                      timestamp=start + k * second))
    sensor = (sensor_class or CartesianToBearingRange)(
        ndim_state=4, mapping=(0, 2), noise_covar=np.diag([np.radians(0.2), 1.0]),
        translation_offset=np.array([[50], [0]]))
    detections = [Detection(sensor.function(s, noise=True), timestamp=s.timestamp,
                            measurement_model=sensor) for s in truth]
    return transition, sensor, truth, detections


def from_python(kernel):
    """A kernel that calls ``kernel`` (one called only from kernels, which Python cannot
    call) with its arguments and returns its result; ``kernel`` itself when the JIT is
    off."""
    import numba
    from fasttrack._jit import KernelOnly
    if not isinstance(kernel, KernelOnly):
        return kernel

    def call(*args):
        return kernel(*args)
    return numba.njit(call)
