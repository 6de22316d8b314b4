"""spikeref.dark_level: the dark level of a dark recording (Eq. 9's E[N]/W), measured and subtracted."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.dark_level import (calibrate_dark, check_dark_level, colour_levels, dark_level_oracle, load_dark_level,
                                 measure_dark_level, subtract_dark_level)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31), t=st.integers(1, 12), h=st.integers(1, 4), w=st.integers(1, 4),
       p=st.floats(0.0, 0.5), hot_share=st.floats(0.0, 1.0))
def test_measure_agrees_with_the_oracle(seed, t, h, w, p, hot_share):
    rng = np.random.default_rng(seed)
    spikes = (rng.random((t, 2 * h, 2 * w)) < p).astype(np.uint8)
    hot = rng.random((2 * h, 2 * w)) < hot_share
    np.testing.assert_allclose(measure_dark_level(spikes, planes=t, hot=hot), dark_level_oracle(spikes, hot),
                               rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(measure_dark_level(spikes, planes=t), dark_level_oracle(spikes), rtol=1e-12)


def test_each_phase_has_its_own_level_and_hot_pixels_are_left_out():
    rng = np.random.default_rng(3)
    rates = np.array([[0.01, 0.02], [0.03, 0.04]])
    p = np.tile(rates, (8, 8))
    p[5, 7] = 0.9  # a hot pixel of phase (1, 1)
    spikes = (rng.random((4000, 16, 16)) < p).astype(np.uint8)
    hot = np.zeros((16, 16), bool)
    hot[5, 7] = True
    level = measure_dark_level(spikes, hot=hot)
    # each phase: 64 pixels (63 for (1,1)) × 4000 readouts; the binomial standard error is ≤ 0.0004
    np.testing.assert_allclose(level, rates.ravel(), atol=0.0015)
    assert measure_dark_level(spikes)[3] > level[3] + 0.01  # left in, the hot pixel lifts its phase


def test_planes_and_start_choose_the_stretch():
    spikes = np.zeros((20, 4, 4), np.uint8)
    spikes[10:] = 1
    np.testing.assert_array_equal(measure_dark_level(spikes, planes=10), 0.0)
    np.testing.assert_array_equal(measure_dark_level(spikes, start=10), 1.0)
    np.testing.assert_array_equal(measure_dark_level(spikes, planes=100), 0.5)  # at most: the stream is shorter


def test_a_simulated_dark_recording_gives_the_dark_current():
    """Eq. 6 with the simulator's α = E_th = 1: E[N_d]/W = γ spikes per readout; Eq. 8's C_i adds
    ``fraction / mu`` (pixels with inherent noise, one spike per mean interval)."""
    from spikeref.simulate.scenes import Scene
    from spikeref.simulate.patterns import Uniform
    from spikeref.simulate.camera import Camera
    from spikeref.simulate.simulator import dark_scene, simulate

    scene = Scene("lit", Uniform(height=32, width=32, brightness=0.3), planes=10,
                  camera=Camera(cfa="RGGB"),
                  effects={"dark_current": {"gamma": 0.01}, "inherent_noise": {"mu": 500.0, "sigma": 50.0,
                                                                                "fraction": 0.2}})
    dark = simulate(dark_scene(scene), seed=5, planes=4000, take=1).stream
    found = calibrate_dark(dark, planes=4000)
    expected = 0.01 + 0.2 / 500.0
    # 256 pixels × 4000 readouts per phase at ≈ 0.0104: ≈ 10 600 spikes, a standard error of 1 %
    np.testing.assert_allclose(found["dark_level"], expected, rtol=0.05)
    assert found["planes"] == 4000 and not found["hot"].any()


def test_dark_scene_keeps_the_sensor_and_take_changes_only_the_noise():
    from spikeref.simulate.scenes import Scene
    from spikeref.simulate.patterns import Uniform
    from spikeref.simulate.camera import Camera
    from spikeref.simulate.simulator import Simulation, dark_scene, simulate

    scene = Scene("lit", Uniform(height=16, width=16, brightness=0.3), planes=200, camera=Camera(cfa="RGGB"),
                  effects={"threshold_fpn": {"sigma": 0.05}, "dark_current": {"gamma": 0.02},
                           "hot_pixels": {"fraction": 0.02, "rate": 0.5}})
    dark = dark_scene(scene)
    assert dark.content.height == 16 and dark.content.brightness == 0.0 and dark.effects == scene.effects
    a, b = Simulation(dark, seed=4), Simulation(dark, seed=4, take=1)
    np.testing.assert_array_equal(a.thresholds, b.thresholds)  # the same sensor
    np.testing.assert_array_equal(a.hot, b.hot)
    s0 = simulate(dark, seed=4, planes=400).spikes
    s1 = simulate(dark, seed=4, planes=400, take=1).spikes
    assert not np.array_equal(s0, s1)  # other dark photons
    np.testing.assert_array_equal(s0, simulate(dark, seed=4, planes=400, take=0).spikes)
    with pytest.raises(ValueError, match="take must be an integer ≥ 0"):
        Simulation(dark, seed=4, take=-1)


def test_subtract_per_colour_and_per_phase_clipped_at_zero():
    level = [0.1, 0.2, 0.3, 0.4]  # RGGB: R 0.1, G (0.2 + 0.3)/2, B 0.4
    np.testing.assert_allclose(colour_levels(level, "RGGB"), [0.1, 0.25, 0.4])
    np.testing.assert_allclose(colour_levels(level, "BGGR"), [0.4, 0.25, 0.1])
    rgb = np.full((2, 4, 3), 0.3, np.float32)
    out = subtract_dark_level(rgb, level, "RGGB")
    assert out.dtype == np.float32
    np.testing.assert_allclose(out[0, 0], [0.2, 0.05, 0.0], atol=1e-7)
    mono = np.full((4, 4), 0.25, np.float32)
    np.testing.assert_allclose(subtract_dark_level(mono, level, None)[:2, :2], [[0.15, 0.05], [0.0, 0.0]],
                               atol=1e-7)


@pytest.mark.parametrize("level, error, match", [
    ([0.1, 0.2, 0.3], ValueError, "one rate per 2×2 phase"),
    ([0.1, -0.1, 0.0, 0.0], ValueError, "rates in \\[0, 1\\)"),
    ([0.1, np.nan, 0.0, 0.0], ValueError, "rates in \\[0, 1\\)"),
    (["a", "b", "c", "d"], TypeError, "four numbers"),
])
def test_bad_levels_are_refused(level, error, match):
    with pytest.raises(error, match=match):
        check_dark_level(level)


def test_bad_frames_and_recordings_are_refused():
    with pytest.raises(ValueError, match="colour frame must be"):
        subtract_dark_level(np.zeros((4, 4)), [0, 0, 0, 0], "RGGB")
    with pytest.raises(ValueError, match="monochrome frame must be"):
        subtract_dark_level(np.zeros((3, 4)), [0, 0, 0, 0], None)
    with pytest.raises(ValueError, match="even height and width"):
        measure_dark_level(np.zeros((4, 3, 4), np.uint8))
    with pytest.raises(ValueError, match="start"):
        measure_dark_level(np.zeros((4, 4, 4), np.uint8), start=4)
    with pytest.raises(ValueError, match="hot must be"):
        measure_dark_level(np.zeros((4, 4, 4), np.uint8), hot=np.zeros((2, 2), bool))


def test_load_the_level_from_a_calibration_map(tmp_path):
    from spikeref.hot_pixels import save_hot_pixel_map

    save_hot_pixel_map(tmp_path / "new.npz", np.zeros((4, 4), bool), dark_level=np.array([0.001, 0.002, 0.002, 0.003]))
    np.testing.assert_allclose(load_dark_level(tmp_path / "new.npz"), [0.001, 0.002, 0.002, 0.003])
    save_hot_pixel_map(tmp_path / "old.npz", np.zeros((4, 4), bool))  # a map made before the dark level
    with pytest.raises(ValueError, match="no dark level in this map"):
        load_dark_level(tmp_path / "old.npz")
    with pytest.raises(FileNotFoundError):
        load_dark_level(tmp_path / "none.npz")
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a readable calibration map"):
        load_dark_level(tmp_path / "bad.npz")


@pytest.mark.filterwarnings("ignore:.*too small for the alignment pyramid")
def test_the_reconstructor_subtracts_it_from_every_frame_and_step():
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.stream import SpikeStream

    rng = np.random.default_rng(0)
    spikes = (rng.random((60, 16, 16)) < 0.3).astype(np.uint8)
    stream = SpikeStream.from_array(spikes, cfa="RGGB")
    params = ReconstructParams(window=5, K=3, L=1, denoise=False)
    level = np.array([0.05, 0.1, 0.1, 0.4])
    plain = list(Reconstructor(stream, params).frames(keep_steps=True))
    dark = list(Reconstructor(stream, params, dark_level=level).frames(keep_steps=True))
    assert len(plain) == len(dark) > 0
    for a, b in zip(plain, dark, strict=True):
        np.testing.assert_allclose(b.rgb, subtract_dark_level(a.rgb, level, "RGGB"))
        for sa, sb in zip(a.steps, b.steps, strict=True):
            np.testing.assert_allclose(sb, subtract_dark_level(sa, level, "RGGB"))
    assert (plain[0].rgb[..., 2] < 0.4).any() and (dark[0].rgb[..., 2] == 0).any()  # blue lost 0.4, clipped at 0
    with pytest.raises(ValueError, match="dark_level must hold one rate per 2×2 phase"):
        Reconstructor(stream, params, dark_level=[0.1])


def test_a_map_of_another_size_or_of_a_lit_scene_is_refused(tmp_path):
    from spikeref.hot_pixels import save_hot_pixel_map

    save_hot_pixel_map(tmp_path / "m.npz", np.zeros((4, 6), bool), height=4, width=6, dark_level=np.full(4, 0.002))
    np.testing.assert_allclose(load_dark_level(tmp_path / "m.npz", (4, 6)), 0.002)
    with pytest.raises(ValueError, match="a map of 4×6 pixels for a recording of 8×8"):
        load_dark_level(tmp_path / "m.npz", (8, 8))
    save_hot_pixel_map(tmp_path / "lit.npz", np.zeros((4, 6), bool), dark_level=np.array([0.3, 0.4, 0.4, 0.2]))
    with pytest.raises(ValueError, match="is not a dark recording's"):
        load_dark_level(tmp_path / "lit.npz")


@pytest.mark.filterwarnings("ignore:.*too small for the alignment pyramid")
def test_a_monochrome_stream_loses_each_phases_level():
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.stream import SpikeStream

    spikes = (np.random.default_rng(1).random((60, 16, 16)) < 0.3).astype(np.uint8)
    stream = SpikeStream.from_array(spikes)  # no CFA
    params = ReconstructParams(window=5, K=3, L=1, denoise=False)
    level = np.array([0.01, 0.02, 0.03, 0.04])
    a = next(Reconstructor(stream, params).frames())
    b = next(Reconstructor(stream, params, dark_level=level).frames())
    assert a.rgb.ndim == 2
    np.testing.assert_allclose(b.rgb, np.maximum(a.rgb - np.tile(level.reshape(2, 2), (8, 8)), 0), atol=1e-7)
