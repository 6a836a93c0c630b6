"""fasttrack.stonesoup.tracker: the ``MultiTargetTracker`` and ``MultiTargetMixtureTracker``
drop-ins give the same tracks as Stone Soup 1.9.1's on the same inputs; Stone Soup's own tests
for the trackers, metric generators, deleters, initiators, Kalman predictors, updaters and
smoothers run against the drop-ins; and Stone Soup's tutorial 9 (initiators and deleters in a
tracker) runs both ways.

Stone Soup's tests are copied, unchanged, from its 1.9.1 sdist (MIT licence, see
``tests/data/stonesoup_tests/LICENSE``) into ``tests/data/stonesoup_tests/<package>/`` with a
``.txt`` suffix, so that this suite's own collection does not pick them up;
:func:`run_stonesoup_tests` rewrites their imports and runs them with pytest in a subprocess.
"""
import ast
import importlib
import os
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest

pytest.importorskip("stonesoup")
import matplotlib  # noqa: E402

matplotlib.use("Agg")

from stonesoup.dataassociator.probability import JPDA  # noqa: E402
from stonesoup.deleter.error import CovarianceBasedDeleter as SSCovarianceBasedDeleter  # noqa
from stonesoup.deleter.time import UpdateTimeStepsDeleter as SSUpdateTimeStepsDeleter  # noqa
from stonesoup.hypothesiser.probability import PDAHypothesiser  # noqa: E402
from stonesoup.initiator import simple as ss_initiator  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor.kalman import KalmanPredictor  # noqa: E402
from stonesoup.tracker import pointprocess as ss_pointprocess  # noqa: E402
from stonesoup.tracker import simple as ss_tracker  # noqa: E402
from stonesoup.types.array import StateVector  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.updater.kalman import KalmanUpdater  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402
from test_stonesoup_deleter import _covariance_tracks, _deleter_tracks  # noqa: E402
from test_stonesoup_initiator import (LINEAR, PRIOR, _assert_same_summaries,  # noqa: E402
                                      _kalman_components, _scans, _summary)

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"


# -- switching imports to the drop-ins ----------------------------------------------------------

def _imported(module, name):
    try:
        return getattr(importlib.import_module(module), name)
    except AttributeError:
        return importlib.import_module(f"{module}.{name}")


def switch_imports(source, package=None):
    """``source`` with every ``from stonesoup... import X`` of a class that
    ``fasttrack.stonesoup`` replaces (a subclass of the same name) turned into ``from
    fasttrack.stonesoup import X``, and the names switched.

    ``package`` is the Stone Soup package a test file came from (``stonesoup/<package>/tests``):
    its relative imports become absolute ones (``from ..simple import A`` to ``from
    stonesoup.<package>.simple import A``).
    """
    tree = ast.parse(source)
    lines = source.splitlines(keepends=True)
    edits, switched = [], []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            parts = ["stonesoup", package, "tests"][:4 - node.level] + [node.module or ""]
            module = ".".join(part for part in parts if part)
        elif node.module == "stonesoup" or (node.module or "").startswith("stonesoup."):
            module = node.module
        else:
            continue
        kept, ours = [], []
        for alias in node.names:
            spelled = alias.name if alias.asname is None else f"{alias.name} as {alias.asname}"
            theirs = _imported(module, alias.name)
            drop_in = getattr(fss, alias.name) if alias.name in fss.__all__ else None
            if isinstance(theirs, type) and isinstance(drop_in, type) \
                    and issubclass(drop_in, theirs):
                ours.append(spelled)
                switched.append(alias.name)
            else:
                kept.append(spelled)
        if not ours and not node.level:
            continue
        indent = lines[node.lineno - 1][:node.col_offset]
        statements = [f"{indent}from {module} import {', '.join(kept)}\n"] if kept else []
        if ours:
            statements.append(f"{indent}from fasttrack.stonesoup import {', '.join(ours)}\n")
        edits.append((node.lineno - 1, node.end_lineno, "".join(statements)))
    for start, end, text in sorted(edits, reverse=True):
        lines[start:end] = [text]
    return "".join(lines), switched


def _run_tracker(tracker):
    return [_summary(tracks) for _, tracks in tracker]


