"""A process's first one-filter Kalman, extended and unscented Kalman steps, in NumPy: the
same results and errors as the kernels, Numba left unloaded, and the kernels taking over."""
import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fasttrack as ft
from fasttrack._jit import kalman as kernels
from fasttrack._jit import status
from fasttrack._jit import unscented as unscented_kernels
from fasttrack.core import kalman, kalman_numpy
from fasttrack.core.kinds import ANALYTIC, CENTRAL, FORWARD

NOISE = np.diag([np.radians(0.2), 1.0])


def _transitions():
    return [ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2),
            ft.LinearGaussianTransitionModel(np.array([[1.0, 0.5], [0.0, 0.9]]),
                                             np.array([[0.2, 0.05], [0.05, 0.1]]))]


def _sensors():
    rotated = dict(translation_offset=[5.0, -3.0], rotation_offset=[0.0, 0.0, 0.6])
    return [ft.CartesianToBearingRange(4, (0, 2), NOISE, **rotated),
            ft.Cartesian2DToBearing(4, (2, 0), [[1e-4]], **rotated),
            ft.LinearGaussian(4, (0, 2), np.eye(2))]


def _covariance(rng, d, scale=1.0):
    a = rng.standard_normal((d, d))
    return scale * (a @ a.T + 0.1 * np.eye(d))


def _kernel_update(spec, method, joseph, x, covar, z):
    m, d = spec.ndim_meas, spec.ndim_state
    out = [np.empty((d, 1)), np.empty((d, d)), np.empty((m, 1)), np.empty((m, m)),
           np.empty((d, m))]
    code = kernels.update_one(*spec.sensor, method, joseph, x, covar, z, *out)
    return (code, *out)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dt=st.floats(-5.0, 5.0))
def test_predict_matches_the_kernel(seed, dt):
    rng = np.random.default_rng(seed)
    for model in _transitions():
        d = model.ndim_state
        x, covar = rng.standard_normal((d, 1)) * 10, _covariance(rng, d)
        spec = model.spec(dt)
        code, x_out, covar_out = kalman_numpy.predict(spec, x, covar)
        x_k, covar_k = np.empty((d, 1)), np.empty((d, d))
        assert code == kernels.predict_one(*spec.kalman(), dt, x, covar, x_k, covar_k) == 0
        np.testing.assert_allclose(x_out, x_k, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(covar_out, covar_k, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(covar_out, covar_out.T)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), joseph=st.booleans(),
       method=st.sampled_from([ANALYTIC, FORWARD, CENTRAL]))
def test_update_matches_the_kernel(seed, joseph, method):
    rng = np.random.default_rng(seed)
    for sensor in _sensors():
        spec = sensor.spec
        x = rng.uniform(-50, 50, (4, 1))
        covar = _covariance(rng, 4)
        z = kalman_numpy.measure(spec, x) + 0.1 * rng.standard_normal((spec.ndim_meas, 1))
        numpy_out = kalman_numpy.update(spec, method, joseph, x, covar, z)
        kernel_out = _kernel_update(spec, method, joseph, x, covar, z)
        assert numpy_out[0] == kernel_out[0] == 0
        # central differences (steps of 6e-6) turn the last bit of NumPy's vectorised
        # arctan2, which the kernels' libm call need not share, into about 1e-7
        rtol = 1e-7 if method == CENTRAL else 1e-8
        for ours, theirs in zip(numpy_out[1:], kernel_out[1:]):
            np.testing.assert_allclose(ours, theirs, rtol=rtol, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dt=st.floats(-5.0, 5.0), joseph=st.booleans(),
       alpha=st.sampled_from([1e-3, 0.5, 1.0]), beta=st.sampled_from([0.0, 2.0]))
def test_unscented_steps_match_the_kernels(seed, dt, joseph, alpha, beta):
    rng = np.random.default_rng(seed)
    kappa = 0.0
    for model in _transitions():
        d = model.ndim_state
        x, covar = rng.standard_normal((d, 1)) * 10, _covariance(rng, d)
        spec = model.spec(dt)
        code, x_out, covar_out = kalman_numpy.unscented_predict(spec, alpha, beta, kappa, x,
                                                                covar)
        x_k, covar_k = np.empty((d, 1)), np.empty((d, d))
        assert code == unscented_kernels.unscented_predict(
            *spec.kalman(), dt, alpha, beta, kappa, x, covar, x_k, covar_k) == 0
        scale = np.abs(covar_k).max()
        np.testing.assert_allclose(x_out, x_k, rtol=1e-9, atol=1e-9 * np.abs(x_k).max())
        np.testing.assert_allclose(covar_out, covar_k, rtol=1e-8, atol=1e-10 * scale)
    for sensor in _sensors():
        spec = sensor.spec
        m = spec.ndim_meas
        x, covar = rng.uniform(-50, 50, (4, 1)), _covariance(rng, 4)
        z = kalman_numpy.measure(spec, x) + 0.1 * rng.standard_normal((m, 1))
        ours = kalman_numpy.unscented_update(spec, alpha, beta, kappa, joseph, x, covar, z)
        theirs = [np.empty((4, 1)), np.empty((4, 4)), np.empty((m, 1)), np.empty((m, m)),
                  np.empty((4, m))]
        code = unscented_kernels.unscented_update(*spec.sensor, alpha, beta, kappa, joseph, x,
                                                  covar, z, *theirs)
        assert ours[0] == code
        if code:  # a spread that leaves S indefinite, in both
            continue
        # the sigma points' weights reach 1 / alpha**2 in size: rounding grows with them
        amplified = max(1.0, 1e-4 / alpha ** 2)
        for found, expected in zip(ours[1:], theirs):
            np.testing.assert_allclose(found, expected, rtol=1e-7,
                                       atol=1e-9 * amplified * max(np.abs(expected).max(), 1.0))


