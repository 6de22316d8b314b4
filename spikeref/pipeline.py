"""The progressive warping reconstruction, Eq. 13–15 and Fig. 3(b) (§4.2), streamed.

Windows of ``W`` planes are numbered ``k = 0, 1, …`` (window ``k`` = planes ``[kW, (k+1)W)``,
``docs/spec/README.md``).  With ``h = (K − 1)/2`` neighbours on each side:

* **step 0** — Eq. 4 per window: ``I_0(k)`` (four Bayer planes of firing rates); Eq. 13:
  ``R_0(k) = Ψ[D(I_0(k))]``, used only to estimate the flow ``F_0(k, k+i)``, ``|i| ≤ h``
  (HDR+ alignment, :mod:`spikeref.align`, on the 2×2 luma of ``D(I_0)``).
* **step 1** — Eq. 14: the spike planes of windows ``k−h … k+h``, each warped by
  ``F_0(k, k+i)``, summed and divided by ``K W`` → ``I_1(k)``.
* **steps l = 2 … L** — Eq. 15: ``I_l(k)`` = mean of ``I_{l−1}(k+i)`` warped by
  ``F_{l−1}(k, k+i)``, where ``F_{l−1}`` aligns ``D(I_{l−1})`` (the denoiser helps the flow at
  every step, Fig. 3(b)).
* **output** — ``R_L(k) = Ψ[D(I_L(k))]``, linear float32 RGB, one frame per window: ``20000/W``
  frames per second.

Interpretations (``docs/equations.md``)
---------------------------
* The ``K`` frames of a step are **adjacent windows** of the previous step (offsets
  ``−h … h``), so the support of ``R_L(k)`` is windows ``k − Lh … k + Lh``:
  ``((K−1)L + 1)·W`` planes, the paper's pseudo-long exposure.  The reference is the middle
  frame (the paper's ``(K+1)/2``-th); ``K`` must be odd.
* **Output frame numbers are window numbers**: frame ``k`` is centred on window ``k``
  (``t = (k + ½) W / 20000`` s) and exists only where its whole support lies inside the
  recording, ``Lh ≤ k < T//W − Lh`` (:func:`frame_range`).  So frames ``a:b`` computed alone are
  the frames ``a:b`` of a full run (every frame depends on its support only), and a long
  recording can be cut into chunks.
* The flow of step ``l`` uses the tile size ``AlignParams.tile_for_step(l)``: large tiles for
  the noisy step-0 frames, smaller ones later (supplement §8).

Beyond the paper (the defaults of :class:`ReconstructParams`, each measured on the stage ladder,
``docs/results.md``; :meth:`ReconstructParams.paper` turns all of them off):

* ``flow_frames="smoothed"`` aligns a Gaussian-smoothed 2×2 luma of ``I_l`` (σ =
  :data:`FLOW_SMOOTHING_SIGMA` plane pixels) instead of the luma of ``D(I_l)``: the U-Net then
  runs once per output frame (for ``R_L``) instead of ``L + 1`` times.  ``"denoised"`` is
  Fig. 3(b).
* ``warp="composed"`` makes ``I_L`` from the spike windows with the step flows composed along
  every path (:mod:`spikeref.compose`): one cubic resample per window instead of ``L``
  bilinear ones, at the mean end of the window's paths (``resample="window"``; ``"path"``
  samples once per path).  ``"progressive"`` is Eq. 14–15; ``"chained"`` (a speed option) composes only
  the step-0 flows, so the frames and flows of steps ``1 … L−1`` are never made.
* ``AlignParams(refine="lk", smoothness=300, zero_test=2)`` (the default here): the sub-pixel part of
  each tile vector by Lucas–Kanade steps instead of HDR+'s quadratic fit, the tile field regularised
  by each tile's confidence over the noise, and zero motion per pixel where zero explains the raw
  frames better than the flow (:mod:`spikeref.align`).
* ``AlignParams.prefer_centre > 0`` (3 by default here; ``AlignParams()`` alone keeps the plain
  HDR+ search) turns on the noise-aware search of :mod:`spikeref.align`; the pipeline tells it
  the noise of ``I_l``, measured on the 2×2 luma of the frames before denoising (variance map
  and the correlation of the two frames' noise — adjacent windows' counts are
  anti-correlated), whatever the flow is estimated on (:meth:`spikeref.pipeline_rings.FrameRings.noise_aware_flow`).
* A :class:`~spikeref.denoise.denoiser.Denoiser` with its guard on (the default,
  :mod:`spikeref.denoise.guard`) is guarded for the output ``D(I_L)`` only; frames that are
  only aligned are denoised without it.

More interpretations:

* ``K = 1`` or ``L = 0`` reduces to the denoised TFP ``Ψ[D(I_0)]`` (no flow is computed);
  ``align=False`` uses zero flow (plain accumulation over the support: TFP with a
  ``((K−1)L+1)·W`` window, then ``D`` and Ψ) — for the accuracy-vs-time study.
* A denoiser trained on spike counts (``Denoiser.input_domain == "count"``) is told the
  exposure of what it denoises: ``W`` at step 0 and the noise-equivalent window
  :func:`exposure_planes` at step ``l`` (``K W`` at step 1; at ``l ≥ 2`` the average of
  overlapping frames weighs the windows of the support unequally, so less than
  ``((K−1)l+1)·W``).
* A monochrome stream is handled as four 2×2 phases and the output is the re-mosaicked
  ``(H, W)`` frame (no Ψ).

The settings are :mod:`spikeref.pipeline_params` (:class:`ReconstructParams`, re-exported here); the
per-step rings of a pass, :mod:`spikeref.pipeline_rings`.

Streaming: each ``I_l(k)``, ``D(I_l(k))`` and its luma is computed once and kept in a ring of
the ``2(L − l)h + 1`` windows that later frames still need; windows are read from the stream
(memory-mapped ``.dat``: from their packed bytes) only when first needed.  Memory is bounded by
``O(L²K)`` frames, whatever the recording's length.
"""

