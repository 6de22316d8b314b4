"""The simulator: chunk and prefix independence, seeds, ground truth, recording to .dat."""

import json

import numpy as np
import pytest

from spikeref.stream import read_dat
from spikeref.simulate.recording import gt_exr_name, simulate_to_dat
from spikeref.simulate.simulator import BLOCK, Simulation, ground_truth, iter_simulation, readout_radiance, simulate
from tests.scene_doubles import Drifting, Flat, scene

ALL = {
    "threshold_fpn": {"sigma": 0.03},
    "random_phase": {},
    "hot_pixels": {"fraction": 0.01, "rate": 0.3},
    "shot_noise": {"photons_per_threshold": 20},
    "dark_current": {"gamma": 0.01},
    "inherent_noise": {"mu": 30, "sigma": 5},
}


@pytest.fixture
def moving():
    return scene(Drifting(16, 24, speed=0.3), planes=150, effects=ALL, substeps=2)


def test_chunks_and_prefixes_do_not_change_the_spikes(moving):
    whole = simulate(moving, seed=7).spikes
    for chunk in (1, BLOCK, 3 * BLOCK, 1000):
        parts = np.concatenate([c.spikes for c in iter_simulation(moving, 7, chunk_planes=chunk)])
        assert np.array_equal(parts, whole), chunk
    assert np.array_equal(simulate(moving, seed=7, planes=41).spikes, whole[:41])


def test_seeds(moving):
    a = simulate(moving, seed=7)
    assert a.seed == 7
    assert not np.array_equal(a.spikes, simulate(moving, seed=8).spikes)
    b = simulate(moving, seed=np.random.default_rng(1))
    assert np.array_equal(b.spikes, simulate(moving, seed=b.seed).spikes)  # the seed used reproduces it
    c = simulate(moving, seed=None)
    assert np.array_equal(c.spikes, simulate(moving, seed=c.seed).spikes)
    with pytest.raises(ValueError, match="seed"):
        simulate(moving, seed=-1)
    with pytest.raises(TypeError, match="seed"):
        simulate(moving, seed=1.5)


def test_effects_are_independent_streams(moving):
    """Dropping one effect leaves the others' draws unchanged: the FPN pattern stays the same."""
    without = {k: v for k, v in ALL.items() if k != "dark_current"}
    a = Simulation(moving, seed=3)
    b = Simulation(moving, seed=3, effects=without)
    assert np.array_equal(a.thresholds, b.thresholds) and np.array_equal(a.state, b.state)
    assert not np.array_equal(a.run(64).spikes, b.run(64).spikes)


def test_effects_override_and_none(moving):
    clean = simulate(moving, seed=1, effects={})
    assert clean.scene.effects == {}
    assert np.array_equal(clean.spikes, simulate(moving, seed=2, effects={}).spikes)
    with pytest.raises(ValueError, match="unknown effect"):
        simulate(moving, effects={"glare": {}})


def test_ground_truth_is_the_window_mean_in_rate_units():
    sc = scene(Drifting(8, 12, speed=0.5), planes=60, substeps=3, alpha=0.5, threshold=2.0)
    gt = ground_truth(sc, 20)
    assert gt.shape == (3, 8, 12, 3) and gt.dtype == np.float32
    # literal: every readout is the mean of 3 sub-step samples; the frame the mean of 20 readouts
    times = np.arange(20, 40)[:, None] + (np.arange(3) + 0.5)[None, :] / 3
    rgb = sc.content.radiance(times.ravel()).astype(np.float64).mean(axis=0)
    np.testing.assert_allclose(gt[1], rgb * 0.5 / 2.0, rtol=1e-6)
    # the same frames come with the chunks, and from the result
    streamed = np.concatenate([c.ground_truth for c in iter_simulation(sc, 0, gt_window=20, chunk_planes=16)])
    np.testing.assert_array_equal(streamed, gt)
    np.testing.assert_array_equal(simulate(sc).ground_truth(20), gt)
    np.testing.assert_array_equal(ground_truth(sc, 20, start=20)[0], gt[1])


def test_noise_free_rate_converges_to_ground_truth():
    """Eq. 4 on a noise-free static scene equals the ground truth to within 1/W (quantisation)."""
    sc = scene(Flat(8, 8, rgb=(0.31, 0.17, 0.05)), planes=2000)
    out = simulate(sc)
    rate = out.spikes.mean(axis=0)
    from spikeref.bayer import demosaic_bilinear

    gt = out.ground_truth(2000)[0]
    assert np.abs(demosaic_bilinear(rate) - gt).max() <= 1 / 2000 + 1e-6


