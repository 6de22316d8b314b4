"""Oracle for the whole progressive warping reconstruction, Eq. 13–15 and Fig. 3(b).

A direct recursion over the steps, written from the paper and built only from the other
oracles: Eq. 4 (:func:`accumulate_oracle`), the Bayer split, the U-Net
(:func:`unet_forward_oracle`, count domain as the bundled weights), the residual shrinkage,
the HDR+ alignment (:func:`align_oracle`), Eq. 14 (:func:`eq14_oracle`, plane by plane),
Eq. 15 (:func:`eq15_oracle`) and Ψ (:func:`demosaic_bilinear_oracle`). Nothing is streamed
or kept in rings: each quantity is defined by its equation and computed once per call,
memoised by its (step, window) key. :class:`spikeref.pipeline.Reconstructor` must give
the same frames (``golden/pipeline_frames.npz``).

Definitions (DESIGN §4; ``h = (K − 1)/2``; window ``j`` = planes ``[jW, (j+1)W)``):

* ``I_0(j)``: the Bayer planes of Eq. 4 over window ``j``.
* ``D_l(j) = f(I_l(j)·E_l)/E_l``, then the shrinkage with window ``E_l``. ``E_l`` is the
  noise-equivalent exposure: ``W`` at ``l = 0``, and ``W / Σ c²`` at ``l ≥ 1``, where ``c``
  is the ``l``-fold convolution of ``K`` equal weights normalised to sum 1. ``f`` is the
  U-Net on counts, in the visible mode.
* ``F_l(j, j+i)``: HDR+ alignment, at step ``l``, of ``luma(D_l(j))`` (the mean of the four
  planes) against ``luma(D_l(j+i))``; zero for ``i = 0``.  With ``flow_frames="smoothed"``
  (the speed option, not in the paper) it aligns :func:`flow_luma_oracle` of ``I_l(j)`` and
  ``I_l(j+i)`` instead, and ``D`` is needed only for the output.
* ``I_1(j)``: Eq. 14 over the spike planes of windows ``j−h … j+h``, each warped by
  ``F_0(j, j+i)``.
* ``I_l(j)``, ``l ≥ 2``: Eq. 15 over ``I_{l−1}(j+i)`` warped by ``F_{l−1}(j, j+i)``.
* Output: ``R_l(k) = Ψ[mosaic(D_l(k))]`` for every step ``l`` (``R_L`` is the frame).
"""

from __future__ import annotations

import numpy as np

from spikeref.oracles.accumulate import accumulate_oracle
from spikeref.oracles.align import align_oracle
from spikeref.oracles.bayer import bayer_planes_oracle, demosaic_bilinear_oracle
from spikeref.oracles.shrinkage import shrink_residual_oracle
from spikeref.oracles.unet import unet_forward_oracle
from spikeref.oracles.warp import eq14_oracle, eq15_oracle

__all__ = ["exposure_oracle", "flow_luma_oracle", "reconstruct_oracle"]


def exposure_oracle(window, K, level):
    """``E_l``: ``W`` at step 0, ``W / Σ_j c_j²`` after ``l`` averages of ``K`` equal weights."""
    if level == 0 or K == 1:
        return float(window)
    weights = [1.0]
    for _ in range(level):
        longer = [0.0] * (len(weights) + K - 1)
        for a, wa in enumerate(weights):
            for b in range(K):
                longer[a + b] += wa / K
        weights = longer
    return window / sum(c * c for c in weights)


def flow_luma_oracle(planes, sigma):
    """The smoothed luma of ``flow_frames="smoothed"``, pixel by pixel.

    ``y = (P_0 + P_1 + P_2 + P_3) / 4`` (rounded to float32, as the luma the alignment sees),
    then a Gaussian of standard deviation ``sigma`` along the rows and then along the columns:
    taps ``g_m ∝ exp(−m² / 2σ²)`` for ``m = −r … r``, ``r = ⌊4σ + ½⌋``, normalised to sum 1; a
    sample outside the image is mirrored half-sample symmetrically (``−1 → 0``, ``n → n − 1``).
    Float64 arithmetic, float32 result.  ``sigma = 0`` returns ``y``.
    """
    y = np.mean(np.asarray(planes, dtype=np.float64), axis=0).astype(np.float32).astype(np.float64)
    if sigma == 0:
        return y.astype(np.float32)
    r = int(4.0 * sigma + 0.5)
    taps = [np.exp(-m * m / (2.0 * sigma * sigma)) for m in range(-r, r + 1)]
    total = sum(taps)
    taps = [g / total for g in taps]

    def mirror(i, n):
        while i < 0 or i >= n:
            i = -i - 1 if i < 0 else 2 * n - i - 1
        return i

    def smooth_rows(img):  # along the last axis
        rows, cols = img.shape
        out = np.zeros_like(img)
        for a in range(rows):
            for b in range(cols):
                out[a, b] = sum(taps[m + r] * img[a, mirror(b + m, cols)] for m in range(-r, r + 1))
        return out

    return smooth_rows(smooth_rows(y).T).T.astype(np.float32)


