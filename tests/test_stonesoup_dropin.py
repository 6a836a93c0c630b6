"""fasttrack.stonesoup: Stone Soup's tutorials with switched imports, Stone Soup's documented
behaviours, equivalence with Stone Soup, and Stone Soup's own tracker driving the drop-ins."""
import datetime
import pathlib
import re
import subprocess
import sys
import types

import numpy as np
import pytest
from scipy import stats

pytest.importorskip("stonesoup")
import matplotlib  # noqa: E402

matplotlib.use("Agg")

from stonesoup.kernel import QuadraticKernel as SSQuadraticKernel  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.measurement.nonlinear import (  # noqa: E402
    Cartesian2DToBearing, CartesianToBearingRange)
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor import kalman as ss_kalman_predictor  # noqa: E402
from stonesoup.predictor import kernel as ss_kernel_predictor  # noqa: E402
from stonesoup.predictor import particle as ss_particle_predictor  # noqa: E402
from stonesoup.resampler import particle as ss_resampler  # noqa: E402
from stonesoup.types import prediction as ss_prediction  # noqa: E402
from stonesoup.types import update as ss_update  # noqa: E402
from stonesoup.types.array import StateVectors  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.state import (GaussianState, KernelParticleState,  # noqa: E402
                                   ParticleState)
from stonesoup.updater import kalman as ss_kalman_updater  # noqa: E402
from stonesoup.updater import kernel as ss_kernel_updater  # noqa: E402
from stonesoup.updater import particle as ss_particle_updater  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402
from fasttrack.metrics import position_rmse  # noqa: E402

TUTORIALS = pathlib.Path(__file__).resolve().parent / "data" / "stonesoup_tutorials"
START = datetime.datetime(2026, 1, 1)
STEP = datetime.timedelta(seconds=1)
SWITCHED = (r"stonesoup\.(?:resampler\.particle|predictor\.(?:particle|kalman|kernel)"
            r"|updater\.(?:particle|kalman|kernel)|kernel)")
#: The 1.9 way to build the particle-filter tutorial's prior (its ``Particles`` type is gone
#: from Stone Soup 1.x, see the tutorials' README).
PARTICLES_FIX = [
    ("from stonesoup.types.particle import Particles\n", ""),
    ("particles = Particles(state_vector=StateVectors(samples.T),\n"
     "                      weight=np.array([Probability(1/number_particles)]*number_particles)\n"
     "                      )\n", ""),
    ("prior = ParticleState(particles, timestamp=start_time)",
     "prior = ParticleState(StateVectors(samples.T),\n"
     "                      weight=np.array([Probability(1/number_particles)]*number_particles),\n"
     "                      timestamp=start_time)"),
]


def switched_tutorial(prefix):
    """A Stone Soup tutorial's source with its imports of the replaced classes switched to
    fasttrack.stonesoup, and the number of import lines switched."""
    path = next(TUTORIALS.glob(f"{prefix}_*.txt"))
    text = path.read_text()
    if prefix == "002":
        for old, new in PARTICLES_FIX:
            assert old in text
            text = text.replace(old, new)
    return re.subn(rf"^(\s*)from {SWITCHED} import ", r"\1from fasttrack.stonesoup import ",
                   text, flags=re.M)


@pytest.mark.parametrize("prefix, switched, uses", [
    ("000", 2, "resampler"), ("002", 3, "predictor"), ("003", 3, "predictor"),
    ("004", 2, "predictor")])
def test_stonesoup_tutorials_run_on_the_drop_ins(prefix, switched, uses):
    text, count = switched_tutorial(prefix)
    assert count == switched
    namespace = {"__name__": "__main__"}
    exec(compile(text, f"tutorial {prefix}", "exec"), namespace)
    assert type(namespace[uses]).__module__.startswith("fasttrack.stonesoup")
    if "track" in namespace:
        assert len(namespace["track"]) == len(namespace["measurements"])
    matplotlib.pyplot.close("all")


# -- the tutorial scenarios, built with Stone Soup -----------------------------------------

def _truth(transition, start, steps):
    truth = GroundTruthPath([GroundTruthState(start, timestamp=START)])
    for k in range(1, steps):
        truth.append(GroundTruthState(transition.function(truth[k - 1], noise=True,
                                                          time_interval=STEP),
                                      timestamp=START + k * STEP))
    return truth


def _detections(truth, sensor):
    return [Detection(sensor.function(s, noise=True), timestamp=s.timestamp,
                      measurement_model=sensor) for s in truth]


def _bearing_range_scenario(seed):
    np.random.seed(seed)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    truth = _truth(transition, [0, 1, 0, 1], 21)
    sensor = CartesianToBearingRange(ndim_state=4, mapping=(0, 2),
                                     noise_covar=np.diag([np.radians(0.2), 1]),
                                     translation_offset=np.array([[50], [0]]))
    return transition, sensor, truth, _detections(truth, sensor)


def _run(predictor, updater, prior, detections):
    track = []
    for detection in detections:
        prior = updater.update(SingleHypothesis(
            predictor.predict(prior, timestamp=detection.timestamp), detection))
        track.append(prior)
    return track


