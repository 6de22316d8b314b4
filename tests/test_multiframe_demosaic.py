"""The multi-frame demosaic (spikeref.multiframe_demosaic): against its oracle, and what it is for."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.bayer import bayer_mosaic, bayer_planes, demosaic_bilinear
from spikeref.multiframe_demosaic import MultiframeParams, multiframe_demosaic, plane_channels, plane_sigmas
from spikeref.oracles.multiframe_demosaic import multiframe_demosaic_oracle
from spikeref.simulate.camera import mosaic_radiance

CFAS = ("RGGB", "BGGR", "GRBG", "GBRG")


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2 ** 31 - 1), st.sampled_from(CFAS), st.integers(1, 4))
def test_the_kernel_is_its_oracle(seed, cfa, n):
    rng = np.random.default_rng(seed)
    h, w = 4, 5
    counts = rng.integers(0, 11, size=(n, 4, h, w)).astype(np.float32)
    yy, xx = np.mgrid[0:h, 0:w]
    positions = (np.stack([yy, xx])[None] + rng.uniform(-1.5, 1.5, size=(n, 2, h, w))).astype(np.float32)
    positions = np.where((rng.random((n, h, w)) < 0.1)[:, None], np.float32(np.nan), positions)
    weights = (rng.random((n, h, w)) * (rng.random((n, h, w)) > 0.2)).astype(np.float32)
    fallback = rng.random((2 * h, 2 * w, 3)).astype(np.float32)
    got = multiframe_demosaic(counts, positions, weights, 10.0, cfa, fallback)
    want = multiframe_demosaic_oracle(counts, positions, weights, 10.0, cfa, fallback)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("cfa", CFAS)
def test_one_window_keeps_each_sites_own_value_and_a_flat_colour(cfa):
    """One window at zero displacement: every site keeps its own colour's value to within the kernel's far tail
    (as Ψ does), and a flat colour comes back flat."""
    rng = np.random.default_rng(1)
    h, w = 6, 7
    planes = rng.random((4, h, w)).astype(np.float32) * 10
    yy, xx = np.mgrid[0:h, 0:w]
    pos = np.stack([yy, xx]).astype(np.float32)[None]
    out = multiframe_demosaic(planes[None], pos, np.ones((1, h, w), np.float32), 10.0, cfa,
                              np.zeros((2 * h, 2 * w, 3)))
    ch = plane_channels(cfa)
    for p, (oy, ox) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
        np.testing.assert_allclose(out[oy::2, ox::2, ch[p]], planes[p] / 10, rtol=0.02, atol=0.02)
    flat = np.ones((1, 4, h, w), np.float32) * np.array([3.0, 5.0, 5.0, 7.0], np.float32)[None, :, None, None]
    out = multiframe_demosaic(flat, pos, np.ones((1, h, w), np.float32), 10.0, "RGGB", np.zeros((2 * h, 2 * w, 3)))
    np.testing.assert_allclose(out, np.broadcast_to([0.3, 0.5, 0.7], out.shape), rtol=1e-5)


def test_windows_at_the_four_phases_recover_what_one_mosaic_misses():
    """A fine pattern seen by four windows shifted by one full-resolution pixel in each direction: every colour is
    sampled at every pixel by some window, and the frame is much closer to the truth than Ψ of one window."""
    rng = np.random.default_rng(2)
    big = rng.random((26, 30, 3)).astype(np.float32)  # white noise: nothing Ψ can interpolate
    h, w = 12, 14
    truth = big[1:1 + 2 * h, 1:1 + 2 * w]
    counts, positions = [], []
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    for dy, dx in ((0, 0), (0, 1), (1, 0), (1, 1)):
        # the scene moved by (dy, dx): the reference pixel X is at X + (dy, dx) in window j
        seen = big[1 - dy: 1 - dy + 2 * h, 1 - dx: 1 - dx + 2 * w]
        counts.append(bayer_planes(mosaic_radiance(seen, "RGGB"), "RGGB") * 10)
        positions.append(np.stack([yy + dy / 2, xx + dx / 2]))
    weights = np.ones((4, h, w), np.float32)
    got = multiframe_demosaic(np.stack(counts), np.stack(positions), weights, 10.0, "RGGB",
                              np.zeros((2 * h, 2 * w, 3)))
    one = demosaic_bilinear(bayer_mosaic(counts[0] / 10, "RGGB"), "RGGB")
    inner = (slice(2, -2), slice(2, -2))
    err_multi = np.sqrt(np.mean((got[inner] - truth[inner]) ** 2))
    err_one = np.sqrt(np.mean((one[inner] - truth[inner]) ** 2))
    assert err_multi < 0.6 * err_one  # 0.148 against 0.273 (seed 2): the neighbours at 1 px still weigh in


def test_the_fallback_where_no_window_has_weight_and_nan_positions_are_skipped():
    h, w = 3, 4
    counts = np.full((2, 4, h, w), 5.0, np.float32)
    yy, xx = np.mgrid[0:h, 0:w]
    pos = np.stack([np.stack([yy, xx]).astype(np.float32)] * 2)
    pos[1] = np.nan  # window 1 nowhere: its samples (which would be 9) must not count
    counts[1] = 9.0
    weights = np.ones((2, h, w), np.float32)
    weights[0, 2, 3] = 0.0
    fallback = np.full((2 * h, 2 * w, 3), -1.0, np.float32)
    out = multiframe_demosaic(counts, pos, weights, 10.0, "RGGB", fallback)
    assert np.all(out[4:, 6:] == -1.0)
    np.testing.assert_allclose(out[:4], 0.5, rtol=1e-6)


def test_plane_sigmas_scale_with_the_spacing_of_the_colour_sites():
    np.testing.assert_allclose(plane_sigmas(plane_channels("GRBG"), 0.6), [0.6 / np.sqrt(2), 0.6, 0.6,
                                                                          0.6 / np.sqrt(2)])
    assert plane_channels("BGGR").tolist() == [2, 1, 1, 0]


def test_bad_arguments_are_named():
    h, w = 3, 4
    counts = np.zeros((2, 4, h, w), np.float32)
    pos = np.zeros((2, 2, h, w), np.float32)
    wt = np.ones((2, h, w), np.float32)
    fb = np.zeros((2 * h, 2 * w, 3), np.float32)
    with pytest.raises(ValueError, match="counts must be"):
        multiframe_demosaic(counts[0], pos, wt, 10.0, "RGGB", fb)
    with pytest.raises(ValueError, match="positions must have shape"):
        multiframe_demosaic(counts, pos[:1], wt, 10.0, "RGGB", fb)
    with pytest.raises(ValueError, match="weights must be"):
        multiframe_demosaic(counts, pos, -wt, 10.0, "RGGB", fb)
    with pytest.raises(ValueError, match="window must be"):
        multiframe_demosaic(counts, pos, wt, 0.0, "RGGB", fb)
    with pytest.raises(ValueError, match="cfa must be"):
        multiframe_demosaic(counts, pos, wt, 10.0, "RGBX", fb)
    with pytest.raises(ValueError, match="fallback must have shape"):
        multiframe_demosaic(counts, pos, wt, 10.0, "RGGB", fb[:2])
    with pytest.raises(TypeError, match="params must be"):
        multiframe_demosaic(counts, pos, wt, 10.0, "RGGB", fb, params={"sigma": 1})
    with pytest.raises(ValueError, match="sigma"):
        MultiframeParams(sigma=0.0)


def test_the_increment_is_kept_where_it_is_detail_and_dropped_where_it_is_noise():
    """``shrink_increment``: a flat base plus an increment that is white noise on the left half and a strong stripe
    pattern (plus the same noise) on the right: the left is pulled back to the base, the right keeps its stripes."""
    from spikeref.multiframe_demosaic import shrink_increment

    rng = np.random.default_rng(3)
    base = np.full((40, 40, 3), 0.4)
    noise = rng.normal(0.0, 0.01, size=base.shape)
    stripes = np.zeros_like(base)
    stripes[:, 20:] = 0.1 * np.where(np.arange(20) % 2, 1.0, -1.0)[None, :, None]
    out = shrink_increment(base + noise + stripes, base)
    left = np.sqrt(np.mean((out[4:-4, 4:16] - base[4:-4, 4:16]) ** 2))
    assert left < 0.5 * 0.01
    kept = out[4:-4, 24:36] - base[4:-4, 24:36]
    assert np.corrcoef(kept.ravel(), stripes[4:-4, 24:36].ravel())[0, 1] > 0.95
    np.testing.assert_array_equal(shrink_increment(base, base), base.astype(np.float32))
    with pytest.raises(ValueError, match="box must be"):
        shrink_increment(base, base, box=4)
    with pytest.raises(ValueError, match="rgb and base"):
        shrink_increment(base, base[:, :, :2])


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 5))
def test_phase_diversity_is_its_oracle(seed, n):
    from spikeref.multiframe_demosaic import phase_diversity
    from spikeref.oracles.multiframe_demosaic import phase_diversity_oracle

    rng = np.random.default_rng(seed)
    h, w = 3, 4
    yy, xx = np.mgrid[0:h, 0:w]
    positions = (np.stack([yy, xx])[None] + rng.uniform(-2.5, 2.5, size=(n, 2, h, w))).astype(np.float32)
    positions = np.where((rng.random((n, h, w)) < 0.15)[:, None], np.float32(np.nan), positions)
    weights = (rng.random((n, h, w)) * (rng.random((n, h, w)) > 0.2)).astype(np.float32)
    got = phase_diversity(positions, weights)
    np.testing.assert_allclose(got, phase_diversity_oracle(positions, weights), rtol=1e-9, atol=1e-12)
    assert got.min() >= 0 and got.max() <= 1


def test_phase_diversity_is_zero_on_the_reference_lattice_and_one_a_pixel_off():
    from spikeref.multiframe_demosaic import phase_diversity

    h, w = 2, 3
    grid = np.mgrid[0:h, 0:w].astype(np.float64)[None]
    ones = np.ones((3, h, w))
    # whole plane pixels (two full-resolution pixels) keep the CFA phase: no diversity, whatever the weights
    still = grid + np.array([0.0, 1.0, -2.0])[:, None, None, None]
    np.testing.assert_array_equal(phase_diversity(still, ones), 0.0)
    # half a plane pixel is one full-resolution pixel: the other phase, capped at 1 on a diagonal
    np.testing.assert_allclose(phase_diversity(grid + 0.5, ones[:1]), 1.0)
    # a quarter plane pixel right: 0.5 px off; the reference window at weight 3 against 1 → 0.5 / 4
    pos = np.concatenate([grid, grid + np.array([0.0, 0.25])[None, :, None, None]])
    np.testing.assert_allclose(phase_diversity(pos, np.stack([3 * ones[0], ones[0]])), 0.125)
    # a cell no window reaches, or whose windows have no weight: 0 (the MHC correction in full)
    pos[:, :, 0, 0] = np.nan
    assert phase_diversity(pos, np.ones((2, h, w)))[0, 0] == 0.0
    with pytest.raises(ValueError, match="weights must be finite"):
        phase_diversity(pos, np.ones((1, h, w)))
    with pytest.raises(ValueError, match="positions must be"):
        phase_diversity(np.zeros((2, h, w)), np.ones((2, h, w)))


def test_colour_saturation_of_grey_pure_and_mixed_colours():
    from spikeref.multiframe_demosaic import colour_saturation

    rgb = np.zeros((4, 9, 3), np.float32)
    rgb[:, :3] = 0.4  # grey
    rgb[:, 3:6] = (0.5, 0.0, 0.0)  # pure red
    rgb[:, 6:] = (0.4, 0.2, 0.1)  # (0.4 − 0.1) / 0.4
    s = colour_saturation(rgb, box=1)
    assert s.shape == (4, 9) and s.dtype == np.float32
    np.testing.assert_allclose(s[0], [0, 0, 0, 1, 1, 1, 0.75, 0.75, 0.75], atol=1e-6)
    assert colour_saturation(np.zeros((2, 2, 3)))[0, 0] == 0  # black: not saturated
    assert colour_saturation(-rgb)[0, 0] == 0  # negative counts as 0
    with pytest.raises(ValueError, match="box must be an odd"):
        colour_saturation(rgb, box=2)
    with pytest.raises(ValueError, match="rgb must be"):
        colour_saturation(rgb[..., 0])


def test_the_gain_takes_the_noise_of_a_pixel_merged_from_fewer_windows():
    """``relative`` scales ``σ²`` per pixel: 1 is the default; where it is larger less of a noisy increment is kept."""
    from spikeref.multiframe_demosaic import shrink_increment

    rng = np.random.default_rng(5)
    base = np.full((32, 40, 3), 0.3)
    noisy = base + rng.normal(0, 0.02, base.shape)
    np.testing.assert_array_equal(shrink_increment(noisy, base, relative=np.ones((32, 40))),
                                  shrink_increment(noisy, base))
    rel = np.ones((32, 40))
    rel[:, 20:] = 4.0  # the right half merged from a quarter of the windows
    kept = np.abs(shrink_increment(noisy, base, relative=rel) - base).mean(axis=(0, 2))
    assert kept[25:].mean() < 0.25 * kept[:15].mean()
    with pytest.raises(ValueError, match="relative must be"):
        shrink_increment(noisy, base, relative=np.ones((32, 39)))
    with pytest.raises(ValueError, match="relative must be"):
        shrink_increment(noisy, base, relative=-rel)


def test_the_frame_where_the_merge_took_one_window_is_psi_and_its_correction():
    """``multiframe_frame(windows=)``: with one window merged everywhere the gathered frame adds nothing (the same
    frame whatever weights its windows have, on the reference's CFA lattice); with as many windows everywhere
    (≥ ``GATHER_RAMP``) the frame is the one without ``windows``."""
    from spikeref.multiframe_demosaic import GATHER_RAMP, multiframe_frame

    rng = np.random.default_rng(8)
    n, h, w, window = 3, 8, 10, 10
    counts = rng.integers(0, window + 1, size=(n, 4, h, w)).astype(np.float32)
    grid = np.stack(np.mgrid[0:h, 0:w]).astype(np.float32)
    # whole plane pixels: on the reference's CFA lattice (δ = 0, the MHC correction the same for any weights)
    positions = np.stack([grid + rng.integers(-1, 2, size=(2, h, w)).astype(np.float32) for _ in range(n)])
    weights = rng.uniform(0.2, 1.0, size=(n, h, w)).astype(np.float32)
    merged = (counts * weights[:, None]).sum(0) / weights.sum(0)[None] / window
    denoised = merged * 0.98

    def frame(wts, windows):
        return multiframe_frame(counts, positions, wts, float(window), "RGGB", merged, denoised, windows)

    one = np.ones((h, w), np.float32)
    np.testing.assert_allclose(frame(weights, one), frame(weights[::-1].copy(), one), atol=1e-6)
    assert np.abs(frame(weights, None) - frame(weights[::-1].copy(), None)).max() > 1e-3  # without: it does
    many = np.full((h, w), GATHER_RAMP, np.float32)
    np.testing.assert_allclose(frame(weights, many), frame(weights, None), atol=1e-6)
    with pytest.raises(ValueError, match="windows must be"):
        frame(weights, one[:, :-1])
    with pytest.raises(ValueError, match="windows must be"):
        frame(weights, 0 * one)


def test_colour_detail_ratio_of_grey_tinted_checkerboard_and_one_colour_detail():
    """``ρ`` (numbers from the definition): 0 for grey detail, 0.01/0.82 for detail tinted (1, 0.9, 0.8), 1/3 on a
    red-and-white checkerboard (red flat, green and blue alike), 1 where only red varies, 0 where flat."""
    from spikeref.multiframe_demosaic import colour_detail_ratio

    rng = np.random.default_rng(3)
    tex = rng.random((16, 20))
    grey = np.repeat(tex[..., None], 3, axis=-1)
    np.testing.assert_allclose(colour_detail_ratio(grey), 0, atol=1e-6)
    tinted = tex[..., None] * np.array([1.0, 0.9, 0.8])
    np.testing.assert_allclose(colour_detail_ratio(tinted), 0.01 / 0.82, rtol=1e-5)
    chk = (np.indices((16, 20)).sum(0) % 2).astype(np.float64)
    red_white = np.stack([np.ones_like(chk), chk, chk], axis=-1)
    np.testing.assert_allclose(colour_detail_ratio(red_white), 1 / 3, rtol=1e-5)
    red_only = np.stack([tex, np.full_like(tex, 0.5), np.full_like(tex, 0.5)], axis=-1)
    np.testing.assert_allclose(colour_detail_ratio(red_only), 1, rtol=1e-5)
    out = colour_detail_ratio(np.full((6, 8, 3), 0.3))
    assert out.shape == (6, 8) and out.dtype == np.float32 and np.all(out == 0)
    with pytest.raises(ValueError, match="box must be an odd"):
        colour_detail_ratio(grey, box=4)
    with pytest.raises(ValueError, match="rgb must be"):
        colour_detail_ratio(tex)


def test_the_correction_is_directional_where_the_colours_share_detail(monkeypatch):
    """A still grey scene of stripes along the rows (every window the same, on the reference's CFA lattice): the
    frame takes the directional demosaic's correction, exact on such stripes, and its error is well below the
    frame's with Malvar–He–Cutler's correction alone (``ρ`` forced to ``DETAIL_GATE``: the directional share 0)."""
    import spikeref.multiframe_demosaic as mfd
    from spikeref.bayer import bayer_planes, cfa_channel_map

    rng = np.random.default_rng(4)
    h, w, n, window = 12, 16, 4, 10
    grey = np.repeat(rng.uniform(0.2, 0.8, 2 * h)[:, None], 2 * w, axis=1)
    chan = cfa_channel_map(2 * h, 2 * w, "RGGB").astype(np.int64)
    mosaic = np.take_along_axis(np.repeat(grey[..., None], 3, -1), chan[..., None], -1)[..., 0]
    planes = bayer_planes(mosaic.astype(np.float32), "RGGB")
    counts = np.repeat(planes[None] * window, n, axis=0)
    positions = np.repeat(np.stack(np.mgrid[0:h, 0:w]).astype(np.float32)[None], n, axis=0)
    weights = np.ones((n, h, w), np.float32)

    def err():
        out = mfd.multiframe_frame(counts, positions, weights, float(window), "RGGB", planes, planes)
        return float(np.mean((out - grey[..., None]) ** 2))

    directional = err()
    monkeypatch.setattr(mfd, "colour_detail_ratio",
                        lambda rgb, box=mfd.SATURATION_BOX: np.full(rgb.shape[:2], mfd.DETAIL_GATE))
    assert directional < 0.5 * err()
