"""PSNR, SSIM and PU21 against scikit-image, the literal oracles and published values."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from spikeref.metrics import luminance, psnr, psnr_after_gain, pu21_encode, pu21_psnr, pu21_ssim, ssim
from spikeref.oracles.metrics import psnr_oracle, pu21_oracle, ssim_oracle

skm = pytest.importorskip("skimage.metrics")


def _skimage_ssim(ref, est, data_range):
    return skm.structural_similarity(ref, est, data_range=data_range, gaussian_weights=True, sigma=1.5,
                                     use_sample_covariance=False,
                                     channel_axis=-1 if ref.ndim == 3 else None)


@pytest.mark.parametrize("shape", [(11, 11), (32, 45), (24, 17, 3), (64, 64, 3)])
@pytest.mark.parametrize("data_range", [1.0, 0.05, 255.0])
def test_ssim_equals_scikit_image_wang_settings(rng, shape, data_range):
    ref = rng.random(shape) * data_range
    est = np.clip(ref + 0.1 * data_range * rng.standard_normal(shape), 0, None)
    assert ssim(ref, est, data_range) == pytest.approx(_skimage_ssim(ref, est, data_range), rel=1e-9, abs=1e-12)


def test_ssim_and_psnr_equal_the_literal_oracles(rng):
    ref = rng.random((14, 17, 3))
    est = ref + 0.05 * rng.standard_normal(ref.shape)
    assert ssim(ref, est, 1.0) == pytest.approx(ssim_oracle(ref, est, 1.0), rel=1e-10)
    assert psnr(ref, est, 1.0) == pytest.approx(psnr_oracle(ref, est, 1.0), rel=1e-12)


def test_psnr_equals_scikit_image_and_a_hand_value():
    ref = np.zeros((4, 4))
    est = np.full((4, 4), 0.1)  # MSE = 0.01 → 10 log10(1 / 0.01) = 20 dB
    assert psnr(ref, est, 1.0) == pytest.approx(20.0, abs=1e-12)
    rng = np.random.default_rng(3)
    a, b = rng.random((9, 7, 3)), rng.random((9, 7, 3))
    assert psnr(a, b, 2.0) == pytest.approx(skm.peak_signal_noise_ratio(a, b, data_range=2.0), rel=1e-12)
    assert psnr(a, a, 1.0) == float("inf")


def test_psnr_after_gain_fits_the_exposure_then_scores(rng):
    ref = rng.random((12, 10, 3))
    est = 0.5 * ref + 0.01 * rng.standard_normal(ref.shape)  # half the exposure, a little noise
    g = float((ref * est).sum() / (est * est).sum())
    assert psnr_after_gain(ref, est, 1.0) == pytest.approx(psnr(ref, g * est, 1.0), rel=1e-12)
    assert psnr_after_gain(ref, est, 1.0) > psnr(ref, est, 1.0) + 5
    assert psnr_after_gain(ref, 3.0 * ref, 1.0) > 250  # the exposure alone: exact up to rounding
    # one gain per channel: a white balance as well
    tinted = ref * np.array([0.5, 1.0, 2.0])
    assert psnr_after_gain(ref, tinted, 1.0, per_channel=True) > 250
    assert psnr_after_gain(ref, tinted, 1.0) < 40
    gains = (ref * est).sum(axis=(0, 1)) / (est * est).sum(axis=(0, 1))
    assert psnr_after_gain(ref, est, 1.0, per_channel=True) == pytest.approx(psnr(ref, est * gains, 1.0), rel=1e-12)
    # a zero estimate (or channel) keeps gain 1
    zero = est.copy()
    zero[..., 1] = 0.0
    assert np.isfinite(psnr_after_gain(ref, zero, 1.0, per_channel=True))
    assert psnr_after_gain(ref, np.zeros_like(ref), 1.0) == pytest.approx(psnr(ref, np.zeros_like(ref), 1.0))
    with pytest.raises(ValueError, match="per_channel needs \\(H, W, C\\) images"):
        psnr_after_gain(ref[..., 0], est[..., 0], 1.0, per_channel=True)
    with pytest.raises(TypeError, match="per_channel must be True or False"):
        psnr_after_gain(ref, est, 1.0, per_channel="yes")
    with pytest.raises(ValueError, match="data_range must be a positive"):
        psnr_after_gain(ref, est, 0.0)


images = arrays(np.float64, st.tuples(st.integers(11, 20), st.integers(11, 20)),
                elements=st.floats(0, 1, allow_nan=False, width=32))


@settings(max_examples=30, deadline=None)
@given(images, st.floats(0.05, 10))
def test_ssim_properties(img, data_range):
    other = np.roll(img, 1, axis=0)
    assert ssim(img, img, data_range) == pytest.approx(1.0, abs=1e-12)
    s = ssim(img, other, data_range)
    assert -1.0 - 1e-12 <= s <= 1.0 + 1e-12
    assert s == pytest.approx(ssim(other, img, data_range), abs=1e-12)  # symmetric


def test_pu21_published_values_and_oracle():
    # Mantiuk & Azimi 2021, banding_glare: PU(100 cd/m²) ≈ 256.38 (≈ 8-bit peak), PU(10 000) ≈ 595.39
    v = pu21_encode([0.005, 100.0, 10000.0])
    assert v[0] == pytest.approx(0.0, abs=1e-6)
    assert v[1] == pytest.approx(256.38, abs=0.01)
    assert v[2] == pytest.approx(595.39, abs=0.01)
    y = np.array([0.0, 1e-4, 0.02, 3.0, 150.0, 9999.0, 5e4])
    np.testing.assert_allclose(pu21_encode(y), pu21_oracle(y), rtol=1e-13)
    assert pu21_encode(0.0) == pu21_encode(0.005) and pu21_encode(2e4) == pu21_encode(1e4)  # clamped
    assert np.all(np.diff(pu21_encode(np.geomspace(0.005, 1e4, 50))) > 0)  # monotone


def test_pu21_scores_scale_the_reference_peak(rng):
    ref = rng.random((24, 24, 3)) ** 3  # linear, wide range
    est = ref * (1 + 0.1 * rng.standard_normal(ref.shape))
    # one factor for both frames: multiplying both by a constant does not change the scores
    assert pu21_psnr(ref, est) == pytest.approx(pu21_psnr(7 * ref, 7 * est), rel=1e-12)
    assert pu21_ssim(ref, est) == pytest.approx(pu21_ssim(0.01 * ref, 0.01 * est), rel=1e-12)
    # ...but an exposure error in the estimate alone is penalised
    assert pu21_psnr(ref, 2 * est) < pu21_psnr(ref, est) - 3
    assert pu21_psnr(ref, ref) == float("inf")
    y = luminance(ref)
    a = pu21_encode(y * 4000 / y.max())
    b = pu21_encode(np.maximum(luminance(est), 0) * 4000 / y.max())
    assert pu21_psnr(ref, est) == pytest.approx(psnr(a, b, 256.0), rel=1e-12)
    assert pu21_ssim(ref, est, peak_luminance=100.0) != pytest.approx(pu21_ssim(ref, est), rel=1e-6)


def test_luminance_rec709():
    np.testing.assert_allclose(luminance(np.array([[[1.0, 1.0, 1.0], [1.0, 0, 0]]])), [[1.0, 0.2126]])


@pytest.mark.parametrize("call, exc, match", [
    (lambda: psnr(np.zeros((4, 4)), np.zeros((4, 5)), 1.0), ValueError, "same shape"),
    (lambda: psnr(np.zeros((4, 4)), np.zeros((4, 4)), 0.0), ValueError, "data_range"),
    (lambda: psnr(np.zeros((4, 4)), np.zeros((4, 4)), None), TypeError, "data_range"),
    (lambda: psnr(np.full((4, 4), np.nan), np.zeros((4, 4)), 1.0), ValueError, "reference has NaN"),
    (lambda: psnr(np.zeros(4), np.zeros(4), 1.0), ValueError, "reference must be an image"),
    (lambda: psnr("a", np.zeros((4, 4)), 1.0), TypeError, "reference"),
    (lambda: ssim(np.zeros((10, 30)), np.zeros((10, 30)), 1.0), ValueError, "at least 11×11"),
    (lambda: ssim(np.zeros((12, 12), bool), np.zeros((12, 12)), 1.0), TypeError, "real numbers"),
    (lambda: pu21_encode([-1.0]), ValueError, "≥ 0"),
    (lambda: pu21_psnr(np.zeros((12, 12, 3)), np.ones((12, 12, 3))), ValueError, "reference is black"),
    (lambda: pu21_psnr(np.ones((12, 12, 3)), np.ones((12, 12, 3)), peak_luminance=-5), ValueError,
     "peak_luminance"),
    (lambda: luminance(np.ones((4, 4, 4))), ValueError, "3 channels"),
])
def test_bad_input(call, exc, match):
    with pytest.raises(exc, match=match):
        call()
