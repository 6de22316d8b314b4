"""Hot pixels: found in the recording itself, and replaced in every window before anything else reads it.

Not in the paper.  A real sensor has defect pixels that collect charge without light (EMVA 1288's
"defect pixels"; the simulator's ``hot_pixels`` effect): they fire far above their light, at the same
place in every window.  Left in, each one is a bright dot in the output and, worse, a fixed feature
that pins the alignment to zero motion.  Burst photography removes them before alignment; this module
does the same for spikes.

Detection (:func:`find_hot_pixels`), on a stretch of the recording (its first
:attr:`HotPixelParams.planes` planes from ``start``, cut into :attr:`HotPixelParams.blocks` equal
blocks):

1. each block's firing rate ``r_b(x) = count / n_b`` (spikes per readout, Eq. 4's ``M_c = 1``);
2. the pixel's *excess* over its colour: ``e_b(x) = r_b(x) − med_b(x)``, where ``med_b`` is the median
   (the 5th smallest, as :func:`scipy.ndimage.median_filter` ranks an even set) of its 8 neighbours of
   the same Bayer phase — two pixels away in the mosaic, so the same colour filter on a colour sensor;
3. a *candidate* stands out in **every** block: ``e_b(x) > max(min_excess, sigmas · σ_b(x))`` with
   ``σ_b = sqrt(m (1 − m) / n_b)`` the binomial standard deviation of a rate ``m = med_b(x)`` (clipped
   to ``[1/n_b, 1 − 1/n_b]``) over ``n_b`` readouts — a moving bright point stands out in some blocks
   only;
4. a *hot pixel* is a candidate that stands alone: the excess of each of its 8 mosaic neighbours
   (other colours, over the whole stretch) is below ``neighbour_ratio`` times its own — light from
   the scene, even a point, reaches the neighbouring photosites of the other colours through the
   optics (and the demosaic of a colour scene needs it there), a defect does not.

A monochrome stream is split into the same four 2×2 phases (so "same colour" is "same phase").

Repair (:class:`HotPixelRepair`): every hot pixel's value in a window — count, charge or rate, in the
mosaic or in the four Bayer planes — is replaced by the mean of its same-colour neighbours (the 8
pixels two away in the mosaic) that are inside the image and not hot themselves; a hot pixel with no
such neighbour is left as it is.  The pipeline applies it to every window it accumulates, before the
denoiser, the alignment and the warp see it (:class:`spikeref.pipeline.Reconstructor`).

A dark recording gives the map directly (``spikeref calibrate DARK -o map.npz``): the same detector,
where the scene cannot hide or mimic anything.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.ndimage import maximum_filter, rank_filter

from spikeref._checks import finite_number, whole_number
from spikeref.accumulate import window_counts
from spikeref.io.atomic import atomic_write
from spikeref.stream import SpikeStream, as_stream

__all__ = ["HotPixelParams", "find_hot_pixels", "hot_pixel_excess", "hot_pixels_to_replace", "HotPixelRepair",
           "repair_oracle",
           "save_hot_pixel_map", "load_hot_pixel_map"]

#: The 8 same-colour neighbours of a mosaic pixel: offsets of two pixels in each direction.
_SAME_COLOUR = tuple((2 * dy, 2 * dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dy, dx) != (0, 0))
#: A 3×3 footprint without its centre (the 8 neighbours of a pixel within one Bayer plane).
_RING = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]], dtype=bool)


@dataclass(frozen=True)
class HotPixelParams:
    """How :func:`find_hot_pixels` reads the recording and what counts as hot.

    Attributes
    ----------
    planes : int
        Readouts read from ``start`` (at most; fewer when the recording is shorter): 2000 = 0.1 s.
    blocks : int
        Equal blocks the stretch is cut into; a hot pixel stands out in every one.
    min_excess : float
        Least excess over the same-colour median, in spikes per readout, in every block.
    sigmas : float
        Least excess in binomial standard deviations of a block's rate at the median's level.
    neighbour_ratio : float
        A candidate whose strongest mosaic neighbour (another colour) has at least this share of its
        excess is a spot of light, not a defect.
    """

    planes: int = 2000
    blocks: int = 4
    min_excess: float = 0.1
    sigmas: float = 6.0
    neighbour_ratio: float = 0.3

    def __post_init__(self):
        for name in ("planes", "blocks"):
            whole_number(getattr(self, name), name, 1, "a whole number ≥ 1")
        for name in ("min_excess", "sigmas", "neighbour_ratio"):
            finite_number(getattr(self, name), name)


def _phase_reference(rates: np.ndarray) -> np.ndarray:
    """The second largest of each pixel's 8 same-phase neighbours, ``(..., H, W)`` → same shape (mirrored edges)."""
    out = np.empty_like(rates)
    for dy in (0, 1):
        for dx in (0, 1):
            plane = rates[..., dy::2, dx::2]
            size = (1,) * (plane.ndim - 2)
            out[..., dy::2, dx::2] = rank_filter(plane, rank=-2, footprint=_RING.reshape(size + (3, 3)), mode="mirror")
    return out


