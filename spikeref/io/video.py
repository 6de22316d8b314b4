"""Display outputs: PNG stills and MP4/GIF videos of 8-bit sRGB frames.

Frames given here are already display-encoded ``uint8`` (see
:func:`spikeref.tonemap.tonemap`).  Files are written atomically: a video is
encoded into a temporary file beside the target and renamed when closed, so
an interrupted run never leaves a truncated video under the final name.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import imageio.v3 as iio
import imageio_ffmpeg

from spikeref.io.atomic import atomic_write, publish, temporary_beside

__all__ = ["write_png", "VideoWriter", "write_video"]

VIDEO_SUFFIXES = (".mp4", ".gif")


def _as_uint8_image(frame: np.ndarray, name: str = "frame") -> np.ndarray:
    arr = np.asarray(frame)
    if arr.dtype != np.uint8:
        raise TypeError(f"{name} must be uint8 display values (use spikeref.tonemap first); got {arr.dtype}")
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] not in (3, 4)):
        raise ValueError(f"{name} must have shape (H, W), (H, W, 3) or (H, W, 4); got {arr.shape}")
    return arr


def write_png(path, frame: np.ndarray) -> Path:
    """Write an 8-bit PNG, atomically."""
    arr = _as_uint8_image(frame)
    return atomic_write(path, lambda tmp: iio.imwrite(tmp, arr, extension=".png"))


class VideoWriter:
    """Append ``uint8`` frames to an MP4 (H.264 via imageio-ffmpeg) or GIF; atomic on close.

    Parameters
    ----------
    path : str or Path
        ``.mp4`` or ``.gif``.
    fps : float
        Playback rate of the file (a 2000 FPS reconstruction is usually played
        slowed down, e.g. at 30 or 60 FPS).
    """

    def __init__(self, path, fps: float = 30.0):
        self.path = Path(path)
        self.suffix = self.path.suffix.lower()
        if self.suffix not in VIDEO_SUFFIXES:
            raise ValueError(f"video output must end in .mp4 or .gif; got {self.path.name!r}")
        if not np.isfinite(fps) or fps <= 0:
            raise ValueError(f"fps must be positive; got {fps!r}")
        self.fps = float(fps)
        self._tmp = temporary_beside(self.path)
        self._frames_gif: list[np.ndarray] = []
        self._writer = None
        self.count = 0

    def append(self, frame: np.ndarray) -> None:
        arr = _as_uint8_image(frame)
        if arr.ndim == 2:
            arr = np.repeat(arr[..., None], 3, axis=2)
        arr = arr[..., :3]
        if self.suffix == ".gif":
            self._frames_gif.append(arr)
        else:
            if self._writer is None:
                h, w = arr.shape[:2]
                # H.264 yuv420p needs even sizes: pad by one edge row/column if needed
                self._pad = (h % 2, w % 2)
                self._writer = imageio_ffmpeg.write_frames(
                    str(self._tmp), (w + self._pad[1], h + self._pad[0]), fps=self.fps,
                    codec="libx264", pix_fmt_out="yuv420p", quality=8, macro_block_size=1,
                    output_params=["-f", "mp4"],
                )
                self._writer.send(None)
            if any(self._pad):
                arr = np.pad(arr, ((0, self._pad[0]), (0, self._pad[1]), (0, 0)), mode="edge")
            self._writer.send(np.ascontiguousarray(arr))
        self.count += 1

    def close(self) -> Path:
        """Finish the file and move it to its final name (nothing if no frame was written)."""
        try:
            if self.count == 0:
                raise ValueError(f"no frames were written to {self.path}")
            if self.suffix == ".gif":
                iio.imwrite(self._tmp, np.stack(self._frames_gif), extension=".gif",
                            duration=1000.0 / self.fps, loop=0)
            else:
                self._writer.close()
            publish(self._tmp, self.path)
        finally:
            self._tmp.unlink(missing_ok=True)
        return self.path

    def abort(self) -> None:
        """Discard the partial file."""
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:
                pass
        self._tmp.unlink(missing_ok=True)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:
            self.abort()
        return False


def write_video(path, frames, fps: float = 30.0) -> Path:
    """Write a sequence of ``uint8`` frames to ``.mp4`` or ``.gif``."""
    with VideoWriter(path, fps) as writer:
        for frame in frames:
            writer.append(frame)
    return writer.path
