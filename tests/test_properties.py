"""Property-based tests of the resamplers over sizes and weight patterns."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import fasttrack as ft
from fasttrack import resampling

import reference
from conftest import stream_key

SCHEMES = [(m, r) for r in (False, True) for m in ("multinomial", "systematic", "stratified")]


@st.composite
def log_weight_patterns(draw):
    """Unnormalised log weights: random, with zeros, one survivor, subnormal linear weights,
    huge offsets, ties."""
    n = draw(st.integers(1, 200))
    pattern = draw(st.sampled_from(["random", "zeros", "survivor", "subnormal", "offset",
                                    "equal"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    log_w = rng.normal(0, 3, n)
    if pattern == "zeros":
        log_w[rng.random(n) < 0.5] = -np.inf
        log_w[rng.integers(n)] = 0.0
    elif pattern == "survivor":
        log_w[:] = -np.inf
        log_w[rng.integers(n)] = rng.normal(0, 100)
    elif pattern == "subnormal":
        # linear weights between 5e-324 and 1e-300, some of them next to 1
        log_w = np.log(rng.uniform(5e-324, 1e-300, n))
        log_w[rng.random(n) < 0.2] = 0.0
    elif pattern == "offset":
        log_w += draw(st.sampled_from([-700.0, 700.0, 1e6, -1e6]))
    elif pattern == "equal":
        log_w[:] = draw(st.floats(-1e3, 1e3))
    return log_w


@settings(max_examples=150, deadline=None)
@given(log_w=log_weight_patterns(), nparts=st.integers(1, 300), seed=st.integers(0, 2**31),
       scheme=st.sampled_from(SCHEMES))
def test_any_weights_give_valid_sorted_indices_equal_to_the_mirror(log_w, nparts, seed, scheme):
    method, residual = scheme
    idx = resampling.draw(log_w, nparts, ft.ResidualMethod(method), residual, rng=seed)
    assert idx.shape == (nparts,) and idx.dtype == np.int64
    assert np.all(np.diff(idx) >= 0)
    assert idx.min() >= 0 and idx.max() < log_w.size
    w = np.exp(log_w - log_w.max())
    assert np.all(w[idx] > 0)  # a zero (or underflowing) weight is never drawn
    want = reference.draw(log_w, nparts, method, residual, stream_key(seed))
    assert np.array_equal(idx, want)


@settings(max_examples=100, deadline=None)
@given(log_w=log_weight_patterns(), nparts=st.integers(1, 300), seed=st.integers(0, 2**31))
def test_systematic_and_residual_systematic_counts_are_floor_or_ceil(log_w, nparts, seed):
    w = np.exp(log_w - log_w.max())
    expected = nparts * w / w.sum()
    for residual in (False, True):
        idx = resampling.draw(log_w, nparts, ft.ResidualMethod.SYSTEMATIC, residual, rng=seed)
        counts = np.bincount(idx, minlength=log_w.size)
        assert np.all(counts >= np.floor(expected - 1e-9))
        assert np.all(counts <= np.ceil(expected + 1e-9))


@settings(max_examples=100, deadline=None)
@given(log_w=log_weight_patterns())
def test_ess_is_between_one_and_n_and_normalise_sums_to_one(log_w):
    ess = ft.ess(log_w)
    assert 1 - 1e-9 <= ess <= log_w.size * (1 + 1e-9)
    normalised = ft.normalise(log_w)
    assert np.isclose(np.exp(normalised).sum(), 1.0, rtol=1e-12)
