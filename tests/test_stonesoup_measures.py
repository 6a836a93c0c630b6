"""fasttrack.stonesoup.measures: the ``Mahalanobis`` measure equals Stone Soup's."""
import types

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup import measures as ss_measures  # noqa: E402
from stonesoup.types.angle import Bearing  # noqa: E402
from stonesoup.types.array import StateVector, StateVectors  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.prediction import GaussianMeasurementPrediction  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402


def test_mahalanobis_measure_equals_stone_soup():
    rng = np.random.default_rng(14)
    ours, theirs = fss.Mahalanobis(), ss_measures.Mahalanobis()
    for _ in range(20):
        a = rng.normal(size=(3, 3))
        state = GaussianState(rng.normal(size=(3, 1)), a @ a.T + 0.1 * np.eye(3))
        other = GaussianState(rng.normal(size=(3, 1)), np.eye(3))
        assert ours(state, other) == pytest.approx(theirs(state, other), rel=1e-10)
    bearing = GaussianMeasurementPrediction(StateVector([[Bearing(3.1)], [10.0]]),
                                            np.diag([0.01, 1.0]))
    z = Detection(StateVector([[-3.1], [11.0]]))
    assert ours(bearing, z) == pytest.approx(theirs(bearing, z), rel=1e-10)
    singular = GaussianState(np.zeros((2, 1)), np.diag([1.0, 0.0]))  # Stone Soup's pinv
    assert ours(singular, z) == theirs(singular, z)
    lopsided = GaussianState(np.zeros((2, 1)), np.array([[2.0, 0.5], [0.0, 1.0]]))  # (inverted)
    assert ours(lopsided, z) == theirs(lopsided, z)
    several = types.SimpleNamespace(state_vector=StateVectors(rng.normal(size=(2, 3))))
    np.testing.assert_array_equal(ours(singular, several), theirs(singular, several))
    mapped = fss.Mahalanobis(mapping=[0])
    assert mapped(bearing, z) == ss_measures.Mahalanobis(mapping=[0])(bearing, z)


def _particles(rng, n, bearing_near_pi):
    """A particle measurement prediction of bearings (about pi when ``bearing_near_pi``,
    where the wrap matters) and ranges, as Stone Soup's measurement functions type it."""
    from stonesoup.types.prediction import ParticleMeasurementPrediction
    centre = np.pi - 0.05 if bearing_near_pi else 0.4
    bearings = np.remainder(rng.normal(centre, 0.1, n) + np.pi, 2 * np.pi) - np.pi
    vectors = np.empty((2, n), dtype=object)
    vectors[0] = [Bearing(b) for b in bearings]
    vectors[1] = rng.normal(30.0, 2.0, n)
    return ParticleMeasurementPrediction(StateVectors(vectors),
                                         log_weight=np.log(rng.uniform(0.1, 1.0, n)))


@pytest.mark.parametrize("bearing_near_pi", [False, True])
def test_mahalanobis_of_particles_equals_stone_soup_and_runs_no_fallback(bearing_near_pi):
    rng = np.random.default_rng(3)
    ours, theirs = fss.Mahalanobis(), ss_measures.Mahalanobis()
    fss.fallbacks(clear=True)
    for n in (1, 2, 500):
        prediction = _particles(rng, n, bearing_near_pi)
        z = Detection(StateVector([[Bearing(-np.pi + 0.01)], [31.0]]))
        if n == 1:  # a zero covariance: Stone Soup's code, which fails on its objects
            for measure in (theirs, ours):
                with pytest.raises(TypeError):
                    measure(prediction, z)
            continue
        assert ours(prediction, z) == pytest.approx(theirs(prediction, z), rel=1e-10)
    floats = _particles(rng, 300, bearing_near_pi)
    floats.state_vector = StateVectors(np.asarray(floats.state_vector, dtype=np.float64))
    assert ours(floats, z) == pytest.approx(theirs(floats, z), rel=1e-10)
    assert fss.fallbacks(clear=True) == {  # one particle; two span a line (rank one)
        ("Mahalanobis", "__call__",
         "a covariance that is singular or ill-conditioned (Stone Soup's pseudo-inverse)"): 2}


@pytest.mark.parametrize("noise", [True, False])
def test_a_particle_measurement_prediction_is_measured_before_its_bearings_are_objects(noise):
    """The drop-in updater's particle measurement prediction keeps its bearings as floats
    until read; the drop-in ``Mahalanobis`` measures those floats, and gives what it gives
    once they are ``Bearing`` objects, and Stone Soup's measure."""
    import copy
    import pickle

    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.types.prediction import ParticleMeasurementPrediction
    from stonesoup.types.state import ParticleState

    rng = np.random.default_rng(2)
    sensor = CartesianToBearingRange(4, (0, 2), np.diag([0.01, 2.0]))
    prior = ParticleState(StateVectors(np.r_[rng.normal(-40.0, 3.0, (1, 500)),
                                             rng.normal(0, 1, (1, 500)),
                                             rng.normal(0.0, 3.0, (1, 500)),
                                             rng.normal(0, 1, (1, 500))]),
                          log_weight=np.log(rng.uniform(0.1, 1, 500)), timestamp=None)
    prediction = fss.ParticleUpdater(sensor).predict_measurement(prior, sensor,
                                                                 measurement_noise=noise)
    z = Detection(StateVector([[Bearing(3.1)], [40.0]]))
    pending = fss.Mahalanobis()(prediction, z)
    assert "_property_state_vector" not in vars(prediction)  # still floats
    copied = copy.copy(prediction)  # a copy is of the built object
    assert type(copied) is type(prediction) is ParticleMeasurementPrediction
    assert isinstance(copied.state_vector[0, 0], Bearing)
    assert fss.Mahalanobis()(prediction, z) == pytest.approx(pending, rel=1e-12)
    assert ss_measures.Mahalanobis()(prediction, z) == pytest.approx(pending, rel=1e-9)
    again = pickle.loads(pickle.dumps(prediction))
    np.testing.assert_array_equal(np.asarray(again.state_vector, dtype=float),
                                  np.asarray(prediction.state_vector, dtype=float))
