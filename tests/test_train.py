"""Training (spikeref.denoise.train, extra 'train'): data from unlabeled streams, Eq. 10-12 in torch, resume."""

import sys

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from spikeref.denoise import train as tr  # noqa: E402
from spikeref.denoise.blindspot import mask_aware_average, masked_volume  # noqa: E402
from spikeref.denoise.unet import UNet  # noqa: E402
from spikeref.io.dat import write_dat  # noqa: E402
from spikeref.stream import SpikeStream, read_dat  # noqa: E402


def _spikes(shape=(40, 70, 84), p=0.3, seed=0):
    return (np.random.default_rng(seed).random(shape) < p).astype(np.uint8)


def test_masked_volume_in_torch_equals_the_numpy_one():
    x = torch.rand(3, 1, 13, 22, dtype=torch.float64)
    volume, masks = tr.masked_volume_torch(x)
    np.testing.assert_allclose(volume[:, :, 0].numpy(), masked_volume(x.numpy()[:, 0]), rtol=1e-12)
    assert volume.shape == (16, 3, 1, 13, 22) and masks.shape == (16, 13, 22)


def test_blind_output_is_the_mask_aware_average_and_visible_has_no_gradient():
    def model(t):  # any per-pixel function of the masked images
        return t * 2.0 + t.mean(dim=(-1, -2), keepdim=True)

    x = torch.rand(2, 1, 8, 12, dtype=torch.float64, requires_grad=True)
    blind, visible = tr.blind_and_visible(model, x)
    outs = model(tr.masked_volume_torch(x.detach())[0].reshape(32, 1, 8, 12)).reshape(16, 2, 1, 8, 12)
    from spikeref.denoise.blindspot import cell_masks

    expected = mask_aware_average(outs.detach().numpy()[:, :, 0], cell_masks(8, 12))
    np.testing.assert_allclose(blind.detach().numpy()[:, 0], expected, rtol=1e-12)
    assert blind.requires_grad and not visible.requires_grad


def test_blind_output_from_a_subset_of_masks_is_the_full_one_where_known():
    def model(t):  # a per-image function of the whole masked image: a hidden pixel sees the fill
        return t * 2.0 + t.mean(dim=(-1, -2), keepdim=True)

    x = torch.rand(3, 1, 8, 12, dtype=torch.float64)
    full, visible = tr.blind_and_visible(model, x)
    # every mask drawn, in another order per image: the paper's D(I) everywhere
    order = torch.stack([torch.randperm(16, generator=torch.Generator().manual_seed(i)) for i in range(3)], 1)
    blind, vis, known = tr.blind_subset_and_visible(model, x, order)
    np.testing.assert_allclose(blind.numpy(), full.numpy(), rtol=1e-12)
    np.testing.assert_array_equal(vis.numpy(), visible.numpy())
    assert bool((known == 1).all())
    # two masks per image: D(I) on their hidden pixels (an eighth of the image), 0 elsewhere
    from spikeref.denoise.blindspot import cell_masks

    subset = torch.tensor([[0, 5, 15], [3, 9, 1]])
    blind, _, known = tr.blind_subset_and_visible(model, x, subset)
    masks = cell_masks(8, 12)
    for n in range(3):
        hidden = masks[int(subset[0, n])] | masks[int(subset[1, n])]
        np.testing.assert_array_equal(known[n, 0].numpy(), hidden.astype(float))
        np.testing.assert_allclose(blind[n, 0].numpy()[hidden], full[n, 0].numpy()[hidden], rtol=1e-12)
        assert not blind[n, 0].numpy()[~hidden].any()
    assert known.sum() == 3 * 2 * 8 * 12 / 16


