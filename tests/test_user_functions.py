"""Users' @njit model functions: checked at construction and on every call, so that a wrong
shape, dtype or non-finite output is a ValueError/TypeError naming the function, never a
read or write out of bounds."""
import datetime
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from numba import njit

import fasttrack as ft
from fasttrack._jit import user

import reference.likelihood
import reference.propagate
import reference.user
from user_models import bearing_range_from_50_0, coordinated_turn

NOISE = np.diag([np.radians(0.2), 1.0])
START = datetime.datetime(2026, 1, 1)


@njit(cache=False)
def one_row(states):
    return states[:1].copy()


@njit(cache=False)
def three_rows(states):
    return states[:3].copy()


@njit(cache=False)
def one_column(states):
    return states[:2, :1].copy()


@njit(cache=False)
def vector(states):
    return states[0].copy()


@njit(cache=False)
def integers(states):
    return np.zeros((2, states.shape[1]), dtype=np.int64)


@njit(cache=False)
def per_state(x):  # written for one (d,) state
    return np.array([np.arctan2(x[2], x[0]), np.sqrt(x[0] ** 2 + x[2] ** 2)])


@njit(cache=False)
def nan_beyond_100(states):
    out = np.zeros((2, states.shape[1]))
    if states[0, 0] > 100.0:
        out[0, 0] = np.nan
    return out


@njit(cache=False)
def short_transition(states, dt):
    return states[:3].copy()


@njit(cache=False)
def nan_transition(states, dt):
    return states * np.nan


@njit(cache=False)
def no_interval(states):
    return states.copy()


@njit(cache=False, error_model="python")
def undefined_at_probe(states):
    out = np.empty((2, states.shape[1]))
    for i in range(states.shape[1]):
        out[0, i] = 1.0 / (states[0, i] - 1.0)  # ZeroDivisionError at the probe's x = 1
        out[1, i] = states[2, i]
    return out


def test_construction_checks_return_type_and_shape_and_names_the_function():
    with pytest.raises(ValueError, match=r"measurement function 'one_row' returned an array of "
                                         r"shape \(1, 3\) .* expected \(2, 3\)"):
        ft.NonlinearGaussianMeasurement(one_row, 4, NOISE)
    with pytest.raises(ValueError, match=r"'three_rows' returned .* \(3, 3\)"):
        ft.NonlinearGaussianMeasurement(three_rows, 4, NOISE)
    with pytest.raises(ValueError, match=r"'one_column' returned .* \(2, 1\)"):
        ft.NonlinearGaussianMeasurement(one_column, 4, NOISE)
    with pytest.raises(TypeError, match=r"'vector' must return a 2-D float64 array .* "
                                        r"returns array\(float64, 1d"):
        ft.NonlinearGaussianMeasurement(vector, 4, NOISE)
    with pytest.raises(TypeError, match="'integers' must return a 2-D float64 array"):
        ft.NonlinearGaussianMeasurement(integers, 4, NOISE)
    with pytest.raises(TypeError, match=r"'per_state' cannot be compiled for a \(d, n\) float64 "
                                        r"array of states .* one per column"):
        ft.NonlinearGaussianMeasurement(per_state, 4, NOISE)
    with pytest.raises(ValueError, match=r"transition function 'short_transition' returned an "
                                         r"array of shape \(3, 3\)"):
        ft.NonlinearGaussianTransitionModel(short_transition, np.eye(4), 4)
    with pytest.raises(TypeError, match=r"'no_interval' cannot be compiled .* and a float "
                                        r"interval \(signature f\(states, dt\)"):
        ft.NonlinearGaussianTransitionModel(no_interval, np.eye(4), 4)
    with pytest.raises(TypeError, match="must be a numba.njit function"):
        ft.NonlinearGaussianMeasurement(lambda x: x, 4, NOISE)


def test_a_function_undefined_at_the_probe_is_accepted_and_checked_on_each_call():
    model = ft.NonlinearGaussianMeasurement(undefined_at_probe, 4, NOISE)
    values = model.function(np.array([[3.0], [0.0], [2.0], [0.0]]))
    np.testing.assert_allclose(values, [[0.5], [2.0]])


def _prediction(n=3000, centre=(0.0, 1.0, 0.0, 1.0)):
    prior = ft.ParticleState(np.asarray(centre)[:, None]
                             + np.random.default_rng(0).normal(size=(4, n)), timestamp=START)
    return prior, ft.ParticlePredictor(ft.CombinedLinearGaussianTransitionModel(
        [ft.ConstantVelocity(0.05)] * 2), rng=1).predict(prior, START + datetime.timedelta(seconds=1))


