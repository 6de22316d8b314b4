"""Image-quality metrics: PSNR, SSIM (Wang et al. 2004 settings) and PU21-encoded PSNR / SSIM.

The paper scores its frames with PSNR, SSIM and, for HDR, metrics on perceptually
uniform values (its Table 1 and §5).  These are the ones that run offline on a CPU:

* :func:`psnr` — ``10 log10(R² / MSE)`` with an explicit ``data_range`` ``R``;
  :func:`psnr_after_gain` the same after the least-squares exposure (or per-channel) gain, for a
  reference known only up to its scale.
* :func:`ssim` — Wang, Bovik, Sheikh & Simoncelli, "Image quality assessment: from error
  visibility to structural similarity", IEEE TIP 13(4), 2004: an 11-tap Gaussian window
  with σ = 1.5, ``K1 = 0.01``, ``K2 = 0.03``, population (biased) variances and covariance,
  the mean of the SSIM map over the *valid* region (pixels whose whole window lies inside
  the image), colour images as the mean over channels.  This equals scikit-image's
  ``structural_similarity(..., gaussian_weights=True, sigma=1.5,
  use_sample_covariance=False)``, which is how the tests check it.
* :func:`pu21_encode` — Mantiuk & Azimi, "PU21: A novel perceptually uniform encoding for
  adapting existing quality metrics for HDR", Picture Coding Symposium 2021, with the
  ``banding_glare`` parameters; luminance in cd/m² clamped to ``[0.005, 10000]``.
  ``PU(100 cd/m²) ≈ 256`` so an 8-bit SDR display maps to roughly ``[0, 256]``.
* :func:`pu21_psnr` / :func:`pu21_ssim` — PSNR (peak 256) and SSIM (``data_range`` 256) of
  PU21 values of the luminance.  Our frames are in relative units (firing rates), so both
  frames are scaled by one factor that puts the *reference's* peak luminance at
  ``peak_luminance`` (4000 cd/m², an HDR display's peak) before encoding.

Not here, and why: LPIPS needs pretrained AlexNet/VGG weights that must be downloaded
(and a deep-learning framework at run time); HDR-VDP-3 and HDR-VQM are MATLAB programs with
no maintained Python port.  None of them can run offline in this package.

All functions take linear images ``(H, W)`` or ``(H, W, C)`` of any real dtype (computed in
float64) and raise ``ValueError``/``TypeError`` naming the argument on bad input.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import correlate1d

__all__ = [
    "SSIM_SIGMA",
    "SSIM_TAPS",
    "PU21_BANDING_GLARE",
    "psnr",
    "psnr_after_gain",
    "ssim",
    "luminance",
    "pu21_encode",
    "pu21_psnr",
    "pu21_ssim",
]

#: Gaussian window of SSIM (Wang et al. 2004): σ = 1.5 pixels, 11 taps (radius 5).
SSIM_SIGMA = 1.5
SSIM_TAPS = 11
_K1, _K2 = 0.01, 0.03

#: PU21 ``banding_glare`` parameters ``p1 … p7`` (Mantiuk & Azimi 2021, the authors' release).
PU21_BANDING_GLARE = (0.353487901, 0.3734658629, 8.277049286e-05, 0.9062562627, 0.09150303166,
                      0.9099517204, 596.3148142)
_PU21_RANGE = (0.005, 10000.0)  # cd/m²
#: PU21 value of a 100 cd/m² white, the "peak" of PU21-PSNR (≈ 256.38; 256 is used, as the authors do).
PU21_PEAK = 256.0
#: Rec. 709 / sRGB luminance weights of linear R, G, B.
_LUMA = np.array([0.2126, 0.7152, 0.0722])


# ---------------------------------------------------------------- argument checks
def _image(name: str, a) -> np.ndarray:
    if isinstance(a, (str, bytes)) or a is None:
        raise TypeError(f"{name} must be an array of numbers; got {type(a).__name__}")
    arr = np.asarray(a)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise TypeError(f"{name} must hold real numbers; got dtype {arr.dtype}")
    if arr.ndim not in (2, 3):
        raise ValueError(f"{name} must be an image (H, W) or (H, W, C); got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    arr = arr.astype(np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} has NaN or infinite values")
    return arr


def _pair(reference, estimate) -> tuple[np.ndarray, np.ndarray]:
    ref = _image("reference", reference)
    est = _image("estimate", estimate)
    if ref.shape != est.shape:
        raise ValueError(f"reference and estimate must have the same shape; got {ref.shape} and {est.shape}")
    return ref, est


def _positive(name: str, value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number ({what}); got {value!r}")
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a positive finite number ({what}); got {value!r}")
    return float(value)


def _data_range(data_range) -> float:
    return _positive("data_range", data_range, "the peak signal, e.g. 1.0")


# ---------------------------------------------------------------------------- PSNR
def psnr(reference, estimate, data_range) -> float:
    """Peak signal-to-noise ratio ``10 log10(R² / MSE)`` in dB.

    Parameters
    ----------
    reference, estimate : array ``(H, W)`` or ``(H, W, C)``
        Same shape, finite.
    data_range : float
        ``R``, the peak value (e.g. 1.0 for rates, 256 for PU21 values).  Never guessed
        from the data, so scores of different methods are comparable.

    Returns
    -------
    float
        dB; ``inf`` when the images are equal.
    """
    ref, est = _pair(reference, estimate)
    r = _data_range(data_range)
    mse = float(np.mean((ref - est) ** 2))
    return float("inf") if mse == 0.0 else float(10.0 * np.log10(r * r / mse))


def psnr_after_gain(reference, estimate, data_range, per_channel: bool = False) -> float:
    """PSNR of ``g · estimate`` with the least-squares gain ``g = Σ ref·est / Σ est²`` (:func:`psnr`).

    For a reference known only up to its exposure — the mean of a long window of a real
    recording, a camera of unknown ``M_c`` (Eq. 4) — the brightness scale is fitted first, so the
    score measures noise and structure, not exposure.

    Parameters
    ----------
    reference, estimate : array ``(H, W)`` or ``(H, W, C)``
        Same shape, finite.
    data_range : float
        ``R`` of :func:`psnr`, in the reference's units.
    per_channel : bool
        One gain per channel of an ``(H, W, C)`` image (a white balance as well as an exposure)
        instead of one for the whole image.

    Returns
    -------
    float
        dB.  Where the estimate is 0 (a channel of it, with ``per_channel``) its gain is 1.
    """
    ref, est = _pair(reference, estimate)
    r = _data_range(data_range)
    if not isinstance(per_channel, (bool, np.bool_)):
        raise TypeError(f"per_channel must be True or False; got {per_channel!r}")
    if per_channel and est.ndim != 3:
        raise ValueError(f"per_channel needs (H, W, C) images; got shape {est.shape}")
    axes = (0, 1) if per_channel else None
    energy = np.sum(est * est, axis=axes)
    gain = np.where(energy > 0, np.sum(ref * est, axis=axes) / np.where(energy > 0, energy, 1.0), 1.0)
    return psnr(ref, est * gain, r)


# ---------------------------------------------------------------------------- SSIM
def _gaussian_taps() -> np.ndarray:
    radius = SSIM_TAPS // 2
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    g = np.exp(-0.5 * (x / SSIM_SIGMA) ** 2)
    return g / g.sum()


def _ssim_map(x: np.ndarray, y: np.ndarray, c1: float, c2: float, taps: np.ndarray) -> np.ndarray:
    """SSIM map of two 2-D float64 images over the valid region ``(H − 10, W − 10)``."""
    r = taps.size // 2

    def mean(a):
        return correlate1d(correlate1d(a, taps, axis=0, mode="reflect"), taps, axis=1, mode="reflect")[r:-r, r:-r]

    mx, my = mean(x), mean(y)
    vx = mean(x * x) - mx * mx
    vy = mean(y * y) - my * my
    cxy = mean(x * y) - mx * my
    return ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2))


def ssim(reference, estimate, data_range) -> float:
    """Structural similarity (Wang et al. 2004), mean over the valid region and the channels.

    Parameters
    ----------
    reference, estimate : array ``(H, W)`` or ``(H, W, C)``
        Same shape, finite, ``H, W ≥ 11`` (one whole Gaussian window).
    data_range : float
        ``L`` of ``C1 = (0.01 L)²``, ``C2 = (0.03 L)²``.

    Returns
    -------
    float
        In ``[−1, 1]``; 1 for equal images.

    Notes
    -----
    Local means, variances and the covariance are Gaussian-weighted (σ = 1.5, 11 taps,
    weights summing to 1) and *population* moments (``E[x²] − E[x]²``), as in Wang et al.;
    only pixels whose whole window is inside the image are averaged (no padding enters the
    score).  A colour image scores the mean of its channels' SSIM.
    """
    ref, est = _pair(reference, estimate)
    r = _data_range(data_range)
    if ref.shape[0] < SSIM_TAPS or ref.shape[1] < SSIM_TAPS:
        raise ValueError(f"ssim needs images of at least {SSIM_TAPS}×{SSIM_TAPS} pixels (one Gaussian window); "
                         f"got {ref.shape[0]}×{ref.shape[1]}")
    if ref.ndim == 2:
        ref, est = ref[..., None], est[..., None]
    taps = _gaussian_taps()
    c1, c2 = (_K1 * r) ** 2, (_K2 * r) ** 2
    scores = [float(_ssim_map(ref[..., c], est[..., c], c1, c2, taps).mean()) for c in range(ref.shape[2])]
    return float(np.mean(scores))


# ---------------------------------------------------------------------------- PU21
def luminance(rgb) -> np.ndarray:
    """Relative luminance ``Y = 0.2126 R + 0.7152 G + 0.0722 B`` of linear RGB ``(..., 3)``.

    Rec. 709 / sRGB primaries are assumed for the camera's colour channels.  An image
    ``(H, W)`` is returned as it is (already one channel).
    """
    arr = _image("rgb", rgb)
    if arr.ndim == 2:
        return arr
    if arr.shape[-1] != 3:
        raise ValueError(f"rgb must have 3 channels in its last axis; got shape {arr.shape}")
    return arr @ _LUMA


def pu21_encode(luminance_cd_m2) -> np.ndarray:
    """PU21 ``banding_glare`` encoding of absolute luminance (cd/m²).

    ``V = p7 · (((p1 + p2 Y^p4) / (1 + p3 Y^p4))^p5 − p6)`` with ``Y`` clamped to
    ``[0.005, 10000]`` cd/m² (Mantiuk & Azimi 2021).  Pinned values: ``V(100) ≈ 256.38``,
    ``V(10000) ≈ 595.39``, ``V(0.005) ≈ 0``.

    Parameters
    ----------
    luminance_cd_m2 : array_like
        Any shape, finite, ≥ 0.

    Returns
    -------
    ndarray float64, same shape.
    """
    y = np.asarray(luminance_cd_m2, dtype=np.float64)
    if not np.all(np.isfinite(y)):
        raise ValueError("luminance_cd_m2 has NaN or infinite values")
    if np.any(y < 0):
        raise ValueError(f"luminance_cd_m2 must be ≥ 0 cd/m²; its minimum is {float(y.min())}")
    p1, p2, p3, p4, p5, p6, p7 = PU21_BANDING_GLARE
    yp = np.clip(y, *_PU21_RANGE) ** p4
    return p7 * (((p1 + p2 * yp) / (1.0 + p3 * yp)) ** p5 - p6)


def _pu21_pair(reference, estimate, peak_luminance) -> tuple[np.ndarray, np.ndarray]:
    ref, est = _pair(reference, estimate)
    peak = _positive("peak_luminance", peak_luminance, "cd/m²")
    y_ref, y_est = luminance(ref), luminance(est)
    top = float(y_ref.max())
    if top <= 0:
        raise ValueError("reference is black (its peak luminance is 0): nothing to scale to peak_luminance")
    scale = peak / top
    return pu21_encode(np.maximum(y_ref * scale, 0)), pu21_encode(np.maximum(y_est * scale, 0))


def pu21_psnr(reference, estimate, peak_luminance: float = 4000.0) -> float:
    """PSNR of PU21-encoded luminance, peak 256.

    Parameters
    ----------
    reference, estimate : array ``(H, W, 3)`` linear RGB or ``(H, W)`` luminance, relative units
        Both are multiplied by ``peak_luminance / max(Y_reference)`` (one factor, so the
        estimate's errors in exposure count) and negative values are clipped to 0.
    peak_luminance : float
        cd/m² given to the reference's brightest pixel (4000: an HDR display).
    """
    a, b = _pu21_pair(reference, estimate, peak_luminance)
    return psnr(a, b, PU21_PEAK)


def pu21_ssim(reference, estimate, peak_luminance: float = 4000.0) -> float:
    """SSIM (:func:`ssim`, ``data_range`` 256) of PU21-encoded luminance; scaling as :func:`pu21_psnr`."""
    a, b = _pu21_pair(reference, estimate, peak_luminance)
    return ssim(a, b, PU21_PEAK)