def test_the_masked_pixel_loss_is_the_paper_loss_when_every_pixel_is_known():
    from spikeref.denoise.revisible import revisible_loss_torch

    g = torch.Generator().manual_seed(0)
    d, f, i = (torch.rand(2, 1, 6, 7, generator=g, dtype=torch.float64) for _ in range(3))
    plain = revisible_loss_torch(d, f, i, 5.0, 1.0)
    assert float(revisible_loss_torch(d, f, i, 5.0, 1.0, weight=torch.ones_like(d))) == pytest.approx(float(plain))
    w = (torch.rand(2, 1, 6, 7, generator=g) < 0.3).double()
    sel = w.bool()
    expected = ((d + 5 * f - 6 * i)[sel] ** 2).mean() + ((d - i)[sel] ** 2).mean()
    assert float(revisible_loss_torch(d, f, i, 5.0, 1.0, weight=w)) == pytest.approx(float(expected))


def test_cpu_recipe_trains_resumes_and_is_recorded(tmp_path):
    streams = [SpikeStream.from_array(_spikes((200, 64, 64), p=0.2, seed=3))]
    cfg = tr.TrainConfig(width=8, depth=2, steps=40, batch=4, patch=16, lr=3e-3, lam_start=2.0, lam_end=2.0,
                         masks_per_step=1, checkpoint_every=10)
    summary = tr.train(streams, tmp_path / "w.npz", cfg, device="cpu", progress=False)
    assert np.mean(summary["losses"][-8:]) < 0.5 * np.mean(summary["losses"][:4])
    net = UNet.load(tmp_path / "w.npz")
    assert net.meta["config"]["masks_per_step"] == 1 and "1 of 16 masks" in net.meta["method"]
    tr.train(streams, tmp_path / "r.npz", cfg, device="cpu", progress=False, stop_after=17)
    tr.train(streams, tmp_path / "r.npz", cfg, device="cpu", progress=False, resume=True)
    again = UNet.load(tmp_path / "r.npz")
    for key in net.params:
        np.testing.assert_array_equal(net.params[key], again.params[key], err_msg=key)
    with pytest.raises(ValueError, match="masks_per_step"):
        tr.TrainConfig(masks_per_step=17)
    with pytest.raises(ValueError, match="masks_per_step"):
        tr.TrainConfig(masks_per_step=0)


@pytest.mark.parametrize("file_width, col_offset", [(84, 0), (96, 8), (92, 3)])
def test_packed_crops_count_like_the_array(tmp_path, file_width, col_offset):
    arr = _spikes()
    wide = np.zeros((arr.shape[0], arr.shape[1], file_width), np.uint8)
    wide[:, :, col_offset : col_offset + 84] = arr
    write_dat(tmp_path / "s.dat", wide)
    packed = read_dat(tmp_path / "s.dat", 70, 84, file_width=file_width, col_offset=col_offset)
    sampler = tr.CropSampler([packed], 16, 5, 10)
    for t, w, y0, x0 in [(0, 5, 0, 0), (3, 7, 2, 4), (30, 10, 38, 52), (1, 1, 38, 50)]:
        got = sampler._counts(packed, t, w, y0, x0).numpy()
        np.testing.assert_array_equal(got, arr[t : t + w, y0 : y0 + 32, x0 : x0 + 32].sum(0))


def test_samples_are_rates_of_whole_windows_within_the_range():
    sampler = tr.CropSampler([SpikeStream.from_array(_spikes())], 16, 5, 9)
    rng = np.random.default_rng(1)
    x = sampler.sample(rng, 6)
    assert x.shape == (24, 1, 16, 16) and x.dtype == torch.float32
    assert float(x.min()) >= 0 and float(x.max()) <= 1
    windows = [sampler._window(rng, sampler.streams[0]) for _ in range(300)]
    assert min(windows) == 5 and max(windows) == 9  # log-uniform over [5, 9] reaches both ends
    for img in x[:, 0].numpy():  # every value is count / W for one W in 5..9
        assert any(np.allclose(img * w, np.round(img * w), atol=1e-5) for w in range(5, 10))