from __future__ import annotations

import copy
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Callable, Iterator

import numpy as np

from spikeref.align import AlignParams
from spikeref.dark_level import check_dark_level, subtract_dark_level
from spikeref.denoise.denoiser import Denoiser, bundled_weights
from spikeref.hot_pixels import HotPixelRepair, hot_pixels_to_replace
from spikeref.pipeline_params import (
    ACCUMULATE, DEFAULT_ACCUMULATE, DEFAULT_PREFER_CENTRE, DEFAULT_REFINE, DEFAULT_SMOOTHNESS, DEFAULT_ZERO_TEST,
    FLOW_FRAMES, FLOW_SMOOTHING_SIGMA, HOT_PIXELS, PRESETS, STAGES, WARPS, ReconstructParams, default_align_params,
    exposure_planes, frame_range, support_planes)
from spikeref.pipeline_rings import FrameRings, ReconstructedFrame, flow_luma
from spikeref.stream import SpikeStream, as_stream

__all__ = ["ReconstructParams", "ReconstructedFrame", "Reconstructor", "reconstruct", "frame_range",
           "support_planes", "exposure_planes", "FLOW_FRAMES", "FLOW_SMOOTHING_SIGMA", "WARPS", "DEFAULT_PREFER_CENTRE",
           "DEFAULT_REFINE", "DEFAULT_SMOOTHNESS", "DEFAULT_ZERO_TEST", "default_align_params",
           "flow_luma", "PRESETS", "STAGES", "StageProfile", "ACCUMULATE", "DEFAULT_ACCUMULATE", "HOT_PIXELS"]

@dataclass(frozen=True)
class StageProfile:
    """Where the time of a reconstruction went, per stage (:meth:`Reconstructor.profile`).

    Attributes
    ----------
    seconds : dict
        ``{stage: seconds}`` for every stage of :data:`STAGES`, plus ``"other"``: the rest of
        ``total`` (ring bookkeeping, stacking windows, the caller's loop), never negative.
    frames : int
        Output frames made.
    total : float
        Wall seconds the breakdown accounts for.
    """

    seconds: dict
    frames: int
    total: float

    @property
    def outside_network(self) -> float:
        """Share of ``total`` outside the U-Net's forward passes (0 … 1; NaN when ``total`` is 0)."""
        if self.total <= 0:
            return float("nan")
        return 1.0 - self.seconds.get("network", 0.0) / self.total

    def table(self) -> str:
        """A plain-text table: stage, seconds, % of the frame time, milliseconds per frame."""
        n = max(self.frames, 1)
        pct = (lambda v: 100.0 * v / self.total) if self.total > 0 else (lambda v: float("nan"))
        lines = [f"{'stage':<11} {'seconds':>9} {'% of time':>9} {'ms/frame':>9}"]
        for stage, v in self.seconds.items():
            lines.append(f"{stage:<11} {v:9.3f} {pct(v):8.1f}% {1e3 * v / n:9.1f}")
        lines.append(f"{'total':<11} {self.total:9.3f} {pct(self.total):8.1f}% {1e3 * self.total / n:9.1f}")
        rate = f"{self.frames / self.total:.2f} frames/s" if self.total > 0 else "no time measured"
        lines.append(f"{self.frames} frames, {rate}; outside the network: {100 * self.outside_network:.1f} %")
        return "\n".join(lines)


