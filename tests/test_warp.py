"""Eq. 14–15 warping: kernels against the plane-by-plane oracles, conservation, shifts, bad input."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.accumulate import accumulate
from spikeref.oracles.warp import eq14_oracle, eq15_oracle
from spikeref.warp import warp_average, warp_bilinear, warp_spike_windows


def _random_case(seed, k=3, c=4, h=9, w=11, reach=3.0):
    rng = np.random.default_rng(seed)
    frames = rng.random((k, c, h, w)).astype(np.float32)
    flows = rng.uniform(-reach, reach, (k, 2, h, w)).astype(np.float32)
    flows[k // 2] = 0.0  # the reference
    return frames, flows


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_eq15_kernel_equals_oracle(seed):
    frames, flows = _random_case(seed)  # flows reach outside the 9×11 image: the renormalisation is exercised
    np.testing.assert_allclose(warp_average(frames, flows), eq15_oracle(frames, flows), rtol=1e-5, atol=1e-6)


def test_eq14_counts_equal_plane_by_plane_sum():
    rng = np.random.default_rng(3)
    window, k = 4, 3
    spikes = (rng.random((k * window, 4, 8, 10)) < 0.3).astype(np.uint8)
    _, flows = _random_case(4, k=k, h=8, w=10, reach=2.5)
    counts = spikes.reshape(k, window, 4, 8, 10).sum(1)
    np.testing.assert_allclose(warp_spike_windows(counts, flows, window), eq14_oracle(spikes, flows, window),
                               rtol=1e-5, atol=1e-6)


def test_zero_flow_is_plain_accumulation():
    # energy conservation: Eq. 14 with zero flow is Eq. 4 over K·W planes
    rng = np.random.default_rng(5)
    window, k = 5, 3
    spikes = (rng.random((k * window, 4, 6, 7)) < 0.4).astype(np.uint8)
    counts = spikes.reshape(k, window, 4, 6, 7).sum(1)
    got = warp_spike_windows(counts, np.zeros((k, 2, 6, 7), np.float32), window)
    want = accumulate(spikes.reshape(k * window, 4 * 6, 7), window=k * window)[0].reshape(4, 6, 7)
    np.testing.assert_allclose(got, want, rtol=1e-6)


def test_integer_shift_is_undone():
    rng = np.random.default_rng(6)
    ref = rng.random((2, 20, 24)).astype(np.float32)
    alt = np.roll(ref, (3, -2), axis=(1, 2))  # alt[y + 3, x - 2] = ref[y, x]
    flow = np.zeros((2, 20, 24), np.float32)
    flow[0], flow[1] = 3, -2
    warped, weight = warp_bilinear(alt, flow)
    np.testing.assert_array_equal(warped[:, :17, 2:], ref[:, :17, 2:])
    assert weight[:17, 2:].min() == 1.0 and weight[18:, :].max() == 0.0


def test_half_pixel_shift_averages_neighbours_and_border_weight():
    img = np.arange(12, dtype=np.float32).reshape(3, 4)
    flow = np.zeros((2, 3, 4), np.float32)
    flow[1] = 0.5
    warped, weight = warp_bilinear(img, flow)
    np.testing.assert_allclose(warped[:, :3], (img[:, :3] + img[:, 1:]) / 2)
    np.testing.assert_array_equal(warped[:, 3], img[:, 3])  # half the taps outside: renormalised
    np.testing.assert_array_equal(weight[:, 3], 0.5)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), k=st.integers(1, 4), reach=st.floats(0.0, 20.0))
def test_average_is_a_convex_combination(seed, k, reach):
    frames, flows = _random_case(seed, k=k, c=2, h=6, w=5, reach=reach)
    out = warp_average(frames, flows)
    assert np.all(np.isfinite(out))
    lo, hi = frames.min(axis=(0, 2, 3)), frames.max(axis=(0, 2, 3))
    assert np.all(out >= lo[:, None, None] - 1e-6) and np.all(out <= hi[:, None, None] + 1e-6)


def test_no_sample_inside_gives_zero_not_nan():
    frames = np.ones((1, 1, 4, 4), np.float32)
    flows = np.full((1, 2, 4, 4), 100.0, np.float32)
    assert np.array_equal(warp_average(frames, flows), np.zeros((1, 4, 4), np.float32))


@pytest.mark.parametrize("call, exc, match", [
    (lambda: warp_average(np.ones((3, 4, 5)), np.zeros((3, 2, 4, 5))), ValueError, "frames must have 4"),
    (lambda: warp_average(np.ones((3, 1, 4, 5)), np.zeros((2, 2, 4, 5))), ValueError, "flows must have shape"),
    (lambda: warp_average(np.full((1, 1, 2, 2), np.nan), np.zeros((1, 2, 2, 2))), ValueError, "frames must be finite"),
    (lambda: warp_average(np.ones((1, 1, 2, 2)), np.full((1, 2, 2, 2), np.inf)), ValueError, "flows must be finite"),
    (lambda: warp_average(np.ones((1, 1, 2, 2), complex), np.zeros((1, 2, 2, 2))), TypeError, "frames must be a real"),
    (lambda: warp_spike_windows(np.ones((1, 1, 2, 2)), np.zeros((1, 2, 2, 2)), 0), ValueError, "window must be"),
    (lambda: warp_bilinear(np.ones((2, 2)), np.zeros((2, 3, 3))), ValueError, "flow must have shape"),
])
def test_bad_input(call, exc, match):
    with pytest.raises(exc, match=match):
        call()
