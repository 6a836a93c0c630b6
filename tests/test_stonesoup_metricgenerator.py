"""fasttrack.stonesoup.metricgenerator: the ``GOSPAMetric`` and ``OSPAMetric`` drop-ins give
the same metric objects as Stone Soup 1.9.1's on the same inputs, and compute through the
compiled GOSPA and OSPA."""
import datetime

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.measures import Euclidean, EuclideanWeighted  # noqa: E402
from stonesoup.metricgenerator import ospametric as ss_ospametric  # noqa: E402
from stonesoup.metricgenerator.manager import MultiManager  # noqa: E402
from stonesoup.types.angle import Bearing  # noqa: E402
from stonesoup.types.array import StateVector, StateVectors  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState  # noqa: E402
from stonesoup.types.metric import SingleTimeMetric, TimeRangeMetric  # noqa: E402
from stonesoup.types.state import GaussianState, ParticleState, State  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402

T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)
TOLERANCE = 1e-9


def _metric_scenario(seed, n_truths=8, steps=20, dim=4):
    """Truth paths on lines and tracks following them with noise: paths and tracks that
    start late, tracks that miss steps, switch truths, clutter tracks, and (over several
    steps) a track with two states at one time and one whose timestamps go back once (Stone
    Soup's last-state-per-timestamp rule)."""
    rng = np.random.default_rng(seed)
    start = np.c_[np.arange(n_truths) * 7.0, rng.normal(0, 1, n_truths),
                  rng.normal(0, 5, n_truths), rng.normal(0, 1, n_truths)][:, :dim]
    truths, tracks = [], []
    for i in range(n_truths):
        first = int(rng.integers(0, 4 if steps > 4 else 1))
        truths.append(GroundTruthPath([
            GroundTruthState((start[i] + k * np.r_[start[i, 1], 0, start[i, 3], 0][:dim])
                             .reshape(-1, 1), timestamp=T0 + k * DT)
            for k in range(first, steps)]))
    for j in range(n_truths + 2):
        track = Track()
        follows = j % n_truths
        for k in range(int(rng.integers(0, 5 if steps > 5 else 1)), steps):
            if rng.random() < 0.15:
                continue
            if rng.random() < 0.05:
                follows = int(rng.integers(n_truths))
            if j >= n_truths:
                x = rng.uniform(-10, 7.0 * n_truths, dim)
            else:
                truth = [s for s in truths[follows] if s.timestamp == T0 + k * DT]
                if not truth:
                    continue
                x = np.ravel(truth[0].state_vector) + rng.normal(0, 1.5, dim)
            track.append(GaussianState(x.reshape(-1, 1), np.eye(dim), timestamp=T0 + k * DT))
        if len(track):
            tracks.append(track)
    if steps == 1:
        return set(truths), set(tracks)
    doubled = tracks[0]
    doubled.append(GaussianState(doubled[-1].state_vector + 0.5, np.eye(dim),
                                 timestamp=doubled[-1].timestamp))
    back = tracks[1]
    back.insert(len(back) - 1, GaussianState(back[-1].state_vector + 0.2, np.eye(dim),
                                             timestamp=back[-1].timestamp + DT))
    return set(truths), set(tracks)


def _assert_same_metric(ours, theirs, generator):
    assert type(ours) is type(theirs)
    assert ours.title == theirs.title
    assert ours.generator is generator
    if isinstance(theirs, TimeRangeMetric):
        assert (ours.time_range.start, ours.time_range.end) == (theirs.time_range.start,
                                                                theirs.time_range.end)
        assert len(ours.value) == len(theirs.value)
        for mine, reference in zip(ours.value, theirs.value):
            _assert_same_metric(mine, reference, generator)
        return
    assert ours.timestamp == theirs.timestamp
    if isinstance(theirs.value, dict):
        assert list(ours.value) == list(theirs.value)
        for key, value in theirs.value.items():
            assert ours.value[key] == pytest.approx(value, rel=TOLERANCE, abs=TOLERANCE), key
    else:
        assert ours.value == pytest.approx(theirs.value, rel=TOLERANCE, abs=TOLERANCE)


def _both(name, **kwargs):
    return getattr(fss, name)(**kwargs), getattr(ss_ospametric, name)(**kwargs)


def _compare_generators(ours, theirs, truths, tracks):
    manager = MultiManager([theirs])
    manager.add_data({"groundtruth_paths": truths, "tracks": tracks})
    _assert_same_metric(ours.compute_metric(manager), theirs.compute_metric(manager), ours)
    args = (*ours.extract_states(tracks, True), *ours.extract_states(truths, True))
    _assert_same_metric(ours.compute_over_time(*args), theirs.compute_over_time(*args), ours)


@pytest.mark.parametrize("c, p, switching_penalty", [
    (10, 1, 0.0), (5.0, 2, 0.0), (8.0, 1, 3.0), (4, 2, 1.5), (6.0, 1.5, 0.5)])
