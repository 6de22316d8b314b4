"""HDR+ tile alignment (§4.2, supplement "Progressive warping"): kernels vs oracle, known motions, edge cases."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from spikeref._align_kernels import (
    block_distances, block_distances_l1_l2, search_fit_tiles, search_tiles, subpixel_fit, three_distances,
    fit_offset, gradient, lucas_kanade, nearest_tiles, tile_distance, window_distances,
)
from spikeref._align_kernels import regularise
from spikeref.align import AlignParams, align, align_tiles, flow_from_tiles, gaussian_pyramid, luma
from spikeref.align_params import SMOOTHNESS_SWEEPS
from spikeref.align_noise import estimate_noise, estimate_noise_correlation, local_noise, zero_motion_test
from spikeref.oracles.align import (
    align_oracle, align_tiles_oracle, estimate_noise_correlation_oracle, estimate_noise_oracle, flow_from_tiles_oracle,
    gaussian_pyramid_oracle, gradient_oracle, level_noise_factors_oracle, local_noise_oracle, lucas_kanade_oracle,
    nearest_tiles_oracle, quadratic_offset_oracle, regularise_oracle, zero_motion_sums_oracle, zero_motion_test_oracle,
)
from spikeref.warp import warp_bilinear

SMALL = AlignParams(levels=2, tile_by_step=(8, 4), coarse_tile=4, search_radius=(1, 2))


def texture(shape, sigma=2.0, seed=0):
    """Smooth periodic random texture: Gaussian-filtered white noise (wrap), so np.roll is seamless."""
    rng = np.random.default_rng(seed)
    return ndimage.gaussian_filter(rng.standard_normal(shape), sigma, mode="wrap").astype(np.float32)


def fourier_shift(image, shift):
    """``out(p) = image(p − shift)`` for a periodic image, so ``out[y + dy, x + dx] = image[y, x]``."""
    return np.fft.ifft2(ndimage.fourier_shift(np.fft.fft2(image), shift)).real.astype(np.float32)


# ----------------------------------------------------------------------------- kernel == oracle
@pytest.mark.parametrize("shape, step, subpixel", [((64, 64), 0, True), ((72, 96), 0, False),
                                                   ((72, 96), 2, True), ((67, 81), 1, True)])
def test_kernels_match_the_oracle_on_random_images(shape, step, subpixel):
    rng = np.random.default_rng(sum(shape) + step)
    params = AlignParams(subpixel=subpixel)
    ref = rng.random(shape, dtype=np.float32)
    # half the pairs unrelated noise (arbitrary vectors, clamped borders), half a noisy shifted copy
    for alt in (rng.random(shape, dtype=np.float32),
                np.roll(ref, (5, -3), axis=(0, 1)) + 0.1 * rng.random(shape, dtype=np.float32)):
        vectors, tile = align_tiles(ref, alt, step, params)
        expected, tile_o = align_tiles_oracle(ref, alt, step, params)
        assert tile == tile_o == params.tile_for_step(step)
        assert vectors.dtype == np.float32 and vectors.shape == expected.shape
        np.testing.assert_allclose(vectors, expected, rtol=0, atol=1e-5)
        if not subpixel:  # integer vectors: exactly equal
            np.testing.assert_array_equal(vectors, expected)
            assert np.all(vectors == np.round(vectors))
        flow = align(ref, alt, step, params)
        assert flow.dtype == np.float32 and flow.shape == (2,) + shape
        np.testing.assert_allclose(flow, align_oracle(ref, alt, step, params), rtol=0, atol=1e-5)
        np.testing.assert_array_equal(flow, flow_from_tiles(vectors, tile, shape))


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31), h=st.integers(8, 30), w=st.integers(8, 30), r0=st.integers(0, 2),
       r1=st.integers(0, 2), subpixel=st.booleans(), shift=st.tuples(st.integers(-3, 3), st.integers(-3, 3)))
def test_kernels_match_the_oracle_property(seed, h, w, r0, r1, subpixel, shift):
    rng = np.random.default_rng(seed)
    params = AlignParams(levels=2, tile_by_step=(8, 4), coarse_tile=4, search_radius=(r0, r1), subpixel=subpixel)
    ref = rng.random((h, w)).astype(np.float32)
    alt = np.roll(ref, shift, axis=(0, 1)) + 0.3 * rng.random((h, w)).astype(np.float32)
    for step in (0, 1):
        vectors, tile = align_tiles(ref, alt, step, params)
        expected, _ = align_tiles_oracle(ref, alt, step, params)
        np.testing.assert_allclose(vectors, expected, rtol=0, atol=1e-5)


def test_pyramid_matches_the_oracle_and_keeps_constants():
    img = np.random.default_rng(3).random((37, 50)).astype(np.float32)
    pyr = gaussian_pyramid(img, 4)
    assert [p.shape for p in pyr] == [(37, 50), (19, 25), (10, 13), (5, 7)]  # ceil(n / 2) per level
    assert all(p.dtype == np.float32 for p in pyr)
    assert np.array_equal(pyr[0], img)
    for got, want in zip(pyr, gaussian_pyramid_oracle(img, 4), strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=0)
    for p in gaussian_pyramid(np.full((20, 9), 0.37, np.float32), 3):
        np.testing.assert_array_equal(p, np.float32(0.37))
    assert len(gaussian_pyramid(img, 1)) == 1


def test_pyramid_blur_is_the_binomial_with_edge_replicate():
    img = np.zeros((9, 9))
    img[4, 4] = 256.0
    level1 = gaussian_pyramid(img, 2)[1]  # rows/cols 0, 2, 4, 6, 8 of the blurred impulse
    e = np.array([0.0, 1.0, 6.0, 1.0, 0.0])  # taps 1, 6, 1 of [1, 4, 6, 4, 1] land on the kept pixels 2, 4, 6
    np.testing.assert_array_equal(level1, np.outer(e, e))  # 256 · (e/16) ⊗ (e/16)
    ramp = np.tile(np.arange(6.0), (6, 1))  # the edge is replicated: column 0 sees 0, 0, 0, 1, 2
    assert gaussian_pyramid(ramp, 2)[1][0, 0] == pytest.approx((0 + 0 + 0 + 4 + 2) / 16.0)


def test_luma_is_the_mean_of_the_four_planes():
    rng = np.random.default_rng(4)
    planes = rng.random((3, 4, 5, 6))
    out = luma(planes)
    assert out.shape == (3, 5, 6) and out.dtype == np.float32
    np.testing.assert_allclose(out, (planes[:, 0] + planes[:, 1] + planes[:, 2] + planes[:, 3]) / 4, rtol=1e-6)
    np.testing.assert_array_equal(luma(np.arange(4, dtype=np.uint16).reshape(4, 1, 1)), [[1.5]])
    with pytest.raises(ValueError, match="planes"):
        luma(np.zeros((3, 5, 6)))
    with pytest.raises(TypeError, match="planes"):
        luma(np.zeros((4, 5, 6), complex))
    with pytest.raises(ValueError, match="planes"):
        luma(np.full((4, 2, 2), np.nan))


# ----------------------------------------------------------------------------- pieces
def test_nearest_coarse_tiles():
    # fine T = 16 (stride 8) over coarse T = 8 (stride 4): fine centre 8i + 7.5 → 4i + 3.75 on the coarse grid,
    # coarse centres 4m + 3.5: nearest m = i, neighbour on the right/bottom side i + 1 (clamped at the end)
    for i in range(7):
        c = 8 * i + 7.5
        expected = (i, min(i + 1, 6))
        assert nearest_tiles(c, 8, 7) == expected == nearest_tiles_oracle(c, 32, 8)
    # fine T = 8 (stride 4): centre 4i + 3.5 → 2i + 1.75 between the coarse centres 4m + 3.5 (clamped at 0)
    got = [nearest_tiles(4 * i + 3.5, 8, 5) for i in range(8)]
    assert got == [(0, 0), (0, 1), (1, 0), (1, 2), (2, 1), (2, 3), (3, 2), (3, 4)]
    assert got == [nearest_tiles_oracle(4 * i + 3.5, 24, 8) for i in range(8)]


def test_quadratic_fit_recovers_a_quadratic_minimum():
    a = np.array([[2.0, 0.7], [0.7, 1.5]])
    u0 = np.array([0.3, -0.45])
    d = np.array([[0.5 * (np.array([uy, ux]) - u0) @ a @ (np.array([uy, ux]) - u0) + 3.0 for ux in (-1, 0, 1)]
                  for uy in (-1, 0, 1)])
    uy, ux, ok = fit_offset(d)
    assert ok
    np.testing.assert_allclose([uy, ux], u0, atol=1e-12)
    np.testing.assert_allclose(quadratic_offset_oracle(d), u0, atol=1e-12)
    saddle = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    assert not fit_offset(saddle)[2] and quadratic_offset_oracle(saddle) is None
    far = np.array([[0.5 * ((uy - 1.8) ** 2 + ux * ux) for ux in (-1, 0, 1)] for uy in (-1, 0, 1)])
    assert not fit_offset(far)[2] and quadratic_offset_oracle(far) is None  # |u*| > 1: keep the integer
    assert not fit_offset(np.full((3, 3), 2.0))[2]  # flat: A = 0 is not positive definite


def test_flow_from_tiles_matches_the_oracle_and_interpolates():
    rng = np.random.default_rng(5)
    shape, tile = (41, 38), 8  # 9 × 8 tiles (stride 4); rows 40 and cols 36–37 lie beyond the last tile
    vectors = rng.standard_normal((9, 8, 2)).astype(np.float32)
    flow = flow_from_tiles(vectors, tile, shape)
    assert flow.shape == (2, 41, 38) and flow.dtype == np.float32
    np.testing.assert_allclose(flow, flow_from_tiles_oracle(vectors, tile, shape), rtol=0, atol=1e-6)
    np.testing.assert_allclose(flow[:, 0, 0], vectors[0, 0], atol=1e-6)  # clamped beyond the outer centres
    np.testing.assert_allclose(flow[:, 40, 37], vectors[8, 7], atol=1e-6)
    # vectors linear in the tile index are reproduced exactly: tile (i, j) has its centre at (4i + 3.5, 4j + 3.5)
    i, j = np.meshgrid(np.arange(9), np.arange(8), indexing="ij")
    plane = np.stack([i + 2.0 * j, -j / 4.0], axis=-1).astype(np.float32)
    y, x = np.meshgrid(np.arange(41.0), np.arange(38.0), indexing="ij")
    ty, tx = np.clip((y - 3.5) / 4, 0, 8), np.clip((x - 3.5) / 4, 0, 7)
    np.testing.assert_allclose(flow_from_tiles(plane, tile, shape), [ty + 2 * tx, -tx / 4], atol=1e-5)
    const = flow_from_tiles(np.broadcast_to(np.float32([1.5, -2.0]), (9, 8, 2)), tile, shape)
    np.testing.assert_array_equal(const[0], 1.5)
    np.testing.assert_array_equal(const[1], -2.0)
    single = flow_from_tiles(np.float32([[[0.25, 4.0]]]), 16, (16, 23))  # one tile: constant
    np.testing.assert_array_equal(single[1], 4.0)


# ----------------------------------------------------------------------------- known motion
@pytest.mark.parametrize("shift", [(0, 0), (1, -1), (3, 0), (-2, 5), (7, -11), (-20, 13)])
def test_integer_shift_is_found_exactly(shift):
    ref = texture((192, 192), seed=1)
    alt = np.roll(ref, shift, axis=(0, 1))  # alt[y + dy, x + dx] = ref[y, x]
    flow = align(ref, alt)
    # tiles whose search reaches past the edge see clamped samples, not the wrapped texture; with
    # step 0's 32-pixel tiles their vectors reach 56 pixels in through the bilinear interpolation
    b = 56
    np.testing.assert_array_equal(flow[0, b:-b, b:-b], shift[0])
    np.testing.assert_array_equal(flow[1, b:-b, b:-b], shift[1])


# exact recovery is an empirical property of textured input (an 8-pixel tile can meet the aperture problem),
# so the examples are derandomized: 0 failures in 600 seeded trials of this kind, none of them flaky
@settings(max_examples=10, deadline=None, derandomize=True)
@given(seed=st.integers(0, 1000), dy=st.integers(-12, 12), dx=st.integers(-12, 12), step=st.integers(0, 3))
def test_integer_shift_property(seed, dy, dx, step):
    ref = texture((96, 96), sigma=1.5, seed=seed)
    flow = align(ref, np.roll(ref, (dy, dx), axis=(0, 1)), step=step)
    b = 32
    assert np.all(flow[0, b:-b, b:-b] == dy) and np.all(flow[1, b:-b, b:-b] == dx)


def test_shift_beyond_the_finest_radius_needs_the_pyramid():
    ref = texture((128, 128), seed=2)
    alt = np.roll(ref, (7, -11), axis=(0, 1))
    flat = AlignParams(levels=1, search_radius=(1,))
    inner = np.s_[:, 40:-40, 40:-40]
    assert np.all(np.abs(align(ref, alt, params=flat)[inner]) <= 2)  # one level, radius 1: cannot reach it
    pyr = align(ref, alt)[inner]
    assert np.all(pyr[0] == 7) and np.all(pyr[1] == -11)


@pytest.mark.parametrize("shift", [(0.3, -0.6), (-0.5, 0.25)])
def test_subpixel_shift(shift):
    ref = texture((96, 96), sigma=2.5, seed=3)
    alt = fourier_shift(ref, shift)
    inner = np.s_[16:-16, 16:-16]
    flow = align(ref, alt)
    assert np.max(np.abs(flow[0][inner] - shift[0])) < 0.15
    assert np.max(np.abs(flow[1][inner] - shift[1])) < 0.15
    integer_params = AlignParams(subpixel=False)
    vectors, _ = align_tiles(ref, alt, params=integer_params)
    assert np.all(vectors == np.round(vectors))  # without the fit the tile vectors are integers
    integer = align(ref, alt, params=integer_params)
    assert np.max(np.abs(integer[1][inner] - shift[1])) >= 0.25
    # the convention: warping alternate backward by the flow gives reference (and the opposite sign does not)
    err = np.abs(warp_bilinear(alt, flow)[0][inner] - ref[inner]).mean()
    assert err < 0.25 * np.abs(alt[inner] - ref[inner]).mean()
    assert err < 0.25 * np.abs(warp_bilinear(alt, -flow)[0][inner] - ref[inner]).mean()


# ----------------------------------------------------------------------------- degenerate input
def test_flat_and_identical_input_give_zero_flow():
    zero = np.zeros((2, 64, 80), np.float32)
    a = np.full((64, 80), 0.4, np.float32)
    np.testing.assert_array_equal(align(a, a), zero)
    np.testing.assert_array_equal(align(a, np.full((64, 80), 0.9)), zero)  # both flat, different levels
    np.testing.assert_array_equal(align(np.zeros((64, 80)), np.zeros((64, 80)), step=2), zero)
    ref = texture((64, 80), seed=4)
    for step in (0, 2):
        np.testing.assert_array_equal(align(ref, ref.copy(), step=step), zero)  # exact match: no sub-pixel drift
    np.testing.assert_array_equal(align(ref, ref, params=AlignParams(levels=1, search_radius=(3,))), zero)


def test_ties_go_to_the_offset_closest_to_the_search_centre():
    """Horizontal stripes match equally well at every dx: the search keeps dx = 0, not the first in raster order."""
    rows = texture((96, 1), seed=5)
    ref = np.repeat(rows, 96, axis=1)
    alt = np.roll(ref, 3, axis=0)
    flow = align(ref, alt, params=AlignParams(subpixel=False))
    np.testing.assert_array_equal(flow[0, 24:-24], 3.0)
    np.testing.assert_array_equal(flow[1], 0.0)


def test_step_picks_the_tile_size():
    ref = texture((64, 64), seed=6)
    alt = np.roll(ref, (2, 1), axis=(0, 1))
    assert align_tiles(ref, alt, 0)[0].shape == (3, 3, 2)  # 32-pixel tiles, stride 16
    assert align_tiles(ref, alt, 1)[0].shape == (7, 7, 2)  # 16-pixel tiles, stride 8
    assert align_tiles(ref, alt, 2)[0].shape == (15, 15, 2)  # 8-pixel tiles, stride 4
    assert align_tiles(ref, alt, 9)[1] == 8
    assert align_tiles(ref.astype(np.float64), alt, 1)[1] == 16


def test_motion_beyond_reach_is_finite():
    ref = texture((64, 64), seed=7)
    flow = align(ref, np.roll(ref, 32, axis=1), params=AlignParams(search_radius=(1, 1, 1, 1)))
    assert np.all(np.isfinite(flow))


# ----------------------------------------------------------------------------- parameters and bad input
def test_params_defaults_and_validation():
    p = AlignParams()
    assert (p.levels, p.tile_by_step, p.coarse_tile, p.search_radius, p.subpixel) == (4, (32, 16, 8), 8,
                                                                                      (1, 4, 4, 4), True)
    assert (p.refine, p.smoothness, p.zero_test) == ("quadratic", 0.0, None)  # HDR+ unless asked otherwise
    assert AlignParams(zero_test=2).zero_test == 2.0
    assert [p.tile_for_step(s) for s in range(5)] == [32, 16, 8, 8, 8]
    assert p.min_size() == 64 and SMALL.min_size(0) == 8 and AlignParams(levels=1, search_radius=(1,)).min_size() == 32
    assert AlignParams(tile_by_step=[4], search_radius=[0, 1, 2, 3]).tile_by_step == (4,)
    bad = [
        (dict(levels=0, search_radius=()), "levels"),
        (dict(levels=2.0), "levels"),
        (dict(levels=True), "levels"),
        (dict(tile_by_step=()), "tile_by_step"),
        (dict(tile_by_step=(16, 7)), "tile_by_step"),
        (dict(tile_by_step=(0,)), "tile_by_step"),
        (dict(tile_by_step=16), "tile_by_step"),
        (dict(coarse_tile=5), "coarse_tile"),
        (dict(coarse_tile=0), "coarse_tile"),
        (dict(search_radius=(1, 4, 4)), "search_radius"),
        (dict(search_radius=(1, -1, 4, 4)), "search_radius"),
        (dict(search_radius=(1, 4.0, 4, 4)), "search_radius"),
        (dict(subpixel=1), "subpixel"),
        (dict(refine="cubic"), "refine"),
        (dict(refine=None), "refine"),
        (dict(refine="lk", smoothness=-1.0), "smoothness"),
        (dict(refine="lk", smoothness=float("nan")), "smoothness"),
        (dict(refine="lk", smoothness=True), "smoothness"),
        (dict(smoothness=10.0), "smoothness regularises the Lucas–Kanade refinement"),
        (dict(zero_test=-1.0), "zero_test"),
        (dict(zero_test=float("inf")), "zero_test"),
        (dict(zero_test=True), "zero_test"),
        (dict(zero_test="2"), "zero_test"),
    ]
    for kwargs, name in bad:
        with pytest.raises(ValueError, match=name):
            AlignParams(**kwargs)
    with pytest.raises(ValueError, match="step"):
        p.tile_for_step(-1)


def test_fitted_params_cut_the_pyramid_to_the_frame():
    p = AlignParams(prefer_centre=3.0)
    assert p.fitted(64, 100) is p and p.fitted(1000, 64) is p  # fits already: the very parameters
    three = p.fitted(32, 40)  # 8 · 2^(levels−1) ≤ 32: the coarsest level goes
    assert (three.levels, three.tile_by_step, three.coarse_tile, three.search_radius) == (3, (32, 16, 8), 8, (1, 4, 4))
    assert (three.subpixel, three.prefer_centre) == (p.subpixel, p.prefer_centre)
    one = p.fitted(8, 8)  # one level; tiles of at most 8
    assert (one.levels, one.tile_by_step, one.search_radius) == (1, (8, 8, 8), (1,))
    assert p.fitted(20, 13).tile_by_step == (12, 12, 8) and p.fitted(20, 13).levels == 1  # the largest even ≤ 13
    assert AlignParams().fitted(2, 5).tile_by_step == (2, 2, 2)  # the plain search: 2×2 tiles
    assert AlignParams().fitted(1, 5) is None and p.fitted(2, 5) is None  # no tile, or no 3×3 noise estimate
    assert p.fitted(3, 3).tile_by_step == (2, 2, 2)
    for h, w in ((32, 40), (8, 8), (20, 13), (3, 3), (17, 200)):
        f = p.fitted(h, w)
        assert all(min(h, w) >= f.min_size(step) for step in range(3)), (h, w, f)
        ref = texture((h, w), seed=h)
        flow = align(ref, np.roll(ref, 1, axis=1), step=0, params=f)  # align() accepts what fitted() gives
        assert flow.shape == (2, h, w) and np.all(np.isfinite(flow))
    with pytest.raises(ValueError, match="height must be an integer ≥ 1"):
        p.fitted(0, 8)
    with pytest.raises(ValueError, match="width must be an integer ≥ 1"):
        p.fitted(8, 2.5)


def test_bad_input_names_the_argument():
    ok = np.zeros((64, 64), np.float32)
    with pytest.raises(ValueError, match="reference must be finite"):
        align(np.full((64, 64), np.nan), ok)
    with pytest.raises(ValueError, match="alternate must be finite"):
        align(ok, np.full((64, 64), np.inf))
    with pytest.raises(ValueError, match="alternate must be finite"):
        align(ok, np.full((64, 64), 1e300))  # beyond float32
    with pytest.raises(ValueError, match="reference must be a single-channel"):
        align(np.zeros((4, 64, 64)), ok)
    with pytest.raises(ValueError, match="alternate must be a single-channel"):
        align(ok, np.zeros(64))
    with pytest.raises(ValueError, match="same shape"):
        align(ok, np.zeros((64, 66), np.float32))
    with pytest.raises(ValueError, match=r"reference is 20×30 on the plane grid; .*levels=4, coarse_tile=8.*"
                                         r"needs at least 64×64"):
        align(np.zeros((20, 30)), np.zeros((20, 30)))
    with pytest.raises(ValueError, match=r"needs at least 32×32"):
        align(np.zeros((12, 40)), np.zeros((12, 40)), params=AlignParams(levels=1, search_radius=(1,)))
    with pytest.raises(TypeError, match="reference must be a real floating-point"):
        align(np.zeros((64, 64), int), ok)
    with pytest.raises(TypeError, match="alternate must be a real floating-point"):
        align(ok, np.zeros((64, 64), complex))
    with pytest.raises(TypeError, match="params"):
        align(ok, ok, params={"levels": 4})
    with pytest.raises(ValueError, match="step"):
        align(ok, ok, step=-1)
    with pytest.raises(ValueError, match="step"):
        align_tiles(ok, ok, step=1.5)
    with pytest.raises(ValueError, match="levels"):
        gaussian_pyramid(ok, 0)
    with pytest.raises(TypeError, match="image"):
        gaussian_pyramid(np.zeros((8, 8), bool), 2)
    with pytest.raises(ValueError, match="vectors must have shape"):
        flow_from_tiles(np.zeros((3, 3, 2)), 16, (64, 64))
    with pytest.raises(ValueError, match="tile"):
        flow_from_tiles(np.zeros((7, 7, 2)), 15, (64, 64))
    with pytest.raises(ValueError, match="vectors must be finite"):
        flow_from_tiles(np.full((7, 7, 2), np.nan), 16, (64, 64))
    with pytest.raises(TypeError, match="vectors"):
        flow_from_tiles(np.zeros((7, 7, 2), complex), 16, (64, 64))
    with pytest.raises(ValueError, match="shape"):
        flow_from_tiles(np.zeros((7, 7, 2)), 16, (8, 64))


# ----------------------------------------------------------------------------- noise-aware search (option)
NOISE_AWARE = AlignParams(prefer_centre=3.0)


def anticorrelated_pair(shape, sigma, seed, rho=-0.5, scene=None):
    """A static scene seen twice with noise of std ``sigma`` correlated ``rho`` between the two frames."""
    rng = np.random.default_rng(seed)
    base = np.full(shape, 0.3, np.float32) if scene is None else scene
    a, b = rng.standard_normal((2,) + shape)
    n1 = sigma * a
    n2 = sigma * (rho * a + np.sqrt(1.0 - rho * rho) * b)
    return (base + n1).astype(np.float32), (base + n2).astype(np.float32)


def test_noise_aware_defaults_are_off_and_bit_identical():
    assert AlignParams().prefer_centre == 0.0
    rng = np.random.default_rng(11)
    ref = rng.random((72, 96), dtype=np.float32)
    alt = np.roll(ref, (2, -3), axis=(0, 1)) + 0.2 * rng.random((72, 96), dtype=np.float32)
    for step in (0, 1, 2):
        base = align(ref, alt, step)
        # the noise arguments are ignored (but validated) while the option is off
        np.testing.assert_array_equal(align(ref, alt, step, AlignParams(prefer_centre=0), noise=0.01,
                                            correlation=-0.5), base)
        np.testing.assert_array_equal(align_tiles(ref, alt, step, noise=np.full((72, 96), 0.01))[0],
                                      align_tiles(ref, alt, step)[0])


def test_noise_aware_search_without_noise_is_the_plain_search_plus_the_zero_candidate():
    # zero noise: no bias, no threshold — the arg-min, with zero motion as one more candidate at every level
    img = 0.4 + texture((96, 128), sigma=2.0, seed=6)
    alt = fourier_shift(img, (3, -2))
    plain = align_tiles(img, alt, 1)[0]
    np.testing.assert_array_equal(align_tiles(img, alt, 1, NOISE_AWARE, noise=0.0, correlation=0.0)[0], plain)
    # where zero is better than anything in the window around a (wrong) centre, it wins
    ref = np.random.default_rng(11).random((72, 96), dtype=np.float32)
    other = np.roll(ref, (2, -3), axis=(0, 1)) + 0.2 * np.random.default_rng(12).random((72, 96), dtype=np.float32)
    zero = align_tiles(ref, other, 0, AlignParams(prefer_centre=3, subpixel=False), noise=0.0, correlation=0.0)[0]
    differs = np.any(zero != align_tiles(ref, other, 0, AlignParams(subpixel=False))[0], axis=-1)
    assert np.any(np.all(zero[differs] == 0, axis=-1))


def moved(vectors):
    """Fraction of tiles whose vector is not zero."""
    return float(np.mean(np.any(vectors != 0, axis=-1)))


@pytest.mark.parametrize("rho", [-0.5, 0.0])
def test_noise_aware_search_keeps_zero_on_noise_of_a_static_scene(rho):
    # flat and textured static scenes; the noise of adjacent spike windows (anti-correlated) or independent
    scene = (0.3 + 0.05 * texture((96, 128), sigma=3.0, seed=2)).astype(np.float32)
    integer = {"subpixel": False}
    for base in (None, scene):
        for seed in range(3):
            ref, alt = anticorrelated_pair((96, 128), 0.02, seed=seed, rho=rho, scene=base)
            assert moved(align_tiles(ref, alt, 0, AlignParams(**integer))[0]) > 0.5  # the plain arg-min moves
            # z = 3 keeps almost every tile at zero (an arg-min over 81 offsets of ~50 tiles still lets a
            # few 3σ events through), z = 6 every one, with the noise given or measured on the images
            assert moved(align_tiles(ref, alt, 0, AlignParams(prefer_centre=3, **integer), noise=4e-4,
                                     correlation=rho)[0]) < 0.15
            for kw in ({"noise": 4e-4, "correlation": rho}, {}):
                assert moved(align_tiles(ref, alt, 0, AlignParams(prefer_centre=6, **integer), **kw)[0]) == 0


def test_anticorrelated_noise_needs_the_zero_offset_bias():
    # ρ = −½ inflates the distance at zero offset by Σ v: told ρ = 0, even z = 3 leaves zero in every tile
    ref, alt = anticorrelated_pair((128, 128), 0.02, seed=9, rho=-0.5)
    params = AlignParams(prefer_centre=3, subpixel=False)
    assert moved(align_tiles(ref, alt, 0, params, noise=4e-4, correlation=0.0)[0]) > 0.9
    assert moved(align_tiles(ref, alt, 0, params, noise=4e-4, correlation=-0.5)[0]) < 0.15
    assert moved(align_tiles(ref, alt, 0, params)[0]) < 0.15  # ρ and v measured on the images


@pytest.mark.parametrize("shift", [(3, -2), (-9, 14), (0.5, -0.25)])
def test_noise_aware_search_still_finds_motion(shift):
    rng = np.random.default_rng(4)
    img = 0.4 + texture((96, 128), sigma=2.0, seed=6)  # texture std ≈ 0.15, noise 0.02
    ref = (img + 0.02 * rng.standard_normal(img.shape)).astype(np.float32)
    alt = (fourier_shift(img, shift) + 0.02 * rng.standard_normal(img.shape)).astype(np.float32)
    plain, tile = align_tiles(ref, alt, 1)
    oy = np.arange(plain.shape[0])[:, None] * (tile // 2) + shift[0]
    ox = np.arange(plain.shape[1])[None, :] * (tile // 2) + shift[1]
    inside = (oy >= 1) & (oy + tile <= 95) & (ox >= 1) & (ox + tile <= 127)  # the shifted tile is in the image
    for kw in ({"noise": 4e-4, "correlation": 0.0}, {}):
        vectors = align_tiles(ref, alt, 1, NOISE_AWARE, **kw)[0]
        if shift[0] == int(shift[0]):  # an integer match is far beyond what noise explains: the same vectors
            np.testing.assert_array_equal(vectors[inside], plain[inside])
        np.testing.assert_allclose(vectors[inside][:, 0], shift[0], atol=0.3)
        np.testing.assert_allclose(vectors[inside][:, 1], shift[1], atol=0.3)


def test_noise_estimators():
    rng = np.random.default_rng(0)
    y, x = np.mgrid[0:200, 0:300]
    plane = 0.2 + 0.001 * y + 0.0005 * x  # the Laplacian ignores a plane
    noisy = plane + 0.05 * rng.standard_normal(plane.shape)
    assert estimate_noise(noisy) == pytest.approx(0.05 ** 2, rel=0.05)
    assert estimate_noise(plane) == pytest.approx(0.0, abs=1e-12)
    half = plane.copy()
    half[:, 150:] += 0.1 * rng.standard_normal((200, 150))
    m = local_noise(half)
    assert m.shape == half.shape and m.dtype == np.float64
    assert m[100, 40] == pytest.approx(0.0, abs=1e-9) and m[100, 260] == pytest.approx(0.01, rel=0.15)
    for rho in (-0.5, 0.0, 0.6):
        a, b = anticorrelated_pair((200, 300), 0.05, seed=3, rho=rho)
        assert estimate_noise_correlation(a, b) == pytest.approx(rho, abs=0.05)
    flat = np.full((20, 20), 0.5)
    assert estimate_noise_correlation(flat, flat) == 0.0  # no noise at all
    assert estimate_noise_correlation(noisy, noisy) == pytest.approx(1.0)


def test_level_noise_factors_match_white_noise_through_the_pyramid():
    from spikeref.align_noise import level_noise_factors

    factors = level_noise_factors(4)
    assert factors[0] == (1.0, 1.0)
    assert factors[1][0] == pytest.approx((70 / 256) ** 2)  # Σ b² / 16² per axis, squared for 2-D
    pyr = gaussian_pyramid(np.random.default_rng(1).standard_normal((512, 512)).astype(np.float32), 4)
    for level, (f, s) in enumerate(factors):
        inner = pyr[level][8 >> level or 1:-(8 >> level or 1), 8 >> level or 1:-(8 >> level or 1)]
        assert inner.var() == pytest.approx(f, rel=0.1)
        assert s >= 1.0


#: Two pyramids for the oracle comparisons: integer vectors (compared exactly), and three levels with the
#: sub-pixel fit and small coarse radii (so that the choice among the upsampling candidates at level 1, where
#: the zero candidate's correction uses the L1 formula under an L2 search, decides some vectors).
NOISE_AWARE_SMALL = AlignParams(levels=2, tile_by_step=(8, 4), coarse_tile=4, search_radius=(1, 2), subpixel=False,
                                prefer_centre=3.0)
NOISE_AWARE_THREE = AlignParams(levels=3, tile_by_step=(16, 8), coarse_tile=4, search_radius=(1, 1, 2),
                                prefer_centre=2.0)


def noisy_pair(shape, seed, shift=(0, 0), rho=-0.5, sigma=0.03):
    """A smooth texture and a copy moved by ``shift`` (periodic), with noise of std ``sigma`` correlated ``rho``
    between the two images at the same pixel; ``shift = None``: two unrelated uniform random images;
    ``"counts"``: two unrelated Poisson counts (whole numbers: distances tie exactly)."""
    rng = np.random.default_rng(seed)
    if shift is None:
        return rng.random(shape, dtype=np.float32), rng.random(shape, dtype=np.float32)
    if shift == "counts":
        return rng.poisson(2.0, shape).astype(np.float32), rng.poisson(2.0, shape).astype(np.float32)
    img = 0.4 + texture(shape, sigma=2.0, seed=seed)
    moved = img if shift == (0, 0) else fourier_shift(img, shift)
    return anticorrelated_pair(shape, sigma, seed + 100, rho=rho, scene=img)[0], \
        anticorrelated_pair(shape, sigma, seed + 100, rho=rho, scene=moved)[1]


GIVEN = {"noise": 9e-4, "correlation": -0.5}


@pytest.mark.parametrize("name, seed, shift, rho, kw", [
    ("still, anti-correlated, noise estimated", 1, (0, 0), -0.5, {}),
    ("still, anti-correlated, noise and ρ given", 2, (0, 0), -0.5, GIVEN),
    ("integer shift, anti-correlated, noise estimated", 3, (2, -3), -0.5, {}),
    ("one-pixel shift, anti-correlated, noise and ρ given", 0, (1, 1), -0.5, GIVEN),
    ("sub-pixel shift, independent, a noise map given", 4, (0.5, -1.25), 0.0, {"noise": "map", "correlation": 0.0}),
    ("positive correlation given (no bias)", 5, (1, 1), 0.4, {"noise": 9e-4, "correlation": 0.4}),
    ("ρ = −0.9 given (clipped to −½)", 0, (1, 1), -0.5, {"noise": 9e-4, "correlation": -0.9}),
    ("unrelated images, noise estimated", 0, None, 0.0, {}),
    ("unrelated images, noise and ρ given", 0, None, 0.0, GIVEN),
    ("other unrelated images, noise and ρ given", 3, None, 0.0, GIVEN),
    ("whole-number counts, no noise: exact ties", 0, "counts", 0.0, {"noise": 0.0, "correlation": 0.0}),
    ("no noise: the plain search plus zero", 7, (2, -3), -0.5, {"noise": 0.0, "correlation": 0.0}),
])
def test_noise_aware_search_matches_the_oracle(name, seed, shift, rho, kw):
    # the literal transcription of docs/spec/align.md#noise-aware-search (spikeref/oracles/align_search.py and
    # align_noise.py, put together by spikeref/oracles/align.py)
    for params, shape in ((NOISE_AWARE_SMALL, (24, 32)), (NOISE_AWARE_THREE, (40, 48))):
        ref, alt = noisy_pair(shape, seed, shift, rho)
        given = dict(kw)
        if given.get("noise") == "map":
            given["noise"] = np.random.default_rng(seed).uniform(0.0, 2e-3, shape)
        for step in (0, 1):
            vectors, tile = align_tiles(ref, alt, step, params, **given)
            expected, tile_o = align_tiles_oracle(ref, alt, step, params, **given)
            assert tile == tile_o and vectors.shape == expected.shape, name
            if params.subpixel:
                np.testing.assert_allclose(vectors, expected, rtol=0, atol=1e-5, err_msg=name)
            else:
                np.testing.assert_array_equal(vectors, expected, err_msg=name)
        np.testing.assert_allclose(align(ref, alt, 1, params, **given), align_oracle(ref, alt, 1, params, **given),
                                   rtol=0, atol=1e-5, err_msg=name)


def test_noise_aware_oracle_sees_what_the_option_changes():
    # the cases above are not vacuous: on them the noise-aware search differs from the plain one, keeps zero
    # on the still pair and follows the integer shift where the texture is
    ref, alt = noisy_pair((40, 48), 7, (0, 0), -0.5)
    plain = align_tiles_oracle(ref, alt, 0, AlignParams(**{**NOISE_AWARE_SMALL.__dict__, "prefer_centre": 0.0}))[0]
    aware = align_tiles_oracle(ref, alt, 0, NOISE_AWARE_SMALL)[0]
    assert moved(plain) > 0.2 and moved(aware) < 0.1
    ref, alt = noisy_pair((40, 48), 8, (2, -3), -0.5)
    aware = align_tiles_oracle(ref, alt, 0, NOISE_AWARE_SMALL)[0]
    assert np.mean(np.all(aware == (2, -3), axis=-1)) > 0.5


def test_noise_estimators_match_their_oracles():
    rng = np.random.default_rng(21)
    img = (0.3 + 0.05 * texture((30, 41), seed=3) + 0.02 * rng.standard_normal((30, 41))).astype(np.float32)
    other = (img + 0.03 * rng.standard_normal(img.shape)).astype(np.float32)
    assert estimate_noise(img) == pytest.approx(estimate_noise_oracle(img), rel=1e-12)
    np.testing.assert_allclose(local_noise(img), local_noise_oracle(img), rtol=1e-12, atol=0)
    np.testing.assert_allclose(local_noise(img, box=5), local_noise_oracle(img, box=5), rtol=1e-12, atol=0)
    assert estimate_noise_correlation(img, other) == pytest.approx(estimate_noise_correlation_oracle(img, other),
                                                                   rel=1e-12)
    flat = np.full((9, 9), 0.5, np.float32)
    assert estimate_noise_correlation_oracle(flat, flat) == 0.0 == estimate_noise_correlation(flat, flat)
    from spikeref.align_noise import level_noise_factors

    # the values docs/spec/align.md prints
    spec = [(1.0, 1.0), (0.07476806640625, 1.7434777176176595), (0.015245858579874039, 2.101252113426672),
            (0.0036432665840493428, 2.1924949257570665)]
    np.testing.assert_allclose(level_noise_factors(4), spec, rtol=1e-14)
    np.testing.assert_allclose(level_noise_factors_oracle(4), spec, rtol=1e-14)


def test_noise_aware_validation():
    ok = texture((64, 64))
    for bad in (-1.0, np.nan, np.inf, True, "3"):
        with pytest.raises(ValueError, match="prefer_centre"):
            AlignParams(prefer_centre=bad)
    assert AlignParams(prefer_centre=2).prefer_centre == 2.0 and isinstance(AlignParams(prefer_centre=2).prefer_centre,
                                                                            float)
    for params in (AlignParams(), NOISE_AWARE):  # validated whether or not the option is on
        with pytest.raises(ValueError, match="noise must be a scalar or an array of the image's shape"):
            align(ok, ok, params=params, noise=np.ones((3, 3)))
        with pytest.raises(ValueError, match="noise must be finite and ≥ 0"):
            align(ok, ok, params=params, noise=-1.0)
        with pytest.raises(ValueError, match="noise must be finite"):
            align(ok, ok, params=params, noise=np.nan)
        with pytest.raises(TypeError, match="noise must be a real number"):
            align(ok, ok, params=params, noise=True)
        with pytest.raises(TypeError, match="noise must be a real number"):
            align(ok, ok, params=params, noise="0.1")
        for bad in (1.5, -2, np.nan, True, "0"):
            with pytest.raises(ValueError, match="correlation"):
                align_tiles(ok, ok, params=params, correlation=bad)
    with pytest.raises(ValueError, match="at least 3×3"):
        estimate_noise(np.zeros((2, 9)))
    with pytest.raises(ValueError, match="box"):
        local_noise(ok, box=4)
    with pytest.raises(ValueError, match="same shape"):
        estimate_noise_correlation(ok, ok[:32])
    with pytest.raises(TypeError, match="image"):
        estimate_noise(np.zeros((8, 8), int))


REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "spikingsim_real_spike.npz"


@pytest.mark.skipif(not REAL.is_file(), reason="the real recording ../shared/data/real/ is not here")
def test_noise_aware_pipeline_on_the_real_near_static_recording():
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.stream import SpikeStream

    # SpikingSIM outdoor scene (mono, near-static): the default moves 18 % of the pixels by more than a
    # plane pixel (spurious matches on noisy flat regions, and zero penalised by the anti-correlated
    # noise of adjacent windows); the noise-aware search, told the noise of I_l, 4 %
    with np.load(REAL) as data:
        stream = SpikeStream.from_array(np.ascontiguousarray(data["arr_0"][:, :, :70].transpose(2, 0, 1)))
    share = {}
    for z in (0.0, 3.0):
        params = ReconstructParams.paper(align_params=AlignParams(prefer_centre=z))  # flows on D(I_l) frames
        (frame,) = Reconstructor(stream, params, lambda p: p).frames(3, 4, keep_steps=True)
        share[z] = np.mean(np.concatenate([np.hypot(*f).ravel() for f in frame.flows.values()]) > 1.0)
    assert share[0.0] > 0.1 and share[3.0] < 0.06


# ----------------------------------------------------------------------------- Lucas–Kanade refinement (an option)
LK = AlignParams(refine="lk")


@pytest.mark.parametrize("shift", [(0.3, -0.6), (-0.5, 0.25), (1.7, 0.2)])
def test_lucas_kanade_refinement_recovers_a_subpixel_shift(shift):
    ref = texture((96, 96), sigma=2.5, seed=3)
    alt = fourier_shift(ref, shift)
    inner = np.s_[16:-16, 16:-16]
    quadratic = align(ref, alt)
    for params in (LK, AlignParams(refine="lk", smoothness=300.0)):
        flow = align(ref, alt, params=params)
        err = np.abs(flow - np.asarray(shift, np.float32)[:, None, None])
        assert np.max(err[(slice(None), *inner)]) < 0.05
        assert np.max(err) < 0.1  # border tiles too: samples moved outside the image are left out
    assert np.abs(quadratic - np.asarray(shift, np.float32)[:, None, None])[(slice(None), *inner)].mean() > 0.005


def test_lucas_kanade_keeps_flat_and_identical_input_at_zero():
    zero = np.zeros((2, 64, 80), np.float32)
    ref = texture((64, 80), seed=4)
    for params in (LK, AlignParams(refine="lk", smoothness=100.0, prefer_centre=3.0)):
        for step in (0, 2):
            np.testing.assert_array_equal(align(ref, ref.copy(), step=step, params=params), zero)
        a = np.full((64, 80), 0.4, np.float32)
        np.testing.assert_array_equal(align(a, np.full((64, 80), 0.9), params=params), zero)


def test_regularisation_pulls_unsure_tiles_to_their_neighbours():
    """A tile without information takes its neighbours' vector; a sure one keeps its own; λ = 0 changes nothing."""
    vec = np.tile(np.array([0.5, -0.25]), (5, 6, 1))
    vec[2, 3] = (3.0, 3.0)
    info = np.zeros((5, 6, 3))
    info[..., 0] = info[..., 2] = 1e3
    info[2, 3] = 0.0  # nothing to go by: an outlier from noise
    var = np.ones((5, 6))
    out = regularise(vec, info, var, 10.0, SMOOTHNESS_SWEEPS)
    np.testing.assert_allclose(out[2, 3], (0.5, -0.25), atol=0.02)
    others = np.delete(out.reshape(-1, 2), 2 * 6 + 3, axis=0)
    np.testing.assert_allclose(others, np.broadcast_to([0.5, -0.25], others.shape), atol=0.02)
    sure = info.copy()
    sure[2, 3] = (1e9, 0.0, 1e9)
    np.testing.assert_allclose(regularise(vec, sure, var, 10.0, SMOOTHNESS_SWEEPS)[2, 3], (3.0, 3.0), atol=1e-3)
    assert regularise(vec, info, var, 0.0, SMOOTHNESS_SWEEPS) is vec
    np.testing.assert_allclose(regularise(np.tile(vec[:1, :1], (5, 6, 1)), info, var, 10.0, SMOOTHNESS_SWEEPS),
                               np.tile(vec[:1, :1], (5, 6, 1)))  # a uniform field stays as it is


