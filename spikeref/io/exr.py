"""OpenEXR output for linear HDR frames (float16 or float32, RGB or Y)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenEXR

from spikeref.io.atomic import atomic_write

__all__ = ["write_exr", "read_exr"]


def write_exr(path, frame: np.ndarray, half: bool = False) -> Path:
    """Write a linear frame ``(H, W, 3)`` (RGB) or ``(H, W)`` (Y) to an EXR file, atomically.

    Parameters
    ----------
    half : bool
        Store float16 (half the size; 11-bit mantissa, max 65504) instead of float32.
    """
    arr = np.asarray(frame)
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] != 3):
        raise ValueError(f"frame must have shape (H, W, 3) or (H, W); got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating) and not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"frame must be real-valued; got {arr.dtype}")
    arr = np.ascontiguousarray(arr, dtype=np.float16 if half else np.float32)
    channels = {"RGB": arr} if arr.ndim == 3 else {"Y": arr}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}

    def _write(tmp):
        with OpenEXR.File(header, channels) as f:
            f.write(str(tmp))

    return atomic_write(path, _write)


def read_exr(path) -> np.ndarray:
    """Read an EXR written by :func:`write_exr` (or any RGB/Y scanline EXR) as float32."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such EXR file: {path}")
    try:
        with OpenEXR.File(str(path)) as f:
            channels = f.channels()
            if "RGB" in channels:
                return np.asarray(channels["RGB"].pixels, dtype=np.float32)
            if "Y" in channels:
                return np.asarray(channels["Y"].pixels, dtype=np.float32)
            if all(c in channels for c in "RGB"):
                return np.stack([np.asarray(channels[c].pixels, np.float32) for c in "RGB"], axis=-1)
            found = sorted(channels)
    except (RuntimeError, ValueError) as exc:  # OpenEXR's errors for an empty, truncated or foreign file
        raise ValueError(f"{path}: not a readable EXR file ({exc})") from None
    raise ValueError(f"{path}: no RGB or Y channels (found {found})")

