"""Oracles for the noise models, Eq. 5–9: the paper's formulas, transcribed as literally as possible."""

import math

import numpy as np

from scipy import integrate, stats

__all__ = [
    "dark_expected_count_oracle",
    "inherent_rate_paper_oracle",
    "inherent_rate_exact_oracle",
    "noise_fraction_oracle",
]


def dark_expected_count_oracle(alpha, gamma, window, threshold):
    """Eq. 6: ``E[N_d] = (α γ W) / E_th``."""
    return (alpha * gamma * window) / threshold


def inherent_rate_paper_oracle(mu, sigma):
    """Eq. 8 with ``W = 1``: ``C_i = ∫_1^∞ (1/T) · 1/(σ√(2π)) · exp(−½((T − μ)/σ)²) dT`` (adaptive quadrature)."""

    def integrand(t):
        return (1.0 / t) * 1.0 / (sigma * math.sqrt(2 * math.pi)) * math.exp(-0.5 * ((t - mu) / sigma) ** 2)

    lo, hi = max(1.0, mu - 40 * sigma), mu + 40 * sigma
    value, _ = integrate.quad(integrand, lo, hi, points=[mu], limit=500, epsabs=0, epsrel=1e-12)
    return value


def inherent_rate_exact_oracle(mu, sigma):
    """``1 / E[rint(T) | T ≥ 1]`` for ``T ~ N(μ, σ)``: each whole interval ``k`` weighted by its probability."""
    if sigma == 0:
        return 1.0 / max(1.0, round(mu))
    dist = stats.truncnorm((1.0 - mu) / sigma, math.inf, loc=mu, scale=sigma)
    k = np.arange(1, math.ceil(mu + 40 * sigma) + 1, dtype=np.float64)
    lo = np.maximum(1.0, k - 0.5)  # rint(T) = k for T in [k − ½, k + ½), and T ≥ 1
    mean = np.sum(k * (dist.cdf(k + 0.5) - dist.cdf(lo)))
    return 1.0 / mean


def noise_fraction_oracle(alpha, gamma, threshold, mu, sigma):
    """Eq. 9: ``E[N]/W = α γ / E_th + C_i``."""
    return alpha * gamma / threshold + inherent_rate_paper_oracle(mu, sigma)
