"""Noise-adaptive residual shrinkage: give back the detail the denoiser removed beyond the noise.

Not in the paper.  The paper's output is ``Ψ[D(I)]``.  A blind-spot network trained on all
windows ``W = 5…200`` (``docs/equations.md``, Eq. 12) smooths a little at every exposure.  At long windows
the noise it removes is small and that smoothing costs PSNR at colour edges (``docs/results_history.md``,
"The former network without the guard").  This step is a local Wiener rule on the residual ``r = I − D(I)``:

.. math::

    \\hat I = D(I) + g \\, r, \\qquad g = \\max\\Bigl(0,\\; 1 - \\frac{\\sigma^2}{\\overline{r^2}}\\Bigr)

``\\overline{r^2}`` is the mean of ``r²`` over the ``(2·radius + 1)²`` neighbourhood of each pixel
(half-sample-symmetric boundary, like Ψ).  ``σ²`` is the variance of a rate read from ``W``
independent Bernoulli readouts with firing probability ``p = D(I)``:

.. math::

    \\sigma^2 = p (1 - p) / W, \\qquad p \\text{ clipped to } [1/(2W),\\, 1 - 1/(2W)]

Where the residual holds no more energy than that noise, ``g ≈ 0`` and ``D(I)`` is kept; where it
holds more (edges, texture the network blurred), that part of the residual is put back.

Interpretations, since the paper has no such step:

* The binomial variance is an upper bound for an integrate-and-fire count, whose variance is
  less than binomial.  So ``σ²`` errs high, and the step errs towards keeping ``D(I)``.  No
  parameter is fitted to data: the rule is the textbook Wiener gain with ``σ²`` from the
  exposure alone.
* The clip keeps ``σ²`` above zero where ``D(I)`` is 0 or 1 (a count of 0 in ``W`` readouts
  does not mean a rate of exactly 0).
* Rates are spikes per readout (``M_c = 1``), the unit the denoiser works in.

:class:`~spikeref.denoise.denoiser.Denoiser` applies it by default; ``shrink=False`` gives the
paper's ``D(I)`` unchanged.  The literal oracle is
:func:`spikeref.oracles.shrinkage.shrink_residual_oracle`.
"""

from __future__ import annotations

import numpy as np

from spikeref._jit import njit, prange
from spikeref.bayer import reflect_index
from spikeref.denoise.blindspot import check_image

__all__ = ["shrink_residual", "residual_noise_variance"]


def residual_noise_variance(denoised, window: float) -> np.ndarray:
    """``σ² = p(1 − p)/W`` with ``p`` = ``denoised`` clipped to ``[1/(2W), 1 − 1/(2W)]`` (float64)."""
    p = np.clip(np.asarray(denoised, dtype=np.float64), 0.5 / window, 1.0 - 0.5 / window)
    return p * (1.0 - p) / window


@njit(parallel=True, error_model="numpy")
def _shrink_residual(noisy, denoised, inv_window, radius, out):
    # noisy, denoised, out: (n, h, w) float32.  Per plane: r² summed over the box by a separable
    # pass (rows, then columns) with mirrored indices, then the Wiener gain per pixel.  Each sum adds
    # the same terms in the same order as this kernel did before 2026-11-25 (0, then dx or dy from
    # −radius to +radius; the literal oracle takes np.mean of the 2-D box, equal within round-off);
    # the loops run the offset outside and the pixels inside, so that the pixels vectorise.
    n, h, w = noisy.shape
    side = 2 * radius + 1
    inv_area = 1.0 / (side * side)
    lo = 0.5 * inv_window
    hi = 1.0 - lo
    rows = np.empty((n, h, w), dtype=np.float64)
    x_lo = min(radius, w)  # columns x_lo … x_hi − 1 need no mirrored index
    x_hi = max(x_lo, w - radius)
    for t in prange(n * h):
        c = t // h
        y = t % h
        r2 = np.empty(w, dtype=np.float64)
        for x in range(w):
            r = np.float64(noisy[c, y, x]) - np.float64(denoised[c, y, x])
            r2[x] = r * r
        row = rows[c, y]
        row[:] = 0.0
        for dx in range(-radius, radius + 1):
            for x in range(x_lo):
                row[x] += r2[reflect_index(x + dx, w)]  # half-sample symmetric, like Ψ
            for x in range(x_lo, x_hi):
                row[x] += r2[x + dx]
            for x in range(x_hi, w):
                row[x] += r2[reflect_index(x + dx, w)]
    for t in prange(n * h):
        c = t // h
        y = t % h
        s = np.zeros(w, dtype=np.float64)
        for dy in range(-radius, radius + 1):
            src = rows[c, reflect_index(y + dy, h)]
            for x in range(w):
                s[x] += src[x]
        for x in range(w):
            energy = s[x] * inv_area
            d = np.float64(denoised[c, y, x])
            p = min(max(d, lo), hi)
            var = p * (1.0 - p) * inv_window
            gain = 1.0 - var / energy if energy > var else 0.0
            out[c, y, x] = d + gain * (np.float64(noisy[c, y, x]) - d)


def shrink_residual(noisy, denoised, window: float, radius: int = 1) -> np.ndarray:
    """Put back the part of ``noisy − denoised`` that exceeds the expected noise (module doc).

    Parameters
    ----------
    noisy : ndarray ``(..., h, w)`` float
        ``I``: firing rates of Eq. 4 (spikes per readout), e.g. the four Bayer planes.
    denoised : ndarray, same shape
        ``D(I)``.
    window : float
        The exposure behind ``I`` in planes: ``W`` of Eq. 4, or the noise-equivalent
        length of a warped accumulation.
    radius : int
        The neighbourhood is ``(2·radius + 1)²`` pixels (default 3×3).

    Returns
    -------
    ndarray, same shape, float32: ``D(I) + g (I − D(I))`` with ``g ∈ [0, 1]`` per pixel, so each
    value lies between ``D(I)`` and ``I``.
    """
    a = check_image(noisy, "noisy")
    d = check_image(denoised, "denoised")
    if a.shape != d.shape:
        raise ValueError(f"noisy and denoised must have the same shape; got {a.shape} and {d.shape}")
    if isinstance(window, bool) or not isinstance(window, (int, float, np.integer, np.floating)) \
            or not np.isfinite(window) or window < 1:
        raise ValueError(f"window must be a number of planes ≥ 1; got {window!r}")
    if isinstance(radius, bool) or not isinstance(radius, (int, np.integer)) or radius < 0:
        raise ValueError(f"radius must be a non-negative int; got {radius!r}")
    shape = a.shape
    a3 = np.ascontiguousarray(a.reshape((-1,) + shape[-2:]), dtype=np.float32)
    d3 = np.ascontiguousarray(d.reshape((-1,) + shape[-2:]), dtype=np.float32)
    out = np.empty_like(a3)
    _shrink_residual(a3, d3, 1.0 / float(window), int(radius), out)
    return out.reshape(shape)
