"""Hard cases stay numerically stable: every stage on dark, saturated, extreme and tiny inputs.

Invariants, not "it runs": outputs finite, rates in [0, 1], radiance ≥ 0, energy conservation
where it holds, shifts by whole Bayer periods commute with the operator, float32 = float64
within stated tolerances, identical results for identical seeds.  Bad input is in
``tests/test_bad_input.py``; the long-recording memory case is at the end (marked slow).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.accumulate import accumulate, window_counts
from spikeref.align import AlignParams, align
from spikeref.baselines import TFI_MAX_INTERVAL, tfi, tfstp
from spikeref.bayer import bayer_mosaic, bayer_planes, demosaic_bilinear
from spikeref.io.dat import pack_planes
from spikeref.metrics import psnr, pu21_psnr, ssim
from spikeref.stream import SpikeStream
from spikeref.tonemap import choose_exposure, tonemap
from spikeref.warp import warp_average, warp_spike_windows

CFAS = ("RGGB", "BGGR", "GRBG", "GBRG")


def _streams(spikes, cfa=None):
    """The same planes in memory and as packed .dat bytes."""
    t, h, w = spikes.shape
    return (SpikeStream.from_array(spikes, cfa=cfa),
            SpikeStream.from_packed(pack_planes(spikes), height=h, width=w, cfa=cfa))


# ------------------------------------------------------------------ accumulation
@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(1, 4), st.integers(1, 5), st.floats(0, 1), st.integers(0, 2**31 - 1))
def test_accumulate_rates_in_unit_interval_packed_equals_unpacked(t, h2, w2, p, seed):
    rng = np.random.default_rng(seed)
    spikes = (rng.random((t, 2 * h2, 8 * w2)) < p).astype(np.uint8)
    w = int(rng.integers(1, t + 1))
    a, b = (accumulate(s, w) for s in _streams(spikes))
    np.testing.assert_array_equal(a, b)
    assert a.shape == (t // w, 2 * h2, 8 * w2) and np.all((a >= 0) & (a <= 1))
    np.testing.assert_allclose(a * w, spikes[: (t // w) * w].reshape(t // w, w, *spikes.shape[1:]).sum(1), rtol=1e-6)


@pytest.mark.parametrize("value", [0, 1])
def test_dark_and_saturated_streams_accumulate_to_0_and_1(value):
    spikes = np.full((50, 4, 8), value, np.uint8)
    for s in _streams(spikes):
        assert np.all(accumulate(s, 50) == value) and np.all(accumulate(s, 1) == value)


def test_smallest_legal_stream_one_plane_2x2():
    spikes = np.array([[[1, 0], [0, 1]]], np.uint8)
    np.testing.assert_array_equal(window_counts(SpikeStream.from_array(spikes, cfa="RGGB"), 1)[0], spikes[0])
    wide = np.array([[[1, 0, 0, 1, 1, 1, 0, 0], [0, 1, 1, 0, 0, 0, 1, 1]]], np.uint8)  # a .dat plane: 8·k bits
    for s in _streams(wide, "RGGB"):
        np.testing.assert_array_equal(window_counts(s, 1)[0], wide[0])
    rgb = demosaic_bilinear(accumulate(spikes, 1)[0], "RGGB")
    assert rgb.shape == (2, 2, 3) and np.all(np.isfinite(rgb))


def test_nyquist_stripes_survive_accumulation_exactly():
    spikes = np.zeros((20, 4, 8), np.uint8)
    spikes[:, :, ::2] = 1  # alternating columns at the Nyquist rate
    np.testing.assert_array_equal(accumulate(spikes, 10)[0], np.tile([1.0, 0.0], (4, 4)))


# ------------------------------------------------------------------ baselines
def test_tfi_tfstp_on_dark_and_saturated_streams():
    dark = np.zeros((300, 4, 6), np.uint8)
    full = np.ones((300, 4, 6), np.uint8)
    np.testing.assert_allclose(tfi(dark, times=[0, 150, 299]), 1.0 / (TFI_MAX_INTERVAL + 1))  # no interval: 257
    np.testing.assert_allclose(tfi(full, times=[1, 150, 299]), 1.0)  # an interval of one readout
    assert np.all(tfstp(dark) == 0)  # never fired: 0, not NaN
    r = tfstp(full)
    assert np.all(np.isfinite(r)) and np.all((r >= 0) & (r <= 1))
    np.testing.assert_allclose(r[-1], 1.0, rtol=1e-3)  # converged to one spike per readout


def test_single_bright_pixel_at_1e5_contrast_stays_local_and_finite(rng):
    t = 20000
    spikes = (rng.random((t, 6, 6)) < 1e-5).astype(np.uint8)  # background: 1e-5 spikes per readout
    spikes[:, 3, 3] = 1  # one pixel fires every readout: contrast 1e5
    stream = SpikeStream.from_array(spikes)
    for out in (accumulate(stream, 100), tfi(stream, times=np.arange(300, t, 997)),
                tfstp(stream, times=np.arange(300, t, 997))):
        assert np.all(np.isfinite(out)) and np.all((out >= 0) & (out <= 1))
        assert np.allclose(out[:, 3, 3], 1.0, rtol=1e-3)
        others = np.delete(out.reshape(out.shape[0], -1), 3 * 6 + 3, axis=1)
        assert others.max() <= 0.5  # nothing bleeds from the bright pixel


@pytest.mark.parametrize("cfa", CFAS)
def test_shift_by_whole_bayer_periods_commutes_with_baselines(rng, cfa):
    spikes = (rng.random((120, 8, 12)) < rng.random((8, 12)) * 0.5).astype(np.uint8)
    shifted = np.roll(spikes, (2, 4), axis=(1, 2))  # one and two Bayer periods: the CFA is unchanged
    for f in (lambda s: accumulate(s, 10), lambda s: tfi(s, times=[60, 90]), lambda s: tfstp(s, times=[60, 119])):
        np.testing.assert_array_equal(f(shifted), np.roll(f(spikes), (2, 4), axis=(-2, -1)))
    planes = bayer_planes(accumulate(spikes, 10)[0], cfa)
    np.testing.assert_array_equal(bayer_planes(accumulate(shifted, 10)[0], cfa),
                                  np.roll(planes, (1, 2), axis=(-2, -1)))


# ------------------------------------------------------------------ demosaic, tonemap
@pytest.mark.parametrize("cfa", CFAS)
def test_demosaic_flat_grey_is_flat_and_float32_matches_float64(rng, cfa):
    flat = np.full((6, 8), 0.37)
    np.testing.assert_allclose(demosaic_bilinear(flat, cfa), 0.37, rtol=1e-12)
    mosaic = rng.random((10, 14))
    a = demosaic_bilinear(mosaic.astype(np.float32), cfa)
    b = demosaic_bilinear(mosaic, cfa)
    assert a.dtype == np.float32 and b.dtype == np.float64
    np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-7)
    assert np.all((b >= mosaic.min() - 1e-12) & (b <= mosaic.max() + 1e-12))  # convex weights: no overshoot
    np.testing.assert_array_equal(bayer_mosaic(bayer_planes(mosaic, cfa), cfa), mosaic)


def test_tonemap_survives_dark_nan_inf_and_huge_values():
    frame = np.array([[[0.0, np.nan, np.inf], [-np.inf, 1e30, -5.0]]])
    out = tonemap(frame, 1.0)
    assert out.dtype == np.uint8 and out.tolist() == [[[0, 0, 255], [0, 255, 0]]]
    gain = choose_exposure(frame).gain  # ignores NaN and inf, finite and positive
    assert np.isfinite(gain) and gain > 0 and np.all(tonemap(frame, gain) >= 0)
    assert choose_exposure(np.zeros((4, 4, 3))).gain == 1.0  # all dark: no division by zero


# ------------------------------------------------------------------ alignment and warping
def _texture(rng, h=96, w=96):
    from scipy.ndimage import gaussian_filter

    return gaussian_filter(rng.random((h + 64, w + 64)), 2.0)[32:-32, 32:-32].astype(np.float32)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_flat_images_give_zero_flow(dtype):
    flat = np.full((64, 80), 0.25, dtype)
    for step in (0, 2):
        flow = align(flat, flat.copy(), step)
        assert np.all(np.isfinite(flow)) and np.all(flow == 0)


def test_periodic_and_far_moved_images_give_finite_bounded_flow(rng):
    y, x = np.mgrid[:96, :96]
    stripes = (0.5 + 0.4 * np.sin(2 * np.pi * x / 4.0)).astype(np.float32)  # period 4: aliases under the pyramid
    tex = _texture(rng)
    far = np.roll(tex, (40, -45), axis=(0, 1))  # beyond the ±4·8 = 32 px reach of the coarsest level
    p = AlignParams()
    reach = sum(r * 2**lvl for lvl, r in enumerate(p.search_radius)) + 1
    for ref, alt in ((stripes, np.roll(stripes, 1, axis=1)), (tex, far)):
        flow = align(ref, alt, 0)
        assert np.all(np.isfinite(flow)) and np.abs(flow).max() <= reach


def test_subpixel_shift_float32_equals_float64(rng):
    from scipy.ndimage import shift as nd_shift

    tex = _texture(rng).astype(np.float64)
    moved = nd_shift(tex, (0.4, -0.3), order=3, mode="wrap")
    f64 = align(tex, moved, 2)
    f32 = align(tex.astype(np.float32), moved.astype(np.float32), 2)
    inner = (slice(None), slice(16, -16), slice(16, -16))
    np.testing.assert_allclose(f32[inner], f64[inner], atol=0.02)
    assert abs(np.median(f64[0][inner[1:]]) - 0.4) < 0.1 and abs(np.median(f64[1][inner[1:]]) + 0.3) < 0.1


def test_warping_with_zero_flow_conserves_spikes_and_far_flow_stays_finite(rng):
    counts = rng.integers(0, 11, (3, 4, 8, 10)).astype(np.float32)
    zero = np.zeros((3, 2, 8, 10), np.float32)
    np.testing.assert_allclose(warp_spike_windows(counts, zero, 10), counts.sum(0) / 30, rtol=1e-6)
    away = zero.copy()
    away[1:] = 1e4  # every neighbour sample leaves the image: only the reference remains
    out = warp_average(counts, away)
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(out, counts[0], rtol=1e-6)
    with pytest.raises(ValueError, match="finite"):
        warp_average(counts, np.full_like(zero, np.nan))


# ------------------------------------------------------------------ denoiser
@pytest.fixture(scope="module")
def denoisers():
    from spikeref.denoise.denoiser import Denoiser

    return {name: Denoiser.load(name) for name in ("b2u_w16", "pairs_w16_charge")}


@pytest.mark.parametrize("mode", ["visible", "blind", "mixed"])
def test_denoiser_on_zeros_ones_and_a_hot_pixel_is_finite_and_bounded(denoisers, mode):
    hot = np.zeros((4, 32, 32), np.float32)
    hot[:, 16, 16] = 1.0
    cases = {"zeros": np.zeros((4, 32, 32), np.float32), "ones": np.ones((4, 32, 32), np.float32), "hot": hot}
    for name, den in denoisers.items():
        for case, planes in cases.items():
            for window in (5.0, 200.0):
                out = den(planes, mode, window=window)
                assert out.shape == planes.shape and np.all(np.isfinite(out)), (name, case)
                # a hot pixel rings slightly below 0 next to it (measured −0.057 for b2u_w16 at W = 200)
                assert -0.1 <= out.min() and out.max() <= 1.3, (name, case, window, out.min(), out.max())
        assert np.abs(den(cases["zeros"], mode, window=10.0)).max() < 0.05
        assert np.abs(den(cases["ones"], mode, window=10.0) - 1).max() < 0.3


# ------------------------------------------------------------------ metrics
def test_metrics_on_constant_and_extreme_images():
    flat = np.full((16, 16, 3), 0.2)
    assert ssim(flat, flat, 1.0) == pytest.approx(1.0) and psnr(flat, flat, 1.0) == np.inf
    assert np.isfinite(ssim(flat, np.zeros_like(flat), 1.0))
    lamp = np.full((16, 16, 3), 1e-6)
    lamp[8, 8] = 1e6  # 1e12 dynamic range: PU21 clamps, nothing overflows
    assert np.isfinite(pu21_psnr(lamp, lamp * 1.01))


# ------------------------------------------------------------------ simulator
def _uniform_scene(brightness, threshold=1.0, effects=None, planes=400, size=8):
    from spikeref.simulate.scenes import scene_from_dict

    return scene_from_dict({"name": "u", "planes": planes,
                            "camera": {"cfa": "RGGB", "threshold": threshold, "substeps": 1},
                            "content": {"type": "uniform", "height": size, "width": size, "brightness": brightness},
                            "effects": effects or {}})


@pytest.mark.parametrize("brightness, threshold, rate", [
    (0.0, 1.0, 0.0),  # no light: no spike, ever
    (1.0, 1.0, 1.0),  # exactly one threshold per readout: a spike every readout
    (7.5, 1.0, 1.0),  # far above: still at most one spike per readout
    (0.3, 1e-6, 1.0),  # threshold near 0: saturates
    (0.25, 1.0, 0.25),  # the closed form floor((φ + r t)/E_th), here with φ = 0
])
def test_simulator_extremes_match_closed_forms(brightness, threshold, rate):
    from spikeref.simulate.simulator import simulate

    spikes = simulate(_uniform_scene(brightness, threshold), seed=0).spikes
    assert spikes.dtype == np.uint8 and set(np.unique(spikes)) <= {0, 1}
    np.testing.assert_allclose(spikes.mean(0), rate, atol=1.0 / spikes.shape[0])


def test_simulator_zero_noise_parameters_equal_no_effect_and_seeds_repeat():
    from spikeref.simulate.simulator import simulate

    base = simulate(_uniform_scene(0.3, effects={"random_phase": {}}), seed=3).spikes
    zeroed = simulate(_uniform_scene(0.3, effects={"random_phase": {}, "dark_current": {"gamma": 0.0},
                                                   "threshold_fpn": {"sigma": 0.0}}), seed=3).spikes
    np.testing.assert_array_equal(zeroed, base)  # γ = 0 and σ = 0 change nothing
    again = simulate(_uniform_scene(0.3, effects={"random_phase": {}}), seed=3).spikes
    np.testing.assert_array_equal(again, base)
    assert not np.array_equal(simulate(_uniform_scene(0.3, effects={"random_phase": {}}), seed=4).spikes, base)


# ------------------------------------------------------------------ pipeline
def _identity(planes):
    return planes


def test_pipeline_on_a_stream_exactly_its_support_and_one_plane_shorter(rng):
    from spikeref.pipeline import ReconstructParams, Reconstructor

    p = ReconstructParams(window=10, K=3, L=3, align=False)
    need = p.support_windows * p.window
    spikes = (rng.random((need, 16, 16)) < 0.3).astype(np.uint8)
    rec = Reconstructor(SpikeStream.from_array(spikes, cfa="RGGB"), p, _identity)
    frames = list(rec.frames())
    assert len(frames) == 1 and np.all(np.isfinite(frames[0].rgb))
    with pytest.raises(ValueError, match=rf"has {need - 1} planes.*needs \(\(K−1\)L\+1\)·W = {need} planes"):
        Reconstructor(SpikeStream.from_array(spikes[:-1], cfa="RGGB"), p, _identity)


@pytest.mark.parametrize("value", [0, 1])
def test_pipeline_on_dark_and_saturated_streams(denoisers, value):
    from spikeref.pipeline import ReconstructParams, Reconstructor

    spikes = np.full((140, 128, 128), value, np.uint8)
    rec = Reconstructor(SpikeStream.from_array(spikes, cfa="RGGB"), ReconstructParams(), denoisers["b2u_w16"])
    for f in rec.frames(3, 5):
        assert np.all(np.isfinite(f.rgb))
        np.testing.assert_allclose(f.rgb, value, atol=0.05 + 0.25 * value)


def test_pipeline_without_flow_is_shift_equivariant_by_bayer_periods(rng):
    from spikeref.pipeline import ReconstructParams, Reconstructor

    spikes = (rng.random((90, 16, 20)) < rng.random((16, 20)) * 0.6).astype(np.uint8)
    shifted = np.roll(spikes, (2, -4), axis=(1, 2))
    p = ReconstructParams(window=10, K=3, L=2, align=False)
    a = [f.rgb for f in Reconstructor(SpikeStream.from_array(spikes, cfa="GRBG"), p, _identity).frames()]
    b = [f.rgb for f in Reconstructor(SpikeStream.from_array(shifted, cfa="GRBG"), p, _identity).frames()]
    # away from the image border and the seams of the roll (rows 1|2, columns 15|16), where Ψ's
    # 3×3 support reaches across
    inner = (slice(3, -1), slice(1, -5))
    for x, y in zip(a, b, strict=True):
        np.testing.assert_allclose(np.roll(x, (2, -4), axis=(0, 1))[inner], y[inner], rtol=1e-6)


def _alignment_notes(record):
    return [str(w.message) for w in record if "alignment pyramid" in str(w.message)]


@pytest.mark.parametrize("size, fitted", [
    (64, "aligned with levels=3, tile_by_step=(32, 16, 8)"),  # 32×32 planes: the coarsest level goes
    (16, "aligned with levels=1, tile_by_step=(8, 8, 8)"),  # 8×8 planes: one level of 8-pixel tiles
    (2, "not aligned, zero flow"),  # 1×1 planes: not even a 2×2 tile
])
def test_default_reconstruction_of_small_colour_streams_fits_its_alignment(rng, size, fitted):
    """The defaults (bundled denoiser, noise-aware alignment) on frames too small for the pyramid: finite
    frames of the right shape, and one note of what alignment was reduced to."""
    import warnings

    from spikeref.pipeline import ReconstructParams, Reconstructor, reconstruct

    spikes = (rng.random((90, size, size)) < rng.random((size, size)) * 0.7).astype(np.uint8)
    for run in ("Reconstructor", "reconstruct"):
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            if run == "Reconstructor":
                rec = Reconstructor(SpikeStream.from_array(spikes, cfa="RGGB"))
                frames = [f.rgb for f in rec.frames()]
            else:
                frames = list(reconstruct(spikes))
        notes = _alignment_notes(record)
        assert len(notes) == 1 and "\n" not in notes[0], notes
        assert notes[0].startswith(f"{size}×{size} frames ({size // 2}×{size // 2} per Bayer plane) are too small")
        assert fitted in notes[0], notes[0]
        assert len(frames) == 3, run
        for rgb in frames:
            assert rgb.shape == (size, size, 3) and rgb.dtype == np.float32 and np.all(np.isfinite(rgb)), run
    assert rec.params.align == (size > 2) and rec.params != ReconstructParams()


def test_default_reconstruction_of_frames_large_enough_keeps_its_alignment(rng):
    """No note, and the very parameters given, where the pyramid fits (256×256; 128×128 exactly)."""
    import warnings

    from spikeref.pipeline import ReconstructParams, Reconstructor

    for size in (256, 128):
        spikes = (rng.random((70, size, size)) < 0.3).astype(np.uint8)
        params = ReconstructParams()
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            rec = Reconstructor(SpikeStream.from_array(spikes, cfa="RGGB"), params)
            if size == 256:
                (frame,) = rec.frames()
                assert frame.rgb.shape == (256, 256, 3) and np.all(np.isfinite(frame.rgb))
        assert _alignment_notes(record) == [] and rec.params is params


def test_cli_reconstruct_of_a_small_stream_prints_one_note(tmp_path, rng, capsys):
    from spikeref.cli import main

    np.save(tmp_path / "small.npy", (rng.random((80, 64, 64)) < 0.3).astype(np.uint8))
    assert main(["reconstruct", str(tmp_path / "small.npy"), "--cfa", "RGGB", "--exr-dir", str(tmp_path / "exr")]) == 0
    err = capsys.readouterr().err
    notes = [line for line in err.splitlines() if "note:" in line]
    assert len(notes) == 1 and notes[0].startswith("spikeref reconstruct: note: 64×64 frames"), err
    assert "aligned with levels=3" in notes[0] and "UserWarning" not in err and "Reconstructor(" not in err
    assert len(list((tmp_path / "exr").glob("*.exr"))) == 2  # 8 windows: frames 3 and 4


@pytest.mark.slow
def test_long_memory_mapped_recording_streams_in_bounded_memory(tmp_path):
    """200 000 planes of an 8×8 RGGB frame from a .dat: the traced peak does not grow with length."""
    import tracemalloc

    from spikeref.io.dat import DatWriter
    from spikeref.stream import read_dat
    from spikeref.pipeline import ReconstructParams, Reconstructor

    planes, h, w = 200_000, 8, 8
    rng = np.random.default_rng(0)
    path = tmp_path / "long.dat"
    with DatWriter(path, h, w) as out:
        for _ in range(planes // 10_000):
            out.append((rng.random((10_000, h, w)) < 0.2).astype(np.uint8))
    stream = read_dat(path, height=h, width=w, cfa="RGGB")
    assert len(stream) == planes
    p = ReconstructParams(window=10, K=3, L=3, align=False)
    rec = Reconstructor(stream, p, _identity)
    n_frames = len(rec.frames_available)
    peaks = []
    tracemalloc.start()
    try:
        for i, frame in enumerate(rec.frames()):
            assert np.all(np.isfinite(frame.rgb)) and frame.rgb.min() >= 0 and frame.rgb.max() <= 1
            if i in (n_frames // 10, n_frames - 1):
                peaks.append(tracemalloc.get_traced_memory()[1])
    finally:
        tracemalloc.stop()
    assert i == n_frames - 1 == planes // 10 - 7  # every frame of the support's range
    assert peaks[1] <= peaks[0] * 1.1 + 64 * 1024  # after 10 % or 100 % of the recording: the same peak


# ------------------------------------------------------------------ properties across stages
even = st.integers(1, 6).map(lambda n: 2 * n)


@settings(max_examples=30, deadline=None)
@given(even, even, st.sampled_from(CFAS), st.integers(0, 2**31 - 1))
def test_demosaic_is_a_convex_interpolation(h, w, cfa, seed):
    mosaic = np.random.default_rng(seed).random((h, w)) * 10 ** np.random.default_rng(seed).uniform(-5, 5)
    rgb = demosaic_bilinear(mosaic, cfa)
    assert np.all(np.isfinite(rgb))
    assert rgb.min() >= mosaic.min() * (1 - 1e-12) and rgb.max() <= mosaic.max() * (1 + 1e-12)
    np.testing.assert_allclose(demosaic_bilinear(mosaic.astype(np.float32), cfa), rgb, rtol=2e-6)


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 3).map(lambda n: 2 * n - 1), st.integers(2, 12), st.integers(2, 12), st.floats(0, 6),
       st.integers(0, 2**31 - 1))
def test_warp_average_is_a_convex_combination(k, h, w, reach, seed):
    rng = np.random.default_rng(seed)
    frames = rng.random((k, 2, h, w))
    flows = rng.uniform(-reach, reach, (k, 2, h, w))
    flows[k // 2] = 0  # the reference
    out = warp_average(frames, flows)
    assert np.all(np.isfinite(out))
    assert out.min() >= frames.min() - 1e-6 and out.max() <= frames.max() + 1e-6
    np.testing.assert_allclose(warp_average(frames.astype(np.float32), flows.astype(np.float32)), out,
                               rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(warp_average(frames, np.zeros_like(flows)), frames.mean(0), rtol=1e-6)


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 300), st.floats(0, 1), st.integers(0, 2**31 - 1))
def test_tfi_tfstp_rates_stay_in_range_on_any_stream(t, p, seed):
    rng = np.random.default_rng(seed)
    spikes = (rng.random((t, 2, 8)) < p * rng.random((2, 8))).astype(np.uint8)
    a = tfi(spikes)
    b = tfstp(spikes)
    assert np.all(np.isfinite(a)) and np.all((a >= 1.0 / 257 - 1e-9) & (a <= 1))
    assert np.all(np.isfinite(b)) and np.all((b >= 0) & (b <= 1))


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=1, max_size=30),
       st.floats(1e-6, 1e6))
def test_tonemap_maps_anything_to_display_values_monotonically(values, gain):
    x = np.array(values)
    out = tonemap(x.reshape(1, -1), gain)[0]
    assert out.dtype == np.uint8
    finite = np.isfinite(x)
    order = np.argsort(x[finite], kind="stable")
    assert np.all(np.diff(out[finite][order].astype(int)) >= 0)


@settings(max_examples=20, deadline=None)
@given(st.floats(0, 1.5), st.floats(0.05, 2.0))
def test_simulator_counts_match_the_integrate_and_fire_closed_form(radiance, threshold):
    from spikeref.simulate.simulator import simulate

    t = 300
    spikes = simulate(_uniform_scene(radiance, threshold, planes=t, size=2), seed=0).spikes
    # no effects, no initial charge: count = min(T, ⌊r T / E_th⌋), to one spike of float rounding
    expect = min(t, int(np.floor(radiance * t / threshold + 1e-9)))
    assert np.all(np.abs(spikes.sum(0).astype(int) - expect) <= 1)


@settings(max_examples=15, deadline=None)
@given(st.integers(8, 40), st.integers(8, 40), st.floats(0, 1), st.floats(5, 200), st.integers(0, 2**31 - 1))
def test_denoiser_output_is_finite_and_bounded_on_any_rates(h, w, level, window, seed):
    from spikeref.denoise.denoiser import Denoiser

    rng = np.random.default_rng(seed)
    planes = np.clip(level + rng.standard_normal((4, h, w)) * 0.3, 0, 1).astype(np.float32)
    out = Denoiser.load()(planes, "visible", window=window)
    assert out.shape == planes.shape and np.all(np.isfinite(out))
    assert out.min() >= -0.2 and out.max() <= 1.5


@settings(max_examples=15, deadline=None)
@given(st.integers(-3, 3), st.integers(-3, 3), st.integers(0, 2**31 - 1))
def test_alignment_recovers_integer_shifts_of_texture(dy, dx, seed):
    tex = _texture(np.random.default_rng(seed))
    moved = np.roll(tex, (dy, dx), axis=(0, 1))  # alternate[y + dy, x + dx] = reference[y, x]
    flow = align(tex, moved, 0)
    inner = (slice(16, -16), slice(16, -16))
    assert np.all(np.isfinite(flow))
    assert abs(np.median(flow[0][inner]) - dy) < 0.25 and abs(np.median(flow[1][inner]) - dx) < 0.25


@settings(max_examples=20, deadline=None)
@given(st.integers(11, 24), st.integers(11, 24), st.integers(0, 2**31 - 1))
def test_metrics_float32_equals_float64(h, w, seed):
    rng = np.random.default_rng(seed)
    a = rng.random((h, w, 3))
    b = np.clip(a + 0.05 * rng.standard_normal(a.shape), 0, None)
    assert psnr(a.astype(np.float32), b.astype(np.float32), 1.0) == pytest.approx(psnr(a, b, 1.0), rel=1e-5)
    assert ssim(a.astype(np.float32), b.astype(np.float32), 1.0) == pytest.approx(ssim(a, b, 1.0), abs=1e-5)


def test_kernels_without_jit_equal_the_compiled_kernels(tmp_path, rng):
    """NUMBA_DISABLE_JIT=1 runs every kernel of a small reconstruction as Python: the same frames."""
    import subprocess
    import sys

    spikes = (rng.random((90, 16, 24)) < rng.random((16, 24)) * 0.7).astype(np.uint8)
    np.save(tmp_path / "spikes.npy", spikes)
    script = f"""
