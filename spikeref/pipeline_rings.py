"""The per-step rings of one streamed pass of :mod:`spikeref.pipeline` over increasing frame numbers.

Each ``I_l(k)`` (Eq. 4 at step 0, Eq. 14 at step 1, Eq. 15 beyond; §4.2), its denoised ``D(I_l(k))``, the
image its flow is estimated on and the flows ``F_{l−1}(k, ·)`` that made it are computed once, when a frame
first needs them, and kept in the ring of step ``l`` until no later frame does (:meth:`FrameRings.evict`):
the ``2(L − l)h + 1`` windows of the module docstring of :mod:`spikeref.pipeline`.  The output frame
``R_L(k) = Ψ[D(I_L(k))]`` is :meth:`FrameRings.output`.  With ``warp="composed"`` or ``"chained"``,
``I_L(k)`` is made from the spike windows of the support in one resample (:mod:`spikeref.compose`) and
merged as ``ReconstructParams.merge_used`` says (:mod:`spikeref.merge`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.ndimage import gaussian_filter

from spikeref import pipeline_params
from spikeref.accumulate import window_counts
from spikeref.align import align
from spikeref.align_noise import estimate_noise, estimate_noise_correlation, local_noise
from spikeref.bayer import bayer_mosaic, bayer_planes, luma
from spikeref.charge import WINDOWS_PER_CALL, window_charge
from spikeref.compose import chained_samples, composed_samples, composed_warp, path_table
from spikeref.demosaic import demosaic
from spikeref.merge import MergeParams, default_shells, robust_merge
from spikeref.multiframe_demosaic import multiframe_frame
from spikeref.pipeline_params import FLOW_SMOOTHING_SIGMA, ReconstructParams, exposure_planes
from spikeref.stream import SpikeStream
from spikeref.warp import warp_average, warp_bilinear, warp_spike_windows

__all__ = ["FrameRings", "ReconstructedFrame", "flow_luma"]


@dataclass
class ReconstructedFrame:
    """One output frame and, on request, what led to it.

    Attributes
    ----------
    index : int
        Frame number = reference window (planes ``[index·W, (index+1)·W)``).
    rgb : ndarray ``(H, W, 3) float32``
        ``R_L``, linear, firing-rate units (spikes per readout); ``(H, W)`` for a mono stream.
    steps : list of ndarray
        With ``keep_steps``: ``R_l`` for ``l = 0 … L`` (Fig. 5); else empty.
    flows : dict
        With ``keep_steps``: ``{(l, i): F_l(k, k+i)}`` ``(2, h, w)`` float32 on the plane grid.
    exposure : ndarray ``(h, w) float32`` or None
        With ``merge="robust"`` or ``"adaptive"``: the pseudo-exposure of each pixel of the plane grid in planes,
        ``W`` times the effective number of windows merged there (:func:`spikeref.merge.robust_merge`); None
        with Eq. 14–15's merge (``27²/141 · W`` everywhere at 10/3/3).
    """

    index: int
    rgb: np.ndarray
    steps: list = field(default_factory=list)
    flows: dict = field(default_factory=dict)
    exposure: np.ndarray | None = None


def flow_luma(planes: np.ndarray, sigma: float = FLOW_SMOOTHING_SIGMA) -> np.ndarray:
    """The image ``flow_frames="smoothed"`` aligns: the 2×2 luma of ``I_l``, Gaussian-smoothed.

    Parameters
    ----------
    planes : ndarray ``(4, h, w)``, real
        Bayer planes of firing rates ``I_l`` (not denoised).
    sigma : float
        Standard deviation of the Gaussian, in Bayer-plane pixels (``≥ 0``; 0: no smoothing);
        the kernel is cut at 4σ and the border is mirrored half-sample symmetrically
        (``scipy.ndimage``'s ``reflect``).

    Returns
    -------
    ndarray ``(h, w) float32``
    """
    if not (np.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma must be a number of plane pixels ≥ 0; got {sigma!r}")
    y = luma(planes)
    if sigma == 0:
        return y
    return gaussian_filter(y.astype(np.float64), sigma, mode="reflect", truncate=4.0).astype(np.float32)


class FrameRings:
    """The per-step rings of one pass over increasing frame numbers (module docstring).

    Parameters
    ----------
    stream : SpikeStream
    params : ReconstructParams
        As :class:`spikeref.pipeline.Reconstructor` fitted them to the frame size.
    timed : callable
        ``timed(stage)``, a context manager adding the block's seconds to a stage
        (:meth:`spikeref.pipeline.Reconstructor.timed`).
    denoise : callable or None
        ``denoise(planes, exposure, final, short)`` → planes: ``D`` as the rings call it (the output's
        guard only where ``final``), or None where ``D`` is the identity (``params.denoise=False``).
    repair : HotPixelRepair or None
        Replaces the hot pixels of every window, or None.
    keep_flows : bool
        Keep every step's flows (for :attr:`ReconstructedFrame.flows`).
    """

    def __init__(self, stream: SpikeStream, params: ReconstructParams, timed: Callable, denoise: Callable | None,
                 repair=None, keep_flows: bool = False):
        self.timed = timed
        self.p = params
        self.stream = stream
        self.denoise = denoise
        self.repair = repair
        self.keep_flows = keep_flows
        # step l: {k: [I_l(k) planes, D(I_l(k)) planes or None, luma or None, F_{l-1}(k, ·) if kept,
        #               (raw luma, its local noise, its noise variance) of the noise-aware search or None]}
        self.rings: list[dict] = [dict() for _ in range(self.p.L + 1)]
        self.step0: dict[int, np.ndarray] = {}  # F_0(k, ·) of warp="chained" and of the adaptive support
        self.merge_windows: dict[int, np.ndarray] = {}  # the robust merge's effective windows per pixel, by frame
        self.multiframe: dict[int, tuple] = {}  # demosaic="multiframe": (windows' planes, positions, final weights)
        self.counts: dict[int, np.ndarray] = {}
        self.noise: dict[int, np.ndarray] = {}  # each window's local noise per plane (the robust merges' v)

    # step 0 -------------------------------------------------------------
    def window_counts(self, k: int) -> np.ndarray:
        """Window ``k``'s charge or count as Bayer planes ``(4, h, w)``, its hot pixels replaced (float32 then)."""
        if k not in self.counts:
            with self.timed("accumulate"):
                if self.p.accumulate == "charge":
                    self._charge_block(k)
                else:
                    c = window_counts(self.stream, self.p.window, start=k * self.p.window, count=1)[0]
                    self.stream.release(k * self.p.window, self.p.window)
                    self.counts[k] = self._repaired(bayer_planes(c))
        return self.counts[k]

    def _repaired(self, planes: np.ndarray) -> np.ndarray:
        """``planes`` with the hot pixels replaced (:class:`~spikeref.hot_pixels.HotPixelRepair`), or as they are."""
        repair = self.repair
        if repair is None:
            return planes
        return repair.planes(planes.astype(np.float32))  # counts become float32, as charges are

    def window_noise(self, k: int) -> np.ndarray:
        """The local noise of window ``k``'s rate per Bayer plane, ``(4, h, w)`` float64
        (:func:`spikeref.align_noise.local_noise`): one window's ``v`` in the robust merges, made once per window
        (the output's merge and each step below ``L`` read it)."""
        if k not in self.noise:
            rates = self.window_counts(k).astype(np.float64) / self.p.window
            self.noise[k] = np.stack([local_noise(plane) for plane in rates])
        return self.noise[k]

    def _charge_block(self, k: int) -> None:
        """The charges (:func:`spikeref.charge.window_charge`) of windows ``k …`` (up to
        :data:`~spikeref.charge.WINDOWS_PER_CALL` that fit), float32 Bayer planes; each window's value
        does not depend on the block."""
        w = self.p.window
        count = min(WINDOWS_PER_CALL, len(self.stream) // w - k)
        charge = window_charge(self.stream, w, start=k * w, count=count)
        for i in range(count):
            if k + i not in self.counts:
                self.counts[k + i] = self._repaired(bayer_planes(charge[i]))

    def planes(self, step: int, k: int) -> np.ndarray:
        """``I_l(k)`` ``(4, h, w) float32``."""
        ring = self.rings[step]
        if k not in ring:
            planes, flows = self._compute(step, k)
            keep = self.keep_flows or (self.p.warp == "composed" and step < self.p.L)
            ring[k] = [planes, None, None, flows if keep else None, None]
        return ring[k][0]

    def denoised(self, step: int, k: int) -> np.ndarray:
        entry = self.rings[step].get(k)
        if entry is None:
            self.planes(step, k)
            entry = self.rings[step][k]
        if entry[1] is None and not self.p.denoise:  # D is the identity
            entry[1] = entry[0]
        if entry[1] is None:
            with self.timed("guard"):  # the network's passes inside are timed apart
                exposure = exposure_planes(self.p.window, self.p.K, step)
                final = step == self.p.L
                windows = self.merge_windows.get(k) if final else None
                if windows is not None:  # the robust merge's frame: the median pixel's pseudo-exposure, in planes
                    exposure = float(np.median(windows)) * self.p.window
                # charges: the guard measures the noise on the reference window's own charge and carries it
                # to the exposure (spikeref.denoise.guard.carried_excess_variance), as denoise mode does
                short = self.planes(0, k) if final and step > 0 and self.p.accumulate == "charge" else None
                out = np.asarray(self.denoise(entry[0], exposure, final, short), dtype=np.float32)
            if out.shape != entry[0].shape:
                raise ValueError(f"the denoiser returned shape {out.shape} for planes {entry[0].shape}")
            if not np.all(np.isfinite(out)):
                raise ValueError(f"the denoiser returned non-finite values (NaN or inf) for window {k} at step "
                                 f"{step}")
            entry[1] = out
        return entry[1]

    def luma(self, step: int, k: int) -> np.ndarray:
        """The image the flow of step ``step`` is estimated on (``flow_frames``)."""
        entry = self.rings[step].get(k)
        if entry is None or entry[2] is None:
            if self.p.flow_frames == "smoothed":
                planes = self.planes(step, k)
                with self.timed("align"):
                    image = flow_luma(planes, pipeline_params.FLOW_SMOOTHING_SIGMA)  # the value at call time
            else:
                image = luma(self.denoised(step, k))
            self.rings[step][k][2] = image
        return self.rings[step][k][2]

    def flows(self, step: int, k: int) -> np.ndarray:
        """``F_l(k, k+i)`` for ``i = −h … h``: ``(K, 2, h, w)`` (zero for ``i = 0``)."""
        p, hh = self.p, self.p.half
        shape = self.window_counts(k).shape[1:]
        out = np.zeros((p.K, 2) + shape, np.float32)
        if not p.align or hh == 0:  # K = 1: no neighbour to align, so no denoising for flow either
            return out
        ref = self.luma(step, k)
        for j, i in enumerate(range(-hh, hh + 1)):
            if i:
                alt = self.luma(step, k + i)
                with self.timed("align"):
                    if p.align_params.prefer_centre > 0 or p.align_params.zero_test is not None:
                        out[j] = self.noise_aware_flow(ref, alt, step, k, k + i)
                    else:
                        out[j] = align(ref, alt, step=step, params=p.align_params)
        return out

    def noise_aware_flow(self, ref: np.ndarray, alt: np.ndarray, step: int, k: int, j: int) -> np.ndarray:
        """``align`` with the noise of ``I_l(k)`` and ``I_l(j)`` (``prefer_centre > 0`` or a ``zero_test``).

        The noise variance (:func:`spikeref.align_noise.local_noise`) and the correlation of the two
        frames' noise (:func:`spikeref.align_noise.estimate_noise_correlation`) are measured on the 2×2
        luma of the frames *before* denoising, whatever the flow is estimated on: a denoised or
        smoothed flow image hides its residual error from a high-pass estimate, and the
        anti-correlation of adjacent windows' counts is a property of the raw spikes.  The per-pixel
        zero-motion test (``AlignParams.zero_test``) compares those raw lumas too.
        """
        (r_raw, r_noise, r_var), (a_raw, a_noise, a_var) = self.raw_noise(step, k), self.raw_noise(step, j)
        rho = estimate_noise_correlation(r_raw, a_raw, noise=(r_var, a_var))  # each frame's own estimate made once
        return align(ref, alt, step=step, params=self.p.align_params, noise=0.5 * (r_noise + a_noise),
                     correlation=rho, raw=(r_raw, a_raw))

    def raw_noise(self, step: int, k: int) -> tuple[np.ndarray, np.ndarray, float]:
        """The 2×2 luma of ``I_l(k)`` before denoising, its local noise map and its global noise variance
        (:func:`spikeref.align_noise.estimate_noise`), made once per frame (each frame is aligned against up
        to ``2h`` others, as reference and as alternate)."""
        self.planes(step, k)
        entry = self.rings[step][k]
        if entry[4] is None:
            raw = luma(entry[0])
            entry[4] = (raw, local_noise(raw), estimate_noise(raw))
        return entry[4]

    def _compute(self, step: int, k: int) -> tuple[np.ndarray, np.ndarray | None]:
        """``I_l(k)`` and the flows ``F_{l−1}(k, ·)`` that made it."""
        p, hh = self.p, self.p.half
        if step == 0:
            return self.window_counts(k).astype(np.float32) / np.float32(p.window), None
        neighbours = range(k - hh, k + hh + 1)
        if step == p.L and p.warp == "chained" and p.align and hh:
            # the steps' own flows are not needed (only kept for keep_steps, which asks for them)
            return self._composed(k, None), (self.flows(step - 1, k) if self.keep_flows else None)
        fl = self.step0_flows(k) if step == 1 else self.flows(step - 1, k)  # F_0 once per window, shared
        if step == p.L and p.warp == "composed" and p.align and hh:
            return self._composed(k, fl), fl
        if p.merge_used != "binomial" and p.align and hh and step < p.L:  # robustly too, not Eq. 14–15's mean
            return self._robust_step(step, k, fl), fl
        if step == 1:  # Eq. 14: the spike planes of K windows
            counts = np.stack([self.window_counts(j) for j in neighbours])
            with self.timed("warp"):
                return warp_spike_windows(counts, fl, p.window), fl
        frames = np.stack([self.planes(step - 1, j) for j in neighbours])  # Eq. 15
        with self.timed("warp"):
            return warp_average(frames, fl), fl

    def _robust_step(self, step: int, k: int, flows: np.ndarray) -> np.ndarray:
        """``I_l(k)``, ``0 < l < L``, with the robust or adaptive merge: the ``K`` frames ``I_{l−1}(k + i)`` (window
        rates at ``l = 1``) warped onto ``I_{l−1}(k)`` as Eq. 14–15 sample them (:func:`spikeref.warp.warp_bilinear`,
        each its in-image weight) and merged by :func:`spikeref.merge.robust_merge` without shells, the reference at
        its own pixels, ``v`` the reference window's local noise (as the output's merge takes it) times
        ``W / e_{l−1}`` (:func:`~spikeref.pipeline_params.exposure_planes`: the frames' noise-equivalent exposure).
        Eq. 14–15's mean of the same frames ghosts where the flow is wrong (the blades of the embedded sample's
        fan), and the output's merge does not: without this the steps below ``L`` fell under ``R_0``."""
        p, hh = self.p, self.p.half
        frames = [self.planes(step - 1, j) for j in range(k - hh, k + hh + 1)]
        reference = frames[hh]
        samples = np.empty((p.K,) + reference.shape, np.float32)
        inside = np.empty((p.K,) + reference.shape[1:], np.float32)
        with self.timed("warp"):
            for j, frame in enumerate(frames):
                if j == hh:
                    samples[j], inside[j] = reference, 1.0
                else:
                    samples[j], inside[j] = warp_bilinear(frame, flows[j])
            # one window's noise (as the output's merge takes it) over the frames' noise-equivalent exposure
            scale = p.window / exposure_planes(p.window, p.K, step - 1)
            merged, _ = robust_merge(samples, inside, self.window_noise(k) * scale, hh, np.ones(p.K, bool),
                                     MergeParams(), check=False)
        return merged

    def step0_flows(self, k: int) -> np.ndarray:
        """``F_0(k, k+i)``, ``i = −h … h``, computed once per window (the steps, ``warp="chained"`` and the
        adaptive support share them)."""
        if k not in self.step0:
            self.step0[k] = self.flows(0, k)
        return self.step0[k]

    def composed_inputs(self, k: int, top: np.ndarray | None) -> tuple:
        """What :func:`spikeref.compose.composed_warp` needs for ``I_L(k)``: ``(counts, bank, hops, targets)``.

        ``counts`` are the support's windows ``k − L·h … k + L·h``; ``bank`` the step flows the
        paths use, each once; ``hops`` and ``targets`` the paths of :func:`path_table` as indices into
        ``bank`` and ``counts``.  ``top`` are the flows ``F_{L−1}(k, ·)``; the lower steps' flows
        ``F_m(j, ·)`` are those that made ``I_{m+1}(j)``, kept in the rings.  With
        ``warp="chained"`` every hop uses the step-0 flow of the window it starts from
        (:meth:`step0_flows`) and ``top`` is not used.
        """
        p, hh, L = self.p, self.p.half, self.p.L
        chained = p.warp == "chained"
        bank, index, hops, targets = [], {}, [], []
        first = k - L * hh
        for path in path_table(p.K, L):
            kk, row = k, []
            for m, i in zip(range(L - 1, -1, -1), path, strict=True):
                if i:
                    key = (0 if chained else m, kk, i)
                    if key not in index:
                        if chained:
                            flows = self.step0_flows(kk)
                        else:
                            flows = top if m == L - 1 else self.rings[m + 1][kk][3]
                        index[key] = len(bank)
                        bank.append(flows[i + hh])
                    row.append(index[key])
                else:
                    row.append(-1)
                kk += i
            hops.append(row)
            targets.append(kk - first)
        counts = np.stack([self.window_counts(j) for j in range(first, k + L * hh + 1)])
        return counts, np.stack(bank), np.asarray(hops), np.asarray(targets)

    def _composed(self, k: int, top: np.ndarray | None) -> np.ndarray:
        """``I_L(k)`` with the step flows composed along every path (:mod:`spikeref.compose`), merged as
        ``merge`` says (:mod:`spikeref.merge`)."""
        counts, bank, hops, targets = self.composed_inputs(k, top)
        p = self.p
        merge = p.merge_used
        if merge == "binomial":
            with self.timed("warp"):
                return composed_warp(counts, bank, hops, targets, p.window, p.resample)
        with self.timed("warp"):
            samples, kept, pos = composed_samples(counts, bank, hops, targets, p.window, identity=p.reach)
        n, reach = counts.shape[0], p.reach
        weights = [kept]  # Eq. 14–15's path counts: the core windows' base weights
        samples = [samples]
        multiframe = p.demosaic_used == "multiframe" and bool(self.stream.cfa)  # a monochrome stream has no demosaic
        raw, where = [counts], [pos]  # each window's own planes and where each cell's content is in it
        offset, shells = 0, ()
        if merge == "adaptive":  # the windows beyond, each way, reached by chaining step-0 flows from the ends
            shells = default_shells(reach, p.support)
            last = len(self.stream) // p.window - 1
            for step, stop, end in ((1, min(k + p.support, last), pos[-1]), (-1, max(k - p.support, 0), pos[0])):
                js = list(range(k + step * (reach + 1), stop + step, step))
                if not js:
                    continue
                flows = np.stack([self.step0_flows(j - step)[p.half + step] for j in js])  # F_0(j − step, j)
                more_counts = np.stack([self.window_counts(j) for j in js])
                with self.timed("warp"):
                    more, ok, *more_pos = chained_samples(more_counts, end, flows, p.window, positions=multiframe)
                if step > 0:
                    samples.append(more)
                    weights.append(ok)
                    raw.append(more_counts)
                    where += more_pos
                else:
                    samples.insert(0, more[::-1])
                    weights.insert(0, ok[::-1])
                    raw.insert(0, more_counts[::-1])
                    where[:0] = [moved[::-1] for moved in more_pos]
                    offset = len(js)
        samples, weights = np.concatenate(samples), np.concatenate(weights)
        core = np.zeros(samples.shape[0], bool)
        core[offset:offset + n] = True
        with self.timed("warp"):
            est, windows, *final = robust_merge(samples, weights, self.window_noise(k), offset + reach, core,
                                                MergeParams(shells=shells, window=float(p.window)),
                                                check=False, final_weights=multiframe)
        self.merge_windows[k] = windows
        if multiframe:
            self.multiframe[k] = (np.concatenate(raw), np.concatenate(where), final[0])
        return est

    # output ------------------------------------------------------------
    def finish(self, planes: np.ndarray) -> np.ndarray:
        with self.timed("demosaic"):
            mosaic = bayer_mosaic(planes, self.stream.cfa or "RGGB")
            if not self.stream.cfa:
                return mosaic
            # the steps below L of the multi-frame demosaic's frames: Ψ (they have no windows of their own)
            used = self.p.demosaic_used
            return demosaic(mosaic, self.stream.cfa, "bilinear" if used == "multiframe" else used)

    def final_rgb(self, k: int) -> np.ndarray:
        """The output frame ``k``: ``Ψ[D(I_L)]`` (Eq. 13), or with the multi-frame demosaic every merged window's
        raw samples at full resolution (:mod:`spikeref.multiframe_demosaic`), what that adds to ``Ψ(I_L)`` shrunk
        where it is not above its noise, plus a sharper demosaic's correction (directional where the colours share
        their detail, Malvar–He–Cutler's elsewhere) where the windows sampled only the reference's CFA phases, plus
        the denoiser's change ``Ψ[D(I_L) − I_L]``, clipped at 0
        (:func:`~spikeref.multiframe_demosaic.multiframe_frame`)."""
        L = self.p.L
        denoised = self.denoised(L, k)
        inputs = self.multiframe.pop(k, None)
        if inputs is None:
            return self.finish(denoised).astype(np.float32, copy=False)
        with self.timed("demosaic"):
            counts, positions, final = inputs
            return multiframe_frame(counts, positions, final, float(self.p.window), self.stream.cfa,
                                    self.planes(L, k), denoised, self.merge_windows.get(k))

    def output(self, k: int, keep_steps: bool) -> ReconstructedFrame:
        L = self.p.L
        rgb = self.final_rgb(k)
        windows = self.merge_windows.get(k)
        frame = ReconstructedFrame(index=k, rgb=rgb,
                                   exposure=None if windows is None else windows * np.float32(self.p.window))
        if keep_steps:
            frame.steps = [self.finish(self.denoised(step, k)) for step in range(L)] + [rgb]
            for step in range(1, L + 1):
                fl = self.rings[step][k][3]
                for i, f in zip(range(-self.p.half, self.p.half + 1), fl, strict=True):
                    if i:
                        frame.flows[(step - 1, i)] = f
        return frame

    def evict(self, next_k: int) -> None:
        """Drop what no frame ``≥ next_k`` needs: step ``l`` keeps windows ``≥ next_k − (L−l)h``."""
        hh, L = self.p.half, self.p.L
        for step, ring in enumerate(self.rings):
            low = next_k - (L - step) * hh
            for key in [key for key in ring if key < low]:
                del ring[key]
        read = self.p.windows_read  # the adaptive support reads further back
        for key in [key for key in self.counts if key < next_k - read]:
            del self.counts[key]
        low0 = next_k - (read if self.p.merge_used == "adaptive" else (L - 1) * hh)  # F_0: the chains' or the steps'
        for key in [key for key in self.step0 if key < low0]:
            del self.step0[key]
        for key in [key for key in self.multiframe if key < next_k]:
            del self.multiframe[key]
        for key in [key for key in self.merge_windows if key < next_k]:
            del self.merge_windows[key]
        for key in [key for key in self.noise if key < next_k - (L - 1) * hh]:  # the steps' lowest window
            del self.noise[key]
