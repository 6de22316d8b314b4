"""Oracle for the SURE guard (:mod:`spikeref.denoise.guard`; not in the paper), pixel by pixel."""

import math

import numpy as np

from spikeref.oracles.case import OracleCase
from spikeref.oracles.shrinkage import box3_mean

__all__ = ["noise_sigma_oracle", "sure_alpha_oracle", "quantisation_variance_oracle", "carried_excess_variance_oracle",
           "GOLDEN_CASES"]


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


# ----------------------------------------------------------------------------- the golden cases
def _inputs_guard():
    """Four 9×13 planes ``y`` of rates of a ``W = 10`` window (binomial counts of a field with a step edge
    and a ramp), ``f`` = their 3×3 mean (a linear denoiser, so ``f(y + εb) = f(y) + ε·f(b)`` is the probed
    output), a ±1 probe ``b``, the probe steps ``ε`` (the last 0: no divergence term), a σ per plane and one
    per pixel, and a short window ``S`` (rates at ``W₀ = 10``) of the same field for the variance carried to
    ``W = 50``.  On the last plane ``f = y`` on rows 0 … 4, so the radius-2 boxes of rows 0 … 2 hold no
    residual (``α = 1`` there); a dark corner (rate 0.01) reaches the floors' low-rate branches."""
    rng = np.random.default_rng(31)
    h, w = 9, 13
    truth = np.where(np.arange(w) < 6, 0.12, 0.55) + np.linspace(0.0, 0.3, 4 * h).reshape(4, h, 1)
    truth[:, 6:, :4] = 0.01  # a dark corner: the floor's p/W and the charge's p²/(6W²) branches
    noisy = rng.binomial(10, truth) / 10.0
    probe = (rng.integers(0, 2, (4, h, w)) * 2 - 1).astype(np.float64)
    eps = np.array([0.004, 0.006, 0.009, 0.0])
    denoised = box3_mean(noisy)
    denoised[3, :5] = noisy[3, :5]
    probed = denoised + eps[:, None, None] * box3_mean(probe)
    short = rng.binomial(10, truth) / 10.0
    return {"noisy": noisy, "denoised": denoised, "probed": probed, "probe": probe, "eps": eps,
            "sigma_plane": np.array([0.05, 0.08, 0.1, 0.12]), "sigma_pixel": np.sqrt(truth * (1 - truth) / 10.0),
            "short": short}


def _guard_outputs(i, sigma, floor, carried, alpha):
    """σ of each plane of ``y``; the floors of ``f`` at ``W = 10`` (count, charge); the excess variance of ``S``
    carried from ``W₀ = 10`` to ``W = 50`` (count, charge); ``α`` with one σ per plane (radius 8, the
    pipeline's) and one per pixel (radius 2)."""
    y, f, fb, b, eps = i["noisy"], i["denoised"], i["probed"], i["probe"], i["eps"]
    return {"sigma": sigma(y), "floor_count": floor(f, 10.0, "count"), "floor_charge": floor(f, 10.0, "charge"),
            "carried_count": carried(i["short"], 10.0, 50.0, "count"),
            "carried_charge": carried(i["short"], 10.0, 50.0, "charge"),
            "alpha_plane": alpha(y, f, fb, b, eps, i["sigma_plane"], 8),
            "alpha_pixel": alpha(y, f, fb, b, eps, i["sigma_pixel"], 2)}


def _guard_oracle(i):
    """:func:`_guard_outputs` with the oracles, plane by plane and pixel by pixel."""
    def floor(rates, window, accumulate):
        return np.vectorize(lambda p: quantisation_variance_oracle(p, window, accumulate))(rates)

    def alpha(y, f, fb, b, eps, sigma, radius):
        return np.stack([sure_alpha_oracle(y[c], f[c], fb[c], b[c], eps[c], sigma[c], radius) for c in range(len(y))])

    return _guard_outputs(
        i, lambda y: np.array([noise_sigma_oracle(p) for p in y]), floor,
        lambda s, w0, w, acc: np.array([carried_excess_variance_oracle(p, w0, w, accumulate=acc) for p in s]),
        alpha)


GOLDEN_CASES = (
    OracleCase(
        "sure_guard", "— (not in the paper; the SURE guard of the output's D, Denoiser(guard=\"sure\"))",
        "spikeref.denoise.guard.noise_sigma / quantisation_variance / carried_excess_variance / sure_alpha",
        "spikeref.oracles.guard.noise_sigma_oracle / quantisation_variance_oracle / "
        "carried_excess_variance_oracle / sure_alpha_oracle",
        "The pieces of the SURE guard on four 9×13 planes of W = 10 rates with a 3×3 mean as the denoiser: the "
        "noise σ of each plane (the smallest 75 % of the |3×3 difference-of-Laplacians| responses, over the "
        "truncated half-normal's mean), the quantisation floor of f at W = 10 for counts and for charges, the "
        "variance above the floor of a short window carried from W₀ = 10 to W = 50 (counts, charges), and the "
        "blend weight α = clip(Σ_N σ²(1 − b(f_b − f)/ε) / Σ_N (f − y)², 0, 1) over the half-sample-symmetric "
        "box N with one σ per plane (radius 8) and one per pixel (radius 2), ε = 0 dropping the divergence "
        "term and α = 1 where the box holds no residual.",
        _inputs_guard, _guard_oracle,
        rtol=1e-9, atol=1e-12,
        params={"keep": 0.75, "window": 10, "short_window": 10, "carried_to": 50, "radii": [8, 2],
                "border": "half-sample symmetric (a b c | c b a), repeated"},
        spec="docs/spec/denoise.md#sure_guard",
        outputs=_guard_outputs,
    ),
)
