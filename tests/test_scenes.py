"""Scene content and scene files: shapes, motion with known answers, HDR ratio, errors naming fields."""

from pathlib import Path

import numpy as np
import pytest

from spikeref.simulate.scenes import (
    CONTENT_TYPES, ColorChart, FanOverToys, HDRLamp, Scene, TranslatingTexture, Uniform, VideoFrames, load_scene,
    scene_from_dict, scene_to_dict,
)

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "scenes"


@pytest.mark.parametrize("path", sorted(p.name for p in EXAMPLES.glob("*.toml") if p.name != "video.toml"))
def test_example_scenes_load_and_render(path):
    scene = load_scene(EXAMPLES / path)
    assert scene.effects, "every example declares its effects"
    r = scene.radiance(np.array([0.0, 17.5]))
    assert r.shape == (2, scene.height, scene.width, 3) and r.dtype == np.float32
    assert np.all(np.isfinite(r)) and r.min() >= 0 and r.max() < 1.0  # below the rate's saturation


def test_video_example_needs_its_frames(tmp_path):
    with pytest.raises(FileNotFoundError, match="content.path"):
        load_scene(EXAMPLES / "video.toml")
    from spikeref.io.video import write_png

    folder = tmp_path / "my_frames"
    folder.mkdir()
    for i, v in enumerate((0, 255)):
        write_png(folder / f"f{i:03d}.png", np.full((6, 8, 3), v, dtype=np.uint8))
    (tmp_path / "video.toml").write_text((EXAMPLES / "video.toml").read_text())
    scene = load_scene(tmp_path / "video.toml")
    assert (scene.height, scene.width) == (6, 8)
    # 240 FPS source at 20 kHz: frame 1 at readout 20000/240; half-way is the mean (linear, then sRGB-decoded)
    half = scene.radiance([20000 / 240 / 2])[0]
    np.testing.assert_allclose(half, 0.5 * 0.5, rtol=1e-6)
    np.testing.assert_allclose(scene.radiance([1e6])[0], 0.5, rtol=1e-6)  # holds the last frame


def test_static_content_is_constant():
    for cls in (Uniform, ColorChart, HDRLamp):
        c = cls(height=32, width=48)
        assert c.static
        a, b = c.radiance([0.0, 1234.5])
        assert np.array_equal(a, b)


def test_uniform_is_brightness_times_color():
    c = Uniform(height=4, width=6, brightness=0.5, color=(1.0, 0.5, 0.25))
    assert np.array_equal(c.radiance([0])[0, 2, 3], np.float32([0.5, 0.25, 0.125]))


def test_color_chart_patches():
    c = ColorChart(height=240, width=360, brightness=1.0)
    img = c.radiance([0])[0]
    white = img[int(3.5 * 60), int(0.5 * 60)]
    assert np.allclose(white, 0.9, atol=0.01)  # white patch reflectance 0.9
    red = img[int(2.5 * 60), int(2.5 * 60)]  # patch 15, "red"
    assert red[0] > 3 * red[1] and red[0] > 3 * red[2]


def test_translation_is_an_exact_shift():
    # 20000 px/s right and 40000 px/s up: exactly (+1, −2) pixels per readout
    c = TranslatingTexture(height=16, width=20, velocity=(20000.0, -40000.0), seed=2)
    a, b = c.radiance([3.0, 4.0])
    assert np.array_equal(b[:-2, 1:], a[2:, :-1])
    assert not np.array_equal(a, b)
    # half a pixel to the right is the mean of the two neighbours (bilinear)
    h = TranslatingTexture(height=16, width=20, velocity=(10000.0, 0.0), seed=2).radiance([1.0])[0]
    t0 = TranslatingTexture(height=16, width=20, velocity=(10000.0, 0.0), seed=2).radiance([0.0])[0]
    np.testing.assert_allclose(h[:, 1:], 0.5 * (t0[:, :-1] + t0[:, 1:]), rtol=1e-5)


def test_texture_depends_on_its_seed_only():
    a = TranslatingTexture(height=8, width=8, seed=1).radiance([0])
    assert np.array_equal(a, TranslatingTexture(height=8, width=8, seed=1).radiance([0]))
    assert not np.array_equal(a, TranslatingTexture(height=8, width=8, seed=2).radiance([0]))


def test_fan_rotates_and_background_stays():
    fan = FanOverToys(height=64, width=64, revolutions_per_second=25.0, blades=4, seed=0)
    period = fan.period_readouts  # 800 readouts at 20 kHz
    assert period == 800
    a, b, c = fan.radiance([0.0, 25.0, period / 4])  # a quarter turn maps a 4-blade fan onto itself
    np.testing.assert_allclose(a, c, atol=1e-5)
    moved = np.abs(a - b).max(axis=-1) > 1e-3
    assert moved.mean() > 0.05
    yy, xx = np.mgrid[0:64, 0:64] + 0.5
    outside = np.hypot(yy - 32, xx - 32) > 0.42 * 64 + 1.5
    assert not moved[outside].any()  # beyond the blade tips nothing changes


