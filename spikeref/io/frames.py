"""Read a user's video or image sequence as frames (for the simulator's ``video`` scenes)."""

from __future__ import annotations

import glob
from pathlib import Path

import numpy as np

__all__ = ["read_frames", "IMAGE_SUFFIXES"]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".exr")


def _as_rgb(frame: np.ndarray, where: str) -> np.ndarray:
    frame = np.asarray(frame)
    if frame.ndim == 2:
        frame = np.repeat(frame[..., None], 3, axis=-1)
    if frame.ndim != 3 or frame.shape[-1] not in (3, 4):
        raise ValueError(f"{where}: expected an RGB image; got shape {frame.shape}")
    return frame[..., :3]


def read_frames(path, max_frames: int | None = None) -> np.ndarray:
    """Frames ``(N, H, W, 3)`` from a video file, a folder of images (sorted by name) or a glob.

    Values are as stored (``uint8`` for 8-bit video and PNG/JPEG; float for EXR).  All
    frames must have the same size.  ``max_frames`` keeps the first frames only.
    """
    import imageio.v3 as iio

    if max_frames is not None and (isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 1):
        raise ValueError(f"max_frames must be a positive integer; got {max_frames!r}")
    path = Path(path)
    text = str(path)
    if any(c in text for c in "*?["):
        files = [Path(p) for p in sorted(glob.glob(text))]
        if not files:
            raise FileNotFoundError(f"no files match {text}")
    elif path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise FileNotFoundError(f"no images ({', '.join(IMAGE_SUFFIXES)}) in folder {path}")
    elif path.is_file():
        files = None
    else:
        raise FileNotFoundError(f"no such video, folder or glob: {path}")
    frames = []
    if files is None:
        try:
            for frame in iio.imiter(path):
                frames.append(_as_rgb(frame, str(path)))
                if max_frames is not None and len(frames) >= max_frames:
                    break
        except (OSError, ValueError, RuntimeError) as exc:
            raise ValueError(f"{path}: cannot read as a video or image ({exc})") from None
    else:
        for f in files[:max_frames]:
            if f.suffix.lower() == ".exr":
                from spikeref.io.exr import read_exr

                frames.append(_as_rgb(read_exr(f), str(f)))
            else:
                try:
                    frames.append(_as_rgb(iio.imread(f), str(f)))
                except (OSError, ValueError, RuntimeError) as exc:
                    raise ValueError(f"{f}: cannot read as an image ({exc})") from None
    if not frames:
        raise ValueError(f"{path}: no frames")
    shapes = {f.shape for f in frames}
    if len(shapes) != 1:
        raise ValueError(f"{path}: frames differ in size ({sorted(shapes)})")
    return np.stack(frames)