class _TimedNetwork:
    """A U-Net that adds the seconds of its forward passes to a stage of a :class:`Reconstructor`."""

    def __init__(self, net, rec: "Reconstructor"):
        self._net, self._rec = net, rec

    def __call__(self, batch, **kw):
        with self._rec.timed("network"):
            return self._net(batch, **kw)

    def __getattr__(self, name):
        if name in ("_net", "_rec"):  # not set yet (copy, pickle): no recursion
            raise AttributeError(name)
        return getattr(self._net, name)


class Reconstructor:
    """Progressive warping over a spike stream, frame by frame, with bounded memory.

    Parameters
    ----------
    stream : SpikeStream
        Colour (with ``cfa``) or monochrome; in memory or memory-mapped.
    params : ReconstructParams
    denoiser : Denoiser or callable, optional
        ``D``; default the bundled weights (:meth:`Denoiser.load`).  A callable takes Bayer
        planes ``(4, h, w) float32`` and returns the same shape.  Not used (nothing is loaded)
        with ``params.denoise=False``.
    hot_pixels : ndarray ``(H, W) bool``, optional
        The hot pixels to replace in every window (a calibration map,
        :func:`spikeref.hot_pixels.load_hot_pixel_map`), whatever ``params.hot_pixels`` says; by default
        they are found in the stream with ``params.hot_pixels="auto"``.  :attr:`hot_pixel_mask` holds
        the map in use (``None``: none replaced).
    dark_level : array_like ``(4,)``, optional
        The sensor's dark level per 2×2 phase, spikes per readout (Eq. 9's ``E[N]/W``, measured on a dark
        recording: :func:`spikeref.dark_level.measure_dark_level`, ``spikeref calibrate``): subtracted from every
        output frame and step, clipped at 0 (:func:`spikeref.dark_level.subtract_dark_level`).  Default none:
        the frames are ``E[I_c]`` as the paper's.
    """

    def __init__(self, stream: SpikeStream, params: ReconstructParams | None = None, denoiser=None,
                 hot_pixels=None, dark_level=None):
        if not isinstance(stream, SpikeStream):
            raise TypeError(f"stream must be a SpikeStream (see spikeref.read_dat); got {type(stream).__name__}")
        self.stream = stream
        self.params = params if params is not None else ReconstructParams()
        if not isinstance(self.params, ReconstructParams):
            raise TypeError(f"params must be a ReconstructParams; got {type(self.params).__name__}")
        p = self.params
        if stream.height % 2 or stream.width % 2:
            raise ValueError(f"the stream must have even height and width (2×2 Bayer cells); "
                             f"got {stream.height}×{stream.width}")
        need = p.support_windows * p.window
        if len(stream) < need:
            raise ValueError(f"the stream has {len(stream)} planes; one frame with W={p.window}, K={p.K}, L={p.L} "
                             f"needs ((K−1)L+1)·W = {need} planes")
        if p.align and p.K > 1 and p.L > 0:  # small frames: a smaller pyramid, or zero flow (with a note)
            p = self.params = _fit_align_size(stream.height // 2, stream.width // 2, p)
        #: seconds spent per stage of :data:`STAGES` since construction, each stage's own time
        #: (a stage timed inside another is taken out of the outer one); ``"write"`` is what callers
        #: time with :meth:`timed`
        self.timings: dict[str, float] = dict.fromkeys(STAGES, 0.0)
        #: wall seconds spent inside :meth:`frames` making frames, and the frames made
        self.busy_seconds = 0.0
        self.frames_made = 0
        self._open: list[list] = []  # [stage, start, seconds of stages nested in it]
        self._denoise = self._make_denoiser(denoiser)
        self.frames_available = frame_range(len(stream), p.window, p.K, p.L)
        # once, before any frame (as loading the weights: not in the stage timings)
        #: the hot pixels replaced in every window ``(H, W) bool``, or None (:mod:`spikeref.hot_pixels`)
        self.hot_pixel_mask = hot_pixels_to_replace(stream, p.hot_pixels, hot_pixels)
        self._repair = HotPixelRepair(self.hot_pixel_mask) if self.hot_pixel_mask is not None else None
        #: the dark level subtracted from every frame ``(4,)``, or None (:mod:`spikeref.dark_level`)
        self.dark_level = None if dark_level is None else check_dark_level(dark_level)

    def _make_denoiser(self, denoiser) -> Callable[[np.ndarray, float, bool], np.ndarray] | None:
        """``D`` as the rings call it, or None with ``denoise=False`` (D is the identity: no network, no weights)."""
        if denoiser is not None and not (isinstance(denoiser, Denoiser) or callable(denoiser)):
            raise TypeError(f"denoiser must be a Denoiser or a callable on (4, h, w) planes; "
                            f"got {type(denoiser).__name__}")
        if not self.params.denoise:
            return None
        if denoiser is None:  # the bundled network trained on what the windows give
            denoiser = Denoiser.load(bundled_weights(self.params.accumulate))
        if isinstance(denoiser, Denoiser):
            mode = self.params.mode
            denoiser = copy.copy(denoiser)  # the same weights and settings; its forward passes timed
            denoiser.unet = _TimedNetwork(denoiser.unet, self)

            # the guard (if the Denoiser has one) on the output only: frames that are only aligned
            # need no guard, and it would cost them a second network pass
            extra = {"accumulate": "charge"} if self.params.accumulate == "charge" else {}  # count: the default
            short_window = self.params.window

            # the output guard on charges: a merge of consecutive window charges shares their inner edges, so it
            # quantises like one charge over the whole support, not over its noise-equivalent exposure
            # (docs/results.md, "Never worse than plain accumulation")
            floor = {"floor_window": float(self.params.support_windows * self.params.window)} \
                if self.params.accumulate == "charge" else {}

            def run(planes, exposure, final, short=None):
                more = {} if short is None else {"short": short, "short_window": short_window}
                if final:
                    more.update(floor)
                return denoiser(planes, mode, window=exposure, guard=None if final else "off", **extra, **more)

            return run

        def call(planes, exposure, final, short=None):
            with self.timed("network"):  # a plain callable counts as the network
                return denoiser(planes)

        return call

    # ------------------------------------------------------------------ public
    @contextmanager
    def timed(self, stage: str):
        """Add the wall time of the ``with`` block to ``timings[stage]`` (a stage of :data:`STAGES`).

        Blocks may nest: an inner stage's seconds are taken out of the outer one, so the stages
        never count the same second twice and sum to at most the wall time.
        """
        if stage not in self.timings:
            raise ValueError(f"stage must be one of {', '.join(STAGES)}; got {stage!r}")
        entry = [stage, time.perf_counter(), 0.0]
        self._open.append(entry)
        try:
            yield
        finally:
            self._open.pop()
            elapsed = time.perf_counter() - entry[1]
            self.timings[stage] += elapsed - entry[2]
            if self._open:
                self._open[-1][2] += elapsed

    def profile(self, total: float | None = None) -> StageProfile:
        """The stage breakdown so far (:class:`StageProfile`).

        Parameters
        ----------
        total : float, optional
            Wall seconds to account for, e.g. the caller's whole loop including writing; default
            :attr:`busy_seconds` plus the ``"write"`` stage.  What the stages leave is ``"other"``.
        """
        if total is None:
            total = self.busy_seconds + self.timings["write"]
        seconds = dict(self.timings)
        seconds["other"] = max(0.0, float(total) - sum(seconds.values()))
        return StageProfile(seconds=seconds, frames=self.frames_made, total=float(total))

    def frames(self, start: int | None = None, stop: int | None = None,
               keep_steps: bool = False) -> Iterator[ReconstructedFrame]:
        """Yield frames ``start … stop−1`` (default: every frame of :attr:`frames_available`)."""
        avail = self.frames_available
        for name, v in (("start", start), ("stop", stop)):
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer))):
                raise TypeError(f"{name} must be a frame number (int) or None; got {v!r}")
        start = avail.start if start is None else int(start)
        stop = avail.stop if stop is None else int(stop)
        if start < avail.start or stop > avail.stop or start > stop:
            raise ValueError(f"frames {start}:{stop} are outside the frames this stream has "
                             f"({avail.start}:{avail.stop} with W={self.params.window}, K={self.params.K}, "
                             f"L={self.params.L}; frame k needs windows k−{self.params.reach} … k+{self.params.reach})")
        state = FrameRings(self.stream, self.params, self.timed, self._denoise, self._repair, keep_steps)
        for k in range(start, stop):
            t0 = time.perf_counter()
            frame = state.output(k, keep_steps)
            if self.dark_level is not None:
                frame.rgb = subtract_dark_level(frame.rgb, self.dark_level, self.stream.cfa)
                frame.steps = [subtract_dark_level(s, self.dark_level, self.stream.cfa) for s in frame.steps]
            state.evict(k + 1)
            self.busy_seconds += time.perf_counter() - t0
            self.frames_made += 1
            yield frame

    def __iter__(self) -> Iterator[np.ndarray]:
        for frame in self.frames():
            yield frame.rgb

    def __len__(self) -> int:
        return len(self.frames_available)