def test_count_samples_are_whole_counts_with_their_windows():
    stream = SpikeStream.from_array(_spikes())
    rates = tr.CropSampler([stream], 16, 5, 9).sample(np.random.default_rng(1), 3)
    counts, windows = tr.CropSampler([stream], 16, 5, 9, domain="count").sample(
        np.random.default_rng(1), 3, with_windows=True)  # same draws, counts instead of rates
    assert windows.shape == (12,) and set(windows.tolist()) <= set(range(5, 10))
    np.testing.assert_array_equal(counts, torch.round(counts))
    np.testing.assert_allclose(counts, rates * windows[:, None, None, None], rtol=1e-6)
    assert (counts.amax((1, 2, 3)) <= windows).all()
    with pytest.raises(ValueError, match="domain must be one of"):
        tr.CropSampler([stream], 16, 5, 9, domain="photons")
    with pytest.raises(ValueError, match="input_domain must be one of"):
        tr.TrainConfig(input_domain="photons")


def test_streams_too_small_are_refused():
    small = SpikeStream.from_array(_spikes((10, 20, 20)))
    with pytest.raises(ValueError, match="smaller than the training crop"):
        tr.CropSampler([small], 16, 5, 10)
    with pytest.raises(ValueError, match="no training streams"):
        tr.CropSampler([], 16, 5, 10)
    with pytest.raises(ValueError, match="multiple of 2\\*\\*depth"):
        tr.TrainConfig(patch=20)


def _tiny_config(**kw):
    return tr.TrainConfig(width=4, depth=2, steps=6, batch=1, patch=16, checkpoint_every=3, **kw)


def test_interrupted_training_resumes_to_the_same_weights(tmp_path, monkeypatch):
    streams = [SpikeStream.from_array(_spikes())]
    cfg = _tiny_config()
    tr.train(streams, tmp_path / "whole.npz", cfg, device="cpu", progress=False)

    calls = {"n": 0}
    original = tr.CropSampler.sample

    def failing(self, rng, batch, **kw):
        calls["n"] += 1
        if calls["n"] == 5:  # after the checkpoint at step 3, during step 5
            raise KeyboardInterrupt
        return original(self, rng, batch, **kw)

    monkeypatch.setattr(tr.CropSampler, "sample", failing)
    with pytest.raises(KeyboardInterrupt):
        tr.train(streams, tmp_path / "resumed.npz", cfg, device="cpu", progress=False)
    assert (tmp_path / "resumed.npz.ckpt").is_file() and not (tmp_path / "resumed.npz").exists()
    monkeypatch.setattr(tr.CropSampler, "sample", original)
    summary = tr.train(streams, tmp_path / "resumed.npz", cfg, resume=True, device="cpu", progress=False)
    assert summary["steps"] == 6
    a, b = UNet.load(tmp_path / "whole.npz"), UNet.load(tmp_path / "resumed.npz")
    for key in a.params:
        np.testing.assert_array_equal(a.params[key], b.params[key], err_msg=key)
    with pytest.raises(ValueError, match="another configuration"):
        tr.train(streams, tmp_path / "resumed.npz", _tiny_config(lr=3e-3), resume=True, device="cpu",
                 progress=False)


def test_training_lowers_the_loss_and_writes_numpy_weights(tmp_path):
    # A noisy flat field: the loss at the end of a short run must be below its start.
    streams = [SpikeStream.from_array(_spikes((200, 64, 64), p=0.2, seed=3))]
    cfg = tr.TrainConfig(width=8, depth=2, steps=60, batch=2, patch=32, lr=3e-3, lam_start=2.0, lam_end=2.0,
                         checkpoint_every=100)
    summary = tr.train(streams, tmp_path / "w.npz", cfg, device="cpu", progress=False)
    losses = summary["losses"]
    assert np.mean(losses[-10:]) < 0.5 * np.mean(losses[:5])
    net = UNet.load(tmp_path / "w.npz")
    assert net.spec.width == 8 and net.meta["config"]["steps"] == 60
    assert net.meta["final_loss"] == pytest.approx(summary["final_loss"])


