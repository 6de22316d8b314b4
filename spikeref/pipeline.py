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
  anti-correlated), whatever the flow is estimated on (``_State.noise_aware_flow``).
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
from dataclasses import dataclass, field, replace
from typing import Callable, Iterator

import numpy as np
from scipy.ndimage import gaussian_filter

from spikeref.accumulate import window_counts
from spikeref.align import AlignParams, align
from spikeref.align_noise import estimate_noise, estimate_noise_correlation, local_noise
from spikeref.bayer import bayer_mosaic, bayer_planes, luma
from spikeref.charge import ACCUMULATE, WINDOWS_PER_CALL, window_charge
from spikeref.hot_pixels import HotPixelRepair, hot_pixels_to_replace
from spikeref.merge import MERGES, MergeParams, default_shells, robust_merge
from spikeref.compose import RESAMPLES, chained_samples, composed_samples, composed_warp, path_table
from spikeref.demosaic import DEMOSAICS, demosaic
from spikeref.denoise.blindspot import MODES
from spikeref.denoise.denoiser import Denoiser, bundled_weights
from spikeref.stream import SpikeStream, as_stream
from spikeref.warp import warp_average, warp_spike_windows

__all__ = ["ReconstructParams", "ReconstructedFrame", "Reconstructor", "reconstruct", "frame_range",
           "support_planes", "exposure_planes", "FLOW_FRAMES", "FLOW_SMOOTHING_SIGMA", "WARPS", "DEFAULT_PREFER_CENTRE",
           "DEFAULT_REFINE", "DEFAULT_SMOOTHNESS", "DEFAULT_ZERO_TEST", "default_align_params",
           "flow_luma", "PRESETS", "STAGES", "StageProfile", "ACCUMULATE", "DEFAULT_ACCUMULATE"]

#: What the flow of each step is estimated on: ``"denoised"`` — the 2×2 luma of ``D(I_l)``, as
#: Fig. 3(b) — or ``"smoothed"`` — the 2×2 luma of ``I_l`` itself, smoothed by a Gaussian.
FLOW_FRAMES = ("denoised", "smoothed")
#: ``AlignParams.prefer_centre`` of the default reconstruction (the noise-aware search; 0 in the
#: paper): chosen among 0, 2, 3, 4 on the real outdoor recording and the benchmark scenes
#: (``scripts/study_align_real.py``, docs/results.md).
DEFAULT_PREFER_CENTRE = 3.0
#: ``AlignParams.refine`` of the default reconstruction (not in the paper or HDR+): Lucas–Kanade steps
#: instead of HDR+'s quadratic fit for the sub-pixel part (docs/results.md, issue 32).
DEFAULT_REFINE = "lk"
#: ``AlignParams.smoothness`` of the default reconstruction (not in the paper or HDR+): the noise-weighted
#: pull between neighbouring tile vectors, chosen among 0, 30, 100, 300, 1000 on the benchmark scenes and
#: the real recording (``scripts/study_align_lk.py``).
DEFAULT_SMOOTHNESS = 300.0
#: ``AlignParams.zero_test`` of the default reconstruction (not in the paper or HDR+): the per-pixel
#: zero-motion test at 2 standard deviations, chosen among 0, 1, 2, 3 (``scripts/study_align_lk.py``).
DEFAULT_ZERO_TEST = 2.0
#: How the output frame is made from the step flows (:class:`ReconstructParams`).
WARPS = ("progressive", "composed", "chained")
#: σ of the Gaussian of ``flow_frames="smoothed"``, in Bayer-plane pixels.  Chosen on the
#: benchmark scenes among 0, 0.7, 1 and 1.5 (``scripts/study_flow_frames.py``, docs/results.md,
#: 2026-11-23): 0.7 and 1 tie on the mean PSNR over W/K/L = 10/3/3, 10/5/2, 20/5/2, 20/3/3
#: (0.01 dB below the denoised flow frames), and 1 loses least at its worst setting (0.09 dB).
FLOW_SMOOTHING_SIGMA = 1.0
#: Named settings of :meth:`ReconstructParams.preset` (``spikeref reconstruct --preset``):
#: ``"default"`` (the defaults), ``"fast"`` (:meth:`ReconstructParams.fast`), ``"fastest"``
#: (:meth:`ReconstructParams.fastest`), ``"paper"`` (:meth:`ReconstructParams.paper`).
PRESETS = ("default", "fast", "fastest", "paper")
#: ``ReconstructParams.accumulate`` of the default reconstruction: the window charge (:mod:`spikeref.charge`;
#: not in the paper, whose Eq. 4 count :meth:`ReconstructParams.paper` keeps), chosen on the stage ladder
#: (docs/results.md); callers that load the bundled network for it ask here.
DEFAULT_ACCUMULATE = "charge"
#: The stages of :attr:`Reconstructor.timings`, in pipeline order: Eq. 4 (reading the stream
#: included), the U-Net's forward passes, the rest of the denoiser (its guard, shrinkage and the
#: blind-spot bookkeeping), the alignment (flow frames and the HDR+ search), the warps (Eq. 14–15
#: or the composed warp), the demosaic Ψ, and writing the frame (timed by the caller, e.g. the CLI).
STAGES = ("accumulate", "network", "guard", "align", "warp", "demosaic", "write")
#: ``ReconstructParams.hot_pixels``: found in the recording and replaced (``"auto"``), or left in.
HOT_PIXELS = ("auto", "off")


