"""Read a user's video or image sequence as frames (the input of the simulator's ``video`` scenes).

Only reading lives here; decoding sRGB, resizing and scaling to radiance are done by
:mod:`spikeref.simulate.scene_media` when a scene file's ``video`` or ``image`` scene is built.
"""

from __future__ import annotations

import glob
from pathlib import Path

import numpy as np
import imageio.v3 as iio
from spikeref.io.exr import read_exr

__all__ = ["read_frames", "IMAGE_SUFFIXES"]

#: File name endings taken as images when ``path`` is a folder (compared in lower case).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".exr")


def _as_rgb(frame: np.ndarray, where: str) -> np.ndarray:
    """``(H, W)``, ``(H, W, 1)``, ``(H, W, 3)`` or ``(H, W, 4)`` → ``(H, W, 3)`` (grey repeated, alpha dropped)."""
    frame = np.asarray(frame)
    if frame.ndim == 3 and frame.shape[-1] == 1:
        frame = frame[..., 0]
    if frame.ndim == 2:
        frame = np.repeat(frame[..., None], 3, axis=-1)
    if frame.ndim != 3 or frame.shape[-1] not in (3, 4):
        raise ValueError(f"{where}: expected a grey, RGB or RGBA image; got an array of shape {frame.shape}")
    return frame[..., :3]


def _list_images(path: Path) -> list[Path] | None:
    """The image files that ``path`` names (a glob or a folder), or ``None`` for a single file."""
    text = str(path)
    if any(c in text for c in "*?["):
        files = [Path(p) for p in sorted(glob.glob(text)) if Path(p).is_file()]
        if not files:
            raise FileNotFoundError(f"no files match {text}")
        return files
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise FileNotFoundError(f"no images ({', '.join(IMAGE_SUFFIXES)}) in folder {path}")
        return files
    if path.is_file():
        return None
    raise FileNotFoundError(f"no such video, folder or glob: {path}")


def read_frames(path, max_frames: int | None = None) -> np.ndarray:
    """Frames of a video file, a folder of images or a glob of images.

    Parameters
    ----------
    path : str or Path
        A video or single image readable by imageio (``.mp4``, ``.gif``, ``.png``, ...), a folder
        (its files ending in one of :data:`IMAGE_SUFFIXES`, sorted by name) or a glob pattern such
        as ``"frames/*.png"`` (sorted by name).
    max_frames : int, optional
        Keep only the first ``max_frames`` frames (≥ 1); the rest is not read.

    Returns
    -------
    ndarray ``(N, H, W, 3)``
        Values as stored: ``uint8`` for 8-bit video, PNG and JPEG, ``uint16`` for 16-bit PNG/TIFF,
        float for OpenEXR.  Grey images are repeated to three channels and alpha is dropped.

    Raises
    ------
    FileNotFoundError
        The path does not exist, the folder holds no images or the glob matches nothing.
    ValueError
        A file cannot be decoded, holds no frames, or the frames differ in size.
    """
    if max_frames is not None and (
        isinstance(max_frames, bool) or not isinstance(max_frames, (int, np.integer)) or max_frames < 1
    ):
        raise ValueError(f"max_frames must be a positive integer; got {max_frames!r}")
    path = Path(path).expanduser()
    files = _list_images(path)
    frames = []
    if files is None:
        try:
            for frame in iio.imiter(path):
                frames.append(_as_rgb(frame, str(path)))
                if max_frames is not None and len(frames) >= max_frames:
                    break
        except (OSError, ValueError, RuntimeError, KeyError, IndexError) as exc:
            raise ValueError(f"{path}: cannot read as a video or image ({exc})") from None
    else:
        for f in files[:max_frames]:
            try:
                if f.suffix.lower() == ".exr":
                    image = read_exr(f)
                else:
                    image = iio.imread(f)
            except (OSError, ValueError, RuntimeError, KeyError, IndexError) as exc:
                raise ValueError(f"{f}: cannot read as an image ({exc})") from None
            frames.append(_as_rgb(image, str(f)))
    if not frames:
        raise ValueError(f"{path}: no frames")
    shapes = sorted({f.shape for f in frames})
    if len(shapes) != 1:
        raise ValueError(f"{path}: frames differ in size ({', '.join('×'.join(map(str, s[:2])) for s in shapes)})")
    return np.stack(frames)
