"""bench/report.py: ratios from pytest-benchmark JSON, target checks and the plot."""
import json
import pathlib
import subprocess
import sys

import pytest

REPORT = pathlib.Path(__file__).resolve().parents[1] / "bench" / "report.py"


def _bench(name, group, median, implementation=None):
    return {"name": name, "group": group, "stats": {"median": median},
            "params": {"implementation": implementation} if implementation else {},
            "extra_info": {}}


def _write(tmp_path, benchmarks):
    path = tmp_path / "run.json"
    path.write_text(json.dumps({"benchmarks": benchmarks, "machine_info": {}}))
    return path


def _run(*args):
    return subprocess.run([sys.executable, str(REPORT), *map(str, args)], capture_output=True,
                          text=True)


def test_ratios_and_a_missed_target_named(tmp_path):
    path = _write(tmp_path, [
        _bench("test_fasttrack_ekf_step", "ekf-step N=1", 1e-5),
        _bench("test_stonesoup_ekf_step", "ekf-step N=1", 5e-4),
        _bench("test_pf_loop[dropin-1000]", "dropin-pf N=1000", 2e-3, "dropin"),
        _bench("test_pf_loop[fasttrack-1000]", "dropin-pf N=1000", 1e-3, "fasttrack"),
        _bench("test_pf_loop[stonesoup-1000]", "dropin-pf N=1000", 8e-3, "stonesoup"),
    ])
    done = _run(path)
    assert done.returncode == 0
    assert "| ekf-step | 1e+00 | 0.01 ms |  | 0.5 ms | 50x |" in done.stdout
    assert "| dropin-pf | 1e+03 | 1 ms | 2 ms | 8 ms | 4x | 2x |" in done.stdout
    checked = _run(path, "--check")
    assert checked.returncode == 1
    assert "MISSED: ekf-step N=1: stonesoup ratio 50 < target 60" in checked.stdout
    assert "MISSED: resample-systematic N=1000000: stonesoup ratio not measured" in checked.stdout


def test_a_floor_of_the_workload_itself_comes_before_its_family_s(tmp_path):
    floor = _bench("test_floor", "rts-smoother-floor", 1e-3)
    floor["extra_info"]["n"] = 1000
    path = _write(tmp_path, [floor,
                             _bench("test_rts_fasttrack", "rts-smoother N=1000", 2e-3),
                             _bench("test_rts_arrays_fasttrack", "rts-smoother-arrays N=1000",
                                    3e-4)])
    done = _run(path)
    assert done.returncode == 0
    assert "| rts-smoother | 1e+03 | 2 ms |  |  |  |  | 2x |" in done.stdout
    assert "| rts-smoother-arrays | 1e+03 | 0.3 ms |  |  |  |  |  |" in done.stdout


def test_plot_is_written(tmp_path):
    pytest.importorskip("matplotlib")
    path = _write(tmp_path, [_bench("test_fasttrack_x", f"pf-step N={n}", n * 1e-8)
                             for n in (10**3, 10**4)])
    done = _run(path, "--plot", tmp_path / "plot.png")
    assert done.returncode == 0 and (tmp_path / "plot.png").stat().st_size > 5000


def test_montecarlo_table(tmp_path):
    def runs(setup, median):
        return {"name": f"test_thousand_pf_runs[{setup}]", "group": "montecarlo-pf runs=1000",
                "stats": {"median": median}, "params": {"setup": setup},
                "extra_info": {"runs": 1000}}

    startup = _bench("test_startup[local-2]", "montecarlo-startup", 1.25)
    startup["params"] = {"setup": "local-2"}
    path = _write(tmp_path, [runs("serial", 5.0), runs("local-2", 2.5), runs("dask-2", 3.0),
                             startup])
    done = _run(path)
    assert done.returncode == 0
    assert "| local-2 | 1,000 | 2.5 s | 400 | 2x | 1.2 s |" in done.stdout
    assert "| dask-2 | 1,000 | 3 s | 333 | 1.67x |  |" in done.stdout
    assert "Dask overhead per run over the local pool: 0.5 ms" in done.stdout