@dataclass(frozen=True)
class ReconstructParams:
    """Hyper-parameters of the progressive warping (defaults: the paper's W = 10, K = 3, L = 3).

    The defaults of ``align_params``, ``warp`` and ``flow_frames`` go beyond the paper, each for
    the gain the stage ladder measured (``docs/results.md``); :meth:`paper` gives the paper's
    procedure exactly.

    Parameters
    ----------
    window : int
        ``W``, planes per window (≥ 1); output frame rate ``rate_hz / W``.
    K : int
        Frames warped together at each step (odd, ≥ 1).
    L : int
        Number of warping steps (≥ 0).
    mode : {"visible", "blind", "mixed"}
        Denoiser inference mode (:class:`~spikeref.denoise.denoiser.Denoiser`).
    align : bool
        Estimate the flow (True) or use zero flow (False: plain accumulation over the support).
    align_params : AlignParams
        Alignment parameters (:mod:`spikeref.align`); with ``prefer_centre > 0`` the search is
        noise-aware, told the noise of the frames before denoising (module doc).  Default:
        :func:`default_align_params`, ``AlignParams(prefer_centre=3, refine="lk", smoothness=300,
        zero_test=2)`` (the noise-aware search, Lucas–Kanade sub-pixel steps, the noise-weighted
        regularisation of the tile field and the per-pixel zero-motion test; none in the paper); the
        paper's HDR+ search is ``AlignParams()``.
    warp : {"composed", "progressive", "chained"}
        How the output ``I_L`` is made from the flows: ``"progressive"`` — Eq. 14 then Eq. 15
        ``L − 1`` times, each step resampling the previous one (the paper); ``"composed"``
        (default) — the same flows composed along every path through the steps, so each spike
        window is resampled once, with a cubic (:mod:`spikeref.compose`; not in the paper).
        The frames of steps ``< L`` (what the flows are estimated on) are made progressively
        either way.  ``"chained"`` (a speed option, not in the paper) composes only the step-0
        flows ``F_0(j, j+i)`` along the same paths — every step estimates the displacement
        between the same windows — so no frame or flow of a step ``≥ 1`` is made at all.
    flow_frames : {"smoothed", "denoised"}
        What each step's flow is estimated on: the luma of the denoised frames ``D(I_l)`` (the
        paper's Fig. 3(b): ``L + 1`` denoiser passes per output frame) or a Gaussian-smoothed
        luma of ``I_l`` (default; :func:`flow_luma`; one denoiser pass per output frame, not in
        the paper).
    demosaic : {"bilinear", "mhc"}
        The output frame's demosaic: Ψ (default, Eq. 13) or Malvar–He–Cutler
        (:mod:`spikeref.demosaic`; sharper, not in the paper).  The flows always use the 2×2 luma.
    accumulate : {"charge", "count"}
        What each window contributes: the charge its pixels integrated, read from the spike times
        around the window's edges (default; :mod:`spikeref.charge`, not in the paper: the count's
        ±1 quantisation at the edges falls by about the firing rate), or its spike count (Eq. 4,
        the paper's; :meth:`paper`).  ``"charge"`` reads up to
        :data:`spikeref.charge.DEFAULT_MARGIN` readouts beyond the support, and without a
        denoiser named the pipeline loads the bundled network trained on charges
        (:func:`spikeref.denoise.denoiser.bundled_weights`).
    resample : {"window", "path"}
        With ``warp="composed"`` or ``"chained"``: each spike window is sampled once, at the mean
        composed position of the paths that end in it, weighted by their number (default; the warp
        step 2.1× faster than with ``"path"`` for the same PSNR on the benchmark and held-out means,
        ``docs/results.md``), or once per path (``"path"``, the composed warp until 2026-11-24);
        :func:`spikeref.compose.composed_warp`.  Not in the paper; the progressive warp resamples
        frames, not windows, and ignores it, as do the robust merges (``merge_used`` ``"robust"`` or
        ``"adaptive"``: one sample per window, at its mean composed position).
    denoise : bool
        Denoise (default) or not: ``False`` makes ``D`` the identity, so no network runs and no
        weights are loaded (a denoiser given to :class:`Reconstructor` is not used).  Not in the
        paper: the stage ladder's "no denoiser" rung, a speed option (:meth:`fastest`).  With
        window charges the network buys little (``docs/results.md``, "The denoiser's share of
        the time"), at half the frame time.
    merge : {"auto", "adaptive", "robust", "binomial"}
        How the composed (or chained) warp merges the windows: ``"adaptive"``: each window weighed by how well
        it agrees with the reference beyond what the noise explains, and the support grown beyond Eq. 14–15's, up
        to ``support`` windows each side, where the samples keep agreeing (windows reached by chaining step-0
        flows; :mod:`spikeref.merge`); ``"robust"``: the same weights at Eq. 14–15's support; ``"binomial"``:
        Eq. 14–15's binomial average (the paper's weights; :meth:`paper` and :meth:`fast`).  ``"auto"``
        (default) is ``"adaptive"`` on window charges with the composed or chained warp and ``"binomial"``
        otherwise (:attr:`merge_used`): on Eq. 4's counts consecutive windows' quantisation errors cancel in a
        plain average, and weighing windows by their agreement with the reference keeps the reference's error
        (the real outdoor recording: −5.1 dB against the binomial merge; ``docs/results.md``, "The adaptive merge
        as the default").  Not in the paper; not with ``warp="progressive"``.  On charges the adaptive merge gains
        0.72 / 0.39 dB on the benchmark / held-out means (10 of 12 scenes up, two within 0.03 dB) and 0.5 dB on the
        real recording, at 0.7× the binomial merge's frames/s.
    support : int
        With ``merge="adaptive"``: the farthest window, in windows from the reference (default 10: 100 planes
        at W = 10), that a pixel may collect.
    hot_pixels : {"auto", "off"}
        ``"auto"`` (default): the hot pixels found in the recording itself
        (:func:`spikeref.hot_pixels.find_hot_pixels`, on its first planes) are replaced in every window by
        the mean of their same-colour neighbours before the denoiser, the alignment and the warp read it;
        ``"off"``: windows as accumulated (the paper's, and :meth:`paper`'s).  A map given to
        :class:`Reconstructor` (``hot_pixels=``, e.g. from ``spikeref calibrate``) replaces the search.
        Not in the paper.
    """

    window: int = 10
    K: int = 3
    L: int = 3
    mode: str = "visible"
    align: bool = True
    align_params: AlignParams = field(default_factory=lambda: default_align_params())
    flow_frames: str = "smoothed"
    warp: str = "composed"
    demosaic: str = "bilinear"
    accumulate: str = DEFAULT_ACCUMULATE
    resample: str = "window"
    denoise: bool = True
    hot_pixels: str = "auto"
    merge: str = "auto"
    support: int = 10

    def __post_init__(self):
        for name, low in (("window", 1), ("K", 1), ("L", 0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
                raise ValueError(f"{name} must be an integer ≥ {low}; got {v!r}")
        if self.K % 2 == 0:
            raise ValueError(f"K must be odd (the reference is the middle frame); got {self.K}")
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}; got {self.mode!r}")
        if self.flow_frames not in FLOW_FRAMES:
            raise ValueError(f"flow_frames must be one of {', '.join(FLOW_FRAMES)}; got {self.flow_frames!r}")
        if not isinstance(self.align_params, AlignParams):
            raise TypeError(f"align_params must be an AlignParams; got {type(self.align_params).__name__}")
        if self.warp not in WARPS:
            raise ValueError(f"warp must be one of {', '.join(WARPS)}; got {self.warp!r}")
        if self.demosaic not in DEMOSAICS:
            raise ValueError(f"demosaic must be one of {', '.join(DEMOSAICS)}; got {self.demosaic!r}")
        if self.accumulate not in ACCUMULATE:
            raise ValueError(f"accumulate must be one of {', '.join(ACCUMULATE)}; got {self.accumulate!r}")
        if self.resample not in RESAMPLES:
            raise ValueError(f"resample must be one of {', '.join(RESAMPLES)}; got {self.resample!r}")
        if not isinstance(self.denoise, (bool, np.bool_)):
            raise TypeError(f"denoise must be True or False; got {self.denoise!r}")
        if self.hot_pixels not in HOT_PIXELS:
            raise ValueError(f"hot_pixels must be one of {', '.join(HOT_PIXELS)}; got {self.hot_pixels!r}")
        if self.merge != "auto" and self.merge not in MERGES:
            raise ValueError(f"merge must be auto or one of {', '.join(MERGES)}; got {self.merge!r}")
        if self.merge not in ("binomial", "auto") and self.warp == "progressive":
            raise ValueError(f"merge={self.merge!r} needs the composed or chained warp (the progressive warp merges "
                             f"frames step by step)")
        if isinstance(self.support, bool) or not isinstance(self.support, (int, np.integer)) or \
                self.support < self.reach:
            raise ValueError(f"support must be a whole number of windows ≥ L·(K−1)/2 = {self.reach}; "
                             f"got {self.support!r}")

    @property
    def merge_used(self) -> str:
        """The merge that runs: :attr:`merge`, with ``"auto"`` resolved (``"adaptive"`` on window charges with the
        composed or chained warp, else ``"binomial"``)."""
        if self.merge != "auto":
            return self.merge
        return "adaptive" if self.accumulate == "charge" and self.warp != "progressive" else "binomial"

    @property
    def half(self) -> int:
        """``h = (K − 1)/2``, neighbours on each side."""
        return (self.K - 1) // 2

    @property
    def reach(self) -> int:
        """Windows on each side of the reference that frame ``k`` depends on: ``L·h``."""
        return self.L * self.half

    @property
    def windows_read(self) -> int:
        """Windows on each side of the reference that frame ``k`` reads: :attr:`reach`, or ``support`` with the
        adaptive merge (:attr:`merge_used`), which chains further where the recording has windows."""
        return max(self.reach, self.support) if self.merge_used == "adaptive" else self.reach

    @property
    def support_windows(self) -> int:
        """``(K − 1)L + 1`` windows."""
        return 2 * self.reach + 1

    @classmethod
    def paper(cls, **kw) -> "ReconstructParams":
        """The paper's procedure exactly (Fig. 3(b)): Eq. 4's counts, progressive warping, flows on
        the denoised frames, the HDR+ search without the noise-aware preference.  Pair it with
        ``Denoiser(guard="off", shrink=False)`` for the paper's ``D``; ``kw`` sets any other field.
        """
        base = dict(warp="progressive", flow_frames="denoised", align_params=AlignParams(), accumulate="count",
                    hot_pixels="off", merge="binomial")
        base.update(kw)
        return cls(**base)

    @classmethod
    def fast(cls, **kw) -> "ReconstructParams":
        """The speed preset: the defaults with ``warp="chained"`` and Eq. 14–15's binomial merge; ``kw`` sets any
        other field.

        Only the step-0 flows are estimated and composed (no frame or flow of steps ``1 … L−1``
        is made), so at W/K/L = 10/3/3 a frame costs one flow search per window instead of ``L``
        and still one denoiser pass (plus the guard's probe), and no robust merge.  Measured in ``docs/results.md``
        (section "Speed"): ≥ 8 frames/s at 250×400 on two cores, within 0.5 dB of the defaults on
        the benchmark scenes; on fast motion the composed step flows of the defaults do better.
        """
        base = dict(warp="chained", merge="binomial")
        base.update(kw)
        return cls(**base)

    @classmethod
    def fastest(cls, **kw) -> "ReconstructParams":
        """The fast preset without a denoiser: ``fast(denoise=False)``; ``kw`` sets any other field.

        No network pass at all: at W/K/L = 10/3/3 and 250×400 about 5× the defaults' frames/s on two
        cores (61 against 12), within 0.1 dB of them on the means of the benchmark and held-out scenes,
        0.4 dB under them in low light (``docs/results.md``, "The denoiser's share of the time").
        """
        return cls.fast(**{"denoise": False, **kw})

    @classmethod
    def preset(cls, name: str, **kw) -> "ReconstructParams":
        """The named preset of :data:`PRESETS` (``"default"``, ``"fast"``, ``"fastest"``, ``"paper"``) with
        ``kw`` set.

        Raises
        ------
        ValueError
            If ``name`` is not one of :data:`PRESETS`.
        """
        if name not in PRESETS:
            raise ValueError(f"preset must be one of {', '.join(PRESETS)}; got {name!r}")
        return {"default": cls, "fast": cls.fast, "fastest": cls.fastest, "paper": cls.paper}[name](**kw)


def default_align_params() -> AlignParams:
    """The default alignment: ``AlignParams(prefer_centre=3, refine="lk", smoothness=300, zero_test=2)``.

    :data:`DEFAULT_PREFER_CENTRE`, :data:`DEFAULT_REFINE`, :data:`DEFAULT_SMOOTHNESS`,
    :data:`DEFAULT_ZERO_TEST` (none in the paper or HDR+; :meth:`ReconstructParams.paper` uses
    ``AlignParams()``).
    """
    return AlignParams(prefer_centre=DEFAULT_PREFER_CENTRE, refine=DEFAULT_REFINE, smoothness=DEFAULT_SMOOTHNESS,
                       zero_test=DEFAULT_ZERO_TEST)


def exposure_planes(window: int, K: int, step: int) -> float:
    """Noise-equivalent window of ``I_l``, in planes: what a count-domain denoiser is told.

    ``I_0`` is one window (``W``); ``I_1`` sums ``K`` windows (Eq. 14: ``K W``); ``I_l`` for
    ``l ≥ 2`` averages ``K`` overlapping ``I_{l−1}`` (Eq. 15), so window ``j`` of the support
    carries the weight ``c_j`` of the ``l``-fold convolution of ``K`` equal weights, and the
    mean's variance is that of ``W / Σ c_j²`` planes (``K = 3, l = 2``: ``81/19 W ≈ 4.26 W``
    rather than the support's ``5 W``).  Warping's interpolation is ignored.
    """
    if step <= 0 or K == 1:
        return float(window)
    c = np.ones(1)
    for _ in range(step):
        c = np.convolve(c, np.ones(K))
    c /= c.sum()
    return float(window / np.sum(c * c))


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


def support_planes(window: int = 10, K: int = 3, L: int = 3) -> int:
    """Planes one output frame needs: ``((K − 1)L + 1)·W`` (Eq. 14–15, the pseudo-long exposure)."""
    return ReconstructParams(window=window, K=K, L=L).support_windows * window


def frame_range(n_planes: int, window: int = 10, K: int = 3, L: int = 3) -> range:
    """Output frame numbers of a recording of ``n_planes`` planes: ``range(Lh, T//W − Lh)``."""
    p = ReconstructParams(window=window, K=K, L=L)
    return range(p.reach, n_planes // window - p.reach)


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

    def __call__(self, batch):
        with self._rec.timed("network"):
            return self._net(batch)

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
    """

    def __init__(self, stream: SpikeStream, params: ReconstructParams | None = None, denoiser=None,
                 hot_pixels=None):
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
        state = _State(self, keep_steps)
        for k in range(start, stop):
            t0 = time.perf_counter()
            frame = state.output(k, keep_steps)
            state.evict(k + 1)
            self.busy_seconds += time.perf_counter() - t0
            self.frames_made += 1
            yield frame

    def __iter__(self) -> Iterator[np.ndarray]:
        for frame in self.frames():
            yield frame.rgb

    def __len__(self) -> int:
        return len(self.frames_available)


class _State:
    """The per-step rings of one pass over increasing frame numbers."""

    def __init__(self, rec: Reconstructor, keep_flows: bool = False):
        self.rec = rec
        self.timed = rec.timed
        self.p = rec.params
        self.stream = rec.stream
        self.keep_flows = keep_flows
        # step l: {k: [I_l(k) planes, D(I_l(k)) planes or None, luma or None, F_{l-1}(k, ·) if kept,
        #               (raw luma, its local noise, its noise variance) of the noise-aware search or None]}
        self.rings: list[dict] = [dict() for _ in range(self.p.L + 1)]
        self.step0: dict[int, np.ndarray] = {}  # F_0(k, ·) of warp="chained" and of the adaptive support
        self.merge_windows: dict[int, np.ndarray] = {}  # the robust merge's effective windows per pixel, by frame
        self.counts: dict[int, np.ndarray] = {}

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
        repair = self.rec._repair
        if repair is None:
            return planes
        return repair.planes(planes.astype(np.float32))  # counts become float32, as charges are

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
                out = np.asarray(self.rec._denoise(entry[0], exposure, final, short), dtype=np.float32)
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
                    image = flow_luma(planes, FLOW_SMOOTHING_SIGMA)  # the module's value at call time
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
        if step == 1:  # Eq. 14: the spike planes of K windows
            counts = np.stack([self.window_counts(j) for j in neighbours])
            with self.timed("warp"):
                return warp_spike_windows(counts, fl, p.window), fl
        frames = np.stack([self.planes(step - 1, j) for j in neighbours])  # Eq. 15
        with self.timed("warp"):
            return warp_average(frames, fl), fl

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
            samples, kept, pos = composed_samples(counts, bank, hops, targets, p.window)
        n, reach = counts.shape[0], p.reach
        weights = [kept]  # Eq. 14–15's path counts: the core windows' base weights
        samples = [samples]
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
                    more, ok = chained_samples(more_counts, end, flows, p.window)
                if step > 0:
                    samples.append(more)
                    weights.append(ok)
                else:
                    samples.insert(0, more[::-1])
                    weights.insert(0, ok[::-1])
                    offset = len(js)
        samples, weights = np.concatenate(samples), np.concatenate(weights)
        core = np.zeros(samples.shape[0], bool)
        core[offset:offset + n] = True
        with self.timed("warp"):
            reference = counts[reach].astype(np.float64) / p.window
            noise = np.stack([local_noise(plane) for plane in reference])
            est, windows = robust_merge(samples, weights, noise, offset + reach, core, MergeParams(shells=shells),
                                        check=False)
        self.merge_windows[k] = windows
        return est

    # output ------------------------------------------------------------
    def finish(self, planes: np.ndarray) -> np.ndarray:
        with self.timed("demosaic"):
            mosaic = bayer_mosaic(planes, self.stream.cfa or "RGGB")
            if not self.stream.cfa:
                return mosaic
            return demosaic(mosaic, self.stream.cfa, self.p.demosaic)

    def output(self, k: int, keep_steps: bool) -> ReconstructedFrame:
        L = self.p.L
        rgb = self.finish(self.denoised(L, k)).astype(np.float32, copy=False)
        windows = self.merge_windows.get(k)
        frame = ReconstructedFrame(index=k, rgb=rgb,
                                   exposure=None if windows is None else windows * np.float32(self.p.window))
        if keep_steps:
            frame.steps = [self.finish(self.denoised(step, k)) for step in range(L + 1)]
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
        for key in [key for key in self.merge_windows if key < next_k]:
            del self.merge_windows[key]


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
