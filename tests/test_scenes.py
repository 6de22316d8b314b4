"""Scene content and scene files: shapes, motion with known answers, HDR ratio, video timing, errors naming fields."""

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.simulate.camera import Camera
from spikeref.simulate.scenes import (
    COLORCHECKER_SRGB, CONTENT_TYPES, ColorChart, FanOverToys, HDRLamp, Scene, SceneContent, TranslatingTexture,
    Uniform, VideoFrames, load_scene, scene_from_dict, scene_to_dict,
)
from spikeref.tonemap import srgb_decode

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "scenes"
ALL_EXAMPLES = sorted(p.name for p in EXAMPLES.glob("*.toml"))
PROCEDURAL_EXAMPLES = [name for name in ALL_EXAMPLES if name != "video.toml"]
RATE = 20000.0


def _small(kind, h=16, w=24):
    """A small content of each type."""
    if kind == "video":
        frames = np.random.default_rng(0).random((3, h, w, 3), dtype=np.float32) * 0.5
        return VideoFrames(frames=frames, fps=1000.0)
    if kind == "image":
        from spikeref.simulate.motion import Motion

        image = np.random.default_rng(0).random((h + 6, w + 4, 3), dtype=np.float32) * 0.9
        return CONTENT_TYPES[kind](image=image, height=h, width=w, motion=Motion(velocity=(900.0, 300.0),
                                                                                  rotation=50.0))
    return CONTENT_TYPES[kind](height=h, width=w)


def _write_frames(folder, values, shape=(6, 8)):
    from spikeref.io.video import write_png

    folder.mkdir(parents=True, exist_ok=True)
    for i, v in enumerate(values):
        write_png(folder / f"f{i:03d}.png", np.full(shape + (3,), v, dtype=np.uint8))


# --------------------------------------------------------------------------- examples
def test_examples_exist():
    assert {"color_chart.toml", "translating_texture.toml", "fan.toml", "hdr_lamp.toml", "low_light.toml",
            "video.toml"} <= {p.name for p in EXAMPLES.glob("*.toml")}


@pytest.mark.parametrize("name", PROCEDURAL_EXAMPLES)
def test_example_scenes_load_and_render(name):
    scene = load_scene(EXAMPLES / name)
    assert scene.effects, "every example declares its effects"
    assert scene.planes >= 1 and scene.content.rate_hz == scene.camera.rate_hz
    r = scene.radiance(np.array([0.0, 17.5, scene.planes - 0.5]))
    assert r.shape == (3, scene.height, scene.width, 3) and r.dtype == np.float32
    assert np.all(np.isfinite(r)) and r.min() >= 0 and r.max() <= 0.95  # below the rate's saturation
    assert r.max() > 0


def test_low_light_example_is_dim_and_noisy():
    scene = load_scene(EXAMPLES / "low_light.toml")
    assert 0.005 <= scene.content.brightness <= 0.02
    assert scene.radiance([0.0]).max() <= 0.02
    assert {"shot_noise", "dark_current", "inherent_noise"} <= set(scene.effects)


