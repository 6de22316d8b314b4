"""Speed suites (pytest-benchmark).  Run with::

    python -m pytest benchmarks --benchmark-enable -q

Every fast path is measured against a baseline measured in the same run (a
straightforward NumPy implementation), and the ratio is printed at the end, so
figures stay comparable on a noisy machine.  Nothing here asserts a time.
"""

import time

import pytest

RESULTS: list[tuple[str, str]] = []


def best_time(fn, repeat: int = 3) -> float:
    """Best wall time of ``repeat`` calls of ``fn`` (seconds)."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


@pytest.fixture
def report():
    def _report(name: str, text: str) -> None:
        RESULTS.append((name, text))

    return _report


def pytest_terminal_summary(terminalreporter):
    if RESULTS:
        terminalreporter.section("spikeref speed (same-run ratios)")
        for name, text in RESULTS:
            terminalreporter.write_line(f"{name:42s} {text}")