def _particle_filter_rmse(seed, classes):
    predictor_class, updater_class, resampler_class = classes
    transition, sensor, truth, detections = _bearing_range_scenario(seed)
    samples = np.random.multivariate_normal([0, 1, 0, 1], np.diag([1.5, 0.5, 1.5, 0.5]), 1000)
    prior = ParticleState(StateVectors(samples.T), weight=np.full(1000, 1e-3), timestamp=START)
    track = _run(predictor_class(transition), updater_class(sensor, resampler_class()), prior,
                 detections)
    return position_rmse(track, truth)


def test_particle_filter_statistically_equal_to_stone_soup():
    ours = [_particle_filter_rmse(seed, (fss.ParticlePredictor, fss.ParticleUpdater,
                                         fss.SystematicResampler)) for seed in range(20)]
    theirs = [_particle_filter_rmse(seed, (ss_particle_predictor.ParticlePredictor,
                                           ss_particle_updater.ParticleUpdater,
                                           ss_resampler.SystematicResampler))
              for seed in range(20)]
    assert stats.wilcoxon(ours, theirs).pvalue > 0.01  # paired: same truth and detections
    assert abs(np.mean(ours) - np.mean(theirs)) < 0.25 * np.std(theirs) + 0.05


def _akkf_rmse(seed, predictor_class, updater_class, kernel_class):
    np.random.seed(seed)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-4)] * 2)
    truth = _truth(transition, [-0.3, 0.001, 0.7, -0.055], 30)
    sensor = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                  noise_covar=np.array([[0.005 ** 2]]))
    detections = _detections(truth, sensor)
    samples = np.random.multivariate_normal(truth[0].state_vector.ravel(),
                                            np.diag([0.1, 0.005, 0.1, 0.01]) ** 2, 30)
    prior = KernelParticleState(state_vector=StateVectors(samples.T), weight=np.full(30, 1 / 30),
                                timestamp=START)
    kernel = kernel_class(c=1, ialpha=1)
    track = _run(predictor_class(transition_model=transition, kernel=kernel),
                 updater_class(measurement_model=sensor, kernel=kernel), prior, detections)
    return position_rmse(track, truth)


def test_akkf_statistically_equal_to_stone_soup():
    ours = [_akkf_rmse(seed, fss.AdaptiveKernelKalmanPredictor, fss.AdaptiveKernelKalmanUpdater,
                       fss.QuadraticKernel) for seed in range(20)]
    theirs = [_akkf_rmse(seed, ss_kernel_predictor.AdaptiveKernelKalmanPredictor,
                         ss_kernel_updater.AdaptiveKernelKalmanUpdater, SSQuadraticKernel)
              for seed in range(20)]
    assert stats.wilcoxon(ours, theirs).pvalue > 0.01
    assert stats.ks_2samp(ours, theirs).pvalue > 0.01


def test_kernel_filter_settings_outside_fasttracks_range_run_stone_soups_code():
    """A ridge <= 0 and NaN kernel weights: Stone Soup computes them; the drop-ins ran the
    kernels and blamed an overflow."""
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    rng = np.random.default_rng(3)
    weight = np.full(20, 1 / 20)
    prior = KernelParticleState(StateVectors(rng.normal(size=(4, 20))), weight=weight,
                                kernel_covar=np.eye(20), timestamp=START)
    later = START + datetime.timedelta(seconds=1)
    fss.fallbacks(clear=True)
    for regulariser, weights in [(-1.0, weight), (1e-3, np.r_[np.nan, weight[1:]])]:
        state = KernelParticleState(prior.state_vector, weight=weights,
                                    kernel_covar=np.eye(20), timestamp=START)
        ours = fss.AdaptiveKernelKalmanPredictor(transition, kernel=fss.QuadraticKernel(),
                                                 lambda_predictor=regulariser)
        theirs = ss_kernel_predictor.AdaptiveKernelKalmanPredictor(
            transition, kernel=SSQuadraticKernel(), lambda_predictor=regulariser)
        np.testing.assert_allclose(np.asarray(ours.predict(state, later).weight, float),
                                   np.asarray(theirs.predict(state, later).weight, float),
                                   rtol=1e-9, atol=1e-12, equal_nan=True)
    reasons = {reason for (_, method, reason) in fss.fallbacks() if method == "predict"}
    assert reasons == {"lambda_predictor -1.0 outside fasttrack's range (finite, > 0)",
                       "kernel weights that are not finite"}


def _ekf_track(seed, predictor_class, updater_class, sensor=None):
    transition, polar, truth, detections = _bearing_range_scenario(seed)
    if sensor is not None:
        detections = [Detection(sensor.function(s, noise=True), timestamp=s.timestamp,
                                measurement_model=sensor) for s in truth]
    prior = GaussianState([[0], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5]), timestamp=START)
    return _run(predictor_class(transition), updater_class(sensor or polar), prior, detections)


def _max_relative_difference(ours, theirs):
    def relative(a, b):
        b = np.asarray(b, dtype=float)
        return np.abs(np.asarray(a, dtype=float) - b).max() / np.abs(b).max()
    return (max(relative(a.state_vector, b.state_vector) for a, b in zip(ours, theirs)),
            max(relative(a.covar, b.covar) for a, b in zip(ours, theirs)))


