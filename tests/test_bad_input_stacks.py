"""Bad input to the faces that carry stacks of Gaussians (mixtures and their reducer, the
PHD and CPHD filters, the IMM, the trackers) and to the runners around them: each error
names the argument (TypeError for a type, ValueError for a value); none crashes."""
import functools
import subprocess
import sys

import numpy as np
import pytest

import fasttrack as ft
from fasttrack import _jit, association, imm, metrics, montecarlo, smoother, tracker
from fasttrack.core import cphd as core_cphd
from fasttrack.core import mixture as core_mixture
from fasttrack.core import phd as core_phd
from fasttrack.phd import CPHDTracker, PHDTracker
from fasttrack.scenarios import vo_linear_birth
from fasttrack.types.mixture import IMMTrackSet

CV = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
CV6 = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 3)
SENSOR = ft.LinearGaussian(4, (0, 2), np.eye(2))
SWITCH = [[0.9, 0.1], [0.1, 0.9]]
MEANS = np.array([[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 1.0, 0.0], [100.0, 0.0, 100.0, 0.0]])
COVARS = np.tile(np.eye(4), (3, 1, 1))
ZEROS = np.zeros(3)


def _raises(call, error, match):
    with pytest.raises(error, match=match):
        call()


@pytest.mark.parametrize("call, error, match", [
    (lambda: ft.GaussianMixture(np.zeros((3, 0)), np.zeros((3, 0, 0))), ValueError,
     "means must have at least one state dimension"),
    (lambda: core_mixture.reduce(np.zeros((3, 0)), np.zeros((3, 0, 0)), [0.5, 0.3, 0.2]),
     ValueError, "means must have at least one state dimension"),
    (lambda: core_mixture.reduce(MEANS, COVARS, [0.5, 0.3, 0.2], mode=["textbook"]),
     ValueError, "mode must be one of"),
    (lambda: ft.GaussianMixtureReducer(mode={}), ValueError, "mode must be one of"),
    (lambda: core_mixture.moment_match(MEANS, np.zeros((3, 2, 4)), ZEROS), ValueError,
     r"covars must have shape \(3, 4, 4\)"),
    (lambda: core_mixture.moment_match(MEANS, COVARS, ZEROS, [0, 1]), ValueError,
     "labels must be 3 integers"),
    (lambda: core_mixture.moment_match(MEANS, COVARS, np.full(3, np.nan)), ValueError,
     "log_weights must not be NaN"),
    (lambda: ft.GaussianMixture(MEANS, COVARS, None, np.array([2**64 - 1, 0, 1], np.uint64)),
     ValueError, r"labels must be below 2\*\*63"),
])
def test_mixtures_name_a_bad_argument(call, error, match):
    _raises(call, error, match)


@pytest.mark.parametrize("first_label, match", [
    (0, r"first_label must be above every label of the mixture \(>= 2\), got 0"),
    (2**63 - 1, "first_label leaves no room for new labels below 2\\*\\*63"),
    (2**70, "first_label leaves no room"),
    (np.uint64(2**64 - 1), "first_label leaves no room"),  # (wrapped to new labels below)
])
def test_new_labels_cannot_collide_or_wrap(first_label, match):
    mixture = ft.GaussianMixture(MEANS, COVARS, ZEROS, [0, 0, 1])
    with pytest.raises(ValueError, match=match):
        ft.GaussianMixtureReducer(merge_threshold=0.0).reduce(mixture, first_label=first_label)
    assert sorted(ft.GaussianMixtureReducer(merge_threshold=0.0).reduce(mixture).labels) == \
        [0, 1, 2]


