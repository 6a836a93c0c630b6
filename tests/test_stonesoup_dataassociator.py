"""fasttrack.stonesoup.dataassociator: parity with Stone Soup on multi-target scans (same
associations, probabilities and updated states), the vectorised path taken without Stone
Soup's code, Stone Soup's own data-association, hypothesiser and gater tests run on the
drop-ins, and Stone Soup's data-association tutorials run both ways."""
import ast
import contextlib
import datetime
import importlib
import os
import pathlib
import re
import subprocess
import sys
from unittest import mock

import numpy as np
import pytest

pytest.importorskip("stonesoup")
import matplotlib  # noqa: E402

matplotlib.use("Agg")

from stonesoup import measures as ss_measures  # noqa: E402
from stonesoup.dataassociator import base as ss_associator_base  # noqa: E402
from stonesoup.dataassociator import neighbour as ss_neighbour  # noqa: E402
from stonesoup.dataassociator import probability as ss_probability  # noqa: E402
from stonesoup.gater import distance as ss_gater  # noqa: E402
from stonesoup.hypothesiser import distance as ss_distance  # noqa: E402
from stonesoup.hypothesiser import probability as ss_hypothesiser_probability  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.measurement.nonlinear import CartesianToBearingRange  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor import kalman as ss_kalman_predictor  # noqa: E402
from stonesoup.types.angle import Bearing  # noqa: E402
from stonesoup.types.array import StateVector  # noqa: E402
from stonesoup.types.detection import Clutter, Detection, MissedDetection  # noqa: E402
from stonesoup.types.hypothesis import (DistanceJointHypothesis,  # noqa: E402
                                        SingleDistanceHypothesis)
from stonesoup.types.multihypothesis import MultipleHypothesis  # noqa: E402
from stonesoup.types.numeric import Probability  # noqa: E402
from stonesoup.types.prediction import (GaussianMeasurementPrediction,  # noqa: E402
                                        GaussianStatePrediction)
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402
from stonesoup.updater import kalman as ss_kalman_updater  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402
from fasttrack.stonesoup import _scan as scan_engine  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parent / "data"
REPO = pathlib.Path(__file__).resolve().parents[1]
T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)
TRANSITION = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05),
                                                    ConstantVelocity(0.05)])
SENSOR = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
POLAR = CartesianToBearingRange(ndim_state=4, mapping=(0, 2),
                                noise_covar=np.diag([np.radians(0.5) ** 2, 1.0]),
                                translation_offset=np.array([[-200.0], [-150.0]]))
PRIOR_COVAR = np.diag([1.0, 0.1, 1.0, 0.1])


# -- scenarios ----------------------------------------------------------------------------------

