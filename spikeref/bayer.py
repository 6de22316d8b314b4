"""Bayer colour filter arrays: the mosaic <-> four planes split, their 2×2 luma, and Ψ.

The paper (§4.1) splits the mosaicked chromatic frame into its four Bayer
channels of size ``H/2 × W/2`` before denoising, and recombines them after;
Eq. 13 applies Ψ, "linear interpolation demosaicking", to obtain RGB.

Conventions (``docs/equations.md``, ``docs/spec/README.md``)
---------------------------------------------
* A CFA pattern is a 4-letter string read at the positions (0,0), (0,1),
  (1,0), (1,1) of every 2×2 cell of the *upright* image: ``"RGGB"`` means
  red at the top-left.  ``RGGB`` (default), ``BGGR``, ``GRBG``, ``GBRG``.
* Planes are ordered by **position**, not by colour: plane ``p`` holds the
  pixels ``mosaic[p // 2 :: 2, p % 2 :: 2]``.  ``cfa_channels(cfa)`` tells
  which RGB channel (0, 1, 2) each plane carries.
* Ψ is bilinear interpolation written as a *normalised* convolution: for
  channel ``c`` every output pixel is the weighted mean of the channel-``c``
  samples in its 3×3 neighbourhood, with the weights
  ``[[0,1,0],[1,4,1],[0,1,0]]/4`` for G and ``[[1,2,1],[2,4,2],[1,2,1]]/4``
  for R and B.  Away from the border the weights of the present samples sum
  to exactly 1, so this *is* the classic bilinear demosaic; at the border the
  image is extended half-sample symmetrically (``d c b a | a b c d``) and the
  weights are renormalised, so a flat mosaic stays flat and a sampled pixel
  keeps its own value exactly.
"""

from __future__ import annotations

import functools

import numpy as np

from spikeref._jit import njit, prange

__all__ = [
    "CFA_PATTERNS",
    "validate_cfa",
    "cfa_channels",
    "cfa_channel_map",
    "bayer_planes",
    "bayer_mosaic",
    "luma",
    "demosaic_bilinear",
    "demosaic_each",
    "check_mosaic",
    "reflect_index",
]

CFA_PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")
_CHANNEL_INDEX = {"R": 0, "G": 1, "B": 2}

#: Ψ weights (Eq. 13), before normalisation; index [dy + 1, dx + 1].
G_KERNEL = np.array([[0, 1, 0], [1, 4, 1], [0, 1, 0]], dtype=np.float64) / 4.0
RB_KERNEL = np.array([[1, 2, 1], [2, 4, 2], [1, 2, 1]], dtype=np.float64) / 4.0


def validate_cfa(cfa: str) -> str:
    """Return the upper-case pattern or raise ``ValueError`` naming ``cfa``."""
    if not isinstance(cfa, str):
        raise TypeError(f"cfa must be a string such as 'RGGB', got {type(cfa).__name__}")
    pattern = cfa.upper()
    if pattern not in CFA_PATTERNS:
        raise ValueError(f"cfa must be one of {', '.join(CFA_PATTERNS)}; got {cfa!r}")
    return pattern


def cfa_channels(cfa: str = "RGGB") -> tuple[int, int, int, int]:
    """RGB channel index (R=0, G=1, B=2) of each of the four planes.

    >>> cfa_channels("RGGB")
    (0, 1, 1, 2)
    >>> cfa_channels("GBRG")
    (1, 2, 0, 1)
    """
    pattern = validate_cfa(cfa)
    return tuple(_CHANNEL_INDEX[c] for c in pattern)  # type: ignore[return-value]


