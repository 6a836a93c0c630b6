"""The drop-in ``PHDUpdater`` against Stone Soup's own on GM-PHD scans: the same
components (up to order and fresh tags), weights to 1e-9, and Stone Soup's code for what the
arrays do not cover."""
import datetime

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.hypothesiser.distance import DistanceHypothesiser
from stonesoup.hypothesiser.gaussianmixture import GaussianMixtureHypothesiser
from stonesoup.measures import Mahalanobis
from stonesoup.models.measurement.linear import LinearGaussian
from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                ConstantVelocity)
from stonesoup.predictor.kalman import KalmanPredictor
from stonesoup.types.detection import Detection
from stonesoup.types.state import TaggedWeightedGaussianState
from stonesoup.updater.kalman import KalmanUpdater
from stonesoup.updater import pointprocess

from fasttrack.stonesoup import LCCUpdater, PHDUpdater, fallbacks

Original = pointprocess.PHDUpdater

T0 = datetime.datetime(2025, 1, 1)
TRANSITION = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
SENSOR = LinearGaussian(4, (0, 2), np.diag([0.75, 0.75]))


def _hypotheses(seed, n=8, clutter=6):
    rng = np.random.default_rng(seed)
    x = np.c_[rng.uniform(-50, 50, n), rng.normal(0, 1, n), rng.uniform(-50, 50, n),
              rng.normal(0, 1, n)]
    components = {TaggedWeightedGaussianState(xi[:, None], np.diag([2.0, 0.5, 2.0, 0.5]),
                                              weight=rng.uniform(0.2, 1.0), timestamp=T0,
                                              tag=f"t{i}") for i, xi in enumerate(x)}
    components.add(TaggedWeightedGaussianState(np.zeros((4, 1)), np.diag([1e4, 2, 1e4, 2]),
                                                weight=0.25, timestamp=T0, tag="birth"))
    t1 = T0 + datetime.timedelta(seconds=1)
    z = np.vstack([x[:, [0, 2]] + x[:, [1, 3]] + rng.normal(0, 0.8, (n, 2)),
                   rng.uniform(-60, 60, (clutter, 2))])
    scan = {Detection(zi[:, None], timestamp=t1, measurement_model=SENSOR) for zi in z}
    hypothesiser = GaussianMixtureHypothesiser(DistanceHypothesiser(
        KalmanPredictor(TRANSITION), KalmanUpdater(SENSOR), Mahalanobis(),
        missed_distance=3), order_by_detection=True)
    return hypothesiser.hypothesise(components, scan, t1, order_by_detection=True)


