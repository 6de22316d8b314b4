"""The stage ladder: what each stage of the method gains, from one noisy window up to the physical limit.

For a scene with known motion and one setting ``W, K, L`` the ladder makes the same output
frames (the frame whose window is centred on each scored instant, as :mod:`spikeref.bench.runner`)
in every way below, from the bottom up, and scores each against the exact ground truth of the
10-plane window at that instant (PSNR and SSIM with the reference's maximum as data range,
linear RGB after Ψ, as ``spikeref bench``):

=====================  ==============================================================================
rung                   what it is
=====================  ==============================================================================
``tfp``                TFP over the ``W`` planes of the window: Eq. 4, then Ψ
``bm3d``, ``nlm``      the classical peer a user would run on that one window instead: BM3D / non-local
                       means on each Bayer plane of Eq. 4's rates, σ estimated blind (the ``peers`` extra)
``net``                our denoiser on that one window: ``Ψ[D(I_0)]`` (the method at ``L = 0``, on what
                       the method's windows give: the charge by default)
``tfp_support``        TFP over the whole support ``((K−1)L+1)·W`` planes, equal weights, no motion
``no_align``           the method with zero flow (plain accumulation with Eq. 14–15's weights, then D)
``no_denoiser``        the method with the identity for ``D`` (flows estimated on the raw frames)
``paper``              the paper's procedure exactly: Fig. 3(b) on Eq. 4's counts with Eq. 14–15 step by
                       step, the plain alignment, the count network's ``D(I)`` without guard or shrinkage
``ours``               the method as this package runs it by default (:class:`~spikeref.pipeline.ReconstructParams`)
``true_flow``          the support warped by the scene's exact motion: every window's Bayer planes (of
                       what the method's windows give) resampled once (cubic) onto the reference window,
                       weighted by Eq. 14–15's binomial weights, no denoiser — what perfect alignment
                       would give
``true_flow_d``        the same, then our denoiser (told the exposure of ``I_L``, and as the pipeline
                       does for charges, the reference window for its noise)
``true_flow_bm3d``     the same, then BM3D on each Bayer plane (σ estimated blind): the classical peer
                       after a perfect merge
``true_flow_clean``    the same warp and weights on the *noise-free* windows (the exact ground truth of
                       each window's ``W`` planes, mosaicked): between it and ``true_flow`` is the noise left
                       after the merge; between it and ``limit``, what resampling half-resolution Bayer
                       planes costs, and where a layer occludes another, the warp's error there (the
                       exact flow carries no occlusion)
``true_flow_support``  the adaptive merge's whole support (``ReconstructParams.support`` windows each side, as
                       far as the recording goes) warped by the exact motion, each window's sample kept only
                       where the exact motion says the point is visible in it, equal weights, no denoiser:
                       what a perfect alignment and a perfect robustness test would merge: the
                       ceiling of the adaptive merge through Ψ before its denoiser (a denoiser after it can
                       pass it where much noise is left, as in low light, and the multi-frame demosaic,
                       which reads the windows' raw samples instead of Ψ, passes it on moving scenes)
``limit``              the noise-free ground-truth mosaic through Ψ: no method that ends in Ψ passes it
``ours_mhc``,          beyond Ψ: ours and the limit with the Malvar–He–Cutler demosaic instead of Ψ for
``limit_mhc``          the output (:mod:`spikeref.demosaic`, ``ReconstructParams(demosaic="mhc")``)
``ours_count``         ours on Eq. 4's counts (``ReconstructParams(accumulate="count")``) with the bundled
                       count network ``b2u_w16``: what the window charge (the default) buys
=====================  ==============================================================================

Without a denoiser given, the method's rungs load the bundled network for what their windows
give (:func:`spikeref.denoise.denoiser.bundled_weights`); a denoiser given is used for every rung.

The true-flow rungs need a motion model (:meth:`SceneContent.true_flow`); a scene without one (a user's
video) shows them empty.  For the method's own flows the ladder also reports the **end-point error**
per step ``l``: the mean over pixels (an 8-pixel border left out, occluded pixels left out) of
``|F_l(k, k+i) − F_true(k, k+i)|`` in plane pixels, averaged over ``i`` and the scored frames,
with the true flow between the centres of windows ``k`` and ``k+i`` at the 2×2 cell centres.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["RUNGS", "RUNG_LABELS", "OPTION_RUNGS", "PEER_RUNGS", "TRUE_FLOW_RUNGS", "GHOST_RUNGS", "NOISE_FREE_RUNGS",
           "RECONSTRUCTOR_RUNGS", "BENCH_DARK_PLANES", "LadderSetting",
           "binomial_weights", "has_true_flow", "clean_window_counts", "motion_edge_band", "band_psnr",
           "true_flow_frame", "psi", "psnr_score", "run_ladder", "ladder_markdown", "plot_ladder"]

#: The rungs, bottom to top.
RUNGS = ("tfp", "bm3d", "nlm", "net", "tfp_support", "no_align", "no_denoiser", "paper", "ours", "true_flow",
         "true_flow_d", "true_flow_bm3d", "true_flow_support", "true_flow_clean", "limit", "ours_mhc", "limit_mhc",
         "ours_count", "ours_binomial", "ours_robust", "ours_adaptive")
RUNG_LABELS = {
    "tfp": "TFP(W)", "bm3d": "BM3D on W", "nlm": "NLM on W", "net": "D on W", "tfp_support": "TFP(support)",
    "no_align": "no alignment", "no_denoiser": "no denoiser", "paper": "paper's Fig. 3(b)", "ours": "ours",
    "true_flow": "true flow",
    "true_flow_d": "true flow + D", "true_flow_bm3d": "true flow + BM3D",
    "true_flow_clean": "true flow (noise-free)", "true_flow_support": "true flow, ±support, visible",
    "limit": "limit (Ψ of truth)", "ours_mhc": "ours, MHC demosaic",
    "limit_mhc": "limit, MHC demosaic", "ours_count": "ours, Eq. 4 count",
    "ours_binomial": "ours, Eq. 14–15 merge", "ours_robust": "ours, robust merge",
    "ours_adaptive": "ours, adaptive support",
}
#: Columns that are options beside the ladder (another demosaic, Eq. 4's counts), not rungs of it.
OPTION_RUNGS = ("ours_mhc", "limit_mhc", "ours_count", "ours_binomial", "ours_robust", "ours_adaptive")
#: The rungs whose PSNR in the motion-edge band the Markdown shows beside the interior's (ghosts).
GHOST_RUNGS = ("no_align", "ours_binomial", "ours_robust", "ours", "true_flow")
#: The rungs that need a classical peer (its package), by peer.
PEER_RUNGS = {"bm3d": ("bm3d", "true_flow_bm3d"), "nlm": ("nlm",)}
#: Rungs made from the noise-free scene: no dark level to subtract.
NOISE_FREE_RUNGS = ("limit", "limit_mhc", "true_flow_clean")
#: Rungs made by :class:`~spikeref.pipeline.Reconstructor` (which subtracts a dark level itself).
RECONSTRUCTOR_RUNGS = ("paper", "ours", "ours_mhc", "ours_count", "ours_binomial", "ours_robust", "ours_adaptive",
                       "no_align", "no_denoiser")
#: The rungs made by warping with the scene's exact motion.
TRUE_FLOW_RUNGS = ("true_flow", "true_flow_d", "true_flow_bm3d", "true_flow_clean", "true_flow_support")
#: Readouts of the dark recording a calibrated ladder simulates per scene (0.2 s at 20 kHz: each phase's level to
#: about 0.6 % at the bench's dark current).
BENCH_DARK_PLANES = 4000
#: Border left out of the end-point error, full-resolution pixels.
EPE_BORDER = 8
#: Plane pixels the motion-edge band reaches beyond the edge (:func:`motion_edge_band`).
EDGE_BAND_RADIUS = 2


@dataclass(frozen=True)
class LadderSetting:
    """``W, K, L`` of the method on the ladder (the paper's 10/3/3 by default)."""

    window: int = 10
    K: int = 3
    L: int = 3

    @property
    def name(self) -> str:
        return f"W={self.window} K={self.K} L={self.L}"


def binomial_weights(K: int, L: int) -> np.ndarray:
    """Weight of each window of the support in ``I_L`` (Eq. 14 then ``L − 1`` times Eq. 15), summing to 1.

    ``I_1`` weighs ``K`` windows equally; each Eq. 15 step convolves the weights with ``K`` equal
    weights, so ``I_L`` weighs window ``j`` of the ``(K−1)L+1`` by the ``L``-fold convolution.
    """
    c = np.ones(1)
    for _ in range(max(L, 0) if K > 1 else 0):
        c = np.convolve(c, np.ones(K))
    return c / c.sum()


def has_true_flow(content) -> bool:
    """Whether a scene's content has a motion model (a user's video has none: no true-flow rungs)."""
    return content.true_flow(0.0, 0.0, np.zeros((1, 2))) is not None


def clean_window_counts(scene, cfa: str, window: int, start: int, count: int) -> np.ndarray:
    """The noise-free windows ``start, start + W, …`` (``count`` of them): each window's exact ground truth (its own
    ``W`` planes) mosaicked by Eq. 3, as Bayer planes in counts like the windows, ``(count, 4, h, w) float32``."""
    from spikeref.bayer import bayer_planes
    from spikeref.simulate.camera import mosaic_radiance
    from spikeref.simulate.simulator import ground_truth

    truths = ground_truth(scene, window, planes=start + count * window, start=start)
    return bayer_planes(mosaic_radiance(truths, cfa).astype(np.float32), cfa) * np.float32(window)


def true_flow_frame(counts: np.ndarray, content, window: int, first_plane: int, ref_index: int,
                    weights: np.ndarray, cfa_offsets=((0, 0), (0, 1), (1, 0), (1, 1)),
                    visible_only: bool = False) -> np.ndarray:
    """``I`` of the support warped by the exact motion: ``(4, h, w) float32`` rates.

    Parameters
    ----------
    counts : ndarray ``(n, 4, h, w)``
        Window counts (or charges, :mod:`spikeref.charge`) of the support's ``n`` windows (Bayer planes).
    content : SceneContent
        Gives the exact flow (:func:`spikeref.simulate.motion.plane_flow`).
    window : int
        ``W``.
    first_plane : int
        Plane index (in the scene's time) of the first window's first plane.
    ref_index : int
        Which of the ``n`` windows is the reference.
    weights : ndarray ``(n,)``
        Weight of each window (:func:`binomial_weights`).
    visible_only : bool
        Keep a window's sample only where the exact motion says the point is visible in that window
        (:func:`~spikeref.simulate.motion.plane_flow`'s ``visible``: not occluded, inside the view); default
        False (every sample inside the plane, as Eq. 14–15 would take it).

    Each plane of each window is resampled once, by cubic interpolation at ``x + F(x)`` with the
    exact backward flow from the reference window's centre to that window's centre, evaluated
    at that plane's own pixel positions; samples outside the plane are dropped and the weights
    renormalised per pixel.
    """
    from scipy.ndimage import map_coordinates

    from spikeref.simulate.motion import plane_flow

    n, _, h, w = counts.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    t_ref = first_plane + (ref_index + 0.5) * window
    acc = np.zeros((4, h, w))
    wsum = np.zeros((4, h, w))
    for j in range(n):
        t_j = first_plane + (j + 0.5) * window
        for p, off in enumerate(cfa_offsets):
            rates = counts[j, p].astype(np.float64) / window
            if j == ref_index:
                acc[p] += weights[j] * rates
                wsum[p] += weights[j]
                continue
            flow, visible = plane_flow(content, t_ref, t_j, offset=off)
            sy, sx = yy + flow[0], xx + flow[1]
            inside = (sy >= -0.5) & (sy <= h - 0.5) & (sx >= -0.5) & (sx <= w - 0.5)
            if visible_only and visible is not None:
                inside &= visible
            sample = map_coordinates(rates, [sy, sx], order=3, mode="mirror")
            acc[p] += np.where(inside, weights[j] * sample, 0.0)
            wsum[p] += np.where(inside, weights[j], 0.0)
    return (acc / np.maximum(wsum, 1e-12)).astype(np.float32)


def psi(planes, cfa: str) -> np.ndarray:
    """``Ψ`` of four Bayer planes ``(..., 4, h, w)``: the mosaic, then the bilinear demosaic (float32 RGB)."""
    from spikeref.bayer import bayer_mosaic, demosaic_bilinear

    return demosaic_bilinear(bayer_mosaic(np.asarray(planes, dtype=np.float32), cfa), cfa)


def psnr_score(reference: np.ndarray, image: np.ndarray) -> float:
    """The ladder's PSNR: linear RGB against ``reference``, the reference's peak as the data range."""
    from spikeref.metrics import psnr

    return psnr(reference, np.asarray(image, dtype=np.float64), float(reference.max()))


def _score(reference: np.ndarray, image: np.ndarray) -> dict:
    from spikeref.metrics import ssim

    return {"psnr": psnr_score(reference, image),
            "ssim": ssim(reference, np.asarray(image, dtype=np.float64), float(reference.max()))}


def motion_edge_band(content, t_ref: float, window: int, radius: int = EDGE_BAND_RADIUS) -> np.ndarray | None:
    """Where the scene's motion has an edge at ``t_ref``: ``(H, W)`` bool at image resolution, or None without a
    motion model.

    A Bayer-plane pixel is on a motion edge when, between ``t_ref`` and the windows one before and one after it
    (``t_ref ± window``), its content is hidden or leaves the view (an occlusion, a blade's leading or trailing
    edge), or the exact flow over its 3 × 3 neighbourhood spans more than half a plane pixel (a discontinuity of
    the motion); the band is those pixels dilated by ``radius`` plane pixels (a square), each covering its 2 × 2
    image pixels.  What a merge averages across such an edge — a ghost — lands in the band; the rest of the frame
    is the interior.
    """
    from scipy.ndimage import binary_dilation, maximum_filter, minimum_filter

    from spikeref.simulate.motion import plane_flow

    edge = None
    for t_other in (t_ref - window, t_ref + window):
        flow, visible = plane_flow(content, t_ref, t_other)
        if flow is None:
            return None
        spread = np.max([maximum_filter(f, size=3, mode="nearest") - minimum_filter(f, size=3, mode="nearest")
                         for f in flow], axis=0)
        here = ~visible | (spread > 0.5)
        edge = here if edge is None else edge | here
    band = binary_dilation(edge, structure=np.ones((2 * radius + 1,) * 2, bool)) if radius else edge
    return np.repeat(np.repeat(band, 2, axis=0), 2, axis=1)


def band_psnr(reference: np.ndarray, image: np.ndarray, band: np.ndarray) -> float:
    """The ladder's PSNR over the pixels of ``band`` ``(H, W)`` only (all three colours; the reference's peak over
    the whole frame as the data range); NaN for an empty band."""
    if not band.any():
        return float("nan")
    err = (np.asarray(image, dtype=np.float64) - reference)[band]
    mse = float(np.mean(err * err))
    peak = float(reference.max())
    return float("inf") if mse == 0 else float(10 * np.log10(peak * peak / mse))


def _epe(est: np.ndarray, true: np.ndarray, visible: np.ndarray) -> float:
    b = EPE_BORDER // 2
    err = np.hypot(est[0] - true[0], est[1] - true[1])[b:-b, b:-b]
    vis = visible[b:-b, b:-b]
    return float(err[vis].mean()) if vis.any() else float("nan")


def _support_frame(view, content, params, k: int, offset: int, cfa: str) -> np.ndarray:
    """The ``true_flow_support`` rung of frame ``k``: windows ``k ± params.support`` (those the recording has) of
    what the method's windows give, warped by the exact motion where visible, equal weights, then Ψ."""
    from spikeref.accumulate import window_counts
    from spikeref.bayer import bayer_planes
    from spikeref.charge import window_charge

    w = params.window
    lo, hi = max(0, k - params.support), min(len(view) // w - 1, k + params.support)
    read = window_charge if params.accumulate == "charge" else window_counts
    planes = bayer_planes(np.asarray(read(view, w, start=lo * w, count=hi - lo + 1), dtype=np.float32), cfa)
    est = true_flow_frame(planes, content, w, offset + lo * w, k - lo, np.ones(hi - lo + 1), visible_only=True)
    return psi(est, cfa)


def _frames_for_scene(sc, setting: LadderSetting, centres: list[int], refs: list, denoisers: dict, peers: dict,
                      rungs, overrides: dict, dark_level=None) -> tuple:
    """Frames of every rung at the centres, seconds per frame of the single-window ones, and EPE per step.

    ``denoisers`` maps what a window gives (``"count"``, ``"charge"``) to the denoiser run on it.  ``dark_level``
    ``(4,)``, if given, is subtracted from every rung's frames but the noise-free ones (:data:`NOISE_FREE_RUNGS`):
    by the :class:`~spikeref.pipeline.Reconstructor` in the method's rungs, after the frame in the others.
    """
    from spikeref.accumulate import window_counts
    from spikeref.charge import window_charge
    from spikeref.bayer import bayer_planes, demosaic_bilinear
    from spikeref.pipeline import ReconstructParams, Reconstructor, exposure_planes
    from spikeref.simulate.camera import mosaic_radiance
    from spikeref.simulate.motion import plane_flow

    stream, cfa = sc.stream, sc.stream.cfa
    w, K, L = setting.window, setting.K, setting.L
    half = (K - 1) // 2
    reach = L * half
    offset = (centres[0] - w // 2) % w
    view = stream.slice(offset)
    ks = [(t - w // 2 - offset) // w for t in centres]

    out = {r: [] for r in rungs}
    secs = {r: [] for r in rungs}
    epe: dict[int, list] = {}
    weights = binomial_weights(K, L)
    base = ReconstructParams(window=w, K=K, L=L, **overrides)
    acc = base.accumulate
    denoiser = denoisers[acc]  # the method's
    has_motion = has_true_flow(sc.scene.content)
    for k, truth in zip(ks, refs, strict=True):
        first = k - reach
        counts = window_counts(view, w, start=first * w, count=2 * reach + 1).astype(np.float32)
        planes = bayer_planes(counts, cfa)  # (n, 4, h, w)
        i0 = planes[reach] / np.float32(w)
        if acc == "charge":  # what the method's windows give (a charge reads up to 200 readouts around)
            method_planes = bayer_planes(window_charge(view, w, start=first * w, count=2 * reach + 1), cfa)
        else:
            method_planes = planes
        m0 = method_planes[reach] / np.float32(w)
        more = {"accumulate": acc} if acc == "charge" else {}
        if "tfp" in rungs:
            out["tfp"].append(psi(i0, cfa))
        for name, peer in peers.items():
            if name in rungs:
                t0 = time.perf_counter()
                out[name].append(psi(peer(i0, window=w), cfa))
                secs[name].append(time.perf_counter() - t0)
        if "net" in rungs:
            t0 = time.perf_counter()
            out["net"].append(psi(denoiser(m0, "visible", window=w, **more), cfa))
            secs["net"].append(time.perf_counter() - t0)
        if "tfp_support" in rungs:
            out["tfp_support"].append(psi(planes.sum(axis=0) / np.float32(w * len(planes)), cfa))
        if any(r in rungs for r in TRUE_FLOW_RUNGS):
            if not has_motion:
                for r in TRUE_FLOW_RUNGS:
                    if r in rungs:
                        out[r].append(None)
            else:
                start = offset + first * w
                if "true_flow_clean" in rungs:
                    clean = clean_window_counts(sc.scene, cfa, w, start, 2 * reach + 1)
                    out["true_flow_clean"].append(psi(true_flow_frame(clean, sc.scene.content, w, start, reach,
                                                                      weights), cfa))
                if any(r in rungs for r in TRUE_FLOW_RUNGS if r != "true_flow_clean"):
                    tf = true_flow_frame(method_planes, sc.scene.content, w, start, reach, weights)
                if "true_flow_bm3d" in rungs:
                    out["true_flow_bm3d"].append(psi(peers["bm3d"](tf, window=exposure_planes(w, K, L)), cfa))
                if "true_flow" in rungs:
                    out["true_flow"].append(psi(tf, cfa))
                if "true_flow_d" in rungs:
                    if acc == "charge" and L > 0:  # the output guard's noise from the reference window, as the pipeline
                        more_d = {**more, "short": m0, "short_window": w}
                    else:
                        more_d = more
                    d_tf = denoiser(tf, "visible", window=exposure_planes(w, K, L), **more_d)
                    out["true_flow_d"].append(psi(d_tf, cfa))
        if "true_flow_support" in rungs:
            out["true_flow_support"].append(
                _support_frame(view, sc.scene.content, base, k, offset, cfa) if has_motion else None)
        if "limit" in rungs or "limit_mhc" in rungs:
            from spikeref.demosaic import demosaic_mhc

            mosaic = mosaic_radiance(truth, cfa).astype(np.float32)  # the noise-free Bayer mosaic (Eq. 3)
            if "limit" in rungs:
                out["limit"].append(demosaic_bilinear(mosaic, cfa))
            if "limit_mhc" in rungs:
                out["limit_mhc"].append(demosaic_mhc(mosaic, cfa))

    def run(params, den, keep):
        rec = Reconstructor(view, params, den, dark_level=dark_level)
        got, flows = [], []
        wanted = set(ks)
        for frame in rec.frames(ks[0], ks[-1] + 1, keep_steps=keep):
            if frame.index in wanted:
                got.append(frame.rgb)
                flows.append(frame.flows)
        return got, flows

    if "paper" in rungs:
        from spikeref.denoise.denoiser import Denoiser

        count_den = denoisers["count"]
        paper_den = Denoiser(count_den.unet, guard="off", shrink=False) if isinstance(count_den, Denoiser) \
            else count_den
        paper = ReconstructParams.paper(window=w, K=K, L=L)
        out["paper"] = run(paper, paper_den, False)[0]
    if "ours" in rungs:
        frames, flows = run(base, denoiser, True)
        out["ours"] = frames
        for k, fl in zip(ks, flows, strict=True):
            for (level, i), f in fl.items():
                t_ref = offset + (k + 0.5) * w
                true, vis = plane_flow(sc.scene.content, t_ref, t_ref + i * w)
                if true is not None:
                    epe.setdefault(level, []).append(_epe(f, true, vis))
    if "ours_mhc" in rungs:
        out["ours_mhc"] = run(replace(base, demosaic="mhc"), denoiser, False)[0]
    if "ours_count" in rungs:
        out["ours_count"] = run(replace(base, accumulate="count"), denoisers["count"], False)[0]
    for merge in ("binomial", "robust", "adaptive"):  # Eq. 14–15's weights; spikeref.merge's at their support, grown
        if f"ours_{merge}" in rungs:
            out[f"ours_{merge}"] = run(replace(base, merge=merge), denoiser, False)[0]
    if "no_align" in rungs:
        out["no_align"] = run(replace(base, align=False), denoiser, False)[0]
    if "no_denoiser" in rungs:
        out["no_denoiser"] = run(base, lambda p: p, False)[0]
    if dark_level is not None:
        from spikeref.dark_level import subtract_dark_level

        for r in rungs:
            if r not in NOISE_FREE_RUNGS and r not in RECONSTRUCTOR_RUNGS:
                out[r] = [None if f is None else subtract_dark_level(f, dark_level, cfa) for f in out[r]]
    return out, secs, {lv: float(np.mean(v)) for lv, v in sorted(epe.items())}


def run_ladder(scenes, settings=(LadderSetting(),), seed: int = 0, denoiser=None, frames: int = 4,
               peers=("bm3d", "nlm"), rungs=RUNGS, progress: bool = True, log=None,
               params: dict | None = None, dark_calibration: bool = False) -> dict:
    """Run the ladder on ``scenes`` (:class:`~spikeref.bench.runner.BenchScene`) for each setting.

    Parameters
    ----------
    scenes : list of BenchScene
    settings : sequence of LadderSetting
    seed : int
        Simulation seed.
    denoiser : Denoiser or callable, optional
        Used for every rung that denoises; default: the bundled network for what each rung's
        windows give (:func:`~spikeref.denoise.denoiser.bundled_weights`).
    frames : int
        Scored frames per scene (:func:`~spikeref.bench.runner.score_centres`).
    peers : sequence of str
        Classical peers to run (``bm3d``, ``nlm``); a peer whose package is missing, or not given, is
        left out with its rungs (:data:`PEER_RUNGS`: without BM3D also ``true_flow_bm3d``), with a note
        in ``result["notes"]`` when its package is missing.
    rungs : sequence of str
        Which rungs to run (default all, :data:`RUNGS`).
    params : dict, optional
        Fields of :class:`~spikeref.pipeline.ReconstructParams` that replace the defaults in the
        method's rungs (``ours``, ``no_align``, ``no_denoiser``) and ``true_flow_support``'s ``support`` — for
        studies; the ``paper``
        rung always runs the paper's procedure.
    dark_calibration : bool
        Calibrate each scene's sensor as a user would (:meth:`~spikeref.bench.runner.BenchScene.dark_calibration`:
        a dark recording of :data:`BENCH_DARK_PLANES` readouts, the same sensor with the lens covered and other
        noise draws) and subtract its dark level from every rung's frames but the noise-free ones.  Default off:
        the frames are ``E[I_c]`` (Eq. 9), as without a calibration.

    Returns
    -------
    dict
        ``rows``: one per scene × setting × rung (``psnr``, ``ssim``, ``seconds_per_frame`` for the
        single-window denoisers, NaN where not run); ``epe``: one per scene × setting × step;
        ``notes``: what was left out and why; ``dark_levels``: each scene's calibrated level (with
        ``dark_calibration``, else empty).
    """
    from tqdm import tqdm

    from spikeref.bench.runner import score_centres
    from spikeref.charge import ACCUMULATE
    from spikeref.denoise.denoiser import Denoiser, bundled_weights

    unknown = [r for r in rungs if r not in RUNGS]
    if unknown:
        raise ValueError(f"unknown rung {', '.join(unknown)}; allowed: {', '.join(RUNGS)}")
    if denoiser is None:
        denoisers = {acc: Denoiser.load(bundled_weights(acc)) for acc in ACCUMULATE}
    else:
        denoisers = dict.fromkeys(ACCUMULATE, denoiser)
    notes = []
    peer_fns = {}
    for name in peers:
        if not any(r in rungs for r in PEER_RUNGS.get(name, (name,))):
            continue
        try:
            from spikeref.denoise.peers import PeerDenoiser, peer_available
        except ImportError:  # pragma: no cover - the module ships with the package
            notes.append(f"{name}: spikeref.denoise.peers is missing")
            continue
        if not peer_available(name):
            notes.append(f"{name}: not installed (pip install \"spikeref[peers]\")")
            continue
        peer_fns[name] = PeerDenoiser(name)
    rungs = tuple(r for r in rungs if all(r not in need or name in peer_fns for name, need in PEER_RUNGS.items()))
    rows, epe_rows = [], []
    dark_levels = {}
    bar = tqdm(total=len(scenes) * len(settings), desc="ladder", unit="scene", disable=not progress)
    try:
        for sc in scenes:
            bar.set_postfix_str(f"{sc.key}: simulating")
            sc.simulate(seed)
            dark = sc.dark_calibration(seed, BENCH_DARK_PLANES)["dark_level"] if dark_calibration else None
            if dark is not None:
                dark_levels[sc.key] = [float(v) for v in dark]
            centres = score_centres(len(sc.stream), frames)
            refs = [sc.reference(t) for t in centres]
            for setting in settings:
                bar.set_postfix_str(f"{sc.key}: {setting.name}")
                out, secs, epe = _frames_for_scene(sc, setting, centres, refs, denoisers, peer_fns, rungs,
                                                   dict(params or {}), dark)
                bands = [motion_edge_band(sc.scene.content, t, setting.window) for t in centres]
                bands = None if any(b is None for b in bands) else bands
                for r in rungs:
                    imgs = out[r]
                    if not imgs or any(i is None for i in imgs):
                        scores = {"psnr": float("nan"), "ssim": float("nan"), "psnr_edge": float("nan"),
                                  "psnr_interior": float("nan")}
                    else:
                        each = [_score(ref, img) for ref, img in zip(refs, imgs, strict=True)]
                        scores = {m: float(np.mean([e[m] for e in each])) for m in ("psnr", "ssim")}
                        for key, inside in (("psnr_edge", True), ("psnr_interior", False)):
                            scores[key] = float("nan") if bands is None else float(np.mean(
                                [band_psnr(ref, img, band if inside else ~band)
                                 for ref, img, band in zip(refs, imgs, bands, strict=True)]))
                    row = {"scene": sc.key, "setting": setting.name, "W": setting.window, "K": setting.K,
                           "L": setting.L, "rung": r, **scores,
                           "seconds_per_frame": float(np.median(secs[r])) if secs[r] else float("nan")}
                    rows.append(row)
                    if log is not None:
                        log(row)
                for level, e in epe.items():
                    epe_rows.append({"scene": sc.key, "setting": setting.name, "step": level, "epe": e})
                bar.update(1)
            sc.stream = None
    finally:
        bar.close()
    return {"rows": rows, "epe": epe_rows, "notes": notes, "rungs": rungs,
            "scenes": [s.key for s in scenes], "settings": [s.name for s in settings], "seed": seed,
            "dark_calibration": bool(dark_calibration), "dark_levels": dark_levels}


def _table(result: dict, setting: str, metric: str) -> tuple[list[str], dict]:
    rows = [r for r in result["rows"] if r["setting"] == setting]
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    grid = {(r["scene"], r["rung"]): r[metric] for r in rows}
    return scenes, grid


def ladder_markdown(result: dict) -> str:
    """The ladder as Markdown: PSNR per scene and rung, the mean, gains over the rung below, EPE per step."""
    lines = []
    rungs = result["rungs"]
    if result.get("dark_calibration"):
        lines.append("Dark level calibrated: each scene's sensor on its own dark recording, the level taken off every "
                     "rung but the noise-free ones (`dark_calibration=True`).\n")
    for setting in result["settings"]:
        scenes, grid = _table(result, setting, "psnr")
        lines.append(f"### Stage ladder, {setting} — PSNR (dB)\n")
        lines.append("| scene | " + " | ".join(RUNG_LABELS[r] for r in rungs) + " |")
        lines.append("|---|" + "---:|" * len(rungs))

        def fmt(v):
            return "—" if v is None or not np.isfinite(v) else f"{v:.2f}"

        for s in scenes:
            lines.append(f"| {s} | " + " | ".join(fmt(grid.get((s, r))) for r in rungs) + " |")
        # means over the scenes that have every rung (true flow needs a motion model)
        full = [s for s in scenes if all(np.isfinite(grid.get((s, r), np.nan)) for r in rungs)]
        if full:
            means = {r: float(np.mean([grid[(s, r)] for s in full])) for r in rungs}
            lines.append(f"| **mean of {len(full)}** | " + " | ".join(f"**{means[r]:.2f}**" for r in rungs) + " |")
        secs = {r["rung"]: r["seconds_per_frame"] for r in result["rows"]
                if r["setting"] == setting and np.isfinite(r["seconds_per_frame"])}
        if secs:
            per = {}
            for r in result["rows"]:
                if r["setting"] == setting and np.isfinite(r["seconds_per_frame"]):
                    per.setdefault(r["rung"], []).append(r["seconds_per_frame"])
            lines.append("\nSeconds per frame of the single-window denoisers (median over frames, mean over scenes): "
                         + ", ".join(f"{RUNG_LABELS[k]} {np.mean(v):.3f}" for k, v in per.items()) + ".")
        ghost = [r for r in GHOST_RUNGS if r in rungs]
        edge_rows = [r for r in result["rows"] if r["setting"] == setting and r["rung"] in ghost
                     and np.isfinite(r.get("psnr_edge", np.nan))]
        if edge_rows:
            lines.append(f"\nGhosts: PSNR in the motion-edge band (occlusions and motion discontinuities within one "
                         f"window, {EDGE_BAND_RADIUS} plane px wide; `motion_edge_band`) / in the interior, "
                         f"{setting}:\n")
            lines.append("| scene | " + " | ".join(RUNG_LABELS[r] for r in ghost) + " |")
            lines.append("|---|" + "---:|" * len(ghost))
            cell = {(r["scene"], r["rung"]): f"{r['psnr_edge']:.2f} / {r['psnr_interior']:.2f}" for r in edge_rows}
            for s in dict.fromkeys(r["scene"] for r in edge_rows):
                lines.append(f"| {s} | " + " | ".join(cell.get((s, g), "—") for g in ghost) + " |")
        epe = [e for e in result["epe"] if e["setting"] == setting]
        if epe:
            steps = sorted({e["step"] for e in epe})
            lines.append(f"\nFlow end-point error of ours against the true flow (plane px), {setting}:\n")
            lines.append("| scene | " + " | ".join(f"step {s}" for s in steps) + " |")
            lines.append("|---|" + "---:|" * len(steps))
            for s in dict.fromkeys(e["scene"] for e in epe):
                vals = {e["step"]: e["epe"] for e in epe if e["scene"] == s}
                lines.append(f"| {s} | " + " | ".join(fmt(vals.get(st)) for st in steps) + " |")
        lines.append("")
    for note in result.get("notes", []):
        lines.append(f"- left out: {note}")
    return "\n".join(lines) + "\n"


def plot_ladder(result: dict, path, setting: str | None = None) -> bool:
    """Draw the ladder (PSNR per rung, one line per scene, the mean in bold); False without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    setting = result["settings"][0] if setting is None else setting
    rungs = result["rungs"]
    scenes, grid = _table(result, setting, "psnr")
    fig, ax = plt.subplots(figsize=(12, 5.2))
    # the ladder's rungs, then (after a gap) the options that are not rungs of it: each part drawn on its own
    parts = [[r for r in rungs if r not in OPTION_RUNGS], [r for r in rungs if r in OPTION_RUNGS]]
    rungs = parts[0] + parts[1]
    x = np.concatenate([np.arange(len(parts[0])), len(parts[0]) + 0.6 + np.arange(len(parts[1]))])
    lines = {s: np.array([grid.get((s, r), np.nan) for r in rungs], dtype=float) for s in scenes}
    full = [y for y in lines.values() if np.all(np.isfinite(y))]
    mean = np.mean(full, axis=0) if full else None
    finite = np.concatenate([y[np.isfinite(y)] for y in lines.values()] or [np.zeros(1)])
    # a scene far below the others (low light: ~10 dB) would squash the rest: keep 8 dB under the mean
    bottom = max(float(finite.min()), float(np.nanmin(mean)) - 8.0) - 0.5 if mean is not None else None
    cut = len(parts[0])
    for s, y in lines.items():
        off = bottom is not None and np.nanmin(y) < bottom
        line, = ax.plot(x[:cut], y[:cut], marker="o", lw=1, alpha=0.6,
                        label=s + (" (partly below the axis)" if off else ""))
        ax.plot(x[cut:], y[cut:], marker="o", lw=1, alpha=0.6, color=line.get_color())
    if mean is not None:
        ax.plot(x[:cut], mean[:cut], marker="s", lw=3, color="k", label=f"mean of {len(full)} (scenes with every rung)")
        ax.plot(x[cut:], mean[cut:], marker="s", lw=3, color="k")
        ax.set_ylim(bottom, float(finite.max()) + 1.0)
    if parts[1]:
        ax.axvline(cut - 0.2, color="0.4", ls="--", lw=1)
        ax.text(cut, 0.98, "options beside the ladder", transform=ax.get_xaxis_transform(), va="top", ha="left",
                fontsize=8, color="0.3")
    ax.set_xticks(x)
    ax.set_xticklabels([RUNG_LABELS[r] for r in rungs], rotation=35, ha="right")
    ax.set_ylabel("PSNR (dB), linear RGB against the exact ground truth")
    ax.set_title(f"Stage ladder, {setting}: what each stage buys, up to the limit")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True
