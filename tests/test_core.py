"""fasttrack.core: the array functions under both APIs, and the layering rule that the
Stone Soup drop-ins reach the kernels only through them."""
import ast
import pathlib

import numpy as np
import pytest

import fasttrack as ft
from fasttrack.core import akkf, kalman, particle

STONESOUP_LAYER = pathlib.Path(ft.__file__).parent / "stonesoup"


def _imports_from_outside(path):
    """(module, name) of every ``from X import name`` in ``path`` where X lies outside
    fasttrack.stonesoup (relative imports resolved against the package)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1:
                continue  # the drop-in package's own modules
            module = ("fasttrack." if node.level == 2 else "") + (node.module or "")
            found += [(module.rstrip("."), alias.name) for alias in node.names]
        elif isinstance(node, ast.Import):
            found += [(alias.name, "") for alias in node.names]
    return found


def test_the_drop_in_layer_uses_no_kernel_and_no_private_name():
    files = sorted(STONESOUP_LAYER.glob("*.py"))
    assert len(files) >= 6
    for path in files:
        for module, name in _imports_from_outside(path):
            if not module.startswith("fasttrack") or module == "fasttrack._lazy":
                continue  # (the packages' lazy exports are no layer)
            parts = module.split(".") + ([name] if name else [])
            assert not any(part.startswith("_") for part in parts[1:]), (path.name, module, name)


def test_weigh_normalises_and_reports_the_ess():
    rng = np.random.default_rng(1)
    sensor = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.01, 1.0]), translation_offset=[50, 0])
    x = rng.standard_normal((4, 5000))
    log_weight = np.log(rng.random(5000))
    z = sensor.measurement_vector(ft.Detection([0.5, 49.0]), "z")
    log_w, ess = particle.weigh(sensor, z, x, log_weight)
    assert np.exp(log_w).sum() == pytest.approx(1.0, rel=1e-12)
    assert ess == pytest.approx(ft.ess(log_w), rel=1e-12)
    with pytest.raises(ValueError, match="zero likelihood"):
        particle.weigh(sensor, z, x, np.full(5000, -np.inf))
    for n in (5000, 40):  # an infinite weight: no normalised weights, not NaN ones
        infinite = log_weight[:n].copy()
        infinite[[3, 7]] = np.inf
        with pytest.raises(ValueError, match=r"log weights include \+inf \(2 particles, the "
                                             r"first at index 3\)"):
            particle.weigh(sensor, z, x[:, :n], infinite)


def test_resampling_decision_uses_half_the_particles_by_default():
    even = np.zeros(10)
    assert particle.resampling_decision(even) == (pytest.approx(10.0), False)
    assert particle.resampling_decision(even, threshold=11)[1]
    skewed = np.log([1.0] + [1e-9] * 9)
    assert particle.resampling_decision(skewed)[1]
    with pytest.raises(ValueError, match="particles.log_weight"):
        particle.resampling_decision([np.nan, 0.0])


def test_gather_takes_the_columns():
    x = np.arange(12.0).reshape(3, 4)
    assert np.array_equal(particle.gather(x, np.array([3, 0, 0])), x[:, [3, 0, 0]])


def test_kalman_steps_check_their_jacobian_names():
    assert kalman.check_jacobian("central") == "central"
    with pytest.raises(ValueError, match="jacobian must be one of 'forward', 'central'"):
        kalman.check_jacobian("analytic", allowed=("forward", "central"))


def test_kalman_predict_and_update_equal_the_textbook_formulas():
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2) * 0.5)
    x, covar = np.array([[0.0], [1.0], [2.0], [-1.0]]), np.eye(4)
    x1, p1 = kalman.predict(transition, 2.0, x, covar)
    f, q = transition.matrix(2.0), transition.covar(2.0)
    np.testing.assert_allclose(x1, f @ x)
    np.testing.assert_allclose(p1, f @ covar @ f.T + q, rtol=1e-12)
    z = np.array([[2.5], [0.0]])
    x2, p2, z_hat, s, cross = kalman.update(sensor, x1, p1, z, joseph=False)
    h = sensor.matrix()
    s_want = h @ p1 @ h.T + sensor.noise_covar
    gain = p1 @ h.T @ np.linalg.inv(s_want)
    np.testing.assert_allclose(s, s_want, rtol=1e-12)
    np.testing.assert_allclose(x2, x1 + gain @ (z - h @ x1), rtol=1e-12)
    np.testing.assert_allclose(p2, p1 - gain @ s_want @ gain.T, rtol=1e-10, atol=1e-12)
    with pytest.raises(ValueError, match="prior.covar is not positive semi-definite"):
        kalman.predict(transition, 1.0, x, -np.eye(4))


def test_akkf_weights_that_vanish_are_an_error():
    with pytest.raises(ValueError, match="all zero"):
        akkf.check_weights(np.zeros(3), "predicted")
