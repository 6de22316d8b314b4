"""Fig. 4a noise check: exact statistics on known streams, channel pooling, packed streams, errors."""

import math

import numpy as np
import pytest

from spikeref.io.dat import read_dat, write_dat
from spikeref.noise_check import noise_check, plot_noise_check

Z = 5.0


def bernoulli(rate_map, planes, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.random((planes,) + rate_map.shape) < rate_map).astype(np.uint8)


def test_bernoulli_spread_matches_theory():
    """A Bernoulli(p) pixel: Var(I/E − 1) at window W is (1 − p)/(pW), times (1 − 1/n) as E is the mean of n frames."""
    p, planes = 0.2, 4000
    spikes = bernoulli(np.full((32, 32), p), planes, seed=1)
    res = noise_check(spikes, windows=(5, 20, 100, 400))
    assert res.channels == ("mono",) and res.pixels[0] == 1024
    for i, w in enumerate(res.windows):
        n = planes // w
        expected_var = (1 - p) / (p * w) * (1 - 1 / n)
        dof = res.pixels[0] * (n - 1)  # independent pixels × frames, minus one mean per pixel
        # sampling error of a variance ≈ var·√(2/dof); the ratio's delta-method error is O(1/(pW·planes))
        assert abs(res.std_ratio[i, 0] ** 2 - expected_var) <= Z * expected_var * math.sqrt(2 / dof) + 2 / (p * planes)
    assert np.all(np.diff(res.mean_abs_ratio[:, 0]) < 0)  # falls with W (Fig. 4a)
    np.testing.assert_allclose(res.mean_ratio, 0, atol=1e-12)  # W divides the span


def test_periodic_pixels_have_zero_ratio():
    spikes = np.zeros((600, 4, 4), dtype=np.uint8)
    spikes[::3] = 1  # every third readout
    res = noise_check(spikes, windows=(3, 6, 30, 300))
    np.testing.assert_allclose(res.mean_abs_ratio, 0, atol=1e-12)
    np.testing.assert_allclose(res.std_ratio, 0, atol=1e-7)


@pytest.mark.parametrize("cfa", ["RGGB", "BGGR"])
def test_channels_are_pooled_by_the_cfa(cfa):
    rates = np.empty((8, 8))
    letters = {"R": 0.4, "G": 0.2, "B": 0.1}
    for (dy, dx), c in zip([(0, 0), (0, 1), (1, 0), (1, 1)], cfa, strict=True):
        rates[dy::2, dx::2] = letters[c]
    res = noise_check(bernoulli(rates, 3000, seed=2), windows=(10,), cfa=cfa)
    assert res.channels == ("R", "G", "B")
    assert list(res.pixels) == [16, 32, 16]
    for k, c in enumerate("RGB"):
        se = math.sqrt(letters[c] * (1 - letters[c]) / (3000 * res.pixels[k]))
        assert abs(res.expected_rate[k] - letters[c]) <= Z * se


def test_packed_dat_equals_in_memory(tmp_path):
    spikes = bernoulli(np.random.default_rng(3).uniform(0.02, 0.5, (16, 24)), 1000, seed=4)
    write_dat(tmp_path / "s.dat", spikes)
    packed = noise_check(read_dat(tmp_path / "s.dat", 16, 24, cfa="RGGB"), windows=(5, 50, 250))
    mem = noise_check(spikes, windows=(5, 50, 250), cfa="RGGB")
    for name in ("mean_ratio", "mean_abs_ratio", "std_ratio", "expected_rate"):
        np.testing.assert_allclose(getattr(packed, name), getattr(mem, name), rtol=1e-12, atol=1e-15)


def test_dark_pixels_are_excluded_and_long_windows_skipped():
    rates = np.full((4, 4), 0.3)
    rates[0, 0] = 0.0
    res = noise_check(bernoulli(rates, 500, seed=5), windows=(10, 250, 300, 1000))
    assert res.pixels[0] == 15
    assert res.windows == (10, 250) and res.skipped == (300, 1000)
    assert "skipped" in res.table() and "| 10 | 0.5 |" in res.table()


def test_span_and_errors():
    spikes = bernoulli(np.full((4, 4), 0.3), 400, seed=6)
    a = noise_check(spikes, windows=(10,), start=100, planes=200)
    b = noise_check(spikes[100:300], windows=(10,))
    np.testing.assert_allclose(a.std_ratio, b.std_ratio)
    with pytest.raises(ValueError, match="windows"):
        noise_check(spikes, windows=(0,))
    with pytest.raises(ValueError, match="windows"):
        noise_check(spikes, windows=())
    with pytest.raises(ValueError, match="start"):
        noise_check(spikes, start=400)
    with pytest.raises(ValueError, match="planes"):
        noise_check(spikes, start=100, planes=301)
    with pytest.raises(ValueError, match="min_rate"):
        noise_check(spikes, min_rate=-1.0)


def test_plot(tmp_path):
    pytest.importorskip("matplotlib")
    res = noise_check(bernoulli(np.full((8, 8), 0.2), 1000, seed=7), windows=(5, 50), cfa="RGGB")
    out = plot_noise_check(res, tmp_path / "fig4a.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.realdata
def test_real_recording_noise_falls_with_window(real_data):
    with np.load(real_data / "spikingsim_real_spike.npz") as f:
        spikes = np.ascontiguousarray(np.moveaxis(f["arr_0"], -1, 0))  # stored (H, W, T)
    assert spikes.shape == (500, 250, 400)
    res = noise_check(spikes.astype(np.uint8), windows=(5, 10, 20, 50))
    assert np.all(np.diff(res.mean_abs_ratio[:, 0]) < 0)