def test_weights_beyond_the_float_range_are_named():
    mixture = ft.GaussianMixture(MEANS, COVARS, [800.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"mixture.log_weights must lie below log\(1.8e308\)"):
        ft.GaussianMixtureReducer().reduce(mixture)


def test_combining_models_checks_their_covariances():
    means, covars = np.zeros((1, 2, 4)), np.tile(np.eye(4), (1, 2, 1, 1))
    with pytest.raises(ValueError, match=r"covars\[0, 1\] is not positive semi-definite"):
        ft.BatchIMMFilter.combine(means, covars * [[[[1.0]], [[-1.0]]]], [[0.5, 0.5]])
    covars[0, 0, 0, 1] = 1.0
    with pytest.raises(ValueError, match=r"covars\[0, 0\] is not symmetric"):
        ft.BatchIMMFilter.combine(means, covars, [[0.5, 0.5]])


def test_zero_dimensional_components_are_refused_by_the_kernels_too():
    """Once the kernels run, a mixture of 0-D components crashed the merge kernel."""
    code = ("import numpy as np, fasttrack._jit as j\n"
            "from fasttrack.core import mixture\n"
            "j.kernels_from_now()\n"
            "try:\n"
            "    mixture.reduce(np.zeros((3, 0)), np.zeros((3, 0, 0)), [0.5, 0.3, 0.2])\n"
            "except ValueError as error:\n"
            "    print(error)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "means must have at least one state dimension" in done.stdout


@pytest.mark.parametrize("kind", [PHDTracker, CPHDTracker])
@pytest.mark.parametrize("models, birth, error, match", [
    ((CV6, SENSOR), None, ValueError, "measurement_model measures 4-D states, transition_model.s are 6-D"),
    ((None, SENSOR), None, TypeError, "transition_model must be a linear-Gaussian"),
    ((CV, None), None, TypeError, "measurement_model must be a built-in MeasurementModel"),
    ((CV, CV), None, TypeError, "measurement_model must be a built-in MeasurementModel"),
    ((CV, SENSOR), "indefinite", ValueError, r"birth.covars\[0\] is not positive semi-definite"),
    ((CV, SENSOR), "asymmetric", ValueError, r"birth.covars\[0\] is not symmetric"),
    ((CV, SENSOR), "heavy", ValueError, "birth.log_weights must total at most 709.8"),
    ((CV, SENSOR), "two heavy", ValueError, "birth.log_weights must total at most 709.8"),
    ((CV, SENSOR), "singular", ValueError, r"birth.covars\[0\] must be positive definite"),
])
def test_intensity_trackers_check_models_and_birth_when_built(kind, models, birth, error,
                                                              match):
    births = vo_linear_birth()
    log_weights = {"heavy": np.full(len(births), 800.0),
                   "two heavy": np.full(len(births), 709.5)}.get(birth, births.log_weights)
    births = ft.GaussianMixture(births.means, births.covars, log_weights)
    covars = births.covars  # (written into: the mixture checked them when made)
    if birth == "indefinite":
        covars[0, 1, 1] = -1.0
    if birth == "asymmetric":
        covars[0, 0, 1] += 1.0
    if birth == "singular":
        covars[0] = 0.0
    with pytest.raises(error, match=match):
        kind(*models, births, 0.9, 0.99, 1e-5, *([10.0] if kind is CPHDTracker else []))


@pytest.mark.parametrize("kind", [PHDTracker, CPHDTracker])
def test_a_mixture_assigned_to_a_tracker_keeps_its_labels_apart_from_new_ones(kind):
    """A mixture of labels 7 and 0 assigned to a tracker failed its next step (the births
    were labelled 0-3, the reducer refused a first label of 4); labels near 2**63 named
    ``first_label``, which the caller never gave."""
    tracker = kind(CV, SENSOR, vo_linear_birth(), 0.9, 0.99, 1e-5,
                   *([10.0] if kind is CPHDTracker else []))
    covars = np.tile(np.eye(4) * 100.0, (2, 1, 1))
    tracker.mixture = ft.GaussianMixture(np.zeros((2, 4)), covars, np.log([0.5, 0.5]), [7, 0])
    tracker.step(np.zeros((1, 2)), 0.0)
    assert (tracker.mixture.labels[tracker.mixture.labels != 0] >= 7).all()  # (births: 8-11)
    with pytest.raises(ValueError, match=r"mixture.labels must be below 2\*\*62"):
        tracker.mixture = ft.GaussianMixture(np.zeros((1, 4)), covars[:1], [0.0], [2**63 - 1])


def test_a_birth_of_fields_set_by_hand_is_named():
    """A birth mixture whose covariances were replaced by fewer (its frozen fields set by
    hand) failed a step later with NumPy's broadcasting message."""
    births = vo_linear_birth()
    object.__setattr__(births, "covars", births.covars[:2])
    with pytest.raises(ValueError, match=r"birth.covars must have shape \(4, 4, 4\), as its "
                                         r"4 means, got \(2, 4, 4\)"):
        PHDTracker(CV, SENSOR, births, 0.9, 0.99, 1e-5)


@pytest.mark.parametrize("kind", [PHDTracker, CPHDTracker])
def test_a_reducer_that_does_not_reduce_is_refused(kind):
    """With pruning, merging and truncating all off, a tracker's intensity grew from 260 to
    1.1 million components by its second scan."""
    args = (CV, SENSOR, vo_linear_birth(), 0.9, 0.99, 1e-5,
            *([10.0] if kind is CPHDTracker else []))
    idle = ft.GaussianMixtureReducer(pruning=False, merging=False, truncating=False)
    with pytest.raises(ValueError, match="reducer must prune, merge or truncate"):
        kind(*args, reducer=idle)
    tracker = kind(*args)
    with pytest.raises(ValueError, match="reducer must prune, merge or truncate"):
        tracker.reducer = idle
    tracker.reducer.pruning = tracker.reducer.merging = tracker.reducer.truncating = False
    with pytest.raises(ValueError, match="reducer must prune, merge or truncate"):
        tracker.step(np.zeros((1, 2)), 0.0)
    assert tracker.time is None  # (refused before the scan changed anything)


def _replaced(mixture, field, value):
    """``mixture`` with its frozen ``field`` set by hand to ``value``."""
    object.__setattr__(mixture, field, value)
    return mixture


def _three():
    return ft.GaussianMixture(np.zeros((3, 2)), np.tile(np.eye(2), (3, 1, 1)))


@pytest.mark.parametrize("field, value, error, match", [
    ("labels", np.zeros(1, dtype=np.int64), ValueError,
     r"mixture.labels must have shape \(3,\), as its 3 means, got \(1,\)"),
    ("covars", np.tile(np.eye(2), (2, 1, 1)), ValueError,
     r"mixture.covars must have shape \(3, 2, 2\), as its 3 means, got \(2, 2, 2\)"),
    ("means", [[0.0, 0.0]] * 3, TypeError, "mixture.means must be a float64 ndarray, got list"),
    ("means", np.zeros(3), ValueError, r"mixture.means must be 2-D \(K, d\), got shape"),
    ("labels", np.zeros(3), TypeError, "mixture.labels must be a int64 ndarray, got float64"),
])
@pytest.mark.parametrize("use", ["reduce", "mean", "covar", "components", "fields"])
def test_a_mixture_of_fields_set_by_hand_is_named_where_it_is_read(field, value, error, match,
                                                                   use):
    """Fields that disagree gave IndexError, NumPy's broadcasting message, or (components)
    two of three components without a word."""
    mixture = _replaced(_three(), field, value)
    read = {"reduce": lambda: ft.GaussianMixtureReducer(merging=False).reduce(mixture),
            "mean": lambda: mixture.mean, "covar": lambda: mixture.covar,
            "components": lambda: mixture.components, "fields": mixture.fields}[use]
    with pytest.raises(error, match=match):
        read()


@pytest.mark.parametrize("kind", [PHDTracker, CPHDTracker])
@pytest.mark.parametrize("which", ["mixture", "birth"])
def test_a_tracker_names_its_mixture_or_birth_set_by_hand_after_it_was_assigned(kind, which):
    """A tracker mixture whose log weights were replaced by fewer failed its next step with
    an IndexError."""
    tracker = kind(CV, SENSOR, vo_linear_birth(), 0.9, 0.99, 1e-5,
                   *([10.0] if kind is CPHDTracker else []))
    tracker.step(np.zeros((1, 2)), 0.0)
    held = getattr(tracker, which)
    _replaced(held, "log_weights", held.log_weights[:1])
    with pytest.raises(ValueError, match=rf"{which}.log_weights must have shape"):
        tracker.step(np.zeros((1, 2)), 1.0)


@pytest.mark.parametrize("numpy_first", [False, True])
@pytest.mark.parametrize("field", ["means", "covars", "log_weights"])
def test_nan_written_into_a_tracker_s_mixture_is_named(field, numpy_first, monkeypatch):
    """NaN written into the tracker's own mixture was reported as a prediction that
    overflowed."""
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: numpy_first)
    tracker = PHDTracker(CV, SENSOR, vo_linear_birth(), 0.9, 0.99, 1e-5)
    tracker.step(np.zeros((1, 2)), 0.0)
    getattr(tracker.mixture, field).flat[0] = np.nan
    with pytest.raises(ValueError, match=rf"(filter 0: {field}\[0\] is not (finite|(symmetric|"
                                         r"positive semi-definite) \(or not finite\)))|"
                                         r"mixture.log_weights must not be NaN"):
        tracker.step(np.zeros((1, 2)), 1.0)



def test_arrays_given_stay_the_caller_s():
    """A mixture, a switching matrix and initial mode probabilities kept the caller's
    arrays: changing those afterwards changed them past every check (NaN weights, rows
    summing to 3)."""
    means, covars, log_weights = np.zeros((2, 1)), np.ones((2, 1, 1)), np.zeros(2)
    mixture = ft.GaussianMixture(means, covars, log_weights)
    means[0], covars[0], log_weights[0] = np.nan, -1.0, np.nan
    assert np.isfinite(mixture.means).all() and (mixture.covars == 1.0).all()
    assert (mixture.log_weights == 0.0).all()
    matrix, modes = np.array([[0.9, 0.1], [0.1, 0.9]]), np.array([0.5, 0.5])
    models = [ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)
              for q in (0.1, 10.0)]
    imm = ft.BatchIMMFilter(models, SENSOR, matrix)
    tracker = ft.IMMTracker(models, SENSOR, matrix, np.zeros(4), np.eye(4), mode_probs=modes)
    matrix[:], modes[:] = 3 * np.eye(2), [7.0, 2.0]
    assert imm.transition_matrix.sum() == 2.0 and tracker.transition_matrix.sum() == 2.0
    assert tracker.mode_probs.tolist() == [0.5, 0.5]