def test_video_example_reads_the_frames_it_ships_with():
    """``video.toml`` loads as shipped: the three frames of ``make_video_frames.py``, sRGB-decoded."""
    import importlib.util

    scene = load_scene(EXAMPLES / "video.toml")
    assert (scene.height, scene.width) == (32, 48) and scene.content.fps == 30.0
    spec = importlib.util.spec_from_file_location("make_video_frames", EXAMPLES / "make_video_frames.py")
    maker = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(maker)
    brightness = dict(scene.content.source_options)["brightness"]
    assert scene.content.frames.shape == (maker.FRAMES, maker.HEIGHT, maker.WIDTH, 3)
    for i in range(maker.FRAMES):  # the PNGs are what the script makes
        expected = srgb_decode(maker.frame(i).astype(np.float32) / 255) * brightness
        np.testing.assert_allclose(scene.content.frames[i], expected, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(scene.radiance([i * RATE / 30])[0], expected, rtol=1e-5, atol=1e-6)


def test_video_template_reads_a_users_frames(tmp_path):
    _write_frames(tmp_path / "video_frames", (0, 255))
    shutil.copy(EXAMPLES / "video.toml", tmp_path / "video.toml")
    scene = load_scene(tmp_path / "video.toml")
    assert (scene.height, scene.width) == (6, 8) and scene.content.fps == 30.0
    brightness = scene.content.source_options[0][1]
    np.testing.assert_array_equal(scene.radiance([0.0])[0], 0.0)
    np.testing.assert_allclose(scene.radiance([RATE / 30])[0], brightness, rtol=1e-6)  # frame 1 (white)
    np.testing.assert_allclose(scene.radiance([RATE / 30 / 2])[0], brightness / 2, rtol=1e-6)  # half-way
    np.testing.assert_allclose(scene.radiance([1e6])[0], brightness, rtol=1e-6)  # holds the last frame
    again = scene_from_dict(scene_to_dict(scene))
    assert again.content == scene.content and np.array_equal(again.content.frames, scene.content.frames)
    (tmp_path / "video.toml").write_text((EXAMPLES / "video.toml").read_text().replace('"video_frames/"',
                                                                                      '"my_frames/"'))
    with pytest.raises(FileNotFoundError, match=r"video\.toml: content\.path"):
        load_scene(tmp_path / "video.toml")  # a path that does not exist is named


@pytest.mark.parametrize("name", ALL_EXAMPLES)
def test_every_example_scene_simulates_as_shipped(name):
    from spikeref.simulate.simulator import simulate

    scene = load_scene(EXAMPLES / name, overrides={"planes": 12})
    result = simulate(scene, seed=0)
    assert result.spikes.shape == (12, scene.height, scene.width) and result.spikes.dtype == np.uint8
    assert result.spikes.max() <= 1 and result.spikes.any(), name


# --------------------------------------------------------------------------- every content type
@pytest.mark.parametrize("kind", sorted(CONTENT_TYPES))
def test_every_content_type_shape_dtype_range(kind):
    c = _small(kind)
    assert isinstance(c, SceneContent) and (c.height, c.width) == (16, 24)
    r = c.radiance(np.array([-3.0, 0.0, 0.37, 123.25]))
    assert r.shape == (4, 16, 24, 3) and r.dtype == np.float32
    assert np.all(np.isfinite(r)) and r.min() >= 0 and r.max() <= 0.95
    assert c.radiance(np.zeros(0)).shape == (0, 16, 24, 3)
    assert c.radiance(2.0).shape == (1, 16, 24, 3)  # a scalar time is one sample
    with pytest.raises(ValueError, match="times"):
        c.radiance(np.array([[0.0]]))
    with pytest.raises(ValueError, match="finite"):
        c.radiance([np.nan])


def test_static_flags_and_static_scenes_are_constant():
    static = [Uniform(height=8, width=8), ColorChart(height=32, width=48), HDRLamp(height=32, width=48),
              FanOverToys(height=32, width=32, revolutions_per_second=0.0),
              TranslatingTexture(height=16, width=16, velocity=(0.0, 0.0)),
              VideoFrames(frames=np.full((1, 4, 4, 3), 0.2, np.float32), fps=30.0)]
    for c in static:
        assert c.static, type(c).__name__
        a, b, d = c.radiance([0.0, 1234.5, 1e7])
        assert np.array_equal(a, b) and np.array_equal(a, d), type(c).__name__
    for kind in ("translating_texture", "fan", "video"):
        c = _small(kind)
        assert not c.static
        a, b = c.radiance([0.0, 10.0])
        assert not np.array_equal(a, b), kind


def test_uniform_is_brightness_times_color():
    c = Uniform(height=4, width=6, brightness=0.5, color=(1.0, 0.5, 0.25))
    assert np.array_equal(c.radiance([0])[0, 2, 3], np.float32([0.5, 0.25, 0.125]))


def test_color_chart_patches_are_the_published_colours_decoded():
    c = ColorChart(height=240, width=360, brightness=0.5, board=0.03)
    img = c.radiance([0])[0]
    lin = srgb_decode(np.asarray(COLORCHECKER_SRGB, dtype=np.float64) / 255.0).reshape(4, 6, 3)
    expected = lin * (0.9 / lin[3, 0].max()) * 0.5
    centers = c.patch_centers.astype(int)
    got = img[centers[..., 0], centers[..., 1]]
    np.testing.assert_allclose(got, expected, rtol=1e-6)
    assert np.isclose(got[3, 0].max(), 0.45)  # white patch: reflectance 0.9
    red = got[2, 2]  # patch 15, "red"
    assert red[0] > 5 * red[1] and red[0] > 5 * red[2]
    np.testing.assert_allclose(img[0, 0], 0.03 * 0.5, rtol=1e-6)  # the board in a corner


# --------------------------------------------------------------------------- translation
def test_translation_is_an_exact_shift_with_wrap_around():
    # texture as large as the image: any whole-pixel shift is np.roll of the image
    c = TranslatingTexture(height=16, width=16, texture_size=16, velocity=(20000.0, -40000.0), seed=2)
    a, b = c.radiance([3.0, 4.0])  # +1 px right and 2 px up per readout
    assert np.array_equal(b, np.roll(a, (-2, 1), axis=(0, 1)))
    assert not np.array_equal(a, b)
    # an image larger than the texture repeats it
    big = TranslatingTexture(height=40, width=24, texture_size=16, seed=2).radiance([0.0])[0]
    assert np.array_equal(big[16:32], big[:16]) and np.array_equal(big[:, 16:], big[:, :8])
    assert not np.array_equal(big[8:24], big[:16])
    # at t = 0 the image is the texture itself, from its origin, times the brightness
    c = TranslatingTexture(height=24, width=40, texture_size=32, brightness=0.3, seed=5)
    expected = np.tile(c.texture * 0.3, (1, 2, 1))[:24, :40].astype(np.float32)
    assert np.array_equal(c.radiance([0.0])[0], expected)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(dx=st.integers(-6, 6), dy=st.integers(-6, 6), step=st.sampled_from([1, 2, 4, 5, 8, 10, 25, 40]),
       k=st.integers(0, 50))
def test_translation_by_whole_pixels_is_exact(dx, dy, step, k):
    # velocity chosen so that the content moves (dx, dy) pixels every `step` readouts, exactly
    c = TranslatingTexture(height=12, width=20, texture_size=20, velocity=(dx * RATE / step, dy * RATE / step),
                           seed=7)
    a, b = c.radiance([k * step, (k + 1) * step])
    shifted = np.roll(a, (dy, dx), axis=(0, 1))
    # rows wrap with the texture's period (20), not the image's (12): compare the rows that stayed inside
    rows = slice(max(dy, 0), 12 + min(dy, 0))
    assert np.array_equal(b[rows], shifted[rows])


def test_translation_half_pixel_is_the_mean_of_neighbours():
    c = TranslatingTexture(height=16, width=20, velocity=(10000.0, 0.0), seed=2)  # 0.5 px per readout, right
    t0, h = c.radiance([0.0, 1.0])
    np.testing.assert_array_equal(h[:, 1:], 0.5 * (t0[:, :-1] + t0[:, 1:]))


def test_texture_depends_on_its_seed_only():
    a = TranslatingTexture(height=8, width=8, seed=1).radiance([0])
    assert np.array_equal(a, TranslatingTexture(height=8, width=8, seed=1, brightness=0.5).radiance([0]))
    assert not np.array_equal(a, TranslatingTexture(height=8, width=8, seed=2).radiance([0]))


# --------------------------------------------------------------------------- fan
def test_fan_period_motion_and_still_background():
    fan = FanOverToys(height=64, width=64, revolutions_per_second=25.0, blades=4, seed=0)
    period = fan.period_readouts
    assert period == 800  # 20 000 / 25
    t = 13.625
    a, b, full, quarter, eighth = fan.radiance([t, t + 5.0, t + period, t + period / 4, t + period / 8])
    np.testing.assert_allclose(full, a, atol=1e-5)  # one turn later: the same image
    np.testing.assert_allclose(quarter, a, atol=1e-5)  # four blades: a quarter turn maps the fan onto itself
    assert np.abs(eighth - a).max() > 0.1  # an eighth does not
    moved = np.abs(a - b).max(axis=-1) > 1e-3
    assert moved.mean() > 0.05  # the blades moved in 5 readouts
    yy, xx = np.mgrid[0:64, 0:64] + 0.5
    r = np.hypot(yy - 32, xx - 32)
    outside = r > fan.tip_radius + 1.0
    many = fan.radiance(np.linspace(0, period, 97))
    assert np.all(many[:, outside] == fan.background[outside])  # beyond the blade tips: the toys, unchanged
    assert fan.background[outside].std() > 0.05  # ... and they are not a flat field
    annulus = (r > 0.5 * fan.tip_radius) & (r < 0.9 * fan.tip_radius)
    blade_rgb = (np.asarray(fan.blade_color) * fan.brightness).astype(np.float32)  # as the fan computes it
    covered = np.all(many[:, annulus] == blade_rgb, axis=-1)  # opaque: exactly the blade's colour
    uncovered = np.all(many[:, annulus] == fan.background[annulus], axis=-1)  # exactly the toys
    assert np.all(covered.any(axis=0)) and np.all(uncovered.any(axis=0))  # every pixel there is passed over


def test_fan_turns_counter_clockwise_at_its_speed():
    fan = FanOverToys(height=128, width=128, revolutions_per_second=50.0, blades=1, blade_width=0.2,
                      blade_color=(0.0, 0.0, 0.0), brightness=0.5, seed=3)
    yy, xx = np.mgrid[0:128, 0:128] + 0.5
    r = np.hypot(yy - 64, xx - 64)
    ring = (r > 0.6 * fan.tip_radius) & (r < 0.95 * fan.tip_radius)
    angles = []
    for t in (0.0, fan.period_readouts / 8):  # an eighth of a turn
        img = fan.radiance([t])[0].sum(axis=-1)
        dark = ring & (img < 1e-6)  # black blade
        angles.append(math.atan2(-(yy[dark] - 64).mean(), (xx[dark] - 64).mean()))
    turn = math.degrees((angles[1] - angles[0]) % (2 * math.pi))
    assert abs(turn - 45.0) < 3.0  # counter-clockwise on screen (row 0 at the top), 45°
    clockwise = FanOverToys(height=128, width=128, revolutions_per_second=-50.0, blades=1, blade_width=0.2,
                            blade_color=(0.0, 0.0, 0.0), seed=3)
    img = clockwise.radiance([fan.period_readouts / 8])[0].sum(axis=-1)
    dark = ring & (img < 1e-6)
    back = math.degrees((math.atan2(-(yy[dark] - 64).mean(), (xx[dark] - 64).mean()) - angles[0]) % (2 * math.pi))
    assert abs(back - 315.0) < 3.0


def test_fan_edges_are_anti_aliased():
    fan = FanOverToys(height=64, width=64, blades=2, blade_color=(0.0, 0.0, 0.0), hub=0.0, seed=1)
    img = fan.radiance([7.3])[0]
    ratio = img.sum(axis=-1) / fan.background.sum(axis=-1)
    partial = (ratio > 0.05) & (ratio < 0.95)
    assert 10 < partial.sum() < 400  # a thin band of partly covered pixels along the blade edges


# --------------------------------------------------------------------------- HDR
@pytest.mark.parametrize("make", [lambda: HDRLamp(height=128, width=128),
                                  lambda: load_scene(EXAMPLES / "hdr_lamp.toml").content])
def test_hdr_lamp_to_deep_shadow_is_at_least_1e4(make):
    c = make()
    img = c.radiance([0])[0]
    mask = c.shadow_mask
    assert mask.mean() > 0.1
    lamp, darkest = img.max(), img[mask].min()
    assert lamp <= 0.95 and darkest > 0
    assert lamp / darkest >= 1e4
    assert img[mask].max() / darkest >= 3  # the deep shadow still holds detail
    lum = img.mean(axis=-1)
    assert ((lum > 1e-3) & (lum < 0.3)).mean() > 0.3  # mid-tones between


# --------------------------------------------------------------------------- video
def test_video_frames_interpolate_linearly_and_hold_at_the_ends():
    frames = np.random.default_rng(1).random((3, 4, 6, 3), dtype=np.float32)
    v = VideoFrames(frames=frames, fps=100.0)  # 200 readouts per source frame at 20 kHz
    r = v.radiance([-50.0, 0.0, 100.0, 200.0, 300.0, 400.0, 5000.0])
    np.testing.assert_array_equal(r[0], frames[0])  # before the first frame: holds it
    np.testing.assert_array_equal(r[1], frames[0])
    np.testing.assert_array_equal(r[2], 0.5 * (frames[0] + frames[1]))  # half-way: the mean
    np.testing.assert_array_equal(r[3], frames[1])
    np.testing.assert_array_equal(r[4], 0.5 * (frames[1] + frames[2]))
    np.testing.assert_array_equal(r[5], frames[2])
    np.testing.assert_array_equal(r[6], frames[2])  # after the last: holds it
    np.testing.assert_allclose(v.radiance([50.0])[0], 0.75 * frames[0] + 0.25 * frames[1], rtol=1e-6)
    # a different camera rate changes the mapping from readouts to source frames
    slow = VideoFrames(frames=frames, fps=100.0, rate_hz=10000.0)
    np.testing.assert_array_equal(slow.radiance([100.0])[0], frames[1])
    out = v.radiance([0.0])
    out[...] = 9.0  # radiance is a fresh array: writing to it changes nothing
    np.testing.assert_array_equal(v.radiance([0.0])[0], frames[0])
    with pytest.raises(ValueError):
        v.frames[0, 0, 0, 0] = 1.0  # kept read-only


def test_video_frames_validation():
    good = np.zeros((2, 4, 6, 3), np.float32)
    with pytest.raises(ValueError, match="content.frames"):
        VideoFrames(frames=np.zeros((2, 4, 6)), fps=1.0)
    with pytest.raises(ValueError, match="content.frames"):
        VideoFrames(frames=good - 1.0, fps=1.0)
    with pytest.raises(ValueError, match="content.fps"):
        VideoFrames(frames=good, fps=0.0)
    with pytest.raises(ValueError, match="content.height must be an even"):
        VideoFrames(frames=np.zeros((2, 5, 6, 3)), fps=1.0)
    with pytest.raises(ValueError, match="built from an array"):
        scene_to_dict(Scene(name="v", content=VideoFrames(frames=good, fps=1.0), planes=4))


def _video_scene(tmp_path, **content):
    return {"name": "v", "planes": 10, "content": {"type": "video", "fps": 50.0, **content}}


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # imageio tries its legacy plugins on the broken file
def test_video_files_decode_resize_crop_and_errors(tmp_path):
    _write_frames(tmp_path / "odd", (128, 255), shape=(7, 9))
    scene = scene_from_dict(_video_scene(tmp_path, path="odd", brightness=0.8), base_dir=tmp_path)
    assert (scene.height, scene.width) == (6, 8)  # odd source: the last row and column are dropped
    np.testing.assert_allclose(scene.radiance([0.0])[0], 0.8 * srgb_decode(128 / 255), rtol=1e-6)
    linear = scene_from_dict(_video_scene(tmp_path, path="odd", srgb=False, brightness=1.0), base_dir=tmp_path)
    np.testing.assert_allclose(linear.radiance([0.0])[0], 128 / 255, rtol=1e-6)
    from spikeref.io.video import write_png

    (tmp_path / "ramp").mkdir()
    ramp = np.zeros((5, 7, 3), np.uint8)
    ramp += (10 * np.arange(5)[:, None, None] + np.arange(7)[None, :, None]).astype(np.uint8)
    write_png(tmp_path / "ramp" / "a.png", ramp)
    cropped = scene_from_dict(_video_scene(tmp_path, path="ramp", srgb=False, brightness=1.0), base_dir=tmp_path)
    np.testing.assert_allclose(cropped.radiance([0.0])[0], ramp[:4, :6] / 255, rtol=1e-6)  # first rows/columns kept
    # resize: area average of a 2-pixel-period pattern is its mean; one size keeps the aspect ratio
    (tmp_path / "stripes").mkdir()
    img = np.zeros((8, 12, 3), np.uint8)
    img[:, ::2] = 255
    write_png(tmp_path / "stripes" / "a.png", img)
    half = scene_from_dict(_video_scene(tmp_path, path="stripes/*.png", height=4, srgb=False), base_dir=tmp_path)
    assert (half.height, half.width) == (4, 6)
    np.testing.assert_allclose(half.radiance([0.0])[0], 0.5 * 0.5, rtol=1e-6)
    assert half.content.source.endswith("*.png")
    up = scene_from_dict(_video_scene(tmp_path, path="stripes", width=24, height=16, srgb=False),
                         base_dir=tmp_path)
    assert (up.height, up.width) == (16, 24) and up.radiance([0.0]).max() <= 0.5 + 1e-6
    with pytest.raises(ValueError, match="content.height must be an even"):
        scene_from_dict(_video_scene(tmp_path, path="odd", height=5), base_dir=tmp_path)
    with pytest.raises(ValueError, match="content.fps is required"):
        scene_from_dict({"planes": 1, "content": {"type": "video", "path": "odd"}}, base_dir=tmp_path)
    with pytest.raises(ValueError, match="content.brightness"):
        scene_from_dict(_video_scene(tmp_path, path="odd", brightness=float("nan")), base_dir=tmp_path)
    with pytest.raises(ValueError, match="content.srgb"):
        scene_from_dict(_video_scene(tmp_path, path="odd", srgb="yes"), base_dir=tmp_path)
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="content.path: no images"):
        scene_from_dict(_video_scene(tmp_path, path="empty"), base_dir=tmp_path)
    with pytest.raises(FileNotFoundError, match="content.path: no such"):
        scene_from_dict(_video_scene(tmp_path, path="nowhere.mp4"), base_dir=tmp_path)
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "a.png").write_bytes(b"not a png")
    with pytest.raises(ValueError, match="content.path: .*cannot read"):
        scene_from_dict(_video_scene(tmp_path, path="broken"), base_dir=tmp_path)


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
    write_png(tmp_path / "p2.png", np.zeros((8, 16, 3), np.uint8))
    with pytest.raises(ValueError, match="differ in size"):
        read_frames(tmp_path / "p*.png")
    with pytest.raises(FileNotFoundError, match="no files match"):
        read_frames(tmp_path / "q*.png")
    with pytest.raises(FileNotFoundError, match="no such"):
        read_frames(tmp_path / "missing.mp4")
    (tmp_path / "junk.mp4").write_bytes(b"not a video")
    with pytest.raises(ValueError, match="cannot read"):
        read_frames(tmp_path / "junk.mp4")
    with pytest.raises(ValueError, match="max_frames"):
        read_frames(tmp_path / "clip.gif", max_frames=0)


