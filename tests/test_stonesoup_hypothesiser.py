"""fasttrack.stonesoup.hypothesiser: the drop-in hypothesisers give Stone Soup's hypotheses
and share the predictor's memo, the objects they build follow Stone Soup's property orders,
the updater uses the measurement prediction a hypothesis carries, and Stone Soup's GM-PHD
tutorial tracks the same with the drop-in hypothesiser."""
import re

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.types.angle import Bearing  # noqa: E402
from stonesoup.types.array import StateVector  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.hypothesis import (SingleDistanceHypothesis,  # noqa: E402
                                        SingleProbabilityHypothesis)
from stonesoup.types.numeric import Probability  # noqa: E402
from stonesoup.types.prediction import GaussianMeasurementPrediction  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.updater import kalman as ss_kalman_updater  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402
from test_stonesoup_dataassociator import (  # noqa: E402
    DT, POLAR, PRIOR_COVAR, SENSOR, T0, TRANSITION, TUTORIALS, assert_close,
    assert_same_multiple, base_of, hypothesiser, no_stone_soup_association, scenario)


def test_hypothesisers_equal_stone_soup_and_share_the_memoised_predictions():
    tracks, detections = scenario(10, spacing=6.0, seed=10, clutter=1.0)
    for kind, options in [("distance", {"missed_distance": 3}),
                          ("distance", {"missed_distance": 3, "include_all": True}),
                          ("distance", {"missed_distance": 10, "gate": 2.0}),
                          ("distance", {"missed_distance": 1e300}),  # (squares overflow)
                          ("distance", {"missed_distance": 1e300, "gate": 1e200}),
                          ("pda", {"clutter_spatial_density": 1e-2}),
                          ("pda", {"normalise": False}),
                          ("pda", {"clutter_spatial_density": 1e-2, "gate": 2.0})]:
        ours, theirs = hypothesiser("ft", kind, **options), hypothesiser("ss", kind, **options)
        for track in tracks:
            with no_stone_soup_association():
                a = ours.hypothesise(track, detections, T0 + DT)
            b = theirs.hypothesise(track, detections, T0 + DT)
            assert_same_multiple(a, b)
            predictor = base_of(ours).predictor
            assert a[0].prediction is predictor.predict(track, timestamp=T0 + DT)


def test_updater_uses_the_measurement_prediction_on_the_hypothesis():
    """As Stone Soup: the given measurement prediction (here a deliberately different one)
    is used, not recomputed; also with the Joseph form and symmetrisation, and bearings."""
    tracks, detections = scenario(5, seed=13)
    prediction = fss.KalmanPredictor(TRANSITION).predict(tracks[0], timestamp=T0 + DT)
    detection = next(iter(detections))
    rng = np.random.default_rng(0)
    given = GaussianMeasurementPrediction(
        StateVector(rng.normal(size=(2, 1))), np.array([[3.0, 0.4], [0.4, 2.0]]),
        timestamp=T0 + DT, cross_covar=rng.normal(size=(4, 2)))
    for options in [{}, {"use_joseph_cov": True}, {"force_symmetric_covariance": True}]:
        hypothesis = SingleProbabilityHypothesis(prediction, detection, Probability(0.5),
                                                 measurement_prediction=given)
        with no_stone_soup_association():
            ours = fss.KalmanUpdater(SENSOR, **options).update(hypothesis)
        theirs = ss_kalman_updater.KalmanUpdater(SENSOR, **options).update(hypothesis)
        assert hypothesis.measurement_prediction is given
        assert_close(ours.state_vector, theirs.state_vector)
        assert_close(ours.covar, theirs.covar)
    prediction = fss.ExtendedKalmanPredictor(TRANSITION).predict(
        GaussianState([[0], [1], [0], [1]], PRIOR_COVAR, timestamp=T0), timestamp=T0 + DT)
    near_pi = Detection(StateVector([[-np.pi + 0.01], [250.0]]), timestamp=T0 + DT,
                        measurement_model=POLAR)
    given = GaussianMeasurementPrediction(StateVector([[Bearing(np.pi - 0.01)], [249.0]]),
                                          np.diag([0.01, 2.0]), timestamp=T0 + DT,
                                          cross_covar=rng.normal(size=(4, 2)))
    hypothesis = SingleDistanceHypothesis(prediction, near_pi, 1.0, given)
    with no_stone_soup_association():
        ours = fss.ExtendedKalmanUpdater(POLAR).update(hypothesis)
    theirs = ss_kalman_updater.ExtendedKalmanUpdater(POLAR).update(hypothesis)
    assert_close(ours.state_vector, theirs.state_vector)  # the innovation wrapped to 0.02
    assert_close(ours.covar, theirs.covar)


