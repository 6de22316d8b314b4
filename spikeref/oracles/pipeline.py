"""Oracle for the whole progressive warping reconstruction, Eq. 13–15 and Fig. 3(b).

A direct recursion over the steps, written from the paper and built only from the other
oracles: Eq. 4 (:func:`accumulate_oracle`), the Bayer split, the U-Net
(:func:`unet_forward_oracle`, count domain as the bundled weights), the residual shrinkage,
the HDR+ alignment (:func:`align_oracle`), Eq. 14 (:func:`eq14_oracle`, plane by plane),
Eq. 15 (:func:`eq15_oracle`) and Ψ (:func:`demosaic_bilinear_oracle`). Nothing is streamed
or kept in rings: each quantity is defined by its equation and computed once per call,
memoised by its (step, window) key. :class:`spikeref.pipeline.Reconstructor` must give
the same frames (``golden/pipeline_frames.npz``).

Definitions (docs/spec/pipeline.md; ``h = (K − 1)/2``; window ``j`` = planes ``[jW, (j+1)W)``):

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

Options beyond the paper (defaults of :class:`spikeref.pipeline.ReconstructParams` and
:class:`spikeref.denoise.denoiser.Denoiser`, each off here unless asked for):

* ``warp="composed"``: ``I_L(k)`` by :func:`composed_warp_oracle` over the ``K^L`` paths
  ``(i_L, …, i_1)`` — hop ``m`` (from step ``L−1`` down to 0) moves by ``F_m(j, j+i)`` of the
  frame ``j`` reached — from the spike counts of the windows the paths end in.
* ``warp="chained"``: the same, but every hop moves by the step-0 flow ``F_0(j, j+i)`` of the
  frame reached; no frame of a step ``1 … L−1`` is needed.
* ``guard="sure"``: the output's ``D_L`` is ``I + α (f(I) − I)`` with the SURE ``α`` of
  :func:`sure_alpha_oracle`: σ of each plane by :func:`noise_sigma_oracle` (keep 0.75), at least
  :func:`quantisation_variance_oracle` of ``f(I)`` per pixel, the probe ``b`` the ±1 array of
  NumPy's ``default_rng(0).integers(0, 2, shape, int8) · 2 − 1``, ``ε = 0.05`` × the root mean
  variance of the plane, radius 8; no shrinkage.  Frames that are only aligned are unguarded.
* ``accumulate="charge"``: every window's Eq. 4 count is replaced by its charge
  (:func:`window_charge_oracle`, margin 200 readouts over the whole stream): ``I_0(j)`` is the
  charge over ``W``; ``I_1(j)`` is Eq. 15 over ``I_0(j+i)`` (Eq. 14 with one flow per window is
  Eq. 15 of the windows' rates; a charge has no spike planes); the composed warp moves charges.
  With ``guard="sure"`` and ``L ≥ 1`` each plane's ``σ²`` is capped at
  :func:`carried_excess_variance_oracle` of ``I_0(k)`` (``W₀ = W``, carried to ``E_L``) plus the
  plane's mean floor, and every floor is the charge's (:func:`quantisation_variance_oracle`).
"""

from __future__ import annotations

import numpy as np

