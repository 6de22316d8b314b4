import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.accumulate import accumulate, accumulate_window, window_counts
from spikeref.io.dat import pack_planes
from spikeref.oracles import accumulate_oracle
from spikeref.stream import SpikeStream


def _spikes(seed, shape, p=0.3):
    return (np.random.default_rng(seed).random(shape) < p).astype(np.uint8)


def test_eq4_matches_oracle_unpacked_and_packed():
    spikes = _spikes(0, (37, 6, 8))
    expected = accumulate_oracle(spikes, 5, start=2)
    got = accumulate(spikes, 5, start=2)
    assert got.shape == (7, 6, 8) and got.dtype == np.float32
    np.testing.assert_allclose(got, expected, atol=1e-7)
    packed = SpikeStream.from_packed(pack_planes(spikes), 6, 8)
    np.testing.assert_allclose(accumulate(packed, 5, start=2), expected, atol=1e-7)


@given(
    h=st.integers(1, 5), w=st.integers(1, 9), t=st.integers(1, 90), window=st.integers(1, 40),
    seed=st.integers(0, 2**31), p=st.floats(0, 1),
)
@settings(max_examples=60, deadline=None)
def test_packed_and_unpacked_counts_agree(h, w, t, window, seed, p):
    # every geometry, including ones where a word straddles rows and the generic kernel runs
    h, w = 2 * h, 4 * w  # H*W a multiple of 8, as the .dat layout needs
    if window > t:
        return
    spikes = _spikes(seed, (t, h, w), p)
    ref = spikes[: t // window * window].reshape(t // window, window, h, w).sum(1)
    np.testing.assert_array_equal(window_counts(spikes, window), ref)
    np.testing.assert_array_equal(window_counts(SpikeStream.from_packed(pack_planes(spikes), h, w), window), ref)


@pytest.mark.parametrize("window, col_offset", [(1, 0), (7, 0), (10, 0), (255, 0), (256, 0), (300, 0),
                                                (2, 8), (11, 16), (200, 24)])
def test_fast_packed_path_with_padded_rows(window, col_offset):
    # 1024-wide stored rows cropped to 1000 columns, at the sizes the fast 64-bit path takes; with
    # an offset, words that straddle the crop's edges take the kernel's per-group branch
    h, fw, w = 8, 1024, 1000
    spikes = _spikes(window, (600, h, fw), 0.6)
    stream = SpikeStream.from_packed(pack_planes(spikes), h, w, file_width=fw, col_offset=col_offset)
    counts = window_counts(stream, window)
    ref = spikes[: 600 // window * window].reshape(-1, window, h, fw).sum(1)[:, :, col_offset : col_offset + w]
    np.testing.assert_array_equal(counts, ref)
    assert counts.dtype == (np.uint8 if window <= 255 else np.uint16)


def test_saturated_and_dark_streams_give_rates_one_and_zero():
    np.testing.assert_array_equal(accumulate(np.ones((20, 2, 4), np.uint8), 10), 1.0)
    np.testing.assert_array_equal(accumulate(np.zeros((20, 2, 4), np.uint8), 10), 0.0)


def test_per_channel_gains_follow_the_cfa():
    spikes = np.ones((4, 2, 2), np.uint8)
    frame = accumulate_window(spikes, start=0, window=4, gains=(2.0, 1.0, 0.5), cfa="RGGB")
    np.testing.assert_allclose(frame, [[2.0, 1.0], [1.0, 0.5]])
    frame = accumulate_window(spikes, start=0, window=4, gains=(2.0, 1.0, 0.5), cfa="BGGR")
    np.testing.assert_allclose(frame, [[0.5, 1.0], [1.0, 2.0]])
    with pytest.raises(ValueError, match="need a Bayer pattern"):
        accumulate(spikes, 2, gains=(1, 1, 1))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(window=0), "window must be at least 1"),
        (dict(window=11), "longer than the 10 planes"),
        (dict(window=2.5), "window must be an integer"),
        (dict(window=2, start=-1), "start must be"),
        (dict(window=2, start=50), r"start=50 is at or past the end of the stream \(10 planes\)"),
        (dict(window=2, start=10), "start=10 is at or past the end"),
        (dict(window=2, count=6), "need 12 planes"),
        (dict(window=2, gains=-1.0), "gains must be"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        accumulate(np.zeros((10, 2, 4), np.uint8), **kwargs)


def test_bad_spike_values_are_rejected():
    with pytest.raises(ValueError, match="only 0 and 1"):
        accumulate(np.full((4, 2, 2), 2, np.uint8), 2)
    with pytest.raises(ValueError, match=r"shape \(T, H, W\)"):
        accumulate(np.zeros((4, 4), np.uint8), 2)


@pytest.mark.parametrize("h, w, fw, col_offset, window", [
    (8, 64, 64, 0, 10),     # the fast 64-bit path
    (8, 1000, 1024, 8, 7),  # the fast path on padded rows
    (6, 12, 16, 0, 5),      # 32-bit words joined in pairs
    (6, 5, 12, 3, 4),       # the generic kernel (columns not whole bytes)
    (4, 8, 8, 0, 300),      # the generic kernel (counts above 255)
])
def test_counts_of_a_top_down_stream_are_upright(h, w, fw, col_offset, window):
    """Eq. 4 counts straight from the bytes of a .dat stored top-down equal those of the upright array, with
    either kernel (they place rows bottom-up; count_windows turns them)."""
    spikes = _spikes(h + w, (600, h, fw), 0.4)
    upright = spikes[:, :, col_offset : col_offset + w]
    ref = upright[: 600 // window * window].reshape(-1, window, h, w).sum(1)
    stream = SpikeStream.from_packed(pack_planes(spikes, rows="top-down"), h, w, file_width=fw,
                                     col_offset=col_offset, rows="top-down")
    np.testing.assert_array_equal(window_counts(stream, window), ref)
    np.testing.assert_array_equal(window_counts(stream.slice(window), window)[0], ref[1])
    np.testing.assert_array_equal(accumulate(stream, window, start=2, count=1),
                                  accumulate(np.ascontiguousarray(upright), window, start=2, count=1))
