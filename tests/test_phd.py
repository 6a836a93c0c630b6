"""The GM-PHD update on arrays: closed forms (the Kalman filter, the weight-sum identity), a
direct evaluation of the formula, gates, log weights that do not underflow, and bad input."""
import numpy as np
import pytest
from scipy.stats import multivariate_normal

import fasttrack as ft
from fasttrack.core import phd

SENSOR = ft.LinearGaussian(4, (0, 2), np.diag([0.75, 0.75]))


def _mixture(seed, j):
    rng = np.random.default_rng(seed)
    means = rng.normal(size=(j, 4)) * [20.0, 1.0, 20.0, 1.0]
    a = rng.standard_normal((j, 4, 4)) * 0.5
    covars = a @ a.transpose(0, 2, 1) + np.eye(4)
    return means, covars, np.log(rng.uniform(0.01, 1.0, j))


def _direct(means, covars, log_weights, detections, p_d, kappa):
    """The update formula evaluated pair by pair in the linear domain."""
    h, r = np.zeros((2, 4)), SENSOR.noise_covar
    h[0, 0] = h[1, 2] = 1.0
    w = np.exp(log_weights)
    out = [(m, p, (1 - p_d) * wi) for m, p, wi in zip(means, covars, w)]
    for z in detections:
        terms = []
        for m, p, wi in zip(means, covars, w):
            s = h @ p @ h.T + r
            k = p @ h.T @ np.linalg.inv(s)
            terms.append((m + k @ (z - h @ m), p - k @ s @ k.T,
                          p_d * wi * multivariate_normal.pdf(z, h @ m, s)))
        total = sum(t[2] for t in terms)
        out += [(m, p, q / (kappa + total)) for m, p, q in terms]
    return out


