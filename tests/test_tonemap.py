import numpy as np
import pytest

from spikeref.tonemap import Exposure, choose_exposure, srgb_decode, srgb_encode, tonemap


def test_srgb_reference_values():
    # IEC 61966-2-1: linear 0.0031308 is the knee (12.92 × → 0.04045); 0.18 grey encodes to ≈ 0.4614
    assert srgb_encode(0.0031308) == pytest.approx(0.04045, abs=1e-6)
    assert srgb_encode(0.18) == pytest.approx(0.4613561, abs=1e-6)
    assert srgb_encode(1.0) == pytest.approx(1.0)
    x = np.linspace(0, 1, 101)
    np.testing.assert_allclose(srgb_decode(srgb_encode(x)), x, atol=1e-12)


def test_tonemap_is_monotone_clipped_and_handles_non_finite():
    frame = np.array([[-1.0, 0.0, 0.5, 1.0, 7.0, np.nan, np.inf]])
    out = tonemap(frame, Exposure(1.0))
    assert out.dtype == np.uint8
    assert out.tolist() == [[0, 0, 188, 255, 255, 0, 255]]


def test_one_exposure_from_frames():
    frames = np.linspace(0, 2, 1000).reshape(10, 10, 10)
    exposure = choose_exposure(frames, percentile=100, target=1.0)
    assert exposure.gain == pytest.approx(0.5)
    assert choose_exposure(np.zeros((3, 4))).gain == 1.0
    with pytest.raises(ValueError, match="exposure gain"):
        Exposure(0.0)
    with pytest.raises(ValueError, match="percentile"):
        choose_exposure(frames, percentile=0)
