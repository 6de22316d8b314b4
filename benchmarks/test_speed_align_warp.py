"""Alignment (HDR+ tiles → dense flow) and warping (Eq. 14/15) at 250×400 and 1000×1000.

Baselines in the same run: the literal oracle of the alignment (Python loops over tiles and
offsets, `spikeref.oracles.align.align_oracle`, timed at 250×400 only — minutes at 1000×1000)
and SciPy's `map_coordinates` (order 1) for the bilinear warp of K = 3 frames of 4 Bayer planes.
"""

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter, map_coordinates

from benchmarks.conftest import best_time
from spikeref.align import align
from spikeref.oracles.align import align_oracle
from spikeref.warp import warp_average

SIZES = {"250x400": (125, 200), "1000x1000": (500, 500)}  # the Bayer-plane grid of each frame size


def _pair(h, w):
    rng = np.random.default_rng(0)
    tex = gaussian_filter(rng.random((h + 16, w + 16)), 1.5).astype(np.float32)
    return tex[8:-8, 8:-8], tex[5:-11, 10:-6]  # moved by (3, −2) plane pixels


@pytest.mark.parametrize("size", list(SIZES))
def test_align(benchmark, report, size):
    h, w = SIZES[size]
    ref, alt = _pair(h, w)
    align(ref, alt, 0)  # compile
    benchmark.pedantic(lambda: align(ref, alt, 0), rounds=5, iterations=1)
    t = benchmark.stats.stats.median
    text = f"{t * 1e3:8.1f} ms per flow (one pair, step 0)"
    if size == "250x400":
        base = best_time(lambda: align_oracle(ref, alt, 0), repeat=1)
        text += f"; literal oracle {base:6.1f} s; ratio {base / t:6.0f}x"
    report(f"align {size}", text)


def _map_coordinates_average(frames, flows):
    k, c, h, w = frames.shape
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    out = np.zeros((c, h, w))
    for i in range(k):
        coords = [yy + flows[i, 0], xx + flows[i, 1]]
        for ch in range(c):
            out[ch] += map_coordinates(frames[i, ch], coords, order=1, mode="nearest")
    return out / k


@pytest.mark.parametrize("size", list(SIZES))
def test_warp_average(benchmark, report, size):
    h, w = SIZES[size]
    rng = np.random.default_rng(1)
    frames = rng.random((3, 4, h, w)).astype(np.float32)
    flows = (rng.random((3, 2, h, w)) * 4 - 2).astype(np.float32)
    flows[1] = 0
    warp_average(frames, flows)  # compile
    benchmark.pedantic(lambda: warp_average(frames, flows), rounds=5, iterations=1)
    t = benchmark.stats.stats.median
    base = best_time(lambda: _map_coordinates_average(frames, flows), repeat=2)
    report(f"warp K=3 ×4 planes {size}", f"{t * 1e3:8.1f} ms; scipy map_coordinates {base * 1e3:8.1f} ms; "
           f"ratio {base / t:5.1f}x")
