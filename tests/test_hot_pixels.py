"""Hot pixels (spikeref.hot_pixels): found in the recording, replaced in every window; the simulator's effect."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.hot_pixels import (HotPixelParams, HotPixelRepair, find_hot_pixels, hot_pixel_excess,
                                 load_hot_pixel_map, repair_oracle, save_hot_pixel_map)


def _bernoulli(rates: np.ndarray, planes: int, seed: int = 0) -> np.ndarray:
    """``(planes, H, W) uint8`` spikes, each readout of pixel x a Bernoulli(rates[x]) draw."""
    return (np.random.default_rng(seed).random((planes,) + rates.shape) < rates).astype(np.uint8)


def _smooth_scene(shape=(48, 64), seed=3) -> np.ndarray:
    from scipy.ndimage import gaussian_filter

    g = gaussian_filter(np.random.default_rng(seed).standard_normal(shape), 4.0)
    return 0.1 + 0.4 * (g - g.min()) / (g.max() - g.min())


def test_hot_pixels_on_a_smooth_scene_are_found_and_nothing_else():
    rates = _smooth_scene()
    hot = np.zeros(rates.shape, bool)
    hot[[5, 20, 33, 40], [7, 50, 12, 61]] = True
    spikes = _bernoulli(np.clip(rates + 0.4 * hot, 0, 1), 800)
    found = find_hot_pixels(spikes)
    np.testing.assert_array_equal(found, hot)
    assert not find_hot_pixels(_bernoulli(rates, 800, seed=1)).any()  # the same scene without them: none


def test_a_moving_bright_point_is_not_a_hot_pixel():
    """A point that sits in each place for a quarter of the stretch stands out in one block only."""
    planes, h, w = 800, 32, 32
    rates = np.full((planes, h, w), 0.1)
    for b in range(4):
        rates[b * 200:(b + 1) * 200, 10, 4 + 6 * b] = 0.9
    spikes = (np.random.default_rng(0).random(rates.shape) < rates).astype(np.uint8)
    assert not find_hot_pixels(spikes).any()
    e = hot_pixel_excess(spikes)
    assert e["excess"][10, 4] > 0.1 and e["block_excess"][10, 4] < 0.1  # above its colour, in one block only


def test_a_spot_of_light_lighting_its_neighbours_is_not_a_hot_pixel():
    """A static bright point that reaches the neighbouring photosites (of the other colours) is the scene."""
    rates = np.full((32, 32), 0.1)
    rates[15:18, 15:18] = 0.3
    rates[16, 16] = 0.8
    spikes = _bernoulli(rates, 800)
    assert not find_hot_pixels(spikes)[16, 16]
    lone = np.full((32, 32), 0.1)
    lone[16, 16] = 0.8
    assert find_hot_pixels(_bernoulli(lone, 800))[16, 16]


def test_two_hot_pixels_side_by_side_are_both_found_but_a_blob_is_not():
    rates = np.full((32, 32), 0.1)
    pair = rates.copy()
    pair[10, 10] = pair[11, 10] = 0.7
    found = find_hot_pixels(_bernoulli(pair, 800))
    assert found[10, 10] and found[11, 10] and found.sum() == 2
    blob = rates.copy()
    blob[10:12, 10:12] = 0.7  # four lit photosites, each next to two others: light, not a defect
    assert not find_hot_pixels(_bernoulli(blob, 800)).any()


def test_a_stretch_too_short_finds_nothing_and_bad_arguments_are_named():
    spikes = _bernoulli(np.full((8, 8), 0.5), 6)
    assert not find_hot_pixels(spikes).any()  # fewer than 2 readouts a block
    with pytest.raises(ValueError, match="start must be a readout"):
        find_hot_pixels(spikes, start=6)
    with pytest.raises(ValueError, match="even height and width"):
        find_hot_pixels(np.zeros((10, 7, 8), np.uint8))
    with pytest.raises(TypeError, match="params must be a HotPixelParams"):
        find_hot_pixels(spikes, params={"planes": 10})
    with pytest.raises(ValueError, match="blocks must be a whole number"):
        HotPixelParams(blocks=0)
    with pytest.raises(ValueError, match="sigmas must be a finite number"):
        HotPixelParams(sigmas=float("nan"))


def test_the_stretch_read_is_the_one_asked_for():
    """``start`` and ``planes`` choose the readouts: a defect that appears later is not in an earlier stretch."""
    rates = np.full((600, 16, 16), 0.1)
    rates[300:, 8, 8] = 0.9
    spikes = (np.random.default_rng(2).random(rates.shape) < rates).astype(np.uint8)
    p = HotPixelParams(planes=300)
    assert not find_hot_pixels(spikes, params=p).any()
    assert find_hot_pixels(spikes, start=300, params=p)[8, 8]


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(1, 6), st.integers(0, 2 ** 31 - 1), st.floats(0.0, 0.2))
def test_repair_matches_its_oracle_in_the_mosaic_and_the_planes(hh, hw, seed, density):
    from spikeref.bayer import bayer_mosaic, bayer_planes

    rng = np.random.default_rng(seed)
    h, w = 2 * hh, 2 * hw
    mask = rng.random((h, w)) < density
    mosaic = rng.random((3, h, w)).astype(np.float32)
    repair = HotPixelRepair(mask)
    got = repair.mosaic(mosaic.copy())
    want = np.stack([repair_oracle(m, mask) for m in mosaic])
    np.testing.assert_allclose(got, want, rtol=1e-6)
    planes = repair.planes(bayer_planes(mosaic))
    np.testing.assert_array_equal(bayer_mosaic(planes), got)
    assert np.array_equal(got[:, ~mask], mosaic[:, ~mask])  # only the hot pixels change


def test_repair_by_hand():
    mosaic = np.arange(36, dtype=np.float64).reshape(6, 6)
    mask = np.zeros((6, 6), bool)
    mask[2, 2] = mask[0, 0] = True
    out = HotPixelRepair(mask).mosaic(mosaic.copy())
    # (2, 2): its same-colour neighbours (0, 2), (0, 4), (2, 4), (4, 0), (4, 2), (4, 4), (2, 0) — (0, 0) is hot
    assert out[2, 2] == pytest.approx(np.mean([2, 4, 16, 24, 26, 28, 12]))
    # (0, 0): (0, 2), (2, 0) and (2, 2)'s is hot: the mean of two
    assert out[0, 0] == pytest.approx(np.mean([2, 12]))
    walled = np.zeros((2, 2), bool)
    walled[0, 0] = True  # no same-colour neighbour inside the image: kept
    assert HotPixelRepair(walled).mosaic(np.ones((2, 2)) * 5)[0, 0] == 5


def test_repair_refuses_what_it_cannot_do_in_place():
    repair = HotPixelRepair(np.eye(4, dtype=bool))
    with pytest.raises(TypeError, match="float ndarray"):
        repair.mosaic(np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError, match=r"end in shape \(4, 4\)"):
        repair.mosaic(np.zeros((4, 6)))
    with pytest.raises(TypeError, match="mask must be a"):
        HotPixelRepair(np.eye(4))
    with pytest.raises(ValueError, match="even height"):
        HotPixelRepair(np.zeros((3, 4), bool))


def test_map_round_trip_and_bad_maps(tmp_path):
    mask = np.zeros((4, 6), bool)
    mask[1, 2] = True
    path = save_hot_pixel_map(tmp_path / "m.npz", mask, planes=100)
    np.testing.assert_array_equal(load_hot_pixel_map(path, (4, 6)), mask)
    with pytest.raises(ValueError, match="a map of 4×6 pixels for a recording of 8×8"):
        load_hot_pixel_map(path, (8, 8))
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="no array 'hot'"):
        load_hot_pixel_map(tmp_path / "other.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a readable hot-pixel map"):
        load_hot_pixel_map(tmp_path / "junk.npz")
    with pytest.raises(FileNotFoundError):
        load_hot_pixel_map(tmp_path / "none.npz")
