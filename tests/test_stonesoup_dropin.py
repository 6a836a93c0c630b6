"""fasttrack.stonesoup: Stone Soup's tutorials with switched imports, Stone Soup's documented
behaviours, equivalence with Stone Soup, and Stone Soup's own tracker driving the drop-ins."""
import datetime
import pathlib
import re
import subprocess
import sys

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


def test_resampled_weights_are_stone_soups_to_the_bit():
    n = next(k for k in range(2, 1000) if np.log(1 / k) != -np.log(k))
    for resampler in (fss.SystematicResampler(), fss.StratifiedResampler(),
                      fss.MultinomialResampler(), fss.ResidualResampler()):
        out = resampler.resample(_particles(n))
        assert np.array_equal(np.asarray(out.log_weight, float), np.full(n, np.log(1 / n)))
