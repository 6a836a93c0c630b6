"""Monte Carlo runs: seeding, metrics, the local pool, a Dask LocalCluster, lost workers and
failing runs."""
import datetime
import functools
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from scipy import stats

import fasttrack as ft
from fasttrack import montecarlo as mc
from fasttrack.scenarios import (Scenario, adaptive_kernel_tutorial, grid_targets,
                                 particle_filter_tutorial)
from fasttrack.tracker import MultiTargetTracker

START = datetime.datetime(2026, 1, 1)
COLUMNS = ("run", "step", "time", "position_error", "nees", "nis", "ess")


def pf_scenario(seed):
    return particle_filter_tutorial(n_particles=300, seed=seed, steps=10)


def make_pf(scenario, rng):
    return (ft.ParticlePredictor(scenario.transition_model, rng=rng),
            ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=rng)))


def linear_scenario(seed, steps=15):
    """A CV target seen in position with unit noise; the truth starts from a draw of the
    prior, so that a Kalman filter is consistent (NEES ~ chi2(4), NIS ~ chi2(2))."""
    rng = np.random.default_rng(seed)
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.1)] * 2)
    sensor = ft.LinearGaussian(4, (0, 2), np.eye(2))
    mean, covar = np.array([0.0, 1.0, 0.0, 1.0]), np.diag([4.0, 0.5, 4.0, 0.5])
    truth = ft.ground_truth(transition, rng.multivariate_normal(mean, covar), steps,
                            start_time=0.0, rng=rng)  # timestamps in seconds, not datetimes
    return Scenario(transition, sensor, truth, ft.detections(truth, sensor, rng=rng),
                    ft.GaussianState(mean, covar, timestamp=0.0))



def known_scenario(seed):
    """:func:`linear_scenario` with a noiseless transition and an exactly known prior: the
    Kalman posteriors' covariances are zero (singular)."""
    scenario = linear_scenario(seed, steps=3)
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.0)] * 2)
    return Scenario(transition, scenario.measurement_model, scenario.truth,
                    scenario.detections, ft.GaussianState(scenario.prior.state_vector,
                                                          np.zeros((4, 4)), timestamp=0.0))

def make_kalman(scenario, rng):
    return ft.KalmanPredictor(scenario.transition_model), ft.KalmanUpdater(scenario.measurement_model)


def make_akkf(scenario, rng):
    kernel = ft.QuadraticKernel(c=1, ialpha=1)
    return (ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, kernel),
            ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, kernel, rng=rng))


def dropout_scenario(seed):
    """The PF scenario with, in about a third of the runs, a NaN detection (a sensor
    dropout the filter must refuse)."""
    scenario = pf_scenario(seed)
    if scenario.detections[0].state_vector[1, 0] > 50.4:  # the first range: 50 +- 1 m
        scenario.detections[4].state_vector[:] = np.nan
    return scenario


def in_worker():
    """Whether this is a worker process (run_trials builds run 0's scenario in the calling
    process too, to check it up front)."""
    import multiprocessing
    return multiprocessing.parent_process() is not None