def test_stop_after_exports_part_of_the_schedule_and_resumes(tmp_path):
    streams = [SpikeStream.from_array(_spikes())]
    cfg = _tiny_config()
    tr.train(streams, tmp_path / "whole.npz", cfg, device="cpu", progress=False)
    part = tr.train(streams, tmp_path / "part.npz", cfg, device="cpu", progress=False, stop_after=3)
    assert part["steps"] == 3 and UNet.load(tmp_path / "part.npz").meta["steps_run"] == 3
    # the same checkpoint continued to the end equals the uninterrupted run (same schedule)
    tr.train(streams, tmp_path / "part.npz", cfg, resume=True, device="cpu", progress=False)
    a, b = UNet.load(tmp_path / "whole.npz"), UNet.load(tmp_path / "part.npz")
    for key in a.params:
        np.testing.assert_array_equal(a.params[key], b.params[key], err_msg=key)
    with pytest.raises(ValueError, match="past stop_after"):
        tr.train(streams, tmp_path / "part.npz", cfg, resume=True, device="cpu", progress=False, stop_after=2)



def test_training_reads_no_ground_truth(tmp_path, monkeypatch):
    # `spikeref train` on an .npz that also carries a ground-truth array and on the embedded sample
    # .dat (whose scene file would give its ground truth): only the spikes are read, and nothing that
    # computes a ground truth or a scene's radiance is called.
    import shutil

    import spikeref.sample
    import spikeref.simulate.simulator as sim
    from spikeref.cli import main

    def forbidden(*args, **kwargs):
        raise AssertionError("training asked for a ground truth")

    for owner, name in ((sim, "ground_truth"), (sim.SimulationResult, "ground_truth"), (sim, "readout_radiance"),
                        (spikeref.sample, "sample_ground_truth"), (spikeref.sample, "sample_scene")):
        original = getattr(owner, name)
        # every module that imported the function by name holds it too
        for module in [m for n, m in sys.modules.items() if n.startswith("spikeref") and m is not None]:
            if any(getattr(module, attr, None) is original for attr in (name,)):
                monkeypatch.setattr(module, name, forbidden)
        monkeypatch.setattr(owner, name, forbidden)
    read_keys = []
    original_getitem = np.lib.npyio.NpzFile.__getitem__

    def recording_getitem(self, key):
        read_keys.append(key)
        return original_getitem(self, key)

    monkeypatch.setattr(np.lib.npyio.NpzFile, "__getitem__", recording_getitem)
    npz = tmp_path / "labelled.npz"
    np.savez(npz, spikes=_spikes((40, 64, 64)), ground_truth=np.full((4, 64, 64, 3), np.nan))
    shutil.copy(spikeref.sample.SAMPLE_DAT, tmp_path / "sample.dat")
    shutil.copy(spikeref.sample.SAMPLE_DAT.with_suffix(".json"), tmp_path / "sample.json")
    code = main(["train", str(npz), str(tmp_path / "sample.dat"), "-o", str(tmp_path / "w.npz"), "--channels", "4",
                 "--steps", "2", "--batch", "1", "--patch", "32", "--checkpoint-every", "10", "--device", "cpu"])
    assert code == 0 and (tmp_path / "w.npz").is_file()
    assert set(read_keys) == {"spikes"}


def test_charge_crops_are_the_window_charge_of_the_crop():
    """accumulate="charge": a crop's image is spikeref.charge.window_charge of the crop's planes, from an
    in-memory and from a packed stream alike; the count crops are the spike counts."""
    from spikeref.charge import window_charge
    from spikeref.io.dat import pack_planes

    spikes = (np.random.default_rng(3).random((500, 72, 96)) < 0.2).astype(np.uint8)
    want = window_charge(spikes[:, 4:36, 6:38], 10, start=250, count=1)[0]
    for stream in (SpikeStream.from_array(spikes), SpikeStream.from_packed(pack_planes(spikes), 72, 96)):
        got = tr.CropSampler([stream], 16, 5, 200, accumulate="charge")._counts(stream, 250, 10, 4, 6)
        np.testing.assert_array_equal(got.numpy(), want)
        counts = tr.CropSampler([stream], 16, 5, 200)._counts(stream, 250, 10, 4, 6)
        np.testing.assert_array_equal(counts.numpy(), spikes[250:260, 4:36, 6:38].sum(0))


