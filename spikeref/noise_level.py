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

__all__ = ["immerkaer_response"]


def immerkaer_response(image) -> np.ndarray:
    """``|image ⊛ [[1, −2, 1], [−2, 4, −2], [1, −2, 1]]|`` over the interior: ``(..., h−2, w−2)`` float64.

    ``image`` is ``(..., h, w)`` with ``h, w ≥ 3``; leading axes are separate images.
    """
    img = np.asarray(image, dtype=np.float64)
    centre = img[..., 1:-1, 1:-1]
    edges = img[..., :-2, 1:-1] + img[..., 2:, 1:-1] + img[..., 1:-1, :-2] + img[..., 1:-1, 2:]
    corners = img[..., :-2, :-2] + img[..., :-2, 2:] + img[..., 2:, :-2] + img[..., 2:, 2:]
    # the three groups summed apart, then combined: exactly 0 on a flat image
    return np.abs(4.0 * centre - 2.0 * edges + corners)