def scenario(n, spacing=20.0, seed=0, clutter=0.5, p_detect=0.9, stale=0.2, sensor=SENSOR):
    """``n`` targets on a jittered grid ``spacing`` apart (as the baseline's ``scenario``),
    a track per target whose last state is at T0 (a fraction ``stale`` of them at T0 - 1 s),
    each target detected at T0 + 1 s with probability ``p_detect``, and ``clutter * n``
    clutter points spread uniformly over the scene: ``(tracks, detections)``."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n)))
    gx, gy = np.meshgrid(np.arange(side), np.arange(side))
    position = np.c_[gx.ravel(), gy.ravel()][:n] * spacing + rng.normal(0, 1, (n, 2))
    velocity = rng.normal(0, 1, (n, 2))
    ages = np.where(rng.random(n) < stale, 2.0, 1.0)
    tracks = []
    for p, v, age in zip(position, velocity, ages):
        start = p - v * (age - 1)
        tracks.append(Track([GaussianState([[start[0]], [v[0]], [start[1]], [v[1]]],
                                           PRIOR_COVAR, timestamp=T0 + DT - age * DT)]))
    truth = position + velocity + rng.normal(0, 0.2, (n, 2))
    detected = rng.random(n) < p_detect
    lo, hi = position.min(0) - spacing, position.max(0) + spacing
    scatter = rng.uniform(lo, hi, (int(round(clutter * n)), 2))
    if sensor is SENSOR:
        points = truth[detected] + rng.normal(0, 1, (detected.sum(), 2))
        vectors = [p.reshape(2, 1) for p in points]
        clutter_vectors = [p.reshape(2, 1) for p in scatter]
    else:
        def polar(xy):
            dx, dy = xy[:, 0] + 200.0, xy[:, 1] + 150.0
            return np.c_[np.arctan2(dy, dx), np.hypot(dx, dy)]
        points = polar(truth[detected]) + rng.normal(0, 1, (detected.sum(), 2)) \
            * [np.radians(0.5), 1.0]
        vectors = [StateVector([[Bearing(b)], [r]]) for b, r in points]
        clutter_vectors = [StateVector([[Bearing(b)], [r]]) for b, r in polar(scatter)]
    detections = {Detection(z, timestamp=T0 + DT, measurement_model=sensor) for z in vectors}
    detections |= {Clutter(z, timestamp=T0 + DT, measurement_model=sensor)
                   for z in clutter_vectors}
    return tracks, detections


def hypothesiser(implementation, kind="distance", sensor=SENSOR, extended=False, gate=None,
                 measure=None, **properties):
    """A Stone Soup ('ss') or drop-in ('ft') hypothesiser of ``kind`` 'distance' or 'pda',
    optionally wrapped in a ``DistanceGater`` (Mahalanobis, threshold ``gate``)."""
    ft = implementation == "ft"
    if extended:
        predictor = (fss.ExtendedKalmanPredictor if ft
                     else ss_kalman_predictor.ExtendedKalmanPredictor)(TRANSITION)
        updater = (fss.ExtendedKalmanUpdater if ft
                   else ss_kalman_updater.ExtendedKalmanUpdater)(sensor)
    else:
        predictor = (fss.KalmanPredictor if ft else ss_kalman_predictor.KalmanPredictor)(
            TRANSITION)
        updater = (fss.KalmanUpdater if ft else ss_kalman_updater.KalmanUpdater)(sensor)
    if kind == "distance":
        measure = measure or (fss.Mahalanobis() if ft else ss_measures.Mahalanobis())
        result = (fss.DistanceHypothesiser if ft else ss_distance.DistanceHypothesiser)(
            predictor, updater, measure, **properties)
    else:
        result = (fss.PDAHypothesiser if ft else ss_hypothesiser_probability.PDAHypothesiser)(
            predictor, updater, **properties)
    if gate is not None:
        result = (fss.DistanceGater if ft else ss_gater.DistanceGater)(
            result, measure=fss.Mahalanobis() if ft else ss_measures.Mahalanobis(),
            gate_threshold=gate)
    return result


def base_of(hypothesiser):
    while hasattr(hypothesiser, "gate_threshold"):
        hypothesiser = hypothesiser.hypothesiser
    return hypothesiser


@contextlib.contextmanager
def no_stone_soup_association():
    """Stone Soup's own association, hypothesising and Kalman update code raise inside."""
    def forbidden(*args, **kwargs):
        raise AssertionError("Stone Soup's code ran")
    targets = [(ss_neighbour.NearestNeighbour, "associate"),
               (ss_neighbour.GlobalNearestNeighbour, "associate"),
               (ss_neighbour.GNNWith2DAssignment, "associate"),
               (ss_probability.PDA, "associate"), (ss_probability.JPDA, "associate"),
               (ss_probability.JPDAwithEHM, "associate"),
               (ss_associator_base.DataAssociator, "generate_hypotheses"),
               (ss_distance.DistanceHypothesiser, "hypothesise"),
               (ss_hypothesiser_probability.PDAHypothesiser, "hypothesise"),
               (ss_gater.DistanceGater, "hypothesise"),
               (ss_kalman_updater.KalmanUpdater, "update"),
               (ss_kalman_updater.KalmanUpdater, "predict_measurement"),
               (ss_kalman_updater.ExtendedKalmanUpdater, "predict_measurement")]
    with contextlib.ExitStack() as stack:
        for owner, name in targets:
            stack.enter_context(mock.patch.object(owner, name, forbidden))
        yield


# -- comparisons --------------------------------------------------------------------------------

def assert_close(ours, theirs, rtol=1e-9, what=""):
    ours, theirs = np.asarray(ours, dtype=float), np.asarray(theirs, dtype=float)
    assert ours.shape == theirs.shape, what
    scale = max(1.0, float(np.abs(theirs).max(initial=0.0)))
    assert np.abs(ours - theirs).max(initial=0.0) <= rtol * scale, what


