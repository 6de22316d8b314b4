"""Oracle of the alignment's noise model (:mod:`spikeref.align_noise`; not in the paper or HDR+).

What noise alone explains, for the noise-aware options of §4.2's alignment
(``docs/spec/align.md#noise-aware-search``), transcribed without the package's code: Immerkær's
response pixel by pixel (:func:`immerkaer_response_oracle`) and the noise variance it gives
(:func:`estimate_noise_oracle`, Immerkær 1996), per pixel over the 15 × 15 box as a sum over its 225
clamped offsets (:func:`local_noise_oracle`), the correlation of two frames' noise
(:func:`estimate_noise_correlation_oracle`, clipped below at :data:`MIN_CORRELATION`), the
pyramid's composite kernels by written-out convolutions (:func:`level_noise_factors_oracle`), the
noise pyramid (:func:`noise_inputs_oracle`), and each tile's bias and threshold as plain sums over
its pixels (:func:`bias_and_threshold_oracle`), which the noise-aware search
(:func:`spikeref.oracles.align_search.noise_aware_search_oracle`) takes.  :func:`noise_map_oracle` is
the level-0 noise map the Lucas–Kanade field (:mod:`spikeref.oracles.align_refine`) and the
zero-motion test (:mod:`spikeref.oracles.align_zero_test`) weigh by.
"""

from __future__ import annotations

import numpy as np

from spikeref.oracles.align_search import PYRAMID_TAPS, blur_decimate_oracle

__all__ = [
    "MIN_CORRELATION",
    "immerkaer_response_oracle",
    "estimate_noise_oracle",
    "local_noise_oracle",
    "estimate_noise_correlation_oracle",
    "level_noise_factors_oracle",
    "noise_inputs_oracle",
    "bias_and_threshold_oracle",
    "noise_map_oracle",
]

#: ``ρ`` is clipped below at −½.
MIN_CORRELATION = -0.5
#: Side of the box of :func:`local_noise_oracle`.
_BOX = 15


def immerkaer_response_oracle(image):
    """``|4·P[y, x] − 2·(4 edge neighbours) + (4 corner neighbours)|`` at every interior pixel, ``(h−2, w−2)`` float64.

    The three groups summed apart (in the order up, down, left, right and top-left, top-right,
    bottom-left, bottom-right), then combined as written: a flat image gives exactly 0.
    """
    img = np.asarray(image, np.float64)
    h, w = img.shape
    out = np.zeros((h - 2, w - 2))
    for y in range(1, h - 1):
        for x in range(1, w - 1):
            edges = img[y - 1, x] + img[y + 1, x] + img[y, x - 1] + img[y, x + 1]
            corners = img[y - 1, x - 1] + img[y - 1, x + 1] + img[y + 1, x - 1] + img[y + 1, x + 1]
            out[y - 1, x - 1] = abs(4.0 * img[y, x] - 2.0 * edges + corners)
    return out


def estimate_noise_oracle(image):
    """``(√(π/2) · mean(response) / 6)²`` of the float32 ``image`` (Immerkær 1996), a float."""
    r = immerkaer_response_oracle(np.asarray(image, np.float32))
    return float((np.sqrt(np.pi / 2.0) * (r.sum() / r.size) / 6.0) ** 2)


def local_noise_oracle(image, box=_BOX):
    """Per pixel ``(√(π/2) · m / 6)²``, ``m`` the mean of the response over the ``box × box`` box centred there.

    The ``(h−2, w−2)`` response is first padded by one pixel on each side by edge replicate to
    ``h × w``; the box then reads that map at clamped coordinates (edge replicate again).
    """
    r = immerkaer_response_oracle(np.asarray(image, np.float32))
    h, w = r.shape[0] + 2, r.shape[1] + 2
    padded = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            padded[y, x] = r[min(max(y - 1, 0), h - 3), min(max(x - 1, 0), w - 3)]
    half = box // 2
    total = np.zeros((h, w))
    for dy in range(-half, half + 1):  # Σ over the box's offsets, every pixel at once
        ys = np.clip(np.arange(h) + dy, 0, h - 1)
        for dx in range(-half, half + 1):
            xs = np.clip(np.arange(w) + dx, 0, w - 1)
            total += padded[np.ix_(ys, xs)]
    return (np.sqrt(np.pi / 2.0) * (total / (box * box)) / 6.0) ** 2


def estimate_noise_correlation_oracle(reference, alternate):
    """``clip(1 − σ²(R − A) / (σ²(R) + σ²(A)), −1, 1)``, 0 when ``σ²(R) + σ²(A) ≤ 0``; ``σ²`` =
    :func:`estimate_noise_oracle`, ``R − A`` of the float32 images taken in float64 and rounded to float32."""
    ref = np.asarray(reference, np.float32)
    alt = np.asarray(alternate, np.float32)
    total = estimate_noise_oracle(ref) + estimate_noise_oracle(alt)
    if total <= 0:
        return 0.0
    diff = (ref.astype(np.float64) - alt.astype(np.float64)).astype(np.float32)
    return min(max(1.0 - estimate_noise_oracle(diff) / total, -1.0), 1.0)