def test_kalman_filter_equal_to_stone_soup_with_a_linear_sensor():
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    for seed in range(3):
        for predictor, updater in [
                (fss.KalmanPredictor, fss.KalmanUpdater),
                (fss.ExtendedKalmanPredictor, fss.ExtendedKalmanUpdater)]:
            ours = _ekf_track(seed, predictor, updater, sensor)
            theirs = _ekf_track(seed, ss_kalman_predictor.KalmanPredictor,
                                ss_kalman_updater.KalmanUpdater, sensor)
            assert max(_max_relative_difference(ours, theirs)) < 1e-9


def test_extended_kalman_filter_matches_stone_soup_to_its_own_jacobian_noise():
    """With the bearing-range sensor both use forward differences with Stone Soup's step
    rule; Stone Soup evaluates the bearings with NumPy's vectorised arctan2, fasttrack with
    its own, and a step of about 1e-8 turns their last-bit differences into ~1e-8 relative
    differences of the Jacobian. Stone Soup's own Jacobian moves by more than that when the
    state moves by one unit in the last place, so agreement is checked at 1e-6."""
    for seed in range(5):
        ours = _ekf_track(seed, fss.ExtendedKalmanPredictor, fss.ExtendedKalmanUpdater)
        theirs = _ekf_track(seed, ss_kalman_predictor.ExtendedKalmanPredictor,
                            ss_kalman_updater.ExtendedKalmanUpdater)
        mean_difference, covar_difference = _max_relative_difference(ours, theirs)
        assert mean_difference < 1e-6 and covar_difference < 1e-5
    sensor = _bearing_range_scenario(0)[1]
    moves = []
    for state in np.random.default_rng(1).normal([10, 1, 10, 1], [5, 1, 5, 1], (50, 4)):
        state = state.reshape(-1, 1)
        jacobian = sensor.jacobian(GaussianState(state, np.eye(4)))
        moved = sensor.jacobian(GaussianState(np.nextafter(state, np.inf), np.eye(4)))
        moves.append(np.abs(jacobian - moved).max() / np.abs(jacobian).max())
    assert max(moves) > 1e-8


# -- Stone Soup's documented behaviours -----------------------------------------------------

def _particles(n=50, seed=0, timestamp=START):
    rng = np.random.default_rng(seed)
    weights = rng.random(n)
    return ParticleState(StateVectors(rng.normal(size=(4, n))), weight=weights / weights.sum(),
                         timestamp=timestamp)


def test_particle_filter_output_types_links_and_timestamps():
    transition, sensor, _, detections = _bearing_range_scenario(3)
    prior = _particles()
    predictor = fss.ParticlePredictor(transition)
    prediction = predictor.predict(prior, timestamp=START + STEP)
    assert type(prediction) is ss_prediction.ParticleStatePrediction
    assert prediction.parent is prior and prediction.prior is prior
    assert prediction.log_weight is prior.log_weight
    assert prediction.timestamp == START + STEP
    hypothesis = SingleHypothesis(prediction, detections[1])
    update = fss.ParticleUpdater(sensor).update(hypothesis)
    assert type(update) is ss_update.ParticleStateUpdate
    assert update.hypothesis is hypothesis and update.parent is prior
    assert update.timestamp == prediction.timestamp  # the prediction's, as Stone Soup
    assert update.state_vector is prediction.state_vector
    assert np.logaddexp.reduce(update.log_weight) == pytest.approx(0.0, abs=1e-12)
    expected = prediction.log_weight + sensor.logpdf(detections[1], prediction)
    np.testing.assert_allclose(update.log_weight, expected - np.logaddexp.reduce(expected),
                               atol=1e-9)


def test_resampled_update_has_equal_weights_and_the_prior_ancestors_as_parent():
    transition, sensor, _, detections = _bearing_range_scenario(4)
    prior = _particles(200)
    prediction = fss.ParticlePredictor(transition).predict(prior, timestamp=START + STEP)
    update = fss.ParticleUpdater(sensor, fss.SystematicResampler()).update(
        SingleHypothesis(prediction, detections[1]))
    assert type(update) is ss_update.ParticleStateUpdate
    np.testing.assert_array_equal(update.log_weight, np.full(200, np.log(1 / 200)))
    columns = {tuple(c): j for j, c in enumerate(np.asarray(prediction.state_vector).T)}
    ancestors = [columns[tuple(c)] for c in np.asarray(update.state_vector).T]
    np.testing.assert_array_equal(update.parent.state_vector,
                                  np.asarray(prior.state_vector)[:, ancestors])
    assert update.parent.parent is None


@pytest.mark.parametrize("cls", [fss.SystematicResampler, fss.StratifiedResampler,
                                 fss.MultinomialResampler, fss.ResidualResampler])
def test_resamplers_are_stone_soup_resamplers_and_keep_the_state_type(cls):
    resampler = cls()
    assert isinstance(resampler, ss_resampler.Resampler)
    source = _particles()
    state = ss_update.ParticleStateUpdate(source.state_vector, log_weight=source.log_weight,
                                          hypothesis=None, parent=_particles(seed=1),
                                          timestamp=START)
    out = resampler.resample(state, nparts=80)
    assert type(out) is ss_update.ParticleStateUpdate and len(out) == 80
    assert out.parent is not None and len(out.parent) == 80
    list_out = resampler.resample([p for p in _particles(5)], nparts=5)
    assert len(list_out) == 5