# --------------------------------------------------------------------------- scene files: errors, overrides
def _fan_dict(**content):
    return {"name": "t", "planes": 10, "camera": {"cfa": "RGGB"},
            "content": {"type": "fan", "height": 16, "width": 16, **content}, "effects": {"random_phase": {}}}


@pytest.mark.parametrize("change, message", [
    ({"content": {"revolutions_per_second": float("nan")}}, "content.revolutions_per_second must be"),
    ({"content": {"brightness": -1.0}}, "content.brightness must be finite and ≥ 0; got -1.0"),
    ({"content": {"brightness": float("inf")}}, "content.brightness"),
    ({"content": {"brightness": "bright"}}, "content.brightness"),
    ({"content": {"blade": 3}}, "unknown field content.blade; fan takes height, width, brightness, revolutions_"),
    ({"content": {"height": 15}}, "content.height must be an even integer"),
    ({"content": {"width": 0}}, "content.width must be an even integer"),
    ({"content": {"blades": 0}}, "content.blades must be an integer ≥ 1"),
    ({"content": {"blades": True}}, "content.blades"),
    ({"content": {"radius": 1.5}}, r"content.radius must be a finite number in \(0, 1\]"),
    ({"content": {"blade_color": [1, 2]}}, "content.blade_color must be 3 values"),
    ({"content": {"rate_hz": 100.0}}, "unknown field content.rate_hz"),
    ({"camera": {"threshold": 0}}, "camera: threshold"),
    ({"camera": {"gain": 2}}, "unknown field camera.gain; camera takes threshold"),
    ({"effects": {"glow": {}}}, "effects: unknown effect 'glow'"),
    ({"effects": {"dark_current": {"gama": 1}}}, "effects: unknown parameter dark_current.gama"),
    ({"planes": 0}, "planes must be a positive integer"),
    ({"planes": 2.5}, "planes must be a positive integer"),
    ({"plane": 3}, "unknown field plane; a scene has"),
    ({"name": 3}, "name must be a string"),
])
def test_scene_errors_name_the_field(change, message):
    data = _fan_dict()
    for key, value in change.items():
        data[key] = {**data[key], **value} if key in ("content", "camera") else value
    with pytest.raises(ValueError, match=message):
        scene_from_dict(data, source="fan.toml")
    with pytest.raises(ValueError, match="^fan.toml: "):
        scene_from_dict(data, source="fan.toml")