@pytest.mark.parametrize("numpy_first", [False, True])
def test_a_bearing_beyond_1e9_rad_is_refused_by_the_stacks(numpy_first, monkeypatch):
    """A bearing of 1e300 rad moved an IMM mean by 5e282; a PHD update of a 1e20 rad
    bearing gave a log weight of -0.0012 in NumPy and -3.3e8 on the kernels."""
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: numpy_first)
    radar = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.01, 1.0]))
    match = r"must hold angles within \+-1e\+09 rad"
    with pytest.raises(ValueError, match="detections " + match):
        core_phd.update(radar, np.array([[10.0, 0, 10, 0]]), np.eye(4)[None], [0.0],
                        [[1e20, 14.0]], 0.9, 1e-3)
    birth = ft.GaussianMixture(np.array([[0.0, 10, 10, 30]]), np.eye(4)[None] * 100,
                               np.log([0.1]))
    with pytest.raises(ValueError, match=match):
        PHDTracker(CV, radar, birth, 0.9, 0.99, 1e-4).run([[[1e300, 10.0]]] * 2)
    imm = ft.BatchIMMFilter([CV, CV], radar, np.full((2, 2), 0.5))
    means, covars = np.tile([10.0, 0, 10, 0], (1, 2, 1)), np.tile(np.eye(4), (1, 2, 1, 1))
    with pytest.raises(ValueError, match="measurements " + match):
        imm.step(means, covars, [[0.5, 0.5]], [[1e300, 14.0]], 1.0)


