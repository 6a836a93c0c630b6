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
    several = types.SimpleNamespace(state_vector=StateVectors(rng.normal(size=(2, 3))))
    np.testing.assert_array_equal(ours(singular, several), theirs(singular, several))
    mapped = fss.Mahalanobis(mapping=[0])
    assert mapped(bearing, z) == ss_measures.Mahalanobis(mapping=[0])(bearing, z)
