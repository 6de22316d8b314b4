"""The SURE guard (spikeref.denoise.guard): its noise estimate, its α against the oracle, and what it buys."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.denoise.guard import (CARRY_FRACTION, NOISE_WINDOW, carried_excess_variance, noise_sigma, probe_step,
                                    quantisation_variance, rademacher_probe, sure_alpha, sure_blend, trusted_excess)
from spikeref.oracles.guard import carried_excess_variance_oracle, noise_sigma_oracle, sure_alpha_oracle


def _smooth(h, w, seed):
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(seed)
    x = gaussian_filter(rng.random((h, w)), 3)
    return 0.1 + 0.5 * (x - x.min()) / (x.max() - x.min())


def test_noise_sigma_is_unbiased_on_white_gaussian_noise():
    rng = np.random.default_rng(0)
    x = rng.normal(0, 0.05, (3, 200, 240)) + _smooth(200, 240, 1)  # smooth signal: cancelled by the kernel
    np.testing.assert_allclose(noise_sigma(x), 0.05, rtol=0.03)
    np.testing.assert_allclose(noise_sigma(x, keep=1.0), 0.05, rtol=0.03)
    assert noise_sigma(np.ones((2, 2))) == 0.0 and noise_sigma(np.full((5, 5), 0.3)) == 0.0


def test_noise_sigma_sees_quantised_spike_rates():
    """Rates of W = 10 readouts are multiples of 0.1; a median-based estimate would say 0 here."""
    rng = np.random.default_rng(3)
    p = _smooth(120, 160, 2)
    rates = rng.binomial(10, p) / 10.0
    truth = np.sqrt(np.mean(p * (1 - p) / 10))
    assert 0.8 * truth < noise_sigma(rates) < 1.1 * truth


@settings(max_examples=10, deadline=None)
@given(st.integers(3, 9), st.integers(3, 9), st.floats(0.2, 1.0), st.integers(0, 1000))
def test_noise_sigma_matches_the_oracle(h, w, keep, seed):
    plane = np.random.default_rng(seed).random((h, w))
    assert noise_sigma(plane, keep=keep) == pytest.approx(noise_sigma_oracle(plane, keep=keep), rel=1e-9, abs=1e-15)


@settings(max_examples=10, deadline=None)
@given(st.integers(1, 7), st.integers(1, 7), st.integers(0, 3), st.integers(0, 1000))
def test_sure_alpha_matches_the_oracle(h, w, radius, seed):
    rng = np.random.default_rng(seed)
    y = rng.random((2, h, w))
    f = y + rng.normal(0, 0.1, y.shape)
    b = rademacher_probe(y.shape, seed)
    fb = f + 0.01 * b * rng.random(y.shape)
    eps, sigma = np.array([0.01, 0.02]), np.array([0.1, 0.05])
    got = sure_alpha(y, f, fb, b, eps, sigma, radius)
    for c in range(2):
        np.testing.assert_allclose(got[c], sure_alpha_oracle(y[c], f[c], fb[c], b[c], eps[c], sigma[c], radius),
                                   rtol=1e-9, atol=1e-12)


def test_sure_keeps_a_good_denoiser_and_rejects_a_harmful_one():
    """Known answers: the ideal linear shrinker is kept (α ≈ 1); a map that wipes detail is undone (α ≈ 0)."""
    rng = np.random.default_rng(5)
    x = _smooth(96, 128, 4)
    sigma = 0.04
    y = x + rng.normal(0, sigma, x.shape)
    # a denoiser that knows the truth is kept: f(y) = x has zero divergence and removes exactly the noise
    out, alpha = sure_blend(y, lambda z: x.astype(np.float32), sigma=sigma)
    assert alpha.mean() > 0.9 and np.mean((out - x) ** 2) < 0.2 * sigma ** 2
    # a "denoiser" that replaces everything by the mean (kills the signal) is rejected where signal lives
    detail = x + 0.2 * np.sin(np.arange(128) / 2.0)[None, :]
    y2 = detail + rng.normal(0, sigma, x.shape)
    out2, alpha2 = sure_blend(y2, lambda z: np.full_like(z, z.mean()), sigma=sigma)
    assert alpha2.mean() < 0.1
    assert np.mean((out2 - detail) ** 2) < 1.3 * sigma ** 2  # about the input's error, never the mean's


def test_sure_blend_is_deterministic_and_checks_its_input():
    y = np.random.default_rng(1).random((4, 16, 16)).astype(np.float32)

    def den(z):
        return z * 0.5 + 0.25

    a, _ = sure_blend(y, den)
    b, _ = sure_blend(y.copy(), den)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(rademacher_probe((3, 4)), rademacher_probe((3, 4)))
    assert set(np.unique(rademacher_probe((50,)))) == {-1.0, 1.0}
    np.testing.assert_allclose(probe_step([0.1, 0.0]), [0.005, 0.0])
    with pytest.raises(ValueError, match="noisy must be finite"):
        sure_blend(np.full((4, 4), np.nan, np.float32), den)
    with pytest.raises(ValueError, match="the denoiser returned shape"):
        sure_blend(y, lambda z: z[0])
    with pytest.raises(ValueError, match="radius must be an integer ≥ 0"):
        sure_alpha(y, y, y, y, 0.1, 0.1, radius=-1)
    with pytest.raises(ValueError, match="keep must be a fraction"):
        noise_sigma(y, keep=0)


def test_sure_alpha_with_one_sigma_per_pixel_matches_the_oracle():
    rng = np.random.default_rng(9)
    y = rng.random((1, 6, 7))
    f = y + rng.normal(0, 0.1, y.shape)
    b = rademacher_probe(y.shape, 3)
    fb = f + 0.01 * b
    sig = rng.uniform(0.01, 0.2, y.shape)
    np.testing.assert_allclose(sure_alpha(y, f, fb, b, [0.01], sig, 2)[0],
                               sure_alpha_oracle(y[0], f[0], fb[0], b[0], 0.01, sig[0], 2), rtol=1e-7, atol=1e-12)


def test_quantisation_floor():
    """The variance of ⌊φ + pW⌋/W over a uniform phase φ, measured, against the floor."""
    from spikeref.denoise.guard import quantisation_variance
    from spikeref.oracles.guard import quantisation_variance_oracle

    rng = np.random.default_rng(0)
    for p, w in ((0.01, 10), (0.37, 10), (0.5, 50)):
        phase = rng.random(200_000)
        counts = np.floor(phase + p * w)
        measured = counts.var() / w ** 2
        floor = float(quantisation_variance(p, w))
        assert floor == pytest.approx(quantisation_variance_oracle(p, w))
        if p * w < 1:
            assert floor == pytest.approx(measured, rel=0.15)  # Poisson-like: p/W
        else:
            assert floor == pytest.approx(1 / (6 * w * w))  # the phase average of {pW}(1 − {pW})/W²
    assert float(quantisation_variance(0.0, 10)) == 0.0 and float(quantisation_variance(1.0, 10)) == 0.0


def test_low_light_is_not_read_as_noise_free():
    """Mostly-zero counts: the trimmed estimate says σ ≈ 0, the floor keeps the guard from returning the input."""
    rng = np.random.default_rng(4)
    p = np.full((1, 64, 64), 0.002)
    y = (rng.binomial(10, p) / 10.0).astype(np.float32)
    assert noise_sigma(y)[0] == 0.0
    smooth = np.full_like(y, y.mean())
    _, alpha_floor = sure_blend(y, lambda z: smooth, window=10)
    _, alpha_none = sure_blend(y, lambda z: smooth)
    assert alpha_none.max() == 0.0 and alpha_floor.mean() > 0.8


@settings(max_examples=15, deadline=None)
@given(h=st.integers(3, 9), w=st.integers(3, 9), w0=st.sampled_from([5, 10]), w1=st.sampled_from([20, 100]),
       seed=st.integers(0, 10_000), accumulate=st.sampled_from(["count", "charge"]))
def test_carried_excess_variance_matches_the_oracle(h, w, w0, w1, seed, accumulate):
    rng = np.random.default_rng(seed)
    short = (rng.integers(0, w0 + 1, (2, h, w)) / w0).astype(np.float32)
    if accumulate == "charge":  # charges are not whole numbers of spikes
        short = (short + rng.random((2, h, w)) / w0).astype(np.float32)
    got = carried_excess_variance(short, w0, w1, accumulate)
    for i in range(2):
        want = carried_excess_variance_oracle(short[i], w0, w1, accumulate=accumulate)
        assert got[i] == pytest.approx(want, rel=1e-9, abs=1e-15)


def _fired_counts(rate, window, rng, shot=0.0):
    """Counts of an integrate-and-fire pixel over ``window`` readouts: ⌊φ + pW⌋, random phase, optional shot noise."""
    drive = rate * window + (rng.normal(0.0, shot * np.sqrt(window), rate.shape) if shot else 0.0)
    return np.clip(np.floor(rng.random(rate.shape) + drive), 0, window)


def test_carried_excess_variance_sees_shot_noise_and_not_the_quantisation():
    """Pure ⌊φ + pW⌋ counts: nothing above the floor; added noise of variance s/W₀ per rate: ≈ s/W once carried."""
    rng = np.random.default_rng(5)
    rate = np.broadcast_to(_smooth(128, 128, 1), (2, 128, 128))
    quantised = (_fired_counts(rate, 10, rng) / 10).astype(np.float32)
    floor = quantisation_variance(quantised, 10).mean()
    assert np.all(carried_excess_variance(quantised, 10, 10) < 0.15 * floor)
    shot = (_fired_counts(rate, 10, rng, shot=0.3) / 10).astype(np.float32)  # rate noise variance 0.09/10 + floor
    carried = carried_excess_variance(shot, 10, 100)
    np.testing.assert_allclose(carried, 0.09 / 100, rtol=0.2)


def test_carried_noise_caps_the_plane_estimate_at_long_windows():
    """A textured long window: the plane's σ reads texture as noise and the guard keeps a smoother's output;
    capped by the noise measured on a short window it gives the texture back.  A cap above σ changes nothing."""
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(11)
    texture = 0.3 + 0.1 * rng.standard_normal((1, 96, 96))  # fine detail, as leaves or a fence
    long_w, short_w = 200, 10
    y = (_fired_counts(texture, long_w, rng) / long_w).astype(np.float32)
    short = (_fired_counts(texture, short_w, rng) / short_w).astype(np.float32)

    def smoother(z):
        return gaussian_filter(z, (0, 2, 2)).astype(np.float32)

    truth_err = {}
    plain, alpha_plain = sure_blend(y, smoother, window=long_w)
    carried = carried_excess_variance(short, short_w, long_w)
    capped, alpha_capped = sure_blend(y, smoother, window=long_w, carried=carried)
    truth_err = {k: float(np.mean((v - texture) ** 2)) for k, v in (("plain", plain), ("capped", capped))}
    assert alpha_capped.mean() < 0.5 * alpha_plain.mean()
    assert truth_err["capped"] < 0.5 * truth_err["plain"]
    huge, _ = sure_blend(y, smoother, window=long_w, carried=[1.0])
    np.testing.assert_array_equal(huge, plain)
    with pytest.raises(ValueError, match="carried needs window"):
        sure_blend(y, smoother, carried=carried)
    with pytest.raises(ValueError, match="carried must be finite"):
        sure_blend(y, smoother, window=long_w, carried=[-1.0])
    with pytest.raises(ValueError, match="short_window must be a positive"):
        carried_excess_variance(short, 0, long_w)


def test_trusted_excess_reads_the_noise_only_where_it_dominates():
    """No cap up to NOISE_WINDOW planes; beyond, CARRY_FRACTION of a short window's excess, or only the floor."""
    rng = np.random.default_rng(2)
    rate = np.broadcast_to(_smooth(64, 64, 3), (2, 64, 64))
    short = (_fired_counts(rate, NOISE_WINDOW, rng, shot=0.3) / NOISE_WINDOW).astype(np.float32)
    assert trusted_excess(None) is None and trusted_excess(NOISE_WINDOW) is None
    assert trusted_excess(NOISE_WINDOW, short, NOISE_WINDOW) is None  # a short window is its own
    assert trusted_excess(NOISE_WINDOW + 1) == 0.0 and trusted_excess(200, accumulate="charge") == 0.0
    assert trusted_excess(200, short, 2 * NOISE_WINDOW) == 0.0  # a "short" window too long to be read
    carried = trusted_excess(200, short, NOISE_WINDOW)
    np.testing.assert_allclose(carried, CARRY_FRACTION * carried_excess_variance(short, NOISE_WINDOW, 200))
    assert np.all(carried > 0) and 0 < CARRY_FRACTION < 1
    with pytest.raises(ValueError, match="short= needs short_window"):
        trusted_excess(200, short)