def test_residual_resampler_takes_the_method_by_name_or_member():
    for method in ("systematic", fss.ResidualMethod.STRATIFIED):
        out = fss.ResidualResampler(residual_method=method).resample(_particles(), nparts=50)
        assert len(out) == 50


def test_ess_resampler_returns_the_same_object_and_recomputes_its_threshold():
    even = ParticleState(StateVectors(np.zeros((1, 10))), weight=np.full(10, 0.1))
    resampler = fss.ESSResampler()
    assert resampler.resample(even) is even
    assert resampler.threshold is None
    skewed = ParticleState(StateVectors(np.arange(20.0)[None]),
                           weight=np.r_[0.9, np.full(19, 0.1 / 19)])
    assert resampler.resample(skewed) is not skewed


def test_predict_is_memoised_and_draws_nothing_the_second_time():
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    predictor = fss.ParticlePredictor(transition)
    prior = _particles()
    first = predictor.predict(prior, timestamp=START + STEP)
    state = np.random.get_state()[1].copy()
    assert predictor.predict(prior, timestamp=START + STEP) is first
    np.testing.assert_array_equal(np.random.get_state()[1], state)
    kalman = fss.ExtendedKalmanPredictor(transition)
    gaussian = GaussianState([[0], [1], [0], [1]], np.eye(4), timestamp=START)
    assert kalman.predict(gaussian, timestamp=START + STEP) is \
        kalman.predict(gaussian, timestamp=START + STEP)


def test_np_random_seed_makes_runs_repeatable():
    runs = []
    for _ in range(2):
        np.random.seed(7)
        runs.append(_particle_filter_rmse(11, (fss.ParticlePredictor, fss.ParticleUpdater,
                                               fss.SystematicResampler)))
    assert runs[0] == runs[1]


def test_kalman_and_kernel_updates_are_stone_soup_types_at_the_measurement_time():
    transition, sensor, _, detections = _bearing_range_scenario(5)
    prior = GaussianState([[0], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5]), timestamp=START)
    prediction = fss.ExtendedKalmanPredictor(transition).predict(prior,
                                                                  timestamp=START + STEP)
    assert type(prediction) is ss_prediction.GaussianStatePrediction
    assert prediction.prior is prior and prediction.transition_model is transition
    hypothesis = SingleHypothesis(prediction, detections[1])
    update = fss.ExtendedKalmanUpdater(sensor).update(hypothesis)
    assert type(update) is ss_update.GaussianStateUpdate
    assert update.timestamp == detections[1].timestamp and update.hypothesis is hypothesis
    assert type(hypothesis.measurement_prediction) is ss_prediction.GaussianMeasurementPrediction
    assert type(hypothesis.measurement_prediction.state_vector[0, 0]).__name__ == "Bearing"
    kernel_prior = KernelParticleState(state_vector=StateVectors(np.random.normal(size=(4, 20))),
                                       weight=np.full(20, 0.05), timestamp=START)
    kernel_prediction = fss.AdaptiveKernelKalmanPredictor(transition).predict(
        kernel_prior, timestamp=START + STEP)
    assert type(kernel_prediction) is ss_prediction.KernelParticleStatePrediction
    kernel_update = fss.AdaptiveKernelKalmanUpdater(sensor).update(
        SingleHypothesis(kernel_prediction, detections[1]))
    assert type(kernel_update) is ss_update.KernelParticleStateUpdate
    assert kernel_update.timestamp == detections[1].timestamp
    assert kernel_update.proposal.shape == (4, 20)


def test_kernel_drop_ins_compute_stone_soup_gram_matrices():
    x = np.random.default_rng(8).normal(size=(3, 12))
    for ours, theirs in [(fss.QuadraticKernel(c=1, ialpha=2), SSQuadraticKernel(c=1, ialpha=2)),
                         (fss.GaussianKernel(variance=3.0), None)]:
        expected = theirs(x, x) if theirs is not None else \
            np.exp(-((x[:, :, None] - x[:, None, :]) ** 2).sum(0) / 6) / np.sqrt(6 * np.pi)
        np.testing.assert_allclose(ours(x), expected, rtol=1e-12)
    kernel = fss.GaussianKernel()
    kernel(x, variance=5.0)  # Stone Soup's keyword convention sets the parameter
    assert kernel.variance == 5.0


def test_other_models_go_through_stone_soup_code():
    """A model the drop-ins do not recognise still works, through its own methods."""
    class ShiftedCV(CombinedLinearGaussianTransitionModel):
        pass
    transition = ShiftedCV([ConstantVelocity(0.05)] * 2)
    prediction = fss.ParticlePredictor(transition).predict(_particles(), timestamp=START + STEP)
    assert type(prediction) is ss_prediction.ParticleStatePrediction


