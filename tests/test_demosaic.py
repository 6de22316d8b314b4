"""The Malvar–He–Cutler demosaic (spikeref.demosaic): the oracle, exactness on linear ramps, a sharper limit."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.bayer import cfa_channel_map, demosaic_bilinear
from spikeref.demosaic import demosaic, demosaic_mhc
from spikeref.oracles.demosaic import demosaic_mhc_oracle


def _mosaic(rgb, cfa):
    chan = cfa_channel_map(rgb.shape[0], rgb.shape[1], cfa).astype(np.int64)
    return np.take_along_axis(rgb, chan[..., None], axis=-1)[..., 0]


@settings(max_examples=12, deadline=None)
@given(st.sampled_from(["RGGB", "BGGR", "GRBG", "GBRG"]), st.integers(1, 5), st.integers(1, 5), st.integers(0, 999))
def test_matches_the_oracle(cfa, hh, ww, seed):
    m = np.random.default_rng(seed).random((2 * hh, 2 * ww))
    np.testing.assert_allclose(demosaic_mhc(m, cfa), demosaic_mhc_oracle(m, cfa), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("cfa", ["RGGB", "BGGR", "GRBG", "GBRG"])
def test_grey_ramp_is_exact_inside(cfa):
    """A grey image that is linear in x and y is reproduced exactly away from the border (bilinear is too)."""
    yy, xx = np.mgrid[0:16, 0:20].astype(np.float64)
    grey = 0.2 + 0.01 * xx + 0.02 * yy
    rgb = np.repeat(grey[..., None], 3, axis=-1)
    out = demosaic_mhc(_mosaic(rgb, cfa), cfa)
    np.testing.assert_allclose(out[2:-2, 2:-2], rgb[2:-2, 2:-2], atol=1e-12)
    assert demosaic_mhc(np.ones((4, 4), np.float32)).dtype == np.float32


def test_sharper_than_bilinear_on_fine_grey_detail():
    """Fine grey detail (all channels alike, as in most natural images): MHC's error is well below Ψ's."""
    rng = np.random.default_rng(1)
    from scipy.ndimage import gaussian_filter

    grey = gaussian_filter(rng.random((64, 64)), 1.2)
    rgb = np.stack([grey, 0.9 * grey, 0.8 * grey], axis=-1)
    m = _mosaic(rgb, "RGGB")
    inner = (slice(4, -4), slice(4, -4))
    err_mhc = np.mean((demosaic_mhc(m)[inner] - rgb[inner]) ** 2)
    err_bil = np.mean((demosaic_bilinear(m)[inner] - rgb[inner]) ** 2)
    assert err_mhc < 0.5 * err_bil


def test_negative_lobes_are_clipped_and_names_are_checked():
    m = np.zeros((8, 8))
    m[4, 4] = 1.0  # a single bright sample: the filters' negative lobes would go below 0 nearby
    assert demosaic_mhc(m).min() == 0.0
    np.testing.assert_array_equal(demosaic(m, "RGGB", "bilinear"), demosaic_bilinear(m, "RGGB"))
    with pytest.raises(ValueError, match="demosaic must be one of bilinear, mhc"):
        demosaic(m, "RGGB", "ahd")
    with pytest.raises(ValueError, match="even"):
        demosaic_mhc(np.zeros((5, 4)))