@pytest.mark.parametrize("seed", range(4))
def test_the_update_is_the_formula(seed):
    means, covars, log_weights = _mixture(seed, 7)
    detections = np.random.default_rng(seed + 10).normal(size=(5, 2)) * 20.0
    got = phd.update(SENSOR, means, covars, log_weights, detections, 0.9, 1e-4)
    want = _direct(means, covars, log_weights, detections, 0.9, 1e-4)
    order = np.lexsort((got[3], got[4]))  # missed first, then detection by detection
    assert got[0].shape == (7 * 6, 4)
    for k, (m, p, w) in zip(order, want):
        np.testing.assert_allclose(got[0][k], m, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(got[1][k], p, rtol=1e-10, atol=1e-10)
        assert np.exp(got[2][k]) == pytest.approx(w, rel=1e-9, abs=1e-300)


def test_one_target_always_detected_without_clutter_is_the_kalman_filter():
    prior = ft.GaussianState([[1.0], [0.5], [-2.0], [0.1]], np.diag([4.0, 1.0, 4.0, 1.0]),
                             timestamp=0.0)
    z = ft.Detection([[1.5], [-1.0]], timestamp=0.0, measurement_model=SENSOR)
    kalman = ft.KalmanUpdater(SENSOR).update(ft.SingleHypothesis(prior, z))
    means, covars, log_weights, components, detections = phd.update(
        SENSOR, prior.state_vector.T, prior.covar[None], [0.0], z.state_vector.T, 1.0, 1e-300)
    assert np.exp(log_weights).tolist() == [0.0, pytest.approx(1.0, rel=1e-12)]
    np.testing.assert_allclose(means[1], kalman.state_vector.ravel(), rtol=1e-12)
    np.testing.assert_allclose(covars[1], kalman.covar, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("threshold", [None, 9.0])
def test_the_weights_sum_as_the_phd_identity(threshold):
    """sum w+ = (1 - P_D) sum w + sum_z W_z / (W_z + kappa), W_z over the gated pairs."""
    means, covars, log_weights = _mixture(3, 30)
    detections = np.random.default_rng(4).normal(size=(12, 2)) * 20.0
    out = phd.update(SENSOR, means, covars, log_weights, detections, 0.8, 2e-4, threshold)
    detected = out[4] >= 0
    w_z = np.bincount(out[4][detected], weights=np.exp(out[2][detected]), minlength=12)
    assert w_z.max() < 1.0  # normalised by W_z + kappa
    raw = np.zeros(12)
    for i, z in zip(out[3][detected], out[4][detected]):  # W_z from the gated pairs
        s = covars[i][np.ix_([0, 2], [0, 2])] + SENSOR.noise_covar
        raw[z] += 0.8 * np.exp(log_weights[i]) * multivariate_normal.pdf(
            detections[z], means[i, [0, 2]], s)
    np.testing.assert_allclose(w_z, raw / (raw + 2e-4), rtol=1e-9)
    assert np.exp(out[2]).sum() == pytest.approx(
        0.2 * np.exp(log_weights).sum() + (raw / (raw + 2e-4)).sum(), rel=1e-12)
    if threshold is not None:  # the gate keeps exactly the pairs within it
        assert 0 < detected.sum() < 30 * 12


def test_far_detections_keep_their_weight_in_logs():
    """A component 1e3 standard deviations away: N underflows to 0 in linear terms, not in
    logs, and the weight of that pair is exp(-5e5 ...), a finite log."""
    out = phd.update(SENSOR, [[0.0, 0.0, 0.0, 0.0], [1e3, 0, 0, 0]], [np.eye(4)] * 2,
                     [0.0, 0.0], [[1e3, 0.0]], 0.9, 1e-300)
    assert np.isfinite(out[2]).all() and out[2][2] < -1e5


@pytest.mark.parametrize("change, message", [
    (dict(prob_detect=1.5), "prob_detect must lie in"),
    (dict(clutter_intensity=0.0), "clutter_intensity must be finite and > 0"),
    (dict(log_weights=[np.nan, 0.0]), "log_weights must be 2 numbers"),
    (dict(detections=[[0.0, 0.0, 0.0]]), r"detections must have shape \(M, 2\)"),
    (dict(covars=[np.eye(4), -np.eye(4)]), r"covars\[1\] is not positive semi-definite"),
    (dict(means=np.zeros((2, 3))), "means must have 4 columns"),
    (dict(gate_threshold=-1.0), "gate_threshold must be finite and > 0"),
])
def test_bad_updates_are_refused_naming_the_argument(change, message):
    arguments = dict(model=SENSOR, means=np.zeros((2, 4)), covars=[np.eye(4)] * 2,
                     log_weights=[0.0, 0.0], detections=[[0.0, 1.0]], prob_detect=0.9,
                     clutter_intensity=1e-4)
    arguments.update(change)
    with pytest.raises(ValueError, match=message):
        phd.update(**arguments)


RADAR = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.01, 1.0]),
                                   translation_offset=[5.0, -3.0])


