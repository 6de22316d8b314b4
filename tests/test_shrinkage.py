"""Residual shrinkage (spikeref.denoise.shrinkage; not in the paper): oracle, limits, a pinned value."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.denoise.shrinkage import residual_noise_variance, shrink_residual
from spikeref.oracles.shrinkage import shrink_residual_oracle


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(1, 4), h=st.integers(1, 9), w=st.integers(1, 9),
       window=st.sampled_from([1, 2.5, 10, 100, 3000]), radius=st.integers(0, 3))
def test_matches_the_oracle(seed, n, h, w, window, radius):
    rng = np.random.default_rng(seed)
    denoised = rng.random((n, h, w)).astype(np.float32)
    noisy = np.clip(denoised + rng.normal(0, 0.2, denoised.shape), 0, 1).astype(np.float32)
    got = shrink_residual(noisy, denoised, window, radius)
    np.testing.assert_allclose(got, shrink_residual_oracle(noisy, denoised, window, radius), rtol=1e-5, atol=1e-6)
    # each value lies between D(I) and I (the gain is in [0, 1])
    lo, hi = np.minimum(noisy, denoised), np.maximum(noisy, denoised)
    assert np.all(got >= lo - 1e-6) and np.all(got <= hi + 1e-6)


def test_pinned_value_at_an_isolated_residual():
    # D = 0.5 everywhere, I = D + 0.3 at the centre of a 3×3 plane, W = 100, 3×3 box.
    # Centre: mean r² = 0.09 / 9 = 0.01, σ² = 0.5·0.5/100 = 0.0025, g = 1 − 0.25 = 0.75,
    # so 0.5 + 0.75·0.3 = 0.725.  Elsewhere r = 0 and the value stays 0.5.
    denoised = np.full((1, 3, 3), 0.5, dtype=np.float32)
    noisy = denoised.copy()
    noisy[0, 1, 1] += 0.3
    out = shrink_residual(noisy, denoised, 100)
    assert out[0, 1, 1] == pytest.approx(0.725, rel=1e-6)
    assert np.all(np.delete(out.ravel(), 4) == np.float32(0.5))


def test_noise_alone_is_removed_and_large_detail_is_kept():
    rng = np.random.default_rng(0)
    W = 20
    p = np.full((1, 64, 64), 0.3)
    counts = rng.binomial(W, p)  # pure binomial noise: its residual energy is σ² on average
    noisy = (counts / W).astype(np.float32)
    denoised = p.astype(np.float32)
    out = shrink_residual(noisy, denoised, W)
    # most of the noise is not given back (Wiener: only the local excess over σ² is)
    assert np.mean((out - denoised) ** 2) < 0.2 * np.mean((noisy - denoised) ** 2)
    # a step the "denoiser" blurred away, 0.4 high against σ = 0.1, comes back almost whole
    edge = denoised.copy()
    edge[..., 32:] += 0.4
    out = shrink_residual(edge, denoised, W)
    assert np.mean(out[..., 33:] - denoised[..., 33:]) > 0.9 * 0.4


def test_long_exposure_gives_the_input_back():
    rng = np.random.default_rng(1)
    noisy = rng.random((2, 8, 8)).astype(np.float32)
    denoised = np.full_like(noisy, 0.5)
    np.testing.assert_allclose(shrink_residual(noisy, denoised, 1e9), noisy, atol=1e-6)
    assert np.array_equal(shrink_residual(denoised, denoised, 10), denoised)


def test_noise_variance_is_binomial_and_clipped():
    v = residual_noise_variance(np.array([0.0, 0.3, 1.0]), 10)
    np.testing.assert_allclose(v, [0.05 * 0.95 / 10, 0.3 * 0.7 / 10, 0.05 * 0.95 / 10])


@pytest.mark.parametrize("call, match", [
    (lambda: shrink_residual(np.zeros(3, np.float32), np.zeros(3, np.float32), 10), "noisy must have shape"),
    (lambda: shrink_residual(np.zeros((2, 2), np.uint8), np.zeros((2, 2), np.float32), 10), "floating point"),
    (lambda: shrink_residual(np.zeros((2, 2)), np.zeros((2, 3)), 10), "same shape"),
    (lambda: shrink_residual(np.full((2, 2), np.nan), np.zeros((2, 2)), 10), "noisy must be finite"),
    (lambda: shrink_residual(np.zeros((2, 2)), np.zeros((2, 2)), 0.5), "window must be"),
    (lambda: shrink_residual(np.zeros((2, 2)), np.zeros((2, 2)), 10, radius=-1), "radius must be"),
])
def test_bad_input(call, match):
    with pytest.raises((ValueError, TypeError), match=match):
        call()