def _static_stream(planes=700, shape=(72, 96), seed=5):
    """Each pixel fires every p planes (p = 2..9 by pixel, random phase): a scene that does not move."""
    rng = np.random.default_rng(seed)
    period = rng.integers(2, 10, shape)
    phase = rng.integers(0, 9, shape)
    t = np.arange(planes)[:, None, None]
    return ((t + phase) % period == 0).astype(np.uint8)


def test_pair_targets_count_every_plane_the_input_did_not_read():
    from spikeref.charge import DEFAULT_MARGIN as M
    from spikeref.io.dat import pack_planes

    spikes = _spikes((700, 72, 96), p=0.25, seed=8)
    for stream in (SpikeStream.from_array(spikes), SpikeStream.from_packed(pack_planes(spikes), 72, 96)):
        sampler = tr.CropSampler([stream], 16, 5, 20, pairs=True)
        for t, w, y0, x0 in [(0, 5, 0, 0), (250, 10, 4, 6), (690, 10, 40, 64), (199, 20, 2, 2)]:
            outside = np.ones(700, bool)
            outside[max(0, t - M) : t + w + M] = False  # the window and the margins its charge reads
            want = spikes[outside, y0 : y0 + 32, x0 : x0 + 32].sum(0) * (w / outside.sum())
            np.testing.assert_allclose(sampler._target(0, t, w, y0, x0).numpy(), want, rtol=1e-6)


def test_pairs_are_augmented_together_and_refused_where_they_cannot_be_made():
    stream = SpikeStream.from_array(_static_stream())
    sampler = tr.CropSampler([stream], 16, 5, 20, domain="count", pairs=True)
    x, target, windows = sampler.sample_pairs(np.random.default_rng(2), 6)
    assert x.shape == target.shape == (24, 1, 16, 16) and windows.shape == (24,)
    # a count over W planes of a pixel firing every p planes is W/p ± 1 spike; so is the target, which
    # counts hundreds of planes — unless input and target were turned or flipped differently
    assert float((x - target).abs().max()) <= 1.0 + 1e-5
    assert float((x - target.flip(-1)).abs().max()) > 2
    with pytest.raises(ValueError, match="pairs=True"):
        tr.CropSampler([stream], 16, 5, 20).sample_pairs(np.random.default_rng(0), 1)
    with pytest.raises(ValueError, match="too short for pairs"):
        tr.CropSampler([SpikeStream.from_array(_static_stream(planes=500))], 16, 5, 20, pairs=True)
    with pytest.raises(ValueError, match="objective must be one of"):
        tr.TrainConfig(objective="noise2void")


def test_pairs_training_lowers_the_loss_resumes_and_is_recorded(tmp_path):
    streams = [SpikeStream.from_array(_static_stream(seed=6))]
    cfg = tr.TrainConfig(width=8, depth=2, steps=30, batch=4, patch=16, lr=3e-3, window_min=5, window_max=20,
                         objective="pairs", checkpoint_every=10)
    summary = tr.train(streams, tmp_path / "w.npz", cfg, device="cpu", progress=False)
    assert np.mean(summary["losses"][-6:]) < 0.5 * np.mean(summary["losses"][:3])
    net = UNet.load(tmp_path / "w.npz")
    assert net.meta["config"]["objective"] == "pairs" and "Noise2Noise" in net.meta["method"]
    tr.train(streams, tmp_path / "r.npz", cfg, device="cpu", progress=False, stop_after=13)
    tr.train(streams, tmp_path / "r.npz", cfg, device="cpu", progress=False, resume=True)
    again = UNet.load(tmp_path / "r.npz")
    for key in net.params:
        np.testing.assert_array_equal(net.params[key], again.params[key], err_msg=key)


