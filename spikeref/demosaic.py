"""A sharper demosaic for the output frame: Malvar, He & Cutler (2004) — an option beyond Ψ.

The paper's Ψ (Eq. 13, :func:`spikeref.bayer.demosaic_bilinear`) interpolates each channel from
its own samples only, which blurs detail and caps what any method that ends in Ψ can reach (the
stage ladder's "limit").  Malvar–He–Cutler ("High-quality linear interpolation for demosaicing
of Bayer-patterned color images", ICASSP 2004) adds to the bilinear estimate a gain-weighted
Laplacian of the channel that *is* sampled at the pixel, in five fixed 5×5 linear filters
(coefficients in eighths):

* G at an R or B pixel: ``[[0,0,−1,0,0], [0,0,2,0,0], [−1,2,4,2,−1], [0,0,2,0,0], [0,0,−1,0,0]] / 8``;
* R (or B) at a G pixel whose row holds R (B) samples:
  ``[[0,0,½,0,0], [0,−1,0,−1,0], [−1,4,5,4,−1], [0,−1,0,−1,0], [0,0,½,0,0]] / 8``,
  and its transpose where the column holds them;
* R at a B pixel (and B at an R pixel):
  ``[[0,0,−3/2,0,0], [0,2,0,2,0], [−3/2,0,6,0,−3/2], [0,2,0,2,0], [0,0,−3/2,0,0]] / 8``;
* the sampled channel keeps its value.

Interpretations: the mosaic is extended beyond its border by whole-sample mirroring
(``c b | a b c``, SciPy's ``mirror``), which keeps the CFA's parity (a half-sample mirror would
put the wrong colour beyond the edge); negative results (the filters' negative lobes at sharp
edges) are clipped to 0, since radiance is not negative.  The literal oracle is
:func:`spikeref.oracles.demosaic.demosaic_mhc_oracle`.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import correlate
from spikeref.bayer import demosaic_bilinear, demosaic_each
from spikeref.directional_demosaic import demosaic_ddfapd


__all__ = ["DEMOSAICS", "MHC_KERNELS", "demosaic_mhc", "demosaic"]

#: The final frame's demosaic: Ψ (``"bilinear"``, the paper's), Malvar–He–Cutler (``"mhc"``) or the directional
#: demosaic of Menon, Andriani & Calvagno (``"ddfapd"``, :mod:`spikeref.directional_demosaic`).
DEMOSAICS = ("bilinear", "mhc", "ddfapd")

#: The Malvar–He–Cutler filters, index ``[dy + 2, dx + 2]``.
MHC_KERNELS = {
    "g_at_rb": np.array([[0, 0, -1, 0, 0], [0, 0, 2, 0, 0], [-1, 2, 4, 2, -1], [0, 0, 2, 0, 0],
                         [0, 0, -1, 0, 0]], dtype=np.float64) / 8.0,
    "at_g_row": np.array([[0, 0, 0.5, 0, 0], [0, -1, 0, -1, 0], [-1, 4, 5, 4, -1], [0, -1, 0, -1, 0],
                          [0, 0, 0.5, 0, 0]], dtype=np.float64) / 8.0,
    "at_opposite": np.array([[0, 0, -1.5, 0, 0], [0, 2, 0, 2, 0], [-1.5, 0, 6, 0, -1.5], [0, 2, 0, 2, 0],
                             [0, 0, -1.5, 0, 0]], dtype=np.float64) / 8.0,
}
MHC_KERNELS["at_g_col"] = MHC_KERNELS["at_g_row"].T.copy()


def _filters(image: np.ndarray) -> dict:
    return {name: correlate(image, k, mode="mirror") for name, k in MHC_KERNELS.items()}


def demosaic_mhc(mosaic, cfa: str = "RGGB") -> np.ndarray:
    """Malvar–He–Cutler demosaic: mosaic ``(..., H, W)`` → linear RGB ``(..., H, W, 3)``.

    Parameters
    ----------
    mosaic : ndarray ``(..., H, W)`` float (or integer, taken as float32)
        Linear values; ``H`` and ``W`` even.
    cfa : str
        Pattern of the upright image.

    Returns
    -------
    ndarray ``(..., H, W, 3)``, float32 (float64 for float64 input), ≥ 0.
    """
    return demosaic_each(mosaic, cfa, _mhc_one)


def _mhc_one(img: np.ndarray, chan: np.ndarray, row_has: dict) -> np.ndarray:
    f = _filters(img)
    out = np.empty(img.shape + (3,))
    out[..., 1] = np.where(chan == 1, img, f["g_at_rb"])
    for c, idx in (("R", 0), ("B", 2)):
        at_g = np.where(row_has[c], f["at_g_row"], f["at_g_col"])
        out[..., idx] = np.where(chan == idx, img, np.where(chan == 1, at_g, f["at_opposite"]))
    return out


def demosaic(mosaic, cfa: str = "RGGB", method: str = "bilinear") -> np.ndarray:
    """The output frame's demosaic by name: ``"bilinear"`` (Ψ, Eq. 13), ``"mhc"`` (:func:`demosaic_mhc`) or
    ``"ddfapd"`` (:func:`spikeref.directional_demosaic.demosaic_ddfapd`)."""
    if method == "bilinear":
        return demosaic_bilinear(mosaic, cfa)
    if method == "mhc":
        return demosaic_mhc(mosaic, cfa)
    if method == "ddfapd":
        return demosaic_ddfapd(mosaic, cfa)
    raise ValueError(f"demosaic must be one of {', '.join(DEMOSAICS)}; got {method!r}")
