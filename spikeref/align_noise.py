"""The noise model of the alignment's options beyond HDR+ (not in the paper): what noise alone explains.

:mod:`spikeref.align` is HDR+'s tile alignment as the paper uses it.  Its noise-aware options ask, at
every tile and pixel, whether a match is better than what noise alone would give; this module
measures that noise and turns it into the search's thresholds:

* the noise variance of an image (:func:`estimate_noise`, Immerkær 1996), per pixel
  (:func:`local_noise`), and the correlation of two frames' noise (:func:`estimate_noise_correlation`:
  integrate-and-fire makes adjacent windows' counts anti-correlated);
* per pyramid level and tile, the bias of the zero offset's distance and ``z`` standard deviations of
  a distance difference under noise (:func:`level_noise_factors`, :func:`search_thresholds`) — the
  noise-aware search, ``AlignParams(prefer_centre=z)``;
* the per-pixel zero-motion test (:func:`zero_motion_test`, ``AlignParams(zero_test=z)``).

The rules are written out in ``docs/spec/align.md`` and in :mod:`spikeref.oracles.align_noise` and
:mod:`spikeref.oracles.align_zero_test` (put together by :mod:`spikeref.oracles.align`).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.ndimage import uniform_filter

from spikeref._align_kernels import (
    PYRAMID_KERNEL, box_sums, integral_image, tile_sums_from_integral, zero_test_terms,
)
from spikeref.noise_level import immerkaer_response

__all__ = [
    "L1_DIFF_VARIANCE", "L2_DIFF_VARIANCE", "MIN_CORRELATION", "LOCAL_NOISE_BOX", "ZERO_TEST_BOX",
    "as_image", "is_integer", "estimate_noise", "estimate_noise_correlation", "local_noise", "level_noise_factors",
    "noise_map", "noise_inputs",
    "checked_correlation", "tile_sums", "search_thresholds", "zero_motion_test", "apply_zero_motion",
    "zero_motion_inputs",
]

#: Side (pixels) of the box over which the per-pixel zero-motion test (``AlignParams.zero_test``) sums.
ZERO_TEST_BOX = 9


def is_integer(v) -> bool:
    """Whether ``v`` is a whole number (Python or NumPy integer, not a bool): the alignment modules' check."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def as_image(a, name: str) -> np.ndarray:
    """A single-channel ``(h, w)`` image as finite float32 (the check of every public alignment function)."""
    arr = np.asarray(a)
    if not np.issubdtype(arr.dtype, np.floating):
        raise TypeError(f"{name} must be a real floating-point array (float32 or float64); got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a single-channel (h, w) image on the plane grid; got shape {arr.shape}")
    with np.errstate(over="ignore", invalid="ignore"):  # out-of-range values become inf and fail below
        arr = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf, and within float32 range)")
    return arr


#: Variance of ``|X − Y| − |X − Z|`` per pixel for independent Gaussian ``X, Y, Z`` of variance ``v``,
#: in units of ``v``: ``4 − (8/π)(√¾ + ½·arcsin ½)`` (the L1 distance difference of the finest level).
L1_DIFF_VARIANCE = 4.0 - (8.0 / np.pi) * (np.sqrt(0.75) + 0.5 * np.arcsin(0.5))
#: The same for the squared distance, ``(X − Y)² − (X − Z)²``, in units of ``v²`` (coarser levels).
L2_DIFF_VARIANCE = 12.0
#: The noise correlation of two frames is clipped below at −½, the lowest lag-1 correlation of a
#: moving-average process (integrate-and-fire quantisation of adjacent windows reaches it).
MIN_CORRELATION = -0.5
#: Side (pixels) of the box over which :func:`local_noise` averages ``|Laplacian|``.
LOCAL_NOISE_BOX = 15