def test_scene_file_errors(tmp_path):
    with pytest.raises(ValueError, match="content.type must be one of uniform, color_chart, translating_texture, "
                                         "fan, hdr_lamp, video, image; got 'sunset'"):
        scene_from_dict({"planes": 1, "content": {"type": "sunset"}})
    with pytest.raises(ValueError, match=r"a \[content\] table is required"):
        scene_from_dict({"planes": 1})
    with pytest.raises(ValueError, match="planes is required"):
        scene_from_dict({"content": {"type": "uniform", "height": 4, "width": 4}})
    bad = tmp_path / "bad.toml"
    bad.write_text("name = 'x'\n[content\n")
    with pytest.raises(ValueError, match="bad.toml: not a valid TOML scene file"):
        load_scene(bad)
    neg = tmp_path / "neg.toml"
    neg.write_text((EXAMPLES / "fan.toml").read_text().replace("brightness = 0.5 ", "brightness = -3 "))
    with pytest.raises(ValueError, match=r"neg\.toml: content\.brightness must be finite and ≥ 0; got -3"):
        load_scene(neg)
    nan = tmp_path / "nan.toml"
    nan.write_text((EXAMPLES / "fan.toml").read_text().replace("= 25.0 ", "= nan "))
    with pytest.raises(ValueError, match=r"nan\.toml: content\.revolutions_per_second .*got nan"):
        load_scene(nan)
    with pytest.raises(FileNotFoundError, match="no such scene file"):
        load_scene(tmp_path / "missing.toml")
    with pytest.raises(ValueError, match="content.rate_hz .* differs from camera.rate_hz"):
        Scene(name="x", content=Uniform(height=4, width=4, rate_hz=1000.0), planes=3)


