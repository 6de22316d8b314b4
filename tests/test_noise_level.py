"""Immerkær's noise filter and the noise scale of a noise-normalised denoiser (spikeref.noise_level)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.align_noise import estimate_noise
from spikeref.noise_level import NOISE_SCALE_FLOOR, immerkaer_response, noise_scale


def test_the_filter_is_zero_on_planes_and_measures_white_noise():
    y, x = np.mgrid[0:40, 0:50].astype(np.float64)
    assert np.abs(immerkaer_response(3.0 + 0.2 * y - 0.7 * x)).max() < 1e-12  # any plane
    noise = np.random.default_rng(0).normal(0.0, 0.05, (3, 200, 200))
    # σ = √(π/2)·mean|k ⊛ n|/6 for Gaussian white noise (Σ k² = 36): within 2 % on 198² samples
    np.testing.assert_allclose(noise_scale(noise), 0.05, rtol=0.02)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**16), st.floats(0.1, 10.0))
def test_noise_scale_scales_with_the_image_and_is_estimate_noise_s_sigma(seed, c):
    img = np.random.default_rng(seed).random((2, 9, 11))
    sigma = noise_scale(img)
    assert sigma.shape == (2,)
    np.testing.assert_allclose(noise_scale(c * img), np.maximum(c * sigma, NOISE_SCALE_FLOOR), rtol=1e-9)
    np.testing.assert_allclose(sigma[0] ** 2, estimate_noise(img[0].astype(np.float32)), rtol=1e-5)


def test_noise_scale_has_a_floor_and_refuses_small_images():
    assert noise_scale(np.zeros((5, 5))) == NOISE_SCALE_FLOOR
    with pytest.raises(ValueError, match="h, w ≥ 3"):
        noise_scale(np.zeros((2, 5)))