def test_regularisation_quiets_noise_on_a_static_scene():
    """Two noisy frames of a still, weakly textured scene: the noise-weighted pull shrinks the spurious motion."""
    rng = np.random.default_rng(12)
    base = 0.5 + 0.05 * texture((96, 96), sigma=3.0, seed=8)
    ref = ndimage.gaussian_filter(base + 0.05 * rng.standard_normal(base.shape), 1.0).astype(np.float32)
    alt = ndimage.gaussian_filter(base + 0.05 * rng.standard_normal(base.shape), 1.0).astype(np.float32)
    noise = np.full(base.shape, 0.05 ** 2)
    plain = align(ref, alt, step=2, params=AlignParams(refine="lk", prefer_centre=3.0), noise=noise)
    smooth = align(ref, alt, step=2, params=AlignParams(refine="lk", smoothness=300.0, prefer_centre=3.0), noise=noise)
    assert 0.05 < np.hypot(*plain).mean() < 2.0
    assert np.hypot(*smooth).mean() < 0.5 * np.hypot(*plain).mean()


def test_lucas_kanade_params_fit_small_frames():
    p = AlignParams(refine="lk", smoothness=100.0)
    small = p.fitted(20, 13)
    assert (small.refine, small.smoothness) == ("lk", 100.0)
    assert p.fitted(2, 5) is None and AlignParams(refine="lk").fitted(2, 5) is not None
    np.testing.assert_array_equal(align(np.zeros((8, 8)), np.ones((8, 8)), params=p.fitted(8, 8)), 0.0)


