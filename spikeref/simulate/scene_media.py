"""The video and photographs a scene file names: read, decoded, resized and scaled to radiance.

The only file I/O of the scenes.  :func:`~spikeref.simulate.scenes.scene_from_dict` hands the
``[content]`` table of a ``video`` scene to :func:`video_from_table` and that of an ``image`` scene
to :func:`image_from_table`; both read with :func:`spikeref.io.frames.read_frames`, decode sRGB to
linear (:func:`spikeref.tonemap.srgb_decode`), resize with :func:`resample_matrix` (area average
when shrinking, bilinear when enlarging) and scale to radiance by ``brightness``, then build the
content (:class:`~spikeref.simulate.video_frames.VideoFrames`,
:class:`~spikeref.simulate.photographs.ImageMotion`), which remembers the path and options so that
:func:`~spikeref.simulate.scenes.scene_to_dict` writes them again (:func:`image_to_table`).  The
fields of each table are :data:`VIDEO_KEYS` and :data:`IMAGE_KEYS`; a photograph may be named
``skimage:NAME`` (:data:`SKIMAGE_PREFIX`).  Errors are ``ValueError`` (or ``FileNotFoundError``)
naming the field path (``content.path``, ``content.foreground.radius``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy import sparse

from spikeref.io.frames import read_frames
from spikeref.simulate.content import (
    SceneContent, check_even_size, check_integer, check_number, coerce_field, is_number,
)
from spikeref.simulate.motion import Motion
from spikeref.simulate.photographs import ImageMotion
from spikeref.simulate.video_frames import VideoFrames
from spikeref.tonemap import srgb_decode

__all__ = [
    "VIDEO_KEYS",
    "IMAGE_KEYS",
    "SKIMAGE_PREFIX",
    "resample_matrix",
    "video_from_table",
    "image_from_table",
    "image_to_table",
]

#: The fields of a ``video`` content's table in a scene file.
VIDEO_KEYS = ("path", "fps", "brightness", "srgb", "max_frames", "height", "width")


def resample_matrix(n_in: int, n_out: int):
    """Sparse ``(n_out, n_in)`` resampling along one axis: area average when shrinking, bilinear when enlarging.

    Parameters
    ----------
    n_in, n_out : int
        Pixels along the axis before and after; enlarging aligns the pixel centres and clamps at the ends.

    Returns
    -------
    scipy.sparse.csr_matrix
        ``M`` such that ``M @ x`` resamples ``x`` ``(n_in, ...)`` along its first axis.
    """
    rows, cols, vals = [], [], []
    if n_out <= n_in:
        scale = n_in / n_out
        for j in range(n_out):
            a, b = j * scale, (j + 1) * scale
            for i in range(int(math.floor(a)), min(int(math.ceil(b)), n_in)):
                overlap = min(b, i + 1) - max(a, i)
                if overlap > 0:
                    rows.append(j)
                    cols.append(i)
                    vals.append(overlap / scale)
    else:
        x = np.clip((np.arange(n_out) + 0.5) * n_in / n_out - 0.5, 0, n_in - 1)  # pixel centres aligned
        i0 = np.floor(x).astype(np.int64)
        i1 = np.minimum(i0 + 1, n_in - 1)
        rows = np.concatenate([np.arange(n_out), np.arange(n_out)])
        cols = np.concatenate([i0, i1])
        vals = np.concatenate([1 - (x - i0), x - i0])
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n_out, n_in))


def video_from_table(table: dict, rate_hz: float, base_dir: Path | None) -> VideoFrames:
    """Read, decode, resize and scale a scene file's ``video`` content (with :func:`image_from_table`, the only
    file I/O of scenes).

    Parameters
    ----------
    table : dict
        The ``[content]`` table without its ``type``: the fields :data:`VIDEO_KEYS`.
    rate_hz : float
        The camera's readout rate.
    base_dir : Path or None
        Folder that a relative ``path`` is relative to (the current folder if None).

    Returns
    -------
    VideoFrames
        The frames as radiance, remembering ``path`` and the options they were read with.
    """
    if "path" not in table:
        raise ValueError("content.path is required for type 'video' (a video file, a folder of images or a glob)")
    if "fps" not in table:
        raise ValueError("content.fps is required for type 'video' (the source frame rate, frames per second)")
    if not isinstance(table["path"], str) or not table["path"]:
        raise ValueError(f"content.path must be a non-empty string; got {table['path']!r}")
    fps = check_number("fps", table["fps"], minimum=0, open_min=True)
    brightness = check_number("brightness", table.get("brightness", 0.5), minimum=0)
    srgb = table.get("srgb", True)
    if not isinstance(srgb, bool):
        raise ValueError(f"content.srgb must be true or false; got {srgb!r}")
    max_frames = table.get("max_frames")
    if max_frames is not None:
        max_frames = check_integer("max_frames", max_frames, 1)
    size = {k: check_even_size(k, coerce_field(SceneContent, k, table[k])) for k in ("height", "width") if k in table}
    path = Path(table["path"]).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    try:
        raw = read_frames(path, max_frames=max_frames)
    except FileNotFoundError as exc:
        raise FileNotFoundError(f"content.path: {exc}") from None
    except ValueError as exc:
        raise ValueError(f"content.path: {exc}") from None
    n, src_h, src_w, _ = raw.shape
    if np.issubdtype(raw.dtype, np.integer):
        unit = np.float32(1.0 / np.iinfo(raw.dtype).max)
    elif np.issubdtype(raw.dtype, np.floating):
        unit = np.float32(1.0)
        if not np.all(np.isfinite(raw)):
            raise ValueError(f"content.path: {path} holds non-finite values")
    else:
        raise ValueError(f"content.path: {path} holds {raw.dtype} pixels; expected integers or floats")
    if size:  # resize; one size given keeps the aspect ratio (rounded to even)
        h = size.get("height") or max(2, 2 * round(size["width"] * src_h / src_w / 2))
        w = size.get("width") or max(2, 2 * round(size["height"] * src_w / src_h / 2))
        along_y, along_x = resample_matrix(src_h, h), resample_matrix(src_w, w)
    else:  # a Bayer sensor needs even sizes: an odd source loses its last row or column
        h, w = src_h // 2 * 2, src_w // 2 * 2
        if h < 2 or w < 2:
            raise ValueError(f"content.path: frames of {src_h}×{src_w} are too small (at least 2×2)")
    frames = np.empty((n, h, w, 3), dtype=np.float32)
    for k in range(n):  # frame by frame: memory holds the source once, not a float copy of it
        linear = raw[k].astype(np.float32) * unit
        linear = srgb_decode(linear) if srgb else np.maximum(linear, 0)
        if size:
            linear = (along_y @ linear.reshape(src_h, -1)).reshape(h, src_w, 3)
            linear = (along_x @ linear.transpose(1, 0, 2).reshape(src_w, -1)).reshape(w, h, 3).transpose(1, 0, 2)
        else:
            linear = linear[:h, :w]
        frames[k] = linear * brightness
    options = {"brightness": table.get("brightness", 0.5), "srgb": srgb}
    options.update({k: table[k] for k in ("max_frames", "height", "width") if k in table})
    return VideoFrames(frames=frames, fps=fps, rate_hz=rate_hz, source=str(path),
                       source_options=tuple(sorted(options.items())))


#: The fields of an ``image`` content's table in a scene file (``foreground``: a table of its own).
IMAGE_KEYS = ("path", "brightness", "srgb", "scale", "height", "width", "origin", "motion", "foreground")
_FOREGROUND_KEYS = ("path", "brightness", "srgb", "scale", "radius", "center", "source_center", "motion")
#: Scene files may name a photograph bundled with scikit-image as ``skimage:NAME`` (the test extra).
SKIMAGE_PREFIX = "skimage:"


def _resolve_image_path(text: str, base_dir: Path | None, name: str) -> Path:
    """A scene file's image path: a file (relative to the scene file's folder) or ``skimage:NAME``."""
    if not isinstance(text, str) or not text:
        raise ValueError(f"{name} must be a non-empty string; got {text!r}")
    if text.startswith(SKIMAGE_PREFIX):
        key = text[len(SKIMAGE_PREFIX):]
        try:
            import skimage.data
        except ImportError:
            raise ValueError(f"{name} = {text!r} needs scikit-image (pip install \"spikeref[test]\")") from None
        folder = Path(skimage.data.__file__).parent
        found = sorted(p for p in folder.iterdir() if p.stem == key and p.suffix.lower() in (".png", ".jpg"))
        if not found:
            names = sorted({p.stem for p in folder.iterdir() if p.suffix.lower() in (".png", ".jpg")})
            raise ValueError(f"{name}: scikit-image bundles no photograph {key!r}; it has {', '.join(names)}")
        return found[0]
    path = Path(text).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    return path


def _read_photograph(table: dict, base_dir: Path | None, name: str) -> tuple:
    """Read, decode (sRGB → linear), rescale (area average / bilinear) and scale one photograph to radiance.

    Returns the radiance ``(h, w, 3) float32`` and how to name the file again (``skimage:NAME`` as
    given, otherwise the resolved path).
    """
    if "path" not in table:
        raise ValueError(f"{name}.path is required (an image file, or skimage:NAME for a scikit-image photograph)")
    path = _resolve_image_path(table["path"], base_dir, f"{name}.path")
    brightness = check_number("brightness", table.get("brightness", 0.5), minimum=0)
    srgb = table.get("srgb", True)
    if not isinstance(srgb, bool):
        raise ValueError(f"{name}.srgb must be true or false; got {srgb!r}")
    scale = table.get("scale", 1.0)
    if not is_number(scale) or not math.isfinite(scale) or not 0 < scale <= 4:
        raise ValueError(f"{name}.scale must be a number in (0, 4]; got {scale!r}")
    try:
        raw = read_frames(path, max_frames=1)[0]
    except FileNotFoundError as exc:
        raise FileNotFoundError(f"{name}.path: {exc}") from None
    except ValueError as exc:
        raise ValueError(f"{name}.path: {exc}") from None
    if np.issubdtype(raw.dtype, np.integer):
        linear = raw.astype(np.float32) / np.float32(np.iinfo(raw.dtype).max)
    else:
        linear = raw.astype(np.float32)
        if not np.all(np.isfinite(linear)):
            raise ValueError(f"{name}.path: {path} holds non-finite values")
    linear = srgb_decode(linear) if srgb else np.maximum(linear, 0)
    src_h, src_w = linear.shape[:2]
    if scale != 1.0:
        h, w = max(2, round(src_h * scale)), max(2, round(src_w * scale))
        along_y, along_x = resample_matrix(src_h, h), resample_matrix(src_w, w)
        linear = (along_y @ linear.reshape(src_h, -1)).reshape(h, src_w, 3)
        linear = (along_x @ linear.transpose(1, 0, 2).reshape(src_w, -1)).reshape(w, h, 3).transpose(1, 0, 2)
    text = table["path"]
    return (linear * brightness).astype(np.float32), text if text.startswith(SKIMAGE_PREFIX) else str(path)


def image_from_table(table: dict, rate_hz: float, base_dir: Path | None) -> ImageMotion:
    """Build a scene file's ``image`` content (reads the photographs: the scenes' only other file I/O).

    Parameters
    ----------
    table : dict
        The ``[content]`` table without its ``type``: the fields :data:`IMAGE_KEYS`, ``foreground`` a table
        of ``path``, ``brightness``, ``srgb``, ``scale``, ``radius``, ``center``, ``source_center``, ``motion``.
    rate_hz, base_dir :
        As for :func:`video_from_table` (the readout rate; the folder relative paths start from).

    Returns
    -------
    ImageMotion
        The photographs as radiance, remembering their paths and the options they were read with.
    """
    image, path = _read_photograph(table, base_dir, "content")
    if "height" not in table or "width" not in table:
        raise ValueError("content.height and content.width are required for type 'image' (the view, in pixels)")
    kw = {"height": coerce_field(SceneContent, "height", table["height"]),
          "width": coerce_field(SceneContent, "width", table["width"]),
          "origin": table.get("origin"), "motion": Motion.from_table(table.get("motion"), "content.motion")}
    fg_table = table.get("foreground")
    fg_options = None
    if fg_table is not None:
        if not isinstance(fg_table, dict):
            raise ValueError(f"content.foreground must be a table; got {fg_table!r}")
        unknown = sorted(set(fg_table) - set(_FOREGROUND_KEYS))
        if unknown:
            raise ValueError(f"unknown field content.foreground.{unknown[0]}; a foreground takes "
                             f"{', '.join(_FOREGROUND_KEYS)}")
        if "radius" not in fg_table:
            raise ValueError("content.foreground.radius is required (the disc's radius in pixels)")
        fg_image, fg_path = _read_photograph(fg_table, base_dir, "content.foreground")
        kw.update(fg_image=fg_image, fg_radius=fg_table["radius"], fg_center=fg_table.get("center"),
                  fg_source_center=fg_table.get("source_center"),
                  fg_motion=Motion.from_table(fg_table.get("motion"), "content.foreground.motion"))
        fg_options = {k: fg_table[k] for k in ("brightness", "srgb", "scale") if k in fg_table}
        fg_options["path"] = fg_path
    options = {k: table[k] for k in ("brightness", "srgb", "scale") if k in table}
    if fg_options is not None:
        options["foreground"] = tuple(sorted(fg_options.items()))
    return ImageMotion(image=image, rate_hz=rate_hz, source=path,
                       source_options=tuple(sorted(options.items())), **kw)


def image_to_table(content: ImageMotion) -> dict:
    """The scene-file table of an ``image`` content read from files (``ValueError`` for one built from arrays).

    Parameters
    ----------
    content : ImageMotion
        Made by :func:`image_from_table`.

    Returns
    -------
    dict
        The ``[content]`` table, with its ``type``, from which
        :func:`~spikeref.simulate.scenes.scene_from_dict` builds an equal content again.
    """
    if not content.source:
        raise ValueError("an image content built from arrays has no file to refer to; save the images and "
                         "load them with a scene file")
    options = dict(content.source_options)
    table = {"type": "image", "path": content.source, "height": content.height, "width": content.width,
             "origin": list(content.origin), "motion": content.motion.to_table()}
    fg = options.pop("foreground", None)
    table.update(options)
    if fg is not None:
        fg = dict(fg)
        fg.update(radius=content.fg_radius, center=list(content.fg_center),
                  source_center=list(content.fg_source_center),
                  motion=content.fg_motion.to_table())
        table["foreground"] = fg
    return table