def test_covariance_status_matches_the_kernels_decisions():
    rng = np.random.default_rng(3)
    good = _covariance(rng, 4)
    singular = np.zeros((4, 4))
    singular[:2, :2] = _covariance(rng, 2)
    cases = {"good": good, "singular": singular, "asymmetric": good + np.triu(good, 1) * 1e-6,
             "indefinite": good - 20 * np.eye(4),
             "hidden negative": np.array([[1.0, 2.0], [2.0, 1.0]]),
             "zero pivot, nonzero column": np.array([[0.0, 1e-3], [1e-3, 1.0]])}
    codes = (status.PRIOR_NOT_SYMMETRIC, status.PRIOR_NOT_PSD)
    for name, a in cases.items():
        x, d = np.zeros((a.shape[0], 1)), a.shape[0]
        model = ft.LinearGaussianTransitionModel(np.eye(d), np.eye(d))
        expected = kernels.predict_one(*model.spec(1.0).kalman(), 1.0, x, a, np.empty((d, 1)),
                                       np.empty((d, d)))
        found = kalman_numpy.covariance_status(a, *codes)
        assert found == expected, name
    fours = [a for a in cases.values() if a.shape == (4, 4)]
    stack = np.array(fours * 3)  # decided together as one by one
    np.testing.assert_array_equal(kalman_numpy.covariance_statuses(stack, *codes),
                                  [kalman_numpy.covariance_status(a, *codes) for a in stack])
    assert set(kalman_numpy.covariance_statuses(stack, *codes)) == {0, *codes}


@pytest.mark.parametrize("case", ["at the sensor", "infinite measurement",
                                  "negative noise", "indefinite prediction"])
def test_update_statuses_match_the_kernel(case):
    sensor = _sensors()[0]
    spec = sensor.spec
    x = np.array([[10.0], [1.0], [4.0], [0.0]])
    covar = np.eye(4)
    z = np.array([[0.1], [7.0]])
    if case == "at the sensor":
        x[[0, 2], 0] = spec.offset
    elif case == "infinite measurement":
        z[1, 0] = np.inf
    elif case == "negative noise":
        spec = spec._replace(noise_covar=-10 * np.eye(2))
    else:
        covar[0, 0] = -1.0
    for method in (ANALYTIC, FORWARD, CENTRAL):
        found = kalman_numpy.update(spec, method, True, x, covar, z)[0]
        expected = _kernel_update(spec, method, True, x, covar, z)[0]
        assert found == expected, (case, method)
        # finite differences are defined at the sensor
        assert expected != 0 or (case == "at the sensor" and method != ANALYTIC), case


def test_the_step_functions_raise_the_kernels_errors(monkeypatch):
    """Through :func:`fasttrack.core.kalman.update`, NumPy's step raises as the kernel's."""
    sensor = _sensors()[0]
    x = np.array([[5.0], [1.0], [-3.0], [0.0]])  # on the sensor
    messages = []
    for numpy_first in (True, False):
        monkeypatch.setattr(kalman, "in_numpy", lambda kind: numpy_first)
        with pytest.raises(ValueError) as error:
            kalman.update(sensor, x, np.eye(4), np.array([[0.1], [7.0]]), "analytic")
        messages.append(str(error.value))
    assert messages[0] == messages[1] and "sensor" in messages[0]


_FIRST_STEPS = r"""
import json, sys
import numpy as np
import fasttrack as ft
from fasttrack import _jit
from fasttrack.core import kalman, unscented
_jit._numpy_work = int(sys.argv[1])
transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
sensor = ft.CartesianToBearingRange(4, (0, 2), np.diag([1e-4, 1.0]), translation_offset=[50, 0])
x, covar = np.array([[0.0], [1.0], [0.0], [1.0]]), np.diag([1.5, 0.5, 1.5, 0.5])
loaded = []
for k in range(20):  # Kalman and unscented steps in turn
    z = np.array([[np.arctan2(k + 1.0, k - 49.0)], [np.hypot(k - 49.0, k + 1.0)]])
    if k % 2:
        x, covar = unscented.predict(transition, 1.0, x, covar, 0.5, 2.0, 0.0)
        x, covar = unscented.update(sensor, x, covar, z, 0.5, 2.0, 0.0)[:2]
    else:
        x, covar = kalman.predict(transition, 1.0, x, covar)
        x, covar = kalman.update(sensor, x, covar, z, "analytic", joseph=False)[:2]
    loaded.append("numba" in sys.modules)
print(json.dumps({"loaded": loaded, "x": x.ravel().tolist(), "covar": covar.ravel().tolist()}))
"""


def _first_steps(numpy_work):
    done = subprocess.run([sys.executable, "-c", _FIRST_STEPS, str(numpy_work)],
                          capture_output=True, text=True, timeout=600, check=True)
    return json.loads(done.stdout.splitlines()[-1])


def test_a_process_first_steps_leave_numba_unloaded_then_the_kernels_take_over():
    short = _first_steps(40)  # 40 predict and update calls: every step of the 20
    assert not any(short["loaded"])
    switching = _first_steps(10)  # the kernels from the sixth step on
    assert switching["loaded"] == [False] * 5 + [True] * 15
    compiled = _first_steps(0)
    assert all(compiled["loaded"])
    for run in (short, switching):
        np.testing.assert_allclose(run["x"], compiled["x"], rtol=1e-10)
        np.testing.assert_allclose(run["covar"], compiled["covar"], rtol=1e-10, atol=1e-14)
