"""Eq. 1–3: the noise-free camera is exact and deterministic, to the spike."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.oracles.camera import fire_oracle
from spikeref.simulate.camera import Camera, fire, mosaic_radiance
from spikeref.simulate.simulator import simulate
from tests.scene_doubles import Flat, scene

# dyadic radiances and phases (k / 2^10) are exact in binary floating point, so the
# accumulator of Eq. 1 is exact and the closed form below holds to the spike
DYADIC = st.integers(0, 1024).map(lambda k: k / 1024)


@settings(max_examples=40, deadline=None)
@given(rate=DYADIC, phase=st.integers(0, 1023).map(lambda k: k / 1024), threshold=st.sampled_from([0.5, 1.0, 2.0]))
def test_static_pixel_fires_floor_of_charge(rate, phase, threshold):
    """A static pixel of radiance L fires ⌊(φ + αL·t)/E_th⌋ times in its first t readouts (αL ≤ E_th)."""
    t = 3000
    charge = np.full((t, 1, 1), rate * threshold)
    state = np.array([[phase * threshold]])
    spikes = fire(charge, threshold, state)[:, 0, 0]
    n = np.arange(1, t + 1)
    expected = np.floor((phase * threshold + rate * threshold * n) / threshold)
    assert np.array_equal(np.cumsum(spikes), expected)
    assert 0 <= state[0, 0] < threshold


def test_scene_without_effects_is_deterministic_to_the_spike():
    rgb = (0.25, 0.375, 0.0625)  # dyadic
    sc = scene(Flat(8, 8, rgb=rgb), planes=512)
    a = simulate(sc, seed=0).spikes
    assert np.array_equal(a, simulate(sc, seed=123).spikes)  # no effect: the seed is not used
    chan = {"R": 0, "G": 1, "B": 2}
    counts = a.sum(axis=0)
    for (dy, dx), c in zip([(0, 0), (0, 1), (1, 0), (1, 1)], "RGGB", strict=True):
        assert np.all(counts[dy::2, dx::2] == np.floor(rgb[chan[c]] * 512))


@pytest.mark.parametrize("rate", [1.0, 1.5, 7.25])
def test_rate_saturates_at_one_spike_per_readout(rate):
    charge = np.full((50, 2, 2), rate)
    state = np.zeros((2, 2))
    spikes = fire(charge, 1.0, state)
    assert spikes.all()
    assert np.all((0 <= state) & (state < 1.0))


def test_fire_matches_oracle_with_per_pixel_thresholds(rng):
    charge = rng.random((200, 6, 5)) * 0.7
    thresholds = 0.5 + rng.random((6, 5))
    phase = rng.random((6, 5)) * thresholds
    state = phase.copy()
    assert np.array_equal(fire(charge, thresholds, state), fire_oracle(charge, thresholds, phase))


def test_chunked_fire_equals_one_call(rng):
    charge = rng.random((100, 4, 6))
    s1, s2 = np.zeros((4, 6)), np.zeros((4, 6))
    whole = fire(charge, 0.8, s1)
    parts = np.concatenate([fire(charge[:37], 0.8, s2), fire(charge[37:], 0.8, s2)])
    assert np.array_equal(whole, parts) and np.array_equal(s1, s2)


def test_mosaic_radiance_follows_the_cfa():
    rgb = np.zeros((4, 4, 3))
    rgb[..., 0], rgb[..., 1], rgb[..., 2] = 1, 2, 3
    assert np.array_equal(mosaic_radiance(rgb, "RGGB")[:2, :2], [[1, 2], [2, 3]])
    assert np.array_equal(mosaic_radiance(rgb, "BGGR")[:2, :2], [[3, 2], [2, 1]])
    assert np.array_equal(mosaic_radiance(rgb, "GRBG")[:2, :2], [[2, 1], [3, 2]])
    with pytest.raises(ValueError, match="even"):
        mosaic_radiance(np.zeros((3, 4, 3)), "RGGB")


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="threshold"):
        Camera(threshold=0)
    with pytest.raises(ValueError, match="threshold"):
        Camera(threshold=float("nan"))
    with pytest.raises(ValueError, match="alpha"):
        Camera(alpha=-1)
    with pytest.raises(ValueError, match="substeps"):
        Camera(substeps=0)
    with pytest.raises(ValueError, match="CFA|cfa|pattern"):
        Camera(cfa="RGBG")
    with pytest.raises(ValueError, match="finite and non-negative"):
        fire(np.full((2, 2, 2), -0.1), 1.0, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="finite and non-negative"):
        fire(np.full((2, 2, 2), np.nan), 1.0, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="threshold"):
        fire(np.zeros((2, 2, 2)), np.array([[1.0, 0.0], [1.0, 1.0]]), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="state"):
        fire(np.zeros((2, 2, 2)), 1.0, np.zeros((3, 2)))
