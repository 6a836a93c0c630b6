"""The drop-ins' object builder: what it builds equals what Stone Soup's constructor builds
(the same class, the same properties in the same order, the same side effects), and it is
the constructor itself where it cannot know that."""
import datetime
import weakref

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.base import Property
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.detection import Detection, MissedDetection
from stonesoup.types.hypothesis import SingleDistanceHypothesis, SingleHypothesis
from stonesoup.types.metric import SingleTimeMetric
from stonesoup.types.multihypothesis import MultipleHypothesis
from stonesoup.types.numeric import Probability
from stonesoup.types.prediction import (GaussianMeasurementPrediction, GaussianStatePrediction,
                                        Prediction, TaggedWeightedGaussianStatePrediction,
                                        WeightedGaussianStatePrediction)
from stonesoup.types.hypothesis import SingleProbabilityHypothesis
from stonesoup.types.state import GaussianState, TaggedWeightedGaussianState, WeightedGaussianState
from stonesoup.types.update import GaussianStateUpdate

from fasttrack.stonesoup._objects import builder, from_state

T0 = datetime.datetime(2025, 1, 1)
MEAN = StateVector([[1.0], [2.0], [3.0], [4.0]])
COVAR = CovarianceMatrix(np.diag([1.0, 2.0, 3.0, 4.0]))
PRIOR = TaggedWeightedGaussianState(MEAN, COVAR, weight=0.3, tag="a", timestamp=T0)
Z_HAT = GaussianMeasurementPrediction(MEAN[:2], COVAR[:2, :2], timestamp=T0,
                                      cross_covar=COVAR[:, :2])

CASES = [
    (GaussianStatePrediction, dict(state_vector=MEAN, covar=COVAR, timestamp=T0, prior=PRIOR)),
    (TaggedWeightedGaussianStatePrediction,
     dict(state_vector=MEAN, covar=COVAR, timestamp=T0, weight=0.5, tag="b", prior=PRIOR)),
    (WeightedGaussianStatePrediction, dict(state_vector=MEAN, covar=COVAR, weight=0.5)),
    (GaussianMeasurementPrediction,
     dict(state_vector=MEAN[:2], covar=COVAR[:2, :2], timestamp=T0, cross_covar=COVAR[:, :2])),
    (TaggedWeightedGaussianState,
     dict(state_vector=MEAN, covar=COVAR, timestamp=T0, weight=0.5, tag="c")),
    (WeightedGaussianState, dict(state_vector=MEAN, covar=COVAR, weight=0.25)),
    (MissedDetection, dict(timestamp=T0)),
    (SingleDistanceHypothesis,
     dict(prediction=PRIOR, measurement=MissedDetection(timestamp=T0), distance=3.0)),
    (SingleProbabilityHypothesis,
     dict(prediction=PRIOR, measurement=Detection(MEAN[:2], timestamp=T0),
          probability=Probability(0.5), measurement_prediction=Z_HAT)),
    (MultipleHypothesis, dict(single_hypotheses=[SingleHypothesis(PRIOR, None)])),
    (SingleTimeMetric, dict(title="t", value=1.0, generator=None, timestamp=T0)),
]


def _same(a, b):
    assert type(a) is type(b)
    assert list(vars(a)) == list(vars(b))
    for (_, x), (_, y) in zip(vars(a).items(), vars(b).items()):
        assert type(x) is type(y)
        assert x is y or (np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y)


@pytest.mark.parametrize("cls, values", CASES, ids=[c.__name__ for c, _ in CASES])
def test_a_built_object_is_the_constructed_one(cls, values):
    build = builder(cls)
    assert build is not cls  # the fast path is taken for every type the drop-ins build
    _same(build(**values), cls(**values))


def test_a_tag_left_out_is_a_new_uuid_as_the_constructor_gives():
    build = builder(TaggedWeightedGaussianState)
    tags = {build(state_vector=MEAN, covar=COVAR, tag=None).tag for _ in range(3)}
    assert len(tags) == 3 and all(len(tag) == 36 for tag in tags)


def test_a_prediction_keeps_its_priors_prior_weakly_as_stone_soup_does():
    """``Prediction.__init__``: the prediction behind the prior's hypothesis then holds its
    own prior by weak reference (Stone Soup's memory rule), in both ways of building."""
    for make in (GaussianStatePrediction, builder(GaussianStatePrediction)):
        old = GaussianState(MEAN, COVAR, timestamp=T0)
        earlier = GaussianStatePrediction(MEAN, COVAR, timestamp=T0, prior=old)
        update = GaussianStateUpdate(MEAN, COVAR, SingleHypothesis(earlier, None), timestamp=T0)
        make(state_vector=MEAN, covar=COVAR, timestamp=T0, prior=update)
        assert isinstance(earlier._property_prior, weakref.ReferenceType)
        assert earlier.prior is old


def test_a_normalised_multiple_hypothesis_is_normalised():
    build = builder(MultipleHypothesis)
    singles = [SingleProbabilityHypothesis(PRIOR, MissedDetection(timestamp=T0),
                                           Probability(p)) for p in (1.0, 3.0)]
    multiple = build(single_hypotheses=singles, normalise=True)
    assert [float(h.probability) for h in multiple] == pytest.approx([0.25, 0.75])


def test_from_state_gives_the_type_and_properties_stone_soups_gives():
    values = dict(state_vector=MEAN + 1, covar=CovarianceMatrix(COVAR * 2), timestamp=T0,
                  prior=PRIOR)
    _same(from_state(Prediction, PRIOR, **values), Prediction.from_state(PRIOR, **values))
    detection = Detection(MEAN[:2], timestamp=T0)
    _same(from_state(Prediction, detection, state_vector=MEAN),
          Prediction.from_state(detection, state_vector=MEAN))


class _OwnInit(GaussianState):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.extra = 1


class _WithSetter(GaussianState):
    level: float = Property(default=0.0)

    @level.setter
    def level(self, value):
        self._property_level = float(value)


@pytest.mark.parametrize("cls", [_OwnInit, _WithSetter])
def test_a_type_it_cannot_know_is_built_by_its_constructor(cls):
    assert builder(cls) is cls


def test_fresh_tags_are_new_version_4_uuids_as_stone_soup_makes_them():
    import uuid

    from fasttrack.stonesoup._objects import fresh_tags
    tags = fresh_tags(500)
    assert len(set(tags)) == 500 and fresh_tags(0) == []
    for tag in tags:
        parsed = uuid.UUID(tag)
        assert str(parsed) == tag and parsed.version == 4
        assert parsed.variant == uuid.uuid4().variant