def test_tracker_state_assigned_is_checked():
    """A PHD intensity of 2-D components or None, a time 'x', a log cardinality of NaN
    (and one changed in place), an IMM track set of 3 models or ragged fields, and no
    clutter density for IMM-JPDA met NumPy's or Python's errors a step later, or none."""
    birth = ft.GaussianMixture(np.zeros((1, 4)), np.eye(4)[None] * 100, np.log([0.1]))
    phd = PHDTracker(CV, SENSOR, birth, 0.9, 0.99, 1e-4)
    with pytest.raises(ValueError, match="mixture must have 4-D components"):
        phd.mixture = ft.GaussianMixture(np.zeros((1, 2)), np.eye(2)[None])
    with pytest.raises(TypeError, match="mixture must be a GaussianMixture"):
        phd.mixture = None
    with pytest.raises(TypeError, match="time must be a real number"):
        phd.time = "x"
    heavy = ft.GaussianMixture(np.zeros((2, 4)), np.tile(np.eye(4), (2, 1, 1)), [709.5] * 2)
    with pytest.raises(ValueError, match="mixture.log_weights must total at most 709.8"):
        phd.mixture = heavy  # (its expected number was inf)
    with pytest.raises(TypeError, match=r"unscented must be \(alpha, beta, kappa\), got 'x'"):
        phd.unscented = "x"  # (was kept, and the updates ignored it)
    cphd = CPHDTracker(CV, SENSOR, birth, 0.9, 0.99, 1e-4, 5.0)
    with pytest.raises(ValueError, match="log_cardinality must be N"):
        cphd.log_cardinality = np.array([np.nan])
    with pytest.raises(ValueError, match="log_cardinality must hold at most 10001"):
        cphd.log_cardinality = np.log(np.full(10_002, 1 / 10_002))
    huge = np.r_[0.0, np.full(200_000, -np.inf)]  # (its O(N^2) recursion ran for minutes)
    with pytest.raises(ValueError, match="log_cardinality must hold at most 10001"):
        core_cphd.predict_cardinality(huge, 0.9, 0.3)
    cphd.step(np.zeros((1, 2)), 0.0)
    with pytest.raises(ValueError, match="read-only"):
        cphd.log_cardinality[:] = 0.0
    models = [CV, CV]
    imm = ft.IMMTracker(models, SENSOR, np.full((2, 2), 0.5), np.zeros(4), np.eye(4))
    three = IMMTrackSet.empty(4, 3)
    with pytest.raises(ValueError, match=r"confirmed.model_means must be a float64 array of "
                                         r"shape \(0, 2, 4\)"):
        imm.confirmed = three
    ragged = IMMTrackSet.empty(4, 2)
    ragged.ids = np.array([0, 1])
    with pytest.raises(ValueError, match=r"tentative.means must be a float64 array of shape "
                                         r"\(2, 4\) \(2 tracks\)"):
        imm.tentative = ragged
    one = IMMTrackSet(np.array([0]), np.zeros((1, 4)), np.eye(4)[None], *np.zeros((3, 1), int),
                      np.zeros((1, 2, 4)), np.tile(np.eye(4), (1, 2, 1, 1)),
                      np.array([[np.nan, 7.0]]))
    with pytest.raises(ValueError, match="confirmed.mode_probs must be finite"):
        imm.confirmed = one
    jpda = ft.IMMTracker(models, SENSOR, np.full((2, 2), 0.5), np.zeros(4), np.eye(4),
                         association="jpda", clutter_density=1e-3)
    with pytest.raises(ValueError, match="association='jpda' needs clutter_density"):
        jpda.clutter_density = None

