"""The timing-aware window charge (spikeref.charge): its oracle, Eq. 4 as its limit, what it buys on ideal pixels."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.accumulate import window_counts
from spikeref.charge import charge_rates, window_charge
from spikeref.oracles.charge import window_charge_oracle
from spikeref.stream import SpikeStream


@settings(max_examples=25, deadline=None)
@given(t=st.integers(8, 40), window=st.integers(1, 9), start=st.integers(0, 6), margin=st.one_of(st.none(),
       st.integers(0, 12)), density=st.floats(0.02, 0.9), seed=st.integers(0, 10_000))
def test_kernel_matches_the_oracle(t, window, start, margin, density, seed):
    spikes = (np.random.default_rng(seed).random((t, 3, 5)) < density).astype(np.uint8)
    if (t - start) // window < 1:
        with pytest.raises(ValueError, match="do not fit"):
            window_charge(spikes, window, start, margin=margin)
        return
    np.testing.assert_allclose(window_charge(spikes, window, start, margin=margin),
                               window_charge_oracle(spikes, window, start, margin=margin), rtol=0, atol=1e-6)


def test_margin_zero_is_eq_4_and_adjacent_windows_add_up():
    rng = np.random.default_rng(1)
    spikes = (rng.random((90, 6, 8)) < 0.3).astype(np.uint8)
    np.testing.assert_array_equal(window_charge(spikes, 10, margin=0), window_counts(spikes, 10).astype(np.float32))
    # one φ per boundary: three windows of 10 add up to one of 30 over the same readouts (no clipping here)
    small = window_charge(spikes, 10, start=30, count=3, margin=10)
    big = window_charge(spikes, 30, start=30, count=1, margin=10)[0]
    unclipped = (small > 0).all(axis=0)
    assert unclipped.mean() > 0.9
    np.testing.assert_allclose(small.sum(axis=0)[unclipped], big[unclipped], atol=1e-5)
    # the same numbers from a stream object, and rates = charge / W
    np.testing.assert_array_equal(window_charge(SpikeStream.from_array(spikes), 10, 30, 3, margin=10), small)
    np.testing.assert_allclose(charge_rates(spikes, 10, 30, 3, 10), small / 10, rtol=1e-6)


def _ideal_pixels(rate, readouts, rng):
    """Integrate-and-fire at constant rate, random phase: a spike at readout r when ⌊φ + p(r+1)⌋ steps up."""
    phase = rng.random(rate.shape)
    charge = phase[None] + rate[None] * np.arange(1, readouts + 1)[:, None, None]
    before = phase[None] + rate[None] * np.arange(0, readouts)[:, None, None]
    return (np.floor(charge) > np.floor(before)).astype(np.uint8)


@pytest.mark.parametrize("p", [0.1913, 0.3771, 0.6133])
def test_ideal_pixels_lose_the_count_quantisation(p):
    """Eq. 4's error on an ideal pixel is the ±1 quantisation, √(1/6)/W; the charge's is about p times it."""
    rng = np.random.default_rng(2)
    w = 10
    rate = np.full((1, 4000), p)
    spikes = _ideal_pixels(rate, 3 * w, rng)
    count_err = np.sqrt(np.mean((window_counts(spikes, w, start=w, count=1)[0] / w - p) ** 2))
    charge_err = np.sqrt(np.mean((charge_rates(spikes, w, start=w, count=1)[0] - p) ** 2))
    frac = (p * w) % 1  # the count is ⌊φ + pW⌋: variance {pW}(1 − {pW}) over a uniform phase
    assert count_err == pytest.approx(np.sqrt(frac * (1 - frac)) / w, rel=0.1)
    assert charge_err < 1.2 * p * np.sqrt(1 / 6) / w and charge_err < 0.6 * count_err


def test_dark_pixels_and_stream_ends_fall_back_to_the_count():
    spikes = np.zeros((30, 2, 2), np.uint8)
    spikes[12, 0, 0] = 1  # one spike: no interval brackets any boundary
    np.testing.assert_array_equal(window_charge(spikes, 10), window_counts(spikes, 10).astype(np.float32))


def test_arguments_are_checked():
    spikes = np.zeros((30, 2, 2), np.uint8)
    for kw, match in (({"window": 0}, "window must be"), ({"window": 10, "start": -1}, "start must be"),
                      ({"window": 10, "count": 0}, "count must be"), ({"window": 10, "margin": -1}, "margin must be"),
                      ({"window": 10, "count": 4}, "do not fit"), ({"window": True}, "window must be")):
        with pytest.raises(ValueError, match=match):
            window_charge(spikes, **kw)
