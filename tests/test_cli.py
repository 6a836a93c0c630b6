"""The command line (``python -m fasttrack``) and the demo without the optional packages."""
import subprocess
import sys

import pytest

import fasttrack

_NO_MATPLOTLIB = "import sys; sys.modules['matplotlib'] = None; "


def _cli(*args, prelude=""):
    code = prelude + "from fasttrack.__main__ import main; raise SystemExit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", "import sys; " + code, *args],
                          capture_output=True, text=True, timeout=900)


def test_version_and_description():
    done = _cli("--version")
    assert done.returncode == 0 and done.stdout.strip() == f"fasttrack {fasttrack.__version__}"
    helped = _cli("--help")
    assert "tracking and state estimation" in helped.stdout
    assert "--quick about 50 s the first time" in " ".join(_cli("demo", "--help").stdout.split())


def test_a_mistyped_option_gets_a_suggestion():
    for typed, meant in (("--fast", "--quick"), ("--qiuck", "--quick"), ("--noplots", "--no-plots")):
        done = _cli("demo", typed)
        assert done.returncode == 2 and f"(did you mean {meant}?)" in done.stderr, done.stderr
    done = _cli("warmup", "--familes", "kalman")
    assert "(did you mean --families?)" in done.stderr


@pytest.mark.slow
def test_the_demo_runs_without_matplotlib_and_says_how_to_get_plots(tmp_path):
    out = tmp_path / "plots"
    done = _cli("demo", "--quick", "--out", str(out), prelude=_NO_MATPLOTLIB)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.count("pip install 'fasttrack[plot]'") == 1
    assert "Time per step" in done.stdout and "ready after" in done.stdout
    assert not out.exists()


def test_plotting_without_matplotlib_names_the_extra():
    done = subprocess.run([sys.executable, "-c", _NO_MATPLOTLIB + "import fasttrack.plotting"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 1
    assert "fasttrack.plotting needs matplotlib: pip install 'fasttrack[plot]'" in done.stderr
