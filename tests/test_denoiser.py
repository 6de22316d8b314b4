"""The Denoiser (bundled weights, modes, frames of a stream) and `spikeref denoise`."""

import numpy as np
import pytest

from spikeref.cli import main
from spikeref.denoise.blindspot import cell_masks, mask_aware_average, masked_volume
from spikeref.denoise.denoiser import DEFAULT_WEIGHTS, Denoiser
from spikeref.denoise.unet import UNet, UNetSpec
from spikeref.sample import load_sample
from spikeref.stream import SpikeStream


@pytest.fixture(scope="module")
def small():
    return Denoiser(UNet.random(UNetSpec(width=4, depth=3), seed=2), guard="off")


def test_modes_follow_eq_10_11(small):
    planes = np.random.default_rng(0).random((4, 12, 20)).astype(np.float32) * 0.4
    visible = small(planes)
    np.testing.assert_array_equal(visible, small.unet(planes))
    outs = np.stack([small.unet(v) for v in masked_volume(planes)])
    blind = mask_aware_average(outs, cell_masks(12, 20))
    np.testing.assert_allclose(small(planes, "blind"), blind, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(small(planes, "mixed"), (blind + 2 * visible) / 3, rtol=1e-5, atol=1e-7)
    with pytest.raises(ValueError, match="mode must be one of"):
        small(planes, "fast")
    with pytest.raises(TypeError, match="floating point"):
        small(planes.astype(np.uint8))


def test_frames_are_demosaicked_colour_or_mono_mosaics(small):
    rng = np.random.default_rng(1)
    spikes = (rng.random((35, 16, 24)) < 0.3).astype(np.uint8)
    colour = list(small.frames(SpikeStream.from_array(spikes, cfa="RGGB"), window=10))
    assert [k for k, _ in colour] == [0, 1, 2] and colour[0][1].shape == (16, 24, 3)
    mono = list(small.frames(SpikeStream.from_array(spikes), window=10, start=5, count=2))
    assert len(mono) == 2 and mono[0][1].shape == (16, 24)
    with pytest.raises(ValueError, match="longer than the stream"):
        list(small.frames(SpikeStream.from_array(spikes), window=40))


def test_long_windows_measure_the_guards_noise_on_their_first_planes():
    """frames(): with the guard and W > NOISE_WINDOW the noise comes from the window's first NOISE_WINDOW planes."""
    from spikeref.accumulate import accumulate
    from spikeref.bayer import bayer_mosaic, bayer_planes, demosaic_bilinear
    from spikeref.denoise.guard import NOISE_WINDOW

    net = UNet.random(UNetSpec(width=4, depth=3), seed=2)
    den = Denoiser(UNet(net.spec, net.params, {"input_domain": "count"}))
    rng = np.random.default_rng(3)
    stream = SpikeStream.from_array((rng.random((90, 16, 24)) < 0.3).astype(np.uint8), cfa="RGGB")
    w = 40
    (_, first), = list(den.frames(stream, window=w, start=5, count=1))
    planes = bayer_planes(accumulate(stream, w, start=5, count=1)[0])
    short = bayer_planes(accumulate(stream, NOISE_WINDOW, start=5, count=1)[0])
    expect = demosaic_bilinear(bayer_mosaic(den(planes, window=w, short=short, short_window=NOISE_WINDOW)), "RGGB")
    np.testing.assert_array_equal(first, expect)
    assert not np.array_equal(expect, demosaic_bilinear(bayer_mosaic(den(planes, window=w)), "RGGB"))
    with pytest.raises(ValueError, match="short must have the shape"):
        den(planes, window=w, short=short[:2], short_window=NOISE_WINDOW)
    with pytest.raises(ValueError, match="short= needs short_window"):
        den(planes, window=w, short=short)


def test_the_guard_takes_only_the_floor_where_a_long_window_is_all_it_has():
    """den(planes, window=W): for W > NOISE_WINDOW without a short window, sure_blend with carried = 0 (the
    quantisation floor); with a short window of at most NOISE_WINDOW planes, CARRY_FRACTION of its excess; a
    longer "short" window is not read; up to NOISE_WINDOW, the plane's own σ; floor_window moves the guard's
    exposure and not the network's."""
    from spikeref.denoise.guard import CARRY_FRACTION, NOISE_WINDOW, carried_excess_variance, sure_blend

    net = _count_network()  # guard off, no shrinkage: the network alone
    guarded = Denoiser(net.unet)
    rng = np.random.default_rng(4)
    w = 50
    planes = (rng.integers(0, w + 1, (4, 16, 24)) / w).astype(np.float32)
    short = (rng.integers(0, NOISE_WINDOW + 1, (4, 16, 24)) / NOISE_WINDOW).astype(np.float32)

    def blend(window, carried):
        return sure_blend(planes, lambda z: net(z, window=window), window=window, carried=carried)[0]

    bare = guarded(planes, window=w)
    np.testing.assert_array_equal(bare, blend(w, 0.0))
    assert not np.array_equal(bare, blend(w, None))  # the plane's own σ, the bare call's until 2026-11-27
    np.testing.assert_array_equal(guarded(planes, window=w, short=short, short_window=2 * NOISE_WINDOW), bare)
    carried = CARRY_FRACTION * carried_excess_variance(short, NOISE_WINDOW, w)
    np.testing.assert_array_equal(guarded(planes, window=w, short=short, short_window=NOISE_WINDOW),
                                  blend(w, carried))
    np.testing.assert_array_equal(guarded(planes, window=NOISE_WINDOW), blend(NOISE_WINDOW, None))
    # floor_window: the guard's exposure (floor, carried noise, the NOISE_WINDOW test) apart from the network's
    merged = sure_blend(planes, lambda z: net(z, window=w), window=7 * w,
                        carried=CARRY_FRACTION * carried_excess_variance(short, NOISE_WINDOW, 7 * w))[0]
    np.testing.assert_array_equal(guarded(planes, window=w, short=short, short_window=NOISE_WINDOW,
                                          floor_window=7 * w), merged)
    np.testing.assert_array_equal(guarded(planes, window=w, floor_window=NOISE_WINDOW),
                                  sure_blend(planes, lambda z: net(z, window=w), window=NOISE_WINDOW)[0])
    for bad in (0, -3.0, float("nan"), True, "7"):
        with pytest.raises(ValueError, match="floor_window must be a positive number"):
            guarded(planes, window=w, floor_window=bad)


@pytest.mark.realdata
def test_the_readme_call_is_never_worse_than_plain_accumulation_on_real_spikes(real_data):
    """The README's call, ``Denoiser.load()(bayer_planes(rates), mode="visible", window=W)`` on Eq. 4 rates of
    SpikingSIM's real outdoor recording: within 0.1 dB of the rates themselves or better at every W, long ones
    included (where the guard once read the branches and the sensor's fixed pattern as noise and lost 4 dB).

    Scored against the mean of planes 300–500 with the recording's 4 hot pixels repaired (tests/test_pipeline.py's
    pseudo ground truth), windows from plane 0 (disjoint from it), PSNR after one least-squares gain, 8-pixel
    border left out.  Measured 2026-11-27 (docs/results.md, "Never worse than plain accumulation, by every
    path"): +6.39 dB at W = 10 (windows 0 and 10), +1.65 at 50, +0.51 at 100, +0.10 at 200; before, −1.53 at
    100 and −4.07 at 200.
    """
    from spikeref.bayer import bayer_mosaic, bayer_planes
    from spikeref.hot_pixels import HotPixelRepair, find_hot_pixels
    from spikeref.metrics import psnr_after_gain

    with np.load(real_data / "spikingsim_real_spike.npz") as data:
        spikes = np.ascontiguousarray(data["arr_0"].transpose(2, 0, 1))  # stored (H, W, T)
    truth = HotPixelRepair(find_hot_pixels(spikes)).mosaic(spikes[300:500].mean(axis=0, dtype=np.float64))[8:-8, 8:-8]

    def score(image):
        return psnr_after_gain(truth, np.asarray(image, np.float64)[8:-8, 8:-8], float(truth.max()))

    den = Denoiser.load()
    gains = {}
    for w, starts in ((10, (0, 10)), (50, (0,)), (100, (0,)), (200, (0,))):
        for t0 in starts:
            rates = spikes[t0:t0 + w].mean(axis=0, dtype=np.float64).astype(np.float32)  # sr.accumulate's Eq. 4
            clean = bayer_mosaic(den(bayer_planes(rates), mode="visible", window=w))
            gains.setdefault(w, []).append(score(clean) - score(rates))
    assert min(min(g) for g in gains.values()) > -0.1, gains
    assert min(gains[10]) > 6.0 and min(gains[50]) > 1.0, gains  # the gain where the network pays is kept


def test_two_networks_ship_one_per_input():
    """One network per input a window gives (issue: at most two bundled networks): Eq. 4's counts and charges."""
    assert sorted(p.stem for p in DEFAULT_WEIGHTS.parent.glob("*.npz")) == ["b2u_w16", "pairs_w16_charge"]
    from spikeref.charge import ACCUMULATE
    from spikeref.denoise.denoiser import bundled_weights

    assert sorted(bundled_weights(a).stem for a in ACCUMULATE) == ["b2u_w16", "pairs_w16_charge"]


@pytest.mark.parametrize("name, width, domain", [("b2u_w16", 16, "count"), ("pairs_w16_charge", 16, "count")])
def test_bundled_weights_load_and_are_documented(name, width, domain):
    den = Denoiser.load(name)  # a bundled name resolves to spikeref/denoise/weights/NAME.npz
    path = DEFAULT_WEIGHTS.parent / f"{name}.npz"
    assert path.stat().st_size < 5 * 2**20  # the budget for bundled weights
    meta = den.unet.meta
    assert den.unet.spec.width == meta["config"]["width"] == width and den.input_domain == domain
    assert meta["final_loss"] > 0 and meta["config"]["window_min"] == 5 and meta["config"]["window_max"] == 200
    # the training scenes, and real or other-simulator recordings of ../shared/data/real, never the held-out
    # scenes nor the real-data test recording (spikingsim_real_spike.npz)
    allowed = ("spikezoo_uhsr.npz", "spikezoo_data_reds_sim_250x400.dat")
    assert all(d["file"].startswith("train_") or d["file"] in allowed for d in meta["data"])
    assert Denoiser.load().unet.meta == Denoiser.load("b2u_w16").unet.meta  # the default
    assert meta.get("accumulate", "count") == ("charge" if name.endswith("_charge") else "count")


@pytest.mark.parametrize("name", ["b2u_w16"])
def test_bundled_weights_beat_tfp_on_the_sample(name):
    """The embedded sample (fan over toys, not a training scene) at W = 10: Ψ[D(I)] is closer to the truth.

    Measured 2026-11-23: +2.6 dB (b2u_w16) over three frames; the bound
    leaves room for a retrained network, not for one that does nothing (0 dB).
    """
    from spikeref.accumulate import accumulate
    from spikeref.bayer import demosaic_bilinear
    from spikeref.sample import sample_ground_truth

    stream = load_sample()
    gt = sample_ground_truth(10)[5:8]
    den = Denoiser.load(name)
    errs_tfp, errs_den = [], []
    for i, k in enumerate(range(5, 8)):
        rates = accumulate(stream, 10, start=10 * k, count=1)[0]
        errs_tfp.append(np.mean((demosaic_bilinear(rates, stream.cfa) - gt[i]) ** 2))
        errs_den.append(np.mean((next(den.frames(stream, 10, start=10 * k, count=1))[1] - gt[i]) ** 2))
    gain_db = 10 * np.log10(np.mean(errs_tfp) / np.mean(errs_den))
    assert gain_db > 2.0, gain_db


def test_cli_denoise_writes_video_and_exr(tmp_path):
    out = tmp_path / "d.mp4"
    assert main(["denoise", "-W", "20", "--frames", "3", "-o", str(out), "--exr-dir", str(tmp_path / "exr")]) == 0
    assert out.stat().st_size > 0
    assert sorted(p.name for p in (tmp_path / "exr").iterdir()) == [
        "frame_000000.exr", "frame_000001.exr", "frame_000002.exr"]


def test_cli_denoise_charge_takes_the_charge_network(tmp_path, monkeypatch):
    """--accumulate charge: window charges (spikeref.charge) and, without --weights, pairs_w16_charge."""
    from spikeref.cli import weights as cli_weights  # the commands call it there: cli_weights.load_denoiser

    loaded = []
    real = cli_weights.load_denoiser
    monkeypatch.setattr(cli_weights, "load_denoiser",
                        lambda weights, **kw: loaded.append(weights) or real(weights, **kw))
    out = tmp_path / "c.mp4"
    assert main(["denoise", "-W", "10", "--frames", "1", "--accumulate", "charge", "-o", str(out)]) == 0
    assert out.stat().st_size > 0 and loaded == ["pairs_w16_charge"]


def test_each_accumulation_loads_the_network_trained_on_it(tmp_path, monkeypatch):
    """bundled_weights: counts → b2u_w16, charges → pairs_w16_charge; the pipeline without a denoiser and
    `spikeref reconstruct` without --weights load the one for their accumulation (charges by default)."""
    from spikeref.cli import weights as cli_weights  # the commands call it there: cli_weights.load_denoiser
    from spikeref.denoise.denoiser import bundled_weights
    from spikeref.pipeline import ReconstructParams, Reconstructor

    assert bundled_weights("count").name == "b2u_w16.npz" and bundled_weights("charge").name == "pairs_w16_charge.npz"
    with pytest.raises(ValueError, match="accumulate must be one of count, charge"):
        bundled_weights("photons")
    loaded = []
    real_load = Denoiser.load.__func__
    monkeypatch.setattr(Denoiser, "load", classmethod(lambda c, path=None, **kw: loaded.append(path)
                                                     or real_load(c, path, **kw)))
    Reconstructor(load_sample(), ReconstructParams())
    Reconstructor(load_sample(), ReconstructParams.paper())
    assert [p.name for p in loaded] == ["pairs_w16_charge.npz", "b2u_w16.npz"]
    names = []
    real = cli_weights.load_denoiser
    monkeypatch.setattr(cli_weights, "load_denoiser",
                        lambda weights, **kw: names.append(str(weights)) or real(weights, **kw))
    for extra in ([], ["--paper"], ["--accumulate", "count"]):
        assert main(["reconstruct", "--frames", "3:4", "-o", str(tmp_path / "r.mp4"), *extra]) == 0
    assert names == ["pairs_w16_charge", "b2u_w16", "b2u_w16"]


def test_cli_denoise_errors(tmp_path, capsys):
    assert main(["denoise", str(tmp_path / "none.dat"), "-o", str(tmp_path / "x.mp4")]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["denoise", "--frames", "1", "-o", str(tmp_path / "x.mp4"), "--weights", str(tmp_path / "w.npz")]) == 2
    assert "no such weights file, nor a bundled name" in capsys.readouterr().err


def test_cli_train_writes_weights(tmp_path):
    pytest.importorskip("torch")
    rng = np.random.default_rng(3)
    np.savez(tmp_path / "s.npz", spikes=(rng.random((30, 64, 64)) < 0.2).astype(np.uint8))
    out = tmp_path / "w.npz"
    assert main(["train", str(tmp_path / "s.npz"), "-o", str(out), "--channels", "4", "--steps", "3",
                 "--batch", "1", "--patch", "32", "--device", "cpu"]) == 0
    net = UNet.load(out)
    assert net.spec.width == 4 and net.meta["data"][0]["file"] == "s.npz"
    assert net.meta["input_domain"] == "count" and Denoiser(net).input_domain == "count"  # the default
    assert (tmp_path / "w.npz.ckpt").is_file()


def test_cli_train_pairs_on_window_charges(tmp_path, capsys):
    """--objective pairs --accumulate charge reach the configuration; a file too short for pairs is a clear error."""
    pytest.importorskip("torch")
    period = np.random.default_rng(4).integers(2, 9, (64, 64))
    spikes = (np.arange(560)[:, None, None] % period == 0).astype(np.uint8)  # a scene that does not move
    np.savez(tmp_path / "s.npz", spikes=spikes)
    out = tmp_path / "w.npz"
    assert main(["train", str(tmp_path / "s.npz"), "-o", str(out), "--channels", "4", "--steps", "2", "--batch", "1",
                 "--patch", "32", "--window-max", "20", "--device", "cpu", "--objective", "pairs",
                 "--accumulate", "charge"]) == 0
    net = UNet.load(out)
    assert net.meta["config"]["objective"] == "pairs" and net.meta["accumulate"] == "charge"
    assert main(["train", str(tmp_path / "s.npz"), "-o", str(tmp_path / "x.npz"), "--steps", "2", "--patch", "32",
                 "--device", "cpu", "--objective", "pairs"]) != 0  # window-max 200: 560 planes are too few
    assert "too short for pairs" in capsys.readouterr().err


def _count_network(shrink=False):
    net = UNet.random(UNetSpec(width=4, depth=3), seed=5)
    return Denoiser(UNet(net.spec, net.params, {"input_domain": "count"}), shrink=shrink, guard="off")


def test_shrinkage_is_on_by_default_and_follows_the_network():
    """Denoiser(...) = shrink_residual(I, D(I), W) after the network; shrink=False is the paper's D(I)."""
    from spikeref.denoise.shrinkage import shrink_residual

    plain = _count_network()
    shrunk = _count_network(shrink=True)
    assert Denoiser(plain.unet).shrink and not plain.shrink  # the default is on (used with guard="off")
    planes = (np.random.default_rng(7).integers(0, 51, (4, 12, 20)) / 50).astype(np.float32)
    d = plain(planes, window=50)
    np.testing.assert_array_equal(shrunk(planes, window=50), shrink_residual(planes, d, 50))
    assert not np.array_equal(shrunk(planes, window=50), d)
    with pytest.raises(TypeError, match="shrink must be True or False"):
        Denoiser(plain.unet, shrink="yes")


def test_count_domain_network_sees_counts_and_returns_rates():
    """A count-domain network denoises I·W and divides back: D(I; W) = f(I·W) / W."""
    den = _count_network()
    assert den.input_domain == "count"
    planes = (np.random.default_rng(4).integers(0, 11, (4, 12, 20)) / 10).astype(np.float32)
    as_rates = Denoiser(UNet(den.unet.spec, den.unet.params), guard="off")  # the same network, told nothing
    for mode in ("visible", "blind"):
        expect = as_rates(planes * np.float32(10), mode) / np.float32(10)
        np.testing.assert_allclose(den(planes, mode, window=10), expect, rtol=1e-6, atol=1e-7)
    # the exposure matters for this network (it would not for a rate network)
    assert not np.allclose(den(planes, window=10), den(planes, window=200))
    with pytest.raises(ValueError, match="pass window="):
        den(planes)
    with pytest.raises(ValueError, match="window must be a positive"):
        den(planes, window=0)


def test_an_exposure_channel_network_is_told_log10_of_the_window():
    """A network with an exposure channel (UNetSpec.in_channels = 2) runs on I·W with level log10(W), in every mode."""
    net = UNet.random(UNetSpec(width=8, depth=3, in_channels=2), seed=2)
    net.meta["input_domain"] = "count"
    den = Denoiser(net, guard="off", shrink=False)
    planes = (np.random.default_rng(5).integers(0, 21, (4, 12, 20)) / 20).astype(np.float32)
    np.testing.assert_allclose(den(planes, window=20), net(planes * np.float32(20), level=np.log10(20.0)) / 20,
                               rtol=1e-6, atol=1e-7)
    blind = den(planes, "blind", window=20)
    outs = net(masked_volume(planes[0] * np.float32(20)), level=np.log10(20.0))
    np.testing.assert_allclose(blind[0], mask_aware_average(outs, cell_masks(12, 20)) / 20, rtol=1e-5, atol=1e-6)
    with pytest.raises(ValueError, match="pass window="):
        den(planes)


def test_rate_domain_network_uses_the_window_only_to_shrink(small):
    planes = np.random.default_rng(6).random((4, 12, 20)).astype(np.float32)
    assert small.input_domain == "rate"
    plain = Denoiser(small.unet, shrink=False, guard="off")
    np.testing.assert_array_equal(plain(planes, window=10), plain(planes, window=200))
    np.testing.assert_array_equal(plain(planes, window=10), small(planes))  # no window: no shrinkage
    assert not np.array_equal(small(planes, window=10), small(planes, window=200))


def test_unknown_input_domain_is_refused():
    net = UNet.random(UNetSpec(width=4, depth=3), seed=5)
    with pytest.raises(ValueError, match="unknown input_domain"):
        Denoiser(UNet(net.spec, net.params, {"input_domain": "photons"}))


def test_bad_settings_are_refused_when_made():
    net = UNet.random(UNetSpec(width=4, depth=3), seed=5)
    for lam in (-1.0, float("nan"), True, "2"):
        with pytest.raises(ValueError, match="lam"):
            Denoiser(net, lam=lam)
    with pytest.raises(ValueError, match="cell must be"):
        Denoiser(net, cell=0)
    trained = UNet(net.spec, net.params, {"config": {"cell": 4}})
    assert Denoiser(trained, cell=(4, 4)).cell == (4, 4)
    with pytest.raises(ValueError, match="trained with"):
        Denoiser(trained, cell=2)
    stream = SpikeStream.from_array(np.zeros((40, 8, 8), np.uint8), cfa="RGGB")
    den = Denoiser(net)
    for kw, word in (({"count": 0}, "count"), ({"count": -2}, "count"), ({"start": -1}, "start")):
        with pytest.raises(ValueError, match=word):
            next(den.frames(stream, 10, **kw))
    assert [k for k, _ in den.frames(stream, 10, count=2)] == [0, 1]


def test_guard_is_the_default_and_is_the_sure_blend_of_the_network():
    """Denoiser(...) = sure_blend(I, network) by default; guard="off" is the network (then the shrinkage)."""
    from spikeref.denoise.guard import sure_blend

    net = _count_network()  # guard off, no shrinkage: the network alone
    guarded = Denoiser(net.unet)
    assert guarded.guard == "sure" and net.guard == "off"
    planes = (np.random.default_rng(8).integers(0, 11, (4, 16, 24)) / 10).astype(np.float32)
    expect, alpha = sure_blend(planes, lambda z: net(z, window=10))
    np.testing.assert_array_equal(guarded(planes, window=10), expect)
    assert 0 <= alpha.min() and alpha.max() <= 1 and not np.array_equal(expect, net(planes, window=10))
    np.testing.assert_array_equal(guarded(planes, window=10, guard="off"), guarded(planes, window=10, guard="off"))
    np.testing.assert_array_equal(Denoiser(net.unet, shrink=False)(planes, window=10, guard="off"),
                                  net(planes, window=10))
    with pytest.raises(ValueError, match="guard must be one of sure, off"):
        Denoiser(net.unet, guard="strong")
    with pytest.raises(ValueError, match="guard_radius must be an integer"):
        Denoiser(net.unet, guard_radius=-2)