def test_stone_soup_tracker_drives_the_drop_in_particle_filter():
    from stonesoup.dataassociator.neighbour import NearestNeighbour
    from stonesoup.deleter.error import CovarianceBasedDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.initiator.simple import GaussianParticleInitiator, SinglePointInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.tracker.simple import SingleTargetTracker

    transition, sensor, truth, detections = _bearing_range_scenario(1991)
    predictor = fss.ParticlePredictor(transition)
    updater = fss.ParticleUpdater(sensor, fss.SystematicResampler())
    initiator = GaussianParticleInitiator(
        SinglePointInitiator(GaussianState([[0], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5])),
                             sensor), number_particles=1000)
    tracker = SingleTargetTracker(
        initiator=initiator, deleter=CovarianceBasedDeleter(covar_trace_thresh=1e4),
        detector=[(d.timestamp, {d}) for d in detections],
        data_associator=NearestNeighbour(DistanceHypothesiser(
            predictor, updater, measure=Mahalanobis(), missed_distance=30)),
        updater=updater)
    for _ in tracker:
        pass
    (track,) = tracker.tracks
    assert len(track) == len(truth)
    assert all(type(state) is ss_update.ParticleStateUpdate for state in track[1:])
    assert position_rmse(track, truth) < 5.0


def test_import_error_without_stone_soup_and_core_never_imports_it():
    hide = "import sys; sys.modules['stonesoup'] = None; "
    failed = subprocess.run([sys.executable, "-c", hide + "import fasttrack.stonesoup"],
                            capture_output=True, text=True)
    assert failed.returncode != 0 and "pip install 'fasttrack[stonesoup]'" in failed.stderr
    core = ("import sys, fasttrack\n"
            "from fasttrack.scenarios import particle_filter_tutorial\n"
            "s = particle_filter_tutorial(100)\n"
            "fasttrack.ParticlePredictor(s.transition_model).predict(s.prior, s.detections[1].timestamp)\n"
            "assert not any(m.startswith('stonesoup') for m in sys.modules)\n")
    subprocess.run([sys.executable, "-c", core], check=True)


def test_a_changed_model_parameter_is_seen():
    from fasttrack.stonesoup._convert import fast_model
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    first = fast_model(sensor)
    assert fast_model(sensor) is first
    sensor.noise_covar[0, 0] = 4.0
    changed = fast_model(sensor)
    assert changed is not first and changed.noise_covar[0, 0] == 4.0
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.1)] * 2)
    first = fast_model(transition)
    transition.model_list[1].noise_diff_coeff = np.float64(0.5)  # a part's (a Stone Soup model)
    assert fast_model(transition) is not first


def test_resampled_weights_are_stone_soups_to_the_bit():
    n = next(k for k in range(2, 1000) if np.log(1 / k) != -np.log(k))
    for resampler in (fss.SystematicResampler(), fss.StratifiedResampler(),
                      fss.MultinomialResampler(), fss.ResidualResampler()):
        out = resampler.resample(_particles(n))
        assert np.array_equal(np.asarray(out.log_weight, float), np.full(n, np.log(1 / n)))


# -- the unscented Kalman filter --------------------------------------------------------------

def _relative_difference(ours, theirs):
    """Largest difference relative to the largest magnitude (NaN where both are NaN
    counting as equal)."""
    ours, theirs = np.asarray(ours, dtype=float), np.asarray(theirs, dtype=float)
    np.testing.assert_array_equal(np.isnan(ours), np.isnan(theirs))
    ours, theirs = np.nan_to_num(ours), np.nan_to_num(theirs)
    return np.abs(ours - theirs).max() / max(np.abs(theirs).max(), 1e-300)


def _unscented_steps(seed, predictor, updater, sensor=None):
    """Predictions, measurement predictions and updates of the bearing-range scenario (or
    ``sensor``'s detections of its truth)."""
    transition, polar, truth, detections = _bearing_range_scenario(seed)
    sensor = sensor or polar
    detections = [Detection(sensor.function(s, noise=True), timestamp=s.timestamp,
                            measurement_model=sensor) for s in truth]
    predictor, updater = predictor(transition), updater(sensor)
    state = GaussianState([[0], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5]),
                          timestamp=START)
    steps = []
    for detection in detections[1:]:
        prediction = predictor.predict(state, timestamp=detection.timestamp)
        measurement_prediction = updater.predict_measurement(prediction)
        state = updater.update(SingleHypothesis(prediction, detection))
        steps.append((prediction, measurement_prediction, state))
    return steps


def _assert_same_steps(ours, theirs, tolerance=1e-9):
    for our_step, their_step in zip(ours, theirs, strict=True):
        for mine, reference in zip(our_step, their_step):
            assert type(mine) is type(reference)
            assert [type(v) for v in mine.state_vector[:, 0]] == \
                [type(v) for v in reference.state_vector[:, 0]]
            attributes = ["state_vector", "covar"] + (
                ["cross_covar"] if hasattr(reference, "cross_covar") else [])
            assert max(_relative_difference(getattr(mine, a), getattr(reference, a))
                       for a in attributes) <= tolerance
        prediction, _, update = our_step
        assert prediction.transition_model is their_step[0].transition_model or \
            type(prediction.transition_model) is type(their_step[0].transition_model)
        assert update.hypothesis.prediction is prediction
        assert type(update.hypothesis.measurement_prediction) is \
            ss_prediction.GaussianMeasurementPrediction


