"""TFI and TFSTP at 250×400 and 1000×1000 against straightforward per-frame NumPy loops (the oracles)."""

import numpy as np
import pytest

from benchmarks.conftest import best_time
from spikeref.baselines import tfi, tfstp
from spikeref.oracles import tfi_oracle, tfstp_oracle

SIZES = {"250x400": (250, 400, 400), "1000x1000": (1000, 1000, 100)}  # H, W, planes


@pytest.fixture(scope="module", params=list(SIZES))
def spikes(request):
    h, w, planes = SIZES[request.param]
    rng = np.random.default_rng(1)
    rates = rng.uniform(0.01, 0.6, (h, w))
    return request.param, (rng.random((planes, h, w)) < rates).astype(np.uint8)


def _tfi_numpy(spikes, times):
    return tfi_oracle(spikes)[times]  # the oracle computes every plane; TFI needs the whole pass anyway


def _tfstp_numpy(spikes, times):
    return tfstp_oracle(spikes, times=times)


@pytest.mark.parametrize("every", [1, 10])
@pytest.mark.parametrize("name, fast, slow", [("tfi", tfi, _tfi_numpy), ("tfstp", tfstp, _tfstp_numpy)])
def test_baseline(benchmark, report, spikes, name, fast, slow, every):
    """Frames at every plane (SpikeCV's spikes2images) and every 10th plane (2000 FPS output)."""
    size, spikes = spikes
    PLANES = spikes.shape[0]
    times = np.arange(0, PLANES, every)
    fast(spikes[:10])  # compile
    benchmark.pedantic(lambda: fast(spikes, times), rounds=5, iterations=1)
    t_fast = benchmark.stats.stats.median
    t_slow = best_time(lambda: slow(spikes, times), repeat=1)
    benchmark.extra_info.update(planes_per_s=PLANES / t_fast, numpy_planes_per_s=PLANES / t_slow)
    report(f"{name} {size}, a frame every {every} plane(s)",
           f"{PLANES / t_fast:9.0f} planes/s; NumPy loop {PLANES / t_slow:7.0f} planes/s; "
           f"ratio {t_slow / t_fast:5.1f}x")
