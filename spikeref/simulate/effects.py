"""Noise effects of a spike camera, each a stage that runs only when a scene lists it.

Each effect is a small frozen dataclass holding its parameters (validated on
construction, errors name the field).  The simulator (:mod:`spikeref.simulate.simulator`)
applies, in this order:

1. ``threshold_fpn`` — per-pixel thresholds ``E_th,x = E_th (1 + σ z_x)``, ``z ~ N(0, 1)``,
   fixed for the whole recording (fixed-pattern noise; the same seed gives the same pattern);
2. ``random_phase`` — initial accumulator ``~ U[0, E_th,x)`` instead of 0;
3. ``hot_pixels`` — a fraction of pixels receive a constant extra charge (a leaky defect
   that fires regardless of light), the same for all or drawn from a range of rates;
4. ``shot_noise`` — photon arrivals are Poisson: the charge of a readout is
   ``Poisson(λ) · E_th / n_th`` with ``λ = α L n_th / E_th`` photons, ``n_th`` photons per threshold;
5. ``dark_current`` — diffuse noise (Eq. 5): ``Poisson(γ)`` extra photons per readout, each
   carrying charge ``α``, so ``E[N_d] = α γ W / E_th`` spikes per window (Eq. 6);
6. integrate-and-fire (Eq. 1–2, :func:`spikeref.simulate.camera.fire`);
7. ``inherent_noise`` — spurious spikes independent of light (Eq. 7): each affected pixel
   fires at intervals drawn from ``N(μ, σ)`` readouts (truncated to ``T ≥ 1``, rounded to
   whole readouts), OR-ed with the integrate-and-fire output.

Sources: diffuse (dark-current) and inherent noise and their models are the paper's §4.1,
after its reference [41]; threshold perturbation is named in its supplement's simulator
description; random phase is the state of a sensor that was running before the recording
starts; hot pixels are the "defect pixels" of the EMVA Standard 1288 (Release 4.0, 2021),
a generic image-sensor defect added here because a real sensor has them.

A scene that lists no effect is noise-free and deterministic.  Units: time in readouts
(1/20 000 s), charge in the unit of ``E_th`` (``α L`` per readout, see
:mod:`spikeref.simulate.camera`).

On Eq. 8: the paper approximates the expected number of inherent-noise spikes in ``W``
readouts by ``C_i W`` with ``C_i = ∫_1^∞ N(T | μ, σ) / T dT``.  For a renewal process the
exact rate is ``1 / E[T | T ≥ 1]``; :func:`inherent_rate_paper` and
:func:`inherent_rate_exact` give both, and they agree to ``O(σ²/μ²)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np


__all__ = [
    "RandomPhase",
    "HotPixels",
    "ShotNoise",
    "DarkCurrent",
    "InherentNoise",
    "ThresholdFPN",
    "EFFECTS",
    "parse_effects",
    "dark_expected_count",
    "noise_fraction",
    "inherent_rate_paper",
    "inherent_rate_exact",
    "draw_inherent_intervals",
    "draw_first_inherent",
    "fpn_thresholds",
    "initial_phase",
    "hot_pixel_charge",
    "add_shot_noise",
    "add_dark_current",
    "InherentNoiseProcess",
]


def _positive(name, value, allow_zero=False):
    ok = np.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        raise ValueError(f"{name} must be {'non-negative' if allow_zero else 'positive'} and finite; got {value!r}")


@dataclass(frozen=True)
class RandomPhase:
    """Initial accumulator uniform in ``[0, E_th)`` (a sensor that was already running)."""

    name = "random_phase"


@dataclass(frozen=True)
class ShotNoise:
    """Poisson photon arrivals.

    Attributes
    ----------
    photons_per_threshold : float
        ``n_th``: photons whose charge adds up to one threshold ``E_th`` (> 0).  Smaller is
        noisier: the spike count over many readouts has variance ≈ mean / ``n_th``.
    """

    photons_per_threshold: float = 50.0
    name = "shot_noise"

    def __post_init__(self):
        _positive("shot_noise.photons_per_threshold", self.photons_per_threshold)


@dataclass(frozen=True)
class DarkCurrent:
    """Diffuse noise, Eq. 5: ``Poisson(γ)`` dark photons per readout, charge ``α`` each.

    Attributes
    ----------
    gamma : float
        ``γ``, expected dark photons per readout (≥ 0).  Eq. 6: ``E[N_d] = α γ W / E_th``.
    """

    gamma: float = 0.002
    name = "dark_current"

    def __post_init__(self):
        _positive("dark_current.gamma", self.gamma, allow_zero=True)


@dataclass(frozen=True)
class InherentNoise:
    """Spurious spikes at Gaussian intervals, Eq. 7.

    Attributes
    ----------
    mu, sigma : float
        Mean and standard deviation of the interval in readouts (``mu ≥ 1``, ``sigma ≥ 0``).
    fraction : float
        Share of pixels affected (0…1); which ones is drawn from the seed.
    """

    mu: float = 2000.0
    sigma: float = 200.0
    fraction: float = 1.0
    name = "inherent_noise"

    def __post_init__(self):
        if not (np.isfinite(self.mu) and self.mu >= 1):
            raise ValueError(f"inherent_noise.mu must be at least 1 readout; got {self.mu!r}")
        _positive("inherent_noise.sigma", self.sigma, allow_zero=True)
        if not (np.isfinite(self.fraction) and 0 <= self.fraction <= 1):
            raise ValueError(f"inherent_noise.fraction must lie in [0, 1]; got {self.fraction!r}")


@dataclass(frozen=True)
class ThresholdFPN:
    """Per-pixel threshold perturbation ``E_th,x = E_th (1 + σ_fpn z)``, ``z ~ N(0, 1)``.

    Attributes
    ----------
    sigma : float
        Relative standard deviation (0 ≤ σ < 0.5); thresholds are clipped to ``[0.1, 1.9] E_th``.
    """

    sigma: float = 0.02
    name = "threshold_fpn"

    def __post_init__(self):
        if not (np.isfinite(self.sigma) and 0 <= self.sigma < 0.5):
            raise ValueError(f"threshold_fpn.sigma must lie in [0, 0.5); got {self.sigma!r}")


@dataclass(frozen=True)
class HotPixels:
    """Defect pixels that collect charge without light (EMVA 1288 "defect pixels").

    Attributes
    ----------
    fraction : float
        Share of pixels that are hot (0…1); which ones is drawn from the seed.
    rate : float
        Extra firing rate of a hot pixel in spikes per readout (0…1): it collects
        ``rate · E_th`` extra charge every readout.
    rate_max : float, optional
        With it, each hot pixel's extra rate is drawn uniformly from ``[rate, rate_max]`` (real defects
        differ in strength); without it every hot pixel has ``rate``.
    """

    fraction: float = 1e-4
    rate: float = 0.2
    rate_max: float | None = None
    name = "hot_pixels"

    def __post_init__(self):
        if not (np.isfinite(self.fraction) and 0 <= self.fraction <= 1):
            raise ValueError(f"hot_pixels.fraction must lie in [0, 1]; got {self.fraction!r}")
        if not (np.isfinite(self.rate) and 0 <= self.rate <= 1):
            raise ValueError(f"hot_pixels.rate must lie in [0, 1] spikes per readout; got {self.rate!r}")
        if self.rate_max is not None and not (np.isfinite(self.rate_max) and self.rate <= self.rate_max <= 1):
            raise ValueError(f"hot_pixels.rate_max must lie in [rate, 1] = [{self.rate:g}, 1] spikes per readout; "
                             f"got {self.rate_max!r}")


#: Every effect by its scene-file name, in the order the simulator applies them.
EFFECTS = {cls.name: cls for cls in (ThresholdFPN, RandomPhase, HotPixels, ShotNoise, DarkCurrent, InherentNoise)}


def parse_effects(spec) -> dict:
    """Effects from a mapping ``{name: {param: value}}`` (or a list of names, default params).

    Returns ``{name: effect}``.  Unknown names or parameters raise ``ValueError`` naming them.
    """
    if spec is None:
        return {}
    if isinstance(spec, (list, tuple)):
        spec = {name: {} for name in spec}
    if not isinstance(spec, dict):
        raise TypeError(f"effects must be a table of effect names; got {type(spec).__name__}")
    out = {}
    for name, params in spec.items():
        if name not in EFFECTS:
            raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}")
        if isinstance(params, EFFECTS[name]):  # already parsed
            out[name] = params
            continue
        params = {} if params is None or params is True else params
        if not isinstance(params, dict):
            raise TypeError(f"parameters of effect {name!r} must be a table; got {params!r}")
        known = {f.name for f in fields(EFFECTS[name])}
        for key in params:
            if key not in known:
                raise ValueError(
                    f"unknown parameter {name}.{key}; {name} takes {', '.join(sorted(known)) or 'no parameters'}"
                )
        try:
            out[name] = EFFECTS[name](**{k: float(v) for k, v in params.items()})
        except (TypeError, ValueError) as exc:
            raise ValueError(f"effect {name}: {exc}") from None
    return out


# ------------------------------------------------------------------------- Eq. 6, 9
def dark_expected_count(alpha: float, gamma: float, window: float, threshold: float) -> float:
    """Eq. 6: expected diffuse-noise spikes of a dark pixel in ``W`` readouts, ``α γ W / E_th``.

    Exact for the simulator when the pixel starts at a uniform random phase
    (``random_phase``): ``E[⌊U + X⌋] = E[X]`` for ``U ~ U[0, 1)`` independent of ``X``.
    """
    return alpha * gamma * window / threshold


def noise_fraction(alpha: float, gamma: float, threshold: float, mu: float, sigma: float,
                   exact: bool = False) -> float:
    """Eq. 9: expected fraction of noise spikes per readout, ``α γ / E_th + C_i``.

    ``exact=False`` uses the paper's ``C_i`` (:func:`inherent_rate_paper`), ``exact=True``
    the renewal rate (:func:`inherent_rate_exact`).  Eq. 9 adds the two rates; in the
    simulator a diffuse and an inherent spike in the same readout are read out as one, so
    the observed fraction is smaller by ``≈ r_d r_i`` (second order).
    """
    c_i = inherent_rate_exact(mu, sigma) if exact else inherent_rate_paper(mu, sigma)
    return alpha * gamma / threshold + c_i


# ---------------------------------------------------------------------------- Eq. 8
_trapezoid = getattr(np, "trapezoid", None) or np.trapz  # NumPy 2 renamed trapz


def _normal_cdf(x):
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def inherent_rate_paper(mu: float, sigma: float) -> float:
    """``C_i`` of Eq. 8: ``∫_1^∞ N(T | μ, σ) / T dT``, spikes per readout.

    Computed by the trapezoid rule on 200 001 points over ``μ ± 12σ`` (cut at 1); the
    oracle :func:`spikeref.oracles.effects.inherent_rate_paper_oracle` integrates the same
    expression adaptively.  For ``σ = 0`` the integral is ``1/μ``.
    """
    _check_mu_sigma(mu, sigma)
    if sigma == 0:
        return 1.0 / mu
    t = np.linspace(max(1.0, mu - 12 * sigma), mu + 12 * sigma, 200001)
    pdf = np.exp(-0.5 * ((t - mu) / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi))
    return float(_trapezoid(pdf / t, t))


def _check_mu_sigma(mu, sigma):
    if not (np.isfinite(mu) and mu >= 1):
        raise ValueError(f"mu must be at least 1 readout; got {mu!r}")
    if not (np.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma must be non-negative and finite; got {sigma!r}")


def inherent_rate_exact(mu: float, sigma: float) -> float:
    """The simulator's inherent-noise rate: ``1 / E[rint(T) | T ≥ 1]`` spikes per readout.

    The spurious spikes form a renewal process whose intervals are ``T ~ N(μ, σ)``
    truncated to ``T ≥ 1`` and rounded to whole readouts; started in its stationary state
    (see :func:`draw_first_inherent`), its expected count in any ``W`` readouts is exactly
    ``W / E[interval]``.  The paper's Eq. 8 uses ``E[1/T]`` instead of ``1 / E[T]``;
    the two agree to ``O(σ²/μ²)`` (Jensen: the paper's value is the larger).
    """
    _check_mu_sigma(mu, sigma)
    if sigma == 0:
        return 1.0 / max(1.0, float(np.rint(mu)))
    z1 = (1.0 - mu) / sigma
    mass = 1.0 - _normal_cdf(z1)  # P(T >= 1)
    k_hi = int(math.ceil(mu + 14 * sigma)) + 1
    k_lo = max(1, int(math.floor(mu - 14 * sigma)))
    mean = 0.0
    for k in range(k_lo, k_hi + 1):  # P(rint(T) = k | T >= 1); the first bin starts at 1, not 0.5
        lo = max(1.0, k - 0.5)
        p = _normal_cdf((k + 0.5 - mu) / sigma) - _normal_cdf((lo - mu) / sigma)
        mean += k * p
    return mass / mean


def draw_inherent_intervals(rng: np.random.Generator, mu: float, sigma: float, size) -> np.ndarray:
    """Intervals in whole readouts: ``rint(T)``, ``T ~ N(μ, σ)`` truncated to ``T ≥ 1`` (rejection), int64."""
    out = np.empty(size, dtype=np.float64).ravel()
    todo = np.arange(out.size)
    while todo.size:
        draw = rng.normal(mu, sigma, todo.size) if sigma > 0 else np.full(todo.size, float(mu))
        ok = draw >= 1.0
        out[todo[ok]] = draw[ok]
        todo = todo[~ok]
    return np.maximum(1, np.rint(out)).astype(np.int64).reshape(size)


def draw_first_inherent(rng: np.random.Generator, mu: float, sigma: float, size) -> np.ndarray:
    """First spurious spike of each pixel, in readouts from the start, int64.

    The renewal process is started in its stationary state, so a recording begins
    "mid-stream" like a sensor that was already running: the interval covering time 0 is
    drawn length-biased (probability ∝ its length, by rejection) and the first spike falls
    uniformly inside it.  This makes the expected count in ``[0, W)`` exactly ``W / E[T]``.
    """
    n = int(np.prod(size))
    cap = mu + 8 * sigma + 1
    biased = np.empty(n, dtype=np.int64)
    todo = np.arange(n)
    while todo.size:
        t = draw_inherent_intervals(rng, mu, sigma, todo.size)
        ok = rng.random(todo.size) * cap < np.minimum(t, cap)
        biased[todo[ok]] = t[ok]
        todo = todo[~ok]
    return rng.integers(0, biased).reshape(size)


# ------------------------------------------------------------------------- stages
def fpn_thresholds(effect: ThresholdFPN, threshold: float, shape, rng: np.random.Generator) -> np.ndarray:
    """Per-pixel thresholds ``E_th (1 + σ z)``, clipped to ``[0.1, 1.9] E_th``; ``(H, W) float64``."""
    z = rng.standard_normal(shape)
    return threshold * np.clip(1.0 + effect.sigma * z, 0.1, 1.9)


def initial_phase(thresholds: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Initial accumulator ``U[0, E_th,x)`` per pixel; ``(H, W) float64``."""
    return rng.random(thresholds.shape) * thresholds


def hot_pixel_charge(effect: HotPixels, threshold: float, shape, rng: np.random.Generator) -> np.ndarray:
    """Extra charge per readout ``(H, W) float64``: ``rate · E_th`` on the hot pixels, 0 elsewhere.

    With ``rate_max``, each pixel's rate is ``U[rate, rate_max]``, drawn after the choice of the hot
    pixels (so the same seed picks the same pixels with or without it).
    """
    hot = rng.random(shape) < effect.fraction
    rate = effect.rate if effect.rate_max is None else rng.uniform(effect.rate, effect.rate_max, shape)
    return np.where(hot, rate * threshold, 0.0)


def add_shot_noise(charge: np.ndarray, effect: ShotNoise, threshold: float, rng: np.random.Generator) -> None:
    """Replace each readout's charge by its photon count: ``Poisson(q n_th / E_th) E_th / n_th``, in place.

    ``charge`` is ``(n, H, W) float64``; draws run in C order, so the first ``m`` planes of
    a block are the same whether ``n = m`` or more.
    """
    unit = threshold / effect.photons_per_threshold
    charge[...] = rng.poisson(charge / unit) * unit


def add_dark_current(charge: np.ndarray, effect: DarkCurrent, alpha: float, block: int,
                     rng: np.random.Generator) -> None:
    """Add the dark photons (Eq. 5) of one block of ``block`` readouts to ``charge[:n]``, in place.

    Each (readout, pixel) receives ``Poisson(γ)`` photons of charge ``α``.  Drawn sparsely:
    the block's total ``Poisson(γ · block · H · W)``, then a uniform position for each
    photon (the same law, by Poisson splitting), so the cost grows with the number of dark
    photons, not of pixels.  Photons that fall beyond ``n = len(charge)`` are dropped, which
    keeps a shortened last block a prefix of the full one.
    """
    n, h, w = charge.shape
    total = rng.poisson(effect.gamma * block * h * w)
    if total == 0:
        return
    pos = rng.integers(0, block * h * w, size=total)
    pos = pos[pos < n * h * w]
    np.add.at(charge.reshape(-1), pos, alpha)


class InherentNoiseProcess:
    """Spurious spikes of Eq. 7 as one renewal process per affected pixel.

    Parameters
    ----------
    effect : InherentNoise
    shape : tuple ``(H, W)``
    rng : numpy.random.Generator
        Draws which pixels are affected and their first spike (:func:`draw_first_inherent`).

    Notes
    -----
    :meth:`apply_block` is called for consecutive blocks of readouts, each with its own
    generator; the intervals a block needs are drawn from that block's generator only, so a
    simulation cut into chunks at block boundaries gives the same spikes as one run.
    """

    def __init__(self, effect: InherentNoise, shape, rng: np.random.Generator):
        self.effect = effect
        self.width = shape[1]
        affected = rng.random(shape).ravel() < effect.fraction
        self.pixels = np.flatnonzero(affected)
        self.next_time = draw_first_inherent(rng, effect.mu, effect.sigma, self.pixels.size)

    def apply_block(self, spikes: np.ndarray, start: int, block: int, rng: np.random.Generator) -> None:
        """OR the spurious spikes of readouts ``[start, start + block)`` into ``spikes`` ``(n, H, W)``.

        ``spikes[k]`` is readout ``start + k``; spikes at ``k ≥ n`` are computed (the state
        moves past the whole block) but not written.
        """
        n = spikes.shape[0]
        flat = spikes.reshape(n, -1)
        end = start + block
        active = np.flatnonzero(self.next_time < end)
        while active.size:
            t = self.next_time[active] - start
            inside = t < n
            flat[t[inside], self.pixels[active[inside]]] = 1
            self.next_time[active] += draw_inherent_intervals(rng, self.effect.mu, self.effect.sigma, active.size)
            active = active[self.next_time[active] < end]
