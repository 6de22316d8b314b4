"""The robust merge with its adaptive support (spikeref.merge), compiled: ms per frame and the ratio to a plain
weighted mean of the same samples (NumPy, Eq. 14–15's arithmetic), measured in the same run.

Input: 41 windows (7 core, shells to 20) or 21 (to 10) of 4 Bayer planes of a 250×400 or 1000×1000 frame, a smooth
texture with noise and a block that some windows show displaced (what the merge must drop).
"""

import numpy as np
import pytest

from benchmarks.conftest import best_time
from spikeref.merge import MergeParams, default_shells, robust_merge


def _inputs(h, w, support, seed=0):
    rng = np.random.default_rng(seed)
    n = 2 * support + 1
    y, x = np.mgrid[0:h, 0:w]
    scene = 0.3 + 0.2 * np.sin(x / 5.0) * np.cos(y / 7.0)
    s = (scene[None, None] + rng.normal(0, 0.03, (n, 4, h, w))).astype(np.float32)
    s[:, :, h // 3:h // 2, w // 4:w // 3] += ((rng.random((n, 1, 1, 1)) < 0.4) * 0.3).astype(np.float32)
    core = np.abs(np.arange(n) - support) <= 3
    return s, np.ones((n, h, w), np.float32), np.full((4, h, w), 0.03 ** 2), support, core


@pytest.mark.parametrize("support", [10, 20])
@pytest.mark.parametrize("size", [(125, 200), (500, 500)], ids=["250x400", "1000x1000"])
def test_merge_speed(benchmark, report, size, support):
    s, weights, noise, ref, core = _inputs(*size, support)
    params = MergeParams(shells=default_shells(3, support))
    robust_merge(s, weights, noise, ref, core, params, check=False)  # compile
    t = benchmark.pedantic(lambda: best_time(lambda: robust_merge(s, weights, noise, ref, core, params,
                                                                  check=False), repeat=5), rounds=1, iterations=1)
    base = best_time(lambda: (weights[:, None] * s).sum(axis=0) / weights.sum(axis=0), repeat=5)
    report(f"robust merge, support {support}, {size[0] * 2}x{size[1] * 2}",
           f"{t * 1e3:7.1f} ms; plain weighted mean {base * 1e3:6.1f} ms; ratio {t / base:4.1f}x")
