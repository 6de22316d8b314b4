"""Oracle for the SURE guard (:mod:`spikeref.denoise.guard`; not in the paper), pixel by pixel."""

import math

import numpy as np

__all__ = ["noise_sigma_oracle", "sure_alpha_oracle", "quantisation_variance_oracle", "carried_excess_variance_oracle"]


def quantisation_variance_oracle(p, window, accumulate="count"):
    """``{pW}(1 − {pW})/W²`` averaged over the phase: ``p(1 − pW)/W ≈ p/W`` below one spike, else ``1/(6W²)``.

    Written as the implementation's floor ``min(min(p, 1 − p)/W, 1/(6W²))`` for one pixel; for the
    window charge (``accumulate="charge"``) at most ``p²/(6W²)``.
    """
    p = min(max(float(p), 0.0), 1.0)
    floor = min(min(p, 1 - p) / window, 1 / (6 * window * window))
    if accumulate == "charge":
        floor = min(floor, p * p / (6 * window * window))
    return floor


def noise_sigma_oracle(plane, keep=0.75):
    """σ of one plane: the smallest ``keep`` share of |3×3 difference-of-Laplacians| responses, averaged.

    The response at interior pixel ``(y, x)`` is ``Σ k[i][j] · plane[y−1+i][x−1+j]`` with
    ``k = [[1, −2, 1], [−2, 4, −2], [1, −2, 1]]``; white Gaussian noise of σ gives responses of
    ``6σ``, whose absolute values form a half-normal; the mean of its smallest share ``keep`` is
    ``√(2/π)(1 − exp(−u²/2))/keep`` standard units with ``u`` the ``(1 + keep)/2`` normal quantile.
    """
    from statistics import NormalDist

    plane = np.asarray(plane, dtype=np.float64)
    kernel = [[1, -2, 1], [-2, 4, -2], [1, -2, 1]]
    h, w = plane.shape
    if h < 3 or w < 3:
        return 0.0
    responses = []
    for y in range(1, h - 1):
        for x in range(1, w - 1):
            r = 0.0
            for i in range(3):
                for j in range(3):
                    r += kernel[i][j] * plane[y - 1 + i, x - 1 + j]
            responses.append(abs(r))
    responses.sort()
    count = max(1, round(len(responses) * keep))
    if (1 + keep) / 2 >= 1:  # the whole half-normal (keep within rounding of 1): mean √(2/π)
        unit = math.sqrt(2 / math.pi)
    else:
        u = NormalDist().inv_cdf((1 + keep) / 2)
        unit = math.sqrt(2 / math.pi) * (1 - math.exp(-u * u / 2)) / keep
    return sum(responses[:count]) / count / (6 * unit)


def carried_excess_variance_oracle(short, short_window, window, keep=0.75, accumulate="count"):
    """One plane: ``max(0, σ(short)² − mean over pixels of q(p, W₀)) · W₀ / W``.

    ``σ`` is :func:`noise_sigma_oracle` of the short window's plane, ``q`` the quantisation floor
    :func:`quantisation_variance_oracle` (``accumulate``'s) of each of its pixels at ``W₀ =
    short_window``: what the floor does not explain, carried to ``W = window`` as noise that falls
    as ``1/W``.
    """
    short = np.asarray(short, dtype=np.float64)
    floors = [quantisation_variance_oracle(p, short_window, accumulate) for p in short.ravel()]
    excess = noise_sigma_oracle(short, keep) ** 2 - sum(floors) / len(floors)
    return max(0.0, excess) * short_window / window


def sure_alpha_oracle(noisy, denoised, probed, probe, eps, sigma, radius=8):
    """``α = clip(Σ_N σ²(1 − b (f_b − f)/ε) / Σ_N (f − y)², 0, 1)`` over the box ``N``, one plane.

    ``sigma`` is one σ for the plane or one per pixel.

    ``N`` is the ``(2·radius + 1)²`` box around the pixel, the plane mirrored half-sample
    symmetrically beyond its border (``a b c | c b a``); ``α = 1`` where ``Σ_N (f − y)² = 0``.
    """
    y = np.asarray(noisy, dtype=np.float64)
    f = np.asarray(denoised, dtype=np.float64)
    fb = np.asarray(probed, dtype=np.float64)
    b = np.asarray(probe, dtype=np.float64)
    h, w = y.shape
    s = np.broadcast_to(np.asarray(sigma, dtype=np.float64), (h, w))  # one σ, or one per pixel

    def mirror(i, n):
        while i < 0 or i >= n:
            i = -i - 1 if i < 0 else 2 * n - 1 - i
        return i

    alpha = np.zeros((h, w))
    for py in range(h):
        for px in range(w):
            num = den = 0.0
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    qy, qx = mirror(py + dy, h), mirror(px + dx, w)
                    derivative = b[qy, qx] * (fb[qy, qx] - f[qy, qx]) / eps if eps > 0 else 0.0
                    num += s[qy, qx] ** 2 * (1 - derivative)
                    den += (f[qy, qx] - y[qy, qx]) ** 2
            alpha[py, px] = 1.0 if den == 0 else min(1.0, max(0.0, num / den))
    return alpha