def test_hdr_ratio_is_at_least_1e4():
    c = HDRLamp(height=128, width=128)
    img = c.radiance([0])[0].max(axis=-1)
    alcove = img[int(0.2 * 128) + 1:int(0.85 * 128) - 1, int(0.62 * 128) + 1:]
    assert img.max() / alcove.min() >= 1e4
    assert alcove.max() / alcove.min() >= 2.5  # the shadow still holds detail


def test_video_frames_interpolate():
    frames = np.stack([np.zeros((4, 6, 3)), np.ones((4, 6, 3))]).astype(np.float32)
    v = VideoFrames(frames=frames, fps=100.0, brightness=0.5)
    r = v.radiance([0.0, 100.0, 200.0, 5000.0])
    np.testing.assert_allclose(r[:, 0, 0, 0], [0.0, 0.25, 0.5, 0.5])
    with pytest.raises(ValueError, match="content.frames"):
        VideoFrames(frames=np.zeros((2, 4, 6)), fps=1.0)
    with pytest.raises(ValueError, match="content.fps"):
        VideoFrames(frames=frames, fps=0.0)


def _fan_dict(**content):
    return {"name": "t", "planes": 10, "camera": {"cfa": "RGGB"},
            "content": {"type": "fan", "height": 16, "width": 16, **content}, "effects": {"random_phase": {}}}


def test_scene_errors_name_the_field(tmp_path):
    with pytest.raises(ValueError, match="content.revolutions_per_second"):
        scene_from_dict(_fan_dict(revolutions_per_second=float("nan")))
    with pytest.raises(ValueError, match="content.brightness"):
        scene_from_dict(_fan_dict(brightness=-1.0))
    with pytest.raises(ValueError, match="unknown field content.blade;"):
        scene_from_dict(_fan_dict(blade=3))
    with pytest.raises(ValueError, match="content.height must be an even"):
        scene_from_dict(_fan_dict(height=15))
    with pytest.raises(ValueError, match="content.type must be one of"):
        scene_from_dict({"content": {"type": "sunset"}})
    with pytest.raises(ValueError, match="camera: threshold"):
        scene_from_dict({**_fan_dict(), "camera": {"threshold": 0}})
    with pytest.raises(ValueError, match="unknown field camera.gain"):
        scene_from_dict({**_fan_dict(), "camera": {"gain": 2}})
    with pytest.raises(ValueError, match="effects: unknown effect"):
        scene_from_dict({**_fan_dict(), "effects": {"glow": {}}})
    with pytest.raises(ValueError, match="planes"):
        scene_from_dict({**_fan_dict(), "planes": 0})
    with pytest.raises(ValueError, match="unknown field"):
        scene_from_dict({**_fan_dict(), "plane": 3})
    bad = tmp_path / "bad.toml"
    bad.write_text("name = 'x'\n[content\n")
    with pytest.raises(ValueError, match="bad.toml: not a valid TOML"):
        load_scene(bad)
    with pytest.raises(FileNotFoundError):
        load_scene(tmp_path / "missing.toml")


def test_overrides_and_round_trip():
    scene = load_scene(EXAMPLES / "fan.toml", overrides={"planes": 33, "content": {"width": 64, "height": 48},
                                                         "effects": {"dark_current": {"gamma": 0.1}}})
    assert scene.planes == 33 and (scene.height, scene.width) == (48, 64)
    assert list(scene.effects) == ["dark_current"] and scene.effects["dark_current"].gamma == 0.1
    again = scene_from_dict(scene_to_dict(scene))
    assert again.content == scene.content and again.camera == scene.camera and again.effects == scene.effects
    mono = scene_from_dict({**_fan_dict(), "camera": {"cfa": "mono"}})
    assert mono.camera.cfa is None
    assert set(CONTENT_TYPES) == {"uniform", "color_chart", "translating_texture", "fan", "hdr_lamp", "video"}
    assert isinstance(scene, Scene)


def test_read_frames_from_a_video_a_glob_and_errors(tmp_path):
    from spikeref.io.frames import read_frames
    from spikeref.io.video import write_png, write_video

    frames = np.zeros((3, 16, 16, 3), dtype=np.uint8)
    frames[1] = 128
    frames[2] = 255
    write_video(tmp_path / "clip.gif", frames, fps=10)
    got = read_frames(tmp_path / "clip.gif")
    assert got.shape == (3, 16, 16, 3)
    assert abs(int(got[1].mean()) - 128) <= 2 and got[2].min() >= 250
    assert read_frames(tmp_path / "clip.gif", max_frames=2).shape[0] == 2
    for i in range(2):
        write_png(tmp_path / f"p{i}.png", frames[i])
    assert read_frames(tmp_path / "p*.png").shape == (2, 16, 16, 3)
    with pytest.raises(FileNotFoundError, match="no files match"):
        read_frames(tmp_path / "q*.png")
    (tmp_path / "junk.mp4").write_bytes(b"not a video")
    with pytest.raises(ValueError, match="cannot read"):
        read_frames(tmp_path / "junk.mp4")
    with pytest.raises(ValueError, match="max_frames"):
        read_frames(tmp_path / "clip.gif", max_frames=0)