@pytest.mark.parametrize("sensor", [
    None, LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2)),
    Cartesian2DToBearing(ndim_state=4, mapping=(0, 2), noise_covar=np.array([[1e-4]]))],
    ids=["bearing-range", "linear", "bearing"])
def test_unscented_kalman_filter_equal_to_stone_soup(sensor):
    for seed in range(3):
        _assert_same_steps(
            _unscented_steps(seed, fss.UnscentedKalmanPredictor, fss.UnscentedKalmanUpdater,
                             sensor),
            _unscented_steps(seed, ss_kalman_predictor.UnscentedKalmanPredictor,
                             ss_kalman_updater.UnscentedKalmanUpdater, sensor))


def test_unscented_drop_ins_compute_without_stone_soups_sigma_points():
    from unittest import mock
    with mock.patch("stonesoup.predictor.kalman.gauss2sigma", side_effect=AssertionError), \
            mock.patch("stonesoup.updater.kalman.gauss2sigma", side_effect=AssertionError):
        steps = _unscented_steps(0, fss.UnscentedKalmanPredictor, fss.UnscentedKalmanUpdater)
    assert len(steps) == 20


def _unscented_step(predictor, updater, prior, detection, **measurement_kwargs):
    prediction = predictor.predict(prior, timestamp=detection.timestamp)
    measurement_prediction = updater.predict_measurement(prediction, **measurement_kwargs)
    return prediction, measurement_prediction, updater.update(
        SingleHypothesis(prediction, detection))


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # Stone Soup's NaN
@pytest.mark.parametrize("parameters", [
    {}, {"alpha": 1.0, "beta": 0.0, "kappa": 1.0}, {"alpha": 0.3, "kappa": -1.0},
    {"alpha": -0.5},  # outside fasttrack's range: Stone Soup's code (alpha**2)
    {"kappa": -4.5},  # a negative spread: Stone Soup's code (NaN)
], ids=["default", "alpha-1", "kappa-1", "negative-alpha", "negative-spread"])
def test_unscented_parameters_and_options_as_stone_soup(parameters):
    transition, sensor, _, detections = _bearing_range_scenario(3)
    prior = GaussianState([[0], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5]), timestamp=START)
    for measurement_kwargs in ({}, {"measurement_noise": False}):
        steps = [_unscented_step(
            predictor(transition, **parameters), updater(sensor, **parameters), prior,
            detections[1], **measurement_kwargs)
            for predictor, updater in [
                (fss.UnscentedKalmanPredictor, fss.UnscentedKalmanUpdater),
                (ss_kalman_predictor.UnscentedKalmanPredictor,
                 ss_kalman_updater.UnscentedKalmanUpdater)]]
        _assert_same_steps([steps[0]], [steps[1]])


def test_unscented_joseph_form_is_stone_soups():
    """Stone Soup's Joseph form takes the model's matrix H with the unscented gain: the
    linear sensor gives its numbers, the bearing-range sensor (no matrix) its error."""
    linear = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    transition, polar, _, detections = _bearing_range_scenario(4)
    prior = GaussianState([[0], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5]), timestamp=START)
    detection = Detection(linear.function(prior, noise=True), timestamp=START + STEP,
                          measurement_model=linear)
    steps = [_unscented_step(predictor(transition), updater(linear, use_joseph_cov=True),
                             prior, detection)
             for predictor, updater in [
                 (fss.UnscentedKalmanPredictor, fss.UnscentedKalmanUpdater),
                 (ss_kalman_predictor.UnscentedKalmanPredictor,
                  ss_kalman_updater.UnscentedKalmanUpdater)]]
    _assert_same_steps([steps[0]], [steps[1]])
    for updater in (fss.UnscentedKalmanUpdater, ss_kalman_updater.UnscentedKalmanUpdater):
        prediction = fss.UnscentedKalmanPredictor(transition).predict(prior, START + STEP)
        with pytest.raises(AttributeError, match="matrix"):
            updater(polar, use_joseph_cov=True).update(SingleHypothesis(prediction,
                                                                        detections[1]))


def test_unscented_predictions_are_memoised_and_other_models_use_stone_soup():
    transition, sensor, _, detections = _bearing_range_scenario(5)
    prior = GaussianState([[0], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5]), timestamp=START)
    predictor, updater = fss.UnscentedKalmanPredictor(transition), \
        fss.UnscentedKalmanUpdater(sensor)
    prediction = predictor.predict(prior, timestamp=START + STEP)
    assert predictor.predict(prior, timestamp=START + STEP) is prediction
    assert prediction.prior is prior and prediction.transition_model is transition
    assert updater.predict_measurement(prediction) is updater.predict_measurement(prediction)

    class UserCV(CombinedLinearGaussianTransitionModel):
        pass

    class UserSensor(CartesianToBearingRange):
        pass

    user_transition = UserCV([ConstantVelocity(0.05)] * 2)
    user_sensor = UserSensor(ndim_state=4, mapping=(0, 2), noise_covar=sensor.noise_covar,
                             translation_offset=sensor.translation_offset)
    detection = Detection(detections[1].state_vector, timestamp=START + STEP,
                          measurement_model=user_sensor)
    steps = [_unscented_step(predictor(user_transition), updater(user_sensor), prior, detection)
             for predictor, updater in [
                 (fss.UnscentedKalmanPredictor, fss.UnscentedKalmanUpdater),
                 (ss_kalman_predictor.UnscentedKalmanPredictor,
                  ss_kalman_updater.UnscentedKalmanUpdater)]]
    _assert_same_steps([steps[0]], [steps[1]], tolerance=1e-15)


