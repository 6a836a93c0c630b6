"""One GM-PHD step at steady state (predict, gate, update, reduce), on N targets on a
jittered 20 m grid with N uniform clutter detections a scan (CV 4-state, q = 0.05, position
sensor, R = I, P_D = 0.9, P_S = 0.99, gate: Mahalanobis distance 3, prune 1e-8, merge 5, a
birth component of covariance diag(1e4, 2, 1e4, 2) and weight 0.25 every scan): fasttrack's
arrays against Stone Soup's ``GaussianMixtureHypothesiser`` + ``PHDUpdater`` +
``GaussianMixtureReducer`` in the same run, after 5 steps from the targets' own components."""
import datetime

import numpy as np
import pytest

import fasttrack as ft
from fasttrack.core import kalman, mixture, phd

TRANSITION = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
SENSOR = ft.LinearGaussian(4, (0, 2), np.eye(2))
P_D, P_S, GATE = 0.9, 0.99, 3.0
STEPS = 6


def scans(n, seed=2):
    """The targets' start (n, 4), the scans' detections (each (2 n, 2)), the surveillance
    box and its clutter density."""
    rng = np.random.default_rng(0)
    side = int(np.ceil(np.sqrt(n)))
    gx, gy = np.meshgrid(np.arange(side), np.arange(side))
    pos = np.c_[gx.ravel(), gy.ravel()][:n] * 20.0 + rng.normal(0, 1, (n, 2))
    vel = rng.normal(0, 1, (n, 2))
    x0 = np.c_[pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]]
    lo, hi = x0[:, [0, 2]].min(0) - 20, x0[:, [0, 2]].max(0) + 20
    rng = np.random.default_rng(seed)
    f = TRANSITION.matrix(time_interval=1.0)
    truth, out = x0, []
    for _ in range(STEPS):
        truth = truth @ f.T
        out.append(np.vstack([truth[:, [0, 2]] + rng.normal(0, 1, (n, 2)),
                              rng.uniform(lo, hi, (n, 2))]))
    return x0, out, (lo, hi), n / float(np.prod(hi - lo))


def native_step(means, covars, log_weights, detections, birth, density):
    """Predict the components and a birth, survive, update, reduce."""
    means, covars = np.vstack([means, birth[0]]), np.concatenate([covars, birth[1]])
    means, covars, _, _ = kalman.stack_predict(TRANSITION, SENSOR, np.ones(len(means)), means,
                                               covars)
    log_weights = np.append(log_weights + np.log(P_S), np.log(0.25))
    means, covars, log_weights, _, _ = phd.update(SENSOR, means, covars, log_weights,
                                                  detections, P_D, density, GATE ** 2)
    means, covars, weights, _, _ = mixture.reduce(means, covars, np.exp(log_weights),
                                                  prune_threshold=1e-8, merge_threshold=5.0)
    return means, covars, np.log(weights)


@pytest.mark.parametrize("n", [10, 50, 100])
def test_phd_step_fasttrack(benchmark, n):
    benchmark.group = f"gm-phd step N={n}"
    x0, detections, (lo, hi), density = scans(n)
    centre = np.r_[(lo + hi) / 2, 0, 0][[0, 2, 1, 3]]
    birth = centre[None], np.diag([1e4, 2.0, 1e4, 2.0])[None]
    state = (x0, np.broadcast_to(np.diag([1.0, 0.1, 1.0, 0.1]), (n, 4, 4)).copy(),
             np.log(np.full(n, 0.9)))
    for scan in detections[:-1]:
        state = native_step(*state, scan, birth, density)
    expected = np.exp(state[2]).sum()
    assert 0.7 * n < expected < 1.3 * n  # the PHD's estimate of the number of targets
    benchmark.extra_info["components"] = len(state[2])
    benchmark.pedantic(native_step, (*state, detections[-1], birth, density), rounds=20,
                       warmup_rounds=1)


@pytest.mark.parametrize("n, implementation", [(10, "stonesoup"), (10, "dropin"),
                                               (50, "dropin"), (100, "dropin")])
