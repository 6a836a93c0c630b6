"""Bad input to the scenario generators (fasttrack.scenarios) and the simulation helpers
(fasttrack.simulate): each error is a TypeError for a wrong type (bools and strings where
numbers are expected included) or a ValueError for a wrong value, and names the argument;
legal edge cases still work."""
import datetime

import numpy as np
import pytest

import fasttrack as ft
from fasttrack import scenarios
from fasttrack.simulate import MultiTargetScenario, detections, ground_truth, multi_target

TRANSITION = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
SENSOR = ft.LinearGaussian(4, (0, 2), np.eye(2))
REGION = [[-10.0, -10.0], [10.0, 10.0]]
START = [0.0, 1.0, 0.0, 1.0]


# --- grid_targets -----------------------------------------------------------------------

@pytest.mark.parametrize("arguments, error, match", [
    (dict(n_targets=0), ValueError, "n_targets must be >= 1, got 0"),
    (dict(n_targets=-1), ValueError, "n_targets must be >= 1, got -1"),
    (dict(n_targets=10**12), ValueError, "n_targets must be <= 10000000"),
    (dict(n_targets=2.5), TypeError, "n_targets must be an int, got float"),
    (dict(n_targets=True), TypeError, "n_targets must be an int, got bool"),
    (dict(n_targets="4"), TypeError, "n_targets must be an int, got str"),
    (dict(steps=0), ValueError, "steps must be >= 1"),
    (dict(steps=2.0), TypeError, "steps must be an int"),
    (dict(clutter_rate=np.inf), ValueError, "clutter_rate must be finite"),
    (dict(clutter_rate=1e30), ValueError, r"clutter_rate must be at most 1e\+07 a scan"),
    (dict(clutter_rate=-1.0), ValueError, "clutter_rate must be finite and >= 0"),
    (dict(clutter_rate="20"), TypeError, "clutter_rate must be a real number, got str"),
    (dict(spacing=-100.0), ValueError, "spacing must be finite and >= 0, got -100"),
    (dict(spacing=np.nan), ValueError, "spacing must be finite, got nan"),
    (dict(spacing=np.inf), ValueError, "spacing must be finite, got inf"),
    (dict(spacing=1e200), ValueError, "spacing 1e\\+200 is too large for 4 targets"),
    (dict(spacing="20"), TypeError, "spacing must be a real number, got str"),
    (dict(prob_detect="0.9"), TypeError, "prob_detect must be a real number, got str"),
    (dict(prob_detect=True), TypeError, "prob_detect must be a real number, got bool"),
    (dict(prob_detect=1.5), ValueError, r"prob_detect must lie in \[0, 1\]"),
    (dict(seed=-1), ValueError, "seed must be a non-negative seed, got -1"),
    (dict(seed=1.5), TypeError, "seed must be None, an int seed.*got float"),
    (dict(seed="1"), TypeError, "seed must be None, an int seed.*got str"),
])
def test_grid_targets_names_a_bad_argument(arguments, error, match):
    with pytest.raises(error, match=match):
        scenarios.grid_targets(**{"n_targets": 4, "steps": 2, **arguments})


@pytest.mark.parametrize("arguments", [
    dict(n_targets=1), dict(spacing=0.0), dict(spacing=5), dict(n_targets=np.int64(3)),
    dict(clutter_rate=0), dict(prob_detect=1), dict(seed=np.random.SeedSequence(3)),
    dict(seed=np.random.default_rng(3)), dict(seed=np.int64(3)), dict(seed=None),
])
def test_grid_targets_takes_legal_edge_input(arguments):
    scenario = scenarios.grid_targets(**{"n_targets": 4, "steps": 2, **arguments})
    assert isinstance(scenario, MultiTargetScenario)
    assert all(np.isfinite(z).all() for z in scenario.detections)


def test_grid_targets_seed_forms_agree():
    a = scenarios.grid_targets(4, 3, seed=7)
    b = scenarios.grid_targets(4, 3, seed=np.random.SeedSequence(7))
    for za, zb in zip(a.detections, b.detections):
        np.testing.assert_array_equal(za, zb)


