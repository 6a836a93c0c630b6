"""GPB1 and GPB2 on stacks: exact where the theory says so (GPB-n over n steps from one
Gaussian is the jump-Markov posterior, enumerated here over every model sequence), the
Kalman filter with one model, the batch against the single filter, and bad input."""
import itertools

import numpy as np
import pytest

import fasttrack as ft

SENSOR = ft.LinearGaussian(4, (0, 2), np.diag([0.5, 0.5]))
MATRIX = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.05, 0.15, 0.8]])


def _models():
    return [ft.KnownTurnRate([0.1, 0.1], w) for w in (0.3, 0.0, -0.3)]


def _exact(models, matrix, x0, p0, mu0, measurements, interval):
    """The jump-Markov posterior after len(measurements) steps from N(x0, p0) with mode
    probabilities mu0: ``(means, covars, probs)`` of the last model, each the moment match
    over every model sequence ending in it."""
    h = SENSOR.matrix()
    r = SENSOR.noise_covar
    m = len(models)
    last = []
    for sequence in itertools.product(range(m), repeat=len(measurements)):
        x, p, weight = x0, p0, mu0 @ matrix[:, sequence[0]]
        for t, j in enumerate(sequence):
            if t:
                weight *= matrix[sequence[t - 1], j]
            f, q = models[j].matrix(interval), models[j].covar(interval)
            x, p = f @ x, f @ p @ f.T + q
            s = h @ p @ h.T + r
            v = measurements[t] - h @ x
            weight *= np.exp(-0.5 * v @ np.linalg.solve(s, v)) / np.sqrt(
                np.linalg.det(2 * np.pi * s))
            gain = p @ h.T @ np.linalg.inv(s)
            x, p = x + gain @ v, p - gain @ s @ gain.T
        last.append((sequence[-1], weight, x, p))
    means, covars, probs = np.empty((m, 4)), np.empty((m, 4, 4)), np.empty(m)
    for j in range(m):
        w = np.array([c[1] for c in last if c[0] == j])
        xs = np.array([c[2] for c in last if c[0] == j])
        ps = np.array([c[3] for c in last if c[0] == j])
        probs[j] = w.sum()
        w = w / w.sum()
        means[j] = w @ xs
        spread = xs - means[j]
        covars[j] = np.einsum("i,iab->ab", w, ps) + np.einsum("i,ia,ib->ab", w, spread, spread)
    return means, covars, probs / probs.sum()


def _run(filt, x0, p0, mu0, measurements, interval):
    m = len(mu0)
    means, covars = np.tile(x0, (2, m, 1)), np.tile(p0, (2, m, 1, 1))
    probs = np.tile(mu0, (2, 1))
    for z in measurements:
        means, covars, probs = filt.step(means, covars, probs, np.tile(z, (2, 1)), interval)
    return means[1], covars[1], probs[1]


@pytest.mark.parametrize("order,steps,exact", [(1, 1, True), (2, 1, True), (2, 2, True),
                                               (1, 2, False), (2, 3, False)])
def test_gpb_n_over_n_steps_is_the_jump_markov_posterior(order, steps, exact):
    rng = np.random.default_rng(order * 10 + steps)
    x0, p0 = np.array([0.0, 10.0, 0.0, 0.0]), np.diag([2.0, 1.0, 2.0, 1.0])
    mu0 = np.array([0.2, 0.5, 0.3])
    measurements = rng.normal(size=(steps, 2)) * 3.0 + [[10.0 * (t + 1), 0.0]
                                                         for t in range(steps)]
    want = _exact(_models(), MATRIX, x0, p0, mu0, measurements, 1.0)
    got = _run(ft.BatchGPBFilter(_models(), SENSOR, MATRIX, order=order), x0, p0, mu0,
               measurements, 1.0)
    close = all(np.allclose(a, b, rtol=1e-9, atol=1e-9) for a, b in zip(got, want))
    assert close == exact
    if exact:
        for a, b in zip(got, want):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)


