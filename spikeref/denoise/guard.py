"""A guard that keeps the denoiser from doing harm: a blend chosen by Stein's unbiased risk estimate.

Not in the paper.  The bundled network was trained on procedural scenes; on photographs and at
long exposures it removes detail that is well above the noise (``docs/results.md``, stage
ladder).  This module blends its output ``f(y)`` with its input ``y``,

.. math::

    \\hat x = y + \\alpha\\,(f(y) - y),

with ``α ∈ [0, 1]`` chosen per pixel from a neighbourhood, **without ground truth**, by
minimising Stein's unbiased risk estimate (SURE) of the mean squared error.  For ``y = x + n``
with independent zero-mean noise of variance ``σ²``, the SURE of ``h(y) = y + α(f(y) − y)``
over a neighbourhood ``N`` is

.. math::

    \\mathrm{SURE}(\\alpha) = \\alpha^2 \\sum_N (f - y)^2 - \\sum_N \\sigma^2
        + 2 \\sum_N \\sigma^2 \\bigl(1 - \\alpha + \\alpha\\,\\partial f_i/\\partial y_i\\bigr),

minimised at

.. math::

    \\alpha = \\mathrm{clip}\\Bigl(\\frac{\\sum_N \\sigma^2 (1 - \\partial f_i / \\partial y_i)}
                                     {\\sum_N (f - y)^2},\\; 0,\\; 1\\Bigr).

Where the network removes about as much as the noise explains, ``α → 1`` (its output is kept);
where it removes more (detail), ``α`` falls and the input comes back.  The divergence terms
``∂f_i/∂y_i`` are estimated by one more pass of the network on a probed input (Monte-Carlo
divergence, Ramani, Blu & Unser 2008): ``σ_i² ∂f_i/∂y_i ≈ σ_i² b_i (f(y + εb) − f(y))_i / ε``
with a Rademacher probe ``b`` (±1, fixed seed, so the output is deterministic).

Interpretations (the noise of spike counts):

* **σ is estimated from the data**, per plane, after Immerkær (:func:`noise_sigma`: the
  truncated mean absolute response of a 3×3 kernel that cancels locally linear signal; a
  median, as in Donoho's MAD, fails on quantised rates).  The binomial variance
  ``p(1 − p)/W`` of :mod:`spikeref.denoise.shrinkage` is far too high for integrate-and-fire
  counts (whose noise is mostly the ±1 quantisation of the count: about 10× less at ``W = 10``),
  and a real sensor's noise is not known in advance; the estimate needs neither.
* The noise is taken as white with one ``σ`` per plane.  After warping (Eq. 14–15) it is
  spatially correlated and the Haar estimate sees less of it, so ``α`` errs towards the input.
* ``N`` is the ``(2·radius + 1)²`` box around each pixel (half-sample symmetric border,
  SciPy's ``reflect``), :data:`DEFAULT_RADIUS` = 8 plane pixels; where ``Σ_N (f − y)² = 0``
  (the network changed nothing) ``α = 1``.
* ``σ²`` per pixel is ``max(σ_c², q(f(y)))``: the plane's :func:`noise_sigma` squared and, when the exposure
  ``window`` is given (the pipeline), the count's :func:`quantisation_variance` at the network's output.
* **Long windows: the noise is read only where it dominates** (:func:`trusted_excess`, the
  ``carried=`` that :class:`~spikeref.denoise.denoiser.Denoiser` gives :func:`sure_blend`).  At
  ``W ≳ 50`` every estimate made from the plane itself reads texture and the sensor's fixed pattern as
  noise: on the real SpikingSIM recording it is 1.3–2.4× the true noise at ``W`` = 50–200 (the pixels'
  fixed pattern alone, which the recording's pseudo ground truth carries too, is ≈ 3 % of the rate) and
  the guard then trusts a network that smooths the branches and the pattern (``docs/results_history.md``).  So
  the plane's ``σ_c²`` is capped at ``e + mean q(f(y))`` (``q`` the floor at ``W``), with ``e`` by how
  much the guard can tell:

  - ``W ≤`` :data:`NOISE_WINDOW`: no cap; a window this short is its own short window.
  - a short window of the same stream given (``short=``, at most :data:`NOISE_WINDOW` planes:
    :meth:`Denoiser.frames <spikeref.denoise.denoiser.Denoiser.frames>` and ``spikeref denoise`` pass the
    window's first ``NOISE_WINDOW`` planes, the pipeline with ``accumulate="charge"`` its reference
    window): there the noise dominates the texture, so :func:`carried_excess_variance` measures what
    exceeds the floor and carries it to ``W`` as temporal (shot-like) noise, ``∝ 1/W``, and the guard
    trusts :data:`CARRY_FRACTION` of it: ``e = κ·e₀·W₀/W``.
  - otherwise (a bare call ``den(planes, window=W)``, or a "short" window longer than
    ``NOISE_WINDOW``): ``e = 0``, only the floor, which every spike count has — a lower bound of the
    noise, so ``α`` errs towards the input and the blend is never much worse than it.

  Interpretation: the noise of a window is the quantisation floor plus a part that falls as ``1/W``; a
  fixed-pattern part (threshold spread, which does not fall with ``W``) is not carried, so where it
  dominates the cap keeps more of the input; from one long window alone a fixed pattern, texture and
  noise cannot be told apart (measured: ``docs/results.md``, "Never worse than plain accumulation").
* ``accumulate="charge"`` (the rates are :mod:`spikeref.charge`'s): the floor is the charge's,
  ``min(q, p²/(6W²))`` (:func:`quantisation_variance`), in both the cap and the per-pixel floor.
* The probe's step is ``ε = 0.05 · √(mean over the plane of σ²)`` (:func:`probe_step` of the root mean
  variance); where ``σ² = 0`` everywhere (no noise at all) ``α = 0``: nothing is removed.

The literal oracle is :func:`spikeref.oracles.guard.sure_blend_oracle`.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter
from scipy.special import ndtri

from spikeref.charge import ACCUMULATE
from spikeref.denoise.blindspot import check_image
from spikeref.noise_level import immerkaer_response

__all__ = ["GUARDS", "DEFAULT_RADIUS", "PROBE_SEED", "NOISE_KEEP", "NOISE_WINDOW", "CARRY_FRACTION", "noise_sigma",
           "quantisation_variance", "carried_excess_variance", "trusted_excess", "rademacher_probe", "probe_step",
           "sure_alpha", "sure_blend"]

#: Guards a :class:`~spikeref.denoise.denoiser.Denoiser` accepts: ``"sure"`` (this module) or ``"off"``.
GUARDS = ("sure", "off")
#: Half side of the SURE neighbourhood, in plane pixels.
DEFAULT_RADIUS = 8
#: Seed of the Rademacher probe (the output is a deterministic function of the input).
PROBE_SEED = 0
#: Fraction of the smallest filter responses :func:`noise_sigma` averages.
NOISE_KEEP = 0.75
#: The probe's step as a fraction of the plane's noise σ.
PROBE_FRACTION = 0.05
#: Length (planes) of the short window on which the guard measures the noise of a longer one
#: (:func:`carried_excess_variance`): the paper's W; chosen before measuring, not tuned.
NOISE_WINDOW = 10
#: The share ``κ`` of the excess variance measured on a short window that the guard trusts at a long one
#: (:func:`trusted_excess`).  A blend weight ``α`` overestimated by a factor ``ρ`` does harm once ``ρ > 2``; with
#: ``κα`` it keeps ``2κ − κ²`` (94 %) of the best gain and tolerates ``ρ < 2/κ`` (2.7).  The short window's
#: excess is a rough measure of the ``1/W`` part (on flat simulated fields 0.3–4× the long-window value);
#: chosen 2026-11-27 as the largest of 1, 0.75, 0.5, 0.25 that keeps every held-out scene within 0.1 dB
#: of the identity (``docs/results.md``; the benchmark scenes were within it at all four).
CARRY_FRACTION = 0.75


def _truncated_halfnormal_mean(q: float) -> float:
    """Mean of ``|Z|``, ``Z ~ N(0, 1)``, over its smallest fraction ``q``: ``√(2/π)(1 − e^{−u²/2})/q``."""
    u = float(ndtri((1.0 + q) / 2.0))
    return float(np.sqrt(2.0 / np.pi) * (1.0 - np.exp(-u * u / 2.0)) / q)


def noise_sigma(planes, keep: float = None) -> np.ndarray:
    """Noise σ of each plane, estimated from the plane alone (after Immerkær 1996).

    The plane is filtered by the 3×3 kernel ``[[1, −2, 1], [−2, 4, −2], [1, −2, 1]]``
    (:func:`spikeref.noise_level.immerkaer_response`: it cancels any locally linear signal and
    turns white noise of σ into noise of ``6σ``).  Edges and texture still leave large responses,
    so only the smallest fraction ``keep`` of the absolute responses over the interior is
    averaged, and the mean is divided by ``6 ·`` the mean of a standard half-normal truncated at
    the same fraction (:func:`_truncated_halfnormal_mean`; for white Gaussian noise the estimate
    is unbiased).
    A mean of absolute values, not a median, because spike rates are quantised (multiples of
    ``1/W``): the median of quantised responses is often exactly 0.

    Parameters
    ----------
    planes : ndarray ``(..., h, w)`` float
        Noisy planes (firing rates).
    keep : float, optional
        Fraction of the responses kept, in ``(0, 1]``; default :data:`NOISE_KEEP` (0.75,
        chosen on the benchmark scenes among 1, 0.9 and 0.75: docs/results.md).

    Returns
    -------
    ndarray ``(...)`` float64
        One σ per plane, in the planes' units; 0 for a plane smaller than 3×3.
    """
    keep = NOISE_KEEP if keep is None else keep
    if isinstance(keep, bool) or not isinstance(keep, (int, float, np.integer, np.floating)) or not 0 < keep <= 1:
        raise ValueError(f"keep must be a fraction in (0, 1]; got {keep!r}")
    arr = check_image(planes, "planes").astype(np.float64)
    lead = arr.shape[:-2]
    if arr.shape[-2] < 3 or arr.shape[-1] < 3:
        return np.zeros(lead)
    response = np.sort(immerkaer_response(arr).reshape(lead + (-1,)), axis=-1)
    count = max(1, int(round(response.shape[-1] * keep)))
    return response[..., :count].mean(axis=-1) / (6.0 * _truncated_halfnormal_mean(float(keep)))


def rademacher_probe(shape, seed: int = PROBE_SEED) -> np.ndarray:
    """A fixed ±1 probe ``b`` of ``shape`` (float32), the same for the same seed and shape."""
    rng = np.random.default_rng(seed)
    return (rng.integers(0, 2, size=shape, dtype=np.int8) * 2 - 1).astype(np.float32)


def probe_step(sigma) -> np.ndarray:
    """``ε`` per plane: :data:`PROBE_FRACTION` × σ (0 where σ is 0)."""
    return PROBE_FRACTION * np.asarray(sigma, dtype=np.float64)


def _box_mean(a: np.ndarray, radius: int) -> np.ndarray:
    size = [1] * (a.ndim - 2) + [2 * radius + 1, 2 * radius + 1]
    return uniform_filter(a, size=size, mode="reflect")


def sure_alpha(noisy, denoised, probed, probe, eps, sigma, radius: int = DEFAULT_RADIUS) -> np.ndarray:
    """The SURE-optimal blend weight ``α`` per pixel (module docstring).

    Parameters
    ----------
    noisy, denoised, probed : ndarray ``(..., h, w)`` float
        ``y``, ``f(y)`` and ``f(y + ε b)``.
    probe : ndarray ``(..., h, w)``
        ``b`` (±1).
    eps : array_like ``(...)``
        The probe step of each plane.
    sigma : array_like ``(...)`` or ``(..., h, w)``
        The noise σ of each plane, or of each pixel (``σ²`` is the variance of ``y``'s noise).
    radius : int
        Half side of the neighbourhood (plane pixels, ≥ 0).

    Returns
    -------
    ndarray ``(..., h, w)`` float64 in ``[0, 1]``.
    """
    y = check_image(noisy, "noisy").astype(np.float64)
    f = check_image(denoised, "denoised").astype(np.float64)
    fb = check_image(probed, "probed").astype(np.float64)
    b = np.asarray(probe, dtype=np.float64)
    for name, arr in (("denoised", f), ("probed", fb), ("probe", b)):
        if arr.shape != y.shape:
            raise ValueError(f"{name} must have the shape of noisy {y.shape}; got {arr.shape}")
    if isinstance(radius, bool) or not isinstance(radius, (int, np.integer)) or radius < 0:
        raise ValueError(f"radius must be an integer ≥ 0 (plane pixels); got {radius!r}")
    lead = y.shape[:-2]
    eps = np.broadcast_to(np.asarray(eps, dtype=np.float64), lead)[..., None, None]
    sig = np.asarray(sigma, dtype=np.float64)
    s2 = sig ** 2 if sig.shape == y.shape else np.broadcast_to(sig ** 2, lead)[..., None, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        div = np.where(eps > 0, s2 * b * (fb - f) / np.where(eps > 0, eps, 1.0), 0.0)
    num = _box_mean(s2 - div, int(radius))
    den = _box_mean((f - y) ** 2, int(radius))
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = np.where(den > 0, num / np.where(den > 0, den, 1.0), 1.0)
    return np.clip(alpha, 0.0, 1.0)


def quantisation_variance(rates, window: float, accumulate: str = "count") -> np.ndarray:
    """The noise floor of a spike count: ``min(min(p, 1 − p) / W, 1 / (6 W²))`` per pixel (rate units²).

    A pixel that fires at rate ``p`` for ``W`` readouts with a random phase counts ``⌊φ + pW⌋``
    spikes: its variance is ``{pW}(1 − {pW}) / W²`` in rate units — ``≈ p / W`` when ``pW < 1``
    (mostly no spike: Poisson-like, the low-light case) and ``1 / (6 W²)`` on average over the
    phase otherwise (the ±1 quantisation of the count).  Every spike camera has at least this
    noise; shot noise, dark current and spurious spikes add to it.  ``p`` is clipped to ``[0, 1]``
    (saturation mirrors the dark end).

    ``accumulate="charge"``: the floor of :func:`spikeref.charge.window_charge`'s rates instead, at
    most ``p² / (6 W²)``: each edge's phase is read from spike times whose ±½-readout rounding is a
    fraction ``p`` of the interval, so the ±1 of the count shrinks by about ``p`` (the count's floor
    where that is lower).
    """
    if accumulate not in ACCUMULATE:
        raise ValueError(f"accumulate must be count or charge; got {accumulate!r}")
    p = np.clip(np.asarray(rates, dtype=np.float64), 0.0, 1.0)
    w = float(window)
    floor = np.minimum(np.minimum(p, 1.0 - p) / w, 1.0 / (6.0 * w * w))
    if accumulate == "charge":
        floor = np.minimum(floor, p * p / (6.0 * w * w))
    return floor


def carried_excess_variance(short, short_window: float, window: float, accumulate: str = "count") -> np.ndarray:
    """The noise variance above the quantisation floor, measured on a short window, carried to ``window``.

    ``e = max(0, σ_c(short)² − mean q(short, W₀)) · W₀ / W`` per plane, with ``σ_c`` the plane
    estimate :func:`noise_sigma`, ``q`` the floor :func:`quantisation_variance` (``accumulate``'s) and ``W₀ =
    short_window``: the part of the short window's noise that the floor does not explain, taken
    to fall as ``1/W`` (shot noise, dark current, spurious spikes; module docstring).

    Parameters
    ----------
    short : ndarray ``(..., h, w)`` float
        Firing rates of a short window of the same stream (e.g. the first :data:`NOISE_WINDOW`
        planes of the long window).
    short_window, window : float
        ``W₀`` and ``W`` in planes, both > 0.
    accumulate : {"count", "charge"}
        What the rates are (the floor subtracted: :func:`quantisation_variance`).

    Returns
    -------
    ndarray ``(...)`` float64
        One variance per plane, in rate units² at ``window``.
    """
    y = check_image(short, "short").astype(np.float64)
    for name, value in (("short_window", short_window), ("window", window)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                or not np.isfinite(value) or value <= 0:
            raise ValueError(f"{name} must be a positive number of planes; got {value!r}")
    floor = quantisation_variance(y, short_window, accumulate).reshape(y.shape[:-2] + (-1,)).mean(axis=-1)
    return np.maximum(0.0, noise_sigma(y) ** 2 - floor) * (float(short_window) / float(window))


def trusted_excess(window, short=None, short_window=None, accumulate: str = "count"):
    """The noise variance above the floor that the guard takes at ``window``: the ``carried=`` of :func:`sure_blend`.

    Parameters
    ----------
    window : float or None
        The exposure ``W`` of the guarded planes, in planes (None: unknown).
    short : ndarray ``(..., h, w)`` float, optional
        Rates of a short window of the same stream (:func:`carried_excess_variance`).
    short_window : float, optional
        Its exposure ``W₀`` in planes; needed with ``short``.
    accumulate : {"count", "charge"}
        What the rates are (the floor: :func:`quantisation_variance`).

    Returns
    -------
    None, 0.0 or ndarray ``(...)`` float64
        ``None`` where ``window`` is unknown or at most :data:`NOISE_WINDOW` planes (the plane's own σ: no
        cap); :data:`CARRY_FRACTION` × :func:`carried_excess_variance` of ``short`` where a short window
        of at most ``NOISE_WINDOW`` planes is given; otherwise ``0.0`` (only the floor: from one long
        window the guard cannot tell texture or a fixed pattern from noise).  Module docstring.
    """
    if short is not None and short_window is None:
        raise ValueError("short= needs short_window= (its exposure in planes)")
    if window is None or window <= NOISE_WINDOW:
        return None
    if short is not None and short_window <= NOISE_WINDOW:
        return CARRY_FRACTION * carried_excess_variance(short, short_window, window, accumulate)
    return 0.0


def sure_blend(noisy, denoise, radius: int = DEFAULT_RADIUS, sigma=None,
               window: float | None = None, carried=None, accumulate: str = "count") -> tuple[np.ndarray, np.ndarray]:
    """Guard a denoiser: ``y + α (f(y) − y)`` with the SURE-optimal ``α`` (module docstring).

    Parameters
    ----------
    noisy : ndarray ``(..., h, w)`` float
        ``y``, firing rates.
    denoise : callable
        ``f``: takes and returns an array of ``noisy``'s shape (called twice: on ``y`` and on
        ``y + ε b``).
    radius : int
        Half side of the SURE neighbourhood in plane pixels.
    sigma : array_like ``(...)``, optional
        The noise σ of each plane; default: :func:`noise_sigma` of ``noisy``.
    window : float, optional
        The exposure ``W`` behind the rates (planes).  When given, each pixel's variance is at
        least the count's quantisation floor :func:`quantisation_variance` of ``f(y)`` (what
        keeps the estimate from reading 0 in low light, where most counts are 0).
    carried : array_like ``(...)``, optional
        Per plane, the noise variance above the floor measured on a short window and carried to
        ``window`` (:func:`carried_excess_variance`); needs ``window``.  When given, each plane's
        ``σ²`` is capped at ``carried + `` the mean of :func:`quantisation_variance` of ``f(y)``
        (module docstring: texture read as noise at long windows).
    accumulate : {"count", "charge"}
        What the rates are: Eq. 4's counts over ``window`` or :mod:`spikeref.charge`'s charges;
        sets the floor (:func:`quantisation_variance`).

    Returns
    -------
    blended : ndarray float32, ``noisy``'s shape
    alpha : ndarray float64, the weight of ``f(y)`` per pixel
    """
    y = check_image(noisy, "noisy").astype(np.float32)
    sig = noise_sigma(y) if sigma is None else np.broadcast_to(np.asarray(sigma, dtype=np.float64), y.shape[:-2])
    if np.any(~np.isfinite(sig)) or np.any(sig < 0):
        raise ValueError(f"sigma must be finite and ≥ 0; got {sigma!r}")
    if window is not None and (isinstance(window, bool) or not np.isfinite(window) or window <= 0):
        raise ValueError(f"window must be a positive number of planes; got {window!r}")
    if accumulate not in ACCUMULATE:
        raise ValueError(f"accumulate must be count or charge; got {accumulate!r}")
    if carried is not None:
        if window is None:
            raise ValueError("carried needs window= (the exposure the variance was carried to)")
        extra = np.broadcast_to(np.asarray(carried, dtype=np.float64), y.shape[:-2])
        if np.any(~np.isfinite(extra)) or np.any(extra < 0):
            raise ValueError(f"carried must be finite variances ≥ 0; got {carried!r}")
    f = np.asarray(denoise(y), dtype=np.float32)
    if f.shape != y.shape:
        raise ValueError(f"the denoiser returned shape {f.shape} for input {y.shape}")
    s2 = sig ** 2
    floor = None if window is None else quantisation_variance(f, window, accumulate)
    if carried is not None:
        s2 = np.minimum(s2, extra + floor.reshape(y.shape[:-2] + (-1,)).mean(axis=-1))
    variance = np.broadcast_to(s2[..., None, None], y.shape)
    if floor is not None:
        variance = np.maximum(variance, floor)
    eps = probe_step(np.sqrt(variance.reshape(y.shape[:-2] + (-1,)).mean(axis=-1)))
    b = rademacher_probe(y.shape)
    fb = np.asarray(denoise((y + (eps[..., None, None] * b)).astype(np.float32)), dtype=np.float32)
    alpha = sure_alpha(y, f, fb, b, eps, np.sqrt(variance), radius)
    out = (y + alpha * (f.astype(np.float64) - y)).astype(np.float32)
    return out, alpha
