"""`spikeref bench`: what accuracy costs in time, every method and setting on the same scenes in one run.

* :mod:`spikeref.bench.settings` — the methods, settings and grids (full and quick);
* :mod:`spikeref.bench.runner` — the benchmark scenes (``scenes/*.toml``, versioned), the
  scored instants, the timing rules, and the run;
* :mod:`spikeref.bench.report` — ``results.csv``, ``results.md``, ``pareto.png``, ``contact_sheet.png``.
"""

from spikeref.bench.runner import BENCH_VERSION, bench_scenes, run_bench, run_setting, score_centres
from spikeref.bench.settings import FULL_GRID, QUICK_GRID, BenchGrid, Setting, grid_settings, parse_grid
from spikeref.bench.report import pareto_front, write_report

__all__ = ["BENCH_VERSION", "bench_scenes", "run_bench", "run_setting", "score_centres", "FULL_GRID",
           "QUICK_GRID", "BenchGrid", "Setting", "grid_settings", "parse_grid", "pareto_front", "write_report"]