def _mosaic(planes):
    _, h, w = planes.shape
    out = np.zeros((2 * h, 2 * w), dtype=planes.dtype)
    for p in range(4):
        out[p // 2::2, p % 2::2] = planes[p]
    return out


def reconstruct_oracle(spikes, cfa, window, K, L, unet_params, align_params, frames, depth=5, slope=0.1,
                       flow_frames="denoised", flow_sigma=1.0, keep_steps=True):
    """Frames ``R_L(k)``, every step ``R_l(k)`` and the flows ``F_l(k, k+i)`` for ``k`` in ``frames``.

    Parameters
    ----------
    spikes : ndarray ``(T, H, W)`` 0/1
        A Bayer spike stream with pattern ``cfa``.
    window, K, L : int
        ``W``, frames per step (odd), steps.
    unet_params : dict
        Weights of a count-domain U-Net (names as :class:`spikeref.denoise.unet.UNet`).
    align_params : AlignParams
    frames : sequence of int
        Output frame numbers; each needs windows ``k − L h … k + L h`` inside the stream.
    flow_frames : {"denoised", "smoothed"}
        What the flows align: ``luma(D_l)`` (Fig. 3(b)) or ``flow_luma_oracle(I_l, flow_sigma)``.
    keep_steps : bool
        Also return every ``R_l`` (``steps``); without it ``D`` runs only for the outputs when
        ``flow_frames="smoothed"``.

    Returns
    -------
    dict
        ``rgb (n, H, W, 3)``, ``steps (n, L+1, H, W, 3)`` (with ``keep_steps``) and
        ``flows (n, L, K, 2, h, w)``, all float64.
    """
    h = (K - 1) // 2
    planes_memo, denoised_memo, flow_memo = {}, {}, {}

    def window_planes(j):  # the spike planes of window j, split into Bayer planes
        return [bayer_planes_oracle(spikes[t]) for t in range(j * window, (j + 1) * window)]

    def I_l(level, j):
        key = (level, j)
        if key not in planes_memo:
            if level == 0:
                planes_memo[key] = bayer_planes_oracle(accumulate_oracle(spikes, window, start=j * window)[0])
            else:
                flows = np.stack([F_l(level - 1, j, j + i) for i in range(-h, h + 1)])
                if level == 1:
                    sp = np.stack([p for i in range(-h, h + 1) for p in window_planes(j + i)])
                    planes_memo[key] = eq14_oracle(sp, flows, window)
                else:
                    planes_memo[key] = eq15_oracle(np.stack([I_l(level - 1, j + i) for i in range(-h, h + 1)]), flows)
        return planes_memo[key]

    def D_l(level, j):
        key = (level, j)
        if key not in denoised_memo:
            exposure = exposure_oracle(window, K, level)
            noisy = I_l(level, j)
            counts = (noisy * exposure).astype(np.float32)
            clean = unet_forward_oracle(unet_params, counts, depth, slope).astype(np.float64) / exposure
            denoised_memo[key] = shrink_residual_oracle(noisy, clean, exposure)
        return denoised_memo[key]

    def luma(planes):
        return np.mean(planes, axis=0).astype(np.float32)

    def F_l(level, j, j2):
        key = (level, j, j2)
        if key not in flow_memo:
            if j == j2:
                flow_memo[key] = np.zeros((2, spikes.shape[1] // 2, spikes.shape[2] // 2))
            elif flow_frames == "smoothed":
                flow_memo[key] = align_oracle(flow_luma_oracle(I_l(level, j), flow_sigma),
                                              flow_luma_oracle(I_l(level, j2), flow_sigma), level, align_params)
            else:
                flow_memo[key] = align_oracle(luma(D_l(level, j)), luma(D_l(level, j2)), level, align_params)
        return flow_memo[key]

    rgb, steps, flows = [], [], []
    for k in frames:
        levels = range(L + 1) if keep_steps else [L]
        frame_steps = [demosaic_bilinear_oracle(_mosaic(D_l(level, k)), cfa) for level in levels]
        if keep_steps:
            steps.append(frame_steps)
        rgb.append(frame_steps[-1])
        flows.append([[F_l(level, k, k + i) for i in range(-h, h + 1)] for level in range(L)])
    out = {"rgb": np.array(rgb), "flows": np.array(flows, dtype=np.float64)}
    if keep_steps:
        out["steps"] = np.array(steps)
    return out