def test_multi_target_tracker_equals_stonesoup():
    scans = _scans(5, n_targets=6, steps=15)

    def tracker(tracker_cls, module):
        _, updater, associator = _kalman_components(module)
        initiator = (module or ss_initiator).MultiMeasurementInitiator(
            prior_state=PRIOR, measurement_model=LINEAR,
            deleter=(module.UpdateTimeStepsDeleter if module else SSUpdateTimeStepsDeleter)(2),
            data_associator=associator, updater=updater, min_points=2)
        deleter = (module.CovarianceBasedDeleter if module else SSCovarianceBasedDeleter)(8.0)
        return tracker_cls(initiator, deleter, scans, associator, updater)

    reference = _run_tracker(tracker(ss_tracker.MultiTargetTracker, None))
    assert max(len(step) for step in reference) >= 4
    for tracker_cls, module in ((fss.MultiTargetTracker, None), (fss.MultiTargetTracker, fss)):
        for mine, theirs in zip(_run_tracker(tracker(tracker_cls, module)), reference):
            _assert_same_summaries(mine, theirs)
    stepped = tracker(fss.MultiTargetTracker, fss)
    for (stamp, detections), theirs in zip(scans, reference):
        _assert_same_summaries(_summary(stepped.update_tracker(stamp, detections)[1]), theirs)


def test_multi_target_mixture_tracker_equals_stonesoup():
    scans = _scans(6, n_targets=5, steps=12, clutter=4)

    def tracker(tracker_cls, associator_module):
        transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
        predictor, updater = KalmanPredictor(transition), KalmanUpdater(LINEAR)
        hypothesiser_cls = associator_module.PDAHypothesiser if associator_module \
            else PDAHypothesiser
        associator_cls = associator_module.JPDA if associator_module else JPDA
        hypothesiser = hypothesiser_cls(predictor, updater, clutter_spatial_density=1e-3,
                                        prob_detect=0.9)
        associator = associator_cls(hypothesiser)
        _, gnn_updater, gnn = _kalman_components()
        initiator = ss_initiator.MultiMeasurementInitiator(
            prior_state=PRIOR, measurement_model=LINEAR, deleter=SSUpdateTimeStepsDeleter(2),
            data_associator=gnn, updater=gnn_updater, min_points=2)
        return tracker_cls(initiator, SSUpdateTimeStepsDeleter(3), scans, associator, updater)

    reference = _run_tracker(tracker(ss_tracker.MultiTargetMixtureTracker, None))
    assert max(len(step) for step in reference) >= 3
    assert any("GaussianStatePrediction" in row[1] for step in reference for row in step)
    for module in (None, fss):
        for mine, theirs in zip(_run_tracker(tracker(fss.MultiTargetMixtureTracker, module)),
                                reference):
            _assert_same_summaries(mine, theirs)


def test_mixture_reduction_falls_back_to_stonesoup_for_zero_weights():
    from fasttrack.stonesoup.tracker import _reduce
    from stonesoup.types.numeric import Probability
    states = [GaussianState([[1.0], [2.0]], np.eye(2)), GaussianState([[3.0], [0.0]],
                                                                      2 * np.eye(2))]
    assert _reduce(states, [Probability(0), Probability(0)]) is None
    mean, covar = _reduce(states, [Probability(0.25), 0.75])
    assert isinstance(mean, StateVector) and mean.shape == (2, 1)
    np.testing.assert_allclose(mean.ravel(), [2.5, 0.5])
    np.testing.assert_allclose(covar, 1.75 * np.eye(2) + 0.1875 * np.array([[4, -4], [-4, 4]]))


def test_tracking_checks_run_at_once(monkeypatch):
    """The deleters check a set of tracks without Stone Soup's per-track code (and without
    copying the tracks), and the mixture tracker reduces without ``gm_reduce_single``."""
    import fasttrack.stonesoup.tracker as fast_tracker

    def stonesoups(*args, **kwargs):
        raise AssertionError("Stone Soup's code ran")
    monkeypatch.setattr(SSCovarianceBasedDeleter, "check_for_deletion", stonesoups)
    monkeypatch.setattr(fast_tracker, "gm_reduce_single", stonesoups)
    from stonesoup.types.state import StateMutableSequence
    monkeypatch.setattr(StateMutableSequence, "__getitem__", stonesoups)  # no track[::-1]
    fss.CovarianceBasedDeleter(5.0).delete_tracks(set(_covariance_tracks(0)))
    fss.UpdateTimeStepsDeleter(2).delete_tracks(set(_deleter_tracks(0)))
    monkeypatch.undo()
    monkeypatch.setattr(fast_tracker, "gm_reduce_single", stonesoups)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    predictor, updater = KalmanPredictor(transition), KalmanUpdater(LINEAR)
    associator = JPDA(PDAHypothesiser(predictor, updater, clutter_spatial_density=1e-3,
                                      prob_detect=0.9))
    initiator = fss.SimpleMeasurementInitiator(PRIOR, LINEAR)
    tracker = fss.MultiTargetMixtureTracker(initiator, fss.UpdateTimeStepsDeleter(2),
                                            _scans(1, steps=4), associator, updater)
    assert sum(len(track) for track in list(tracker)[-1][1]) > 4


