"""The IMM multi-target tracker: one model is today's tracker, turning targets are kept by
turn models, and its tracks' mode probabilities and bad input."""
import numpy as np
import pytest

import fasttrack as ft
from fasttrack.simulate import multi_target
from fasttrack.tracker import IMMTracker, MultiTargetTracker

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
])
def test_bad_input_is_refused_naming_the_argument(change, message):
    arguments = dict(transition_models=[TRANSITION, TRANSITION], measurement_model=SENSOR,
                     transition_matrix=[[0.9, 0.1], [0.1, 0.9]], **SETTINGS)
    arguments.update(change)
    with pytest.raises(ValueError, match=message):
        IMMTracker(**arguments)