# --- the tutorials' scenarios -----------------------------------------------------------

TUTORIALS = [scenarios.particle_filter_tutorial, scenarios.adaptive_kernel_tutorial]


@pytest.mark.parametrize("tutorial", TUTORIALS + [scenarios.extended_kalman_tutorial])
@pytest.mark.parametrize("arguments, error, match", [
    (dict(seed=-1), ValueError, "seed must be a non-negative seed, got -1"),
    (dict(seed=1.5), TypeError, "seed must be None, an int seed.*got float"),
    (dict(seed="a"), TypeError, "seed must be None, an int seed.*got str"),
    (dict(steps=0), ValueError, "steps must be >= 1, got 0"),
    (dict(steps=2.5), TypeError, "steps must be an int, got float"),
    (dict(steps=True), TypeError, "steps must be an int, got bool"),
])
def test_tutorials_name_a_bad_seed_or_steps(tutorial, arguments, error, match):
    with pytest.raises(error, match=match):
        tutorial(**arguments)


@pytest.mark.parametrize("tutorial", TUTORIALS)
@pytest.mark.parametrize("n_particles, error, match", [
    (0, ValueError, "n_particles must be >= 1, got 0"),
    (-1, ValueError, "n_particles must be >= 1, got -1"),
    (10**13, ValueError, "n_particles must be <= "),
    (2.5, TypeError, "n_particles must be an int, got float"),
    (True, TypeError, "n_particles must be an int, got bool"),
    ("5", TypeError, "n_particles must be an int, got str"),
])
def test_tutorials_name_a_bad_particle_count(tutorial, n_particles, error, match):
    with pytest.raises(error, match=match):
        tutorial(n_particles=n_particles, steps=2)


@pytest.mark.parametrize("tutorial", TUTORIALS)
def test_tutorials_take_one_particle_and_a_generator(tutorial):
    scenario = tutorial(n_particles=1, seed=np.random.default_rng(0), steps=2)
    assert scenario.prior.state_vector.shape == (4, 1)
    assert len(scenario.truth) == len(scenario.detections) == 2


# --- multi_target -----------------------------------------------------------------------

def _multi(**arguments):
    return multi_target(**{"transition_model": TRANSITION, "measurement_model": SENSOR,
                           "initial_states": np.zeros((2, 4)), "steps": 3, "region": REGION,
                           "rng": 0, **arguments})


BIRTH = dict(birth_rate=5.0, birth_mean=np.zeros(4))