def test_a_long_window_alone_is_never_made_much_worse():
    """At W = 200 with no short window: noise-free texture is not read as noise (the plane's σ was, and the
    guard kept a smoother that wipes it), and a flat noisy field is still not made worse; given the short
    window, the guard measures that field's noise and removes most of it."""
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(13)
    w = 200

    def smoother(z):
        return gaussian_filter(z, (0, 2, 2)).astype(np.float32)

    def mse(a, truth):
        return float(np.mean((np.asarray(a, np.float64) - truth) ** 2))

    texture = np.clip(0.3 + 0.1 * rng.standard_normal((2, 96, 96)), 0.05, 0.95)  # fine detail, no noise but the count's
    y = (_fired_counts(texture, w, rng) / w).astype(np.float32)
    former, _ = sure_blend(y, smoother, window=w)  # σ of the plane: texture read as noise
    bare, alpha = sure_blend(y, smoother, window=w, carried=trusted_excess(w))
    assert mse(former, texture) > 5 * mse(y, texture)
    assert mse(bare, texture) < 1.05 * mse(y, texture) and alpha.mean() < 0.2

    flat = np.full((2, 96, 96), 0.3)
    noisy = (_fired_counts(flat, w, rng, shot=0.3) / w).astype(np.float32)  # noise ≈ 100× the floor's variance
    short = (_fired_counts(flat, NOISE_WINDOW, rng, shot=0.3) / NOISE_WINDOW).astype(np.float32)
    bare, _ = sure_blend(noisy, smoother, window=w, carried=trusted_excess(w))
    measured, _ = sure_blend(noisy, smoother, window=w, carried=trusted_excess(w, short, NOISE_WINDOW))
    assert mse(bare, flat) <= mse(noisy, flat)
    assert mse(measured, flat) < 0.5 * mse(noisy, flat) < mse(bare, flat)