def assert_same_hypothesis(ours, theirs, rtol=1e-9):
    """Same type, detection (the very object, or both missed), prediction, measurement
    prediction and score."""
    assert type(ours) is type(theirs)
    if theirs:
        assert ours.measurement is theirs.measurement
    else:
        assert type(ours.measurement) is MissedDetection and not ours
        assert ours.measurement.timestamp == theirs.measurement.timestamp
    for a, b in [(ours.prediction, theirs.prediction)]:
        assert type(a) is type(b) is GaussianStatePrediction
        assert a.timestamp == b.timestamp and a.prior is b.prior
        assert a.transition_model is not None
        assert_close(a.state_vector, b.state_vector, rtol, "prediction")
        assert_close(a.covar, b.covar, rtol, "prediction covar")
    a, b = ours.measurement_prediction, theirs.measurement_prediction
    assert (a is None) == (b is None)
    if b is not None:
        assert type(a) is type(b) is GaussianMeasurementPrediction
        assert a.timestamp == b.timestamp
        assert [type(e) for e in a.state_vector.ravel()] == \
            [type(e) for e in b.state_vector.ravel()]
        assert_close(a.state_vector, b.state_vector, rtol, "measurement prediction")
        assert_close(a.covar, b.covar, rtol, "innovation covariance")
        assert_close(a.cross_covar, b.cross_covar, rtol, "cross covariance")
    if isinstance(theirs, SingleDistanceHypothesis):
        assert ours.distance == pytest.approx(theirs.distance, rel=rtol, abs=rtol)
    else:
        assert isinstance(ours.probability, Probability)
        assert float(ours.probability) == pytest.approx(float(theirs.probability), rel=rtol,
                                                        abs=1e-9)


def assert_same_multiple(ours, theirs, rtol=1e-9):
    """The same hypotheses in the same order."""
    assert type(ours) is type(theirs) is MultipleHypothesis
    assert len(ours) == len(theirs)
    assert ours.normalise == theirs.normalise
    for a, b in zip(ours, theirs):
        assert_same_hypothesis(a, b, rtol)


def assert_same_updates(ours, theirs, ft_updater, ss_updater, rtol=1e-9):
    """The drop-in updater on our hypotheses and Stone Soup's on its own agree."""
    for track in theirs:
        ours_h, theirs_h = ours[track], theirs[track]
        pairs = zip(ours_h, theirs_h) if isinstance(theirs_h, MultipleHypothesis) \
            else [(ours_h, theirs_h)]
        for a, b in pairs:
            if not b:
                continue
            with no_stone_soup_association():
                ours_update = ft_updater.update(a)
            theirs_update = ss_updater.update(b)
            assert type(ours_update) is type(theirs_update)
            assert ours_update.hypothesis is a and ours_update.timestamp == b.measurement.timestamp
            assert_close(ours_update.state_vector, theirs_update.state_vector, rtol, "update")
            assert_close(ours_update.covar, theirs_update.covar, rtol, "update covar")


def associate_both(associator, kind, tracks, detections, fast=True, rtol=1e-9, **options):
    """Run Stone Soup's ``associator`` and the drop-in of the same name on the same inputs;
    check the results are equal and return ``(ours, theirs)``."""
    ss_class = getattr(ss_neighbour, associator, None) or getattr(ss_probability, associator)
    ours_hypothesiser = hypothesiser("ft", kind, **options)
    theirs_hypothesiser = hypothesiser("ss", kind, **options)
    theirs = ss_class(theirs_hypothesiser).associate(tracks, detections, T0 + DT)
    guard = no_stone_soup_association() if fast else contextlib.nullcontext()
    with guard:
        ours = getattr(fss, associator)(ours_hypothesiser).associate(tracks, detections,
                                                                     T0 + DT)
    assert type(ours) is type(theirs)
    assert set(ours) == set(theirs)
    for track in theirs:
        if isinstance(theirs[track], MultipleHypothesis):
            assert_same_multiple(ours[track], theirs[track], rtol)
        else:
            assert_same_hypothesis(ours[track], theirs[track], rtol)
    assert_same_updates(ours, theirs, base_of(ours_hypothesiser).updater,
                        base_of(theirs_hypothesiser).updater, rtol)
    return ours, theirs


# -- (1) parity on multi-target scans -----------------------------------------------------------