# ----------------------------------------------------------------------------- per-pixel zero-motion test (an option)
def _noisy_pair(shift, sigma=0.02, seed=21):
    rng = np.random.default_rng(seed)
    ref = texture((64, 80), sigma=2.0, seed=9)
    alt = fourier_shift(ref, shift)
    return (ref + sigma * rng.standard_normal(ref.shape)).astype(np.float32), \
        (alt + sigma * rng.standard_normal(ref.shape)).astype(np.float32)


def test_zero_motion_test_drops_motion_that_zero_explains_better():
    ref, alt = _noisy_pair((0.0, 0.0))
    spurious = np.full((2, 64, 80), 0.7, np.float32)  # e.g. a moving tile's vector spread onto a still background
    out = zero_motion_test(spurious, ref, alt, 2.0, noise=0.02 ** 2, correlation=0.0)
    assert np.mean(out[0] == 0) > 0.95 and out.dtype == np.float32
    assert set(np.unique(out)) <= {0.0, np.float32(0.7)}


def test_zero_motion_test_keeps_true_motion_and_what_it_cannot_tell():
    ref, alt = _noisy_pair((1.0, -0.5))
    true = np.stack([np.full((64, 80), 1.0), np.full((64, 80), -0.5)]).astype(np.float32)
    kept = zero_motion_test(true, ref, alt, 2.0, noise=0.02 ** 2, correlation=0.0)
    np.testing.assert_array_equal(kept[:, 8:-8, 8:-8], true[:, 8:-8, 8:-8])  # (the periodic shift wraps at the border)
    flat = np.full((64, 80), 0.5, np.float32)
    np.testing.assert_array_equal(zero_motion_test(true, flat, flat, 2.0, noise=0.02 ** 2, correlation=0.0), true)
    # in align(): identical frames keep their exact zero flow; a shifted pair keeps its motion
    p = AlignParams(refine="lk", smoothness=300.0, prefer_centre=3.0, zero_test=2.0)
    np.testing.assert_array_equal(align(ref, ref.copy(), params=p, noise=0.02 ** 2), 0.0)
    flow = align(ref, alt, params=p, noise=0.02 ** 2, raw=(ref, alt))
    assert np.abs(flow[0, 16:-16, 16:-16] - 1.0).max() < 0.1