@pytest.mark.parametrize("arguments, error, match", [
    (dict(BIRTH, birth_covar=np.diag([1.0, -1, 1, 1])), ValueError,
     "birth_covar is not positive semi-definite"),
    (dict(BIRTH, birth_covar=np.eye(4) + 0.9 * np.eye(4, k=1)), ValueError,
     "birth_covar must be symmetric"),
    (dict(BIRTH, birth_covar=np.eye(2)), ValueError, r"birth_covar must have shape \(4, 4\)"),
    (dict(BIRTH, birth_covar=np.full((4, 4), np.nan)), ValueError, "birth_covar contains NaN"),
    (dict(BIRTH, birth_covar="eye"), TypeError, "birth_covar must be a numeric array"),
    (dict(birth_rate=5.0, birth_mean=np.full(4, np.nan), birth_covar=np.eye(4)), ValueError,
     "birth_mean contains NaN"),
    (dict(birth_rate=5.0, birth_mean=np.zeros(3), birth_covar=np.eye(4)), ValueError,
     "birth_mean must have 4 components"),
    (dict(birth_rate=5.0, birth_mean=np.zeros((2, 2)), birth_covar=np.eye(4)), ValueError,
     "birth_mean must have 4 components"),
    (dict(birth_rate=np.inf, birth_mean=np.zeros(4), birth_covar=np.eye(4)), ValueError,
     "birth_rate must be finite"),
    (dict(birth_rate=1e8, birth_mean=np.zeros(4), birth_covar=np.eye(4)), ValueError,
     r"birth_rate must be at most 1e\+07 a scan"),
    (dict(birth_rate=1.0), ValueError, "birth_rate > 0 needs birth_mean and birth_covar"),
    (dict(clutter_rate=1e12), ValueError, r"clutter_rate must be at most 1e\+07 a scan"),
    (dict(clutter_rate="5"), TypeError, "clutter_rate must be a real number, got str"),
    (dict(prob_detect=True), TypeError, "prob_detect must be a real number, got bool"),
    (dict(prob_survive=-0.1), ValueError, r"prob_survive must lie in \[0, 1\]"),
    (dict(time_interval="1"), TypeError, "time_interval must be a datetime.timedelta, "
                                         "numpy.timedelta64 or a number of seconds, got str"),
    (dict(time_interval=True), TypeError, "time_interval must be a datetime.timedelta"),
    (dict(time_interval=0.0), ValueError, "time_interval must be > 0 seconds"),
    (dict(time_interval=-1.0), ValueError, "time_interval must be > 0 seconds"),
    (dict(time_interval=np.nan), ValueError, "time_interval must be finite"),
    (dict(time_interval=datetime.timedelta(0)), ValueError,
     "time_interval must be > 0 seconds"),
    (dict(region=[[-1e308, -1e308], [1e308, 1e308]]), ValueError, "region's volume overflows"),
    (dict(region=[[0.0, 0.0], [1e-300, 1e-300]]), ValueError, "region's volume underflows"),
    (dict(region=[[0.0, 0.0], [1e-160, 1e-160]], clutter_rate=1e7), ValueError,
     "clutter density .*clutter_rate .*region's volume"),
    (dict(region=np.zeros((2, 3))), ValueError, r"region must be \(2, 2\)"),
    (dict(initial_states=np.full((1, 4), np.nan)), ValueError, "initial_states contains NaN"),
    (dict(initial_states=np.zeros(4)), ValueError, "initial_states must be 2-D"),
    (dict(steps=2.0), TypeError, "steps must be an int"),
    (dict(rng="abc"), TypeError, "rng must be None, an int seed"),
    (dict(transition_model=None), TypeError,
     "transition_model must be a TransitionModel of fasttrack.models"),
    (dict(measurement_model=TRANSITION), TypeError,
     "measurement_model must be a MeasurementModel of fasttrack.models"),
    (dict(initial_states=[[0.0, 1e300, 0.0, 1.0]], time_interval=1e10), ValueError,
     "states overflow float64 at scan 1.*time_interval"),
])
def test_multi_target_names_a_bad_argument(arguments, error, match):
    with pytest.raises(error, match=match):
        _multi(**arguments)


def test_multi_target_takes_a_timedelta_interval_as_seconds():
    seconds = _multi(time_interval=2.0, clutter_rate=3.0)
    delta = _multi(time_interval=datetime.timedelta(seconds=2), clutter_rate=3.0)
    assert delta.time_interval == 2.0
    for a, b in zip(seconds.detections, delta.detections):
        np.testing.assert_array_equal(a, b)


def test_multi_target_legal_edges():
    # No initial targets: births only; a (d, 1) birth mean; clutter at the float64 limit of
    # a region's extent that still has a finite volume.
    scenario = _multi(initial_states=np.zeros((0, 4)), birth_rate=2.0,
                      birth_mean=np.zeros((4, 1)), birth_covar=np.eye(4), clutter_rate=2.0)
    assert scenario.truths[0].shape == (0, 4)
    assert all(np.isfinite(x).all() for x in scenario.truths + scenario.detections)
    scenario = _multi(region=[[-1e150, -1e150], [1e150, 1e150]], clutter_rate=2.0)
    assert np.isfinite(scenario.clutter_density) and scenario.clutter_density > 0
    # A birth mean and covariance with birth_rate 0 are accepted (and unused).
    _multi(birth_rate=0.0, birth_mean=np.zeros(4), birth_covar=np.eye(4))