def _wrapped(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize("sensor", [RADAR, ft.Cartesian2DToBearing(4, (0, 2), [[0.01]])])
def test_a_polar_sensor_updates_each_pair_as_the_extended_kalman_filter(sensor):
    means, covars, log_weights = _mixture(2, 4)
    means[3, [0, 2]] = [-40.0, -3.5]  # behind the sensor: bearings near +-pi
    m = sensor.ndim_meas
    detections = np.array([sensor.function(ft.GaussianState(x[:, None], np.eye(4))).ravel()
                           for x in means + 0.3])
    detections[3, 0] = _wrapped(detections[3, 0] + 0.05)
    got = phd.update(sensor, means, covars, log_weights, detections, 0.9, 1e-4)
    assert got[0].shape == (4 * 5, 4)
    w = np.exp(log_weights)
    for k in np.flatnonzero(got[4] >= 0):
        i, z = got[3][k], detections[got[4][k]]
        prior = ft.GaussianState(means[i][:, None], covars[i])
        ekf = ft.ExtendedKalmanUpdater(sensor, use_joseph_cov=False).update(
            ft.SingleHypothesis(prior, ft.Detection(z[:, None], measurement_model=sensor)))
        np.testing.assert_allclose(got[0][k], ekf.state_vector.ravel(), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(got[1][k], ekf.covar, rtol=1e-9, atol=1e-9)
        terms = []
        for j in range(4):
            predicted = ft.ExtendedKalmanUpdater(sensor).predict_measurement(
                ft.GaussianState(means[j][:, None], covars[j]))
            innovation = z - predicted.state_vector.ravel()
            innovation[0] = _wrapped(innovation[0])
            terms.append(0.9 * w[j] * multivariate_normal.pdf(innovation, np.zeros(m),
                                                                predicted.covar))
        assert np.exp(got[2][k]) == pytest.approx(terms[i] / (1e-4 + sum(terms)), rel=1e-9,
                                                  abs=1e-300)


@pytest.mark.parametrize("parameters", [(0.5, 2.0, None), (1.0, 0.0, 1.0)])
def test_the_unscented_form_updates_each_pair_as_the_unscented_kalman_filter(parameters):
    means, covars, log_weights = _mixture(3, 3)
    means[2, [0, 2]] = [-40.0, -3.5]  # behind the sensor: bearings near +-pi
    detections = np.array([RADAR.function(ft.GaussianState(x[:, None], np.eye(4))).ravel()
                           for x in means - 0.4])
    got = phd.update(RADAR, means, covars, log_weights, detections, 0.9, 1e-4,
                     unscented=parameters)
    alpha, beta, kappa = parameters
    ukf = ft.UnscentedKalmanUpdater(RADAR, alpha=alpha, beta=beta, kappa=kappa,
                                    use_joseph_cov=False)
    w = np.exp(log_weights)
    for k in np.flatnonzero(got[4] >= 0):
        i, z = got[3][k], detections[got[4][k]]
        prior = ft.GaussianState(means[i][:, None], covars[i])
        want = ukf.update(ft.SingleHypothesis(prior, ft.Detection(z[:, None],
                                                                  measurement_model=RADAR)))
        np.testing.assert_allclose(got[0][k], want.state_vector.ravel(), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(got[1][k], want.covar, rtol=1e-9, atol=1e-9)
        terms = []
        for j in range(3):
            predicted = ukf.predict_measurement(ft.GaussianState(means[j][:, None], covars[j]))
            innovation = z - predicted.state_vector.ravel()
            innovation[0] = _wrapped(innovation[0])
            terms.append(0.9 * w[j] * multivariate_normal.pdf(innovation, np.zeros(2),
                                                                predicted.covar))
        assert np.exp(got[2][k]) == pytest.approx(terms[i] / (1e-4 + sum(terms)), rel=1e-9)
    extended = phd.update(RADAR, means, covars, log_weights, detections, 0.9, 1e-4)
    assert not np.allclose(extended[1], got[1])  # the two forms differ on a polar sensor
    with pytest.raises(TypeError, match="unscented must be \\(alpha, beta, kappa\\)"):
        phd.update(RADAR, means, covars, log_weights, detections, 0.9, 1e-4, unscented=0.5)
    with pytest.raises(ValueError, match="alpha must be > 0"):
        phd.update(RADAR, means, covars, log_weights, detections, 0.9, 1e-4,
                   unscented=(0.0, 2.0, None))


def test_a_component_at_the_sensor_and_a_sensor_of_user_functions_are_refused():
    with pytest.raises(ValueError, match=r"means\[1\] lies at the sensor"):
        phd.update(RADAR, [[0.0, 1.0, 0.0, 1.0], [5.0, 0.0, -3.0, 0.0]], [np.eye(4)] * 2,
                   [0.0, 0.0], [[0.1, 1.0]], 0.9, 1e-4)
    birth = ft.GaussianMixture([[5.0, 0.0, -3.0, 0.0], [0.0, 1.0, 0.0, 1.0]], [np.eye(4)] * 2,
                               [0.0, 0.0])
    cv = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1)] * 2)
    with pytest.raises(ValueError, match=r"birth.means\[0\] lies at the sensor"):
        ft.PHDTracker(cv, RADAR, birth, 0.9, 0.99, 1e-4)  # (not first at its first update)
    ft.PHDTracker(cv, RADAR, birth, 0.9, 0.99, 1e-4, unscented=(0.5, 2.0, None))
    from user_models import bearing_range_from_50_0
    sensor = ft.NonlinearGaussianMeasurement(bearing_range_from_50_0, 4, np.eye(2))
    with pytest.raises(ValueError, match="take a built-in measurement model"):
        phd.update(sensor, np.zeros((1, 4)), [np.eye(4)], [0.0], [[0.1, 1.0]], 0.9, 1e-4)


