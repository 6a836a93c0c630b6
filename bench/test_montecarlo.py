"""Monte Carlo throughput: 1,000 runs of the particle-filter tutorial (21 steps, N = 1000,
systematic resampling every step), each scenario simulated from its run's seed, scored with
every metric: in this process on one Numba thread, on a local pool of 2 worker processes,
and on a 2-worker Dask LocalCluster (one thread each); and 1,000 runs of a 20-target
scenario (30 scans, clutter, P_D = 0.9) tracked by the multi-target tracker and scored by
GOSPA, on the Dask cluster; and 1,000 runs of Vo and Ma's PHD scenario by the GM-CPHD tracker
on the local pool.

The local pool and the cluster are started, and their kernels compiled, before timing;
``test_startup`` times what a fresh pool and a fresh cluster cost before their first run.
``python bench/report.py`` turns the medians into runs per second and the Dask path's
overhead per run over the local pool.
"""
import functools

import pytest

import fasttrack as ft
from fasttrack import montecarlo
from fasttrack.scenarios import grid_targets, particle_filter_tutorial
from fasttrack.tracker import MultiTargetTracker

N_RUNS = 1000
SCENARIO = functools.partial(particle_filter_tutorial, n_particles=1000)
TARGETS = functools.partial(grid_targets, n_targets=20, steps=30, clutter_rate=20.0)


def make_filter(scenario, rng):
    return (ft.ParticlePredictor(scenario.transition_model, rng=rng),
            ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=rng)))


def make_tracker(scenario, rng):
    return MultiTargetTracker(scenario.transition_model, scenario.measurement_model,
                              [0.0] * 4, [[0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0],
                                          [0, 0, 0, 1]], missed_distance=3.0, min_points=3)


@pytest.fixture(scope="module")
def cluster():
    pytest.importorskip("distributed")
    with montecarlo.local_cluster(2) as client:
        yield client


def _trials(n_runs, where):
    return ft.run_trials(SCENARIO, make_filter, n_runs, seed=1, progress=False, **where)


@pytest.mark.parametrize("setup", ["serial", "local-2", "dask-2"])
def test_thousand_pf_runs(benchmark, setup, request):
    benchmark.group = f"montecarlo-pf runs={N_RUNS}"
    benchmark.extra_info["runs"] = N_RUNS
    where = ({"client": request.getfixturevalue("cluster")} if setup == "dask-2"
             else {"processes": 1 if setup == "serial" else 2})
    threads = ft.get_threads()
    ft.set_threads(1)  # for the serial setup: one core (workers use one thread each)
    try:
        _trials(8, where)  # workers started, kernels loaded
        results = benchmark.pedantic(lambda: _trials(N_RUNS, where), rounds=3, iterations=1)
    finally:
        ft.set_threads(threads)
    assert not results.failures and len(results.table) == 21 * N_RUNS


@pytest.mark.parametrize("setup", ["local-2", "dask-2"])
def test_startup(benchmark, setup):
    """A fresh pool or cluster, to the end of its first 2 runs (kernels from the cache)."""
    benchmark.group = "montecarlo-startup"
    if setup == "dask-2":
        pytest.importorskip("distributed")

    def local():
        montecarlo.workers._local_pool(2).shutdown()
        montecarlo.workers._pool.clear()
        ft.run_trials(SCENARIO, make_filter, 2, seed=0, processes=2, progress=False)

    def dask():
        with montecarlo.local_cluster(2) as client:
            ft.run_trials(SCENARIO, make_filter, 2, seed=0, client=client, progress=False)

    benchmark.pedantic(local if setup == "local-2" else dask, rounds=3, iterations=1)


def test_thousand_multi_target_runs_on_dask(benchmark, cluster):
    benchmark.group = f"montecarlo-mtt runs={N_RUNS}"
    benchmark.extra_info["runs"] = N_RUNS

    def trials(n_runs):
        return ft.run_trials(TARGETS, make_tracker, n_runs, seed=1, client=cluster,
                             progress=False)

    trials(8)  # kernels loaded on the workers
    results = benchmark.pedantic(lambda: trials(N_RUNS), rounds=1, iterations=1)
    assert not results.failures and len(results.table) == 30 * N_RUNS
    assert results.mean_over_time("gospa")[-1] < 40  # 20 targets: c / 2 = 5 m each if lost


def _vo_linear(seed):
    from fasttrack.scenarios import vo_linear
    return vo_linear(clutter_rate=10.0, seed=seed)


def make_cphd(scenario, rng):
    from fasttrack.scenarios import vo_linear_birth
    return ft.CPHDTracker(scenario.transition_model, scenario.measurement_model,
                          vo_linear_birth(), 0.98, 0.99, scenario.clutter_density, 10.0,
                          max_targets=30, gate_threshold=13.8)


def test_thousand_cphd_runs(benchmark):
    """1,000 runs of Vo and Ma's linear scenario (100 scans, clutter 10) by the GM-CPHD
    tracker, scored by GOSPA (c = 100 m) and the cardinality error, on a local pool of 2
    worker processes."""
    benchmark.group = f"montecarlo-cphd runs={N_RUNS}"
    benchmark.extra_info["runs"] = N_RUNS

    def trials(n_runs):
        return ft.run_trials(_vo_linear, make_cphd, n_runs, seed=1, processes=2,
                             gospa_cutoff=100.0, progress=False)

    trials(8)  # workers started, kernels loaded
    results = benchmark.pedantic(lambda: trials(N_RUNS), rounds=1, iterations=1)
    assert not results.failures and len(results.table) == 100 * N_RUNS
    assert results.per_run()["mean_cardinality_error"].mean() < 1.0