def test_overrides_replace_effects_and_merge_tables():
    scene = load_scene(EXAMPLES / "fan.toml", overrides={"planes": 33, "content": {"width": 64, "height": 48},
                                                         "effects": {"dark_current": {"gamma": 0.1}}})
    assert scene.planes == 33 and (scene.height, scene.width) == (48, 64)
    assert scene.content.revolutions_per_second == 25.0  # the rest of the content table is kept
    assert list(scene.effects) == ["dark_current"] and scene.effects["dark_current"].gamma == 0.1
    assert load_scene(EXAMPLES / "fan.toml", overrides={"effects": {}}).effects == {}
    other = load_scene(EXAMPLES / "fan.toml", overrides={"content": {"type": "uniform", "height": 4, "width": 6}})
    assert isinstance(other.content, Uniform) and (other.height, other.width) == (4, 6)
    fast = load_scene(EXAMPLES / "fan.toml", overrides={"camera": {"rate_hz": 40000.0}})
    assert fast.content.rate_hz == 40000.0 and fast.content.period_readouts == 1600  # velocities follow the rate
    mono = load_scene(EXAMPLES / "fan.toml", overrides={"camera": {"cfa": "mono"}})
    assert mono.camera.cfa is None


@pytest.mark.parametrize("name", PROCEDURAL_EXAMPLES)
def test_scene_to_dict_round_trips(name):
    scene = load_scene(EXAMPLES / name)
    again = scene_from_dict(scene_to_dict(scene))
    assert again == scene
    assert np.array_equal(again.radiance([5.5]), scene.radiance([5.5]))