def killing_scenario(marker, seed):
    """The PF scenario, but the first call in any worker kills its process (SIGKILL): the
    marker is created atomically, so of two workers starting together only one dies."""
    if in_worker():
        try:
            os.close(os.open(marker, os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            return pf_scenario(seed)
        os.kill(os.getpid(), signal.SIGKILL)
    return pf_scenario(seed)


def assert_same_results(a, b):
    assert a.table.dtype.names == b.table.dtype.names
    for name in COLUMNS:
        np.testing.assert_array_equal(a.table[name], b.table[name], err_msg=name)
    assert [f.run for f in a.failures] == [f.run for f in b.failures]


@pytest.fixture(scope="module")
def serial_pf():
    return mc.run_trials(pf_scenario, make_pf, 12, seed=7, processes=1, progress=False)


def test_a_run_is_the_filter_on_its_own_seeds(serial_pf):
    run = 5
    run_seed = mc.run_seeds(7, 12)[run]
    scenario_seed, filter_seed = run_seed.spawn(2)
    scenario = pf_scenario(scenario_seed)
    predictor, updater = make_pf(scenario, np.random.default_rng(filter_seed))
    state, ess, track = scenario.prior, [], ft.Track()
    for detection in scenario.detections:
        prediction = predictor.predict(state, timestamp=detection.timestamp)
        weighted = ft.ParticleUpdater(scenario.measurement_model).update(
            ft.SingleHypothesis(prediction, detection))
        ess.append(1 / np.sum(weighted.weight ** 2))
        state = updater.resampler.resample(weighted)
        track.append(state)
    rows = serial_pf.table[serial_pf.table["run"] == run]
    np.testing.assert_array_equal(rows["step"], np.arange(10))
    np.testing.assert_array_equal(rows["time"], np.arange(10.0))
    errors = [np.hypot(*(s.mean[[0, 2], 0] - t.state_vector[[0, 2], 0]))
              for s, t in zip(track, scenario.truth)]
    np.testing.assert_allclose(rows["position_error"], errors, rtol=1e-12)
    np.testing.assert_allclose(rows["ess"], ess, rtol=1e-10)
    assert np.isnan(rows["nees"]).all() and np.isnan(rows["nis"]).all()
    assert (rows["step_seconds"] > 0).all()
    per_run = serial_pf.per_run()
    assert per_run["rmse"][run] == pytest.approx(ft.position_rmse(track, scenario.truth),
                                                 rel=1e-12)


def test_a_seed_sequence_gives_the_same_runs_each_time(serial_pf):
    root = np.random.SeedSequence(7)
    root.spawn(3)  # already spawned from: the runs still come from a fresh spawn
    again = mc.run_trials(pf_scenario, make_pf, 12, seed=root, processes=1, progress=False)
    assert_same_results(serial_pf, again)
    assert [s.spawn_key for s in mc.run_seeds(root, 2)] == [(0,), (1,)]


def test_results_do_not_depend_on_processes_or_batches(serial_pf):
    pooled = mc.run_trials(pf_scenario, make_pf, 12, seed=7, processes=2, batch_size=5,
                           progress=False)
    assert_same_results(serial_pf, pooled)
    single_batches = mc.run_trials(pf_scenario, make_pf, 12, seed=7, processes=1,
                                   batch_size=1, progress=False)
    assert_same_results(serial_pf, single_batches)


def test_kalman_nees_and_nis_are_chi_square():
    results = mc.run_trials(linear_scenario, make_kalman, 300, seed=11, processes=1,
                            progress=False)
    summary = {s.metric: s for s in results.summary()}
    assert set(summary) == {"rmse", "anees", "anis", "step_seconds"}
    assert summary["anees"].mean == pytest.approx(4.0, abs=0.3)
    assert summary["anis"].mean == pytest.approx(2.0, abs=0.2)
    # NIS per step, pooled over runs, is chi2(2)
    assert stats.kstest(results.table["nis"], stats.chi2(2).cdf).pvalue > 1e-3
    assert len(results.rmse_over_time()) == 15


def test_nees_and_nis_against_the_formulas():
    results = mc.run_trials(linear_scenario, make_kalman, 2, seed=3, processes=1,
                            progress=False)
    scenario_seed, _ = mc.run_seeds(3, 2)[1].spawn(2)
    scenario = linear_scenario(scenario_seed)
    predictor, updater = make_kalman(scenario, None)
    state, nees, nis = scenario.prior, [], []
    for detection, truth in zip(scenario.detections, scenario.truth):
        hypothesis = ft.SingleHypothesis(predictor.predict(state, detection.timestamp), detection)
        state = updater.update(hypothesis)
        e = state.state_vector[:, 0] - truth.state_vector[:, 0]
        nees.append(e @ np.linalg.inv(state.covar) @ e)
        z = hypothesis.measurement_prediction
        v = detection.state_vector[:, 0] - z.state_vector[:, 0]
        nis.append(v @ np.linalg.inv(z.covar) @ v)
    rows = results.table[results.table["run"] == 1]
    np.testing.assert_array_equal(rows["time"], np.arange(15.0))
    np.testing.assert_allclose(rows["nees"], nees, rtol=1e-9)
    np.testing.assert_allclose(rows["nis"], nis, rtol=1e-9)


def test_nis_wraps_the_bearing():
    sensor = ft.Cartesian2DToBearing(4, (0, 2), np.array([[0.01]]))
    predicted = ft.GaussianMeasurementPrediction([[np.pi - 0.05]], [[0.01]])
    hypothesis = ft.SingleHypothesis(None, ft.Detection([[-np.pi + 0.05]]))
    hypothesis.measurement_prediction = predicted
    (nis,) = mc.metrics._score(("nis",), None, None, hypothesis, sensor, [0, 2], np.nan, 0.0)
    assert nis == pytest.approx(0.1 ** 2 / 0.01)


def test_adaptive_kernel_filter_runs():
    scenario = functools.partial(adaptive_kernel_tutorial, n_particles=20, steps=8)
    results = mc.run_trials(scenario, make_akkf, 4, seed=2, processes=1, progress=False)
    assert not results.failures
    assert np.isfinite(results.table["position_error"]).all()
    assert [s.metric for s in results.summary()] == ["rmse", "step_seconds"]


def test_summary_is_a_t_interval_of_the_log_mean():
    table = np.zeros(6, mc.metrics._row_dtype(("position_error", "nees")))
    table["run"] = [0, 0, 1, 1, 2, 2]
    table["step"] = [0, 1] * 3
    table["position_error"] = [3.0, 4.0, 1.0, 1.0, 0.0, 2.0]
    table["nees"] = [1.0, np.nan, 2.0, 4.0, 5.0, 7.0]
    results = mc.TrialResults(table, [], np.random.SeedSequence(0), 3)
    rmse = np.sqrt([12.5, 1.0, 2.0])
    summary = {s.metric: s for s in results.summary(confidence=0.9)}
    low, high = stats.t.interval(0.9, 2, loc=np.log(rmse.mean()),
                                 scale=stats.sem(rmse) / rmse.mean())
    assert (summary["rmse"].low, summary["rmse"].high) == pytest.approx(np.exp([low, high]))
    assert summary["anees"].mean == pytest.approx(np.mean([1.0, 3.0, 6.0]))
    np.testing.assert_allclose(results.rmse_over_time(), np.sqrt([10 / 3, 7.0]))
    assert "3 of 3 runs completed" in str(results)


def test_summary_interval_of_a_skewed_positive_metric_stays_positive():
    table = np.zeros(3, mc.metrics._row_dtype(("step_seconds",)))
    table["run"] = [0, 1, 2]
    table["step_seconds"] = [1e-3, 2e-3, 0.5]  # one run paid for compilation
    (summary,) = mc.TrialResults(table, [], np.random.SeedSequence(0), 3).summary()
    assert 0 < summary.low < summary.mean < summary.high
    assert summary.mean - stats.t.ppf(0.975, 2) * stats.sem(table["step_seconds"]) < 0


def test_failing_runs_are_reported_and_the_others_complete():
    with pytest.warns(RuntimeWarning, match="runs failed"):
        results = mc.run_trials(dropout_scenario, make_pf, 16, seed=5, processes=1,
                                progress=False)
    expected = set()
    for run, run_seed in enumerate(mc.run_seeds(5, 16)):
        try:
            mc.run_trial(dropout_scenario, make_pf, run_seed)
        except ValueError:
            expected.add(run)
    assert 0 < len(expected) < 16
    assert {f.run for f in results.failures} == expected
    assert set(np.unique(results.table["run"])) == set(range(16)) - expected
    for failure in results.failures:
        assert failure.error.startswith("ValueError") and "NaN" in failure.error
        assert "Traceback" in failure.traceback
        with pytest.raises(ValueError, match="NaN"):
            mc.run_trial(dropout_scenario, make_pf, failure.seed)
    assert f"run {results.failures[0].run} failed" in str(results)


def test_killed_local_worker_is_replaced_and_its_batch_rerun(tmp_path, serial_pf):
    scenario = functools.partial(killing_scenario, str(tmp_path / "killed"))
    results = mc.run_trials(scenario, make_pf, 12, seed=7, processes=2, batch_size=3,
                            progress=False)
    assert (tmp_path / "killed").exists()
    assert_same_results(serial_pf, results)


def test_a_batch_that_always_kills_its_worker_fails_its_runs():
    def always_killing(seed):
        if in_worker():
            os.kill(os.getpid(), signal.SIGKILL)
        return pf_scenario(seed)

    with pytest.raises(RuntimeError, match="all 4 runs failed .* run 0: WorkerLost") as error:
        mc.run_trials(always_killing, make_pf, 4, seed=1, processes=2, max_retries=1,
                      progress=False)
    results = error.value.results
    assert [f.run for f in results.failures] == [0, 1, 2, 3]
    assert all("died 2 times" in f.error for f in results.failures)


@pytest.fixture(scope="module")
def dask_client():
    pytest.importorskip("distributed")
    with mc.local_cluster(2) as client:
        assert len(client.nthreads()) == 2
        yield client


def test_dask_results_equal_local_results(dask_client, serial_pf):
    results = mc.run_trials(pf_scenario, make_pf, 12, seed=7, client=dask_client,
                            batch_size=4, progress=False)
    assert_same_results(serial_pf, results)


def test_a_scheduler_address_connects_and_disconnects(dask_client, serial_pf):
    def connected():
        return len(dask_client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.clients))

    before = connected()
    results = mc.run_trials(pf_scenario, make_pf, 12, seed=7,
                            client=dask_client.scheduler.address, progress=False)
    assert_same_results(serial_pf, results)
    deadline = time.monotonic() + 10
    while connected() != before and time.monotonic() < deadline:
        time.sleep(0.1)
    assert connected() == before


def test_killed_dask_worker_task_is_retried(dask_client, serial_pf, tmp_path):
    scenario = functools.partial(killing_scenario, str(tmp_path / "killed"))
    results = mc.run_trials(scenario, make_pf, 12, seed=7, client=dask_client, batch_size=3,
                            progress=False)
    assert (tmp_path / "killed").exists()
    assert_same_results(serial_pf, results)


def test_failing_runs_on_dask(dask_client):
    with pytest.warns(RuntimeWarning):
        remote = mc.run_trials(dropout_scenario, make_pf, 8, seed=5, client=dask_client,
                               progress=False)
    with pytest.warns(RuntimeWarning):
        local = mc.run_trials(dropout_scenario, make_pf, 8, seed=5, processes=1,
                              progress=False)
    assert_same_results(local, remote)
    assert [f.error for f in local.failures] == [f.error for f in remote.failures]


mt_scenario = functools.partial(grid_targets, n_targets=9, steps=12, clutter_rate=5.0)


def make_tracker(scenario, rng):
    return MultiTargetTracker(scenario.transition_model, scenario.measurement_model,
                              np.zeros(4), np.diag([0.0, 1.0, 0.0, 1.0]), min_points=2)


def _same_except_time(a, b):
    names = [n for n in a.table.dtype.names if n != "step_seconds"]
    for name in names:
        np.testing.assert_array_equal(a.table[name], b.table[name])


@pytest.fixture(scope="module")
def serial_tracking():
    return mc.run_trials(mt_scenario, make_tracker, 6, seed=3, processes=1, progress=False)


def test_multi_target_runs_score_gospa_per_scan(serial_tracking):
    results = serial_tracking
    assert results.metrics == mc.MULTI_TARGET_METRICS and len(results.table) == 6 * 12
    parts = (results.table["gospa_localisation"] + results.table["gospa_missed"]
             + results.table["gospa_false"])
    np.testing.assert_allclose(results.table["gospa"], parts)  # p = 1
    first = results.table[results.table["step"] == 0]
    np.testing.assert_allclose(first["gospa"], 9 * 10.0 / 2)  # no confirmed track yet
    assert np.all(first["n_tracks"] == 0)
    over_time = results.mean_over_time("gospa")
    assert over_time[-1] < 0.5 * over_time[0]  # the tracker finds the targets
    assert {s.metric for s in results.summary()} == {
        "mean_gospa", "mean_localisation", "mean_missed", "mean_false", "mean_tracks",
        "mean_cardinality_error", "step_seconds"}
    with pytest.raises(ValueError, match="rmse_over_time needs the metric 'position_error'"):
        results.rmse_over_time()


def test_a_multi_target_run_is_the_tracker_on_its_scenario(serial_tracking):
    from fasttrack.metrics import gospa
    seed = mc.run_seeds(3, 6)[2]
    world = mt_scenario(seed=seed.spawn(2)[0])
    tracker = make_tracker(world, None)
    row = serial_tracking.table[serial_tracking.table["run"] == 2]
    for t, scan in enumerate(world.detections):
        tracks = tracker.step(scan, float(t))
        want = gospa(world.truths[t][:, [0, 2]], tracks.means[:, [0, 2]], 10.0)
        assert row["gospa"][t] == pytest.approx(want.distance, rel=1e-12)
        assert row["n_tracks"][t] == len(tracks)
        assert row["cardinality_error"][t] == abs(len(tracks) - len(world.truths[t]))


def test_multi_target_results_do_not_depend_on_processes(serial_tracking):
    results = mc.run_trials(mt_scenario, make_tracker, 6, seed=3, processes=2, batch_size=2,
                            progress=False)
    _same_except_time(serial_tracking, results)


def test_multi_target_runs_on_dask(dask_client, serial_tracking):
    results = mc.run_trials(mt_scenario, make_tracker, 6, seed=3, client=dask_client,
                            progress=False)
    _same_except_time(serial_tracking, results)


def test_multi_target_metric_names_and_cutoff_are_checked():
    with pytest.raises(ValueError, match="a multi-target scenario's gospa"):
        mc.run_trials(mt_scenario, make_tracker, 2, metrics=("position_error",), processes=1)
    with pytest.raises(ValueError, match="gospa_cutoff must be finite and > 0"):
        mc.run_trials(mt_scenario, make_tracker, 2, gospa_cutoff=0.0, processes=1)
    results = mc.run_trials(mt_scenario, make_tracker, 2, seed=1, metrics=("gospa",),
                            gospa_cutoff=4.0, processes=1, progress=False)
    assert results.metrics == ("gospa",)
    np.testing.assert_allclose(results.table["gospa"][results.table["step"] == 0], 9 * 2.0)


def test_bad_arguments():
    with pytest.raises(ValueError, match="n_runs"):
        mc.run_trials(pf_scenario, make_pf, 0)
    with pytest.raises(ValueError, match="metrics"):
        mc.run_trials(pf_scenario, make_pf, 2, metrics=("rmse",))
    with pytest.raises(ValueError, match="batch_size"):
        mc.run_trials(pf_scenario, make_pf, 2, batch_size=0, processes=1)
    with pytest.raises(TypeError, match="processes"):
        mc.run_trials(pf_scenario, make_pf, 2, processes=1.5)
    with pytest.raises(ValueError, match="processes is for local runs"):
        mc.run_trials(pf_scenario, make_pf, 2, processes=2, client=object())
    with pytest.raises(ValueError, match="seed"):
        mc.run_trials(pf_scenario, make_pf, 2, seed=-1)
    with pytest.raises(TypeError, match="seed"):
        mc.run_trials(pf_scenario, make_pf, 2, seed=np.random.default_rng(0))
    with pytest.raises(ValueError, match="position_mapping"):
        mc.run_trials(pf_scenario, make_pf, 2, position_mapping=(0, 0))
    with pytest.raises(ValueError, match="position_mapping"):
        mc.run_trials(pf_scenario, make_pf, 2, position_mapping=())
    with pytest.raises(TypeError, match="max_retries"):
        mc.run_trials(pf_scenario, make_pf, 2, max_retries=None)
    with pytest.raises(TypeError, match="run_seed"):
        mc.run_trial(pf_scenario, make_pf, 3)
    with pytest.raises(ValueError, match="n_runs"):
        mc.run_seeds(1, 0)
    with pytest.raises(ValueError, match="n_workers"):
        with mc.local_cluster(0):
            pass
    with pytest.raises(ValueError, match="confidence"):
        mc.TrialResults(np.zeros(0, mc.metrics._row_dtype(mc.METRICS)), [], None, 0).summary(1.0)


def test_asking_for_dask_without_it_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ImportError, match=r"fasttrack\[distributed\]"):
        mc.run_trials(pf_scenario, make_pf, 2, client="tcp://127.0.0.1:8786")
    with pytest.raises(ImportError, match=r"fasttrack\[distributed\]"):
        with mc.local_cluster(2):
            pass


