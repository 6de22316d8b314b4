"""Oracle of the alignment's per-pixel zero-motion test (:func:`spikeref.align_noise.zero_motion_test`).

``AlignParams(zero_test=z)`` (not in the paper or HDR+; ``docs/spec/align.md#per-pixel-zero-motion-test``),
transcribed without the package's code: per pixel, the warped sample interpolated along ``x`` then
``y`` as the specification writes it (its taps by :func:`spikeref.oracles.align_refine.bilinear_taps`),
the noise moments of each pixel from the four taps' weights, and the :data:`ZERO_TEST_BOX` box as a sum
over its clamped offsets (:func:`zero_motion_sums_oracle`); the flow is set to zero where zero motion
explains the frames better by ``z`` standard deviations (:func:`zero_motion_test_oracle`), with the
noise map and correlation of :mod:`spikeref.oracles.align_noise`.  The box's side is written out here;
``tests/test_align.py`` holds it equal to :mod:`spikeref.align`'s.
"""

from __future__ import annotations

import numpy as np

from spikeref.oracles.align_noise import MIN_CORRELATION, estimate_noise_correlation_oracle, noise_map_oracle
from spikeref.oracles.align_refine import bilinear_cell, bilinear_taps

__all__ = ["ZERO_TEST_BOX", "zero_motion_sums_oracle", "zero_motion_test_oracle"]

#: Side of the box of the per-pixel zero-motion test.
ZERO_TEST_BOX = 9


def zero_motion_sums_oracle(flow, reference, alternate, noise_map, rho, box=ZERO_TEST_BOX):
    """``(S, Q)`` per pixel, float64: ``S`` the sum over the ``box × box`` box of ``d``, ``Q`` that of ``var``.

    Per pixel ``p`` (``r = reference``, ``a = alternate``, both float32, ``v = noise_map[p]``): the bilinear
    sample ``a_u = a(p + F(p))`` at the position clamped to the image (interpolated along ``x``, then along
    ``y``, as the specification writes it), with tap weights ``w`` and ``w₀``
    the weight of the tap on ``p`` itself (0 when ``p`` is not a tap); ``x = r(p) − a(p)``, ``y = r(p) − a_u``;
    ``σ_x² = 2v(1 − ρ)``, ``σ_y² = v(1 + Σw² − 2ρw₀)``, ``c = v(1 + w₀)(1 − ρ)``;
    ``d = x² − y² − (σ_x² − σ_y²)``, ``var = max(2σ_x⁴ + 2σ_y⁴ − 4c², 0)``.  The box reads ``d`` and ``var``
    at clamped coordinates (edge replicate).
    """
    ref = np.asarray(reference, np.float32)
    alt = np.asarray(alternate, np.float32)
    h, w = ref.shape
    d = np.zeros((h, w))
    var = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            sy, sx = y + float(flow[0, y, x]), x + float(flow[1, y, x])
            taps = bilinear_taps((h, w), sy, sx)
            (y0, x0), (y1, x1), fy, fx = bilinear_cell((h, w), sy, sx)
            a_u = ((1.0 - fy) * ((1.0 - fx) * float(alt[y0, x0]) + fx * float(alt[y0, x1]))
                   + fy * ((1.0 - fx) * float(alt[y1, x0]) + fx * float(alt[y1, x1])))  # along x first, as specified
            sum_w2 = sum(weight * weight for _, weight in taps)
            w0 = sum(weight for tap, weight in taps if tap == (y, x))
            v = float(noise_map[y, x])
            s_x = 2.0 * v * (1.0 - rho)
            s_y = v * (1.0 + sum_w2 - 2.0 * rho * w0)
            c = v * (1.0 + w0) * (1.0 - rho)
            xd = float(ref[y, x]) - float(alt[y, x])
            yd = float(ref[y, x]) - a_u
            d[y, x] = xd * xd - yd * yd - (s_x - s_y)
            var[y, x] = max(2.0 * s_x * s_x + 2.0 * s_y * s_y - 4.0 * c * c, 0.0)
    half = box // 2
    total_d = np.zeros((h, w))
    total_var = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            for dy in range(-half, half + 1):
                for dx in range(-half, half + 1):
                    yy, xx = min(max(y + dy, 0), h - 1), min(max(x + dx, 0), w - 1)
                    total_d[y, x] += d[yy, xx]
                    total_var[y, x] += var[yy, xx]
    return total_d, total_var


def zero_motion_test_oracle(flow, reference, alternate, z, noise=None, correlation=None, box=ZERO_TEST_BOX):
    """``(2, h, w) float32``: ``flow`` set to 0 at the pixels where ``S < −z √Q`` (:func:`zero_motion_sums_oracle`).

    ``noise``: the noise variance of each frame (a number or an ``(h, w)`` map; default
    ``½ (local_noise(reference) + local_noise(alternate))``); ``correlation``: ``ρ`` (default
    :func:`estimate_noise_correlation_oracle` of the two frames), clipped below at −½.
    """
    ref = np.asarray(reference, np.float32)
    alt = np.asarray(alternate, np.float32)
    out = np.array(flow, np.float32)
    v = noise_map_oracle(noise, ref, alt)
    rho = estimate_noise_correlation_oracle(ref, alt) if correlation is None else float(correlation)
    s, q = zero_motion_sums_oracle(out, ref, alt, v, max(rho, MIN_CORRELATION), box)
    for y in range(ref.shape[0]):
        for x in range(ref.shape[1]):
            if s[y, x] < -z * np.sqrt(q[y, x]):
                out[:, y, x] = 0.0
    return out