def test_scene_defaults_and_properties():
    content = TranslatingTexture(height=8, width=10)
    scene = Scene(name="s", content=content, planes=5, effects={"random_phase": {}})
    assert scene.camera == Camera() and list(scene.effects) == ["random_phase"]
    assert (scene.height, scene.width) == (8, 10)
    assert np.array_equal(scene.radiance([1.0]), content.radiance([1.0]))
    with pytest.raises(TypeError):
        TranslatingTexture(8, 10)  # keyword-only: sizes cannot be swapped by position


# ----------------------------------------------------------------------------- image content
def _image_scene_file(tmp_path, extra=""):
    import imageio.v3 as iio

    rng = np.random.default_rng(5)
    iio.imwrite(tmp_path / "photo.png", (rng.random((40, 50, 3)) * 255).astype(np.uint8))
    path = tmp_path / "photo.toml"
    path.write_text(f"""
name = "photo"
planes = 30
[content]
type = "image"
path = "photo.png"
height = 16
width = 20
brightness = 0.4
[content.motion]
velocity = [2000.0, 0.0]
{extra}
""")
    return path


def test_image_scene_reads_a_photograph_and_round_trips(tmp_path):
    from spikeref.simulate.scenes import ImageMotion, scene_from_dict, scene_to_dict
    from spikeref.tonemap import srgb_decode

    scene = load_scene(_image_scene_file(tmp_path))
    c = scene.content
    assert isinstance(c, ImageMotion) and (c.height, c.width) == (16, 20) and c.image.shape == (40, 50, 3)
    assert c.origin == (15.0, 12.0)  # the view is centred on the photograph
    import imageio.v3 as iio

    raw = iio.imread(tmp_path / "photo.png")
    np.testing.assert_allclose(c.image, srgb_decode(raw / 255.0) * 0.4, rtol=1e-5, atol=1e-6)
    # at t = 0 the view is the centred crop of the photograph; 10 readouts later it moved 1 px right
    r = c.radiance([0.0, 10.0])
    np.testing.assert_allclose(r[0], c.image[12:28, 15:35], atol=1e-6)
    np.testing.assert_allclose(r[1][:, 1:], c.image[12:28, 15:34], atol=1e-6)
    again = scene_from_dict(scene_to_dict(scene))
    assert again == scene and np.array_equal(again.content.image, c.image)