@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("associator", ["GNNWith2DAssignment", "NearestNeighbour"])
def test_neighbour_associators_equal_stone_soup_on_100_tracks(associator, seed):
    tracks, detections = scenario(100, seed=seed)
    for missed_distance in (3, 12):
        ours, _ = associate_both(associator, "distance", tracks, detections,
                                 missed_distance=missed_distance)
        detected = sum(bool(h) for h in ours.values())
        assert 60 < detected < 100  # missed detections and clutter both occur


def test_include_all_and_the_infinite_default_missed_distance():
    tracks, detections = scenario(40, seed=2, p_detect=1.0, clutter=0.5)
    associate_both("GNNWith2DAssignment", "distance", tracks, detections)  # inf, feasible
    associate_both("NearestNeighbour", "distance", tracks, detections, missed_distance=3,
                   include_all=True)
    tracks, detections = scenario(12, seed=3, p_detect=0.5, clutter=0.0)
    with pytest.raises(RuntimeError, match="not feasible"):  # as Stone Soup, no finite option
        fss.GNNWith2DAssignment(hypothesiser("ft")).associate(tracks, detections, T0 + DT)


def test_global_nearest_neighbour_equals_stone_soup_on_small_scans():
    for seed in range(3):
        tracks, detections = scenario(6, spacing=4.0, seed=seed, clutter=0.5)
        associate_both("GlobalNearestNeighbour", "distance", tracks, detections,
                       missed_distance=4)
        associate_both("GNNWith2DAssignment", "distance", tracks, detections,
                       missed_distance=4)


@pytest.mark.parametrize("normalise", [True, False])
def test_global_nearest_neighbour_over_probabilities_equals_stone_soup(normalise):
    """Stone Soup's ``GlobalNearestNeighbour`` on PDA hypotheses: the joint hypothesis of
    greatest product of probabilities, an assignment on minus their logs."""
    for seed in range(3):
        tracks, detections = scenario(6, spacing=4.0, seed=seed, clutter=0.5)
        ours, theirs = associate_both("GlobalNearestNeighbour", "pda", tracks, detections,
                                      clutter_spatial_density=1e-2, prob_detect=0.9,
                                      normalise=normalise)
        assert float(ours.probability) == pytest.approx(float(theirs.probability), rel=1e-9)
        assert any(ours.values())


def test_extended_kalman_with_a_bearing_range_sensor():
    """Bearings wrapped as Stone Soup's ``Bearing`` arithmetic wraps them; the Jacobian
    follows Stone Soup's forward-difference rule, so agreement is to its own Jacobian noise
    (see test_stonesoup_dropin)."""
    tracks, detections = scenario(40, spacing=15.0, seed=5, sensor=POLAR)
    ours, _ = associate_both("GNNWith2DAssignment", "distance", tracks, detections,
                             missed_distance=4, sensor=POLAR, extended=True, rtol=1e-6)
    assert sum(bool(h) for h in ours.values()) > 20
    associate_both("JPDAwithEHM", "pda", tracks, detections, sensor=POLAR, extended=True,
                   rtol=1e-6, clutter_spatial_density=1e-3, prob_detect=0.9)


@pytest.mark.parametrize("density", [2e-3, None])
@pytest.mark.parametrize("normalise", [True, False])
def test_pda_equals_stone_soup(density, normalise):
    tracks, detections = scenario(30, spacing=6.0, seed=6, clutter=1.0)
    associate_both("PDA", "pda", tracks, detections, clutter_spatial_density=density,
                   prob_detect=0.9, prob_gate=0.99, normalise=normalise)


def test_pda_equals_stone_soup_on_100_tracks():
    tracks, detections = scenario(100, seed=15)
    ours, _ = associate_both("PDA", "pda", tracks, detections, clutter_spatial_density=1e-3,
                             prob_detect=0.9, prob_gate=0.99)
    assert sum(len(h) > 1 for h in ours.values()) > 60


def test_jpda_equals_stone_soup_on_small_scans():
    """Stone Soup's JPDA enumerates the joint hypotheses of every track together, so only
    a few tracks; include_all and gated variants too."""
    for seed in range(3):
        tracks, detections = scenario(5, spacing=4.0, seed=seed, clutter=1.0)
        associate_both("JPDA", "pda", tracks, detections, clutter_spatial_density=0.02,
                       prob_detect=0.9, prob_gate=0.99)
    tracks, detections = scenario(4, spacing=4.0, seed=7, clutter=0.5)
    associate_both("JPDA", "pda", tracks, detections, clutter_spatial_density=0.02,
                   include_all=True)
    associate_both("JPDA", "pda", tracks, detections, clutter_spatial_density=0.02, gate=2.0)