def test_the_imm_is_exact_over_one_step_only():
    rng = np.random.default_rng(5)
    x0, p0, mu0 = np.array([0.0, 10.0, 0.0, 0.0]), np.diag([2.0, 1.0, 2.0, 1.0]), \
        np.array([0.2, 0.5, 0.3])
    measurements = rng.normal(size=(2, 2)) * 3.0 + [[10.0, 0.0], [20.0, 0.0]]
    filt = ft.BatchIMMFilter(_models(), SENSOR, MATRIX)
    one = _run(filt, x0, p0, mu0, measurements[:1], 1.0)
    two = _run(filt, x0, p0, mu0, measurements, 1.0)
    want_one = _exact(_models(), MATRIX, x0, p0, mu0, measurements[:1], 1.0)
    want_two = _exact(_models(), MATRIX, x0, p0, mu0, measurements, 1.0)
    for a, b in zip(one, want_one):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)
    assert not np.allclose(two[0], want_two[0], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("order", [1, 2])
def test_one_model_is_the_kalman_filter(order):
    model = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.3)] * 2)
    rng = np.random.default_rng(order)
    means, covars = rng.normal(size=(6, 1, 4)), np.tile(np.eye(4), (6, 1, 1, 1))
    z = rng.normal(size=(6, 2))
    got = ft.BatchGPBFilter([model], SENSOR, [[1.0]], order=order).step(
        means, covars, np.ones((6, 1)), z, 1.0)
    want = ft.BatchExtendedKalmanFilter(model, SENSOR).step(means[:, 0], covars[:, 0], z, 1.0)
    np.testing.assert_allclose(got[0][:, 0], want[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got[1][:, 0], want[1], rtol=1e-12, atol=1e-12)


def test_the_batch_is_the_filters_one_by_one_and_a_far_measurement_stays_finite():
    filt = ft.BatchGPBFilter(_models(), SENSOR, MATRIX, order=2)
    rng = np.random.default_rng(2)
    k = 40
    means = rng.normal(size=(k, 3, 4)) * 5.0
    covars = np.tile(np.diag([2.0, 1.0, 2.0, 1.0]), (k, 3, 1, 1))
    probs = rng.dirichlet(np.ones(3), size=k)
    z = rng.normal(size=(k, 2)) * 5.0
    z[7] = 1e4 * 0.7  # 10^4 sigma away
    batch = filt.step(means, covars, probs, z, 1.0)
    for i in (0, 7, k - 1):
        one = filt.step(means[i:i + 1], covars[i:i + 1], probs[i:i + 1], z[i:i + 1], 1.0)
        for a, b in zip(one, batch):
            np.testing.assert_allclose(a[0], b[i], rtol=1e-12, atol=1e-12)
    assert np.isfinite(batch[2]).all()
    np.testing.assert_allclose(batch[2].sum(axis=1), 1.0, rtol=1e-12)


@pytest.mark.parametrize("order,error,match", [
    (0, ValueError, "order must be 1 or 2"), (3, ValueError, "order must be 1 or 2"),
    (True, TypeError, "order must be an int, 1 or 2 .*, got bool"),
    ("2", TypeError, "order must be an int, 1 or 2 .*, got str")])
def test_an_order_other_than_one_or_two_is_refused(order, error, match):
    with pytest.raises(error, match=match):
        ft.BatchGPBFilter(_models(), SENSOR, MATRIX, order=order)
    gpb = ft.BatchGPBFilter(_models(), SENSOR, MATRIX, order=2)
    with pytest.raises(error, match=match):  # (it was accepted and ignored)
        gpb.order = order
    gpb.order = 1
    assert gpb.order == 1 and gpb.algorithm == "gpb1"
    with pytest.raises(AttributeError):
        gpb.algorithm = "gpb3"
