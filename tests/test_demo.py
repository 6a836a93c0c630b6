"""The README's main job: ``python -m fasttrack demo`` runs end to end, and the plots."""
import subprocess
import sys

import numpy as np
import pytest

import fasttrack as ft
from fasttrack.scenarios import adaptive_kernel_tutorial, extended_kalman_tutorial

matplotlib = pytest.importorskip("matplotlib")
from matplotlib import image  # noqa: E402

from fasttrack import plotting  # noqa: E402


@pytest.mark.slow
def test_quick_demo_runs_and_writes_plots(tmp_path):
    done = subprocess.run([sys.executable, "-m", "fasttrack", "demo", "--quick", "--out",
                           str(tmp_path)], capture_output=True, text=True, check=True,
                          timeout=600)
    out = done.stdout
    assert "Resampler tutorial" in out and "offspring" in out
    for row in ("resample systematic", "resample residual", "particle filter",
                "extended Kalman filter", "AKKF quadratic", "AKKF gaussian", "GM-PHD",
                "GM-CPHD", "IMM, 3 turn models", "IMM smoother"):
        assert row in out
    assert "speed-up" in out and "Demo finished" in out
    pngs = sorted(tmp_path.glob("*.png"))
    assert len(pngs) >= 7 and {"cphd-vo-linear-30.png", "target-count-30.png",
                               "imm-mode-probabilities-filtered.png",
                               "imm-mode-probabilities-smoothed.png", "imm-track.png"} <= {
        png.name for png in pngs}
    for png in pngs:
        _assert_drawn(png)


def _assert_drawn(path):
    pixels = image.imread(path)
    assert pixels.shape[0] > 100 and pixels.shape[1] > 100
    assert (pixels[..., :3] < 0.9).mean() > 0.005  # not a blank canvas


def test_cli_rejects_unknown_commands():
    done = subprocess.run([sys.executable, "-m", "fasttrack", "fly"], capture_output=True,
                          text=True)
    assert done.returncode == 2 and "invalid choice" in done.stderr


def test_plots_of_tracks_detections_particles_and_ellipses(tmp_path):
    scenario = extended_kalman_tutorial(steps=5)
    predictor = ft.ExtendedKalmanPredictor(scenario.transition_model)
    updater = ft.ExtendedKalmanUpdater(scenario.measurement_model)
    track = ft.run_filter(predictor, updater, scenario.prior, scenario.detections)
    ax = plotting.plot_ground_truth(scenario.truth)
    assert plotting.plot_detections(scenario.detections, ax=ax) is ax
    plotting.plot_track(track, ax=ax, uncertainty=True)
    assert len(ax.patches) == len(track) and len(ax.collections) == 1
    _assert_drawn(plotting.save(ax, tmp_path / "ekf.png", title="EKF"))
    bearings = adaptive_kernel_tutorial(10, steps=4)
    ax = plotting.plot_detections(bearings.detections)
    plotting.plot_track([bearings.prior], ax=ax, particles=True)
    _assert_drawn(plotting.save(ax, tmp_path / "bearings.png"))
    ax = plotting.plot_resampling([0.1, 0.5, 0.15, 0.05, 0.2], points=np.linspace(0.1, 0.9, 5))
    assert len(ax.patches) == 5
    ax = plotting.plot_resampling([0.1, 0.5, 0.15, 0.05, 0.2], offspring=[0, 3, 1, 0, 1])
    (marks,) = ax.collections
    x = marks.get_offsets()[:, 0]
    assert np.allclose(x, [0.1 + 0.5 / 6, 0.1 + 0.5 / 2, 0.1 + 2.5 / 6, 0.675, 0.9])
    bars = [(p.get_x(), p.get_x() + p.get_width()) for p in ax.patches]
    assert all(bars[1][0] < v < bars[1][1] for v in x[:3])  # particle 1's copies on its bar
    assert [t.get_text() for t in ax.texts] == ["x 3", "x 1", "x 1"]
    assert "drawn copies" in ax.get_legend_handles_labels()[1]
    _assert_drawn(plotting.save(ax, tmp_path / "cdf.png"))


@pytest.mark.parametrize("resampler", [ft.SystematicResampler, ft.StratifiedResampler,
                                       ft.MultinomialResampler])
def test_resampling_plot_marks_sit_on_the_bars_of_the_particles_drawn(resampler):
    weights = np.array([1, 5, 1.5, 0.5, 2]) / 10
    particles = ft.ParticleState(np.arange(5.0)[None], weight=weights)
    drawn = resampler(rng=7).resample(particles).state_vector[0].astype(int)
    ax = plotting.plot_resampling(weights, ft.resampling_points(5, resampler.method, rng=7))
    (marks,) = ax.collections
    bars = np.array([(p.get_x(), p.get_x() + p.get_width()) for p in ax.patches])
    under = [np.flatnonzero((bars[:, 0] <= x) & (x < bars[:, 1]))[0]
             for x in marks.get_offsets()[:, 0]]
    np.testing.assert_array_equal(np.sort(under), drawn)