def test_zero_motion_test_in_a_noise_free_region_after_a_noisy_one_matches_the_oracle():
    # The box sums of the term variances run over the rows left to right; after large variances, a
    # region of zero variance used to be left with round-off below zero, √ of which is NaN: the test
    # kept there the flow that the oracle (exact sum 0) drops.  224 of the 480 right-half pixels
    # differed with SciPy's uniform_filter (until 2026-11-25), with a RuntimeWarning.
    rng = np.random.default_rng(0)
    ref = rng.random((24, 40)).astype(np.float32)
    alt = ref.copy()
    alt[:, :20] = rng.random((24, 20))  # the left half differs, under a large noise variance …
    noise = np.zeros((24, 40))
    noise[:, :20] = rng.random((24, 20)) * 1e3 + 1e3  # … the right half is identical and noise-free
    flow = np.full((2, 24, 40), 0.3, np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = zero_motion_test(flow, ref, alt, 2.0, noise=noise, correlation=0.0)
    np.testing.assert_array_equal(out, zero_motion_test_oracle(flow, ref, alt, 2.0, noise=noise, correlation=0.0))
    assert np.all(out[:, :, 24:] == 0.0)  # zero motion explains the identical half exactly
    # a constant, noise-free right half: d = 0 exactly, nothing tells zero from the flow, which is kept (the
    # clip of the running sum that came first dropped it at 80–128 of its pixels: round-off below 0)
    for seed in range(3):
        rng = np.random.default_rng(seed)
        ref, alt = rng.random((2, 24, 40)).astype(np.float32)
        ref[:, 20:] = alt[:, 20:] = 0.5
        noise = np.zeros((24, 40))
        noise[:, :20] = rng.random((24, 20)) * 1e3 + 1e3
        out = zero_motion_test(flow, ref, alt, 2.0, noise=noise, correlation=0.0)
        np.testing.assert_array_equal(out, zero_motion_test_oracle(flow, ref, alt, 2.0, noise=noise,
                                                                   correlation=0.0))
        assert np.all(out[:, :, 24:] == np.float32(0.3))


@pytest.mark.parametrize("l2", [False, True])
def test_block_and_window_distances_are_tile_distance_to_the_bit(l2):
    # The search sums nine offsets side by side (block_distances); each must be tile_distance's value
    # exactly, inside the image and where the shifted tile is clamped at an edge, for every radius.
    rng = np.random.default_rng(3)
    ref = rng.random((30, 34)).astype(np.float32)
    alt = rng.random((30, 34)).astype(np.float32)
    for oy, ox, tile in [(8, 8, 8), (0, 0, 8), (22, 26, 8), (4, 10, 16)]:
        # inside, far outside, and one past each edge with the other axis inside (tile at (8, 8): the block
        # (−8, 0) reaches row −1 and (14, 0) row 30 of 30; the same for the columns)
        for q in [(0, 0), (3, -2), (-7, 5), (9, 9), (-oy, 0), (0, -ox), (30 - oy - tile, 0), (0, 34 - ox - tile),
                  (-oy + 1, 0), (0, -ox + 1), (30 - oy - tile - 1, 0), (0, 34 - ox - tile - 1)]:
            d = np.empty((3, 3))
            block_distances(ref, alt, oy, ox, tile, q[0], q[1], l2, d, 0, 0)
            want = [[tile_distance(ref, alt, oy, ox, tile, q[0] + a - 1, q[1] + b - 1, l2) for b in range(3)]
                    for a in range(3)]
            np.testing.assert_array_equal(d, want)
        for radius in range(5):  # 2·radius + 1 = 1, 3, 5, 7, 9: whole blocks and remainders
            d = np.empty((2 * radius + 1, 2 * radius + 1))
            window_distances(ref, alt, oy, ox, tile, 1, -2, radius, l2, d)
            want = [[tile_distance(ref, alt, oy, ox, tile, 1 + dy, -2 + dx, l2) for dx in range(-radius, radius + 1)]
                    for dy in range(-radius, radius + 1)]
            np.testing.assert_array_equal(d, want)


def test_fused_distances_and_search_equal_their_parts_to_the_bit():
    # The paper's finest level runs the radius-1 L1 search and the L2 quadratic fit in one kernel, and the
    # upsampling sums its three candidates side by side: each must give what the separate kernels give,
    # inside the image and at its edges (the first row and column of tiles are clamped blocks).
    rng = np.random.default_rng(4)
    ref = rng.random((30, 34))
    alt = rng.random((30, 34))
    for oy, ox, tile in [(8, 8, 8), (0, 0, 8), (22, 26, 8), (4, 10, 16)]:
        for q in [(0, 0), (3, -2), (-oy, 0), (0, -ox), (30 - oy - tile - 1, 0), (0, 34 - ox - tile - 1), (9, 9)]:
            d1, d2, w1, w2 = np.empty((4, 3, 3))
            block_distances_l1_l2(ref, alt, oy, ox, tile, q[0], q[1], d1, d2)
            block_distances(ref, alt, oy, ox, tile, q[0], q[1], False, w1, 0, 0)
            block_distances(ref, alt, oy, ox, tile, q[0], q[1], True, w2, 0, 0)
            np.testing.assert_array_equal(d1, w1)
            np.testing.assert_array_equal(d2, w2)
        for cand in [[(0, 0), (2, -2), (-1, 1)], [(-oy, 0), (0, 0), (0, 40)], [(-9, -9), (9, 9), (0, -ox)]]:
            cand = np.asarray(cand, np.int64)
            got = np.empty(3)
            three_distances(ref, alt, oy, ox, tile, cand, got)
            np.testing.assert_array_equal(got, [tile_distance(ref, alt, oy, ox, tile, c[0], c[1], False)
                                                for c in cand])
    for tile, noise_aware in [(8, False), (8, True), (16, True), (4, False)]:
        grid = ((30 - tile) // (tile // 2) + 1, (34 - tile) // (tile // 2) + 1)
        centre = rng.integers(-3, 4, grid + (2,))
        bias = rng.random(grid) * 2 if noise_aware else np.zeros(grid)
        thresh = rng.random(grid) * 3 if noise_aware else np.full(grid, -1.0)
        vectors, want = np.empty(grid + (2,), np.int64), np.empty(grid + (2,), np.int64)
        out, want_out = np.empty(grid + (2,), np.float32), np.empty(grid + (2,), np.float32)
        search_fit_tiles(ref, alt, tile, centre, bias, thresh, vectors, out)
        search_tiles(ref, alt, tile, centre, 1, False, bias, thresh, want)
        subpixel_fit(ref, alt, tile, want, want_out)
        np.testing.assert_array_equal(vectors, want)
        np.testing.assert_array_equal(out, want_out)
        assert np.any(vectors == centre) and np.any(out != vectors)  # the kept block and a fit both used


def test_zero_motion_test_checks_its_arguments():
    ref, alt = _noisy_pair((0.0, 0.0))
    flow = np.zeros((2, 64, 80), np.float32)
    with pytest.raises(ValueError, match="flow must be a finite"):
        zero_motion_test(flow[:, :10], ref, alt, 2.0)
    with pytest.raises(ValueError, match="z must be"):
        zero_motion_test(flow, ref, alt, -1.0)
    with pytest.raises(ValueError, match="box must be"):
        zero_motion_test(flow, ref, alt, 2.0, box=4)
    with pytest.raises(ValueError, match="same shape"):
        zero_motion_test(flow, ref, alt[:10], 2.0)


# ----------------------------------------------------------------------------- the options' oracles
# refine="lk", smoothness and zero_test against their literal transcriptions (spikeref/oracles/align_refine.py and
# align_zero_test.py; docs/spec/align.md#lucas-kanade-refinement, #regularised-tile-field,
# #per-pixel-zero-motion-test)
LK_SMALL = AlignParams(levels=2, tile_by_step=(16, 8), coarse_tile=8, search_radius=(1, 2), refine="lk")
LK_ALL = AlignParams(levels=2, tile_by_step=(16, 8), coarse_tile=8, search_radius=(1, 2), refine="lk",
                     smoothness=300.0, prefer_centre=3.0, zero_test=2.0)


def lk_pair(kind, shape=(32, 40), sigma=0.02, seed=0):
    """``(reference, alternate)`` float32 with noise of std ``sigma`` correlated −½ at the same pixel: ``still``;
    ``moving`` (the texture moved by (0.6, −0.35)); ``object`` (a still background, flat on its left quarter,
    and a textured block moved by (1.25, −0.75)); ``half flat`` (no noise: the left half exactly constant,
    where the Lucas–Kanade system is singular; the right half moved by (0.4, 0.3))."""
    h, w = shape
    back = 0.4 + 0.5 * texture(shape, sigma=2.0, seed=seed + 1)
    if kind == "still":
        ref, alt = back, back
    elif kind == "moving":
        ref, alt = back, fourier_shift(back, (0.6, -0.35))
    elif kind == "object":
        back = back.copy()
        back[:, : w // 4] = 0.4
        obj = 0.45 + 0.6 * texture(shape, sigma=1.5, seed=seed + 2)
        block = np.zeros(shape, bool)
        block[h // 4: 3 * h // 4, w // 2: w - 4] = True
        moved_block = ndimage.shift(block.astype(np.float64), (1.25, -0.75), order=0) > 0.5
        ref = np.where(block, obj, back)
        alt = np.where(moved_block, fourier_shift(obj, (1.25, -0.75)), back)
    else:  # half flat, no noise
        ref = back.copy()
        ref[:, : w // 2] = 0.4
        alt = fourier_shift(back, (0.4, 0.3))
        alt[:, : w // 2] = 0.4
        return ref.astype(np.float32), alt.astype(np.float32)
    return anticorrelated_pair(shape, sigma, seed + 100, scene=ref)[0], anticorrelated_pair(shape, sigma, seed + 100,
                                                                                           scene=alt)[1]


LK_CASES = [
    ("still, noise estimated", "still", {}),
    ("still, noise and ρ given", "still", {"noise": 4e-4, "correlation": -0.5}),
    ("moving, noise estimated", "moving", {}),
    ("moving, a noise map and ρ = −0.8 (clipped) given", "moving", {"noise": "map", "correlation": -0.8}),
    ("object on a still background, noise given, raw frames apart", "object",
     {"noise": 4e-4, "correlation": -0.5, "raw": True}),
    ("object on a still background, noise estimated, raw frames apart", "object", {"raw": True}),
    ("half flat, no noise: singular tiles, the variance floor", "half flat", {"noise": 0.0, "correlation": 0.0}),
]


def _lk_inputs(kind, kw, shape=(32, 40)):
    ref, alt = lk_pair(kind, shape)
    given = dict(kw)
    if given.get("noise") == "map":
        given["noise"] = np.random.default_rng(3).uniform(1e-4, 8e-4, shape)
    if given.pop("raw", False):  # the flow on smoothed frames, the zero test on the raw ones (as the pipeline)
        given["raw"] = (ref, alt)
        ref = ndimage.gaussian_filter(ref.astype(np.float64), 1.0).astype(np.float32)
        alt = ndimage.gaussian_filter(alt.astype(np.float64), 1.0).astype(np.float32)
    return ref, alt, given


@pytest.mark.parametrize("name, kind, kw", LK_CASES, ids=[c[0] for c in LK_CASES])
def test_lk_regularised_zero_test_match_the_oracle(name, kind, kw):
    ref, alt, given = _lk_inputs(kind, kw)
    tiles_kw = {k: v for k, v in given.items() if k != "raw"}
    for step in (0, 1):
        for params in (LK_SMALL, LK_ALL):
            vectors, tile = align_tiles(ref, alt, step, params, **tiles_kw)
            expected, tile_o = align_tiles_oracle(ref, alt, step, params, **tiles_kw)
            assert tile == tile_o
            np.testing.assert_allclose(vectors, expected, rtol=1e-5, atol=1e-6, err_msg=f"{name}, step {step}")
        flow = align(ref, alt, step, LK_ALL, **given)
        expected = align_oracle(ref, alt, step, LK_ALL, **given)
        np.testing.assert_array_equal(flow == 0, expected == 0, err_msg=f"{name}, step {step}: the zero test")
        np.testing.assert_allclose(flow, expected, rtol=1e-5, atol=1e-6, err_msg=f"{name}, step {step}")


def test_lk_oracle_cases_exercise_the_options():
    """On the pairs above the options change the result: regularisation moves vectors, the zero test fires on
    the object's still background, samples are left out at the border, and the half-flat pair has singular
    tiles that keep their integer vector."""
    ref, alt, given = _lk_inputs("object", {"noise": 4e-4, "correlation": -0.5, "raw": True})
    raw = given.pop("raw")
    plain = align_oracle(ref, alt, 1, AlignParams(**{**LK_ALL.__dict__, "zero_test": None}), **given)
    tested = align_oracle(ref, alt, 1, LK_ALL, raw=raw, **given)
    fired = np.any(plain != tested, axis=0)
    assert 20 < fired.sum() and np.all(tested[:, fired] == 0)
    lk = align_tiles_oracle(ref, alt, 1, AlignParams(**{**LK_ALL.__dict__, "smoothness": 0.0}), **given)[0]
    smooth = align_tiles_oracle(ref, alt, 1, LK_ALL, **given)[0]
    assert np.abs(lk - smooth).max() > 0.1
    ref, alt = lk_pair("half flat")
    best = np.zeros((7, 9, 2), np.int64)
    _, info = lucas_kanade_oracle(ref, alt, 0, 0, 8, best[0, 0])
    assert np.all(info == 0)  # flat: no information, the steps stop at once
    u, _ = lucas_kanade_oracle(ref, alt, 0, 32, 8, (1, 1))  # the tile's right column moved past the border
    assert np.all(np.isfinite(u)) and np.any(u != (1, 1))


def test_lk_kernels_match_the_oracle_in_float64():
    """The Lucas–Kanade and Jacobi kernels before the float32 rounding: agreement to ~1e-14."""
    ref, alt = lk_pair("moving", (32, 40))
    gy, gx = np.empty(alt.shape), np.empty(alt.shape)
    gradient(alt, gy, gx)
    o_gy, o_gx = gradient_oracle(alt)
    np.testing.assert_array_equal(gy, o_gy)
    np.testing.assert_array_equal(gx, o_gx)
    np.testing.assert_array_equal(gy, np.gradient(alt.astype(np.float64))[0])  # as numpy.gradient
    tile = 8
    best = np.random.default_rng(1).integers(-2, 3, (7, 9, 2)).astype(np.int64)
    out, info = np.empty((7, 9, 2)), np.empty((7, 9, 3))
    lucas_kanade(ref, alt, gy, gx, tile, best, 2, out, info)
    for i in range(7):
        for j in range(9):
            u, inf = lucas_kanade_oracle(ref, alt, 4 * i, 4 * j, tile, best[i, j], gradient=(o_gy, o_gx))
            np.testing.assert_allclose(out[i, j], u, rtol=0, atol=1e-10)
            np.testing.assert_allclose(info[i, j], inf, rtol=1e-12, atol=0)
    variance = np.random.default_rng(2).uniform(1e-4, 1e-3, (7, 9))
    variance[0, 0] = 0.0  # floored at 1e-20
    for lam in (1.0, 300.0, 1e5):
        np.testing.assert_allclose(regularise(out, info, variance, lam, SMOOTHNESS_SWEEPS),
                                   regularise_oracle(out, info, variance, lam),
                                   rtol=0, atol=1e-10)


def test_regularise_oracle_sweeps_towards_the_minimiser_of_its_energy():
    """The Jacobi update is the energy's stationarity for fixed neighbours: many sweeps reach the exact minimiser
    (``sweeps=None``), which no small perturbation improves; 30 sweeps (the option) stop short where λ ≫ J."""
    rng = np.random.default_rng(4)
    hat = rng.normal(0.0, 1.0, (4, 5, 2))
    info = np.stack([rng.uniform(0, 50, (4, 5)), rng.uniform(-5, 5, (4, 5)), rng.uniform(0, 50, (4, 5))], -1)
    info[..., 1] = np.clip(info[..., 1], -0.9 * np.sqrt(info[..., 0] * info[..., 2]),
                           0.9 * np.sqrt(info[..., 0] * info[..., 2]))
    variance = np.full((4, 5), 0.5)
    lam = 10.0

    def energy(u):
        e = 0.0
        for i in range(4):
            for j in range(5):
                jm = np.array([[info[i, j, 0], info[i, j, 1]], [info[i, j, 1], info[i, j, 2]]]) / variance[i, j]
                d = u[i, j] - hat[i, j]
                e += d @ jm @ d
                e += lam * sum(np.sum((u[i, j] - u[a, b]) ** 2) for a, b in ((i + 1, j), (i, j + 1)) if a < 4 and b < 5)
        return e

    exact = regularise_oracle(hat, info, variance, lam, sweeps=None)
    np.testing.assert_allclose(regularise_oracle(hat, info, variance, lam, sweeps=3000), exact, atol=1e-9)
    e0 = energy(exact)
    for _ in range(5):
        assert energy(exact + 1e-3 * rng.standard_normal(exact.shape)) > e0
    far = regularise_oracle(hat, info / 1e4, variance, lam)  # J ≪ λ: 30 sweeps are not the minimiser
    assert np.abs(far - regularise_oracle(hat, info / 1e4, variance, lam, sweeps=None)).max() > 0.05
    np.testing.assert_array_equal(regularise_oracle(hat[:1, :1], info[:1, :1], variance[:1, :1], lam), hat[:1, :1])


def test_lucas_kanade_oracle_converges_on_a_bilinear_image():
    """Bilinear samples and central differences are exact on ``f = a + by + cx + dxy``: Gauss–Newton steps
    converge to the shift (the first step is off only by the cross term ``d·u_y·u_x``)."""
    y, x = np.mgrid[0:24, 0:24].astype(np.float64)

    def f(yy, xx):
        return 0.5 + 0.02 * yy - 0.03 * xx + 0.004 * yy * xx

    shift = np.array([0.3, -0.45])
    alt, ref = f(y, x), f(y + shift[0], x + shift[1])  # ref(p) = alt(p + shift)
    one, _ = lucas_kanade_oracle(ref, alt, 8, 8, 8, (0, 0), iterations=1)
    assert np.abs(one - shift).max() < 0.05
    many, info = lucas_kanade_oracle(ref, alt, 8, 8, 8, (0, 0), iterations=8)
    np.testing.assert_allclose(many, shift, atol=1e-9)
    assert info[0] > 0 and info[2] > 0


@pytest.mark.parametrize("rho", [-0.5, 0.0, 0.3])
def test_zero_motion_noise_moments_by_monte_carlo(rho):
    """Noise only (a flat scene): the oracle's d has mean 0 and variance q (bilinear weights and ρ included)."""
    rng = np.random.default_rng(int(10 * rho) + 7)
    shape = (8, 8)
    flow = np.stack([np.full(shape, 0.3), np.full(shape, -0.6)]).astype(np.float32)
    flow[:, :, -1] = np.array([[0.0], [0.4]], np.float32)  # the last column: sampled on its own row
    d_all, q_all = [], []
    for _ in range(300):
        a = rng.standard_normal(shape)
        b = rho * a + np.sqrt(1 - rho ** 2) * rng.standard_normal(shape)
        d, q = zero_motion_sums_oracle(flow, a, b, np.ones(shape), rho, box=1)
        d_all.append(d)
        q_all.append(q)
    d_all, q = np.array(d_all), q_all[0]
    assert abs(d_all.mean()) < 5 * np.sqrt(q.mean() / d_all.size) * 3  # (neighbours share taps: ×3 for that)
    np.testing.assert_allclose(d_all.var(axis=0).mean(), q.mean(), rtol=0.1)
    np.testing.assert_allclose(d_all[:, :, -1].var(), q[:, -1].mean(), rtol=0.15)


@pytest.mark.parametrize("kw", [{"noise": 4e-4, "correlation": -0.5}, {}, {"noise": "map", "correlation": 0.4},
                                {"noise": 4e-4, "correlation": -0.9, "box": 5}, {"noise": 0.0, "correlation": 0.0}])
def test_zero_motion_test_matches_the_oracle(kw):
    ref, alt = lk_pair("object")
    rng = np.random.default_rng(5)
    flow = np.stack([ndimage.gaussian_filter(rng.normal(0, 1.5, ref.shape), 3) for _ in range(2)]).astype(np.float32)
    flow[:, :, : 10] += np.array([1.25, -0.75], np.float32)[:, None, None]
    given = dict(kw)
    if given.get("noise") == "map":
        given["noise"] = rng.uniform(1e-4, 8e-4, ref.shape)
    got = zero_motion_test(flow, ref, alt, 2.0, **given)
    expected = zero_motion_test_oracle(flow, ref, alt, 2.0, **given)
    np.testing.assert_array_equal(got, expected)
    assert 0 < np.sum(got[0] == 0) < got[0].size


def test_the_oracle_constants_are_the_kernel_s():
    import importlib

    from spikeref.oracles import align as o_align

    kernel = importlib.import_module("spikeref.align")
    assert (o_align.LK_ITERATIONS, o_align.SMOOTHNESS_SWEEPS, o_align.ZERO_TEST_BOX) == (
        kernel.LK_ITERATIONS, kernel.SMOOTHNESS_SWEEPS, kernel.ZERO_TEST_BOX)


def test_the_oracle_states_the_kernels_constants_and_defaults_on_its_own():
    # The oracle reads no fast code: its tolerances and the paper's defaults are written out there.
    # They must be the kernel's, or an agreement test between the two would compare different rules.
    import dataclasses

    import spikeref.align as fast
    import spikeref.oracles.align as literal

    assert literal.PD_TOLERANCE == fast.PD_TOLERANCE and literal.SLACK == fast.SLACK
    assert vars(literal.PAPER_ALIGN) == dataclasses.asdict(fast.AlignParams())


def test_tile_sums_are_the_sums_over_each_tile():
    from spikeref.align_noise import tile_sums

    rng = np.random.default_rng(12)
    values = rng.integers(0, 1000, (21, 30)).astype(np.float64)  # integers: every order of the sums is exact
    for tile in (2, 4, 8):
        grid = ((21 - tile) // (tile // 2) + 1, (30 - tile) // (tile // 2) + 1)
        want = [[values[i * tile // 2:i * tile // 2 + tile, j * tile // 2:j * tile // 2 + tile].sum()
                 for j in range(grid[1])] for i in range(grid[0])]
        np.testing.assert_array_equal(tile_sums(values, tile, grid), want)
