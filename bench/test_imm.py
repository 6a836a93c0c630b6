"""Multiple-model steps on stacks: one filter and 10^4 filters of 3 constant-velocity models
(noise 0.01, 1 and 10; d = 4, a position sensor), one step of the IMM (order 0), GPB1 or
GPB2 (order 1, 2) per call of ``step``; one IMM step of a constant-velocity and a
constant-turn model (the extended Kalman filter's prediction); one IMM step through the
predictor and updater classes; the IMM smoother over 1 and 100 tracks of 1000 steps; one
IMM-GNN scan of 1000 tracks and one IMM-JPDA step of 100 tracks."""
import numpy as np
import pytest

import fasttrack as ft

MATRIX = [[0.9, 0.05, 0.05], [0.05, 0.9, 0.05], [0.05, 0.05, 0.9]]


def _filter(order=0):
    """The IMM filter (order 0), or the GPB filter of that order."""
    models = [ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)
              for q in (0.01, 1.0, 10.0)]
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    if order:
        return ft.BatchGPBFilter(models, sensor, MATRIX, order=order)
    return ft.BatchIMMFilter(models, sensor, MATRIX)


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("k", [1, 10_000])
def test_imm_step(benchmark, k, order):
    benchmark.group = f"imm-step K={k} M=3"
    rng = np.random.default_rng(0)
    means = np.repeat(rng.normal(size=(k, 1, 4)) * 10.0, 3, axis=1)
    covars = np.broadcast_to(np.eye(4), (k, 3, 4, 4)).copy()
    probs = np.full((k, 3), 1.0 / 3.0)
    z = rng.normal(size=(k, 2)) * 10.0
    out = benchmark(_filter(order).step, means, covars, probs, z, 1.0)
    assert np.allclose(out[2].sum(axis=1), 1.0)


@pytest.mark.parametrize("k", [1, 10_000])
def test_imm_step_turn_model(benchmark, k):
    """A constant-velocity model embedded in the turn state (x, vx, y, vy, w) and
    ``ConstantTurn`` (the extended Kalman filter's prediction) in one batch IMM step."""
    from fasttrack.models.transition import EmbeddedTransitionModel
    benchmark.group = f"imm-step-turn K={k} M=2"
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.01)] * 2)
    imm = ft.BatchIMMFilter([EmbeddedTransitionModel(cv, (0, 1, 2, 3), 5),
                             ft.ConstantTurn([0.01, 0.01], 1e-4)],
                            ft.LinearGaussian(5, (0, 2), np.eye(2)), [[0.95, 0.05], [0.05, 0.95]])
    rng = np.random.default_rng(0)
    means = np.repeat(rng.normal(size=(k, 1, 5)) * [10.0, 1.0, 10.0, 1.0, 0.05], 2, axis=1)
    means[:, 0, 4] = 0.0
    covars = np.broadcast_to(np.diag([1.0, 1.0, 1.0, 1.0, 1e-3]), (k, 2, 5, 5)).copy()
    covars[:, 0, 4, 4] = 0.0
    z = means[:, 0, [0, 2]] + rng.normal(size=(k, 2))
    out = benchmark(imm.step, means, covars, np.full((k, 2), 0.5), z, 1.0)
    assert np.allclose(out[2].sum(axis=1), 1.0)


def test_imm_class_step(benchmark):
    """``IMMPredictor.predict`` + ``IMMUpdater.update`` on a GaussianMixture of the same 3
    models, one filter (Kalman predictors and updaters)."""
    benchmark.group = "imm-step K=1 M=3"
    imm = _filter()
    predictor = ft.IMMPredictor([ft.KalmanPredictor(m) for m in imm.transition_models], MATRIX)
    updater = ft.IMMUpdater([ft.KalmanUpdater(imm.measurement_model)] * 3, MATRIX)
    prior = ft.GaussianMixture([ft.WeightedGaussianState(np.zeros(4), np.eye(4), weight=1 / 3,
                                                         timestamp=0.0)] * 3)
    detection = ft.Detection([1.0, -2.0], timestamp=1.0, measurement_model=imm.measurement_model)

    def step():
        prediction = predictor.predict(prior, timestamp=1.0)
        return updater.update(ft.SingleHypothesis(prediction, detection))

    out = benchmark(step)
    assert abs(sum(c.weight for c in out.components) - 1.0) < 1e-12