def test_charge_floor_is_below_the_counts_and_bounds_ideal_pixels():
    """accumulate="charge": the floor p²/(6W²) (≤ the count's) is about what ideal pixels' charge rates show."""
    from spikeref.charge import charge_rates
    from spikeref.oracles.guard import quantisation_variance_oracle

    rng = np.random.default_rng(6)
    w = 10
    for p in (0.1913, 0.3771, 0.6133):
        phase = rng.random(4000)
        charge = phase[None] + p * np.arange(1, 3 * w + 1)[:, None]
        before = phase[None] + p * np.arange(0, 3 * w)[:, None]
        spikes = (np.floor(charge) > np.floor(before)).astype(np.uint8)[:, None, :]
        measured = np.mean((charge_rates(spikes, w, start=w, count=1)[0] - p) ** 2)
        floor = float(quantisation_variance(p, w, "charge"))
        assert floor == pytest.approx(quantisation_variance_oracle(p, w, "charge"))
        assert floor == pytest.approx(min(p * p, 1.0) / (6 * w * w)) and floor <= float(quantisation_variance(p, w))
        assert 0.3 * floor < measured < 1.2 * floor  # the ±½-readout rounding of each edge, about p²/12 each
    with pytest.raises(ValueError, match="accumulate must be count or charge"):
        quantisation_variance(0.5, 10, "photons")