def test_local_runs_work_without_dask(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    results = mc.run_trials(pf_scenario, make_pf, 2, seed=1, processes=1, progress=False)
    assert len(np.unique(results.table["run"])) == 2


def test_progress_bar(capsys, monkeypatch):
    bar = mc.runner._Progress(10, enabled=True)
    bar.start -= 5.0
    monkeypatch.setattr(bar, "tty", False)
    for _ in range(10):
        bar.advance(1)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 10 and lines[-1].startswith("[" + "#" * 30 + "] 10/10 runs")
    quiet = mc.runner._Progress(10, enabled=False)
    quiet.start -= 5.0
    quiet.advance(10)
    assert capsys.readouterr().err == ""


def test_dataframe():
    pytest.importorskip("pandas")
    results = mc.run_trials(pf_scenario, make_pf, 2, seed=1, processes=1, progress=False)
    frame = results.to_dataframe()
    assert list(frame.columns) == list(results.table.dtype.names) and len(frame) == 20


def test_a_dead_worker_costs_only_the_batch_it_was_running(tmp_path, serial_pf):
    """One SIGKILL with max_retries=0: the killed batch fails, every other run completes
    (queued batches and the batch on the other worker are not charged)."""
    scenario = functools.partial(killing_scenario, str(tmp_path / "killed"))
    with pytest.warns(RuntimeWarning, match="2 of 12 runs failed"):
        results = mc.run_trials(scenario, make_pf, 12, seed=7, processes=2, batch_size=2,
                                max_retries=0, progress=False)
    failed = [f.run for f in results.failures]
    assert len(failed) == 2 and failed[1] == failed[0] + 1 and failed[0] % 2 == 0
    assert all("died 1 times" in f.error for f in results.failures)
    kept = ~np.isin(serial_pf.table["run"], failed)
    for name in COLUMNS:
        np.testing.assert_array_equal(results.table[name], serial_pf.table[name][kept])


def test_a_position_mapping_outside_the_states_is_an_error_up_front():
    with pytest.raises(ValueError, match=r"position_mapping \(0, 5\) is outside the "
                                         r"scenario's 4-dimensional states"):
        mc.run_trials(pf_scenario, make_pf, 3, seed=1, position_mapping=(0, 5), progress=False)
    with pytest.raises(ValueError, match="position_mapping"):
        mc.run_trial(pf_scenario, make_pf, mc.run_seeds(1, 1)[0], position_mapping=(0, 5))

class _FlatTracks:
    means = np.zeros(4)


class _FlatTracker:
    def step(self, detections, time):
        return _FlatTracks()


@pytest.mark.parametrize("arguments, error, match", [
    (dict(client=42), TypeError, r"client must be a distributed.Client or a scheduler's "
                                 r"address \(a str\), got int"),
    (dict(scenario=lambda seed: None), TypeError,
     r"scenario\(seed=...\) must return a Scenario \(truth, detections, prior\) or a "
     r"MultiTargetScenario, got NoneType"),
    (dict(scenario=lambda: pf_scenario(1)), TypeError, "scenario must take a seed keyword"),
    (dict(position_mapping=(0, 2.0)), TypeError,
     r"position_mapping must hold integer indices, got 2.0"),
    (dict(position_mapping=(True, 2)), TypeError, "position_mapping must hold integer indices"),
    (dict(position_mapping=None), TypeError, "position_mapping must be a sequence"),
    (dict(position_mapping={0: 1, 2: 3}), TypeError, "position_mapping must be a sequence"),
    (dict(position_mapping=[[0, 2]]), TypeError, "position_mapping must hold integer indices"),
    (dict(position_mapping=(0, -1)), ValueError, r"position_mapping indices must lie in \[0,"),
    (dict(gospa_cutoff=1e301), ValueError, r"gospa_cutoff must lie in \[1e-300, 1e\+300\]"),
    (dict(gospa_cutoff=1e-310), ValueError, "gospa_cutoff must lie in"),
    (dict(n_runs=2**40), ValueError, "n_runs=1099511627776 needs"),
    (dict(processes=10**6), ValueError, "processes must be <= 1024, got 1000000"),
])
def test_run_trials_names_bad_arguments_up_front(arguments, error, match):
    arguments = {"scenario": pf_scenario, "make_filter": make_pf, "n_runs": 2,
                 "processes": 1, "progress": False, **arguments}
    if "client" in arguments:
        del arguments["processes"]
    with pytest.raises(error, match=match):
        mc.run_trials(**arguments)


def test_a_position_mapping_may_be_any_sequence_of_indices():
    ranged = mc.run_trials(pf_scenario, make_pf, 2, seed=3, position_mapping=range(0, 3, 2),
                           processes=1, progress=False)
    listed = mc.run_trials(pf_scenario, make_pf, 2, seed=3, position_mapping=[0, 2],
                           processes=1, progress=False)
    np.testing.assert_array_equal(ranged.table["position_error"],
                                  listed.table["position_error"])


def test_tracks_of_the_wrong_shape_fail_their_run_naming_the_means():
    """Tracks with 1-D means failed every run with NumPy's 'too many indices'."""
    with pytest.raises(RuntimeError, match=r"the tracker's step must return tracks with means "
                                           r"of shape \(K, 4\) .* got _FlatTracks with means "
                                           r"of shape \(4,\)"):
        mc.run_trials(mt_scenario, lambda scenario, rng: _FlatTracker(), 2, processes=1,
                      progress=False)


@pytest.mark.parametrize("confidence, error", [("0.9", TypeError), (None, TypeError),
                                               (np.array([0.5, 0.9]), TypeError),
                                               (True, TypeError), (1.0, ValueError)])
def test_a_summary_names_a_bad_confidence(confidence, error):
    results = mc.TrialResults(np.zeros(0, mc.metrics._row_dtype(mc.METRICS)), [], None, 0)
    with pytest.raises(error, match="confidence"):
        results.summary(confidence)


def test_an_imm_run_scores_the_nees_of_its_moment_matched_posterior():
    """An IMM posterior (a mixture) had NaN NEES, silently."""
    def imm_scenario(seed):
        world = linear_scenario(seed, steps=6)
        prior = ft.GaussianMixture([ft.WeightedGaussianState(
            world.prior.state_vector, world.prior.covar, weight=0.5, timestamp=0.0)] * 2)
        return Scenario(world.transition_model, world.measurement_model, world.truth,
                        world.detections, prior)

    def make_imm(scenario, rng):
        models = [ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)
                  for q in (0.1, 5.0)]
        matrix = [[0.95, 0.05], [0.05, 0.95]]
        return (ft.IMMPredictor([ft.KalmanPredictor(m) for m in models], matrix),
                ft.IMMUpdater([ft.KalmanUpdater(scenario.measurement_model)] * 2, matrix))

    table = mc.run_trial(imm_scenario, make_imm, mc.run_seeds(4, 1)[0], metrics=("nees",))
    world = imm_scenario(mc.trial._children(mc.run_seeds(4, 1)[0], 2)[0])
    predictor, updater = make_imm(world, None)
    state = world.prior
    for step, (detection, truth) in enumerate(zip(world.detections, world.truth)):
        state = updater.update(ft.SingleHypothesis(
            predictor.predict(state, timestamp=detection.timestamp), detection))
        error = np.ravel(state.mean) - np.ravel(truth.state_vector)
        assert table["nees"][step] == pytest.approx(error @ np.linalg.solve(state.covar, error),
                                                    rel=1e-9)


