"""Immerkær's noise filter (spikeref.noise_level), shared by the noise-aware alignment and the guard."""

import numpy as np

from spikeref.align_noise import estimate_noise
from spikeref.noise_level import immerkaer_response


def test_the_filter_is_zero_on_planes_and_measures_white_noise():
    y, x = np.mgrid[0:40, 0:50].astype(np.float64)
    assert np.abs(immerkaer_response(3.0 + 0.2 * y - 0.7 * x)).max() < 1e-12  # any plane, exactly
    assert immerkaer_response(np.zeros((2, 6, 7))).shape == (2, 4, 5)  # leading axes are separate images
    noise = np.random.default_rng(0).normal(0.0, 0.05, (200, 200))
    # σ = √(π/2)·mean|k ⊛ n|/6 for Gaussian white noise (Σ k² = 36): within 2 % on 198² samples
    sigma = np.sqrt(0.5 * np.pi) * immerkaer_response(noise).mean() / 6.0
    assert abs(sigma - 0.05) < 0.001
    assert abs(np.sqrt(estimate_noise(noise.astype(np.float32))) - sigma) < 1e-6


def test_the_kernel_is_the_oracle_to_the_bit():
    # the order of the sums is written out in both (edges, corners, then the combination)
    from spikeref.oracles.align import immerkaer_response_oracle

    rng = np.random.default_rng(3)
    images = rng.standard_normal((3, 17, 23)) * 10.0 ** rng.uniform(-3, 3, (3, 1, 1))
    got = immerkaer_response(images.astype(np.float32))
    assert got.shape == (3, 15, 21) and got.dtype == np.float64
    for k in range(3):
        np.testing.assert_array_equal(got[k], immerkaer_response_oracle(images[k].astype(np.float32)))
    assert immerkaer_response(np.ones((2, 2))).shape == (0, 0)  # no interior