def test_gm_phd_tutorial_tracks_the_same_with_the_drop_ins():
    """Stone Soup's GM-PHD tutorial: its scenario once (it draws in set-iteration order, so
    two runs differ whatever the seed), then its tracking with Stone Soup's Kalman
    predictor, updater, hypothesiser, measure, PHD updater and reducer, and with the
    drop-ins."""
    source = (TUTORIALS / "010_gm_phd_filter.txt").read_text()
    split = source.index("from stonesoup.updater.kalman import KalmanUpdater")
    end = source.index("\nfor track in tracks:\n    for state in track:")  # then plots
    scenario, tracking = source[:split], source[split:end]
    switched, count = re.subn(r"^from stonesoup\.(?:updater\.kalman|predictor\.kalman"
                              r"|hypothesiser\.distance|measures|updater\.pointprocess"
                              r"|mixturereducer\.gaussianmixture|hypothesiser\.gaussianmixture)"
                              r" import ", "from fasttrack.stonesoup import ", tracking,
                              flags=re.M)
    assert count == 7
    np.random.seed(3)
    world = {"__name__": "__main__"}
    exec(compile(scenario, "GM-PHD scenario", "exec"), world)
    runs = {}
    for name, text in (("stonesoup", tracking), ("fasttrack", switched)):
        runs[name] = dict(world)
        fss.fallbacks(clear=True)
        exec(compile(text, f"GM-PHD tracking ({name})", "exec"), runs[name])
    assert fss.fallbacks() == {}  # the tagged, weighted components take the fast path
    assert type(runs["fasttrack"]["hypothesiser"].hypothesiser).__module__ \
        == "fasttrack.stonesoup.hypothesiser"
    states = {name: sorted((*np.ravel(s.state_vector), float(getattr(s, "weight", 1.0)))
                           for t in run["tracks"] for s in t)
              for name, run in runs.items()}
    assert len(states["fasttrack"]) == len(states["stonesoup"]) > 20
    np.testing.assert_allclose(states["fasttrack"], states["stonesoup"], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("tagged", [True, False])
def test_gaussian_mixture_predictions_are_stone_soups(tagged):
    import datetime

    from stonesoup.hypothesiser.distance import DistanceHypothesiser as SSDistance
    from stonesoup.hypothesiser.gaussianmixture import GaussianMixtureHypothesiser as SSMixture
    from stonesoup.measures import Mahalanobis as SSMahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor as SSPredictor
    from stonesoup.types.state import TaggedWeightedGaussianState, WeightedGaussianState
    t0 = datetime.datetime(2025, 1, 1)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = LinearGaussian(4, (0, 2), np.eye(2))
    rng = np.random.default_rng(1)
    components = []
    for i, x in enumerate(rng.uniform(-20, 20, (5, 4))):
        state = dict(state_vector=x[:, None], covar=np.eye(4) * 3, weight=0.1 * (i + 1),
                     timestamp=t0)
        components.append(TaggedWeightedGaussianState(**state, tag="birth" if i == 0 else
                                                      f"t{i}") if tagged
                          else WeightedGaussianState(**state))
    t1 = t0 + datetime.timedelta(seconds=1)
    scan = {Detection(z[:, None], timestamp=t1, measurement_model=sensor)
            for z in np.vstack([c.state_vector[[0, 2], 0] for c in components]) + 0.5}
    made = {}
    for name, (predictor, distance, mixture, measure) in {
            "ft": (fss.KalmanPredictor, fss.DistanceHypothesiser,
                   fss.GaussianMixtureHypothesiser, fss.Mahalanobis),
            "ss": (SSPredictor, SSDistance, SSMixture, SSMahalanobis)}.items():
        hypothesiser = mixture(distance(predictor(transition),
                                        fss.KalmanUpdater(sensor) if name == "ft"
                                        else ss_kalman_updater.KalmanUpdater(sensor),
                                        measure(), missed_distance=5), order_by_detection=True)
        made[name] = hypothesiser.hypothesise(components, scan, t1)
    pairs = [(a, b) for ma, mb in zip(made["ft"], made["ss"]) for a, b in zip(ma, mb)]
    assert len(pairs) > len(components)
    for a, b in pairs:
        pa, pb = a.prediction, b.prediction
        assert type(pa) is type(pb) and pa.timestamp == pb.timestamp
        assert pa.weight == pb.weight and pa.transition_model is pb.transition_model is None
        np.testing.assert_allclose(pa.state_vector, pb.state_vector, rtol=1e-12)
        np.testing.assert_allclose(pa.covar, pb.covar, rtol=1e-12)
        if tagged:
            assert pa.tag == pb.tag or (len(pa.tag) == len(pb.tag) == 36)  # fresh uuids