def test_no_detections_leaves_the_missed_components():
    means, covars, log_weights = _mixture(0, 3)
    out = phd.update(SENSOR, means, covars, log_weights, np.empty((0, 2)), 0.9, 1e-4)
    np.testing.assert_allclose(out[2], log_weights + np.log(0.1))
    assert (out[4] == -1).all()


# -- The tracker ---------------------------------------------------------------------------

def _tracker(scenario, **settings):
    starts = scenario.truths[0]
    birth = ft.GaussianMixture(starts, np.broadcast_to(np.diag([4.0, 1.0, 4.0, 1.0]),
                                                       (len(starts), 4, 4)),
                               np.log(np.full(len(starts), 0.05)))
    return ft.PHDTracker(scenario.transition_model, scenario.measurement_model, birth,
                         prob_detect=0.9, prob_survival=0.99,
                         clutter_intensity=scenario.clutter_density, **settings)


@pytest.mark.parametrize("gate", [None, 16.0])
def test_the_tracker_finds_the_targets_and_keeps_their_labels(gate):
    from fasttrack.scenarios import grid_targets
    scenario = grid_targets(n_targets=9, steps=25, spacing=30.0, clutter_rate=10.0, seed=1)
    tracker = _tracker(scenario, gate_threshold=gate)
    estimates = tracker.run(scenario.detections)
    assert 7.0 < tracker.expected_number < 11.0
    assert np.mean([len(e) for e in estimates[-10:]]) == pytest.approx(9, abs=1.0)
    labels, distances = [], []
    for truths, found in zip(scenario.truths[-10:], estimates[-10:]):
        distances.append(ft.metrics.gospa(truths[:, [0, 2]], found.means[:, [0, 2]],
                                          c=10.0).distance)
        nearest = np.argmin(np.linalg.norm(found.means[:, [0, 2]] - truths[0, [0, 2]], axis=1))
        labels.append(found.labels[nearest])
    # 9 targets about 1 m off; a missed detection drops a target below 0.5 for a scan and a
    # detection left over may pass it (5 each): 15-25 a scan, against 45 for no estimates
    assert np.mean(distances) < 22.0
    assert len(set(labels)) == 1  # the first target keeps one label