def test_substeps_integrate_within_the_readout():
    content = Drifting(4, 6, speed=2.0)
    one = readout_radiance(content, 5, 1)
    four = readout_radiance(content, 5, 4)
    manual = content.radiance(5 + (np.arange(4) + 0.5) / 4).astype(np.float64).mean(axis=0)
    np.testing.assert_allclose(four, manual)
    assert not np.allclose(one, four)


def test_bad_radiance_is_an_error():
    with pytest.raises(ValueError, match="finite and non-negative"):
        simulate(scene(Flat(4, 4, rgb=(-0.1, 0, 0)), planes=4))
    with pytest.raises(ValueError, match="finite and non-negative"):
        simulate(scene(Flat(4, 4, rgb=(np.inf, 0, 0)), planes=4))
    with pytest.raises(ValueError, match="even"):
        simulate(scene(Flat(5, 4), planes=4))
    with pytest.raises(ValueError, match="planes"):
        simulate(scene(Flat(4, 4), planes=4), planes=0)
    with pytest.raises(TypeError, match="Scene"):
        simulate(object())


def test_recording_to_dat(tmp_path, moving):
    out = tmp_path / "run.dat"
    meta = simulate_to_dat(moving, out, seed=5, gt_path=tmp_path / "gt.npz", gt_window=10,
                           gt_exr_dir=tmp_path / "gt", chunk_planes=16)
    stream = read_dat(out, 16, 24)
    ref = simulate(moving, seed=5)
    assert np.array_equal(stream.window(0, len(stream)), ref.spikes)
    side = json.loads((tmp_path / "run.json").read_text())
    assert side == meta and side["height"] == 16 and side["cfa"] == "RGGB" and side["seed"] == 5
    assert side["effects"]["dark_current"] == {"gamma": 0.01}
    with np.load(tmp_path / "gt.npz") as gt:
        np.testing.assert_array_equal(gt["gt"], ref.ground_truth(10))
        assert int(gt["window"]) == 10 and float(gt["fps"]) == 2000.0
    from spikeref.io.exr import read_exr

    np.testing.assert_array_equal(read_exr(tmp_path / "gt" / gt_exr_name(14)), ref.ground_truth(10)[14])
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []  # no temporary left


def test_failed_recording_leaves_nothing(tmp_path):
    bad = scene(Flat(4, 4, rgb=(0.1, 0.1, np.nan)), planes=40)
    with pytest.raises(ValueError):
        simulate_to_dat(bad, tmp_path / "x.dat", gt_path=tmp_path / "x_gt.npz")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match=".dat"):
        simulate_to_dat(scene(Flat(4, 4)), tmp_path / "x.bin")


def test_recording_memory_does_not_grow_with_planes(tmp_path):
    """Peak traced memory of a chunked recording is the same for 4× the planes (spikes and ground truth)."""
    import tracemalloc

    sc = scene(Drifting(32, 32, speed=0.2), planes=8, effects=ALL)

    def peak(planes):
        tracemalloc.start()
        simulate_to_dat(sc, tmp_path / "m.dat", planes=planes, gt_path=tmp_path / "m.npz", gt_window=10,
                        chunk_planes=32)
        _, top = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        return top

    peak(64)  # warm-up: compiled kernels, caches
    small, large = peak(400), peak(1600)
    assert large <= 1.1 * small + 65536, (small, large)
    assert (tmp_path / "m.dat").stat().st_size == 1600 * 32 * 32 // 8


def test_embedded_sample_is_what_its_script_makes():
    """spikeref/data/sample.dat is the simulation of sample.toml with the script's seed, bit for bit."""
    import importlib.util

    from spikeref.sample import SAMPLE_DAT, load_sample, sample_ground_truth, sample_scene

    spec = importlib.util.spec_from_file_location("make_sample", SAMPLE_DAT.parents[2] / "scripts" / "make_sample.py")
    if spec is None or not spec.loader or not (SAMPLE_DAT.parents[2] / "scripts" / "make_sample.py").is_file():
        pytest.skip("scripts/ not present (installed package)")
    make_sample = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_sample)
    stream = load_sample()
    scene = sample_scene()
    assert (len(stream), stream.height, stream.width, stream.cfa) == (264, 224, 256, "RGGB")
    assert SAMPLE_DAT.stat().st_size < 2_000_000
    # W = 10, K = 3, L = 3 need ((K - 1) L + 1) W = 70 planes of support: 20 output frames
    assert (len(stream) - 70) // 10 + 1 >= 20
    fresh = simulate(scene, seed=make_sample.SEED)
    assert np.array_equal(stream.window(0, len(stream)), fresh.spikes)
    gt = sample_ground_truth(10)
    assert gt.shape == (26, 224, 256, 3) and np.isfinite(gt).all()