def _block_rates(stream: SpikeStream, start: int, params: HotPixelParams) -> tuple[np.ndarray, int]:
    """``(blocks, H, W) float64`` rates of the stretch's blocks and the readouts each covers."""
    available = len(stream) - start
    n = min(params.planes, available)
    blocks = max(1, min(params.blocks, n))
    per = n // blocks
    counts = window_counts(stream, per, start=start, count=blocks)
    return counts.astype(np.float64) / per, per


def hot_pixel_excess(stream, start: int = 0, params: HotPixelParams = HotPixelParams()) -> dict:
    """The quantities :func:`find_hot_pixels` decides on, for auditing and plots.

    Returns
    -------
    dict
        ``rate`` ``(H, W)``: the pixel's rate over the stretch (spikes per readout); ``excess`` ``(H, W)``: its
        excess over its same-colour reference, over the stretch; ``threshold`` ``(H, W)``: what the excess must
        pass; ``block_excess`` ``(H, W)``: the median over the blocks of each block's excess; ``candidate``
        ``(H, W) bool``; ``neighbour_excess`` ``(H, W)``: the largest excess among the 8 mosaic neighbours that
        are not candidates; ``candidate_neighbours`` ``(H, W)``: how many of the 8 are; ``hot`` ``(H, W) bool``:
        the candidates that stand alone (:func:`find_hot_pixels`' answer); ``planes_per_block`` and ``blocks``.
    """
    stream = _check_stream(stream)
    start = _check_start(stream, start)
    if not isinstance(params, HotPixelParams):
        raise TypeError(f"params must be a HotPixelParams; got {type(params).__name__}")
    rates, per = _block_rates(stream, start, params)
    n = per * rates.shape[0]
    rate = rates.mean(axis=0)
    ref = _phase_reference(rate)
    m = np.clip(ref, 1.0 / n, 1.0 - 1.0 / n)
    threshold = np.maximum(params.min_excess, params.sigmas * np.sqrt(m * (1.0 - m) / n))
    excess = rate - ref
    block_excess = np.median(rates - _phase_reference(rates), axis=0)
    candidate = (excess > threshold) & (block_excess > params.min_excess)
    others = np.where(candidate, -np.inf, excess)
    neighbour = maximum_filter(others, footprint=_RING, mode="constant", cval=-np.inf)
    paired = _ring_sum(candidate)
    alone = (neighbour < params.neighbour_ratio * excess) & (paired <= 1)
    return {"rate": rate, "excess": excess, "threshold": threshold, "block_excess": block_excess,
            "candidate": candidate, "neighbour_excess": neighbour, "candidate_neighbours": paired,
            "hot": candidate & alone, "planes_per_block": per, "blocks": rates.shape[0]}


def _ring_sum(mask: np.ndarray) -> np.ndarray:
    """How many of each pixel's 8 mosaic neighbours are set, ``(H, W) int``."""
    padded = np.pad(mask.astype(np.int16), 1)
    h, w = mask.shape
    return sum(padded[1 + dy: 1 + dy + h, 1 + dx: 1 + dx + w] for dy in (-1, 0, 1) for dx in (-1, 0, 1)
               if (dy, dx) != (0, 0))


