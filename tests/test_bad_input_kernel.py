"""Bad input to the kernels' angle rows and points, to tune_allocator and to ESSResampler's
threshold: a TypeError for a wrong type (bools and strings included), a ValueError for a
wrong value, each naming the argument; legal edge cases still work."""
import numpy as np
import pytest

import fasttrack as ft

KERNELS = [ft.GaussianKernel(), ft.GaussianKernel(variance=10.0), ft.QuadraticKernel(),
           ft.QuarticKernel(), ft.LinearKernel(), ft.PolynomialKernel(3)]
IDS = [repr(kernel) for kernel in KERNELS]
POINTS = np.random.default_rng(0).normal(size=(2, 5))


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
@pytest.mark.parametrize("angles, error, match", [
    ([True], TypeError, r"angle_components must hold integer indices, got True \(bool\)"),
    (0, TypeError, "angle_components must be a sequence of integer indices, got int"),
    ("0", TypeError, "angle_components must be a sequence of integer indices, got str"),
    ([1.0], TypeError, r"angle_components must hold integer indices, got 1.0 \(float\)"),
    (np.array([False, True]), TypeError, "angle_components must hold integer indices, got "
                                         ".*False"),
    (["0"], TypeError, "angle_components must hold integer indices, got '0'"),
    ([2], ValueError, r"angle_components indices must lie in \[0, 2\), got \(2,\)"),
    ([-1], ValueError, r"angle_components indices must lie in \[0, 2\), got \(-1,\)"),
])
def test_angle_components_are_integer_rows(kernel, angles, error, match):
    with pytest.raises(error, match=match):
        kernel(POINTS, angle_components=angles)
    with pytest.raises(error, match=match):
        kernel(POINTS, POINTS[:, :3], angle_components=angles)


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_angle_components_none_or_empty_mean_none(kernel):
    plain = kernel(POINTS)
    for none in (None, (), [], np.array([], dtype=int)):
        np.testing.assert_array_equal(kernel(POINTS, angle_components=none), plain)
    for rows in ([1], (np.int64(1),), np.array([1]), range(1, 2)):
        np.testing.assert_array_equal(kernel(POINTS, angle_components=rows),
                                      kernel(POINTS, angle_components=(1,)))


def test_angle_mask_refuses_bools():
    np.testing.assert_array_equal(ft.Kernel.angle_mask(3, None), [False] * 3)
    np.testing.assert_array_equal(ft.Kernel.angle_mask(3, [0, 2]), [True, False, True])
    with pytest.raises(TypeError, match="angle_components must hold integer indices"):
        ft.Kernel.angle_mask(3, [True, False, True])


@pytest.mark.parametrize("kernel", [ft.GaussianKernel(), ft.QuadraticKernel(),
                                    ft.LinearKernel()], ids=repr)
@pytest.mark.parametrize("scale", [1e154, 1e300])
def test_a_gram_matrix_that_overflows_names_the_states(kernel, scale):
    with pytest.raises(ValueError, match="kernel values are not finite.*rescale state1 and "
                                         "state2"):
        kernel(POINTS * scale)


def test_far_points_are_fine_where_the_kernel_stays_finite():
    # A data-chosen length scale does not depend on the units: 1e150 is like 1.
    np.testing.assert_allclose(ft.GaussianKernel()(POINTS * 1e150), ft.GaussianKernel()(POINTS),
                               rtol=1e-12)
    # A fixed variance: distinct far points are 0 apart from the normaliser on the diagonal.
    gram = ft.GaussianKernel(variance=10.0)(POINTS * 1e300)
    np.testing.assert_allclose(gram, np.eye(5) / np.sqrt(2 * np.pi * 10.0))


@pytest.mark.parametrize("points, error, match", [
    (np.full((2, 3), np.nan), ValueError, "state1 contains NaN"),
    (np.array([[1.0, np.inf]]), ValueError, "state1 contains infinite values"),
    ("points", TypeError, "state1 must be a numeric array"),
    (np.ones((2, 3), dtype=bool), TypeError, "state1 must be a numeric array"),
])
def test_bad_points_name_the_states(points, error, match):
    with pytest.raises(error, match=match):
        ft.GaussianKernel()(points)


@pytest.mark.parametrize("arguments, error, match", [
    (dict(mmap_threshold_mb=-1), ValueError, "mmap_threshold_mb must be finite and >= 0"),
    (dict(mmap_threshold_mb=1e9), ValueError, "mmap_threshold_mb must be below 2048 MiB"),
    (dict(mmap_threshold_mb=2048), ValueError, "mmap_threshold_mb must be below 2048 MiB"),
    (dict(mmap_threshold_mb=np.nan), ValueError, "mmap_threshold_mb must be finite, got nan"),
    (dict(mmap_threshold_mb=np.inf), ValueError, "mmap_threshold_mb must be finite, got inf"),
    (dict(mmap_threshold_mb="64"), TypeError, "mmap_threshold_mb must be a real number, "
                                              "got str"),
    (dict(mmap_threshold_mb=True), TypeError, "mmap_threshold_mb must be a real number, "
                                              "got bool"),
    (dict(mmap_threshold_mb=None), TypeError, "mmap_threshold_mb must be a real number"),
    (dict(trim_threshold_mb=-5), ValueError, "trim_threshold_mb must be finite and >= 0"),
    (dict(trim_threshold_mb=1e7), ValueError, "trim_threshold_mb must be below 2048 MiB"),
    (dict(trim_threshold_mb="1024"), TypeError, "trim_threshold_mb must be a real number"),
])
def test_tune_allocator_names_a_bad_size(arguments, error, match, monkeypatch):
    import ctypes

    def no_libc(*args, **kwargs):  # a bad size must be refused before mallopt is reached
        raise AssertionError("mallopt reached")

    monkeypatch.setattr(ctypes, "CDLL", no_libc)
    with pytest.raises(error, match=match):
        ft.tune_allocator(**arguments)


@pytest.mark.parametrize("threshold, error, match", [
    (-5.0, ValueError, "threshold must be finite and > 0"),
    (0, ValueError, "threshold must be finite and > 0"),
    (np.nan, ValueError, "threshold must be finite, got nan"),
    (np.inf, ValueError, "threshold must be finite, got inf"),
    (True, TypeError, "threshold must be a number or None, got bool"),
    ("10", TypeError, "threshold must be a number or None, got str"),
])
def test_ess_threshold_must_be_a_positive_number(threshold, error, match):
    with pytest.raises(error, match=match):
        ft.ESSResampler(threshold=threshold)


def test_ess_threshold_legal_edges():
    state = ft.ParticleState(np.zeros((1, 4)), log_weight=np.log([0.7, 0.1, 0.1, 0.1]))
    assert ft.ESSResampler(threshold=0.5).resample(state) is state  # an ESS is >= 1
    assert ft.ESSResampler().threshold is None
    resampled = ft.ESSResampler(threshold=100).resample(state)  # above N: always resamples
    assert resampled is not state and resampled.state_vector.shape == (1, 4)