@functools.lru_cache(maxsize=8)
def level_noise_factors(levels: int) -> tuple[tuple[float, float], ...]:
    """Per level ``k``: ``(F_k, S_k)`` for white noise of unit variance at level 0.

    ``F_k`` is the variance of a level-``k`` pixel (``(Σ h_k²)²`` for the composite 1-D kernel
    ``h_k`` of ``k`` blur-and-decimate steps) and ``S_k = (Σ_m ρ_k(m)²)²`` the sum of squared
    correlations between level-``k`` pixels: the factor by which spatial correlation inflates the
    variance of a sum of squared differences over a tile (1 at level 0).  Computed once per
    ``levels`` (every alignment asks for them: 0.12 ms a call).
    """
    b = np.asarray(PYRAMID_KERNEL) / 16.0
    h = np.ones(1)
    out = []
    for k in range(levels):
        energy = float(np.sum(h * h))
        step = 2 ** k
        rho = [float(np.sum(h[: h.size - m * step] * h[m * step:])) / energy for m in range(-(-h.size // step))]
        s1 = rho[0] ** 2 + 2.0 * sum(r * r for r in rho[1:])
        out.append((energy ** 2, s1 ** 2))
        up = np.zeros(4 * step + 1)
        up[::step] = b
        h = np.convolve(h, up)
    return tuple(out)


def estimate_noise(image) -> float:
    """Variance of white noise in ``image`` (Immerkær 1996, "Fast noise variance estimation").

    The image is filtered with ``[[1, −2, 1], [−2, 4, −2], [1, −2, 1]]`` (zero on any plane,
    ``Σ k² = 36``) over its interior, and ``σ = √(π/2) · mean|·| / 6``: exact for Gaussian white
    noise on a locally planar image, an over-estimate where texture dominates.  (The mean
    absolute value, not the median: spike counts are discrete and a median jumps between
    quantised values.)

    Parameters
    ----------
    image : ndarray ``(h, w)`` float, ``h, w ≥ 3``

    Returns
    -------
    float
        The per-pixel noise variance ``σ²`` (≥ 0).
    """
    img = as_image(image, "image")
    if min(img.shape) < 3:
        raise ValueError(f"image must be at least 3×3 to estimate its noise; got {img.shape}")
    return float((np.sqrt(0.5 * np.pi) * np.mean(immerkaer_response(img)) / 6.0) ** 2)


def estimate_noise_correlation(reference, alternate, *, noise=None) -> float:
    """Correlation of the noise of two images at the same pixel, ``1 − σ²(r − a) / (σ²(r) + σ²(a))``.

    Each ``σ²`` is :func:`estimate_noise`.  Spike counts of adjacent windows are anti-correlated
    (integrate-and-fire carries the residual charge of a window into the next: ``−½`` when the
    quantisation dominates, the value measured on the SpikingSIM real recording), frames with
    overlapping supports positively.  Texture that moves between the images lowers the estimate.

    Parameters
    ----------
    reference, alternate : ndarray ``(h, w)`` float, same shape
    noise : (float, float), optional
        ``(σ²(r), σ²(a))`` when the caller has measured them already (the pipeline measures each
        frame once and pairs it with several others); default :func:`estimate_noise` of each.

    Returns
    -------
    float in ``[−1, 1]`` (0 when both images are noise-free)
    """
    ref = as_image(reference, "reference")
    alt = as_image(alternate, "alternate")
    if ref.shape != alt.shape:
        raise ValueError(f"reference and alternate must have the same shape; got {ref.shape} and {alt.shape}")
    if noise is None:
        var_ref, var_alt = estimate_noise(ref), estimate_noise(alt)
    else:
        try:
            var_ref, var_alt = (float(v) for v in noise)
        except (TypeError, ValueError):
            raise TypeError(f"noise must be a pair of variances (σ²(r), σ²(a)); got {noise!r}") from None
        if not (np.isfinite(var_ref) and np.isfinite(var_alt) and var_ref >= 0 and var_alt >= 0):
            raise ValueError(f"noise must be two finite variances ≥ 0; got {noise!r}")
    total = var_ref + var_alt
    if total <= 0:
        return 0.0
    diff = estimate_noise(ref.astype(np.float64) - alt.astype(np.float64))
    return float(np.clip(1.0 - diff / total, -1.0, 1.0))


def local_noise(image, box: int = LOCAL_NOISE_BOX) -> np.ndarray:
    """Per-pixel noise variance: :func:`estimate_noise` over a ``box × box`` neighbourhood.

    ``(√(π/2) · m(p) / 6)²`` with ``m`` the mean of ``|Laplacian|`` (Immerkær's kernel) over the box
    centred on ``p`` (the Laplacian's border ring replicates its edge, and so does the box beyond the
    image's border: SciPy's ``uniform_filter(mode="nearest")``).  Spike noise depends on the rate, so a
    map follows it where one number cannot.

    Parameters
    ----------
    image : ndarray ``(h, w)`` float, ``h, w ≥ 3``
    box : int
        Odd side of the box, ≥ 1.

    Returns
    -------
    ndarray ``(h, w)`` float64
    """
    img = as_image(image, "image")
    if min(img.shape) < 3:
        raise ValueError(f"image must be at least 3×3 to estimate its noise; got {img.shape}")
    if not is_integer(box) or box < 1 or box % 2 == 0:
        raise ValueError(f"box must be an odd integer ≥ 1; got {box!r}")
    lap = np.pad(immerkaer_response(img), 1, mode="edge")
    m = uniform_filter(lap, size=int(box), mode="nearest")
    return (np.sqrt(0.5 * np.pi) * m / 6.0) ** 2


def noise_map(noise, shape, ref, alt) -> np.ndarray:
    """The level-0 noise variance as an ``(h, w)`` float64 map (``None``: estimated from both images)."""
    if noise is None:
        return 0.5 * (local_noise(ref) + local_noise(alt))
    if isinstance(noise, (bool, np.bool_)):
        raise TypeError(f"noise must be a real number or array (a variance); got {noise!r}")
    arr = np.asarray(noise)
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"noise must be a real number or array (a variance); got dtype {arr.dtype}")
    if arr.ndim not in (0, 2) or (arr.ndim == 2 and arr.shape != shape):
        raise ValueError(f"noise must be a scalar or an array of the image's shape {shape} (the per-pixel noise "
                         f"variance); got shape {arr.shape}")
    arr = arr.astype(np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError("noise must be finite and ≥ 0 (a variance)")
    return np.broadcast_to(arr, shape).copy()


def noise_inputs(ref, alt, params, noise, correlation) -> tuple[np.ndarray | None, float | None]:
    """What :func:`spikeref.align.align` needs of the noise, made once: the level-0 variance map and the correlation.

    Each is None where ``params`` (an :class:`~spikeref.align_params.AlignParams`) uses neither and none was given:
    the map is used by the noise-aware search and the regularised Lucas–Kanade field, the correlation by the search.
    A given ``noise`` or ``correlation`` is checked (:func:`noise_map`, :func:`checked_correlation`) even when unused.
    """
    noise0 = rho = None
    if params.prefer_centre > 0 or (params.subpixel and params.smoothness > 0) or noise is not None:
        noise0 = noise_map(noise, ref.shape, ref, alt)
    if params.prefer_centre > 0 or correlation is not None:
        rho = checked_correlation(correlation, ref, alt)
    return noise0, rho


def checked_correlation(correlation, ref, alt) -> float:
    """The noise correlation of the pair, given or estimated, clipped to ``[MIN_CORRELATION, 1]``."""
    if correlation is None:
        rho = estimate_noise_correlation(ref, alt)
    else:
        if isinstance(correlation, (bool, np.bool_)) or not isinstance(correlation, (int, float, np.integer,
                                                                                     np.floating)) \
                or not np.isfinite(correlation) or not -1.0 <= correlation <= 1.0:
            raise ValueError(f"correlation must be a number in [−1, 1] or None (estimated); got {correlation!r}")
        rho = float(correlation)
    return max(rho, MIN_CORRELATION)


def tile_sums(values: np.ndarray, tile: int, shape: tuple[int, int]) -> np.ndarray:
    """``Σ`` of ``values`` over every tile of the grid ``shape`` (size ``tile``, stride ``tile/2``)."""
    c = np.zeros((values.shape[0] + 1, values.shape[1] + 1))
    integral_image(np.ascontiguousarray(values, np.float64), c)  # = cumsum(cumsum(values, 0), 1), bit for bit
    out = np.empty((int(shape[0]), int(shape[1])))
    tile_sums_from_integral(c, int(tile), out)
    return out


def search_thresholds(var_k: np.ndarray, factors: tuple[float, float], tile: int, shape, l2: bool, z: float,
                rho: float) -> tuple[np.ndarray, np.ndarray]:
    """Per tile of one level: ``(bias, thresh)`` of the noise-aware search.

    ``bias = E[D(0)] − E[D(u)]``, ``u ≠ 0``, in a flat region: with noise of variance ``v`` per image
    and correlation ``ρ`` between the images at the same pixel, the difference at the zero offset
    has variance ``2v(1 − ρ)``, elsewhere ``2v`` (pixels apart are independent) — so
    ``Σ −2ρ v`` (L2, levels > 0) or ``Σ √(2/π)(√(1 − ρ) − 1)·√(2v)`` (L1, finest level); only
    ``ρ < 0`` is corrected.  ``thresh`` is ``z`` standard deviations of ``D(c) − D(u)`` for white
    noise (:data:`L2_DIFF_VARIANCE`, :data:`L1_DIFF_VARIANCE`; ``S_k`` for the pyramid's
    correlation).  On white noise this standard deviation is an upper bound: the terms of
    neighbouring pixels share samples and partly cancel (measured 15–25 % lower).
    """
    f, s = factors
    v = var_k * f
    r = min(rho, 0.0)
    if l2:
        variance = L2_DIFF_VARIANCE * s * tile_sums(v * v, tile, shape)
        bias = -2.0 * r * tile_sums(v, tile, shape)
    else:
        variance = L1_DIFF_VARIANCE * s * tile_sums(v, tile, shape)
        bias = np.sqrt(2.0 / np.pi) * (np.sqrt(1.0 - r) - 1.0) * tile_sums(np.sqrt(2.0 * v), tile, shape)
    return np.ascontiguousarray(bias), np.ascontiguousarray(z * np.sqrt(variance))


def zero_motion_test(flow, reference, alternate, z: float, noise=None, correlation=None,
                     box: int = ZERO_TEST_BOX) -> np.ndarray:
    """The flow with zero motion where zero explains the frames better (``AlignParams.zero_test``; not in the paper).

    Per pixel ``p``, ``d(p) = (r(p) − a(p))² − (r(p) − a(p + F(p)))²`` less its mean under noise alone, summed
    over the ``box × box`` pixels around ``p`` (the edge replicated; a direct sum,
    :func:`~spikeref._align_kernels.box_sums`); where that sum is below ``−z`` standard deviations of what
    noise gives (:func:`zero_test_terms`), the zero offset
    fits the data significantly better than the flow and ``F(p)`` becomes 0.  Where the two are not told
    apart (flat regions) the flow is kept.

    Parameters
    ----------
    flow : ndarray ``(2, h, w)`` float
        The dense flow (:func:`align`'s convention).
    reference, alternate : ndarray ``(h, w)`` float
        The frames the test compares (the pipeline: the raw 2×2 luma, not smoothed: the noise model is
        white noise per pixel).
    z : float
        Standard deviations (≥ 0).
    noise : float or ndarray ``(h, w)``, optional
        Noise variance per pixel of each frame; default :func:`local_noise`, averaged.
    correlation : float, optional
        Correlation of the two frames' noise at the same pixel (clipped below at :data:`MIN_CORRELATION`);
        default :func:`estimate_noise_correlation`.
    box : int
        Odd side of the box, ≥ 1.

    Returns
    -------
    ndarray ``(2, h, w)`` float32
    """
    ref = as_image(reference, "reference")
    alt = as_image(alternate, "alternate")
    if ref.shape != alt.shape:
        raise ValueError(f"reference and alternate must have the same shape; got {ref.shape} and {alt.shape}")
    f = np.array(flow, dtype=np.float32)
    if f.shape != (2,) + ref.shape or not np.all(np.isfinite(f)):
        raise ValueError(f"flow must be a finite (2, {ref.shape[0]}, {ref.shape[1]}) array; got {f.shape}")
    if isinstance(z, (bool, np.bool_)) or not np.isfinite(z) or z < 0:
        raise ValueError(f"z must be a finite number ≥ 0; got {z!r}")
    if not is_integer(box) or box < 1 or box % 2 == 0:
        raise ValueError(f"box must be an odd integer ≥ 1; got {box!r}")
    v = noise_map(noise, ref.shape, ref, alt)
    rho = checked_correlation(correlation, ref, alt)
    return apply_zero_motion(np.ascontiguousarray(f, np.float32), ref, alt, float(z), v, rho, int(box))


def zero_motion_inputs(raw, ref, alt, noise, correlation, noise0, rho):
    """The frames, variance map and correlation the zero-motion test of :func:`spikeref.align.align` uses.

    ``raw`` is ``align``'s argument (None, or the two frames to compare instead of ``ref`` and ``alt``, checked
    here); ``noise``/``correlation`` as given to ``align``, ``noise0``/``rho`` what :func:`noise_inputs` made of
    them (None where not made).  Those are reused where they describe the compared frames (given, or estimated
    from ``ref`` and ``alt`` when ``raw`` is None); else they are estimated from the raw frames.
    """
    if raw is None:
        r_img, a_img = ref, alt
    else:
        r_img, a_img = as_image(raw[0], "raw[0]"), as_image(raw[1], "raw[1]")
        if r_img.shape != ref.shape or a_img.shape != ref.shape:
            raise ValueError(f"raw must be two images of the reference's shape {ref.shape}; got {r_img.shape} and "
                             f"{a_img.shape}")
    same = raw is None
    v = noise0 if noise0 is not None and (same or noise is not None) else noise_map(noise, ref.shape, r_img, a_img)
    r = rho if rho is not None and (same or correlation is not None) else checked_correlation(correlation, r_img,
                                                                                              a_img)
    return r_img, a_img, v, r


def apply_zero_motion(flow: np.ndarray, ref: np.ndarray, alt: np.ndarray, z: float, noise: np.ndarray, rho: float,
                 box: int) -> np.ndarray:
    """:func:`zero_motion_test` on checked input (float32 images and flow, a float64 noise map); ``flow`` is changed."""
    d = np.empty(ref.shape, np.float64)
    var = np.empty(ref.shape, np.float64)
    zero_test_terms(ref, alt, flow, noise, rho, d, var)
    # S and Q as direct box sums: a running sum (SciPy's uniform_filter, until 2026-11-25) left round-off of
    # either sign where it followed large values, so a noise-free region compared noise with 0 (or took √ of a
    # negative Q), where the oracle's exact sums keep the flow
    total = np.empty_like(d)
    spread = np.empty_like(var)
    box_sums(d, box // 2, total)
    box_sums(var, box // 2, spread)
    flow[:, total < -z * np.sqrt(spread)] = 0.0
    return flow