@pytest.mark.parametrize("covars", [np.eye(4) * [-0.5, 1, -0.5, 1], np.eye(4) * [1, -1, 1, -1]])
def test_phd_and_cphd_updates_refuse_an_indefinite_prediction(covars):
    covars = np.tile(covars, (3, 1, 1))
    scan = np.array([[0.0, 0.0], [5.0, 5.0]])
    with pytest.raises(ValueError, match=r"covars\[0\] is not positive semi-definite"):
        core_phd.update(SENSOR, MEANS, covars, ZEROS, scan, 0.9, 1e-4)
    with pytest.raises(ValueError, match=r"covars\[0\] is not positive semi-definite"):
        core_cphd.update(SENSOR, MEANS, covars, ZEROS, np.log(np.full(11, 1 / 11)), scan,
                         0.9, 1e-4, 2.0)


@pytest.mark.parametrize("numpy_first", [False, True])
def test_a_huge_birth_mean_puts_the_predicted_cardinality_at_the_top(numpy_first, monkeypatch):
    """The Poisson births' common factor exp(-mean) underflowed, leaving every count at 0
    in logs (probability 1 each); the kernel and the NumPy twin."""
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: numpy_first)
    uniform = np.log(np.full(11, 1 / 11))
    for birth_mean, top in ((1e300, 1.0), (1e6, 1 - 1e-5)):  # p(9) / p(10) = 10 / mean
        predicted = np.exp(core_cphd.predict_cardinality(uniform, 0.9, birth_mean))
        assert predicted.sum() == pytest.approx(1.0, rel=1e-12)
        assert predicted[-1] == pytest.approx(top, rel=1e-9)
    moderate = np.exp(core_cphd.predict_cardinality(uniform, 0.9, 2.0))
    assert moderate.sum() == pytest.approx(1.0) and 0.05 < moderate.max() < 0.2


