"""Warping, Eq. 14–15 (§4.2): neighbours pulled onto the reference window by the flow, then averaged.

Eq. 14 (step 1) warps the **spike planes** of ``K`` neighbouring windows onto the reference
window and sums them,

.. math::

    I_{c,1}(x, t) = \\frac{M_c}{K W} \\sum_{t'} S_c(x + F_0(x, t, t'), t'),

and Eq. 15 (steps ``l ≥ 2``) averages ``K`` frames of the previous step, each warped by its flow,

.. math::

    I_{c,l}(x, t) = \\frac{1}{K} \\sum_{i} I_{c,l-1}(x + F_{l-1}(x, t, t_i), t_i).

What runs where: the paper's procedure (``ReconstructParams.paper()``, ``warp="progressive"``) makes every
step with this module.  The package's default (``warp="composed"``) makes the frames of steps ``1 … L − 1``
(which the later steps' flows are estimated on) here, and the output ``I_L`` with
:func:`spikeref.compose.composed_warp`, which composes the same flows so that each spike window is resampled
once, with a cubic kernel (``docs/spec/warp.md``).

Interpretations (``docs/equations.md``, "Interpretations")
---------------------------
* **Backward bilinear sampling, per Bayer plane.**  A frame is ``(4, h, w)`` Bayer planes
  (or any ``(C, h, w)`` stack) on the plane grid; the flow ``(2, h, w)`` holds ``(dy, dx)`` in
  plane pixels with the convention of :func:`spikeref.align.align`:
  ``alternate[y + dy, x + dx] ≈ reference[y, x]``.  The same flow moves all four planes.
* **Samples outside the image are dropped and the weights renormalised.**  A sample at
  ``(y + dy, x + dx)`` has four bilinear taps; taps outside the plane are left out.  For
  neighbour ``i`` this gives a partial sum ``s_i(x)`` and its tap weight ``ω_i(x)`` (the in-image
  bilinear weights, in ``[0, 1]``), and the average is ``Σ_i s_i(x) / Σ_i ω_i(x)`` — the
  ``1/K`` of Eq. 15 when every sample lies inside.  The reference itself has zero flow and
  weight 1, so the denominator is never below 1 in the pipeline; where it is 0 (no sample at
  all, only possible without the reference) the output is 0.
* **Eq. 14 on counts.**  Within one neighbour window every plane is moved by the same flow
  ``F_0(x, t, t')`` (the flow is estimated per window, step 0), and bilinear sampling is
  linear, so the sum over the window's ``W`` warped planes equals the warped window count.
  :func:`warp_spike_windows` therefore warps the ``K`` window counts — ``W`` times fewer
  samples than warping plane by plane — and divides by ``W``; the plane-by-plane sum of
  the equation is :func:`spikeref.oracles.warp.eq14_oracle`, and a test holds the two equal.
  ``M_c = 1`` (firing rates, ``docs/spec/README.md``).
"""

from __future__ import annotations

import numpy as np

from spikeref._warp_kernels import warp_average_kernel, warp_bilinear_kernel

__all__ = ["warp_bilinear", "warp_average", "warp_spike_windows"]


# ----------------------------------------------------------------------------- checks
def _as_float_stack(a, name: str, ndim: int) -> np.ndarray:
    arr = np.asarray(a)
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)) \
            or arr.dtype == np.bool_:
        raise TypeError(f"{name} must be a real numeric array; got dtype {arr.dtype}")
    if arr.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimensions; got shape {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def _check_flows(flows, shape, name: str) -> np.ndarray:
    arr = _as_float_stack(flows, name, len(shape))
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape} ((dy, dx) per pixel of the plane grid); got {arr.shape}")
    return arr


# ----------------------------------------------------------------------------- public
def warp_bilinear(image, flow) -> tuple[np.ndarray, np.ndarray]:
    """Backward bilinear warp of one frame, out-of-image taps dropped: Eq. 14–15's sampling for a single frame.

    :func:`warp_average` and :func:`warp_spike_windows` sample the same way inside one kernel; this
    function is the single-frame form, for inspecting a flow.

    Parameters
    ----------
    image : ndarray ``(C, h, w)`` or ``(h, w)``, real
        Frame on the plane grid (e.g. the four Bayer planes of firing rates).
    flow : ndarray ``(2, h, w)`` float
        ``(dy, dx)`` in plane pixels: the output at ``(y, x)`` samples ``image`` at
        ``(y + dy, x + dx)``.

    Returns
    -------
    warped : ndarray, same shape as ``image``, float32
        Renormalised samples ``s / w`` (0 where no tap lies inside the image).
    weight : ndarray ``(h, w)`` float32
        In-image bilinear weight ``w ∈ [0, 1]`` of each sample (1 where all taps are inside).
    """
    arr = np.asarray(image)
    squeeze = arr.ndim == 2
    arr = _as_float_stack(arr[None] if squeeze else arr, "image", 3)
    fl = _check_flows(flow, (2,) + arr.shape[1:], "flow")
    out = np.empty_like(arr)
    weight = np.empty(arr.shape[1:], np.float32)
    warp_bilinear_kernel(arr, fl, out, weight)
    safe = np.where(weight > 0, weight, 1.0).astype(np.float32)
    warped = np.where(weight > 0, out / safe, 0.0).astype(np.float32)
    return (warped[0] if squeeze else warped), weight


def warp_average(frames, flows) -> np.ndarray:
    """Eq. 15: the mean of ``K`` frames, each warped onto the reference by its flow.

    Parameters
    ----------
    frames : ndarray ``(K, C, h, w)`` real
        The neighbours ``I_{l−1}(t_i)`` (the reference among them, with zero flow).
    flows : ndarray ``(K, 2, h, w)`` float
        ``F_{l−1}(x, t, t_i)``, ``(dy, dx)`` in plane pixels (convention of
        :func:`spikeref.align.align`).

    Returns
    -------
    ndarray ``(C, h, w)`` float32
        ``Σ_i s_i / Σ_i w_i`` (module doc): ``1/K Σ_i I(x + F_i)`` where every sample is inside.
    """
    arr = _as_float_stack(frames, "frames", 4)
    if arr.shape[0] < 1:
        raise ValueError("frames must hold at least one frame (K ≥ 1)")
    fl = _check_flows(flows, (arr.shape[0], 2) + arr.shape[2:], "flows")
    out = np.empty(arr.shape[1:], np.float32)
    warp_average_kernel(arr, fl, out)
    return out


def warp_spike_windows(counts, flows, window: int) -> np.ndarray:
    """Eq. 14: spike planes of ``K`` windows warped onto the reference window, summed, over ``K·W``.

    Parameters
    ----------
    counts : ndarray ``(K, C, h, w)`` integer or float
        Spike counts of each neighbour window (``Σ_τ S_c(x, τ)`` over its ``W`` planes, per
        Bayer plane).  Warping the count equals summing the warped planes (module doc).
    flows : ndarray ``(K, 2, h, w)`` float
        ``F_0(x, t, t')`` from the reference window to each neighbour window.
    window : int
        ``W``, planes per window.

    Returns
    -------
    ndarray ``(C, h, w)`` float32
        ``I_1``, firing rates in spikes per readout (``M_c = 1``).
    """
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 1:
        raise ValueError(f"window must be a positive integer number of planes; got {window!r}")
    return warp_average(counts, flows) / np.float32(window)