def test_imm_step_filterpy(benchmark):
    """filterpy 2.0.0's ``IMMEstimator`` (predict + update) on the same 3 models, one
    filter."""
    kalman = pytest.importorskip("filterpy.kalman")
    benchmark.group = "imm-step K=1 M=3"
    imm = _filter()
    filters = []
    for model in imm.transition_models:
        f = kalman.KalmanFilter(dim_x=4, dim_z=2)
        f.F, f.Q, f.R = model.matrix(1.0), model.covar(1.0), np.eye(2)
        f.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
        f.x, f.P = np.zeros(4), np.eye(4)
        filters.append(f)
    estimator = kalman.IMMEstimator(filters, np.full(3, 1.0 / 3.0), np.array(MATRIX))
    z = np.array([1.0, -2.0])

    def step():
        estimator.predict()
        estimator.update(z)

    benchmark(step)


@pytest.mark.parametrize("k", [1, 100])
def test_imm_smooth(benchmark, k):
    """The fixed-interval smoother over K tracks of 1000 filtered steps of the 3 models."""
    benchmark.group = f"imm-smooth K={k} T=1000 M=3"
    rng = np.random.default_rng(0)
    means = rng.normal(size=(k, 1000, 3, 4))
    a = rng.normal(size=(k, 1000, 3, 4, 4))
    covars = a @ a.swapaxes(-1, -2) + np.eye(4)
    probs = rng.dirichlet(np.ones(3), size=(k, 1000))
    out = benchmark(_filter().smooth, means, covars, probs, 1.0)
    assert np.allclose(out[2].sum(axis=-1), 1.0)


def test_imm_gnn_scan(benchmark):
    """One IMM-GNN scan of 1000 tracks x 1000 detections (the targets of
    ``bench/test_gating.py``, 3 constant-velocity models): predict every model, gate and
    assign on the mode-combined predicted measurements, update the assigned tracks."""
    from bench.test_gating import MISSED, PRIOR_COVAR, scenario
    from fasttrack.core import imm
    from fasttrack.core.assign import global_nearest_neighbour
    from fasttrack.core.gating import gate
    benchmark.group = "imm-gnn-scan N=1000 M=3"
    n, filt = 1000, _filter()
    means, detections = scenario(n)
    means = np.repeat(means[:, None], 3, axis=1)
    covars = np.broadcast_to(PRIOR_COVAR, (n, 3, 4, 4)).copy()
    probs = np.full((n, 3), 1.0 / 3.0)
    models, sensor = filt.transition_models, filt.measurement_model

    def scan():
        x, p, predicted, z_hats, s = imm.predictions(models, sensor, filt.transition_matrix,
                                                     means, covars, probs, np.ones(n))
        chosen = global_nearest_neighbour(gate(*imm.combine(z_hats, s, predicted), detections,
                                               MISSED ** 2), MISSED)
        hit = chosen >= 0
        imm.updates(models, sensor, x[hit], p[hit], predicted[hit], z_hats[hit], s[hit],
                    detections[chosen[hit]])
        return chosen

    assert (scan() >= 0).mean() > 0.95
    benchmark.pedantic(scan, rounds=20, warmup_rounds=1)


def test_imm_jpda_step(benchmark):
    """One IMM-JPDA step of 100 tracks on 100 targets + 100 clutter points (the workload of
    ``bench/test_jpda.py``; 3 models of its noise, q = 0.05, turning at 0.1, 0 and -0.1
    rad/s): predict every model, gate on the mode-combined predicted measurements, exact
    JPDA marginals of the mode-mixture likelihoods, and each model's PDA update."""
    from bench.test_jpda import P0, PROB_DETECT, PROB_GATE, workload
    from fasttrack.core import imm
    from fasttrack.core.gating import gate
    from scipy.stats import chi2
    benchmark.group = "imm-jpda-step N=100+100 M=3"
    x0, z, clutter, density = workload()
    points = np.concatenate([z, clutter])
    n = len(x0)
    filt = ft.BatchIMMFilter([ft.KnownTurnRate([0.05, 0.05], w) for w in (0.1, 0.0, -0.1)],
                             ft.LinearGaussian(4, (0, 2), np.eye(2)), MATRIX)
    means = np.repeat(x0[:, None], 3, axis=1)
    covars = np.broadcast_to(P0, (n, 3, 4, 4)).copy()
    probs = np.full((n, 3), 1.0 / 3.0)
    models, sensor = filt.transition_models, filt.measurement_model
    threshold = chi2.ppf(PROB_GATE, 2)

    def step():
        x, p, predicted, z_hats, s = imm.predictions(models, sensor, filt.transition_matrix,
                                                     means, covars, probs, np.ones(n))
        result = gate(*imm.combine(z_hats, s, predicted), points, threshold)
        return imm.jpda_updates(sensor, x, p, predicted, z_hats, s, points, result,
                                PROB_DETECT, PROB_GATE, density)

    out = step()
    assert np.allclose(out[2].sum(axis=1), 1.0) and (out[3] < 1).mean() > 0.9
    benchmark.pedantic(step, rounds=20, warmup_rounds=1)