def test_a_pair_is_the_target_of_its_own_window():
    """sample_pairs hands _target the very window, crop and stream its input came from."""
    stream = SpikeStream.from_array(_static_stream(seed=9))
    sampler = tr.CropSampler([stream], 16, 5, 20, domain="count", pairs=True)
    seen, counts, targets = [], sampler._counts, sampler._target
    sampler._counts = lambda s, t, w, y0, x0: seen.append(("input", t, w, y0, x0)) or counts(s, t, w, y0, x0)
    sampler._target = lambda i, t, w, y0, x0, *a: seen.append(("target", t, w, y0, x0)) or targets(i, t, w, y0, x0, *a)
    sampler.sample_pairs(np.random.default_rng(3), 5)
    assert len(seen) == 10
    for got_input, got_target in zip(seen[::2], seen[1::2], strict=True):
        assert got_input[0] == "input" and got_target[0] == "target" and got_input[1:] == got_target[1:]
    assert len({s[1] for s in seen}) > 1  # several windows were drawn


def test_pairs_in_the_rate_domain_are_rates():
    stream = SpikeStream.from_array(_static_stream(seed=10))
    counts, ct, w = tr.CropSampler([stream], 16, 5, 20, domain="count", pairs=True).sample_pairs(
        np.random.default_rng(4), 3)
    rates, rt, _ = tr.CropSampler([stream], 16, 5, 20, domain="rate", pairs=True).sample_pairs(
        np.random.default_rng(4), 3)
    np.testing.assert_allclose(rates * w[:, None, None, None], counts, rtol=1e-6)
    np.testing.assert_allclose(rt * w[:, None, None, None], ct, rtol=1e-6)


def test_a_checkpoint_written_before_the_objective_resumes_as_b2u(tmp_path):
    """Checkpoints whose configuration has no "objective" (written before it existed) resume as b2u."""
    streams = [SpikeStream.from_array(_spikes())]
    cfg = _tiny_config()
    tr.train(streams, tmp_path / "w.npz", cfg, device="cpu", progress=False, stop_after=3)
    ckpt = tmp_path / "w.npz.ckpt"
    state = torch.load(ckpt, weights_only=False)
    del state["config"]["objective"]
    torch.save(state, ckpt)
    tr.train(streams, tmp_path / "w.npz", cfg, device="cpu", progress=False, resume=True)
    assert UNet.load(tmp_path / "w.npz").meta["steps_run"] == cfg.steps
    with pytest.raises(ValueError, match="another configuration"):
        tr.train([SpikeStream.from_array(_static_stream())], tmp_path / "w.npz", _tiny_config(objective="pairs"),
                 device="cpu", progress=False, resume=True)  # a pairs run does not take over a b2u checkpoint


@pytest.mark.parametrize("file_width, col_offset", [(96, 0), (92, 3)])
def test_crops_of_a_dat_stored_top_down_are_upright(tmp_path, file_width, col_offset):
    """rows="top-down": the packed crops (counts, charges, pair targets) are those of the upright array, as for
    the bottom-up default; read with the wrong order they are the crops of the flipped image."""
    from spikeref.charge import window_charge

    arr = _spikes((700, 72, 84), p=0.2, seed=4)
    wide = np.zeros((arr.shape[0], arr.shape[1], file_width), np.uint8)
    wide[:, :, col_offset : col_offset + 84] = arr
    write_dat(tmp_path / "td.dat", wide, rows="top-down")
    packed = read_dat(tmp_path / "td.dat", 72, 84, file_width=file_width, col_offset=col_offset, rows="top-down")
    for t, w, y0, x0 in [(0, 5, 0, 0), (250, 10, 4, 6), (690, 10, 40, 52), (1, 1, 39, 50)]:
        counts = tr.CropSampler([packed], 16, 5, 10)._counts(packed, t, w, y0, x0).numpy()
        np.testing.assert_array_equal(counts, arr[t : t + w, y0 : y0 + 32, x0 : x0 + 32].sum(0))
    want = window_charge(arr[:, 4:36, 6:38], 10, start=250, count=1)[0]
    got = tr.CropSampler([packed], 16, 5, 200, accumulate="charge")._counts(packed, 250, 10, 4, 6).numpy()
    np.testing.assert_array_equal(got, want)
    in_memory = tr.CropSampler([SpikeStream.from_array(arr)], 16, 5, 20, pairs=True)
    np.testing.assert_allclose(tr.CropSampler([packed], 16, 5, 20, pairs=True)._target(0, 100, 10, 8, 12).numpy(),
                               in_memory._target(0, 100, 10, 8, 12).numpy(), rtol=1e-6)
    wrong = read_dat(tmp_path / "td.dat", 72, 84, file_width=file_width, col_offset=col_offset)  # bottom-up
    counts = tr.CropSampler([wrong], 16, 5, 10)._counts(wrong, 0, 5, 0, 0).numpy()
    np.testing.assert_array_equal(counts, arr[0:5, ::-1][:, 0:32, 0:32].sum(0))