def test_non_finite_outputs_raise_naming_the_function_in_every_entry_point():
    model = ft.NonlinearGaussianMeasurement(nan_beyond_100, 4, NOISE)
    far = np.full((4, 1), 200.0)
    message = r"measurement function 'nan_beyond_100' returned NaN or infinite values"
    with pytest.raises(ValueError, match=message):
        model.function(far)
    with pytest.raises(ValueError, match=message):
        model.logpdf([0.0, 0.0], far)
    prior, prediction = _prediction(centre=(200.0, 1.0, 0.0, 1.0))
    with pytest.raises(ValueError, match=message):
        ft.ParticleUpdater(model).update(ft.SingleHypothesis(prediction, ft.Detection([0.0, 0.0])))
    gaussian = ft.GaussianStatePrediction(far, np.eye(4), timestamp=1.0)
    with pytest.raises(ValueError, match=message):
        ft.ExtendedKalmanUpdater(model).update(ft.SingleHypothesis(gaussian, ft.Detection([0.0, 0.0])))
    transition = ft.NonlinearGaussianTransitionModel(nan_transition, np.eye(4), 4)
    message = r"transition function 'nan_transition' returned NaN or infinite values"
    with pytest.raises(ValueError, match=message):
        transition.function(far, time_interval=1.0)
    with pytest.raises(ValueError, match=message):
        ft.ParticlePredictor(transition).predict(prior, START + datetime.timedelta(seconds=1))
    with pytest.raises(ValueError, match=message):
        ft.ExtendedKalmanPredictor(transition).predict(
            ft.GaussianState(far, np.eye(4), timestamp=0.0), 1.0)


def test_shape_checks_on_every_call_name_the_function_and_shapes():
    # a function whose shape is right at the probe (3 states) but wrong for blocks of 1024
    @njit(cache=False)
    def short_for_many(states):
        rows = 2 if states.shape[1] < 1000 else 1
        return np.zeros((rows, states.shape[1]))

    model = ft.NonlinearGaussianMeasurement(short_for_many, 4, NOISE)
    prior, prediction = _prediction(5000)
    with pytest.raises(ValueError, match=r"'short_for_many' returned an array of shape "
                                         r"\(1, 1024\) for states of shape \(4, 1024\); "
                                         r"expected \(2, 1024\)"):
        ft.ParticleUpdater(model).update(ft.SingleHypothesis(prediction, ft.Detection([0.0, 0.0])))
    with pytest.raises(ValueError, match="'short_for_many' returned an array of shape"):
        model.function(prediction.state_vector)


def test_an_error_a_kernel_could_not_pass_on_is_found_and_named():
    """A function raising for one particle beyond the first block (compiled calls cannot
    pass the error on): the error names the block and carries the function's own error; a
    failure that calling again does not reproduce says so, instead of a shape that matches
    the one expected."""
    @njit(cache=False)
    def refuses_outliers(states, dt):
        for j in range(states.shape[1]):
            if states[0, j] > 1e3:
                raise ValueError("an outlier")
        return states.copy()

    @njit(cache=False)
    def short_for_five(states, dt):
        return states[:, :1].copy() if states.shape[1] == 5 else states.copy()

    model = ft.NonlinearGaussianTransitionModel(refuses_outliers, np.eye(4) * 0.01, 4)
    particles = np.zeros((4, 5000))
    particles[0, 3000] = 2e3
    with pytest.raises(ValueError, match=r"transition function 'refuses_outliers' raised "
                                         r"ValueError: an outlier for states 2048 to 3071 "
                                         r"\(of 5000\)") as raised:
        ft.ParticlePredictor(model, rng=0).predict(ft.ParticleState(particles, timestamp=0.0),
                                                   1.0)
    assert str(raised.value.__cause__) == "an outlier"
    model = ft.NonlinearGaussianTransitionModel(short_for_five, np.eye(4), 4)
    with pytest.raises(ValueError, match=r"'short_for_five' returned an array of the wrong "
                                         r"shape when a kernel called it .* not when called "
                                         r"again on these states of shape \(4, 1\)"):
        ft.ExtendedKalmanPredictor(model).predict(ft.GaussianState(np.arange(4.0), np.eye(4),
                                                                   timestamp=0.0), 1.0)


def test_kernels_check_outputs_as_their_mirrors_do():
    x = np.random.default_rng(2).normal(size=(4, 2500))
    for values, rows, cols in [(x[:2], 2, 2500), (x[:1], 2, 2500), (x[:2, :5], 2, 4),
                               (np.where(x > 3, np.inf, x)[:2], 2, 2500)]:
        values = np.ascontiguousarray(values)
        assert (user.output_status(values, rows, cols)
                == reference.user.output_status(values, rows, cols))
    np.testing.assert_array_equal(user.columns(x, 3, 17), reference.user.columns(x, 3, 17))
    for codes in ([0, 0, 0], [0, 6, 7], [7]):
        codes = np.array(codes, dtype=np.int64)
        assert user.first_failure(codes) == reference.user.first_failure(codes)
    from fasttrack._jit import likelihood, propagate
    for function in (bearing_range_from_50_0, one_row):
        got, want = np.empty((2, 2500)), np.empty((2, 2500))
        angles = np.array([True, False])
        assert likelihood.measure_function(function, x, angles, got) == \
            reference.likelihood.measure_function(function, x, angles, want)
        got_w, want_w = np.empty(2500), np.empty(2500)
        top, code = likelihood.log_likelihood_function(function, np.zeros(2), x, angles,
                                                       np.eye(2), -1.0, np.zeros(2500), got_w)
        assert code == reference.likelihood.log_likelihood_function(
            function, np.zeros(2), x, angles, np.eye(2), -1.0, np.zeros(2500), want_w)[1]
    for function in (coordinated_turn, short_transition):
        got, want = np.empty_like(x), np.empty_like(x)
        assert propagate.propagate_function(function, 1.0, x, np.eye(4), 5, got) == \
            reference.propagate.propagate_function(function, 1.0, x, np.eye(4), 5, want)


