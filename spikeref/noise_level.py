"""Immerkær's noise filter, shared by the noise-aware alignment and the denoiser's guard.

Immerkær (1996), "Fast noise variance estimation": the 3×3 kernel
``[[1, −2, 1], [−2, 4, −2], [1, −2, 1]]`` (the difference of two Laplacians) is zero on any
locally planar image and turns white noise of standard deviation σ into noise of ``6σ``
(``Σ k² = 36``), so the mean of its absolute response, ``√(2/π)·6σ``, measures σ.
:func:`spikeref.align_noise.estimate_noise` and :func:`spikeref.align_noise.local_noise` average all of it;
:func:`spikeref.denoise.guard.noise_sigma` averages its smallest share (edges inflate the rest).
"""

from __future__ import annotations

import numpy as np

from spikeref._jit import njit, prange

__all__ = ["immerkaer_response"]


@njit(parallel=True)
def _immerkaer(img, out):
    # img (n, h, w) float64, out (n, h − 2, w − 2): the response of each interior pixel
    n, h, w = img.shape
    for t in prange(n * (h - 2)):
        i = t // (h - 2)
        y = t % (h - 2) + 1
        for x in range(1, w - 1):
            edges = img[i, y - 1, x] + img[i, y + 1, x] + img[i, y, x - 1] + img[i, y, x + 1]
            corners = img[i, y - 1, x - 1] + img[i, y - 1, x + 1] + img[i, y + 1, x - 1] + img[i, y + 1, x + 1]
            # the three groups summed apart, then combined: exactly 0 on a flat image
            out[i, y - 1, x - 1] = abs(4.0 * img[i, y, x] - 2.0 * edges + corners)


def immerkaer_response(image) -> np.ndarray:
    """``|image ⊛ [[1, −2, 1], [−2, 4, −2], [1, −2, 1]]|`` over the interior: ``(..., h−2, w−2)`` float64.

    ``image`` is ``(..., h, w)`` with ``h, w ≥ 3``; leading axes are separate images.  Per pixel, in float64:
    ``edges = ((up + down) + left) + right``, ``corners`` the same over the four diagonal neighbours, then
    ``|(4·centre − 2·edges) + corners|``.
    """
    img = np.asarray(image, dtype=np.float64)
    lead, (h, w) = img.shape[:-2], img.shape[-2:]
    out = np.empty((int(np.prod(lead)), max(h - 2, 0), max(w - 2, 0)))  # (an image under 3×3 has no interior)
    if out.size:
        _immerkaer(np.ascontiguousarray(img.reshape((-1, h, w))), out)
    return out.reshape(lead + out.shape[1:])