def test_image_scene_with_foreground_round_trips(tmp_path):
    from spikeref.simulate.scenes import scene_from_dict, scene_to_dict

    path = _image_scene_file(tmp_path, """
[content.foreground]
path = "photo.png"
scale = 0.5
radius = 5.0
center = [6.0, 8.0]
[content.foreground.motion]
velocity = [-3000.0, 1000.0]
""")
    scene = load_scene(path)
    c = scene.content
    assert c.fg_image.shape == (20, 25, 3) and c.fg_radius == 5.0 and c.fg_motion.center == (6.0, 8.0)
    assert scene_from_dict(scene_to_dict(scene)) == scene


@pytest.mark.parametrize("extra, match", [
    ("scale = 0\n", "content.scale must be a number in"),
    ("origin = [1]\n", "content.origin must be"),
    ("[content.foreground]\npath = 'photo.png'\n", "content.foreground.radius is required"),
    ("[content.foreground]\npath = 'photo.png'\nradius = 3\nshape = 'disc'\n",
     "unknown field content.foreground.shape"),
])
def test_bad_image_scene(tmp_path, extra, match):
    path = _image_scene_file(tmp_path)
    text = path.read_text()
    if extra.startswith("["):
        text += extra
    else:
        text = text.replace("brightness = 0.4\n", "brightness = 0.4\n" + extra)
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        load_scene(path)