def test_jpda_with_ehm_equals_stone_soup_on_100_targets_and_100_clutter():
    tracks, detections = scenario(100, spacing=6.0, seed=8, clutter=1.0, stale=0.1)
    ours, _ = associate_both("JPDAwithEHM", "pda", tracks, detections,
                             clutter_spatial_density=5e-3, prob_detect=0.9, prob_gate=0.99)
    assert max(len(h) for h in ours.values()) >= 4  # tracks do share detections
    tracks, detections = scenario(30, spacing=6.0, seed=9, clutter=1.0)
    associate_both("JPDAwithEHM", "pda", tracks, detections, prob_detect=0.9)
    associate_both("JPDAwithEHM", "pda", tracks, detections, clutter_spatial_density=5e-3,
                   gate=2.0)  # a gater re-sorts by probability


def test_empty_scans_return_what_stone_soup_returns():
    tracks, detections = scenario(5, seed=11)
    for associator, kind in [("NearestNeighbour", "distance"),
                             ("GlobalNearestNeighbour", "distance"),
                             ("GNNWith2DAssignment", "distance"), ("PDA", "pda"),
                             ("JPDA", "pda"), ("JPDAwithEHM", "pda")]:
        options = {"missed_distance": 3} if kind == "distance" else {}
        for some_tracks, some_detections in [(tracks, set()), ([], detections), ([], set())]:
            ours, theirs = associate_both(associator, kind, some_tracks, some_detections,
                                          fast=False, **options)
            assert len(ours) == len(theirs)
    joint = fss.GlobalNearestNeighbour(hypothesiser("ft", missed_distance=3)).associate(
        tracks, detections, T0 + DT)
    assert type(joint) is DistanceJointHypothesis


def test_a_track_given_twice_gets_stone_soups_association():
    tracks, detections = scenario(4, spacing=4.0, seed=7, clutter=0.5)
    twice = [tracks[0], *tracks]
    for associator, kind, options in [("NearestNeighbour", "distance", {"missed_distance": 4}),
                                      ("JPDA", "pda", {"clutter_spatial_density": 0.02})]:
        associate_both(associator, kind, twice, detections, fast=False, **options)


def test_other_configurations_run_stone_soup_code():
    """A Stone Soup predictor, an unrecognised model, detections at another time or
    keywords: Stone Soup's code, with its results."""
    tracks, detections = scenario(8, spacing=5.0, seed=12)

    class OtherCV(CombinedLinearGaussianTransitionModel):
        pass

    scans = []
    original = scan_engine._Scan

    def counting(*args, **kwargs):
        scan = original(*args, **kwargs)
        scans.append(scan)
        return scan

    with mock.patch.object(scan_engine, "_Scan", counting):
        slow = fss.DistanceHypothesiser(ss_kalman_predictor.KalmanPredictor(TRANSITION),
                                        fss.KalmanUpdater(SENSOR), fss.Mahalanobis(),
                                        missed_distance=3)
        other = fss.DistanceHypothesiser(
            fss.KalmanPredictor(OtherCV([ConstantVelocity(0.05)] * 2)),
            fss.KalmanUpdater(SENSOR), fss.Mahalanobis(), missed_distance=3)
        squared = fss.DistanceHypothesiser(fss.KalmanPredictor(TRANSITION),
                                           fss.KalmanUpdater(SENSOR),
                                           ss_measures.SquaredMahalanobis(), missed_distance=9)
        for h in (slow, other, squared):
            ours = fss.GNNWith2DAssignment(h).associate(tracks, detections, T0 + DT)
            theirs = ss_neighbour.GNNWith2DAssignment(h).associate(tracks, detections, T0 + DT)
            assert {t: x.measurement for t, x in ours.items() if x} == \
                {t: x.measurement for t, x in theirs.items() if x}
        late = {Detection(d.state_vector, timestamp=T0 + 2 * DT, measurement_model=SENSOR)
                for d in detections}
        h = hypothesiser("ft", missed_distance=3)
        fss.NearestNeighbour(h).associate(tracks, late, T0 + DT)
        other_sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
        mixed = {Detection(d.state_vector, timestamp=T0 + DT,
                           measurement_model=other_sensor if i % 2 else SENSOR)
                 for i, d in enumerate(detections)}
        for scan_detections in (mixed,):
            ours = fss.NearestNeighbour(h).associate(tracks, scan_detections, T0 + DT)
            theirs = ss_neighbour.NearestNeighbour(hypothesiser("ss", missed_distance=3)) \
                .associate(tracks, scan_detections, T0 + DT)
            for track in tracks:
                assert_same_hypothesis(ours[track], theirs[track])
        fss.NearestNeighbour(h).associate(tracks, detections, T0 + DT, noise=False)
        assert not scans  # a keyword that Stone Soup's models read
        fss.NearestNeighbour(h).associate(tracks, detections, T0 + DT)
        assert len(scans) == 1