def test_nees_of_a_singular_posterior_is_named():
    """A posterior covariance of zero has no inverse: the NEES was numpy's LinAlgError."""
    with pytest.raises(ValueError, match="metric 'nees': the posterior covariance is not "
                                         "positive definite"):
        mc.run_trial(known_scenario, make_kalman, mc.run_seeds(1, 1)[0])
    table = mc.run_trial(known_scenario, make_kalman, mc.run_seeds(1, 1)[0],
                         metrics=("position_error", "nis"))
    assert np.isfinite(table["nis"]).all()


_UNGUARDED = """
import functools
import fasttrack as ft
from fasttrack.scenarios import particle_filter_tutorial


def make_filter(scenario, rng):
    return (ft.ParticlePredictor(scenario.transition_model, rng=rng),
            ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=rng)))

scenario = functools.partial(particle_filter_tutorial, 50, steps=3)
{call}
"""
_CALL = "print(ft.run_trials(scenario, make_filter, 4, seed=1, processes=2, progress=False))"


@pytest.mark.parametrize("guarded", [False, True])
def test_a_script_without_the_main_guard_is_told_so(tmp_path, guarded):
    call = f'if __name__ == "__main__":\n    {_CALL}' if guarded else _CALL
    script = tmp_path / "trials.py"
    script.write_text(_UNGUARDED.format(call=call))
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=600)
    if guarded:
        assert done.returncode == 0, done.stderr[-2000:]
        assert "4 of 4 runs completed" in done.stdout
    else:
        assert done.returncode == 1
        assert "outside an 'if __name__ == \"__main__\":' block" in done.stderr
        assert "processes=1" in done.stderr and "WorkerLost" not in done.stderr


def test_one_process_needs_nothing_picklable():
    local = lambda seed: pf_scenario(seed)  # noqa: E731 (a lambda cannot be pickled)
    results = mc.run_trials(local, make_pf, 2, seed=3, processes=1, progress=False)
    assert not results.failures and len(results.per_run()) == 2


def test_compilation_is_not_timed_as_a_step():
    calls = []

    def counting(scenario, rng):
        calls.append(1)
        return make_pf(scenario, rng)

    mc.run_trials(pf_scenario, counting, 3, seed=2, processes=1, progress=False)
    assert len(calls) == 4  # one untimed run first, in a process new to this filter
    mc.run_trials(pf_scenario, counting, 3, seed=2, processes=1, progress=False)
    assert len(calls) == 7  # the same filter in the same process is warm already
