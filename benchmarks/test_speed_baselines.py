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


def _tfi_numpy(spikes, times):
    return tfi_oracle(spikes)[times]  # the oracle computes every plane; TFI needs the whole pass anyway


def _tfstp_numpy(spikes, times):
    return tfstp_oracle(spikes, times=times)


@pytest.mark.parametrize("every", [1, 10])
@pytest.mark.parametrize("name, fast, slow", [("tfi", tfi, _tfi_numpy), ("tfstp", tfstp, _tfstp_numpy)])
def test_baseline_250x400(benchmark, report, spikes, name, fast, slow, every):
    """Frames at every plane (SpikeCV's spikes2images) and every 10th plane (2000 FPS output)."""
    times = np.arange(0, PLANES, every)
    fast(spikes[:10])  # compile
    benchmark.pedantic(lambda: fast(spikes, times), rounds=5, iterations=1)
    t_fast = benchmark.stats.stats.median
    t_slow = best_time(lambda: slow(spikes, times), repeat=1)
    benchmark.extra_info.update(planes_per_s=PLANES / t_fast, numpy_planes_per_s=PLANES / t_slow)
    report(f"{name} 250x400, a frame every {every} plane(s)",
           f"{PLANES / t_fast:9.0f} planes/s; NumPy loop {PLANES / t_slow:7.0f} planes/s; "
           f"ratio {t_slow / t_fast:5.1f}x")