@pytest.mark.parametrize("call, error, match", [
    (lambda: imm.BatchIMMFilter(None, SENSOR, SWITCH), TypeError,
     "transition_models must be an iterable"),
    (lambda: imm.BatchIMMFilter([CV, "x"], SENSOR, SWITCH), TypeError,
     r"transition_models\[1\] must be of type TransitionModel, got str"),
    (lambda: imm.BatchIMMFilter([CV, CV], None, SWITCH), TypeError,
     "measurement_model must be a built-in MeasurementModel"),
    (lambda: imm.IMMPredictor(["a", "b"], SWITCH), TypeError,
     r"predictors\[0\] must be of type Predictor, got str"),
    (lambda: imm.IMMPredictor(None, SWITCH), TypeError, "predictors must be an iterable"),
    (lambda: imm.IMMUpdater([ft.KalmanUpdater(SENSOR), 3], SWITCH), TypeError,
     r"updaters\[1\] must be of type Updater, got int"),
    (lambda: imm.BatchGPBFilter([CV, CV], SENSOR, SWITCH, order=2.0), TypeError,
     "order must be an int, 1 or 2 .*, got float"),
    (lambda: tracker.IMMTracker(None, SENSOR, SWITCH, np.zeros(4), np.eye(4)), TypeError,
     "transition_models must be an iterable"),
    (lambda: tracker.IMMTracker([CV, None], SENSOR, SWITCH, np.zeros(4), np.eye(4)),
     TypeError, r"transition_models\[1\] must be of type TransitionModel"),
    (lambda: tracker.IMMTracker([CV, CV], SENSOR, SWITCH, np.zeros(4), np.eye(4),
                                prob_detect=5.0), ValueError, "prob_detect must lie in"),
    (lambda: tracker.IMMTracker([CV, CV], SENSOR, SWITCH, np.zeros(4), np.eye(4),
                                clutter_density=-1), ValueError, "clutter_density must be"),
    (lambda: tracker.MultiTargetTracker(CV, SENSOR, np.zeros((2, 2)), np.eye(4)), ValueError,
     r"prior_mean must be a \(d,\) vector, got shape \(2, 2\)"),
    (lambda: tracker.MultiTargetTracker(CV, SENSOR, np.zeros(4), np.eye(4)).run(None),
     TypeError, "scans must be an iterable"),
    (lambda: PHDTracker(CV, SENSOR, vo_linear_birth(), 0.9, 0.99, 1e-5).run(5), TypeError,
     "scans must be an iterable"),
    (lambda: smoother.ffbs(None, CV, 5), TypeError, "particle_states must be an iterable"),
    (lambda: metrics.position_rmse(None, [1]), TypeError, "track must be an iterable"),
    (lambda: metrics.gospa(np.zeros((3, 0)), np.zeros((2, 0)), 10.0), ValueError,
     r"truths must have at least one coordinate a point, got shape \(3, 0\)"),
    (lambda: ft.KalmanSmoother(CV).smooth_arrays(MEANS, COVARS, 1.0, MEANS,
                                                 COVARS + np.triu(np.ones((4, 4)), 1)),
     ValueError, r"predicted_covars\[1\] is not symmetric"),  # (time 0's is not read)
    (lambda: ft.KalmanSmoother(CV).smooth_arrays(MEANS, COVARS, np.ones((2, 1))), ValueError,
     r"time_intervals must be one interval or T - 1 = 2 of them, got an array of shape "
     r"\(2, 1\)"),
    (lambda: ft.KalmanSmoother(CV).smooth_arrays(MEANS, COVARS, 1.0,
                                                 np.where(np.arange(3)[:, None] == 1, np.nan,
                                                          MEANS), COVARS), ValueError,
     r"predicted_means contains NaN or infinite values \(past time 0"),
    (lambda: association.jpda_marginals([np.ones((2, 3)), np.ones(3)]), ValueError,
     r"weights\[1\] must be 2-D, got 1-D with shape \(3,\)"),
    (lambda: core_phd.update(CV, MEANS, COVARS, ZEROS, np.zeros((1, 2)), 0.9, 1e-4),
     TypeError, "model must be a MeasurementModel, got CombinedLinearGaussianTransitionModel"),
    (lambda: core_phd.update(SENSOR, MEANS, COVARS, ZEROS, np.zeros((1, 2)), 0.9, 1e-4,
                             unscented=(np.nan, 2.0, 0.0)), ValueError, "alpha must be finite"),
    (lambda: CPHDTracker(CV, SENSOR, vo_linear_birth(), 0.9, 0.99, 1e-5, 10.0,
                         max_targets=2**40), ValueError, "max_targets must be <= 10000"),
])
def test_multiple_models_trackers_and_smoothers_name_a_bad_argument(call, error, match):
    _raises(call, error, match)