def _key(c):
    return (round(float(c.weight), 12), tuple(np.round(c.state_vector.ravel(), 8)))


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("joseph", [False, True])
def test_the_drop_in_updates_as_stone_soup_does(seed, joseph):
    hypotheses = _hypotheses(seed)
    settings = dict(clutter_spatial_density=1e-3, prob_detection=0.9, prob_survival=0.99)
    fallbacks(clear=True)
    got = PHDUpdater(KalmanUpdater(SENSOR, use_joseph_cov=joseph), **settings).update(hypotheses)
    want = Original(KalmanUpdater(SENSOR, use_joseph_cov=joseph), **settings).update(hypotheses)
    assert not fallbacks()
    assert len(got) == len(want) and len(got) > 9
    for g, w in zip(sorted(got, key=_key), sorted(want, key=_key)):
        assert float(g.weight) == pytest.approx(float(w.weight), rel=1e-9)
        np.testing.assert_allclose(g.state_vector, w.state_vector, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(g.covar, w.covar, rtol=1e-9, atol=1e-9)
        assert g.timestamp == w.timestamp
        assert (g.tag == w.tag) or (g.tag != "birth" and len(g.tag) == 36)  # fresh uuids
    assert {c.tag for c in got if len(c.tag) < 36} == {c.tag for c in want if len(c.tag) < 36}


def test_another_updater_runs_stone_soups_code_and_says_why():
    class OwnUpdater(KalmanUpdater):
        """A user's updater: its own code may differ."""

    hypotheses = _hypotheses(1)
    fallbacks(clear=True)
    got = PHDUpdater(OwnUpdater(SENSOR), clutter_spatial_density=1e-3,
                     prob_detection=0.9).update(hypotheses)
    want = Original(OwnUpdater(SENSOR), clutter_spatial_density=1e-3,
                    prob_detection=0.9).update(hypotheses)
    assert len(got) == len(want) > 0
    assert [reason for (_, _, reason) in fallbacks()] == ["an updater of type OwnUpdater"]


def test_the_lcc_drop_in_keeps_stone_soups_cumulant_over_scans():
    settings = dict(clutter_spatial_density=1e-3, prob_detection=0.9, prob_survival=0.99,
                    mean_number_of_false_alarms=6, variance_of_false_alarms=8)
    mine = LCCUpdater(KalmanUpdater(SENSOR), **settings)
    theirs = pointprocess.LCCUpdater(KalmanUpdater(SENSOR), **settings)
    fallbacks(clear=True)
    for seed in (5, 6, 7):
        hypotheses = _hypotheses(seed)
        got, want = mine.update(hypotheses), theirs.update(hypotheses)
        np.testing.assert_allclose(sorted(float(c.weight) for c in got),
                                   sorted(float(c.weight) for c in want), rtol=1e-9)
        assert mine.second_order_cumulant == pytest.approx(theirs.second_order_cumulant,
                                                          rel=1e-9)
    assert not fallbacks()


def _scan_of(seed, n=8, clutter=6):
    rng = np.random.default_rng(seed)
    x = np.c_[rng.uniform(-50, 50, n), rng.normal(0, 1, n), rng.uniform(-50, 50, n),
              rng.normal(0, 1, n)]
    components = [TaggedWeightedGaussianState(xi[:, None], np.diag([2.0, 0.5, 2.0, 0.5]),
                                              weight=rng.uniform(0.2, 1.0), timestamp=T0,
                                              tag=f"t{i}") for i, xi in enumerate(x)]
    t1 = T0 + datetime.timedelta(seconds=1)
    z = np.vstack([x[:, [0, 2]] + x[:, [1, 3]] + rng.normal(0, 0.8, (n, 2)),
                   rng.uniform(-60, 60, (clutter, 2))])
    return components, {Detection(zi[:, None], timestamp=t1, measurement_model=SENSOR)
                        for zi in z}, t1


def _described(hypotheses):
    """Each MultipleHypothesis as (measurement id or None, distance) pairs, in order."""
    return [[(id(h.measurement) if h else None, round(float(h.distance), 10)) for h in multiple]
            for multiple in hypotheses]


@pytest.mark.parametrize("options", [dict(max_distance_covariance_multiplier=1),
                                     dict(max_distance=4.0),
                                     dict(number_of_neighbours=2),
                                     dict(number_of_neighbours=1, max_distance=3.0),
                                     dict()])
@pytest.mark.parametrize("order_by_detection", [False, True])
def test_the_kd_tree_drop_in_keeps_stone_soups_detections(options, order_by_detection):
    from stonesoup.hypothesiser import gaussianmixture as ss_gaussianmixture

    from fasttrack.stonesoup import (DistanceHypothesiser, GaussianMixtureKDTreeHypothesiser,
                                     KalmanPredictor, KalmanUpdater as FastKalmanUpdater,
                                     Mahalanobis as FastMahalanobis)
    components, scan, t1 = _scan_of(3)

    def made(module_classes):
        gm, distance, predictor_class, updater_class, measure = module_classes
        predictor, updater = predictor_class(TRANSITION), updater_class(SENSOR)
        return gm(DistanceHypothesiser(predictor, updater, measure(), missed_distance=10)
                  if gm is GaussianMixtureKDTreeHypothesiser else
                  distance(predictor, updater, measure(), missed_distance=10),
                  predictor=predictor, updater=updater, order_by_detection=order_by_detection,
                  **options)

    ours = made((GaussianMixtureKDTreeHypothesiser, None, KalmanPredictor, FastKalmanUpdater,
                 FastMahalanobis))
    theirs = made((ss_gaussianmixture.GaussianMixtureKDTreeHypothesiser, DistanceHypothesiser,
                   KalmanPredictor, KalmanUpdater, Mahalanobis))
    fallbacks(clear=True)
    got = ours.hypothesise(components, scan, t1)
    assert not fallbacks()
    want = theirs.hypothesise(components, scan, t1)
    assert _described(got) == _described(want)
    kept = sum(len(multiple) for multiple in got)
    assert len(components) < kept < len(components) * (len(scan) + 1)  # the tree filtered


def test_the_kd_tree_drop_in_with_another_predictor_runs_stone_soups_code():
    from fasttrack.stonesoup import (DistanceHypothesiser, GaussianMixtureKDTreeHypothesiser,
                                     KalmanPredictor, KalmanUpdater as FastKalmanUpdater)
    components, scan, t1 = _scan_of(4)
    updater = FastKalmanUpdater(SENSOR)
    inner = DistanceHypothesiser(KalmanPredictor(TRANSITION), updater, Mahalanobis(),
                                 missed_distance=10)
    hypothesiser = GaussianMixtureKDTreeHypothesiser(
        inner, predictor=KalmanPredictor(TRANSITION), updater=updater, max_distance=5.0)
    fallbacks(clear=True)
    got = hypothesiser.hypothesise(components, scan, t1)
    assert len(got) == len(components)
    assert [reason for (_, _, reason) in fallbacks()][0] == \
        "a kd-tree predictor or updater other than the hypothesiser's"


def _scans(seed, n=6, clutter=5, steps=10):
    """(time, detections) of ``n`` targets moving at constant velocity, with clutter."""
    rng = np.random.default_rng(seed)
    x = np.c_[rng.uniform(-40, 40, n), rng.normal(0, 1, n), rng.uniform(-40, 40, n),
              rng.normal(0, 1, n)]
    f = TRANSITION.matrix(time_interval=datetime.timedelta(seconds=1))
    out = []
    for k in range(1, steps + 1):
        x = x @ f.T
        time = T0 + datetime.timedelta(seconds=k)
        z = np.vstack([x[:, [0, 2]] + rng.normal(0, 0.8, (n, 2)),
                       rng.uniform(-60, 60, (clutter, 2))])
        out.append((time, {Detection(zi[:, None], timestamp=time, measurement_model=SENSOR)
                           for zi in z}))
    return out


def _flat(mixture):
    """A mixture's weights and states, sorted, as rows."""
    return [(weight, *state) for weight, state in sorted(map(_key, mixture))]


def test_the_drop_in_point_process_tracker_tracks_as_stone_soups():
    """Stone Soup's GM-PHD tracker with its own components, and the drop-in tracker with
    the drop-ins: the same mixture each step (weights and states to 1e-9, up to order and
    fresh tags) and tracks of the same lengths, without a fallback."""
    from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer
    from stonesoup.tracker.pointprocess import PointProcessMultiTargetTracker

    import fasttrack.stonesoup as fss

    def tracker(kind, hypothesiser, distance, reducer, updater, kalman_predictor,
                kalman_updater, measure):
        return kind(
            detector=_scans(5),
            hypothesiser=hypothesiser(distance(kalman_predictor(TRANSITION),
                                               kalman_updater(SENSOR), measure(),
                                               missed_distance=3), order_by_detection=True),
            updater=updater(kalman_updater(SENSOR), clutter_spatial_density=3e-4,
                            prob_detection=0.9, prob_survival=0.99),
            reducer=reducer(prune_threshold=1e-6, merge_threshold=4),
            birth_component=TaggedWeightedGaussianState(
                np.zeros((4, 1)), np.diag([1e3, 2.0, 1e3, 2.0]), weight=0.3, tag="birth",
                timestamp=T0),
            extraction_threshold=0.5)

    theirs = tracker(PointProcessMultiTargetTracker, GaussianMixtureHypothesiser,
                     DistanceHypothesiser, GaussianMixtureReducer, Original, KalmanPredictor,
                     KalmanUpdater, Mahalanobis)
    ours = tracker(fss.PointProcessMultiTargetTracker, fss.GaussianMixtureHypothesiser,
                   fss.DistanceHypothesiser, fss.GaussianMixtureReducer, PHDUpdater,
                   fss.KalmanPredictor, fss.KalmanUpdater, fss.Mahalanobis)
    fallbacks(clear=True)
    for (time, want), (_, got) in zip(theirs, ours):
        np.testing.assert_allclose(_flat(ours.gaussian_mixture), _flat(theirs.gaussian_mixture),
                                   rtol=1e-9, atol=1e-9)
        assert sorted(map(len, got)) == sorted(map(len, want))
        assert ours.estimated_number_of_targets == pytest.approx(
            theirs.estimated_number_of_targets, rel=1e-9)
        assert len(ours.extracted_target_states) == len(theirs.extracted_target_states)
    assert time == T0 + datetime.timedelta(seconds=10) and len(got) >= 4
    assert fallbacks() == {}


def _drop_in_hypotheses(seed):
    """The drop-in hypothesiser's groups of :func:`_scan_of`'s scan, with a birth component."""
    import fasttrack.stonesoup as fss
    components, scan, t1 = _scan_of(seed)
    components.append(TaggedWeightedGaussianState(np.zeros((4, 1)), np.diag([1e4, 2, 1e4, 2]),
                                                  weight=0.25, timestamp=T0, tag="birth"))
    hypothesiser = fss.GaussianMixtureHypothesiser(fss.DistanceHypothesiser(
        fss.KalmanPredictor(TRANSITION), fss.KalmanUpdater(SENSOR), fss.Mahalanobis(),
        missed_distance=3), order_by_detection=True)
    return components, scan, hypothesiser.hypothesise(components, scan, t1), hypothesiser


def _built(hypotheses):
    return all("_property_single_hypotheses" in vars(group) for group in hypotheses)


@pytest.mark.parametrize("seed", range(3))
def test_the_drop_in_hypothesisers_groups_are_updated_from_its_arrays(seed):
    """The drop-in updater reads the drop-in hypothesiser's arrays (its hypotheses stay
    unbuilt) and gives what Stone Soup's updater gives on the hypotheses built afterwards."""
    _, _, hypotheses, _ = _drop_in_hypotheses(seed)
    settings = dict(clutter_spatial_density=1e-3, prob_detection=0.9, prob_survival=0.99)
    fallbacks(clear=True)
    got = PHDUpdater(KalmanUpdater(SENSOR), **settings).update(hypotheses)
    assert not fallbacks() and not _built(hypotheses)
    want = Original(KalmanUpdater(SENSOR), **settings).update(hypotheses)
    assert _built(hypotheses) and len(got) == len(want) > 9
    for g, w in zip(sorted(got, key=_key), sorted(want, key=_key)):
        assert float(g.weight) == pytest.approx(float(w.weight), rel=1e-12)
        np.testing.assert_allclose(g.state_vector, w.state_vector, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(g.covar, w.covar, rtol=1e-12, atol=1e-12)
        assert type(g) is type(w) and g.timestamp == w.timestamp
        assert g.tag == w.tag or len(g.tag) == len(w.tag) == 36  # fresh uuids
    again = PHDUpdater(KalmanUpdater(SENSOR), **settings).update(hypotheses)  # from objects
    assert sorted(map(_key, again)) == sorted(map(_key, got))


def test_a_detection_listed_twice_is_updated_as_stone_soup_updates_it():
    """The same Detection object twice in a scan: the drop-ins' arrays counted it once (12
    components against Stone Soup's 18) unless the groups were read first."""
    import fasttrack.stonesoup as fss
    components, scan, t1 = _scan_of(0, n=3, clutter=1)
    scan = [*scan, next(iter(scan))]
    settings = dict(clutter_spatial_density=1e-3, prob_detection=0.9, prob_survival=0.99)
    results = []
    fallbacks(clear=True)
    for hypothesiser, distance, predictor, kalman, updater in (
            (fss.GaussianMixtureHypothesiser, fss.DistanceHypothesiser, fss.KalmanPredictor,
             fss.KalmanUpdater, PHDUpdater),
            (GaussianMixtureHypothesiser, DistanceHypothesiser, KalmanPredictor, KalmanUpdater,
             Original)):
        groups = hypothesiser(distance(predictor(TRANSITION), kalman(SENSOR), Mahalanobis(),
                                       missed_distance=3),
                              order_by_detection=True).hypothesise(components, scan, t1)
        results.append(updater(kalman(SENSOR), **settings).update(groups))
    got, want = results
    assert len(got) == len(want) > 4
    assert sorted(map(_key, got)) == sorted(map(_key, want))
    assert "a detection given twice" in str(fallbacks())  # (Stone Soup's code scans it)



def _groups_of_both(components, scan, t1):
    """The drop-in hypothesiser's groups (unbuilt) and Stone Soup's, of the same scan."""
    import fasttrack.stonesoup as fss
    return [hypothesiser(distance(predictor(TRANSITION), kalman(SENSOR), Mahalanobis(),
                                  missed_distance=3),
                         order_by_detection=True).hypothesise(components, scan, t1)
            for hypothesiser, distance, predictor, kalman in (
                (fss.GaussianMixtureHypothesiser, fss.DistanceHypothesiser,
                 fss.KalmanPredictor, fss.KalmanUpdater),
                (GaussianMixtureHypothesiser, DistanceHypothesiser, KalmanPredictor,
                 KalmanUpdater))]


def test_a_detection_changed_after_hypothesising_is_read_when_updating():
    """Stone Soup's updater reads a detection's state vector when it updates; the drop-in's
    arrays held the value the hypothesiser read (a top weight of 0.62 against 0.57)."""
    components, scan, t1 = _scan_of(1, n=3, clutter=1)
    ours, theirs = _groups_of_both(components, scan, t1)
    for detection in scan:
        detection.state_vector[0, 0] += 3.0
    settings = dict(clutter_spatial_density=1e-3, prob_detection=0.9, prob_survival=0.99)
    got = PHDUpdater(KalmanUpdater(SENSOR), **settings).update(ours)
    want = Original(KalmanUpdater(SENSOR), **settings).update(theirs)
    assert len(got) == len(want) > 4
    assert sorted(map(_key, got)) == sorted(map(_key, want))
    whole = {Detection(np.round(d.state_vector).astype(int), timestamp=t1,
                       measurement_model=SENSOR) for d in scan}  # read as floats: unchanged
    ours, theirs = _groups_of_both(components, whole, t1)
    got = PHDUpdater(KalmanUpdater(SENSOR), **settings).update(ours)
    assert not _built(ours)  # (updated from the scan's arrays)
    want = Original(KalmanUpdater(SENSOR), **settings).update(theirs)
    assert sorted(map(_key, got)) == sorted(map(_key, want))


@pytest.mark.parametrize("updater, theirs", [(PHDUpdater, Original),
                                             (LCCUpdater, pointprocess.LCCUpdater)])
def test_a_weight_that_is_not_a_number_gets_stone_soups_error(updater, theirs):
    """A component weighing '0.5' (a string): Stone Soup's arithmetic raises; the drop-in
    read it as 0.5 and returned a mixture."""
    components, scan, t1 = _scan_of(0, n=3, clutter=1)
    components[0].weight = "0.5"
    settings = dict(clutter_spatial_density=1e-3, prob_detection=0.9, prob_survival=0.99)
    for groups, kind in zip(_groups_of_both(components, scan, t1), (updater, theirs)):
        with pytest.raises(TypeError, match="can't multiply sequence"):
            kind(KalmanUpdater(SENSOR), **settings).update(groups)


def test_the_drop_in_tracker_counts_no_targets_without_a_mixture():
    """``gaussian_mixture = None`` (or empty): Stone Soup's tracker estimates 0 targets; the
    drop-in raised TypeError."""
    import fasttrack.stonesoup as fss
    tracker = fss.PointProcessMultiTargetTracker(detector=None, hypothesiser=None,
                                                 updater=None, reducer=None)
    assert tracker.estimated_number_of_targets == 0
    tracker.gaussian_mixture = None
    assert tracker.estimated_number_of_targets == 0

@pytest.mark.parametrize("joseph", [False, True])
@pytest.mark.parametrize("drop_in_hypothesiser", [True, False])
def test_an_updater_of_another_measurement_model_weighs_by_its_own(joseph,
                                                                   drop_in_hypothesiser):
    """Detections without a model of their own: the hypothesiser predicts them with its
    updater's model, the PHD updater weighs them by its own and updates from the
    hypotheses' measurement predictions (the Joseph form with its own H and R), as Stone
    Soup's does."""
    import fasttrack.stonesoup as fss
    components, scan, t1 = _scan_of(1)
    scan = {Detection(d.state_vector, timestamp=t1) for d in scan}
    classes = [GaussianMixtureHypothesiser, DistanceHypothesiser, KalmanPredictor,
               KalmanUpdater, Mahalanobis]
    if drop_in_hypothesiser:
        classes = [getattr(fss, cls.__name__) for cls in classes]
    mixture, distance, predictor, updater, measure = classes
    hypothesiser = mixture(distance(predictor(TRANSITION), updater(SENSOR), measure(),
                                    missed_distance=3), order_by_detection=True)
    hypotheses = hypothesiser.hypothesise(components, scan, t1)
    other = LinearGaussian(4, (0, 2), np.diag([3.0, 2.0]))
    settings = dict(clutter_spatial_density=1e-3, prob_detection=0.9, prob_survival=0.99)
    fallbacks(clear=True)
    got = PHDUpdater(KalmanUpdater(other, use_joseph_cov=joseph), **settings).update(
        hypotheses)
    assert not fallbacks() and _built(hypotheses) != drop_in_hypothesiser
    want = Original(KalmanUpdater(other, use_joseph_cov=joseph), **settings).update(
        hypotheses)
    assert len(got) == len(want) > len(components)
    for g, w in zip(sorted(got, key=_key), sorted(want, key=_key)):
        assert float(g.weight) == pytest.approx(float(w.weight), rel=1e-12)
        np.testing.assert_allclose(g.state_vector, w.state_vector, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(g.covar, w.covar, rtol=1e-12, atol=1e-12)


def test_unbuilt_groups_hold_the_components_as_they_were():
    """Groups built after the components changed show the weights and tags the components
    had when hypothesised, as Stone Soup's (built at once) do; a copy or pickle of a group
    holds the built hypotheses."""
    import copy
    import pickle

    components, scan, hypotheses, hypothesiser = _drop_in_hypotheses(0)
    weights = {id(c): c.weight for c in components}
    tags = {id(c): c.tag for c in components}
    for c in components:
        c.weight, c.tag = 7.0, "changed"
    copied = copy.deepcopy(hypotheses[-1])
    assert _built(hypotheses) and len(copied) == len(components)
    missed = [h.prediction for h in hypotheses[-1]]
    assert sorted(p.weight for p in missed) == sorted(weights.values())
    assert {p.tag for p in missed} == set(tags.values())
    assert [h.prediction.weight for h in copied] == [p.weight for p in missed]
    assert len(pickle.loads(pickle.dumps(hypotheses[0]))) == len(hypotheses[0])
    assert len(hypotheses) == len(scan) + 1
    assert sum(len(group) for group in hypotheses) > len(components)


def _state_key(c):
    return tuple(np.round(c.state_vector.ravel(), 8))


@pytest.mark.parametrize("seed", range(3))
def test_the_drop_in_reducer_reduces_the_updates_arrays(seed):
    """The drop-in update of the drop-in hypothesiser's groups holds its components as
    arrays; the drop-in reducer reduces them, building only the components it returns
    unmerged, with Stone Soup's result, and leaves the update's components (read afterwards)
    as Stone Soup's reducer leaves its input."""
    import copy
    import pickle

    from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer as SSReducer
    from stonesoup.types.update import GaussianMixtureUpdate

    from fasttrack.stonesoup import GaussianMixtureReducer
    from fasttrack.stonesoup._pending import PendingMixtureUpdate

    _, _, hypotheses, _ = _drop_in_hypotheses(seed)
    updater = PHDUpdater(KalmanUpdater(SENSOR), clutter_spatial_density=1e-3,
                         prob_detection=0.9, prob_survival=0.99)
    mine, theirs = updater.update(hypotheses), list(updater.update(hypotheses))
    assert type(mine) is PendingMixtureUpdate
    settings = dict(prune_threshold=1e-4, merge_threshold=9)
    fallbacks(clear=True)
    got = GaussianMixtureReducer(**settings).reduce(mine)
    assert not fallbacks() and type(mine) is PendingMixtureUpdate  # its list not built
    want = SSReducer(**settings).reduce(theirs)
    assert len(got) == len(want)
    for g, w in zip(sorted(got, key=_key), sorted(want, key=_key)):
        assert type(g) is type(w) and g.timestamp == w.timestamp
        assert float(g.weight) == pytest.approx(float(w.weight), rel=1e-9)
        np.testing.assert_allclose(g.state_vector, w.state_vector, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(g.covar, w.covar, rtol=1e-9, atol=1e-9)
    assert len({c.tag for c in got}) == len(got)
    built = list(mine)
    assert type(mine) is GaussianMixtureUpdate and len(built) == len(theirs)
    for b, t in zip(sorted(built, key=_state_key), sorted(theirs, key=_state_key)):
        assert float(b.weight) == pytest.approx(float(t.weight), rel=1e-9)
    unmerged = [c for c in got if any(c is b for b in built)]
    assert 0 < len(unmerged) < len(got)
    again = updater.update(hypotheses)
    copied = copy.copy(again)
    assert type(copied) is type(again) is GaussianMixtureUpdate
    assert copied.components == again.components and copied.components is not again.components
    assert len(pickle.loads(pickle.dumps(updater.update(hypotheses)))) == len(built)


def test_an_indefinite_innovation_covariance_goes_to_stone_soups_code():
    """An indefinite component makes an innovation covariance Stone Soup's likelihood
    refuses: the drop-in runs Stone Soup's code (which raises) instead of weighing it."""
    t1 = T0 + datetime.timedelta(seconds=1)
    components = [TaggedWeightedGaussianState(np.array([[0.0], [1], [0], [1]]), -np.eye(4),
                                              weight=0.8, timestamp=T0, tag="a"),
                  TaggedWeightedGaussianState(np.zeros((4, 1)), np.diag([1e4, 2, 1e4, 2]),
                                              weight=0.25, timestamp=T0, tag="birth")]
    scan = {Detection(np.array([[1.0], [1.0]]), timestamp=t1, measurement_model=SENSOR)}
    hypotheses = GaussianMixtureHypothesiser(DistanceHypothesiser(
        KalmanPredictor(TRANSITION), KalmanUpdater(SENSOR), Mahalanobis(), missed_distance=3),
        order_by_detection=True).hypothesise(components, scan, t1, order_by_detection=True)
    fallbacks(clear=True)
    for updater in (PHDUpdater, Original):
        with pytest.raises(ValueError, match="must be symmetric positive semidefinite"):
            updater(KalmanUpdater(SENSOR), clutter_spatial_density=1e-3,
                    prob_detection=0.9).update(hypotheses)
    assert [reason for (_, _, reason) in fallbacks()] == [
        "an innovation covariance that is not positive definite"]
    for updater in (PHDUpdater, Original):  # no hypotheses at all: Stone Soup's IndexError
        with pytest.raises(IndexError):
            updater(KalmanUpdater(SENSOR), clutter_spatial_density=1e-3).update([])


def test_the_drop_in_reducer_names_stone_soups_cap():
    from fasttrack.stonesoup import GaussianMixtureReducer
    component = TaggedWeightedGaussianState(np.zeros((4, 1)), np.eye(4), weight=0.8,
                                            timestamp=T0, tag="a")
    with pytest.raises(ValueError, match="max_number_components must be >= 1, got 0"):
        GaussianMixtureReducer(max_number_components=0).reduce([component] * 2)


@pytest.mark.parametrize("updater", [PHDUpdater, LCCUpdater])
@pytest.mark.parametrize("name, value, match", [
    ("prob_detection", 1.5, "prob_detection must be a probability in"),
    ("prob_survival", float("nan"), "prob_survival must be a probability in"),
    ("clutter_spatial_density", -1e-3, "clutter_spatial_density must be finite and >= 0"),
    ("clutter_spatial_density", float("inf"), "clutter_spatial_density must be finite")])
def test_a_probability_outside_0_1_or_a_negative_clutter_density_is_named(updater, name, value,
                                                                          match):
    """Stone Soup weighs with them (negative or NaN weights); the drop-ins' reducer then
    failed naming its own arrays. Set at construction or later, they are named at update."""
    hypotheses = _hypotheses(0)
    settings = dict(clutter_spatial_density=1e-3, prob_detection=0.9, prob_survival=0.99)
    with pytest.raises(ValueError, match=match):
        updater(KalmanUpdater(SENSOR), **{**settings, name: value}).update(hypotheses)
    later = updater(KalmanUpdater(SENSOR), **settings)
    setattr(later, name, value)
    with pytest.raises(ValueError, match=match):
        later.update(hypotheses)
