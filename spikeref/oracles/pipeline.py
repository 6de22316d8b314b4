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
* ``D_l(j) = f(I_l(j)·E_l)/E_l``, then (``shrink=True``, not in the paper) the shrinkage with window
  ``E_l``. ``E_l`` is the noise-equivalent exposure: ``W`` at ``l = 0``, and ``W / Σ c²`` at ``l ≥ 1``, where ``c``
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
  :func:`sure_alpha_oracle`: σ of each plane by :func:`noise_sigma_oracle` (keep 0.75) — where the
  exposure ``E_L`` exceeds 10 planes (``NOISE_WINDOW``) its square capped at the plane's mean floor (the
  count path: no short window) —, at least :func:`quantisation_variance_oracle` of ``f(I)`` per pixel,
  the probe ``b`` the ±1 array of
  NumPy's ``default_rng(0).integers(0, 2, shape, int8) · 2 − 1``, ``ε = 0.05`` × the root mean
  variance of the plane, radius 8; no shrinkage.  Frames that are only aligned are unguarded.  On charges the
  floor, the carried noise and the 10-plane test take the whole support ``((K−1)L + 1)·W`` in place of ``E_L``
  (a merge of consecutive window charges shares their inner edges); the network still takes ``E_L``.
* ``accumulate="charge"``: every window's Eq. 4 count is replaced by its charge
  (:func:`window_charge_oracle`, margin 200 readouts over the whole stream): ``I_0(j)`` is the
  charge over ``W``; ``I_1(j)`` is Eq. 15 over ``I_0(j+i)`` (Eq. 14 with one flow per window is
  Eq. 15 of the windows' rates; a charge has no spike planes); the composed warp moves charges.
  With ``guard="sure"``, ``L ≥ 1`` and ``E_L > 10`` each plane's ``σ²`` is capped at 0.75 ×
  (``CARRY_FRACTION``) :func:`carried_excess_variance_oracle` of ``I_0(k)`` (``W₀ = W``, carried to
  ``E_L``; only where ``W ≤ 10``, else 0) plus the plane's mean floor, and every floor is the charge's
  (:func:`quantisation_variance_oracle`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter, map_coordinates

from spikeref.oracles.accumulate import accumulate_oracle
from spikeref.oracles.align import align_oracle, case_align_params
from spikeref.oracles.bayer import bayer_planes_oracle, demosaic_bilinear_oracle
from spikeref.oracles.case import OracleCase
from spikeref.oracles.charge import window_charge_oracle
from spikeref.oracles.compose import composed_warp_oracle
from spikeref.oracles.guard import (
    carried_excess_variance_oracle,
    noise_sigma_oracle,
    quantisation_variance_oracle,
    sure_alpha_oracle,
)
from spikeref.oracles.shrinkage import shrink_residual_oracle
from spikeref.oracles.unet import layer_names, unet_forward_oracle, unet_params_from_inputs
from spikeref.oracles.warp import eq14_oracle, eq15_oracle

__all__ = ["exposure_oracle", "flow_luma_oracle", "reconstruct_oracle", "GOLDEN_CASES", "PIPELINE_WEIGHTS"]


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
                       guard="off", accumulate="count", resample="path", shrink=True):
    """Frames ``R_L(k)``, every step ``R_l(k)`` and the flows ``F_l(k, k+i)`` for ``k`` in ``frames``.

    Parameters
    ----------
    spikes : ndarray ``(T, H, W)`` 0/1
        A Bayer spike stream with pattern ``cfa``.
    window, K, L : int
        ``W``, frames per step (odd), steps.
    unet_params : dict
        Weights of a count-domain U-Net (names as :class:`spikeref.denoise.unet.UNet`).
    align_params : object
        The alignment parameters: any object with :class:`spikeref.align.AlignParams`' attributes (the
        golden cases give :data:`~spikeref.oracles.align.PAPER_ALIGN` with their own settings).
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
    shrink : bool
        With ``guard="off"``, the residual shrinkage after every ``D`` (the package's default); False is the
        paper's ``D_l(j) = f(I_l(j)·E_l)/E_l`` alone (``--paper``).
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
        # on charges the guard's floor, carried noise and test are at the whole support (a merge of consecutive
        # window charges quantises like one charge over it); the network still gets the exposure
        noise_at = float(((K - 1) * L + 1) * window) if accumulate == "charge" else exposure
        var = np.zeros_like(noisy)
        for c in range(noisy.shape[0]):
            s2 = noise_sigma_oracle(noisy[c]) ** 2
            floors = [[quantisation_variance_oracle(clean[c, y, x], noise_at, accumulate)
                       for x in range(noisy.shape[2])] for y in range(noisy.shape[1])]
            if noise_at > 10:  # longer than NOISE_WINDOW: the plane's σ reads texture and fixed pattern as noise
                carried = 0.0  # no short window of at most 10 planes: the floor alone
                if short is not None and window <= 10:  # the noise measured on the reference window, 3/4 of it
                    carried = 0.75 * carried_excess_variance_oracle(short[c], window, noise_at, accumulate=accumulate)
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
                clean = network(noisy, exposure)
                denoised_memo[key] = shrink_residual_oracle(noisy, clean, exposure) if shrink else clean
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


# ----------------------------------------------------------------------------- the golden cases
#: The golden pipeline's settings: W = 5, K = 3, L = 3 on a 64×64 RGGB stream of 45 planes
#: (frames 3 … 5 exist), with an alignment pyramid small enough for 32×32 Bayer planes.
_PIPELINE = {"window": 5, "K": 3, "L": 3, "frames": (3, 4), "cfa": "RGGB",
             "align": {"levels": 2, "tile_by_step": (16, 8), "coarse_tile": 8, "search_radius": (1, 4),
                       "subpixel": True}}
#: The bundled weights the pipeline cases run (trained on Eq. 4's counts; ``tests/test_golden.py`` holds it
#: equal to :data:`spikeref.denoise.denoiser.DEFAULT_WEIGHTS`).
PIPELINE_WEIGHTS = Path(__file__).resolve().parents[1] / "denoise" / "weights" / "b2u_w16.npz"


def _pipeline_params(extra: dict) -> dict:
    """The manifest parameters of a pipeline case: the shared settings, ``extra``, then the alignment's."""
    return {"window": _PIPELINE["window"], "K": _PIPELINE["K"], "L": _PIPELINE["L"],
            "frames": list(_PIPELINE["frames"]), "cfa": _PIPELINE["cfa"], "mode": "visible", **extra,
            "align": {k: list(v) if isinstance(v, tuple) else v for k, v in _PIPELINE["align"].items()}}


def _bundled_unet_params(path: Path) -> dict:
    """The layers' arrays of a weights ``.npz`` in running order, read without the package's reader (the
    file's other members are its format, shape and JSON metadata)."""
    with np.load(path, allow_pickle=False) as z:
        depth = int(z["depth"])
        return {f"{name}.{part}": np.asarray(z[f"{name}.{part}"], dtype=np.float32)
                for name in layer_names(depth) for part in ("weight", "bias")}


def _inputs_pipeline():
    """45 planes of 64×64 RGGB spikes: integrate-and-fire (random phase, no other noise) of a
    smooth random texture translating by (0.1, 0.25) pixels per plane (down, right), i.e. by
    (0.25, 0.625) Bayer-plane pixels per window of 5 planes; and the bundled ``b2u_w16`` weights."""
    rng = np.random.default_rng(14)
    t_total, h, w = 45, 64, 64
    field = gaussian_filter(rng.random((h + 32, w + 32)), 2.0)
    field = (field - field.min()) / (field.max() - field.min())
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    charge = rng.random((h, w))
    spikes = np.zeros((t_total, h, w), np.uint8)
    for t in range(t_total):
        charge += 0.05 + 0.85 * map_coordinates(field, [yy + 8 - 0.1 * t, xx + 8 - 0.25 * t], order=1)
        spikes[t] = charge >= 1.0
        charge[charge >= 1.0] -= 1.0
    return {"spikes": spikes, **{f"param_{k}": v for k, v in _bundled_unet_params(PIPELINE_WEIGHTS).items()}}


def _pipeline_case_oracle(i, outputs=("rgb", "flows", "steps"), **variant):
    """``outputs`` of :func:`reconstruct_oracle` on the case's inputs and settings, the steps without ``R_L``,
    as float32 (the file stays small)."""
    c = _PIPELINE
    out = reconstruct_oracle(i["spikes"], c["cfa"], c["window"], c["K"], c["L"], unet_params_from_inputs(i),
                             case_align_params(c["align"]), c["frames"],
                             keep_steps="steps" in outputs, **variant)
    if "steps" in outputs:
        out["steps"] = out["steps"][:, :-1]  # R_L is out["rgb"]
    return {k: out[k].astype(np.float32) for k in outputs}


_SMOOTHED = {"outputs": ("rgb", "flows"), "flow_frames": "smoothed"}
_COMPOSED = {"outputs": ("rgb", "flows"), "warp": "composed", "guard": "sure"}
_CHAINED = {"outputs": ("rgb",), "warp": "chained", "guard": "sure"}
_CHARGE = {"outputs": ("rgb", "flows"), "warp": "composed", "guard": "sure", "flow_frames": "smoothed",
           "accumulate": "charge"}
_WINDOW = {**_CHARGE, "outputs": ("rgb",), "resample": "window"}
#: The SURE guard's settings in the manifest of the cases that use it (spikeref.denoise.guard).
_GUARD_PARAMS = {"guard": "sure", "guard_radius": 8, "noise_keep": 0.75, "probe_seed": 0, "probe_fraction": 0.05,
                 "noise_window": 10, "carry_fraction": 0.75}


def _charge_case_params(resample: str) -> dict:
    """The manifest parameters of the pipeline cases on window charges (``pipeline_frames_charge``, ``…_window``)."""
    return _pipeline_params({"input_domain": "count", "accumulate": "charge", "charge_margin": 200,
                             "warp": "composed", "resample": resample, "flow_frames": "smoothed",
                             "flow_sigma": 1.0, **_GUARD_PARAMS,
                             "guard_short_window": "the frame's own window (W)"})


def _pipeline_case(name, equation, function, oracle, description, params, variant=None):
    """A pipeline case: the shared inputs and tolerance, its ``variant`` of the settings (with the outputs
    kept) in ``settings`` for the fast side."""
    variant = variant or {}
    return OracleCase(name, equation, function, oracle, description, _inputs_pipeline,
                      lambda i: _pipeline_case_oracle(i, **variant), rtol=1e-4, atol=1e-5, params=params,
                      spec=f"docs/spec/pipeline.md#{name}", jit_disabled_check=False,
                      settings={**_PIPELINE, "variant": variant})


def _inputs_flow_luma():
    """Four 9×13 Bayer planes of random rates (float32): small enough that σ = 1.5 mirrors twice."""
    return {"planes": np.random.default_rng(15).random((4, 9, 13)).astype(np.float32)}


_FLOW_SIGMAS = (0.0, 0.7, 1.0, 1.5)


def _flow_luma_outputs(i, flow_luma):
    return {f"sigma_{s:g}": flow_luma(i["planes"], s) for s in _FLOW_SIGMAS}


GOLDEN_CASES = (
    _pipeline_case(
        "pipeline_frames", "Eq. 13–15, Fig. 3(b)", "spikeref.pipeline.Reconstructor (frames with keep_steps)",
        "spikeref.oracles.pipeline.reconstruct_oracle",
        "The whole reconstruction end to end: a 64×64 RGGB stream of 45 planes (a smooth texture moving by "
        "(0.25, 0.625) plane pixels per window), W=5, K=3, L=3, the count-domain U-Net whose weights are in the "
        "file (b2u_w16), visible mode, residual shrinkage, AlignParams(levels=2, tile_by_step=(16, 8), "
        "coarse_tile=8, search_radius=(1, 4)). Outputs for frames 3 and 4: R_L (rgb), the earlier R_l (steps, "
        "l = 0…2) and the flows F_l(k, k+i) (l = 0…2, i = −1, 0, 1; zero for i = 0) as (dy, dx) with "
        "alternate[y+dy, x+dx] ≈ reference[y, x]. The oracle computes in float64; its outputs are stored "
        "as float32.",
        _pipeline_params({"shrink": True, "input_domain": "count",
                          "exposure": "W at l=0, W/Σc² at l≥1 (spikeref.pipeline.exposure_planes)"}),
    ),
    _pipeline_case(
        "pipeline_frames_paper", "Eq. 13–15, Fig. 3(b), the paper's D (no shrinkage)",
        "spikeref.pipeline.Reconstructor (ReconstructParams.paper(), Denoiser(guard=\"off\", shrink=False): --paper)",
        "spikeref.oracles.pipeline.reconstruct_oracle (shrink=False)",
        "The inputs and settings of pipeline_frames with every D_l the network's output alone, "
        "f(I_l·E_l)/E_l, as the paper has it (no residual shrinkage): what spikeref reconstruct --paper runs. "
        "Outputs: R_L (rgb) and every flow of frames 3 and 4. The oracle computes in float64; its outputs are "
        "stored as float32.",
        _pipeline_params({"shrink": False, "input_domain": "count",
                          "exposure": "W at l=0, W/Σc² at l≥1 (spikeref.pipeline.exposure_planes)"}),
        {"outputs": ("rgb", "flows"), "shrink": False},
    ),
    OracleCase(
        "flow_luma", "— (not in the paper; the flow frames of flow_frames=\"smoothed\")",
        "spikeref.pipeline.flow_luma", "spikeref.oracles.pipeline.flow_luma_oracle",
        "The smoothed 2×2 luma that flow_frames=\"smoothed\" aligns: the mean of four 9×13 Bayer planes "
        "(rounded to float32), then a Gaussian of σ = 0, 0.7, 1 (the pipeline's value), 1.5 plane pixels along "
        "rows then columns: taps exp(−m²/2σ²), m = −r…r, r = ⌊4σ + ½⌋, normalised; half-sample symmetric "
        "border; float64 arithmetic, float32 result.",
        _inputs_flow_luma, lambda i: _flow_luma_outputs(i, flow_luma_oracle),
        rtol=1e-6, atol=1e-7, params={"sigmas": list(_FLOW_SIGMAS), "truncate": 4.0,
                                      "border": "half-sample symmetric (SciPy 'reflect': index −1 reads 0)"},
        spec="docs/spec/pipeline.md#flow_luma",
        outputs=_flow_luma_outputs,
    ),
    _pipeline_case(
        "pipeline_frames_smoothed_flow", "Eq. 13–15 with flow_frames=\"smoothed\" (not in the paper)",
        "spikeref.pipeline.Reconstructor (ReconstructParams(flow_frames=\"smoothed\"))",
        "spikeref.oracles.pipeline.reconstruct_oracle (flow_frames=\"smoothed\")",
        "The inputs and settings of pipeline_frames, with each step's flow estimated on flow_luma(I_l) (σ = 1 "
        "plane pixel) instead of the luma of D(I_l): R_L (rgb) and the flows F_l(k, k+i) of frames 3 and 4. "
        "The oracle computes in float64; its outputs are stored as float32.",
        _pipeline_params({"shrink": True, "input_domain": "count", "flow_frames": "smoothed", "flow_sigma": 1.0}),
        _SMOOTHED,
    ),
    _pipeline_case(
        "pipeline_frames_composed_guard",
        "Eq. 13–15 with warp=\"composed\" and the SURE guard (not in the paper; the package's defaults)",
        "spikeref.pipeline.Reconstructor (ReconstructParams(warp=\"composed\"), Denoiser(guard=\"sure\"))",
        "spikeref.oracles.pipeline.reconstruct_oracle (warp=\"composed\", guard=\"sure\")",
        "The inputs and settings of pipeline_frames, with I_L made by composing the step flows along the 27 "
        "paths and resampling each spike window once (Catmull–Rom; spikeref.compose), and the output's D "
        "guarded by Stein's unbiased risk estimate (spikeref.denoise.guard: σ per plane from the smallest 75 % "
        "of the 3×3 difference-of-Laplacians responses, its square capped at the plane's mean quantisation "
        "floor since the exposure E_3 = 3645/141 exceeds 10 planes and no short window is given, the "
        "quantisation floor per pixel, a ±1 probe from "
        "default_rng(0), ε = 0.05 × the plane's root mean variance, a 17×17 box); frames of steps < L and "
        "their flows as in pipeline_frames. Outputs: R_L (rgb) and the flows of frames 3 and 4. The oracle "
        "computes in float64; its outputs are stored as float32.",
        _pipeline_params({"input_domain": "count", "warp": "composed", "resample": "path",
                          "interpolant": "Catmull-Rom (Keys a = -1/2)", **_GUARD_PARAMS}),
        _COMPOSED,
    ),
    _pipeline_case(
        "pipeline_frames_chained",
        "Eq. 13–15 with warp=\"chained\" and the SURE guard (a speed option, not in the paper)",
        "spikeref.pipeline.Reconstructor (ReconstructParams(warp=\"chained\"), Denoiser(guard=\"sure\"))",
        "spikeref.oracles.pipeline.reconstruct_oracle (warp=\"chained\", guard=\"sure\")",
        "The inputs and settings of pipeline_frames_composed_guard, with every hop of the 27 paths moved by the "
        "step-0 flow F_0(j, j+i) of the window reached (no frame or flow of steps 1…L−1): R_L (rgb) of frames 3 "
        "and 4. The oracle computes in float64; its outputs are stored as float32.",
        _pipeline_params({"input_domain": "count", "warp": "chained", "resample": "path",
                          "flow_frames": "denoised", "guard": "sure"}),
        _CHAINED,
    ),
    _pipeline_case(
        "pipeline_frames_charge",
        "Eq. 13–15 on window charges, warp=\"composed\", smoothed flow frames and the SURE guard (not in the "
        "paper; the package's defaults but for the alignment parameters)",
        "spikeref.pipeline.Reconstructor (ReconstructParams(accumulate=\"charge\", warp=\"composed\", "
        "flow_frames=\"smoothed\"), Denoiser(guard=\"sure\"))",
        "spikeref.oracles.pipeline.reconstruct_oracle (accumulate=\"charge\", warp=\"composed\", "
        "flow_frames=\"smoothed\", guard=\"sure\")",
        "The inputs and network of pipeline_frames, every window's Eq. 4 count replaced by its charge "
        "(spikeref.charge, margin 200 readouts: the whole stream here): I_0 is the charge over W, I_1 Eq. 15 "
        "over the I_0 of the K windows (Eq. 14 with one flow per window), flows on flow_luma(I_l) (σ = 1), I_L "
        "by the composed warp of the charges (as pipeline_frames_composed_guard), and the output's guard with "
        "each plane's σ² capped at 3/4 (CARRY_FRACTION) of the noise above the charge's floor measured on I_0 "
        "of the frame's own window (W = 5 ≤ 10 planes) and carried to the whole support ((K−1)L+1)·W (a merge of "
        "consecutive charges shares their inner edges), plus the mean floor, every floor the charge's p²/(6W²) "
        "bound at that length. Outputs: R_L (rgb) and "
        "the flows of frames 3 and 4. The oracle computes in float64; its outputs are stored as float32.",
        _charge_case_params("path"),
        _CHARGE,
    ),
    _pipeline_case(
        "pipeline_frames_window",
        "Eq. 13–15 on window charges, warp=\"composed\" with one sample per window, smoothed flow frames and the "
        "SURE guard (not in the paper; the package's defaults but for the alignment parameters)",
        "spikeref.pipeline.Reconstructor (ReconstructParams(accumulate=\"charge\", warp=\"composed\", "
        "resample=\"window\", flow_frames=\"smoothed\"), Denoiser(guard=\"sure\"))",
        "spikeref.oracles.pipeline.reconstruct_oracle (accumulate=\"charge\", warp=\"composed\", "
        "resample=\"window\", flow_frames=\"smoothed\", guard=\"sure\")",
        "pipeline_frames_charge with I_L sampling each of the 7 windows once, at the mean of the composed "
        "positions of its paths inside the plane, weighted by their number (spikeref.compose, "
        "resample=\"window\"). Output: R_L (rgb) of frames 3 and 4 (the flows are pipeline_frames_charge's). "
        "The oracle computes in float64; its outputs are stored as float32.",
        _charge_case_params("window"),
        _WINDOW,
    ),
)
