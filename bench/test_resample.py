"""Resamplers on 4-D particles, N = 1e3 ... 1e6: fasttrack's class API, the NumPy reference,
Stone Soup 1.9.1, and the floor of copying the state (np.copyto)."""
import numpy as np
import pytest

import fasttrack as ft

import reference.resample
import reference.weights
from .conftest import SIZES, run, workload

SCHEMES = {
    "systematic": (lambda: ft.SystematicResampler(rng=0), "systematic", False),
    "stratified": (lambda: ft.StratifiedResampler(rng=0), "stratified", False),
    "multinomial": (lambda: ft.MultinomialResampler(rng=0), "multinomial", False),
    "residual": (lambda: ft.ResidualResampler("systematic", rng=0), "systematic", True),
}


def _stonesoup(scheme):
    from stonesoup.resampler import particle as ss
    return {
        "systematic": ss.SystematicResampler,
        "stratified": ss.StratifiedResampler,
        "multinomial": ss.MultinomialResampler,
        "residual": lambda: ss.ResidualResampler(residual_method=ss.ResidualMethod.SYSTEMATIC),
        "ess": ss.ESSResampler,
    }[scheme]()


def _stonesoup_state(log_w, x):
    from stonesoup.types.array import StateVectors
    from stonesoup.types.state import ParticleState
    return ParticleState(StateVectors(x), log_weight=log_w - np.logaddexp.reduce(log_w))


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_fasttrack(benchmark, scheme, n):
    benchmark.group = f"resample-{scheme} N={n}"
    log_w, x = workload(n)
    state = ft.ParticleState(x, log_weight=log_w)
    resampler = SCHEMES[scheme][0]()
    out = run(benchmark, lambda: resampler.resample(state), n)
    assert len(out) == n


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_numpy_reference(benchmark, scheme, n):
    benchmark.group = f"resample-{scheme} N={n}"
    log_w, x = workload(n)
    _, method, residual = SCHEMES[scheme]
    out = run(benchmark, lambda: x[:, reference.resample.draw(log_w, n, method, residual, 12345)],
              n)
    assert out.shape == x.shape


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_stonesoup(benchmark, scheme, n):
    pytest.importorskip("stonesoup")
    benchmark.group = f"resample-{scheme} N={n}"
    log_w, x = workload(n)
    state = _stonesoup_state(log_w, x)
    resampler = _stonesoup(scheme)
    np.random.seed(0)
    out = run(benchmark, lambda: resampler.resample(state), n, slow=True)
    assert len(out) == n


@pytest.mark.parametrize("n", SIZES)
def test_copy_floor(benchmark, n):
    """The floor: copying the (4, N) state into an existing array."""
    benchmark.group = "resample-floor"
    _, x = workload(n)
    out = np.empty_like(x)
    benchmark.extra_info["n"] = n
    run(benchmark, lambda: np.copyto(out, x), n)


@pytest.mark.parametrize("n", SIZES)
def test_ess_check_fasttrack(benchmark, n):
    """ESSResampler on weights whose ESS is above N/2: the check alone, no draw."""
    benchmark.group = f"resample-ess N={n}"
    log_w, x = workload(n)
    state = ft.ParticleState(x, log_weight=log_w)
    resampler = ft.ESSResampler()
    assert run(benchmark, lambda: resampler.resample(state), n) is state


@pytest.mark.parametrize("n", SIZES)
def test_ess_check_numpy_reference(benchmark, n):
    benchmark.group = f"resample-ess N={n}"
    log_w, _ = workload(n)
    run(benchmark, lambda: reference.weights.ess(log_w, log_w.max()) < n / 2, n)


@pytest.mark.parametrize("n", SIZES)
def test_ess_check_stonesoup(benchmark, n):
    pytest.importorskip("stonesoup")
    benchmark.group = f"resample-ess N={n}"
    log_w, x = workload(n)
    state = _stonesoup_state(log_w, x)
    resampler = _stonesoup("ess")
    assert run(benchmark, lambda: resampler.resample(state), n, slow=True) is state
