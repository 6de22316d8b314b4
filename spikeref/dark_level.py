"""The dark level: what the sensor fires without light, measured on a dark recording and taken out of the output.

Paper §4.1, Eq. 9: a window's expected rate is ``E[I_c] = L + E[N]/W`` with ``E[N]/W = αγ/E_th + C_i`` — the
diffuse noise (dark current, Eq. 5–6) and the inherent noise (Eq. 7–8).  The paper's denoiser is trained to
give ``E[I_c]`` (the zero-mean hypothesis), so its frames keep ``E[N]/W``: a raw photograph's black level, added
to every pixel (10 % of white in the bench's low light).  No frame of the recording can tell it from light.

Not in the paper: the same term measured where ``L = 0`` — a recording made with the lens covered, the one
``spikeref calibrate`` already reads for the hot pixels — and subtracted from every output frame, as a raw
pipeline subtracts the black level its camera's metadata gives.

Measurement (:func:`measure_dark_level`): per 2×2 phase of the mosaic (the four Bayer planes, in plane order
(0,0), (0,1), (1,0), (1,1); a monochrome sensor's four phases alike), the mean firing rate — spikes per
readout, Eq. 4's ``M_c = 1`` — of the phase's pixels that are not hot (:mod:`spikeref.hot_pixels` replaces
those; their rate is not the sensor's floor) over ``planes`` readouts.  One level per phase, not per pixel:
the pipeline's frames merge samples of many sensor pixels wherever the scene moves, and a per-pixel map of a
short dark recording is mostly its own noise (``docs/results.md``, "The dark level").

Subtraction (:func:`subtract_dark_level`): each output pixel loses the level of its colour — for a colour frame
the mean of the colour's phases (green: two), for a monochrome frame its own phase's — and is clipped at 0
(light is never negative; the clip only lowers the error).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spikeref._checks import whole_number
from spikeref.accumulate import window_counts
from spikeref.bayer import cfa_channels
from spikeref.hot_pixels import HotPixelParams, hot_pixel_excess
from spikeref.stream import SpikeStream, as_stream

__all__ = ["DARK_PLANES", "DARK_MIN_EXCESS", "DARK_LEVEL_MAX", "calibrate_dark", "measure_dark_level",
           "dark_level_oracle", "check_dark_level", "colour_levels", "subtract_dark_level", "load_dark_level"]


#: Above this rate (spikes per readout, any phase) a "dark" recording is not dark: a pixel of a spike camera fires
#: without light at well under 0.01 (the paper's Fig. 4; the bench's sensors 0.0002–0.004), so ``spikeref calibrate``
#: warns and ``--dark-level`` refuses such a map.
DARK_LEVEL_MAX = 0.05
#: Readouts of a dark recording read by default: 1 s at 20 kHz.
DARK_PLANES = 20000
#: The hot-pixel test on a dark recording: the least excess over the same-colour reference, spikes per readout.  No
#: scene can mimic a defect there, so the statistical test (6 σ in the stretch, half the blocks) decides down to a
#: weak leak.
DARK_MIN_EXCESS = 0.02


def calibrate_dark(stream, planes: int = DARK_PLANES) -> dict:
    """A dark recording's calibration: its hot pixels and its dark level (what ``spikeref calibrate`` writes).

    Parameters
    ----------
    stream : SpikeStream or ndarray ``(T, H, W)``
        Recorded with the lens covered; even ``H`` and ``W``.
    planes : int
        Readouts read from the start (at most).

    Returns
    -------
    dict
        ``hot`` ``(H, W) bool`` (:func:`spikeref.hot_pixels.hot_pixel_excess` with ``min_excess`` =
        :data:`DARK_MIN_EXCESS`), ``excess`` ``(H, W)`` (each pixel's excess over its colour, spikes per readout),
        ``dark_level`` ``(4,)`` (:func:`measure_dark_level`'s mean without the hot pixels, from the rates the
        hot-pixel test read: the recording is read once; its stretch is the whole blocks of ``planes``) and
        ``planes`` (asked for, at most the recording's length).
    """
    stream = as_stream(stream)
    planes = whole_number(planes, "planes", 8, "a number of readouts ≥ 8")
    found = hot_pixel_excess(stream, params=HotPixelParams(planes=planes, min_excess=DARK_MIN_EXCESS))
    return {"hot": found["hot"], "excess": found["excess"], "planes": min(planes, len(stream)),
            "dark_level": _phase_means(found["rate"], ~found["hot"])}


def check_dark_level(level, name: str = "dark_level") -> np.ndarray:
    """``level`` as a ``(4,) float64`` array of finite rates in ``[0, 1)`` (spikes per readout), or a clear error."""
    try:
        arr = np.asarray(level, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be four numbers (spikes per readout per 2×2 phase); got {level!r}") from None
    if arr.shape != (4,):
        raise ValueError(f"{name} must hold one rate per 2×2 phase (4 values); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or arr.min() < 0 or arr.max() >= 1:
        raise ValueError(f"{name} must be rates in [0, 1) spikes per readout; got {arr.tolist()}")
    return arr


def _phase_means(rate: np.ndarray, keep: np.ndarray) -> np.ndarray:
    out = np.zeros(4, dtype=np.float64)
    for p, (dy, dx) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
        r, k = rate[dy::2, dx::2], keep[dy::2, dx::2]
        out[p] = float(r[k].mean()) if k.any() else float(r.mean())
    return out


def measure_dark_level(stream, planes: int = DARK_PLANES, start: int = 0, hot=None) -> np.ndarray:
    """The dark level of a recording made without light: each 2×2 phase's mean rate, its hot pixels left out.

    Parameters
    ----------
    stream : SpikeStream or ndarray ``(T, H, W)``
        A dark recording (lens covered) of the sensor, even ``H`` and ``W``.
    planes : int
        Readouts read from ``start`` (at most; the stream may be shorter).  20 000 = 1 s at 20 kHz: at the
        bench's dark current (0.002 spikes per readout) a phase of 64 × 64 pixels counts ≈ 160 000 dark spikes,
        a relative error of 0.25 %.
    start : int
        First readout.
    hot : ndarray ``(H, W) bool``, optional
        Pixels to leave out (a hot-pixel map of the same recording, :func:`spikeref.hot_pixels.find_hot_pixels`);
        a phase whose every pixel is hot keeps them all.

    Returns
    -------
    ndarray ``(4,) float64``
        ``E[N]/W`` of Eq. 9 per phase, in plane order (0,0), (0,1), (1,0), (1,1); spikes per readout.
    """
    stream = as_stream(stream)
    if not isinstance(stream, SpikeStream):  # pragma: no cover - as_stream raises first
        raise TypeError("stream must be a SpikeStream or a (T, H, W) array")
    if stream.height % 2 or stream.width % 2:
        raise ValueError(f"the recording must have even height and width (2×2 phases); got {stream.height}×"
                         f"{stream.width}")
    planes = whole_number(planes, "planes", 1, "a number of readouts ≥ 1")
    start = whole_number(start, "start", 0, "a readout ≥ 0")
    if start >= len(stream):
        raise ValueError(f"start ({start}) must be inside the recording of {len(stream)} planes")
    n = min(planes, len(stream) - start)
    keep = np.ones((stream.height, stream.width), dtype=bool)
    if hot is not None:
        hot = np.asarray(hot)
        if hot.dtype != bool or hot.shape != keep.shape:
            raise ValueError(f"hot must be a ({stream.height}, {stream.width}) bool map; got {hot.dtype} of shape "
                             f"{hot.shape}")
        keep = ~hot
    rate = window_counts(stream, n, start=start, count=1)[0].astype(np.float64) / n
    return _phase_means(rate, keep)


def dark_level_oracle(spikes: np.ndarray, hot: np.ndarray | None = None) -> np.ndarray:
    """Literal :func:`measure_dark_level` over all of ``spikes`` ``(T, H, W)``: for each phase, the spikes of its
    pixels that are not hot, summed, over (those pixels × T readouts)."""
    spikes = np.asarray(spikes)
    T, H, W = spikes.shape
    out = []
    for dy, dx in ((0, 0), (0, 1), (1, 0), (1, 1)):
        total, pixels = 0, 0
        for y in range(dy, H, 2):
            for x in range(dx, W, 2):
                if hot is None or not hot[y, x]:
                    total += int(spikes[:, y, x].sum())
                    pixels += 1
        if pixels == 0:  # every pixel of the phase hot: all of them, as measure_dark_level
            total = int(spikes[:, dy::2, dx::2].sum())
            pixels = spikes[0, dy::2, dx::2].size
        out.append(total / (pixels * T))
    return np.asarray(out)


def colour_levels(level, cfa: str) -> np.ndarray:
    """The level of each RGB colour ``(3,)``: the mean of its phases' levels under ``cfa`` (green: two)."""
    level = check_dark_level(level)
    ch = np.asarray(cfa_channels(cfa))
    return np.array([level[ch == c].mean() for c in range(3)])


def subtract_dark_level(image: np.ndarray, level, cfa: str | None) -> np.ndarray:
    """``image`` minus the dark level, clipped at 0, ``float32``.

    Parameters
    ----------
    image : ndarray ``(H, W, 3)`` (colour, with ``cfa``) or ``(H, W)`` (monochrome, ``cfa=None``)
        An output frame in firing-rate units (spikes per readout).
    level : array_like ``(4,)``
        Per 2×2 phase (:func:`measure_dark_level`).
    cfa : str or None
        The sensor's CFA; None for a monochrome sensor, whose pixel ``(y, x)`` loses its phase's level.
    """
    level = check_dark_level(level)
    image = np.asarray(image)
    if cfa is None:
        if image.ndim != 2 or image.shape[0] % 2 or image.shape[1] % 2:
            raise ValueError(f"a monochrome frame must be (H, W) with even H and W; got shape {image.shape}")
        h, w = image.shape
        sub = np.tile(level.reshape(2, 2), (h // 2, w // 2))
    else:
        if image.ndim != 3 or image.shape[2] != 3:
            raise ValueError(f"a colour frame must be (H, W, 3); got shape {image.shape}")
        sub = colour_levels(level, cfa)
    return np.maximum(image - sub.astype(np.float32), np.float32(0)).astype(np.float32, copy=False)


def load_dark_level(path, shape: tuple[int, int] | None = None) -> np.ndarray:
    """The dark level stored by ``spikeref calibrate`` in its map ``.npz`` (array ``dark_level``, ``(4,)``).

    ``shape``, if given, is checked against the map's recorded ``height`` and ``width`` (the same sensor); a level
    above :data:`DARK_LEVEL_MAX` is refused (a map made from a lit recording).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such calibration map: {path}")
    try:
        with np.load(path) as data:
            files = list(data.files)
            level = np.asarray(data["dark_level"]) if "dark_level" in files else None
            size = tuple(int(data[k]) for k in ("height", "width")) if {"height", "width"} <= set(files) \
                else None
    except (OSError, EOFError, ValueError, AttributeError, TypeError) as exc:
        raise ValueError(f"{path}: not a readable calibration map ({exc})") from None
    if level is None:
        raise ValueError(f"{path}: no dark level in this map (found {files}); make it again with spikeref "
                         f"calibrate DARK -o {path.name}")
    level = check_dark_level(level, f"{path}: dark_level")
    if shape is not None and size is not None and size != tuple(shape):
        raise ValueError(f"{path}: a map of {size[0]}×{size[1]} pixels for a recording of {shape[0]}×{shape[1]}")
    if level.max() > DARK_LEVEL_MAX:
        raise ValueError(f"{path}: a dark level of {level.max():.4f} spikes per readout is not a dark recording's "
                         f"(above {DARK_LEVEL_MAX}); calibrate on a recording made with the lens covered")
    return level