def test_the_training_script_refuses_a_missing_gpu_in_one_line(tmp_path):
    """``scripts/train_denoiser.py --device cuda`` (issue: a GPU run when one is lent) on a machine without CUDA:
    an argparse error naming the device, before any data is simulated."""
    import subprocess
    from pathlib import Path

    if torch.cuda.is_available():
        pytest.skip("a CUDA device is here: the refusal is for machines without one")
    script = Path(__file__).resolve().parents[1] / "scripts" / "train_denoiser.py"
    run = subprocess.run([sys.executable, str(script), "--device", "cuda", "--steps", "1", "--data-dir",
                          str(tmp_path / "data"), "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert run.returncode == 2 and "--device cuda: PyTorch sees no CUDA device" in run.stderr
    assert not (tmp_path / "data").exists()
    run = subprocess.run([sys.executable, str(script), "--minutes", "0", "--steps", "1", "--data-dir",
                          str(tmp_path / "data"), "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert run.returncode == 2 and "--minutes must be a positive number" in run.stderr


def test_an_exposure_channel_run_trains_and_exports_a_two_channel_network(tmp_path):
    """TrainConfig(exposure_channel=True): every image (and each masked copy of it) is given log10 of its
    window as a second channel, and the exported NumPy network equals the torch one on that input."""
    model = torch.nn.Conv2d(2, 1, 1, bias=False)
    with torch.no_grad():
        model.weight[:] = torch.tensor([0.0, 1.0]).reshape(1, 2, 1, 1)  # reads the level only
    levels = torch.tensor([0.5, 2.0])
    out = tr.WithExposure(model, levels)(torch.zeros((6, 1, 4, 4)))  # three masked copies of two images
    np.testing.assert_allclose(out[:, 0, 0, 0].detach().numpy(), [0.5, 2.0] * 3)
    streams = [SpikeStream.from_array(_static_stream(seed=6))]
    cfg = tr.TrainConfig(width=8, depth=2, steps=12, batch=2, patch=16, lr=3e-3, window_min=5, window_max=20,
                         objective="pairs", checkpoint_every=6, exposure_channel=True)
    assert cfg.spec.in_channels == 2
    tr.train(streams, tmp_path / "w.npz", cfg, device="cpu", progress=False)
    net = UNet.load(tmp_path / "w.npz")
    assert net.spec.in_channels == 2 and net.meta["exposure_channel"] == "log10(window)"
    x = np.random.default_rng(1).random((3, 16, 16)).astype(np.float32) * 10
    from spikeref.denoise.torch_unet import TorchUNet

    twin = TorchUNet(net.spec)
    twin.load_state_dict(torch.load(tmp_path / "w.npz.ckpt", weights_only=False)["model"])
    t = torch.from_numpy(x)[:, None]
    want = twin(torch.cat([t, torch.full_like(t, np.log10(30.0))], 1)).detach().numpy()[:, 0]
    np.testing.assert_allclose(net(x, level=np.log10(30.0)), want, atol=2e-5)
    blind = tr.TrainConfig(width=8, depth=2, steps=4, batch=2, patch=16, window_min=5, window_max=20,
                           exposure_channel=True, checkpoint_every=4)
    tr.train([SpikeStream.from_array(_spikes())], tmp_path / "b.npz", blind, device="cpu", progress=False)
    assert UNet.load(tmp_path / "b.npz").spec.in_channels == 2  # the blind-spot loss runs with it too
    with pytest.raises(TypeError, match="exposure_channel"):
        tr.TrainConfig(exposure_channel=1)