def test_an_imm_update_refuses_an_indefinite_prediction():
    predictor = imm.IMMPredictor([ft.KalmanPredictor(CV)] * 2, SWITCH)
    updater = imm.IMMUpdater([ft.KalmanUpdater(SENSOR)] * 2, SWITCH)
    prior = ft.GaussianMixture([ft.WeightedGaussianState(np.zeros(4), np.eye(4), weight=0.5,
                                                         timestamp=0.0)] * 2)
    prediction = predictor.predict(prior, timestamp=1.0)
    bad = ft.GaussianMixture([ft.WeightedGaussianState(mean, 0.1 * np.eye(4), weight=0.5,
                                                       timestamp=1.0)
                              for mean in prediction.means])
    bad.covars[:] *= -1.0  # (written into: the mixture checked them when made)
    detection = ft.Detection(np.zeros((2, 1)), timestamp=1.0)
    updater.update(ft.SingleHypothesis(prediction, detection))  # (the legal one)
    with pytest.raises(ValueError, match=r"hypothesis.prediction.covars\[0\] is not positive"):
        updater.update(ft.SingleHypothesis(bad, detection))


@pytest.mark.parametrize("arguments, error, match", [
    (dict(scenario=None), TypeError, "scenario must be callable, got NoneType"),
    (dict(make_filter=None), TypeError, "make_filter must be callable, got NoneType"),
    (dict(gospa_cutoff="10"), TypeError, "gospa_cutoff must be a real number"),
    (dict(gospa_cutoff=np.inf), ValueError, "gospa_cutoff must be finite"),
    (dict(gospa_cutoff=True), TypeError, "gospa_cutoff must be a real number"),
    (dict(progress="yes"), TypeError, "progress must be a bool"),
    (dict(metrics=5), TypeError, "metrics must be an iterable"),
])
def test_run_trials_names_a_bad_argument(arguments, error, match):
    settings = dict(scenario=functools.partial(ft.scenarios.particle_filter_tutorial,
                                               n_particles=10, steps=2),
                    make_filter=lambda world, rng: None, n_runs=2)
    with pytest.raises(error, match=match):
        montecarlo.run_trials(**{**settings, **arguments})


def _user_sensor():
    from user_models import bearing_range_from_50_0
    return ft.NonlinearGaussianMeasurement(bearing_range_from_50_0, 4, np.eye(2))