# -- (2) Stone Soup's own tests on the drop-ins -------------------------------------------------

STONE_SOUP_TESTS = DATA / "stonesoup_tests"
#: The Stone Soup test files run here, by package.
OWN_TESTS = {"dataassociator": ["conftest", "test_neighbour", "test_probability"],
             "hypothesiser": ["conftest", "test_distance", "test_probability",
                              "test_gaussianmixture"],
             "gater": ["conftest", "test_distance"]}
#: Tests deselected because they pin an implementation detail (none so far).
DESELECTED = []
FAST_PATH_COUNTER = '''
import fasttrack.stonesoup._scan as scan_engine

SCANS = [0]
_original = scan_engine._Scan.__init__


def _counting(self, *args, **kwargs):
    _original(self, *args, **kwargs)
    SCANS[0] += 1


scan_engine._Scan.__init__ = _counting


def pytest_terminal_summary(terminalreporter):
    terminalreporter.write_line(f"FASTTRACK_SCANS={SCANS[0]}")
'''


def replaced(module, name):
    """Whether ``fasttrack.stonesoup.<name>`` replaces ``<module>.<name>``."""
    if name not in fss.__all__:
        return False
    try:
        original = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError):
        return False
    return isinstance(original, type) and issubclass(getattr(fss, name), original)


def rewrite_imports(source, package):
    """A Stone Soup test module's source with its relative imports made absolute
    (``package`` is the module's package, e.g. ``stonesoup.dataassociator.tests``) and the
    classes fasttrack.stonesoup replaces imported from there; and the names switched."""
    lines = source.splitlines()
    switched = []
    for node in sorted((n for n in ast.walk(ast.parse(source))
                        if isinstance(n, ast.ImportFrom) and n.level),
                       key=lambda n: n.lineno, reverse=True):
        parts = package.split(".")
        module = ".".join(parts[:len(parts) - node.level + 1] + ([node.module]
                                                                 if node.module else []))
        keep = [alias for alias in node.names if not replaced(module, alias.name)]
        ours = [alias for alias in node.names if replaced(module, alias.name)]
        indent = " " * node.col_offset

        def names(aliases):
            return ", ".join(a.name + (f" as {a.asname}" if a.asname else "") for a in aliases)

        new = []
        if keep:
            new.append(f"{indent}from {module} import {names(keep)}")
        if ours:
            new.append(f"{indent}from fasttrack.stonesoup import {names(ours)}")
            switched += [a.name for a in ours]
        lines[node.lineno - 1:node.end_lineno] = new
    return "\n".join(lines) + "\n", sorted(switched)


