"""The benchmarks (a package, so that pytest names their modules ``bench.test_<family>`` and
they do not clash with ``tests/test_<family>.py`` when both folders run at once)."""
