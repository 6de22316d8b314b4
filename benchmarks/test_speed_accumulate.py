"""Eq. 4 from packed `.dat` bytes at 1000×1000 and 250×400 against np.unpackbits + sum."""

import importlib

import numpy as np
import pytest

from benchmarks.conftest import best_time
from spikeref.stream import SpikeStream

acc = importlib.import_module("spikeref.accumulate")

PLANES = 1000
SIZES = {"1000x1000": (1000, 1000), "250x400": (250, 400)}


@pytest.fixture(scope="module", params=list(SIZES))
def stream(request):
    h, w = SIZES[request.param]
    rng = np.random.default_rng(0)
    # random bytes: every pixel fires with probability 1/2, the worst case for nothing
    packed = rng.integers(0, 256, (PLANES, h * w // 8), dtype=np.uint8)
    return SpikeStream.from_packed(packed, h, w)


def _unpack_sum(stream, window, n_windows):
    H, W = stream.height, stream.width
    out = np.empty((n_windows, H, W), np.uint16)
    for k in range(n_windows):
        bits = np.unpackbits(stream.packed[k * window : (k + 1) * window], axis=1, bitorder="little")
        out[k] = bits.reshape(window, H, W)[:, ::-1].sum(axis=0)
    return out


@pytest.mark.parametrize("window", [10, 100])
@pytest.mark.parametrize("kind", ["counts", "rates"])
def test_eq4_packed(benchmark, report, stream, window, kind):
    H, W = stream.height, stream.width
    chunk = max(1, 200 // window)  # windows per call: a streaming reader's chunk
    if kind == "counts":
        out = np.empty((chunk, H, W), np.uint8)
        step = lambda s: acc.window_counts(stream, window, start=s, count=chunk, out=out)  # noqa: E731
    else:
        out = np.empty((chunk, H, W), np.float32)
        step = lambda s: acc.accumulate(stream, window, start=s, count=chunk, out=out)  # noqa: E731
    starts = range(0, PLANES - chunk * window + 1, chunk * window)
    planes = len(starts) * chunk * window

    def run():
        for s in starts:
            step(s)

    run()  # compile
    benchmark.pedantic(run, rounds=5, iterations=1)
    fast = benchmark.stats.stats.median
    n_base = 2
    base = best_time(lambda: _unpack_sum(stream, window, n_base), repeat=2) / (n_base * window)
    rate = planes / fast
    benchmark.extra_info.update(planes_per_s=rate, unpackbits_planes_per_s=1 / base)
    report(f"eq4 packed {H}x{W} {kind} W={window}", f"{rate:9.0f} planes/s; unpackbits+sum {1 / base:7.0f} planes/s; "
           f"ratio {rate * base:5.1f}x")
