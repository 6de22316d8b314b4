"""Blind-spot denoising, Eq. 10–11 (§4.1): the masked volume Ω and mask-aware averaging Φ.

Each Bayer plane ``I_c`` is cut into cells of ``h_s × w_s`` pixels (4 × 4 by default);
mask ``M_i`` (``i = 0 … h_s w_s − 1``) hides the pixel at ``(i // w_s, i % w_s)`` of every
cell, in order top to bottom, left to right.  The masked frame ``Ω_{c,i}`` is ``I_c`` with
the hidden pixels replaced; the network ``f_θ`` denoises every masked frame and Φ keeps, at
each pixel, the outputs of the frames where that pixel was hidden:

.. math::

    D(I_c) = \\Phi(f_\\theta(\\Omega_{c,0}), \\dots) = \\sum_i M_i f_\\theta(\\Omega_{c,i}) / \\sum_i M_i

Interpretations (``docs/equations.md``)
---------------------------
* Eq. 11 writes ``Ω_{c,i} = (1 − M_i) I_c`` (hidden pixels set to 0).  As in Blind2Unblind,
  a hidden pixel is instead **filled with the weighted mean of its 8 neighbours**, weights
  ``[[½, 1, ½], [1, 0, 1], [½, 1, ½]] / 6``, so the network sees no holes.  Neighbours outside
  the plane are left out and the remaining weights renormalised (the same border rule as Ψ).
* The cells tile the plane from its top-left corner; a plane whose size is not a multiple of
  the cell keeps partial cells at the right and bottom (their pixels are still hidden once).
* Inference modes: ``visible`` (``f(I)``, one pass, Blind2Unblind's deliverable, the default),
  ``blind`` (Eq. 10–11 exactly, ``h_s w_s`` passes) and ``mixed``
  (``(D(I) + λ f(I)) / (1 + λ)``, the combination the re-visible loss trains toward).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = [
    "FILL_KERNEL",
    "MODES",
    "cell_masks",
    "neighbour_fill",
    "masked_volume",
    "mask_aware_average",
    "blindspot_denoise",
    "check_cell",
    "check_image",
]

#: Weights of the 8 neighbours that fill a hidden pixel (before normalisation by their sum).
FILL_KERNEL = np.array([[0.5, 1.0, 0.5], [1.0, 0.0, 1.0], [0.5, 1.0, 0.5]])

MODES = ("visible", "blind", "mixed")


def check_cell(cell) -> tuple[int, int]:
    """The blind-spot cell ``(h_s, w_s)`` from an int or a pair; ``ValueError`` naming ``cell`` otherwise."""
    hs, ws = (cell, cell) if isinstance(cell, (int, np.integer)) else tuple(cell)
    for v in (hs, ws):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"cell must be a positive integer or (h_s, w_s); got {cell!r}")
    return int(hs), int(ws)


def check_image(image, name="image") -> np.ndarray:
    """A float image ``(..., H, W)`` of firing rates, finite; the error names the argument ``name``.

    The argument check shared by the denoiser's stages (masks, guard, residual shrinkage).
    """
    arr = np.asarray(image)
    if arr.ndim < 2:
        raise ValueError(f"{name} must have shape (..., H, W); got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating):
        raise TypeError(f"{name} must be floating point (firing rates); got {arr.dtype}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return arr


def cell_masks(height: int, width: int, cell=4) -> np.ndarray:
    """The masks ``M_i``: ``(h_s w_s, H, W) bool``; mask ``i`` is True at ``(i // w_s, i % w_s)`` of every cell."""
    hs, ws = check_cell(cell)
    y = np.arange(height)[:, None] % hs
    x = np.arange(width)[None, :] % ws
    index = y * ws + x
    return index[None, :, :] == np.arange(hs * ws)[:, None, None]


def neighbour_fill(image: np.ndarray) -> np.ndarray:
    """Weighted mean of each pixel's 8 neighbours (:data:`FILL_KERNEL`), renormalised at the border.

    ``image`` is ``(..., H, W)`` float; the result has the same shape and dtype.
    """
    img = check_image(image)
    h, w = img.shape[-2:]
    acc = np.zeros(img.shape, dtype=np.float64)
    wsum = np.zeros((h, w), dtype=np.float64)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            k = FILL_KERNEL[dy + 1, dx + 1]
            if k == 0:
                continue
            ys = slice(max(0, -dy), h - max(0, dy))  # target rows whose neighbour (y + dy) exists
            xs = slice(max(0, -dx), w - max(0, dx))
            ysrc = slice(max(0, dy), h + min(0, dy))
            xsrc = slice(max(0, dx), w + min(0, dx))
            acc[..., ys, xs] += k * img[..., ysrc, xsrc]
            wsum[ys, xs] += k
    return (acc / np.maximum(wsum, 1e-300)).astype(img.dtype)


def masked_volume(image: np.ndarray, cell=4) -> np.ndarray:
    """The masked volume Ω of Eq. 10: ``(..., H, W)`` → ``(h_s w_s, ..., H, W)``.

    ``Ω_i`` equals ``image`` except at the pixels mask ``i`` hides, which hold
    :func:`neighbour_fill` of ``image``.
    """
    img = check_image(image)
    h, w = img.shape[-2:]
    masks = cell_masks(h, w, cell)
    fill = neighbour_fill(img)
    return np.where(masks.reshape((masks.shape[0],) + (1,) * (img.ndim - 2) + (h, w)), fill, img)


def mask_aware_average(outputs: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """Φ of Eq. 11: ``Σ_i M_i f_i / Σ_i M_i`` over the first axis.

    ``outputs`` is ``(C, ..., H, W)``, ``masks`` ``(C, H, W)`` (bool or 0/1).  Every pixel must
    be hidden by at least one mask (true of :func:`cell_masks`).
    """
    out = check_image(outputs, "outputs")
    m = np.asarray(masks, dtype=out.dtype)
    if m.ndim != 3 or m.shape[0] != out.shape[0] or m.shape[1:] != out.shape[-2:]:
        raise ValueError(f"masks must have shape (C, H, W) = ({out.shape[0]}, {out.shape[-2]}, {out.shape[-1]}); "
                         f"got {m.shape}")
    count = m.sum(axis=0)
    if np.any(count == 0):
        raise ValueError("every pixel must be hidden by at least one mask")
    m = m.reshape((m.shape[0],) + (1,) * (out.ndim - 3) + m.shape[1:])
    return (m * out).sum(axis=0) / count


def blindspot_denoise(image: np.ndarray, network: Callable[[np.ndarray], np.ndarray], mode: str = "visible",
                      cell=4, lam: float = 2.0) -> np.ndarray:
    """Denoise Bayer planes with ``network`` in one of the three modes.

    Parameters
    ----------
    image : ndarray ``(..., H, W)`` float
        Firing rates of Bayer planes (Eq. 4), e.g. ``(4, H/2, W/2)``.
    network : callable
        ``f_θ``: maps a batch ``(N, H, W)`` to ``(N, H, W)`` (one channel, shared by all planes).
    mode : {"visible", "blind", "mixed"}
        ``visible``: ``f(I)``; ``blind``: ``D(I)`` of Eq. 10–11 (``h_s w_s`` passes);
        ``mixed``: ``(D(I) + λ f(I)) / (1 + λ)``.
    cell : int or (int, int)
        ``(h_s, w_s)``, 4 by default (16 masks).
    lam : float
        ``λ`` of the mixed mode (≥ 0).

    Returns
    -------
    ndarray, the shape and dtype of ``image``.
    """
    img = check_image(image)
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}; got {mode!r}")
    if not (np.isfinite(lam) and lam >= 0):
        raise ValueError(f"lam must be a non-negative number; got {lam!r}")
    lead = img.shape[:-2]
    h, w = img.shape[-2:]
    flat = img.reshape((-1, h, w))

    def run(batch):
        out = np.asarray(network(batch))
        if out.shape != batch.shape:
            raise ValueError(f"network returned shape {out.shape} for input {batch.shape}")
        return out

    if mode == "visible":
        return run(flat).reshape(img.shape).astype(img.dtype)
    volume = masked_volume(flat, cell)  # (C, N, H, W)
    outputs = run(volume.reshape((-1, h, w))).reshape(volume.shape)
    blind = mask_aware_average(outputs, cell_masks(h, w, cell))
    if mode == "blind":
        return blind.reshape(img.shape).astype(img.dtype)
    visible = run(flat)
    return ((blind + lam * visible) / (1.0 + lam)).reshape(lead + (h, w)).astype(img.dtype)
