"""The settings of the reconstruction (:class:`ReconstructParams`) and the arithmetic of its support.

What :mod:`spikeref.pipeline` runs is set here: ``W``, ``K``, ``L`` of Eq. 13–15 (§4.2), the presets
(the paper's procedure one call away, :meth:`ReconstructParams.paper`), and the defaults that go beyond
the paper, each with the measurement that chose it (``docs/results.md``).  :func:`exposure_planes`,
:func:`support_planes` and :func:`frame_range` say how many planes a frame reads and which frames a
recording has (``docs/equations.md``).  No algorithm runs here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spikeref.align import AlignParams
from spikeref.charge import ACCUMULATE
from spikeref.compose import RESAMPLES
from spikeref.demosaic import DEMOSAICS
from spikeref.denoise.blindspot import MODES
from spikeref.merge import MERGES

__all__ = ["ReconstructParams", "frame_range", "support_planes", "exposure_planes", "FLOW_FRAMES",
           "FLOW_SMOOTHING_SIGMA", "WARPS", "DEFAULT_PREFER_CENTRE", "DEFAULT_REFINE", "DEFAULT_SMOOTHNESS",
           "DEFAULT_ZERO_TEST", "default_align_params", "PRESETS", "STAGES", "HOT_PIXELS", "ACCUMULATE",
           "DEFAULT_ACCUMULATE"]

#: What the flow of each step is estimated on: ``"denoised"`` — the 2×2 luma of ``D(I_l)``, as
#: Fig. 3(b) — or ``"smoothed"`` — the 2×2 luma of ``I_l`` itself, smoothed by a Gaussian.
FLOW_FRAMES = ("denoised", "smoothed")
#: ``AlignParams.prefer_centre`` of the default reconstruction (the noise-aware search; 0 in the
#: paper): chosen among 0, 2, 3, 4 on the real outdoor recording and the benchmark scenes
#: (``scripts/study_align_real.py``, docs/results.md).
DEFAULT_PREFER_CENTRE = 3.0
#: ``AlignParams.refine`` of the default reconstruction (not in the paper or HDR+): Lucas–Kanade steps
#: instead of HDR+'s quadratic fit for the sub-pixel part (docs/results_history.md, issue 32).
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
#: benchmark scenes among 0, 0.7, 1 and 1.5 (``scripts/study_flow_frames.py``, docs/results_history.md,
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
#: ``ReconstructParams.demosaic``: :mod:`spikeref.demosaic`'s of the merged frame, or every merged window's raw samples
#: (:mod:`spikeref.multiframe_demosaic`).
OUTPUT_DEMOSAICS = ("auto",) + DEMOSAICS + ("multiframe",)
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
    demosaic : {"auto", "multiframe", "bilinear", "mhc", "ddfapd"}
        The output frame's demosaic: ``"multiframe"`` — every merged window's raw Bayer samples gathered at full
        resolution with the merge's weights, so that the windows' sub-pixel motion fills in what one mosaic
        does not sample, plus a sharper demosaic's correction where the windows sampled only the reference's
        CFA phases (the directional demosaic where the colours share their detail, Malvar–He–Cutler's
        elsewhere; :mod:`spikeref.multiframe_demosaic`; not in the paper; the denoiser's change of the merged
        planes is added through Ψ); Ψ of the merged frame (``"bilinear"``, Eq. 13), Malvar–He–Cutler
        (``"mhc"``, :mod:`spikeref.demosaic`) or Menon–Andriani–Calvagno's directional demosaic (``"ddfapd"``,
        :mod:`spikeref.directional_demosaic`), both sharper and not in the paper.  ``"auto"`` (default) is
        ``"multiframe"`` where the merge is the robust or adaptive one (:attr:`merge_used`) of aligned windows,
        else ``"bilinear"`` (:attr:`demosaic_used`): on the benchmark / held-out means 31.63 / 30.67 dB
        against Ψ's 28.82 / 28.58, at about half the frames/s (``docs/results.md``, "The directional demosaic
        where the colours share their detail" and "Where the windows add no phase, and the dark level").
        Monochrome recordings have no demosaic.  The flows always use the 2×2 luma.
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
        ``docs/results_history.md``), or once per path (``"path"``, the composed warp until 2026-11-24);
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
        real recording, at 0.7× the binomial merge's frames/s.  With ``"adaptive"`` or ``"robust"`` (and
        alignment on) the steps below ``L`` merge their ``K`` frames robustly too, without shells (the embedded
        sample's steps rise, 27.48, 27.98, 28.01, 28.70 dB, where Eq. 14–15's mean put steps 1–2 under ``R_0``).
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
    demosaic: str = "auto"
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
        if self.demosaic not in OUTPUT_DEMOSAICS:
            raise ValueError(f"demosaic must be one of {', '.join(OUTPUT_DEMOSAICS)}; got {self.demosaic!r}")
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
        if self.demosaic == "multiframe" and not self.merges_windows_robustly:
            raise ValueError(f"demosaic='multiframe' needs the robust or adaptive merge of aligned windows (the merge "
                             f"here is {self.merge_used!r}{'' if self.align and self.half else ', without alignment'})")

    @property
    def demosaic_used(self) -> str:
        """The output's demosaic: :attr:`demosaic`, with ``"auto"`` resolved (``"multiframe"`` where the merge is the
        robust or adaptive one of aligned windows, else ``"bilinear"``, Eq. 13's Ψ)."""
        if self.demosaic != "auto":
            return self.demosaic
        return "multiframe" if self.merges_windows_robustly else "bilinear"

    @property
    def merges_windows_robustly(self) -> bool:
        """Whether the output is the robust or adaptive merge of aligned windows (what the multi-frame demosaic
        reads: each window's final weight and position)."""
        return self.merge_used != "binomial" and self.align and self.half > 0

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


def support_planes(window: int = 10, K: int = 3, L: int = 3) -> int:
    """Planes one output frame needs: ``((K − 1)L + 1)·W`` (Eq. 14–15, the pseudo-long exposure)."""
    return ReconstructParams(window=window, K=K, L=L).support_windows * window


def frame_range(n_planes: int, window: int = 10, K: int = 3, L: int = 3) -> range:
    """Output frame numbers of a recording of ``n_planes`` planes: ``range(Lh, T//W − Lh)``."""
    p = ReconstructParams(window=window, K=K, L=L)
    return range(p.reach, n_planes // window - p.reach)