def test_stone_soups_own_tests_pass_on_the_drop_ins(tmp_path):
    switched = {}
    for package, files in OWN_TESTS.items():
        folder = tmp_path / f"stonesoup_{package}"
        folder.mkdir()
        (folder / "__init__.py").write_text("")
        for name in files:
            source = (STONE_SOUP_TESTS / package / f"{name}.py.txt").read_text()
            text, names = rewrite_imports(source, f"stonesoup.{package}.tests")
            (folder / f"{name}.py").write_text(text)
            switched[f"{package}/{name}"] = names
    assert switched["dataassociator/conftest"] == [
        "DistanceHypothesiser", "ExtendedKalmanUpdater", "KalmanPredictor", "Mahalanobis",
        "PDAHypothesiser"]
    assert switched["dataassociator/test_neighbour"] == [
        "GNNWith2DAssignment", "GlobalNearestNeighbour", "NearestNeighbour"]
    assert switched["dataassociator/test_probability"] == ["JPDA", "JPDAwithEHM", "PDA"]
    assert switched["hypothesiser/test_distance"] == ["DistanceHypothesiser"]
    assert switched["hypothesiser/test_probability"] == ["PDAHypothesiser"]
    assert switched["hypothesiser/test_gaussianmixture"] == [
        "DistanceHypothesiser", "GaussianMixtureHypothesiser",
        "GaussianMixtureKDTreeHypothesiser"]
    assert switched["gater/test_distance"] == [
        "DistanceGater", "DistanceHypothesiser", "ExtendedKalmanPredictor",
        "ExtendedKalmanUpdater", "PDAHypothesiser"]
    (tmp_path / "fasttrack_fast_path_counter.py").write_text(FAST_PATH_COUNTER)
    environment = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(tmp_path), str(REPO), os.environ.get("PYTHONPATH", "")]), MPLBACKEND="Agg")
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
               "-p", "fasttrack_fast_path_counter", "-W", "ignore::DeprecationWarning"]
    command += [f"--deselect={test}" for test in DESELECTED]
    command += [f"stonesoup_{package}" for package in OWN_TESTS]
    run = subprocess.run(command, cwd=tmp_path, env=environment, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    passed = int(re.search(r"(\d+) passed", run.stdout).group(1))
    assert passed >= 40 and "failed" not in run.stdout
    assert int(re.search(r"FASTTRACK_SCANS=(\d+)", run.stdout).group(1)) > 20


# -- (3) Stone Soup's data-association tutorials ------------------------------------------------

TUTORIALS = DATA / "stonesoup_tutorials"
SWITCHED = (r"stonesoup\.(?:predictor\.kalman|updater\.kalman|hypothesiser\.(?:distance|"
            r"probability)|dataassociator\.(?:neighbour|probability)|measures|gater\.distance)")


def run_tutorial(prefix, switch):
    """Execute a tutorial (its imports of the replaced classes switched to the drop-ins with
    ``switch``); its namespace, and the number of imports switched."""
    text = next(TUTORIALS.glob(f"{prefix}_*.txt")).read_text()
    count = 0
    if switch:
        text, count = re.subn(rf"^(\s*)from {SWITCHED} import ",
                              r"\1from fasttrack.stonesoup import ", text, flags=re.M)
    namespace = {"__name__": "__main__"}
    exec(compile(text, f"tutorial {prefix}", "exec"), namespace)
    matplotlib.pyplot.close("all")
    return namespace, count


def _tracks(namespace):
    tracks = namespace.get("tracks") or {namespace["track"]}
    return {tuple(np.ravel(track[0].state_vector)): track for track in tracks}


@pytest.mark.parametrize("prefix, associator", [
    ("005", "NearestNeighbour"), ("006", "GlobalNearestNeighbour"), ("007", "PDA"),
    ("008", "JPDA")])
def test_stone_soup_tutorials_give_the_same_tracks_on_the_drop_ins(prefix, associator):
    scans = []
    original = scan_engine._Scan

    def counting(*args, **kwargs):
        scans.append(original(*args, **kwargs))
        return scans[-1]

    theirs, _ = run_tutorial(prefix, switch=False)
    with mock.patch.object(scan_engine, "_Scan", counting):
        ours, count = run_tutorial(prefix, switch=True)
    assert count == (5 if prefix in ("005", "006") else 4)
    for name in ("predictor", "updater", "hypothesiser", "data_associator"):
        assert type(ours[name]).__module__.startswith("fasttrack.stonesoup"), name
    assert type(ours["data_associator"]).__name__ == associator
    assert len(scans) == len(ours["all_measurements"])  # every scan took the fast path
    ours_tracks, theirs_tracks = _tracks(ours), _tracks(theirs)
    assert ours_tracks.keys() == theirs_tracks.keys()
    for key, theirs_track in theirs_tracks.items():
        ours_track = ours_tracks[key]
        assert len(ours_track) == len(theirs_track) == len(ours["all_measurements"]) + 1
        for a, b in zip(ours_track, theirs_track):
            assert type(a) is type(b)
            assert_close(a.state_vector, b.state_vector, 1e-9, f"tutorial {prefix}")
            assert_close(a.covar, b.covar, 1e-9, f"tutorial {prefix}")
        updates = [s for s in ours_track if hasattr(s, "hypothesis")]
        assert updates  # the tracks do take detections