ROW_CASES = textwrap.dedent("""
    import sys
    import numpy as np
    from numba import njit
    import fasttrack as ft

    def rows_function(rows):
        @njit(cache=False)
        def h(states):  # right at the construction probe (3 states), `rows` rows otherwise
            n = states.shape[1]
            out = np.empty((2 if n == 3 else rows, n))
            for r in range(out.shape[0]):
                for i in range(n):
                    out[r, i] = states[r % states.shape[0], i]
            return out
        return h

    rng = np.random.default_rng(int(sys.argv[1]))
    outcomes = []
    for rows in range(5):
        model = ft.NonlinearGaussianMeasurement(rows_function(rows), 4, np.diag([0.01, 1.0]),
                                                angle_components=(0,))
        for n in (1, 7, 1024, 3001):
            x = rng.normal(size=(4, n))
            prediction = ft.ParticleStatePrediction(x, timestamp=0.0)
            gaussian = ft.GaussianStatePrediction(x[:, :1], np.eye(4), timestamp=0.0)
            calls = [lambda: model.function(x), lambda: model.logpdf([0.1, 1.0], x),
                     lambda: ft.ParticleUpdater(model).update(
                         ft.SingleHypothesis(prediction, ft.Detection([0.1, 1.0]))),
                     lambda: ft.ExtendedKalmanUpdater(model).update(
                         ft.SingleHypothesis(gaussian, ft.Detection([0.1, 1.0]))),
                     lambda: ft.UnscentedKalmanUpdater(model).update(
                         ft.SingleHypothesis(gaussian, ft.Detection([0.1, 1.0])))]
            for call in calls:
                try:
                    call()
                    outcomes.append(f"{rows}:ok")
                except ValueError as error:
                    assert "'h' returned an array of shape" in str(error), error
                    outcomes.append(f"{rows}:ValueError")
    print(" ".join(sorted(set(outcomes))))
""")


@pytest.mark.slow
def test_any_number_of_rows_never_crashes():
    """Functions returning 0..4 rows against a 2x2 noise, through every entry point, in a
    subprocess (a crash there cannot take the test run down)."""
    result = subprocess.run([sys.executable, "-c", ROW_CASES, "0"], capture_output=True,
                            text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout.split() == ["0:ValueError", "1:ValueError", "2:ok", "3:ValueError",
                                     "4:ValueError"]


def test_user_models_track_like_the_built_in_ones():
    transition = ft.NonlinearGaussianTransitionModel(coordinated_turn, np.eye(4) * 0.01, 4)
    sensor = ft.NonlinearGaussianMeasurement(bearing_range_from_50_0, 4, NOISE,
                                             angle_components=(0,))
    built_in = ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    x = np.random.default_rng(3).normal(size=(4, 500)) * 10
    np.testing.assert_allclose(sensor.function(x), built_in.function(x), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(transition.function(x, time_interval=1.0),
                               coordinated_turn(x, 1.0), rtol=1e-15)


@njit(cache=False)
def refuses_long_steps(states, dt):
    if dt > 1.5:
        raise ValueError("refuses_long_steps: dt too long")
    return states + 0.1 * dt


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")  # Numba's print
def test_an_exception_inside_the_function_reaches_the_caller():
    """Raised inside a kernel's call, it is printed by Numba and the kernel sees no output;
    the error then calls the function from Python, which raises it to the caller."""
    from fasttrack import _jit
    _jit.kernels_from_now()
    model = ft.NonlinearGaussianTransitionModel(refuses_long_steps, np.eye(2) * 0.01, 2)
    prior = ft.GaussianState([0.0, 0.0], np.eye(2), timestamp=0.0)
    assert np.allclose(ft.ExtendedKalmanPredictor(model).predict(prior, 1.0).state_vector, 0.1)
    particles = ft.ParticleState(np.zeros((2, 50)), timestamp=0.0)
    for predict in (ft.ExtendedKalmanPredictor(model).predict,
                    ft.UnscentedKalmanPredictor(model).predict,
                    ft.ParticlePredictor(model, rng=1).predict):
        with pytest.raises(ValueError, match="dt too long"):
            predict(particles if "Particle" in predict.__qualname__ else prior, 2.0)