def test_image_scene_from_scikit_image():
    pytest.importorskip("skimage")
    from spikeref.simulate.scenes import scene_from_dict

    data = {"planes": 10, "content": {"type": "image", "path": "skimage:astronaut", "height": 32, "width": 32,
                                      "scale": 0.125}}
    scene = scene_from_dict(data)
    assert scene.content.image.shape == (64, 64, 3) and scene.content.static
    data["content"]["path"] = "skimage:no_such_photo"
    with pytest.raises(ValueError, match="scikit-image bundles no photograph 'no_such_photo'; it has .*astronaut"):
        scene_from_dict(data)


def test_denoiser_training_scenes_keep_their_photographs_out_of_every_scored_set():
    """The photographs of scripts/denoiser_scenes/train_*.toml are in no benchmark or held-out scene, and
    the static twins (train_static_*.toml, for the pairs objective) do not move."""
    import tomllib

    root = Path(__file__).resolve().parents[1]

    def photographs(paths):
        found = set()
        for path in paths:
            text = tomllib.loads(path.read_text())
            for table in (text.get("content", {}), text.get("content", {}).get("foreground", {})):
                if isinstance(table, dict) and str(table.get("path", "")).startswith("skimage:"):
                    found.add(table["path"])
        return found

    train = sorted((root / "scripts" / "denoiser_scenes").glob("train_*.toml"))
    scored = [*(root / "spikeref" / "bench" / "scenes").glob("*.toml"), *(root / "scripts" / "heldout_scenes").glob(
        "*.toml"), *(root / "scripts" / "denoiser_scenes").glob("heldout_*.toml")]
    assert len(photographs(train)) == 7 and photographs(scored)
    assert not photographs(train) & photographs(scored)
    twins = sorted((root / "scripts" / "denoiser_scenes").glob("train_static_*.toml"))
    assert len(twins) == len(train) - len(twins) == 12
    pytest.importorskip("skimage")
    for path in twins:
        scene = load_scene(path)
        assert scene.content.static, path.name
        assert scene.planes >= 200 + 2 * 200 + 100, path.name  # window_max + 2 margins + the target's 100


def test_the_fan_has_an_exact_flow():
    """Blades turn about the centre, the toys stay: the radiance at t_ref is found at x + flow at t_other wherever
    visible, and what the blades cover then is marked hidden (the fan's true-flow rungs and flow error use it)."""
    import numpy as np

    from spikeref.simulate.scenes import FanOverToys

    fan = FanOverToys(height=64, width=64, brightness=0.5, revolutions_per_second=25.0)
    flow, visible = fan.true_flow(100.0, 110.0)
    pts = np.stack(np.mgrid[0:64, 0:64][::-1], axis=-1).astype(float)
    target = pts + flow
    before, after = fan.radiance([100.0])[0], fan.radiance([110.0])[0]
    xi = np.clip(np.rint(target[..., 0]).astype(int), 0, 63)
    yi = np.clip(np.rint(target[..., 1]).astype(int), 0, 63)
    err = np.abs(after[yi, xi] - before).mean(axis=-1)
    assert err[visible].mean() < 0.01 < err[~visible].mean()
    assert 0.9 < visible.mean() < 1.0 and np.abs(flow).max() > 1.0  # the tips move; some toys are covered
    still = FanOverToys(height=64, width=64, revolutions_per_second=0.0)
    f, v = still.true_flow(0.0, 50.0)
    assert not f.any() and v.all()
