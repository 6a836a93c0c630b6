"""The ported tutorials in docs/examples run headless, and write their plots."""
import os
import pathlib
import subprocess
import sys

import pytest

EXAMPLES = sorted((pathlib.Path(__file__).resolve().parents[1] / "docs" / "examples")
                  .glob("*.py"))


def test_the_tutorials_are_there():
    assert [e.stem for e in EXAMPLES] == ["adaptive_kernel_kalman_filter",
                                          "extended_kalman_filter", "multiple_models",
                                          "particle_filter", "resampling"]


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda path: path.stem)
def test_example_runs_headless(example, tmp_path):
    pytest.importorskip("matplotlib")
    done = subprocess.run([sys.executable, str(example), str(tmp_path)], capture_output=True,
                          text=True, timeout=600, env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip()
    pngs = list(tmp_path.glob("*.png"))
    assert pngs and all(png.stat().st_size > 10_000 for png in pngs)


def test_guide_quick_start_runs():
    import re
    guide = (EXAMPLES[0].parents[1] / "guide.md").read_text()
    code = re.search(r"## Quick start\n\n```python\n(.*?)```", guide, re.S).group(1)
    namespace = {}
    exec(compile(code, "guide quick start", "exec"), namespace)
    assert len(namespace["track"]) == 21


@pytest.mark.slow
def test_docs_build_without_warnings_one_api_page_per_domain_and_a_gallery(tmp_path):
    pytest.importorskip("sphinx_gallery")
    docs = EXAMPLES[0].parents[1]
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-q", "-b", "html", str(docs),
                           str(tmp_path)], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr
    pages = {page.stem: page.read_text() for page in (tmp_path / "api").glob("*.html")}
    assert {"states", "models", "resampling", "filters", "stonesoup"} <= set(pages)
    assert "ParticleStateUpdate" in pages["states"] and "ESSResampler" in pages["resampling"]
    for helper in ("_SchemeResampler", "check_timestamp", "as_particle_state", "column_vector",
                   "dense_kernel_covar", "as_kernel", "rotation_matrix", "stream_key",
                   "in_chunks", "check_main_guard"):
        assert not any(helper in page for page in pages.values()), helper  # public names only
    assert (tmp_path / "guide.html").exists()  # the Markdown guides are in the site
    for example in EXAMPLES:  # each tutorial in the gallery, with the figures it drew
        assert (tmp_path / "tutorials" / f"{example.stem}.html").exists()
        assert list((tmp_path / "_images").glob(f"sphx_glr_{example.stem}_00*.png"))


def test_guide_monte_carlo_runs():
    import re
    guide = (EXAMPLES[0].parents[1] / "guide.md").read_text()
    code = re.search(r"## Monte Carlo evaluation\n.*?```python\n(.*?)```", guide, re.S).group(1)
    namespace = {"__name__": "__main__"}  # the snippet guards its work
    exec(compile(code, "guide monte carlo", "exec"), namespace)
    results = namespace["results"]
    assert not results.failures and len(namespace["rmse_by_step"]) == 21
    assert {s.metric for s in results.summary()} == {"rmse", "anees", "anis", "step_seconds"}


def test_guide_mixture_reduction_runs():
    import re
    guide = (EXAMPLES[0].parents[1] / "guide.md").read_text()
    code = re.search(r"### Gaussian mixtures\n.*?```python\n(.*?)```", guide, re.S).group(1)
    namespace = {}
    exec(compile(code, "guide mixtures", "exec"), namespace)
    assert 0 < len(namespace["reduced"]) < 1000


def test_guide_phd_tracker_runs():
    import re
    guide = (EXAMPLES[0].parents[1] / "guide.md").read_text()
    code = re.search(r"```python\n([^`]*?ft\.PHDTracker[^`]*?)```", guide, re.S).group(1)
    namespace = {}
    exec(compile(code, "guide phd", "exec"), namespace)
    assert 6 <= len(namespace["estimates"][-1]) <= 12


def test_guide_cphd_tracker_runs():
    import re
    guide = (EXAMPLES[0].parents[1] / "guide.md").read_text()
    code = re.search(r"```python\n([^`]*?ft\.CPHDTracker[^`]*?)```", guide, re.S).group(1)
    namespace = {}
    exec(compile(code, "guide cphd", "exec"), namespace)
    assert len(namespace["estimates"][-1]) == namespace["tracker"].most_probable_number == 10


def test_guide_imm_runs():
    import re
    guide = (EXAMPLES[0].parents[1] / "guide.md").read_text()
    code = re.search(r"```python\n([^`]*?ft\.BatchIMMFilter[^`]*?)```", guide, re.S).group(1)
    namespace = {}
    exec(compile(code, "guide imm", "exec"), namespace)
    assert namespace["probs"][0].argmax() == 2  # turning right: the -0.02 rad/s model


def test_guide_multi_target_runs():
    import re
    guide = (EXAMPLES[0].parents[1] / "guide.md").read_text()
    code = re.search(r"## Multi-target tracking\n.*?```python\n(.*?)```", guide, re.S).group(1)
    namespace = {}
    exec(compile(code, "guide multi-target", "exec"), namespace)
    tracks, scenario = namespace["tracks"], namespace["scenario"]
    assert len(tracks) == 40 and 14 <= len(tracks[-1]) <= 20


def test_guide_smoothing_runs():
    import re
    guide = (EXAMPLES[0].parents[1] / "guide.md").read_text()
    code = re.search(r"## Smoothing\n.*?```python\n(.*?)```", guide, re.S).group(1)
    namespace = {}
    exec(compile(code, "guide smoothing", "exec"), namespace)
    track, smoothed, paths = namespace["track"], namespace["smoothed"], namespace["paths"]
    assert len(smoothed) == len(track) == 20 and smoothed[-1] is track[-1]
    assert paths.shape == (20, 4, 100)