def find_hot_pixels(stream, start: int = 0, params: HotPixelParams = HotPixelParams()) -> np.ndarray:
    """Hot pixels of a recording, from a stretch of the recording itself (see the module doc).

    Parameters
    ----------
    stream : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
        Colour or monochrome; ``H`` and ``W`` even.  A packed (``.dat``) stream is counted from its bytes.
    start : int
        First readout of the stretch.
    params : HotPixelParams

    Returns
    -------
    ndarray ``(H, W) bool``
        True at the hot pixels.  A stretch of fewer than ``2 · blocks`` readouts finds none.
    """
    stream = _check_stream(stream)
    start = _check_start(stream, start)
    if not isinstance(params, HotPixelParams):
        raise TypeError(f"params must be a HotPixelParams; got {type(params).__name__}")
    if len(stream) - start < 2 * params.blocks:
        return np.zeros((stream.height, stream.width), dtype=bool)
    return hot_pixel_excess(stream, start, params)["hot"]


def hot_pixels_to_replace(stream, mode: str = "auto", given=None) -> np.ndarray | None:
    """The map a reconstruction replaces: ``given`` (a calibration map, its size checked), else what
    :func:`find_hot_pixels` finds in the stream's first planes (``mode="auto"``), else none (``"off"``).

    Returns
    -------
    ndarray ``(H, W) bool`` or None
        None where nothing is to be replaced (``"off"``, or an empty map).
    """
    stream = as_stream(stream)
    if given is not None:
        mask = np.asarray(given)
        if mask.dtype != bool or mask.shape != (stream.height, stream.width):
            raise ValueError(f"hot_pixels must be a ({stream.height}, {stream.width}) bool map of the stream; "
                             f"got {mask.dtype} of shape {mask.shape}")
    elif mode == "auto":
        mask = find_hot_pixels(stream)
    elif mode == "off":
        mask = None
    else:
        raise ValueError(f"mode must be 'auto' or 'off'; got {mode!r}")
    return mask if mask is not None and mask.any() else None


def _check_stream(stream) -> SpikeStream:
    stream = as_stream(stream)
    if stream.height % 2 or stream.width % 2:
        raise ValueError(f"stream must have even height and width (2×2 phases); got {stream.height}×{stream.width}")
    return stream


def _check_start(stream: SpikeStream, start) -> int:
    if isinstance(start, bool) or not isinstance(start, (int, np.integer)) or not 0 <= start < len(stream):
        raise ValueError(f"start must be a readout of the stream, 0 … {len(stream) - 1}; got {start!r}")
    return int(start)