import numpy as np
from spikeref.baselines import tfi, tfstp
from spikeref.io.dat import pack_planes
from spikeref.pipeline import ReconstructParams, Reconstructor
from spikeref.stream import SpikeStream
s = np.load({str(tmp_path / "spikes.npy")!r})
packed = SpikeStream.from_packed(pack_planes(s), 16, 24, cfa="RGGB")
p = ReconstructParams(window=10, K=3, L=2, align=False)
frames = np.stack([f.rgb for f in Reconstructor(packed, p, lambda x: x).frames()])
np.savez({str(tmp_path / "out.npz")!r}, frames=frames, tfi=tfi(s, times=[10, 50]), tfstp=tfstp(s, times=[10, 89]))
"""
    import os

    for jit in ("0", "1"):
        env = {**os.environ, "NUMBA_DISABLE_JIT": jit}
        subprocess.run([sys.executable, "-c", script], check=True, env=env, capture_output=True)
        (tmp_path / "out.npz").rename(tmp_path / f"out_{jit}.npz")
    with np.load(tmp_path / "out_0.npz") as a, np.load(tmp_path / "out_1.npz") as b:
        for key in ("frames", "tfi", "tfstp"):
            np.testing.assert_allclose(a[key], b[key], rtol=1e-6, atol=1e-7, err_msg=key)