# -- the Kalman smoothers -----------------------------------------------------------------

def _filtered_track(seed, missed=(), steps=21):
    """A Stone Soup track (a prior, then updates, and predictions at the ``missed`` steps)
    of the bearing-range scenario filtered by Stone Soup's UKF."""
    from stonesoup.types.track import Track
    transition, sensor, truth, detections = _bearing_range_scenario(seed)
    predictor = ss_kalman_predictor.UnscentedKalmanPredictor(transition)
    updater = ss_kalman_updater.UnscentedKalmanUpdater(sensor)
    state = GaussianState([[0], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5]), timestamp=START)
    track = Track([state])
    for k, detection in enumerate(detections[1:steps], start=1):
        state = predictor.predict(state, timestamp=detection.timestamp)
        if k not in missed:
            state = updater.update(SingleHypothesis(state, detection))
        track.append(state)
    return transition, track


def _assert_same_track(ours, theirs, track, tolerance=1e-9):
    assert type(ours) is type(theirs) and ours is not track and ours.id == track.id
    assert len(ours) == len(theirs) == len(track)
    assert ours[-1] is track[-1] and theirs[-1] is track[-1]
    for mine, reference, original in zip(ours, theirs, track):
        assert type(mine) is type(reference)
        assert mine.timestamp == original.timestamp
        assert getattr(mine, "hypothesis", None) is getattr(original, "hypothesis", None)
        assert max(_relative_difference(mine.state_vector, reference.state_vector),
                   _relative_difference(mine.covar, reference.covar)) <= tolerance


@pytest.mark.parametrize("name", ["KalmanSmoother", "ExtendedKalmanSmoother",
                                  "UnscentedKalmanSmoother"])
@pytest.mark.parametrize("missed", [(), (7,), (1, 2, 12, 20)],
                         ids=["all-detected", "one-missed", "missed-at-the-ends"])
def test_kalman_smoothers_equal_to_stone_soup(name, missed):
    from unittest import mock

    from stonesoup.smoother import kalman as ss_smoother
    for seed in range(3):
        transition, track = _filtered_track(seed, missed)
        theirs = getattr(ss_smoother, name)(transition).smooth(track)
        with mock.patch.object(getattr(ss_smoother, name), "smooth",
                               side_effect=AssertionError("Stone Soup's smooth ran")):
            ours = getattr(fss, name)(transition).smooth(track)
        _assert_same_track(ours, theirs, track)
        assert ours[0] is track[0]  # the prior, kept as Stone Soup keeps it
        for k in missed:
            assert type(ours[k]) is ss_prediction.GaussianStatePrediction


def test_kalman_smoother_reads_single_prediction_multiple_hypotheses():
    from stonesoup.smoother.kalman import KalmanSmoother
    from stonesoup.types.multihypothesis import MultipleHypothesis
    transition, track = _filtered_track(6)
    for state in track[1:]:
        state.hypothesis = MultipleHypothesis([state.hypothesis])
    _assert_same_track(fss.KalmanSmoother(transition).smooth(track),
                       KalmanSmoother(transition).smooth(track), track)
    track[3].hypothesis = MultipleHypothesis(
        list(track[3].hypothesis) + [SingleHypothesis(track[2], track[3].hypothesis[0]
                                                      .measurement)])
    for smoother in (fss.KalmanSmoother(transition), KalmanSmoother(transition)):
        with pytest.raises(ValueError, match="multiple predictions"):
            smoother.smooth(track)


def test_kalman_smoothers_fall_back_to_stone_soup():
    """A user's transition model, a prediction naming another model, an overridden hook, a
    keyword or a non-Gaussian state go through Stone Soup's code (or its error)."""
    from stonesoup.smoother.kalman import KalmanSmoother

    class UserCV(CombinedLinearGaussianTransitionModel):
        pass

    transition, track = _filtered_track(8, missed=(4,))
    user = UserCV(transition.model_list)
    track[5].hypothesis.prediction.transition_model = user  # one step's model
    _assert_same_track(fss.KalmanSmoother(transition).smooth(track),
                       KalmanSmoother(transition).smooth(track), track, tolerance=0)
    for state in track[1:]:  # the predictions' model is used before the smoother's
        getattr(state, "hypothesis", types.SimpleNamespace(prediction=state)) \
            .prediction.transition_model = user
    _assert_same_track(fss.KalmanSmoother(transition).smooth(track),
                       KalmanSmoother(transition).smooth(track), track, tolerance=0)

    track[2] = track[2].hypothesis.measurement
    errors = []
    for smoother in (fss.KalmanSmoother(transition), KalmanSmoother(transition)):
        with pytest.raises(Exception) as error:
            smoother.smooth(track)
        errors.append((type(error.value), str(error.value)))
    assert errors[0] == errors[1]
    transition, track = _filtered_track(8)

    def damped_gain(self, state, prediction, **kwargs):
        return 0.5 * KalmanSmoother._smooth_gain(self, state, prediction, **kwargs)

    damped = [type("Damped", (base,), {"_smooth_gain": damped_gain})(transition)
              for base in (fss.KalmanSmoother, KalmanSmoother)]
    _assert_same_track(damped[0].smooth(track), damped[1].smooth(track), track, tolerance=0)
    prediction = track[3].hypothesis.prediction  # invertible, not positive definite
    prediction.covar = -prediction.covar
    _assert_same_track(fss.KalmanSmoother(transition).smooth(track),
                       KalmanSmoother(transition).smooth(track), track, tolerance=0)