def _fit_align_size(h: int, w: int, p: ReconstructParams) -> ReconstructParams:
    """``p``, its alignment cut down to frames of ``h × w`` plane pixels when they are too small.

    Alignment needs one finest tile of every step ``0 … L−1`` and one coarse tile at the coarsest
    level (:meth:`AlignParams.min_size`, the rule :func:`align` itself applies).  Frames that hold
    them keep ``p`` itself (the same result, bit for bit); smaller ones align with
    :meth:`AlignParams.fitted` (fewer levels, smaller finest tiles) or, when not even one level
    fits, not at all (``align=False``: zero flow), and a one-line ``UserWarning`` says so.
    """
    a = p.align_params
    need = max(a.min_size(step) for step in range(p.L))
    if min(h, w) >= need:
        return p
    fitted = a.fitted(h, w)
    small = (f"{2 * h}×{2 * w} frames ({h}×{w} per Bayer plane) are too small for the alignment pyramid "
             f"(levels={a.levels}, tile_by_step={a.tile_by_step} need {need}×{need} per plane)")
    if fitted is None:
        warnings.warn(f"{small}: not aligned, zero flow (as align=False)", UserWarning, stacklevel=3)
        return replace(p, align=False)
    warnings.warn(f"{small}: aligned with levels={fitted.levels}, tile_by_step={fitted.tile_by_step}", UserWarning,
                  stacklevel=3)
    return replace(p, align_params=fitted)