def test_gospa_metric_equals_stonesoup(c, p, switching_penalty):
    truths, tracks = _metric_scenario(1)
    ours, theirs = _both("GOSPAMetric", c=c, p=p, switching_penalty=switching_penalty)
    _compare_generators(ours, theirs, truths, tracks)


def test_gospa_switching_with_given_ids_equals_stonesoup():
    """Ids given to ``compute_over_time``: strings, and a truth id twice in a step (Stone
    Soup keeps the last one's assignment; through Stone Soup's code)."""
    truths, tracks = _metric_scenario(10)
    ours, theirs = _both("GOSPAMetric", c=6.0, p=1, switching_penalty=2.0)
    estimates, estimate_ids = ours.extract_states(tracks, True)
    paths, path_ids = ours.extract_states(truths, True)
    named = [f"track {i}" for i in estimate_ids]
    for ids in (path_ids, [i // 2 for i in path_ids]):
        args = (estimates, named, paths, ids)
        _assert_same_metric(ours.compute_over_time(*args), theirs.compute_over_time(*args),
                            ours)


@pytest.mark.parametrize("name, c, p", [("GOSPAMetric", 10, 40), ("OSPAMetric", 10, 0.5),
                                         ("OSPAMetric", 3, 50)])
def test_orders_fasttrack_refuses_run_stonesoups_code(name, c, p):
    """Orders above 30 or below 1 (and c ** p beyond [1e-300, 1e300]), which fasttrack's
    metrics refuse, are Stone Soup's to compute."""
    truths, tracks = _metric_scenario(3)
    ours, theirs = _both(name, c=c, p=p)
    _compare_generators(ours, theirs, truths, tracks)


@pytest.mark.parametrize("p", [1, 2, np.inf])
@pytest.mark.parametrize("c", [4.0, 10])
def test_ospa_metric_equals_stonesoup(c, p):
    truths, tracks = _metric_scenario(2)
    ours, theirs = _both("OSPAMetric", c=c, p=p)
    _compare_generators(ours, theirs, truths, tracks)


@pytest.mark.parametrize("measure", [Euclidean(mapping=[0, 2]),
                                     Euclidean(mapping=(0, 2), mapping2=(0, 2)),
                                     EuclideanWeighted(weighting=[1, 0.5, 2, 1])],
                         ids=["mapping", "mapping2", "weighted (Stone Soup's code)"])
@pytest.mark.parametrize("name", ["GOSPAMetric", "OSPAMetric"])
def test_metrics_with_other_measures_equal_stonesoup(name, measure):
    truths, tracks = _metric_scenario(3)
    kwargs = dict(c=6.0, p=2, measure=measure)
    if name == "GOSPAMetric":
        kwargs["switching_penalty"] = 2.0
    _compare_generators(*_both(name, **kwargs), truths, tracks)


def test_metrics_of_particle_states_angles_and_other_alpha_equal_stonesoup():
    """ParticleState estimates (the measure reads their mean), Bearing-valued state vectors
    and alpha != 2 (both through Stone Soup's code)."""
    rng = np.random.default_rng(4)
    truths = {GroundTruthPath([GroundTruthState([[i * 3.0 + k], [k * 0.5]], timestamp=T0 + k * DT)
                               for k in range(6)]) for i in range(4)}
    particles = {Track([ParticleState(StateVectors(np.array([[i * 3.0 + k], [k * 0.5]])
                                                   + rng.normal(0, 1, (2, 30))),
                                      weight=np.full(30, 1 / 30), timestamp=T0 + k * DT)
                        for k in range(6)]) for i in range(4)}
    ours, theirs = _both("GOSPAMetric", c=5.0, p=1, switching_penalty=1.0)
    _compare_generators(ours, theirs, truths, particles)
    _compare_generators(*_both("OSPAMetric", c=5.0, p=2), truths, particles)
    angles = {Track([State(StateVector([Bearing(0.3 * i + 0.1 * k), 1.0 * k]),
                           timestamp=T0 + k * DT) for k in range(6)]) for i in range(4)}
    _compare_generators(*_both("OSPAMetric", c=5.0, p=1), truths, angles)
    ours, theirs = _both("GOSPAMetric", c=5.0, p=1)
    ours.alpha = theirs.alpha = 1
    _compare_generators(ours, theirs, truths, particles)


def test_metrics_edge_cases_equal_stonesoup():
    truths, tracks = _metric_scenario(5, steps=1)
    for name, kwargs in (("GOSPAMetric", dict(c=5, p=1, switching_penalty=1)),
                         ("OSPAMetric", dict(c=5, p=1))):
        ours, theirs = _both(name, **kwargs)
        single = ours.compute_over_time(*ours.extract_states(tracks, True),
                                        *ours.extract_states(truths, True))
        assert isinstance(single, SingleTimeMetric)
        _compare_generators(ours, theirs, truths, tracks)
        many_truths, many_tracks = _metric_scenario(6)
        _compare_generators(ours, theirs, many_truths, {})  # no tracks
        _compare_generators(ours, theirs, {}, many_tracks)  # no truths
        manager = MultiManager([theirs])
        manager.add_data({"groundtruth_paths": {}, "tracks": {}})
        with pytest.raises(ValueError):  # Stone Soup cannot time an empty range
            theirs.compute_metric(manager)
        with pytest.raises(ValueError):
            ours.compute_metric(manager)


def test_extract_states_equals_stonesoup():
    truths, tracks = _metric_scenario(7)
    detections = [Detection([[i]], timestamp=T0) for i in range(3)]
    for objects in (tracks, truths, detections, list(tracks) + detections):
        mine, my_ids = fss.GOSPAMetric.extract_states(objects, True)
        theirs, their_ids = ss_ospametric.GOSPAMetric.extract_states(objects, True)
        assert mine.states == theirs.states and my_ids == their_ids
        assert fss.OSPAMetric.extract_states(objects).states == theirs.states
    with pytest.raises(RuntimeError):  # Stone Soup's generator on an empty track
        fss.GOSPAMetric.extract_states([Track()])
    with pytest.raises(ValueError, match="has no state extraction method"):
        fss.GOSPAMetric.extract_states([1.0])


def test_one_step_metrics_equal_stonesoup():
    rng = np.random.default_rng(8)
    truths = [State(rng.normal(0, 5, (2, 1)), timestamp=T0) for _ in range(6)]
    estimates = [State(t.state_vector + rng.normal(0, 1, (2, 1)), timestamp=T0)
                 for t in truths[:4]] + [State(rng.normal(0, 20, (2, 1)), timestamp=T0)]
    ours, theirs = _both("GOSPAMetric", c=3.0, p=2)
    for e, t in ((estimates, truths), (truths, estimates), ([], truths), (estimates, [])):
        (mine, my_assignment), (reference, assignment) = (
            ours.compute_gospa_metric(e, t), theirs.compute_gospa_metric(e, t))
        _assert_same_metric(mine, reference, ours)
        assert type(my_assignment) is type(assignment)
        assert np.array_equal(my_assignment, assignment)
    with pytest.raises(ValueError, match="same time"):
        ours.compute_gospa_metric(estimates, [State([[0], [0]], timestamp=T0 + DT)])
    ours, theirs = _both("OSPAMetric", c=3.0, p=np.inf)
    for e, t in ((estimates, truths), (truths[:5], estimates), ([], truths)):
        _assert_same_metric(ours.compute_OSPA_distance(e, t), theirs.compute_OSPA_distance(e, t),
                            ours)
    with pytest.raises(ValueError, match="same time"):
        ours.compute_OSPA_distance(estimates, [State([[0], [0]], timestamp=T0 + DT)])


def test_metric_drop_ins_keep_stonesoups_properties_and_defaults():
    for name in ("GOSPAMetric", "OSPAMetric"):
        ours, theirs = getattr(fss, name), getattr(ss_ospametric, name)
        assert issubclass(ours, theirs)
        assert list(ours.properties) == list(theirs.properties)
        assert all(ours.properties[key].default == theirs.properties[key].default
                   for key in theirs.properties)
    metric = fss.GOSPAMetric(10, 1)
    assert (metric.p, metric.c, metric.alpha, metric.generator_name) == (10, 1, 2,
                                                                         "gospa_generator")


def test_metrics_compute_through_the_compiled_code(monkeypatch):
    """The default measure's GOSPA and OSPA never reach Stone Soup's per-step code; a
    subclass's own ``compute_over_time`` is still what ``compute_metric`` calls."""
    def stonesoups(*args, **kwargs):
        raise AssertionError("Stone Soup's code ran")
    for cls, names in ((ss_ospametric.GOSPAMetric, ("compute_over_time",
                                                    "compute_gospa_metric",
                                                    "compute_cost_matrix", "extract_states")),
                       (ss_ospametric.OSPAMetric, ("compute_over_time",
                                                   "compute_OSPA_distance"))):
        for name in names:
            monkeypatch.setattr(cls, name, stonesoups)
    truths, tracks = _metric_scenario(9)
    manager = MultiManager([])
    manager.add_data({"groundtruth_paths": truths, "tracks": tracks})
    gospa = fss.GOSPAMetric(c=5, p=2, switching_penalty=1)
    ospa = fss.OSPAMetric(c=5, p=np.inf, measure=Euclidean(mapping=[0, 2]))
    for metric in (gospa, ospa):
        assert len(metric.compute_metric(manager).value) == 20
        assert len(metric.compute_over_time(*metric.extract_states(tracks, True),
                                            *metric.extract_states(truths, True)).value) == 20
    states = [s for t in tracks for s in t if s.timestamp == T0 + 5 * DT]
    gospa.compute_gospa_metric(states, states)
    ospa.compute_OSPA_distance(states, states)

    class Custom(fss.GOSPAMetric):
        def compute_over_time(self, *args):
            return "custom"
    assert Custom(c=5, p=1).compute_metric(manager) == "custom"