def cfa_channel_map(height: int, width: int, cfa: str = "RGGB") -> np.ndarray:
    """``(height, width) int8`` array of the RGB channel seen by every pixel."""
    channels = np.asarray(cfa_channels(cfa), dtype=np.int8).reshape(2, 2)
    return np.tile(channels, (height // 2 + 1, width // 2 + 1))[:height, :width].copy()


def _check_even(shape: tuple[int, ...], name: str) -> None:
    if len(shape) < 2:
        raise ValueError(f"{name} must have at least 2 dimensions (..., H, W); got shape {shape}")
    h, w = shape[-2], shape[-1]
    if h % 2 or w % 2 or h == 0 or w == 0:
        raise ValueError(
            f"{name} must have even, non-zero height and width for a 2×2 Bayer pattern; "
            f"got H={h}, W={w}"
        )


def check_mosaic(mosaic) -> tuple[np.ndarray, type]:
    """A demosaic's input as an array with even sides, and its output dtype (float64 stays, else float32).

    The argument check of every demosaic (Ψ here, Malvar–He–Cutler in :mod:`spikeref.demosaic`):
    ``ValueError`` naming ``mosaic`` for odd sides, ``TypeError`` for a dtype that is not float or integer.
    """
    mosaic = np.asarray(mosaic)
    _check_even(mosaic.shape, "mosaic")
    if mosaic.dtype == np.float64:
        return mosaic, np.float64
    if mosaic.dtype == np.float32 or np.issubdtype(mosaic.dtype, np.integer) or mosaic.dtype == bool:
        return mosaic, np.float32
    raise TypeError(f"mosaic must be float32, float64 or integer; got {mosaic.dtype}")


def demosaic_each(mosaic, cfa: str, one) -> np.ndarray:
    """Run a single-image demosaic on every 2-D mosaic of ``(..., H, W)``: the frame the sharper demosaics share.

    ``one(image, channels, row_has)`` gets one ``(H, W)`` float64 mosaic, :func:`cfa_channel_map`'s ``channels``
    and, for ``"R"`` and ``"B"``, an ``(H, 1)`` bool column saying which rows hold that colour, and returns
    ``(H, W, 3)`` float64.  The arguments are checked as every demosaic checks them (:func:`check_mosaic`,
    :func:`validate_cfa`); the result is clipped below at 0 (radiance is not negative) and is float32, or float64
    for float64 input.
    """
    pattern = validate_cfa(cfa)
    arr, dtype = check_mosaic(mosaic)
    h, w = arr.shape[-2:]
    channels = cfa_channel_map(h, w, pattern)
    rows = [set(pattern[0:2]), set(pattern[2:4])]  # the colours each row parity holds
    row_has = {c: np.array([c in rows[y % 2] for y in range(h)])[:, None] for c in "RB"}
    flat = arr.reshape((-1, h, w)).astype(np.float64)
    out = np.empty(flat.shape + (3,), dtype=np.float64)
    for i, img in enumerate(flat):
        out[i] = one(img, channels, row_has)
    np.maximum(out, 0.0, out=out)
    return out.reshape(arr.shape + (3,)).astype(dtype)


def bayer_planes(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Split a mosaic into its four Bayer planes (§4.1, Fig. 3a).

    Parameters
    ----------
    mosaic : ndarray, shape ``(..., H, W)``
        Any dtype.  ``H`` and ``W`` must be even.
    cfa : str
        Pattern of the upright image; only validated here, since planes are
        ordered by position (see module doc and :func:`cfa_channels`).

    Returns
    -------
    ndarray, shape ``(..., 4, H/2, W/2)``, same dtype, a new contiguous array.
    """
    validate_cfa(cfa)
    mosaic = np.asarray(mosaic)
    _check_even(mosaic.shape, "mosaic")
    planes = [mosaic[..., dy::2, dx::2] for dy in (0, 1) for dx in (0, 1)]
    return np.ascontiguousarray(np.stack(planes, axis=-3))


def bayer_mosaic(planes: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Inverse of :func:`bayer_planes`: ``(..., 4, h, w)`` → ``(..., 2h, 2w)``."""
    validate_cfa(cfa)
    planes = np.asarray(planes)
    if planes.ndim < 3 or planes.shape[-3] != 4:
        raise ValueError(f"planes must have shape (..., 4, h, w); got {planes.shape}")
    h, w = planes.shape[-2:]
    out = np.empty(planes.shape[:-3] + (2 * h, 2 * w), dtype=planes.dtype)
    for p in range(4):
        out[..., p // 2 :: 2, p % 2 :: 2] = planes[..., p, :, :]
    return out


def luma(planes) -> np.ndarray:
    """The 2×2 luma on the plane grid: the mean of the four Bayer planes.

    Parameters
    ----------
    planes : ndarray ``(..., 4, h, w)``, real
        Bayer planes in CFA-position order (``docs/spec/README.md``), e.g. the denoised firing
        rates ``D(I_l)``.

    Returns
    -------
    ndarray ``(..., h, w)`` float32
        ``(P_0 + P_1 + P_2 + P_3) / 4`` (computed in float64): the mean of each 2×2 Bayer
        cell, the image :func:`spikeref.align.align` works on.
    """
    arr = np.asarray(planes)
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"planes must be a real numeric array; got dtype {arr.dtype}")
    if arr.ndim < 3 or arr.shape[-3] != 4:
        raise ValueError(f"planes must have shape (..., 4, h, w) (four Bayer planes); got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("planes must be finite (no NaN or inf)")
    return arr.mean(axis=-3, dtype=np.float64).astype(np.float32)


@njit
def reflect_index(i, n):
    """Ψ's border rule as an index: half-sample symmetric extension (−1 → 0, n → n − 1, n ≥ 1).

    Folded again for offsets beyond the image (the residual shrinkage's box, which uses the same
    rule, can be wider than a small plane).  A Numba function: call it from kernels.
    """
    while i < 0 or i >= n:
        i = -i - 1 if i < 0 else 2 * n - i - 1
    return i


@njit(inline="always")
def _edge_pixel(mosaics, img, y, x, c, channel_of_plane, kern):
    # channel c at (y, x), every tap reflected into the image and tested for its colour
    h, w = mosaics.shape[1], mosaics.shape[2]
    num = np.float64(0.0)  # float64 sums without Numba too (NumPy would keep float32 after a float32 term)
    den = np.float64(0.0)
    for dy in range(-1, 2):
        yy = reflect_index(y + dy, h)
        for dx in range(-1, 2):
            xx = reflect_index(x + dx, w)
            if channel_of_plane[(yy % 2) * 2 + (xx % 2)] == c:
                wgt = kern[dy + 1, dx + 1]
                num += wgt * mosaics[img, yy, xx]
                den += wgt
    return num / den


@njit(parallel=True)
def _demosaic_bilinear(mosaics, channel_of_plane, g_kernel, rb_kernel, weight, use, den, zero, out):
    # mosaics (N, H, W) float; out (N, H, W, 3) float; channel_of_plane (4,).  The first and last row and
    # column: _edge_pixel.  Inside them, row y's channel c sums the taps t = 3 (dy + 1) + dx + 1 in that
    # order, tap t at column x weighted weight[y % 2, c, t, x] where use[y % 2, c, t, x] (the tap has colour
    # c) and adding `zero` (+0 of the mosaics' dtype) where not, over den[y % 2, c, x]: _edge_pixel's sums
    # in its order (a float64 sum that starts at +0.0 is never -0.0, so adding +0.0 leaves it as it was),
    # a row at a time so that LLVM vectorises over x
    n, h, w = mosaics.shape
    for k in prange(n * h):
        img = k // h
        y = k % h
        if y == 0 or y == h - 1 or w < 3:
            for x in range(w):
                for c in range(3):
                    out[img, y, x, c] = _edge_pixel(mosaics, img, y, x, c, channel_of_plane,
                                                    g_kernel if c == 1 else rb_kernel)
            continue
        for x in (0, w - 1):
            for c in range(3):
                out[img, y, x, c] = _edge_pixel(mosaics, img, y, x, c, channel_of_plane,
                                                g_kernel if c == 1 else rb_kernel)
        py = y % 2
        num = np.empty(w)
        for c in range(3):
            num[:] = 0.0
            for t in range(9):
                src = mosaics[img, y + t // 3 - 1]
                dx = t % 3 - 1
                wt = weight[py, c, t]
                on = use[py, c, t]
                for x in range(1, w - 1):
                    num[x] += wt[x] * (src[x + dx] if on[x] else zero)
            d = den[py, c]
            for x in range(1, w - 1):
                out[img, y, x, c] = num[x] / d[x]


@functools.lru_cache(maxsize=16)
def _interior_taps(channels: tuple, dtype: str, width: int):
    """The rows of tap weights, colour tests and weight sums of :func:`_demosaic_bilinear` for each row parity,
    made once per CFA, dtype and width (a video's frames share them; nothing writes to them)."""
    g_kernel, rb_kernel = G_KERNEL.astype(dtype), RB_KERNEL.astype(dtype)
    weight = np.zeros((2, 3, 9, width), dtype=dtype)
    use = np.zeros((2, 3, 9, width), dtype=np.bool_)
    den = np.ones((2, 3, width), dtype=np.float64)
    for py in range(2):
        for px in range(2):
            for c in range(3):
                kern = g_kernel if c == 1 else rb_kernel
                total = 0.0
                for dy in range(-1, 2):
                    for dx in range(-1, 2):
                        if channels[((py + dy) % 2) * 2 + (px + dx) % 2] == c:
                            weight[py, c, 3 * (dy + 1) + dx + 1, px::2] = kern[dy + 1, dx + 1]
                            use[py, c, 3 * (dy + 1) + dx + 1, px::2] = True
                            total += float(kern[dy + 1, dx + 1])  # in float64, as _edge_pixel sums
                den[py, c, px::2] = total
    return weight, use, den


def demosaic_bilinear(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Bilinear demosaic Ψ (Eq. 13): mosaic ``(..., H, W)`` → RGB ``(..., H, W, 3)``.

    Parameters
    ----------
    mosaic : ndarray, shape ``(..., H, W)``, float32 or float64
        Linear values (firing rates or radiance); integer input is converted
        to float32.  ``H`` and ``W`` even.
    cfa : str
        Pattern of the upright image (``RGGB`` default).

    Returns
    -------
    ndarray, shape ``(..., H, W, 3)``, float32 for float32/integer input,
    float64 for float64 input.

    Notes
    -----
    Interpretation (the paper says only "linear interpolation"): the weights
    are ``[[0,1,0],[1,4,1],[0,1,0]]/4`` (G) and ``[[1,2,1],[2,4,2],[1,2,1]]/4``
    (R, B), applied as a normalised convolution with half-sample symmetric
    extension, so border pixels are the weighted mean of the same-colour
    samples in reach.  The literal oracle is
    :func:`spikeref.oracles.demosaic_bilinear_oracle`.
    """
    channels = np.asarray(cfa_channels(cfa), dtype=np.int64)
    mosaic, dtype = check_mosaic(mosaic)
    lead = mosaic.shape[:-2]
    h, w = mosaic.shape[-2:]
    flat = np.ascontiguousarray(mosaic.reshape((-1, h, w)), dtype=dtype)
    out = np.empty(flat.shape + (3,), dtype=dtype)
    _demosaic_bilinear(flat, channels, G_KERNEL.astype(dtype), RB_KERNEL.astype(dtype),
                       *_interior_taps(tuple(channels.tolist()), np.dtype(dtype).str, w), np.dtype(dtype).type(0), out)
    return out.reshape(lead + (h, w, 3))