def test_multi_target_plot_draws_truths_clutter_detections_and_tracks():
    from fasttrack.scenarios import grid_targets
    scenario = grid_targets(n_targets=4, steps=12, clutter_rate=6.0, seed=1)
    tracker = ft.MultiTargetTracker(scenario.transition_model, scenario.measurement_model,
                                    np.zeros(4), np.diag([0.0, 1.0, 0.0, 1.0]))
    tracks = tracker.run(scenario.detections)
    ax = plotting.plot_multi_target(scenario, tracks)
    labels = ax.get_legend_handles_labels()[1]
    assert labels == ["ground truth", "clutter", "target detections", "tracks"]
    clutter, detected = ax.collections
    origins = np.concatenate(scenario.origins)
    assert len(clutter.get_offsets()) == (origins < 0).sum()
    np.testing.assert_allclose(detected.get_offsets(),
                               np.concatenate(scenario.detections)[origins >= 0])
    lines = ax.get_lines()
    n_tracks = len({int(i) for t in tracks for i in t.ids})
    assert len(lines) == 4 + n_tracks  # a dashed path per target, a line per track
    first = lines[0].get_xydata()
    np.testing.assert_allclose(first, [x[0, [0, 2]] for x in scenario.truths])
    assert ax.get_xlabel() == "x = state[0] (m)"


def test_phd_estimates_and_the_number_of_targets_are_drawn():
    from fasttrack.scenarios import vo_linear, vo_linear_birth
    scenario = vo_linear(clutter_rate=10.0, seed=0)
    tracker = ft.CPHDTracker(scenario.transition_model, scenario.measurement_model,
                             vo_linear_birth(), 0.98, 0.99, scenario.clutter_density, 10.0,
                             max_targets=20, gate_threshold=13.8)
    estimates = tracker.run(scenario.detections[:30])
    ax = plotting.plot_multi_target(scenario, estimates)
    assert ax.get_legend_handles_labels()[1][-1] == "estimates (a path per label)"
    labels = {int(i) for e in estimates for i in e.labels}
    assert len(ax.get_lines()) == 12 + len(labels)  # a dashed path per target, one per label
    counts = [len(e) for e in estimates]
    ax = plotting.plot_target_count(scenario, {"CPHD": counts})
    truth, line = ax.get_lines()
    assert truth.get_ydata().tolist() == [len(x) for x in scenario.truths]
    assert line.get_ydata().tolist() == counts and ax.get_ylabel() == "number of targets"


def test_mode_probabilities_and_paths_are_drawn():
    probs = np.array([[0.2, 0.8], [0.6, 0.4], [0.9, 0.1]])
    ax = plotting.plot_mode_probabilities(probs, ["turn", "straight"], [0.0, 0.01, 0.01])
    lines = ax.get_lines()
    assert [line.get_label() for line in lines] == ["turn", "straight"]
    np.testing.assert_array_equal(lines[1].get_ydata(), probs[:, 1])
    assert "turning" in ax.get_legend_handles_labels()[1]  # the turns shaded
    ax = plotting.plot_paths({"truth": [[0, 0], [1, 1]], "estimate": [[0, 0.1], [1, 1.1]]})
    truth, estimate = ax.get_lines()
    assert truth.get_linestyle() == "--" and estimate.get_label() == "estimate"
    np.testing.assert_array_equal(estimate.get_ydata(), [0.1, 1.1])


def test_plotting_errors():
    class Unknown:
        state_vector = np.zeros((1, 1))
        measurement_model = ft.LinearGaussian(2, (0,), np.eye(1))
    with pytest.raises(ValueError, match="cannot map LinearGaussian"):
        plotting.plot_detections([Unknown()])
    with pytest.raises(ValueError, match=r"offspring must have one count per weight, \(3,\)"):
        plotting.plot_resampling([0.2, 0.3, 0.5], offspring=[1, 2])


def test_bearing_rays_keep_the_view_of_the_track_and_everything_is_labelled():
    scenario = adaptive_kernel_tutorial(30, steps=10)
    predictor = ft.AdaptiveKernelKalmanPredictor(scenario.transition_model)
    updater = ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, rng=1)
    track = ft.run_filter(predictor, updater, scenario.prior, scenario.detections)
    ax = plotting.plot_ground_truth(scenario.truth)
    view = ax.get_xlim(), ax.get_ylim()
    plotting.plot_detections(scenario.detections, ax=ax)
    assert (ax.get_xlim(), ax.get_ylim()) == view  # the rays do not stretch the axes
    corners = np.array([[x, y] for x in view[0] for y in view[1]])
    origin = np.ravel(scenario.measurement_model.translation_offset)[:2]
    (rays,) = ax.collections
    for ends in rays.get_segments():
        assert np.allclose(ends[0], origin)
        assert np.linalg.norm(ends[1] - origin) == pytest.approx(
            3 * np.linalg.norm(corners - origin, axis=1).max())
    plotting.plot_track(track, ax=ax, particles=True)
    labels = ax.get_legend_handles_labels()[1]
    assert labels == ["ground truth", "bearings", "track", "track particles"]
    assert ax.get_xlabel() == "x = state[0] (m)" and ax.get_ylabel() == "y = state[2] (m)"
    ekf = extended_kalman_tutorial(steps=4)
    ekf_track = ft.run_filter(ft.ExtendedKalmanPredictor(ekf.transition_model),
                              ft.ExtendedKalmanUpdater(ekf.measurement_model), ekf.prior,
                              ekf.detections)
    ax = plotting.plot_track(ekf_track, uncertainty=True)
    assert "track 1-sigma ellipses" in ax.get_legend_handles_labels()[1]