def test_tracking_drop_ins_are_stonesoup_subclasses_with_the_same_properties():
    pairs = [("UpdateTimeStepsDeleter", SSUpdateTimeStepsDeleter),
             ("CovarianceBasedDeleter", SSCovarianceBasedDeleter),
             ("SimpleMeasurementInitiator", ss_initiator.SimpleMeasurementInitiator),
             ("MultiMeasurementInitiator", ss_initiator.MultiMeasurementInitiator),
             ("MultiTargetTracker", ss_tracker.MultiTargetTracker),
             ("MultiTargetMixtureTracker", ss_tracker.MultiTargetMixtureTracker),
             ("PointProcessMultiTargetTracker",
              ss_pointprocess.PointProcessMultiTargetTracker)]
    for name, theirs in pairs:
        ours = getattr(fss, name)
        assert issubclass(ours, theirs) and ours.__name__ == theirs.__name__
        assert list(ours.properties) == list(theirs.properties)
        for key, prop in theirs.properties.items():
            assert ours.properties[key].default is prop.default, (name, key)


# -- Stone Soup's own tests -----------------------------------------------------------------

#: The copied Stone Soup test files, by package (tests/data/stonesoup_tests/<package>/).
STONESOUP_TESTS = {
    "deleter": ["test_time.py", "test_error.py"],
    "initiator": ["test_simple.py"],
    "metricgenerator": ["conftest.py", "test_ospametric.py"],
    "mixturereducer": ["test_gaussian_mixture_reducer.py"],
    "predictor": ["test_kalman.py"],
    "smoother": ["test_kalman.py"],
    "tracker": ["conftest.py", "test_simple.py", "test_pointprocess.py"],
    "updater": ["conftest.py", "test_kalman.py", "test_pointprocess.py"],
}

#: Tests that pin an implementation detail rather than the replaced classes' behaviour, or
#: that fail at random whatever is replaced.
DESELECTED = [
    # compares the Kalman updater's update bit for bit (np.array_equal) with Stone Soup's
    # SinglePointInitiator, which runs Stone Soup's own ExtendedKalmanUpdater: the drop-in
    # Kalman updaters agree with it to rounding (1e-14), not to the last bit
    "initiator/test_simple.py::test_spi",
    # Stone Soup's own StochasticIntegrationPredictor (not replaced) draws from NumPy's
    # unseeded global generator and its mean is checked to 1e-14: with Stone Soup's classes
    # alone it fails 3 times in 5000 (errors up to 6e-14)
    "predictor/test_kalman.py::test_kalman[stochasticIntegration]",
]


def run_stonesoup_tests(directory, tests=STONESOUP_TESTS, deselected=DESELECTED):
    """Write Stone Soup's copied tests into ``directory`` with their imports switched to
    the drop-ins (:func:`switch_imports`) and run them with pytest in a subprocess.

    Returns ``(returncode, output, outcomes, switched)``: ``outcomes`` maps each test id
    (``package/file::name``) to "passed", "failed", "error" or "skipped"; ``switched`` maps
    each file to the class names it now imports from ``fasttrack.stonesoup``.
    """
    switched = {}
    for package, names in tests.items():
        (directory / package).mkdir(parents=True, exist_ok=True)
        for name in names:
            text = (DATA / "stonesoup_tests" / package / f"{name}.txt").read_text()
            text, names_switched = switch_imports(text, package)
            (directory / package / name).write_text(text)
            switched[f"{package}/{name}"] = names_switched
    report = directory / "report.xml"
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
               "--import-mode=importlib", "-o", "python_classes=", "--rootdir",
               str(directory), f"--junitxml={report}", *tests]
    for test_id in deselected:
        command += ["--deselect", test_id]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]),
        MPLBACKEND="Agg")
    done = subprocess.run(command, cwd=directory, env=env, capture_output=True, text=True,
                          timeout=600)
    outcomes = {}
    if report.exists():
        for case in ElementTree.parse(report).iter("testcase"):
            path = case.get("classname").replace(".", "/")
            test_id = f"{path}.py::{case.get('name')}"
            kinds = [child.tag for child in case if child.tag in ("failure", "error",
                                                                   "skipped")]
            outcomes[test_id] = {"failure": "failed"}.get(kinds[0], kinds[0]) if kinds \
                else "passed"
    return done.returncode, done.stdout + done.stderr, outcomes, switched


@pytest.fixture(scope="module")
def stonesoup_test_run(tmp_path_factory):
    return run_stonesoup_tests(tmp_path_factory.mktemp("stonesoup_tests"))


