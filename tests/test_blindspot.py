"""Eq. 10–11: masks, masked volume, mask-aware averaging, the three inference modes."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.denoise.blindspot import (
    blindspot_denoise, cell_masks, mask_aware_average, masked_volume, neighbour_fill,
)
from spikeref.oracles.blindspot import mask_aware_average_oracle, masked_volume_oracle


@settings(max_examples=25, deadline=None)
@given(h=st.integers(1, 13), w=st.integers(1, 13), hs=st.integers(1, 5), ws=st.integers(1, 5))
def test_every_pixel_is_hidden_exactly_once(h, w, hs, ws):
    masks = cell_masks(h, w, (hs, ws))
    assert masks.shape == (hs * ws, h, w)
    assert np.array_equal(masks.sum(axis=0), np.ones((h, w)))


def test_mask_order_is_top_to_bottom_left_to_right():
    masks = cell_masks(8, 8)
    assert masks[0, 0, 0] and masks[0, 4, 4] and masks[1, 0, 1] and masks[4, 1, 0] and masks[15, 3, 3]
    assert masks[5].sum() == 4  # one pixel per 4×4 cell, 4 cells


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31), h=st.integers(2, 11), w=st.integers(2, 11))
def test_volume_and_phi_match_the_oracles(seed, h, w):
    rng = np.random.default_rng(seed)
    img = rng.random((h, w))
    np.testing.assert_allclose(masked_volume(img), masked_volume_oracle(img), rtol=1e-12, atol=1e-15)
    outputs = rng.random((16, h, w))
    np.testing.assert_allclose(mask_aware_average(outputs, cell_masks(h, w)), mask_aware_average_oracle(outputs),
                               rtol=1e-12)


def test_fill_is_the_neighbour_mean():
    img = np.zeros((5, 5))
    img[2, 2] = 12.0  # a spike in the centre is invisible to its own fill...
    assert neighbour_fill(img)[2, 2] == 0.0
    img = np.arange(25.0).reshape(5, 5)  # ...and a linear ramp is reproduced exactly inside the plane
    np.testing.assert_allclose(neighbour_fill(img)[1:-1, 1:-1], img[1:-1, 1:-1])
    np.testing.assert_allclose(neighbour_fill(np.full((3, 4), 0.3)), 0.3)


def test_blind_mode_never_sees_the_pixel_it_outputs():
    """With f = identity, D(I) at a pixel is its neighbours' fill: changing the pixel does not change D there."""
    rng = np.random.default_rng(1)
    img = rng.random((2, 12, 12)).astype(np.float32)
    d1 = blindspot_denoise(img, lambda x: x, mode="blind")
    np.testing.assert_allclose(d1, neighbour_fill(img), rtol=1e-6)
    img2 = img.copy()
    img2[0, 5, 7] += 10.0
    d2 = blindspot_denoise(img2, lambda x: x, mode="blind")
    assert d2[0, 5, 7] == pytest.approx(d1[0, 5, 7])


def test_modes():
    rng = np.random.default_rng(2)
    img = rng.random((4, 8, 10))
    halve = lambda x: 0.5 * x  # noqa: E731
    np.testing.assert_allclose(blindspot_denoise(img, halve, "visible"), 0.5 * img)
    blind = blindspot_denoise(img, halve, "blind")
    mixed = blindspot_denoise(img, halve, "mixed", lam=3.0)
    np.testing.assert_allclose(mixed, (blind + 3.0 * 0.5 * img) / 4.0)
    calls = []

    def counting(x):
        calls.append(x.shape)
        return x

    blindspot_denoise(img, counting, "blind")
    assert calls == [(16 * 4, 8, 10)]  # one batch of 16 masked frames per plane


def test_bad_input():
    img = np.zeros((4, 4))
    with pytest.raises(ValueError, match="mode"):
        blindspot_denoise(img, lambda x: x, mode="dark")
    with pytest.raises(ValueError, match="finite"):
        blindspot_denoise(np.full((4, 4), np.nan), lambda x: x)
    with pytest.raises(TypeError, match="floating"):
        masked_volume(np.zeros((4, 4), dtype=np.uint8))
    with pytest.raises(ValueError, match="network returned"):
        blindspot_denoise(img, lambda x: x[..., :2])
    with pytest.raises(ValueError, match="cell"):
        cell_masks(4, 4, 0)
    with pytest.raises(ValueError, match="masks must have shape"):
        mask_aware_average(np.zeros((16, 4, 4)), cell_masks(4, 5))
    with pytest.raises(ValueError, match="lam"):
        blindspot_denoise(img, lambda x: x, "mixed", lam=-1)