def test_unscented_drop_ins_in_an_associator_give_stone_soups_hypotheses():
    """The associators' batched path over several tracks computes Kalman steps, not
    unscented ones: with the unscented drop-ins they give Stone Soup's unscented
    hypotheses."""
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.measures import Mahalanobis
    from stonesoup.types.track import Track
    transition, sensor, _, _ = _bearing_range_scenario(9)
    tracks = {Track([GaussianState([[x], [1], [0], [1]], np.diag([1.5, 0.5, 1.5, 0.5]),
                                   timestamp=START)]) for x in (0, 3, 6)}
    scan = {Detection(sensor.function(GaussianState([[x], [1], [1], [1]], np.eye(4)),
                                      noise=True), timestamp=START + STEP,
                      measurement_model=sensor) for x in (1, 4)}
    found = []
    for associator, hypothesiser, predictor, updater in [
            (fss.GNNWith2DAssignment, fss.DistanceHypothesiser, fss.UnscentedKalmanPredictor,
             fss.UnscentedKalmanUpdater),
            (GNNWith2DAssignment, DistanceHypothesiser,
             ss_kalman_predictor.UnscentedKalmanPredictor,
             ss_kalman_updater.UnscentedKalmanUpdater)]:
        associations = associator(hypothesiser(
            predictor(transition), updater(sensor), measure=Mahalanobis(),
            missed_distance=30)).associate(tracks, scan, START + STEP)
        found.append({track.id: hypothesis for track, hypothesis in associations.items()})
    assert found[0].keys() == found[1].keys()
    for track_id, hypothesis in found[0].items():
        reference = found[1][track_id]
        assert float(hypothesis.distance) == pytest.approx(float(reference.distance), rel=1e-9)
        assert _relative_difference(hypothesis.prediction.covar, reference.prediction.covar) \
            < 1e-9
        if reference:
            assert hypothesis.measurement is reference.measurement
            assert _relative_difference(hypothesis.measurement_prediction.covar,
                                        reference.measurement_prediction.covar) < 1e-9
        else:
            assert not hypothesis
    assert sum(map(bool, found[1].values())) == 2


@pytest.mark.parametrize("noise", [True, False])
def test_particle_measurement_prediction_equals_stone_soup(noise):
    """The drop-in's measurement prediction: Stone Soup's values (to rounding), types,
    weights and its draw of noise from NumPy's global state (the same numbers left)."""
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.measurement.nonlinear import (Cartesian2DToBearing,
                                                        CartesianToBearingRange)
    from stonesoup.types.array import StateVectors
    from stonesoup.types.state import ParticleState
    from stonesoup.updater.particle import ParticleUpdater as StoneSoupUpdater
    models = [CartesianToBearingRange(4, (0, 2), np.diag([0.01, 2.0]),
                                      translation_offset=np.array([[-5.0], [3.0]]),
                                      rotation_offset=np.array([[0.0], [0.0], [0.3]])),
              Cartesian2DToBearing(4, (0, 2), np.array([[0.01]])),
              LinearGaussian(4, (0, 2), np.diag([1.0, 2.0]))]
    rng = np.random.default_rng(0)
    fss.fallbacks(clear=True)
    for model in models:
        prior = ParticleState(StateVectors(rng.normal(0, 10, (4, 700))),
                              log_weight=np.log(rng.uniform(0.1, 1, 700)), timestamp=START)
        found = []
        for updater in (StoneSoupUpdater(model), fss.ParticleUpdater(model)):
            np.random.seed(5)
            found.append((updater.predict_measurement(prior, measurement_noise=noise),
                          np.random.random()))
        (theirs, their_next), (ours, our_next) = found
        assert isinstance(ours, type(theirs)) and our_next == their_next
        assert [type(v) for v in ours.state_vector[:, 0]] == \
            [type(v) for v in theirs.state_vector[:, 0]]
        assert type(ours) is type(theirs)  # bearings made objects when first read
        np.testing.assert_allclose(np.asarray(ours.state_vector, dtype=float),
                                   np.asarray(theirs.state_vector, dtype=float),
                                   rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(ours.log_weight, theirs.log_weight)
        assert ours.timestamp == theirs.timestamp
    assert not fss.fallbacks()