@pytest.mark.parametrize("package, replaced", [
    ("deleter", {"UpdateTimeStepsDeleter", "CovarianceBasedDeleter"}),
    ("initiator", {"SimpleMeasurementInitiator", "MultiMeasurementInitiator",
                   "UpdateTimeStepsDeleter"}),
    ("metricgenerator", {"GOSPAMetric", "OSPAMetric"}),
    ("mixturereducer", {"GaussianMixtureReducer"}),
    ("predictor", {"KalmanPredictor", "ExtendedKalmanPredictor", "UnscentedKalmanPredictor"}),
    ("smoother", {"KalmanPredictor", "KalmanUpdater", "KalmanSmoother",
                  "ExtendedKalmanSmoother", "UnscentedKalmanSmoother"}),
    ("tracker", {"MultiTargetTracker", "MultiTargetMixtureTracker",
                 "PointProcessMultiTargetTracker", "GaussianMixtureHypothesiser",
                 "DistanceHypothesiser", "PHDUpdater", "GaussianMixtureReducer"}),
    ("updater", {"KalmanUpdater", "ExtendedKalmanUpdater", "UnscentedKalmanUpdater",
                 "PHDUpdater", "LCCUpdater"})])
def test_stonesoups_own_tests_pass_on_the_drop_ins(stonesoup_test_run, package, replaced):
    returncode, output, outcomes, switched = stonesoup_test_run
    names = {name for file, found in switched.items() if file.startswith(f"{package}/")
             for name in found}
    assert replaced <= names
    mine = {test: outcome for test, outcome in outcomes.items()
            if test.startswith(f"{package}/")}
    assert len(mine) >= 2, output[-3000:]
    failed = {test: outcome for test, outcome in mine.items() if outcome != "passed"}
    assert not failed, output[-5000:]
    assert returncode == 0, output[-5000:]


def test_switch_imports_rewrites_relative_and_absolute_imports():
    source = ("from ..simple import MultiTargetTracker, SingleTargetTracker\n"
              "from ...types.track import Track\n"
              "def f():\n"
              "    from stonesoup.metricgenerator.ospametric import (\n"
              "        GOSPAMetric as G, _SwitchingLoss)\n")
    text, switched = switch_imports(source, "tracker")
    assert text == ("from stonesoup.tracker.simple import SingleTargetTracker\n"
                    "from fasttrack.stonesoup import MultiTargetTracker\n"
                    "from stonesoup.types.track import Track\n"
                    "def f():\n"
                    "    from stonesoup.metricgenerator.ospametric import _SwitchingLoss\n"
                    "    from fasttrack.stonesoup import GOSPAMetric as G\n")
    assert switched == ["MultiTargetTracker", "GOSPAMetric"]


# -- Stone Soup's tutorial 9 ----------------------------------------------------------------

class _NoPlots:
    """Stands for the plotter in the reference run (plotting does not touch the tracks)."""

    def __getattr__(self, name):
        return lambda *args, **kwargs: None


def test_initiators_and_deleters_tutorial_runs_on_the_drop_ins_with_stonesoups_tracks():
    """Tutorial 9 with its imports switched: its scenario runs once (its random draws follow
    set iteration order, so two runs of the whole script differ even under one seed), then
    its tracking part runs with the drop-ins and with Stone Soup's classes on the same
    detections, giving the same tracks."""
    source = (DATA / "stonesoup_tutorials" / "009_initiators_and_deleters.txt").read_text()
    switched_source, switched = switch_imports(source)
    assert {"CovarianceBasedDeleter", "MultiMeasurementInitiator"} <= set(switched)
    marker = "# %%\n# Creating a Tracker\n"
    scenario, tracking = source.split(marker)
    switched_scenario, switched_tracking = switched_source.split(marker)
    assert switched_scenario == scenario  # nothing replaced before the tracker
    namespace = {"__name__": "__main__"}
    exec(compile(scenario, "tutorial 009 (scenario)", "exec"), namespace)
    ours = dict(namespace)
    exec(compile(switched_tracking, "tutorial 009 (tracking, drop-ins)", "exec"), ours)
    theirs = dict(namespace, plotter=_NoPlots())
    exec(compile(tracking, "tutorial 009 (tracking, Stone Soup)", "exec"), theirs)
    for name in ("initiator", "deleter", "data_associator", "hypothesiser", "predictor",
                 "updater"):
        expected = type(ours[name]).__name__ in switched
        assert type(ours[name]).__module__.startswith("fasttrack.stonesoup") == expected
        assert type(theirs[name]).__module__.startswith("stonesoup.")
    assert type(ours["initiator"].initiator) is fss.SimpleMeasurementInitiator
    assert len(theirs["all_tracks"]) >= 3
    _assert_same_summaries(_summary(ours["all_tracks"]), _summary(theirs["all_tracks"]))
    matplotlib.pyplot.close("all")