from spikeref.oracles.accumulate import accumulate_oracle
from spikeref.oracles.align import align_oracle
from spikeref.oracles.bayer import bayer_planes_oracle, demosaic_bilinear_oracle
from spikeref.oracles.charge import window_charge_oracle
from spikeref.oracles.compose import composed_warp_oracle
from spikeref.oracles.guard import (
    carried_excess_variance_oracle,
    noise_sigma_oracle,
    quantisation_variance_oracle,
    sure_alpha_oracle,
)
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
                       flow_frames="denoised", flow_sigma=1.0, keep_steps=True, warp="progressive",
                       guard="off", accumulate="count", resample="path"):
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
    warp : {"progressive", "composed", "chained"}
        How ``I_L`` is made (module docstring).
    resample : {"path", "window"}
        With ``warp="composed"``/``"chained"``: each path samples its window, or each window is sampled once
        at the mean position of its paths (:func:`composed_warp_oracle`).
    guard : {"off", "sure"}
        The guard on the output's ``D_L`` (module docstring); ``"off"`` applies the shrinkage.
    accumulate : {"count", "charge"}
        What a window gives: Eq. 4's count or the window charge (module docstring).

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

    totals_memo = {}

    def window_total(j):  # what window j gives, per Bayer plane: its spike count or its charge (made once)
        if j not in totals_memo:
            if accumulate == "charge":
                totals_memo[j] = bayer_planes_oracle(window_charge_oracle(spikes, window, start=j * window, count=1)[0])
            else:
                totals_memo[j] = bayer_planes_oracle(accumulate_oracle(spikes, window, start=j * window)[0]) * window
        return totals_memo[j]

    def I_l(level, j):
        key = (level, j)
        if key not in planes_memo:
            if level == 0:
                if accumulate == "charge":
                    planes_memo[key] = window_total(j) / window
                else:
                    planes_memo[key] = bayer_planes_oracle(accumulate_oracle(spikes, window, start=j * window)[0])
            else:
                flows = np.stack([F_l(level - 1, j, j + i) for i in range(-h, h + 1)])
                if level == L and warp in ("composed", "chained") and h:
                    planes_memo[key] = composed_I_L(j)
                elif level == 1 and accumulate == "charge":
                    planes_memo[key] = eq15_oracle(np.stack([I_l(0, j + i) for i in range(-h, h + 1)]), flows)
                elif level == 1:
                    sp = np.stack([p for i in range(-h, h + 1) for p in window_planes(j + i)])
                    planes_memo[key] = eq14_oracle(sp, flows, window)
                else:
                    planes_memo[key] = eq15_oracle(np.stack([I_l(level - 1, j + i) for i in range(-h, h + 1)]), flows)
        return planes_memo[key]

    def composed_I_L(j):
        bank, index, hops, targets = [], {}, [], []
        paths = [[]]
        for _ in range(L):
            paths = [p + [i] for p in paths for i in range(-h, h + 1)]
        for path in paths:
            jj, row = j, []
            for m, i in zip(range(L - 1, -1, -1), path, strict=True):
                if i:
                    step = 0 if warp == "chained" else m
                    if (step, jj, i) not in index:
                        index[(step, jj, i)] = len(bank)
                        bank.append(F_l(step, jj, jj + i))
                    row.append(index[(step, jj, i)])
                else:
                    row.append(-1)
                jj += i
            hops.append(row)
            targets.append(jj - (j - L * h))
        counts = np.stack([window_total(t) for t in range(j - L * h, j + L * h + 1)])
        return composed_warp_oracle(counts, np.stack(bank), hops, targets, window, resample)

    def network(planes, exposure):
        counts = (planes * exposure).astype(np.float32)
        return unet_forward_oracle(unet_params, counts, depth, slope).astype(np.float64) / exposure

    def sure_guard(noisy, exposure, short=None):
        noisy = noisy.astype(np.float32).astype(np.float64)
        clean = network(noisy, exposure).astype(np.float32).astype(np.float64)
        var = np.zeros_like(noisy)
        for c in range(noisy.shape[0]):
            s2 = noise_sigma_oracle(noisy[c]) ** 2
            floors = [[quantisation_variance_oracle(clean[c, y, x], exposure, accumulate)
                       for x in range(noisy.shape[2])] for y in range(noisy.shape[1])]
            if short is not None:  # the noise measured on the reference window, carried to the exposure
                carried = carried_excess_variance_oracle(short[c], window, exposure, accumulate=accumulate)
                s2 = min(s2, carried + float(np.mean(floors)))
            for y in range(noisy.shape[1]):
                for x in range(noisy.shape[2]):
                    var[c, y, x] = max(s2, floors[y][x])
        b = (np.random.default_rng(0).integers(0, 2, size=noisy.shape, dtype=np.int8) * 2 - 1).astype(np.float64)
        eps = [0.05 * np.sqrt(var[c].mean()) for c in range(noisy.shape[0])]
        probed_in = (noisy + np.array(eps)[:, None, None] * b).astype(np.float32)
        probed = network(probed_in, exposure).astype(np.float32).astype(np.float64)
        out = np.zeros_like(noisy)
        for c in range(noisy.shape[0]):
            alpha = sure_alpha_oracle(noisy[c], clean[c], probed[c], b[c], eps[c], np.sqrt(var[c]), 8)
            out[c] = noisy[c] + alpha * (clean[c] - noisy[c])
        return out

    def D_l(level, j):
        key = (level, j)
        if key not in denoised_memo:
            exposure = exposure_oracle(window, K, level)
            noisy = I_l(level, j)
            if guard == "sure" and level == L:
                short = I_l(0, j).astype(np.float32) if accumulate == "charge" and L > 0 else None
                denoised_memo[key] = sure_guard(noisy, exposure, short)
            else:
                denoised_memo[key] = shrink_residual_oracle(noisy, network(noisy, exposure), exposure)
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