def test_phd_step_stonesoup(benchmark, n, implementation):
    """Stone Soup's classes, or the drop-ins of its Kalman predictor and updater,
    hypothesisers, measure, PHD updater and reducer."""
    pytest.importorskip("stonesoup")
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import TaggedWeightedGaussianState
    if implementation == "stonesoup":
        from stonesoup.hypothesiser.distance import DistanceHypothesiser
        from stonesoup.hypothesiser.gaussianmixture import GaussianMixtureHypothesiser
        from stonesoup.measures import Mahalanobis
        from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer
        from stonesoup.predictor.kalman import KalmanPredictor
        from stonesoup.updater.kalman import KalmanUpdater
        from stonesoup.updater.pointprocess import PHDUpdater
    else:
        from fasttrack.stonesoup import (DistanceHypothesiser, GaussianMixtureHypothesiser,
                                         GaussianMixtureReducer, KalmanPredictor,
                                         KalmanUpdater, Mahalanobis, PHDUpdater)
    benchmark.group = f"gm-phd step N={n}"
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = LinearGaussian(4, (0, 2), np.eye(2))
    x0, detections, (lo, hi), density = scans(n)
    updater = KalmanUpdater(sensor)
    hypothesiser = GaussianMixtureHypothesiser(
        DistanceHypothesiser(KalmanPredictor(transition), updater, Mahalanobis(),
                             missed_distance=GATE), order_by_detection=True)
    phd_updater = PHDUpdater(updater, clutter_spatial_density=density, prob_detection=P_D,
                             prob_survival=P_S)
    reducer = GaussianMixtureReducer(prune_threshold=1e-8, merge_threshold=5)
    t0 = datetime.datetime(2025, 1, 1)
    components = {TaggedWeightedGaussianState(x[:, None], np.diag([1.0, 0.1, 1.0, 0.1]),
                                              weight=0.9, timestamp=t0, tag="birth")
                  for x in x0}
    centre = np.r_[(lo + hi) / 2, 0, 0][[0, 2, 1, 3]]

    def step(components, k):
        timestamp = t0 + datetime.timedelta(seconds=k + 1)
        birth = TaggedWeightedGaussianState(centre[:, None], np.diag([1e4, 2.0, 1e4, 2.0]),
                                            weight=0.25, tag="birth", timestamp=timestamp)
        scan = {Detection(z[:, None], timestamp=timestamp, measurement_model=sensor)
                for z in detections[k]}
        hypotheses = hypothesiser.hypothesise(set(components) | {birth}, scan, timestamp,
                                              order_by_detection=True)
        return set(reducer.reduce(phd_updater.update(hypotheses)))

    for k in range(STEPS - 1):
        components = step(components, k)
    benchmark.extra_info["components"] = len(components)
    benchmark.pedantic(step, (components, STEPS - 1), rounds=3, warmup_rounds=0)


@pytest.mark.parametrize("clutter", [10, 30, 60])
def test_phd_vo_linear_run(benchmark, clutter):
    """A whole run of Vo and Ma's linear scenario (100 scans): PHDTracker with its birth
    intensity, gate chi2(0.999, 2) = 13.8, prune 1e-5, merge 4, at most 100 components."""
    from fasttrack.scenarios import vo_linear, vo_linear_birth
    benchmark.group = "gm-phd vo-linear run"
    scenario = vo_linear(clutter_rate=float(clutter), seed=1)

    def run():
        tracker = ft.PHDTracker(scenario.transition_model, scenario.measurement_model,
                                vo_linear_birth(), 0.98, 0.99, scenario.clutter_density,
                                gate_threshold=13.8)
        return tracker.run(scenario.detections)

    estimates = run()
    assert np.mean([abs(len(e) - len(t)) for e, t in zip(estimates, scenario.truths)]) < 1.0
    benchmark.pedantic(run, rounds=7, warmup_rounds=1)


@pytest.mark.parametrize("clutter", [10, 30, 60])
def test_cphd_vo_linear_run(benchmark, clutter):
    """The same run with CPHDTracker (at most 30 targets, Vo's N_max)."""
    from fasttrack.scenarios import vo_linear, vo_linear_birth
    benchmark.group = "gm-cphd vo-linear run"
    scenario = vo_linear(clutter_rate=float(clutter), seed=1)

    def run():
        tracker = ft.CPHDTracker(scenario.transition_model, scenario.measurement_model,
                                 vo_linear_birth(), 0.98, 0.99, scenario.clutter_density,
                                 float(clutter), max_targets=30, gate_threshold=13.8)
        return tracker.run(scenario.detections)

    estimates = run()
    assert np.mean([abs(len(e) - len(t)) for e, t in zip(estimates, scenario.truths)]) < 1.0
    benchmark.pedantic(run, rounds=7, warmup_rounds=1)