def test_the_tracker_refuses_bad_settings():
    from fasttrack.scenarios import grid_targets
    scenario = grid_targets(n_targets=2, steps=2, seed=0)
    with pytest.raises(TypeError, match="birth must be a GaussianMixture"):
        ft.PHDTracker(scenario.transition_model, scenario.measurement_model, None, 0.9, 0.99,
                      1e-4)
    with pytest.raises(ValueError, match="prob_survival must lie in"):
        _tracker(scenario).__class__(scenario.transition_model, scenario.measurement_model,
                                     _tracker(scenario).birth, 0.9, 1.2, 1e-4)
    tracker = _tracker(scenario)
    tracker.step(scenario.detections[0], 5.0)
    with pytest.raises(ValueError, match=r"time must be after the previous scan's \(5.0 s\)"):
        tracker.step(scenario.detections[1], 5.0)
    with pytest.raises(ValueError, match="time must be finite"):
        tracker.step(scenario.detections[1], np.nan)
    with pytest.raises(TypeError, match="time must be a real number"):
        tracker.step(scenario.detections[1], "6")
    with pytest.raises(ValueError, match="time_interval must be finite and > 0"):
        tracker.run(scenario.detections, 0.0)
    assert tracker.time == 5.0 and len(tracker.run(scenario.detections[1:])) == 1
    assert tracker.time == 6.0
    # settings changed after construction: refused where they are set, the tracker unchanged
    for name, value, error, message in [
            ("prob_survival", 2.0, ValueError, "prob_survival must lie in"),
            ("prob_detect", "0.9", TypeError, "prob_detect must be a real number"),
            ("clutter_intensity", 0.0, ValueError, "clutter_intensity must be finite and > 0"),
            ("gate_threshold", np.nan, ValueError, "gate_threshold must be finite"),
            ("extraction_threshold", -1.0, ValueError, "extraction_threshold must be finite"),
            ("reducer", None, TypeError, "reducer must be of type GaussianMixtureReducer, got "
                                         "NoneType"),
            ("birth", [], TypeError, "birth must be a GaussianMixture, got list"),
            ("birth", ft.GaussianMixture(np.zeros((1, 2)), np.eye(2)[None], [0.1]),
             ValueError, "birth must have 4-D components")]:
        before = getattr(tracker, name)
        with pytest.raises(error, match=message):
            setattr(tracker, name, value)
        assert getattr(tracker, name) is before
    tracker.gate_threshold = None  # (every pair)
    assert len(tracker.step(scenario.detections[1], 7.0)) >= 0


def test_vo_linear_scenario_and_the_tracker_on_it():
    from fasttrack.scenarios import vo_linear, vo_linear_birth
    scenario = vo_linear(clutter_rate=30.0, seed=3)
    counts = [len(t) for t in scenario.truths]
    assert len(counts) == 100 and counts[0] == 3 and max(counts) == 10 and counts[-1] == 10
    assert counts[69] == 10 and counts[70] == 8  # targets 0 and 2 last seen at scan 70
    np.testing.assert_allclose(scenario.truths[0][0], [0.0, 0.0, -10.0, -10.0])  # F x0
    assert scenario.clutter_density == pytest.approx(30.0 / 4e6)
    tracker = ft.PHDTracker(scenario.transition_model, scenario.measurement_model,
                            vo_linear_birth(), prob_detect=0.98, prob_survival=0.99,
                            clutter_intensity=scenario.clutter_density, gate_threshold=13.8)
    estimates = tracker.run(scenario.detections)
    errors = [abs(len(e) - len(t)) for e, t in zip(estimates, scenario.truths)]
    # a newborn target passes 0.5 after a scan or two (12 births), a missed one drops below
    # it for a scan (2 % of some 800): about 0.4-0.5 a scan, against 7.7 for no estimates
    assert np.mean(errors) < 0.8


def test_an_unscented_tracker_predicts_a_component_at_the_sensor():
    """Its prediction measured every component by the sensor's Jacobian, which is undefined
    at a polar sensor: the second scan failed ('filter 0: the measurement Jacobian is
    undefined'), though the unscented update needs no Jacobian."""
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1)] * 2)
    birth = ft.GaussianMixture(np.array([[5.0, 0.0, -3.0, 0.0]]), np.eye(4)[None])  # at it
    tracker = ft.PHDTracker(transition, RADAR, birth, 0.9, 0.99, 1e-3,
                            unscented=(0.5, 2, None))
    for time in (0.0, 1.0, 2.0):
        tracker.step([[0.7, 10.0]], time)
    assert np.isfinite(tracker.mixture.means).all() and len(tracker.mixture)