class HotPixelRepair:
    """Replace the hot pixels of a window by the mean of their same-colour neighbours.

    Parameters
    ----------
    mask : ndarray ``(H, W) bool``
        The hot pixels (:func:`find_hot_pixels`, or a calibration map); ``H`` and ``W`` even.

    Notes
    -----
    The neighbours of each hot pixel and their weights are found once, here; :meth:`mosaic` and
    :meth:`planes` then cost one gather of at most eight values per hot pixel and window.
    """

    def __init__(self, mask):
        mask = np.asarray(mask)
        if mask.dtype != bool or mask.ndim != 2:
            raise TypeError(f"mask must be a (H, W) bool array; got {mask.dtype} of shape {mask.shape}")
        h, w = mask.shape
        if h % 2 or w % 2:
            raise ValueError(f"mask must have even height and width (2×2 phases); got {h}×{w}")
        self.mask = mask
        self.shape = (h, w)
        ys, xs = np.nonzero(mask)
        self.count = int(ys.size)
        idx = np.zeros((self.count, len(_SAME_COLOUR)), dtype=np.int64)
        wts = np.zeros((self.count, len(_SAME_COLOUR)), dtype=np.float64)
        for j, (dy, dx) in enumerate(_SAME_COLOUR):
            ny, nx = ys + dy, xs + dx
            ok = (ny >= 0) & (ny < h) & (nx >= 0) & (nx < w)
            ok[ok] &= ~mask[ny[ok], nx[ok]]
            idx[:, j] = np.where(ok, np.clip(ny, 0, h - 1) * w + np.clip(nx, 0, w - 1), 0)
            wts[:, j] = ok
        total = wts.sum(axis=1)
        keep = total > 0  # a hot pixel walled in by others keeps its value
        self._targets = (ys * w + xs)[keep]
        self._idx = idx[keep]
        self._wts = (wts[keep] / total[keep, None])
        # the same pixels in the four Bayer planes (p = 2·(y mod 2) + x mod 2, at (y // 2, x // 2))
        self._targets_p = _plane_index(self._targets, w, h)
        self._idx_p = _plane_index(self._idx, w, h)

    def mosaic(self, values: np.ndarray) -> np.ndarray:
        """Repair ``(..., H, W)`` mosaic values in place (float arrays; counts should be cast first); returns them."""
        return self._apply(values, self._targets, self._idx, self.shape)

    def planes(self, values: np.ndarray) -> np.ndarray:
        """Repair ``(..., 4, H/2, W/2)`` Bayer planes in place (as :func:`spikeref.bayer.bayer_planes` orders them)."""
        h, w = self.shape
        return self._apply(values, self._targets_p, self._idx_p, (4, h // 2, w // 2))

    def _apply(self, values, targets, idx, tail) -> np.ndarray:
        if not isinstance(values, np.ndarray) or not np.issubdtype(values.dtype, np.floating):
            raise TypeError("values must be a float ndarray (cast counts to float before the repair)")
        if values.shape[values.ndim - len(tail):] != tail:
            raise ValueError(f"values must end in shape {tail}; got {values.shape}")
        if targets.size == 0:
            return values
        flat = values.reshape(values.shape[:values.ndim - len(tail)] + (-1,))  # a view of a contiguous array
        if not np.shares_memory(flat, values):
            raise ValueError("values must be C-contiguous to be repaired in place")
        flat[..., targets] = (flat[..., idx] * self._wts).sum(axis=-1).astype(values.dtype)
        return values


def _plane_index(flat_mosaic: np.ndarray, w: int, h: int) -> np.ndarray:
    y, x = np.divmod(flat_mosaic, w)
    return ((y % 2) * 2 + x % 2) * (h // 2) * (w // 2) + (y // 2) * (w // 2) + x // 2


def repair_oracle(mosaic: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """A literal, slow transcription of :class:`HotPixelRepair` on one ``(H, W)`` mosaic (a copy, float64)."""
    mosaic = np.asarray(mosaic, dtype=np.float64)
    out = mosaic.copy()
    h, w = mosaic.shape
    for y in range(h):
        for x in range(w):
            if not mask[y, x]:
                continue
            values = [mosaic[y + dy, x + dx] for dy, dx in _SAME_COLOUR
                      if 0 <= y + dy < h and 0 <= x + dx < w and not mask[y + dy, x + dx]]
            if values:
                out[y, x] = sum(values) / len(values)
    return out


def save_hot_pixel_map(path, mask: np.ndarray, **facts) -> Path:
    """Write a hot-pixel map ``.npz``: ``hot`` ``(H, W) bool`` and the scalar ``facts`` given (planes, source …)."""
    mask = np.asarray(mask)
    if mask.dtype != bool or mask.ndim != 2:
        raise TypeError(f"mask must be a (H, W) bool array; got {mask.dtype} of shape {mask.shape}")
    path = Path(path)

    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, hot=mask, **{k: np.asarray(v) for k, v in facts.items()})

    return atomic_write(path, write)


def load_hot_pixel_map(path, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Read a map written by :func:`save_hot_pixel_map` (``spikeref calibrate``); ``shape`` checks its size."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such hot-pixel map: {path}")
    try:
        data = np.load(path)
        if not isinstance(data, np.lib.npyio.NpzFile):
            raise ValueError("one array, not an .npz")
        with data:
            files = list(data.files)
            mask = np.asarray(data["hot"]) if "hot" in files else None
    except (OSError, EOFError, ValueError) as exc:  # not an .npz, a damaged one, or one holding Python objects
        raise ValueError(f"{path}: not a readable hot-pixel map ({exc})") from None
    if mask is None:
        raise ValueError(f"{path}: not a hot-pixel map (no array 'hot', found {files}; made by spikeref calibrate)")
    if mask.dtype != bool or mask.ndim != 2:
        raise ValueError(f"{path}: 'hot' must be a (H, W) bool array; got {mask.dtype} of shape {mask.shape}")
    if shape is not None and mask.shape != tuple(shape):
        raise ValueError(f"{path}: a map of {mask.shape[0]}×{mask.shape[1]} pixels for a recording of "
                         f"{shape[0]}×{shape[1]}")
    return mask