# --- ground_truth and detections --------------------------------------------------------

@pytest.mark.parametrize("arguments, error, match", [
    (dict(time_interval=-1.0), ValueError, "time_interval must be > 0 seconds, got -1"),
    (dict(time_interval=0.0), ValueError, "time_interval must be > 0 seconds, got 0"),
    (dict(time_interval=datetime.timedelta(seconds=-2)), ValueError,
     "time_interval must be > 0 seconds"),
    (dict(time_interval="1"), TypeError, "time_interval must be a datetime.timedelta"),
    (dict(time_interval=np.inf), ValueError, "time_interval must be finite"),
    (dict(time_interval=1e308), ValueError, r"time_interval of 1e\+308 s overflows"),
    (dict(initial_state=[0.0, 1e300, 0.0, 1.0], time_interval=1e10), ValueError,
     "truth overflows float64 at step 1.*time_interval=1e\\+10 s from initial_state"),
    (dict(time_interval=1e12, start_time=datetime.datetime(2020, 1, 1)), ValueError,
     "timestamps run out of range: start_time .*time_interval"),
    (dict(initial_state=[0.0, 1.0, 0.0]), ValueError, "initial_state must have 4 components"),
    (dict(initial_state=np.zeros((2, 2))), ValueError, "initial_state must have 4 components"),
    (dict(initial_state=[np.nan, 1.0, 0.0, 1.0]), ValueError, "initial_state contains NaN"),
    (dict(initial_state=None), TypeError, "initial_state must be a numeric array"),
    (dict(initial_state=ft.GroundTruthState([0.0, 1.0], timestamp=0.0)), ValueError,
     "initial_state must have 4 components"),
    (dict(steps=0), ValueError, "steps must be >= 1"),
    (dict(steps=1.5), TypeError, "steps must be an int"),
    (dict(start_time=None), ValueError, "start_time is required"),
    (dict(start_time="now"), TypeError, "start_time"),
    (dict(transition_model=None), TypeError,
     "transition_model must be a TransitionModel of fasttrack.models"),
    (dict(transition_model=SENSOR), TypeError,
     "transition_model must be a TransitionModel of fasttrack.models"),
    (dict(rng=-3), ValueError, "rng must be a non-negative seed"),
])
def test_ground_truth_names_a_bad_argument(arguments, error, match):
    with pytest.raises(error, match=match):
        ground_truth(**{"transition_model": TRANSITION, "initial_state": START, "steps": 3,
                        **arguments})


@pytest.mark.parametrize("initial_state", [
    ft.GroundTruthState(START, timestamp=0.0),
    ft.GaussianState(START, np.eye(4), timestamp=0.0),
    np.array(START).reshape(4, 1),
    tuple(START),
])
def test_ground_truth_takes_a_state_or_a_column(initial_state):
    path = ground_truth(TRANSITION, initial_state, 3, rng=0)
    expected = ground_truth(TRANSITION, START, 3, rng=0)
    assert len(path) == 3
    for a, b in zip(path, expected):
        np.testing.assert_array_equal(a.state_vector, b.state_vector)


def test_ground_truth_timedelta_interval_and_datetime_start():
    start = datetime.datetime(2026, 1, 1)
    path = ground_truth(TRANSITION, START, 3, time_interval=datetime.timedelta(seconds=2),
                        start_time=start, rng=0)
    assert [s.timestamp for s in path] == [start + datetime.timedelta(seconds=2 * k)
                                           for k in range(3)]


def test_ground_truth_float_timestamps_must_stay_finite():
    still = ft.LinearGaussianTransitionModel(np.eye(2), np.eye(2))  # time-invariant
    with pytest.raises(ValueError, match="timestamps run out of range: start_time 1.7e"):
        ground_truth(still, [0.0, 0.0], 3, time_interval=1e307, start_time=1.7e308)


