"""The README's main job: ``python -m fasttrack demo`` runs end to end."""
import subprocess
import sys


def test_quick_demo_runs():
    done = subprocess.run([sys.executable, "-m", "fasttrack", "demo", "--quick"],
                          capture_output=True, text=True, check=True, timeout=600)
    out = done.stdout
    assert "Resampler tutorial" in out and "expected N w" in out
    for name in ("systematic", "stratified", "multinomial", "residual"):
        assert out.count(name) >= 2
    assert "vs Stone Soup" in out and "Demo finished" in out


def test_cli_rejects_unknown_commands():
    done = subprocess.run([sys.executable, "-m", "fasttrack", "fly"], capture_output=True,
                          text=True)
    assert done.returncode == 2 and "invalid choice" in done.stderr