def level_noise_factors_oracle(levels):
    """``[(F_k, S_k)]`` for ``k = 0 … levels−1``: white noise of unit variance at level 0, seen at level ``k``.

    ``h_0 = [1]``, ``h_{k+1} = h_k ∗ up_k`` (``up_k`` = ``[1,4,6,4,1]/16`` with ``2^k − 1`` zeros between
    taps; full convolution); ``e_k = Σ h_k²``; ``ρ_k(m) = Σ_i h_k[i] h_k[i + m·2^k] / e_k`` for
    ``m = 0 … ⌈len(h_k)/2^k⌉ − 1``; ``F_k = e_k²``, ``S_k = (ρ_k(0)² + 2 Σ_{m≥1} ρ_k(m)²)²``.
    """
    h = [1.0]
    out = []
    for k in range(levels):
        spacing = 2 ** k
        energy = sum(v * v for v in h)
        count = (len(h) + spacing - 1) // spacing
        rho = []
        for m in range(count):
            total = 0.0
            for i in range(len(h) - m * spacing):
                total += h[i] * h[i + m * spacing]
            rho.append(total / energy)
        s1 = rho[0] ** 2 + 2.0 * sum(r * r for r in rho[1:])
        out.append((energy ** 2, s1 ** 2))
        up = [0.0] * (4 * spacing + 1)
        for n, tap in enumerate(PYRAMID_TAPS):
            up[n * spacing] = tap / 16.0
        conv = [0.0] * (len(h) + len(up) - 1)
        for i, a in enumerate(h):
            for j, b in enumerate(up):
                conv[i + j] += a * b
        h = conv
    return out


def noise_inputs_oracle(ref, alt, levels, noise, correlation):
    """The noise pyramid ``V_0 … V_{levels−1}`` (float64 arrays), the factors ``(F_k, S_k)`` and the clipped ``ρ``.

    ``V_0`` is the noise map as given (float64, not rounded); ``V_{k+1}`` is the pyramid step of
    ``V_k`` (rounded to float32, then used as float64).
    """
    shape = ref.shape
    if noise is None:
        v0 = 0.5 * (local_noise_oracle(ref) + local_noise_oracle(alt))
    else:
        v0 = np.broadcast_to(np.asarray(noise, np.float64), shape).copy()
    pyramid = [v0]
    for _ in range(levels - 1):
        pyramid.append(blur_decimate_oracle(pyramid[-1]).astype(np.float64))
    rho = estimate_noise_correlation_oracle(ref, alt) if correlation is None else float(correlation)
    return pyramid, level_noise_factors_oracle(levels), max(rho, MIN_CORRELATION)


def bias_and_threshold_oracle(var_k, factors, oy, ox, tile, l2, z, rho):
    """``(bias, thresh)`` of the tile at ``(oy, ox)`` of level ``k`` (variance map ``var_k``, factors ``(F_k, S_k)``).

    ``v = V_k · F_k`` per pixel, ``r = min(ρ, 0)``; L2 (levels ≥ 1): ``bias = −2r Σ v``,
    ``thresh = z √(12 S_k Σ v²)``; L1 (level 0): ``bias = √(2/π)(√(1 − r) − 1) Σ √(2v)``,
    ``thresh = z √(c_1 S_k Σ v)``, ``c_1 = 4 − (8/π)(√¾ + ½ arcsin ½)``.
    """
    f, s = factors
    r = min(rho, 0.0)
    sum_v = sum_v2 = sum_sqrt = 0.0
    for y in range(oy, oy + tile):
        for x in range(ox, ox + tile):
            v = float(var_k[y, x]) * f
            sum_v += v
            sum_v2 += v * v
            sum_sqrt += np.sqrt(2.0 * v)
    if l2:
        return -2.0 * r * sum_v, z * np.sqrt(12.0 * s * sum_v2)
    c1 = 4.0 - (8.0 / np.pi) * (np.sqrt(0.75) + 0.5 * np.arcsin(0.5))
    return np.sqrt(2.0 / np.pi) * (np.sqrt(1.0 - r) - 1.0) * sum_sqrt, z * np.sqrt(c1 * s * sum_v)


def noise_map_oracle(noise, ref, alt):
    """The level-0 noise variance map, float64: ``noise`` as given (a number or a map), else
    ``½ (local_noise(ref) + local_noise(alt))``."""
    if noise is None:
        return 0.5 * (local_noise_oracle(ref) + local_noise_oracle(alt))
    return np.broadcast_to(np.asarray(noise, np.float64), np.shape(ref)).copy()