@pytest.mark.parametrize("make", [
    lambda: ft.BatchExtendedKalmanFilter(CV, SENSOR),
    lambda: ft.BatchUnscentedKalmanFilter(CV, SENSOR),
    lambda: tracker.MultiTargetTracker(CV, SENSOR, np.zeros(4), np.eye(4)),
    lambda: PHDTracker(CV, SENSOR, vo_linear_birth(), 0.9, 0.99, 1e-4),
])
def test_models_swapped_after_construction_are_checked_as_the_constructor_checks_them(make):
    """A model of another kind or dimension assigned later reached the kernels unchecked
    (a segfault, or out-of-bounds reads): refused where it is assigned."""
    owner = make()
    for name, model, error, match in [
            ("measurement_model", ft.LinearGaussian(600, (0, 599), np.eye(2)), ValueError,
             "measurement_model measures 600-D states, transition_model.s are 4-D"),
            ("measurement_model", _user_sensor(), TypeError,
             "measurement_model must be a"),
            ("transition_model", ft.ConstantVelocity(1.0), ValueError,
             "measurement_model measures 4-D states, transition_model.s are 2-D"),
            ("transition_model", "CV", TypeError, "transition_model must be a")]:
        before = getattr(owner, name)
        with pytest.raises(error, match=match):
            setattr(owner, name, model)
        assert getattr(owner, name) is before
    owner.measurement_model = ft.LinearGaussian(4, (0, 2), 2 * np.eye(2))  # (one that fits)


def test_multiple_model_filters_check_swapped_models_and_switching():
    for owner in (imm.BatchIMMFilter([CV, CV], SENSOR, [[0.9, 0.1], [0.1, 0.9]]),
                  tracker.IMMTracker([CV, CV], SENSOR, [[0.9, 0.1], [0.1, 0.9]], np.zeros(4),
                                     np.eye(4))):
        with pytest.raises(ValueError, match="transition_models must keep 2 models"):
            owner.transition_models = [CV]
        with pytest.raises(ValueError, match="transition model 0 .* has 6 state dimensions"):
            owner.transition_models = [CV6, CV6]
        with pytest.raises(ValueError, match="measures 6-D states, transition_model.s are 4-D|"
                                             "has 4 state dimensions, the state 6"):
            owner.measurement_model = ft.LinearGaussian(6, (0, 2), np.eye(2))
        with pytest.raises(ValueError, match=r"transition_matrix must have shape \(2, 2\)"):
            owner.transition_matrix = np.eye(3)
        owner.transition_models = [CV, CV]  # (models that fit: accepted)
        assert len(owner.transition_models) == 2


def test_a_tracker_keeps_a_copy_of_its_prior():
    """NaN written into the caller's prior after construction reached the tracks."""
    mean, covar = np.zeros(4), np.eye(4)
    tracker = ft.IMMTracker([CV, CV], SENSOR, np.full((2, 2), 0.5), mean, covar)
    mean[1], covar[1, 1] = np.nan, np.nan
    assert len(tracker.run([np.zeros((1, 2))] * 3)[-1]) == 1


def test_a_smoother_does_not_read_the_prediction_of_time_0():
    """predicted_means[0] is documented unused, yet a NaN there was refused."""
    smoothed = ft.KalmanSmoother(CV).smooth_arrays(MEANS, COVARS, 1.0, MEANS, COVARS)
    unread = MEANS.copy(), COVARS.copy()
    unread[0][0], unread[1][0] = np.nan, np.nan
    for got, want in zip(ft.KalmanSmoother(CV).smooth_arrays(MEANS, COVARS, 1.0, *unread),
                         smoothed):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("make", [
    lambda: tracker.MultiTargetTracker(CV, SENSOR, np.zeros(4), np.eye(4), min_points=1),
    lambda: PHDTracker(CV, SENSOR, vo_linear_birth(), 0.9, 0.99, 1e-5),
])
def test_a_scan_time_beyond_the_float_range_of_the_last_is_named_as_time(make):
    """Scans at -1e308 s and then 1e308 s: the interval overflowed and the error named
    time_interval, which step does not take."""
    scanner = make()
    scanner.step(np.zeros((1, 2)), -1e308)
    with pytest.raises(ValueError, match=r"time must lie within 1.8e308 s of the previous "
                                         r"scan's \(-1e\+308 s\), got 1e\+308"):
        scanner.step(np.zeros((1, 2)), 1e308)


def test_a_particle_state_s_linear_weights_are_read_only():
    """``weight`` is made from ``log_weight`` when read: a write into it was lost."""
    state = ft.ParticleState(np.zeros((4, 5)), timestamp=0.0)
    with pytest.raises(ValueError, match="read-only"):
        state.weight[0] = 0.5
    state.weight = [0.5, 0.125, 0.125, 0.125, 0.125]
    np.testing.assert_allclose(state.weight, [0.5, 0.125, 0.125, 0.125, 0.125])