@pytest.mark.parametrize("truth, error, match", [
    (np.zeros((3, 4)), TypeError, "truth must be an iterable of states.*got ndarray"),
    (5, TypeError, "truth must be an iterable of states.*got int"),
    ("abc", TypeError, "truth must be an iterable of states.*got str"),
    (ft.GroundTruthState(START, timestamp=0.0), TypeError,
     "truth must be an iterable of states.*got GroundTruthState"),
])
def test_detections_name_bad_truth(truth, error, match):
    with pytest.raises(error, match=match):
        detections(truth, SENSOR)


def test_detections_name_a_bad_model_or_overflow():
    path = ground_truth(TRANSITION, START, 2, rng=0)
    for model in (None, TRANSITION):
        with pytest.raises(TypeError, match="measurement_model must be a MeasurementModel"):
            detections(path, model)
    polar = ft.CartesianToBearingRange(4, (0, 2), np.diag([1e-4, 1.0]))
    far = [ft.GroundTruthState([1e200, 0.0, 1e200, 0.0], timestamp=0.0)]
    with pytest.raises(ValueError, match=r"measurement of truth\[0\] is not finite: "
                                         r"measurement_model"):
        detections(far, polar, rng=0)
    assert detections([], SENSOR) == []


# --- sizes beyond memory, models that disagree ---------------------------------------------

def _huge_memory(monkeypatch, gib):
    """The machine as reported to the checks: ``gib`` GiB of memory."""
    import os
    sysconf = os.sysconf
    pages = {"SC_PAGE_SIZE": 4096, "SC_PHYS_PAGES": gib * 2**30 // 4096}
    monkeypatch.setattr(os, "sysconf", lambda name: pages.get(name) or sysconf(name))


@pytest.mark.parametrize("call, match", [
    (lambda: scenarios.vo_linear(clutter_rate=1e7), r"100 scans of clutter_rate=1e\+07, about "
                                                    r"1e\+09 measurements, needs .* GiB"),
    (lambda: scenarios.grid_targets(n_targets=4, clutter_rate=1e7),
     r"steps=50 of clutter_rate=1e\+07, birth_rate=0 and 4 initial_states"),
    (lambda: scenarios.grid_targets(n_targets=10**7, steps=2**40, clutter_rate=0.0),
     r"steps=1099511627776 of .* 10000000 initial_states"),
    (lambda: _multi(steps=10**6, **BIRTH, birth_covar=np.eye(4)), r"birth_rate=5"),
    (lambda: scenarios.particle_filter_tutorial(n_particles=10**11, steps=2),
     "n_particles=100000000000 needs"),
    (lambda: scenarios.adaptive_kernel_tutorial(n_particles=2**40, steps=2),
     "n_particles=1099511627776 needs"),
    (lambda: scenarios.particle_filter_tutorial(steps=10**9), "steps=1000000000 needs"),
    (lambda: ground_truth(TRANSITION, START, 10**9), "steps=1000000000 needs"),
])
def test_scenarios_beyond_memory_are_named_at_once(call, match, monkeypatch):
    """vo_linear's documented clutter_rate of 1e7 needed 24 GB and ran for minutes into
    NumPy's MemoryError; counts under the 2**40 cap that could not be stored ran until
    killed."""
    _huge_memory(monkeypatch, 16)
    with pytest.raises(ValueError, match=match + ".*more than this machine's 16 GiB"):
        call()


def test_a_measurement_model_of_other_states_is_named():
    six = ft.LinearGaussian(6, (0, 2), np.eye(2))
    with pytest.raises(ValueError, match="measurement_model measures 6-D states, "
                                         "transition_model's are 4-D"):
        _multi(measurement_model=six, region=REGION)
    with pytest.raises(ValueError, match=r"measurement_model measures 6-D states, got "
                                         r"truth\[0\] of shape \(4, 1\)"):
        detections(ground_truth(TRANSITION, START, 2, rng=0), six)
