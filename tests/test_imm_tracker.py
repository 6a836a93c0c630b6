"""The IMM multi-target tracker: one model is today's tracker, turning targets are kept by
turn models, and its tracks' mode probabilities and bad input."""
import numpy as np
import pytest

import fasttrack as ft
from fasttrack.simulate import multi_target
from fasttrack.tracker import IMMTracker, MultiTargetTracker
from fasttrack.types.mixture import TrackSet

TRANSITION = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
SENSOR = ft.LinearGaussian(4, (0, 2), np.eye(2))
SETTINGS = dict(prior_mean=np.zeros(4), prior_covar=np.diag([0.0, 1.0, 0.0, 1.0]),
                missed_distance=3.0, min_points=3, delete_after_misses=3, tentative_misses=2)


def _scenario(model, n=12, steps=30, clutter=5.0, seed=3, speed=1.0):
    rng = np.random.default_rng(seed)
    pos = np.c_[np.arange(n) % 4, np.arange(n) // 4] * 40.0 + rng.normal(0, 1, (n, 2))
    vel = rng.normal(0, speed, (n, 2))
    x0 = np.c_[pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]]
    return multi_target(model, SENSOR, x0, steps, [[-60, -60], [180, 180]], prob_detect=0.9,
                        clutter_rate=clutter, rng=seed)


