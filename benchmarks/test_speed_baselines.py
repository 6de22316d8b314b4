"""TFI and TFSTP at 250×400 against straightforward per-frame NumPy loops (the oracles)."""

import numpy as np
import pytest

from benchmarks.conftest import best_time
from spikeref.baselines import tfi, tfstp
from spikeref.oracles import tfi_oracle, tfstp_oracle

H, W, PLANES = 250, 400, 400


@pytest.fixture(scope="module")
def spikes():
    rng = np.random.default_rng(1)
    rates = rng.uniform(0.01, 0.6, (H, W))
    return (rng.random((PLANES, H, W)) < rates).astype(np.uint8)


@pytest.mark.parametrize("name, fast, slow", [("tfi", tfi, tfi_oracle), ("tfstp", tfstp, tfstp_oracle)])
def test_baseline_every_plane_250x400(benchmark, report, spikes, name, fast, slow):
    fast(spikes[:10])  # compile
    benchmark.pedantic(lambda: fast(spikes), rounds=5, iterations=1)
    t_fast = benchmark.stats.stats.median
    t_slow = best_time(lambda: slow(spikes), repeat=1)
    benchmark.extra_info.update(frames_per_s=PLANES / t_fast, numpy_frames_per_s=PLANES / t_slow)
    report(f"{name} 250x400, every plane", f"{PLANES / t_fast:9.0f} frames/s; NumPy loop {PLANES / t_slow:7.0f} "
           f"frames/s; ratio {t_slow / t_fast:5.1f}x")