def reconstruct(stream, W: int = 10, K: int = 3, L: int = 3, mode: str = "visible", denoiser=None,
                align: bool = True, align_params: AlignParams | None = None, frames: slice | None = None,
                flow_frames: str | None = None, warp: str | None = None) -> Iterator[np.ndarray]:
    """Reconstruct colour frames from a spike stream: ``R_L = Ψ[D(I_L)]`` (Eq. 13–15, Fig. 3(b)).

    Parameters
    ----------
    stream : SpikeStream or ndarray ``(T, H, W) uint8``
        Chromatic spikes (``cfa`` set; an array is taken as RGGB) or monochrome.
    W, K, L : int
        Window (planes), frames per step (odd), steps.  Defaults 10, 3, 3 (the paper's).
    mode : str
        Denoiser inference mode (``visible``, ``blind``, ``mixed``).
    denoiser : Denoiser or callable, optional
        Default: the bundled weights.
    align : bool
        Estimate flow (default) or use zero flow.
    align_params : AlignParams, optional
    frames : slice, optional
        Frame numbers to produce (default: all, :func:`frame_range`).
    flow_frames : {"denoised", "smoothed"}, optional
        See :class:`ReconstructParams` (default: its default, ``"smoothed"``; the paper's is
        ``"denoised"``).
    warp : {"composed", "progressive", "chained"}, optional
        See :class:`ReconstructParams` (default ``"composed"``; the paper's is ``"progressive"``).

    Yields
    ------
    ndarray ``(H, W, 3) float32``
        Linear RGB in spikes per readout, at ``20000 / W`` frames per second.
    """
    if isinstance(stream, np.ndarray):
        stream = as_stream(stream, cfa="RGGB")
    kw = {k: v for k, v in (("flow_frames", flow_frames), ("warp", warp), ("align_params", align_params))
          if v is not None}
    params = ReconstructParams(window=W, K=K, L=L, mode=mode, align=align, **kw)
    if frames is not None and (not isinstance(frames, slice) or frames.step not in (None, 1)):
        raise ValueError(f"frames must be a slice a:b of frame numbers without a step; got {frames!r}")
    rec = Reconstructor(stream, params, denoiser)
    a = frames.start if frames is not None else None
    b = frames.stop if frames is not None else None
    for frame in rec.frames(a, b):
        yield frame.rgb