@pytest.mark.parametrize("association", ["gnn", "nn"])
def test_one_model_is_the_multi_target_tracker(association):
    scenario = _scenario(TRANSITION)
    plain = MultiTargetTracker(TRANSITION, SENSOR, association=association, **SETTINGS)
    imm = IMMTracker([TRANSITION], SENSOR, [[1.0]], association=association, **SETTINGS)
    for t, scan in enumerate(scenario.detections):
        want, got = plain.step(scan, float(t)), imm.step(scan, float(t))
        assert isinstance(got, ft.types.IMMTrackSet)
        np.testing.assert_array_equal(got.ids, want.ids)
        np.testing.assert_array_equal(got.updates, want.updates)
        np.testing.assert_allclose(got.means, want.means, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(got.covars, want.covars, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(got.model_means[:, 0], got.means, rtol=1e-12, atol=1e-12)
        assert (got.mode_probs == 1.0).all()
    assert len(want) >= 10  # a run that confirmed the targets


def _errors(tracks, truths):
    """Each truth's distance to its nearest confirmed track's position (inf if none)."""
    if len(tracks) == 0:
        return np.full(len(truths), np.inf)
    gaps = np.hypot(truths[:, None, 0] - tracks.means[None, :, 0],
                    truths[:, None, 2] - tracks.means[None, :, 2])
    return gaps.min(axis=1)


def test_turning_targets_are_kept_by_turn_models():
    turning = ft.KnownTurnRate([0.05, 0.05], 0.3)
    scenario = _scenario(turning, speed=3.0, seed=5)
    models = [ft.KnownTurnRate([0.05, 0.05], w) for w in (0.3, 0.0, -0.3)]
    matrix = np.full((3, 3), 0.05) + 0.85 * np.eye(3)
    imm = IMMTracker(models, SENSOR, matrix, **SETTINGS)
    plain = MultiTargetTracker(TRANSITION, SENSOR, **SETTINGS)
    held = {"imm": [], "plain": []}
    for t, (scan, truths) in enumerate(zip(scenario.detections, scenario.truths)):
        for name, tracker in (("imm", imm), ("plain", plain)):
            held[name].append(np.mean(_errors(tracker.step(scan, float(t)), truths) < 3.0))
        if len(imm.confirmed):
            np.testing.assert_allclose(imm.confirmed.mode_probs.sum(axis=1), 1.0, rtol=1e-12)
    imm_held, plain_held = np.mean(held["imm"][5:]), np.mean(held["plain"][5:])
    # measured: 81 % of the targets within 3 m of a confirmed IMM track, 38 % of a CV one
    assert imm_held > 0.7 and imm_held > plain_held + 0.3
    assert imm.confirmed.mode_probs.mean(axis=0).argmax() == 0  # the turn flown


@pytest.mark.parametrize("change,message", [
    (dict(transition_models=[]), "transition_models must hold at least one model"),
    (dict(transition_matrix=[[0.5, 0.6], [0.5, 0.5]]), "row 0 sums to 1.1"),
    (dict(mode_probs=[0.2, 0.2]), "mode_probs must sum to 1; they sum to 0.4"),
    (dict(mode_probs=[0.2, 0.3, 0.5]), r"mode_probs must have shape \(2,\)"),
    (dict(association="jpda"), "association='jpda' needs clutter_density"),
    (dict(association="jpda", clutter_density=1e-3, prob_detect=0.0), "prob_detect must be > 0"),
    (dict(association="pda"), r"association must be one of \['gnn', 'jpda', 'nn'\]"),
    (dict(association=np.array(["jpda"])), "association must be one of"),
])
def test_bad_input_is_refused_naming_the_argument(change, message):
    arguments = dict(transition_models=[TRANSITION, TRANSITION], measurement_model=SENSOR,
                     transition_matrix=[[0.9, 0.1], [0.1, 0.9]], **SETTINGS)
    arguments.update(change)
    with pytest.raises(ValueError, match=message):
        IMMTracker(**arguments)


def test_settings_changed_after_construction_are_checked():
    tracker = IMMTracker([TRANSITION, TRANSITION], SENSOR, [[0.9, 0.1], [0.1, 0.9]],
                         association="jpda", clutter_density=1e-3, **SETTINGS)
    for name, value, error, match in [
            ("transition_matrix", np.eye(3), ValueError, r"must have shape \(2, 2\)"),
            ("mode_probs", [1.0], ValueError, r"mode_probs must have shape \(2,\)"),
            ("prob_detect", 0.0, ValueError, "prob_detect must be > 0 for JPDA"),
            ("clutter_density", -1.0, ValueError, "clutter_density must be finite and > 0"),
            ("confirmed", TrackSet.empty(4), TypeError,
             "confirmed must be of type IMMTrackSet, got TrackSet")]:
        with pytest.raises(error, match=match):
            setattr(tracker, name, value)
    gate = tracker.prob_gate
    tracker.missed_distance = 4.0  # the JPDA gate probability follows the gate
    assert tracker.prob_gate > gate
    tracker.step(np.zeros((1, 2)), 0.0)
    assert len(tracker.tentative) == 1
    with pytest.raises(ValueError, match="max_nodes must be >= 1, got 0"):
        tracker.max_nodes = 0


def test_detections_whose_squares_overflow_are_refused():
    tracker = IMMTracker([TRANSITION, TRANSITION], SENSOR, [[0.9, 0.1], [0.1, 0.9]],
                         **SETTINGS)
    tracker.step([[1e149, -1e149]], 0.0)
    with pytest.raises(ValueError, match=r"detections must lie within \+-1e\+150 \(the "
                                         r"models' mixing squares differences of states\), "
                                         r"got 1e\+160"):
        tracker.step([[1.0, -1e160]], 1.0)


def test_a_jpda_cluster_beyond_max_nodes_is_refused_naming_it():
    tracker = IMMTracker([TRANSITION, TRANSITION], SENSOR, [[0.9, 0.1], [0.1, 0.9]],
                         association="jpda", clutter_density=1e-3, max_nodes=2, **SETTINGS)
    tracker.step([[0.0, 0.0], [1.0, 0.0]], 0.0)
    with pytest.raises(ValueError, match=r"\(2 tracks x 3 detections\) is too big for exact "
                                         r"JPDA: its EHM net needs more than max_nodes=2"):
        tracker.step([[0.5, 0.0], [0.6, 0.0], [0.4, 0.1]], 1.0)
    assert tracker.time == 0.0  # the failed scan left the tracker as it was
    tracker.max_nodes = 100  # the same scan with room: both tracks take it
    tracker.step([[0.5, 0.0], [0.6, 0.0], [0.4, 0.1]], 1.0)
    assert len(tracker.tentative) == 2


def test_the_jpda_update_is_each_hypothesis_and_model_merged():
    """jpda_updates against Kalman updates of every (detection, model) pair, merged by the
    joint probabilities built from the dense JPDA marginals of the mixture likelihoods."""
    from scipy.stats import chi2, multivariate_normal

    from fasttrack.association import gate, jpda_marginals
    from fasttrack.core import imm
    rng = np.random.default_rng(4)
    models = [ft.KnownTurnRate([0.1, 0.1], w) for w in (0.2, 0.0, -0.2)]
    matrix = np.full((3, 3), 0.1) + 0.7 * np.eye(3)
    k = 4
    means = np.repeat(np.array([[0.0, 1, 0, 1], [3.0, -1, 0, 1], [40, 0, 40, 0],
                                [-40, 0, -40, 0]])[:, None], 3, axis=1)
    means = means + rng.normal(size=means.shape) * 0.3
    covars = np.tile(np.diag([2.0, 0.5, 2.0, 0.5]), (k, 3, 1, 1))
    probs = rng.dirichlet(np.ones(3), size=k)
    x, p, c, z_hats, s = imm.predictions(models, SENSOR, matrix, means, covars, probs,
                                         np.ones(k))
    detections = np.array([[1.5, 1.2], [2.5, 0.8], [4.0, 1.5], [41.0, 39.0], [90.0, 90.0]])
    pd, density = 0.9, 1e-3
    result = gate(*imm.combine(z_hats, s, c), detections, 16.0)
    pg = float(chi2.cdf(16.0, 2))
    got = imm.jpda_updates(SENSOR, x, p, c, z_hats, s, detections, result, pd, pg, density)
    weights = np.zeros((k, len(detections) + 1))
    weights[:, 0] = 1 - pd * pg
    likelihood = np.zeros((k, len(detections), 3))
    for t in range(k):
        for j in result.detections[result.starts[t]:result.starts[t + 1]]:
            for m in range(3):
                likelihood[t, j, m] = multivariate_normal.pdf(detections[j], z_hats[t, m],
                                                              s[t, m])
            weights[t, j + 1] = pd * (c[t] @ likelihood[t, j]) / density
    beta = jpda_marginals(weights)
    assert result.starts[-1] > 0 and np.diff(result.starts)[3] == 0  # an empty gate
    h = SENSOR.matrix()
    for t in range(k):
        for m in range(3):
            joint = [beta[t, 0] * c[t, m]]
            states = [(x[t, m], p[t, m])]
            for j in result.detections[result.starts[t]:result.starts[t + 1]]:
                joint.append(beta[t, j + 1] * c[t, m] * likelihood[t, j, m]
                             / (c[t] @ likelihood[t, j]))
                gain = p[t, m] @ h.T @ np.linalg.inv(s[t, m])
                states.append((x[t, m] + gain @ (detections[j] - z_hats[t, m]),
                               p[t, m] - gain @ s[t, m] @ gain.T))
            joint = np.array(joint)
            np.testing.assert_allclose(got[2][t, m], joint.sum(), rtol=1e-9, atol=1e-12)
            w = joint / joint.sum()
            mean = sum(wi * xi for wi, (xi, _) in zip(w, states))
            covar = sum(wi * (pi + np.outer(xi - mean, xi - mean))
                        for wi, (xi, pi) in zip(w, states))
            np.testing.assert_allclose(got[0][t, m], mean, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(got[1][t, m], covar, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(got[3], beta[:, 0], rtol=1e-12)
    np.testing.assert_allclose(got[2][3], c[3], rtol=1e-12)  # no detection: the prediction


def test_imm_jpda_keeps_turning_targets():
    turning = ft.KnownTurnRate([0.05, 0.05], 0.3)
    scenario = _scenario(turning, speed=3.0, seed=5)
    models = [ft.KnownTurnRate([0.05, 0.05], w) for w in (0.3, 0.0, -0.3)]
    matrix = np.full((3, 3), 0.05) + 0.85 * np.eye(3)
    imm = IMMTracker(models, SENSOR, matrix, association="jpda", prob_detect=0.9,
                     clutter_density=scenario.clutter_density, **SETTINGS)
    held = []
    for t, (scan, truths) in enumerate(zip(scenario.detections, scenario.truths)):
        held.append(np.mean(_errors(imm.step(scan, float(t)), truths) < 3.0))
    # measured: 81 % of the targets within 3 m of a confirmed track (as IMM-GNN)
    assert np.mean(held[5:]) > 0.7
    np.testing.assert_allclose(imm.confirmed.mode_probs.sum(axis=1), 1.0, rtol=1e-12)
    assert imm.confirmed.mode_probs.mean(axis=0).argmax() == 0
