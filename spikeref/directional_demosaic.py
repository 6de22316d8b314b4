"""A directional demosaic: Menon, Andriani & Calvagno (2007) — an option beyond Ψ, without its refining step.

"Demosaicing with directional filtering and a posteriori decision" (IEEE Trans. Image Processing 16(1), 2007)
interpolates the green channel twice, along the rows and along the columns, and keeps at each pixel the
direction in which the colour differences vary least; red and blue then follow the green through their
differences with it.  On photographs it keeps edges that a fixed linear filter (Ψ, Malvar–He–Cutler) blurs
or zips; it assumes, as Malvar–He–Cutler does, that the colours share their detail.

1. **Green along each direction.** At an R or B pixel the row's five samples ``x₋₂ … x₂`` give
   ``Ĝ_H = (x₋₁ + x₁)/2 + (2x₀ − x₋₂ − x₂)/4``: the filter ``[−¼, ½, ½, ½, −¼]`` on the row; ``Ĝ_V`` the same
   filter on the column.  At a G pixel the same filter gives the row's (column's) other colour, ``X̂_H``
   (``X̂_V``).
2. **The decision.** The colour difference along each direction, ``C_H = X − Ĝ_H`` at R and B pixels and
   ``X̂_H − G`` at G pixels (``C_V`` alike), its variation between samples two pixels apart,
   ``D_H(y, x) = |C_H(y, x) − C_H(y, x + 2)|``, and the classifier ``δ_H`` its weighted sum over the 5 × 5
   window: weight 3 on the pixel's row, 1 on the rows two above and below (the pairs ``x − 2 → x`` and
   ``x → x + 2`` of each), 1 on the rows next to it (the pair ``x − 1 → x + 1``); ``δ_V`` the transpose.  The
   green is ``Ĝ_H`` where ``δ_H ≤ δ_V``, else ``Ĝ_V``.
3. **Red and blue at green pixels**: the green plus the mean colour difference (``R − G`` or ``B − G``) of
   the two neighbours that hold the colour (in the row or in the column).
4. **Red at blue pixels, blue at red ones**: the pixel's own sample plus the mean of ``R − B`` (``B − R``) of
   its two green neighbours along the direction chosen at step 2.

Interpretations (the paper leaves them to the implementer): the mosaic is extended beyond its border by
whole-sample mirroring (``c b | a b c``, SciPy's ``mirror``), which keeps the CFA's parity; a tie
``δ_H = δ_V`` (a flat patch) takes the rows; the paper's optional refining step (§III-D) is left out: on
the eight benchmark scenes' exact mosaics it lost on seven (colour-demosaicing's implementation with and without
it, 34.00 against 34.11 dB on the mean; docs/results.md, "The directional demosaic where the colours share their
detail");
negative results are clipped to 0, since radiance is not negative.  The literal oracle is
:func:`spikeref.oracles.directional_demosaic.demosaic_ddfapd_oracle`.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import correlate1d

from spikeref.bayer import demosaic_each

__all__ = ["GREEN_FILTER", "demosaic_ddfapd"]

#: Step 1's filter along a row (or a column): the green at an R or B pixel, the other colour at a G pixel.
GREEN_FILTER = np.array([-0.25, 0.5, 0.5, 0.5, -0.25])

_PAIR = np.array([0.5, 0.0, 0.5])  # the mean of the two neighbours along an axis


def _along(image: np.ndarray, weights: np.ndarray, axis: int) -> np.ndarray:
    return correlate1d(image, weights, axis=axis, mode="mirror")


def _classifier(c: np.ndarray, axis: int) -> np.ndarray:
    """``δ`` along ``axis`` (step 2): ``D = |C(·) − C(· + 2)|`` summed over the 5 × 5 window with its weights."""
    other = 1 - axis
    d = np.abs(c - _along(c, np.array([0.0, 0.0, 0.0, 0.0, 1.0]), axis))  # C(x + 2), mirrored beyond the edge
    pairs = _along(d, np.array([1.0, 0.0, 1.0, 0.0, 0.0]), axis)  # x − 2 → x and x → x + 2
    odd = _along(d, np.array([1.0, 0.0, 0.0]), axis)  # x − 1 → x + 1
    return (_along(pairs, np.array([1.0, 0.0, 3.0, 0.0, 1.0]), other)
            + _along(odd, np.array([1.0, 0.0, 1.0]), other))


def _one(m: np.ndarray, chan: np.ndarray, row_has: dict) -> np.ndarray:
    green = chan == 1
    f_h, f_v = _along(m, GREEN_FILTER, 1), _along(m, GREEN_FILTER, 0)
    c_h = np.where(green, f_h - m, m - f_h)
    c_v = np.where(green, f_v - m, m - f_v)
    rows = _classifier(c_h, 1) <= _classifier(c_v, 0)  # step 2: the rows where their variation is not larger
    g = np.where(green, m, np.where(rows, f_h, f_v))
    out = np.empty(m.shape + (3,))
    out[..., 1] = g
    for idx, c in ((0, "R"), (2, "B")):  # step 3
        diff = np.where(chan == idx, m - g, 0.0)
        mean = np.where(row_has[c], _along(diff, _PAIR, 1), _along(diff, _PAIR, 0))
        out[..., idx] = np.where(chan == idx, m, np.where(green, g + mean, 0.0))
    rb = np.where(green, out[..., 0] - out[..., 2], 0.0)  # step 4: R − B at the green pixels
    mean = np.where(rows, _along(rb, _PAIR, 1), _along(rb, _PAIR, 0))
    out[..., 0] = np.where(chan == 2, m + mean, out[..., 0])
    out[..., 2] = np.where(chan == 0, m - mean, out[..., 2])
    return out


def demosaic_ddfapd(mosaic, cfa: str = "RGGB") -> np.ndarray:
    """Menon–Andriani–Calvagno directional demosaic (module doc): mosaic ``(..., H, W)`` → RGB ``(..., H, W, 3)``.

    Parameters
    ----------
    mosaic : ndarray ``(..., H, W)`` float (or integer, taken as float32)
        Linear values; ``H`` and ``W`` even.
    cfa : str
        Pattern of the upright image.

    Returns
    -------
    ndarray ``(..., H, W, 3)``, float32 (float64 for float64 input), ≥ 0; the sampled colour of each pixel
    is its sample.
    """
    return demosaic_each(mosaic, cfa, _one)
