import os

import imageio.v3 as iio
import numpy as np
import pytest

from spikeref.io.exr import read_exr, write_exr
from spikeref.io.video import VideoWriter, write_png, write_video
from spikeref.render import FrameSink


@pytest.mark.parametrize("half", [False, True])
def test_exr_roundtrip_keeps_hdr(tmp_path, rng, half):
    frame = (rng.random((6, 10, 3)) * 1e4).astype(np.float32)
    write_exr(tmp_path / "f.exr", frame, half=half)
    back = read_exr(tmp_path / "f.exr")
    np.testing.assert_allclose(back, frame, rtol=1e-3 if half else 0)
    write_exr(tmp_path / "y.exr", frame[..., 0])
    assert read_exr(tmp_path / "y.exr").shape == (6, 10)
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        write_exr(tmp_path / "bad.exr", np.zeros((2, 2, 2)))


def test_png_and_videos_open_in_standard_readers(tmp_path, rng):
    frames = [(rng.random((30, 41, 3)) * 255).astype(np.uint8) for _ in range(4)]  # odd width on purpose
    write_png(tmp_path / "a.png", frames[0])
    np.testing.assert_array_equal(iio.imread(tmp_path / "a.png"), frames[0])
    write_video(tmp_path / "a.gif", frames, fps=10)
    assert iio.imread(tmp_path / "a.gif", index=None).shape[0] == 4
    write_video(tmp_path / "a.mp4", frames, fps=10)
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(tmp_path / "a.mp4"))
    meta = next(reader)
    assert meta["size"] == (42, 30) and sum(1 for _ in reader) == 4
    assert oct(os.stat(tmp_path / "a.mp4").st_mode & 0o777) != "0o600"  # normal permissions, not mkstemp's


def test_writers_reject_bad_frames_and_leave_nothing(tmp_path):
    with pytest.raises(TypeError, match="uint8"):
        write_png(tmp_path / "x.png", np.zeros((4, 4), np.float32))
    with pytest.raises(ValueError, match=".mp4 or .gif"):
        VideoWriter(tmp_path / "x.avi")
    with pytest.raises(FileNotFoundError, match="output folder does not exist"):
        VideoWriter(tmp_path / "missing" / "x.mp4")
    with pytest.raises(TypeError):
        with VideoWriter(tmp_path / "y.mp4") as writer:
            writer.append(np.zeros((4, 4, 3), np.float64))
    assert sorted(os.listdir(tmp_path)) == []


def test_frame_sink_uses_one_exposure(tmp_path):
    frames = [np.full((4, 6, 3), v, np.float32) for v in (0.1, 0.2, 0.4)]
    with FrameSink(tmp_path / "v.gif", tmp_path / "exr", fps=5, exposure_frames=2) as sink:
        for i, f in enumerate(frames):
            sink.add(i, f)
    shown = iio.imread(tmp_path / "v.gif", index=None)[..., :3]
    levels = shown.reshape(3, -1).mean(axis=1)
    assert levels[0] < levels[1] < levels[2]  # brightness follows the scene: no per-frame normalisation
    assert sorted(os.listdir(tmp_path / "exr")) == ["frame_000000.exr", "frame_000001.exr", "frame_000002.exr"]
