"""Parameters of the alignment (:mod:`spikeref.align`, §4.2): HDR+'s pyramid and search, and the options beyond them.

:class:`AlignParams` with its defaults is HDR+'s alignment as the paper uses it (supplement §8);
the options below are not in the paper or HDR+ and are off in ``AlignParams()`` (the pipeline turns
them on: :func:`spikeref.pipeline.default_align_params`).

Noise-aware search (an option: ``AlignParams.prefer_centre = z > 0``; not in the paper or HDR+)
---------------------------------------------------------------------------------------------
The plain arg-min has two failure modes on noisy spike frames of a still scene, both measured on
the SpikingSIM real recording (``scripts/study_align_real.py``, docs/results.md): alignment plus
warping there scores 2.9 dB below plain accumulation over the same support.

* **Anti-correlated noise penalises zero motion.**  Integrate-and-fire carries each pixel's
  residual charge from one window into the next, so the count noise of adjacent windows has
  correlation ``ρ ≈ −½`` (−0.49 measured on the real recording, for W = 10, 20, 30).  At the
  zero offset the difference of the two frames then has variance ``2v(1 − ρ) = 3v``, at any
  other offset ``2v``: in a flat region every non-zero offset beats zero.  The zero offset's
  distance is therefore lowered by its expected excess ``E[D(0)] − E[D(u)]`` (``Σ −2ρv`` for the
  L2 distance, ``Σ √(2/π)(√(1−ρ) − 1)√(2v)`` for L1; ``ρ ≥ 0`` is left alone), in the search at
  every level and among the upsampling candidates.
* **Spurious matches in flat regions.**  At every level the zero vector, else the search centre
  (the upsampled vector), is kept unless the best offset's distance is lower than its distance by
  more than ``z`` standard deviations of ``D(c) − D(u)`` under white noise — ``√(12 S_k Σ v_k²)``
  (L2) or ``√(1.128 Σ v_k)`` (L1) over the tile, ``v_k`` the noise variance of a level-``k``
  pixel and ``S_k`` the inflation by the pyramid blur's spatial correlation
  (:func:`~spikeref.align_noise.level_noise_factors`).  Zero is tried at every level, even outside the
  search window around the centre, so that a spurious coarse vector is not handed down to every finer tile.

(The noise model — :func:`~spikeref.align_noise.level_noise_factors`, :func:`~spikeref.align_noise.local_noise`,
:func:`~spikeref.align_noise.estimate_noise_correlation`, :data:`~spikeref.align_noise.MIN_CORRELATION`,
:func:`~spikeref.align_noise.zero_motion_test` — is in :mod:`spikeref.align_noise`.)
``v`` is a per-pixel map at level 0 (``noise``; default :func:`~spikeref.align_noise.local_noise` of the two
images, Immerkær's estimator over a 15×15 box: spike noise depends on the rate) carried to level ``k`` by
the pyramid's blur; ``ρ`` is ``correlation`` (default :func:`~spikeref.align_noise.estimate_noise_correlation`),
clipped below at :data:`~spikeref.align_noise.MIN_CORRELATION`.  With ``noise = 0`` the option is the plain
search with zero motion as one more candidate at every level.  The sub-pixel fit is unchanged.

Sub-pixel refinement by Lucas–Kanade (an option: ``AlignParams.refine = "lk"``; not in the paper or HDR+)
-------------------------------------------------------------------------------------------------------
Measured on the benchmark scenes (issue 32, ``scripts/study_align_lk.py``): with flows on smoothed
frames, HDR+'s quadratic through the 3×3 L2 distances is the largest part of the flow error, and it
grows with the step (end-point error 0.12 → 0.24 plane px from step 0 to step 2 on a photograph
turning 0.4° per window, 0.12 → 0.27 on a static scene): around a kept zero vector the fit follows the
noise, and at steps ≥ 1 the frames of neighbouring windows share most of their support, so their
common noise — warped by the previous step's flows — gives the cost surface a minimum of its own.
``refine="lk"`` replaces the fit by :data:`LK_ITERATIONS` Gauss–Newton steps of a translation per
tile from the integer vector: ``Δu = G⁻¹ Σ g (ref(p) − alt(p + u))`` with ``g`` the central-difference
gradient of ``alternate`` (one-sided at the border, as ``numpy.gradient``) and both sampled bilinearly at ``p + u``,
``G = Σ g gᵀ``; a step is clamped to ±1 pixel per component, a singular ``G`` stops the steps, and
samples whose moved position lies outside the image are left out.  Identical images give ``Δu = 0``
(zero flow stays exactly zero).

``smoothness = λ > 0`` then regularises the tile field by each tile's confidence: with
``J_i = G_i / v_i`` (``v_i`` the tile's mean noise variance, the ``noise`` map as for the noise-aware
search), the vectors move towards the minimiser of ``Σ_i (u_i − û_i)ᵀ J_i (u_i − û_i) + λ Σ_{i~j} |u_i − u_j|²``
over the 4-neighbours by :data:`SMOOTHNESS_SWEEPS` Jacobi sweeps from the Lucas–Kanade vectors ``û``
(the sweeps are the definition: where ``J`` is small next to ``λ`` they stop short of the minimiser,
by up to 0.5 px on the golden case ``align_lk_regularised``, a milder pull than the minimiser's): a tile
whose texture pins its motion keeps it, one whose estimate is mostly noise (flat, dark) takes its
neighbours'.  ``λ`` is in units of one pixel's information (a pixel whose gradient equals the noise
standard deviation).

Per-pixel zero-motion test (an option: ``AlignParams.zero_test = z``; not in the paper or HDR+)
---------------------------------------------------------------------------------------------
Tile vectors interpolated between tile centres carry a moving object's motion onto the still pixels
beside it (the benchmark's fan: 0.64 plane px of mean flow on its still background, where warping
then costs more than alignment gains).  :func:`spikeref.align.align` (and the pipeline, on the raw 2×2
luma) sets the dense flow to zero at pixels where the zero offset explains the two frames better than the
flow by more than ``z`` standard deviations of what noise gives, summed over a
:data:`~spikeref.align_noise.ZERO_TEST_BOX`-pixel box (:func:`~spikeref.align_noise.zero_motion_test`: the
expected noise-only difference of the two squared residuals — bilinear interpolation lowers the noise of
the warped frame, and adjacent windows' noise is anti-correlated at the zero offset — is taken out, and
its variance under Gaussian noise scales the threshold).  Where the data cannot tell the two apart (flat
regions), the flow is kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spikeref.align_noise import as_image, is_integer

__all__ = ["REFINES", "LK_ITERATIONS", "SMOOTHNESS_SWEEPS", "AlignParams", "DEFAULT_PARAMS", "check_step",
           "check_pair"]

#: The sub-pixel refinements of :attr:`AlignParams.refine`.
REFINES = ("quadratic", "lk")
#: Gauss–Newton steps of ``refine="lk"`` per tile.
LK_ITERATIONS = 2
#: Jacobi sweeps of the regularisation of ``refine="lk"`` with ``smoothness > 0``.
SMOOTHNESS_SWEEPS = 30


def _int_tuple(name: str, value, *, minimum: int, even: bool) -> tuple[int, ...]:
    if is_integer(value) or isinstance(value, (str, bytes)):
        raise ValueError(f"{name} must be a non-empty tuple of integers; got {value!r}")
    try:
        items = tuple(value)
    except TypeError:
        raise ValueError(f"{name} must be a non-empty tuple of integers; got {value!r}") from None
    if not items:
        raise ValueError(f"{name} must be a non-empty tuple of integers; got {value!r}")
    for v in items:
        if not is_integer(v) or v < minimum or (even and v % 2):
            kind = f"even integers ≥ {minimum}" if even else f"integers ≥ {minimum}"
            raise ValueError(f"{name} must hold {kind}; got {value!r}")
    return tuple(int(v) for v in items)


@dataclass(frozen=True)
class AlignParams:
    """Alignment parameters (defaults documented with their source).

    Parameters
    ----------
    levels : int
        Pyramid levels, ≥ 1: 4 gives scales 1, ½, ¼, ⅛ (paper supplement §8, "Progressive
        warping": "downsampling … with the scales of ½, ¼, and ⅛ … each group of multi-scale
        maps contains 4 frames").
    tile_by_step : tuple of int
        Finest-level tile size (plane pixels, even, ≥ 2) for pipeline step ``l = 0, 1, 2, …``;
        the last value serves every later step.  ``(32, 16, 8)``: large tiles while frames are
        noisy, halved at each step (supplement: "larger patch sizes for these initial frames,
        progressively decreasing the patch size"); 16 and 8 are HDR+'s two tile sizes, 32 is
        for the noisiest frames, those of step 0.  Measured (``docs/results_history.md``, "Alignment
        tile sizes"): against ``(16, 16, 8)`` the flow error on a translating texture falls from
        0.84 to 0.31 plane px at step 0, and the benchmark's mean PSNR rises 0.07–0.21 dB.
    coarse_tile : int
        Tile size (pixels of that level, even, ≥ 2) at every coarser level; 8 as HDR+.
    search_radius : tuple of int
        Search radius ``r_k`` (pixels of level ``k``, ≥ 0) per level, finest → coarsest;
        ``len(search_radius) == levels``.  ``(1, 4, 4, 4)`` as HDR+.
    subpixel : bool
        Quadratic sub-pixel refinement at the finest level (HDR+ supplement).
    prefer_centre : float
        Noise-aware search (not in the paper or HDR+; an option, see "Noise-aware search" in the
        module doc): at every level the zero vector, else the search centre (the upsampled
        vector), is kept unless the best offset's distance is lower by more than
        ``prefer_centre`` standard deviations of the distance difference that noise alone gives;
        and the zero offset's distance is corrected for anti-correlated noise.  ``0`` (default):
        off, the plain arg-min of HDR+.
    refine : {"quadratic", "lk"}
        The sub-pixel step at the finest level (with ``subpixel=True``): ``"quadratic"`` (default) —
        HDR+'s least-squares quadratic through the 3×3 L2 distances around the integer vector;
        ``"lk"`` (not in the paper or HDR+) — :data:`LK_ITERATIONS` Lucas–Kanade (Gauss–Newton)
        steps of a translation per tile, starting from the integer vector ("Sub-pixel refinement by
        Lucas–Kanade" in the module doc).
    smoothness : float
        With ``refine="lk"`` (not in the paper or HDR+): weight ``λ ≥ 0`` of the pull between
        neighbouring tile vectors when the refined field is regularised by the tiles' confidence
        (their Lucas–Kanade information over the noise variance, module doc).  ``0`` (default):
        off, each tile keeps its own estimate.
    zero_test : float or None
        Per-pixel zero-motion test on the dense flow (not in the paper or HDR+; "Per-pixel zero-motion
        test" in the module doc): the flow is set to zero at pixels where the zero offset explains the
        two frames better than the flow by more than ``zero_test`` standard deviations of what noise
        gives, over a :data:`~spikeref.align_noise.ZERO_TEST_BOX`-pixel box.  ``None`` (default): off.
    """

    levels: int = 4
    tile_by_step: tuple[int, ...] = (32, 16, 8)
    coarse_tile: int = 8
    search_radius: tuple[int, ...] = (1, 4, 4, 4)
    subpixel: bool = True
    prefer_centre: float = 0.0
    refine: str = "quadratic"
    smoothness: float = 0.0
    zero_test: float | None = None

    def __post_init__(self):
        if not is_integer(self.levels) or self.levels < 1:
            raise ValueError(f"levels must be an integer ≥ 1; got {self.levels!r}")
        object.__setattr__(self, "levels", int(self.levels))
        object.__setattr__(self, "tile_by_step", _int_tuple("tile_by_step", self.tile_by_step, minimum=2, even=True))
        if not is_integer(self.coarse_tile) or self.coarse_tile < 2 or self.coarse_tile % 2:
            raise ValueError(f"coarse_tile must be an even integer ≥ 2; got {self.coarse_tile!r}")
        object.__setattr__(self, "coarse_tile", int(self.coarse_tile))
        radius = _int_tuple("search_radius", self.search_radius, minimum=0, even=False)
        if len(radius) != self.levels:
            raise ValueError(f"search_radius must have one radius per level (levels={self.levels}); "
                             f"got {len(radius)}: {radius!r}")
        object.__setattr__(self, "search_radius", radius)
        if not isinstance(self.subpixel, (bool, np.bool_)):
            raise ValueError(f"subpixel must be True or False; got {self.subpixel!r}")
        object.__setattr__(self, "subpixel", bool(self.subpixel))
        z = self.prefer_centre
        if isinstance(z, (bool, np.bool_)) or not isinstance(z, (int, float, np.integer, np.floating)) \
                or not np.isfinite(z) or z < 0:
            raise ValueError(f"prefer_centre must be a finite number ≥ 0 (standard deviations of noise; 0: off); "
                             f"got {z!r}")
        object.__setattr__(self, "prefer_centre", float(z))
        if not isinstance(self.refine, str) or self.refine not in REFINES:
            raise ValueError(f"refine must be one of {', '.join(REFINES)}; got {self.refine!r}")
        lam = self.smoothness
        if isinstance(lam, (bool, np.bool_)) or not isinstance(lam, (int, float, np.integer, np.floating)) \
                or not np.isfinite(lam) or lam < 0:
            raise ValueError(f"smoothness must be a finite number ≥ 0 (0: off); got {lam!r}")
        if lam > 0 and self.refine != "lk":
            raise ValueError("smoothness regularises the Lucas–Kanade refinement: it needs refine='lk' "
                             f"(got refine={self.refine!r}, smoothness={lam!r})")
        object.__setattr__(self, "smoothness", float(lam))
        zt = self.zero_test
        if zt is not None:
            if isinstance(zt, (bool, np.bool_)) or not isinstance(zt, (int, float, np.integer, np.floating)) \
                    or not np.isfinite(zt) or zt < 0:
                raise ValueError(f"zero_test must be None (off) or a finite number ≥ 0 (standard deviations of "
                                 f"noise); got {zt!r}")
            object.__setattr__(self, "zero_test", float(zt))

    def tile_for_step(self, step: int) -> int:
        """Finest-level tile size for pipeline step ``step`` (≥ 0); the last entry for late steps."""
        check_step(step)
        return self.tile_by_step[min(int(step), len(self.tile_by_step) - 1)]

    def min_size(self, step: int = 0) -> int:
        """Smallest ``min(h, w)`` (plane pixels) that alignment at ``step`` accepts.

        ``max(tile_for_step(step), coarse_tile · 2^(levels−1))`` (the second term only when
        ``levels > 1``): every level ``k`` holds one tile at scale ``2^−k``.
        """
        need = self.tile_for_step(step)
        if self.levels > 1:
            need = max(need, self.coarse_tile * 2 ** (self.levels - 1))
        return need

    def fitted(self, height: int, width: int) -> "AlignParams | None":
        """These parameters cut down to fit frames of ``height × width`` plane pixels.

        The largest pyramid of these settings that such frames hold (the rule of
        :meth:`min_size`, for every step): with ``n = min(height, width)``,

        * the levels drop, coarsest first, to the most with ``coarse_tile · 2^(levels−1) ≤ n``
          (one level, the image itself, needs no coarse tile); ``search_radius`` keeps the
          radii of the levels left; ``coarse_tile`` is kept;
        * every finest tile larger than ``n`` becomes the largest even size ``≤ n``.

        Parameters
        ----------
        height, width : int
            Frame size on the plane grid (≥ 1).

        Returns
        -------
        AlignParams or None
            ``self`` when it fits already (``n ≥ min_size(step)`` for every entry of
            ``tile_by_step``); ``None`` when not even one level fits: ``n < 2`` (a tile is at
            least 2×2), or ``n < 3`` with ``prefer_centre > 0``, ``smoothness > 0`` or a ``zero_test`` (their noise
            estimate, :func:`~spikeref.align_noise.local_noise`, needs 3×3 pixels).  The pipeline then uses zero flow.
        """
        for name, v in (("height", height), ("width", width)):
            if not is_integer(v) or v < 1:
                raise ValueError(f"{name} must be an integer ≥ 1 (plane pixels); got {v!r}")
        n = int(min(height, width))
        if n >= max(self.min_size(step) for step in range(len(self.tile_by_step))):
            return self
        if n < 2 or ((self.prefer_centre > 0 or self.smoothness > 0 or self.zero_test is not None) and n < 3):
            return None
        levels = self.levels
        while levels > 1 and self.coarse_tile * 2 ** (levels - 1) > n:
            levels -= 1
        largest = n - n % 2
        return AlignParams(levels=levels, tile_by_step=tuple(min(t, largest) for t in self.tile_by_step),
                           coarse_tile=self.coarse_tile, search_radius=self.search_radius[:levels],
                           subpixel=self.subpixel, prefer_centre=self.prefer_centre, refine=self.refine,
                           smoothness=self.smoothness, zero_test=self.zero_test)


#: The default parameters (the default of every ``params`` argument).
DEFAULT_PARAMS = AlignParams()


def check_step(step) -> int:
    """``step`` as an int, or a ``ValueError`` naming it: a pipeline step is an integer ≥ 0."""
    if not is_integer(step) or step < 0:
        raise ValueError(f"step must be an integer ≥ 0 (the pipeline step l); got {step!r}")
    return int(step)


def check_pair(reference, alternate, step, params) -> tuple[np.ndarray, np.ndarray, int]:
    """The checks of :func:`spikeref.align.align` and :func:`~spikeref.align.align_tiles`, once per call.

    Returns the two images as C-contiguous float32 (:func:`spikeref.align_noise.as_image`) and ``step`` as an int;
    raises the ``TypeError`` or ``ValueError`` those functions document, naming the argument.
    """
    if not isinstance(params, AlignParams):
        raise TypeError(f"params must be an AlignParams; got {type(params).__name__}")
    step = check_step(step)
    ref = as_image(reference, "reference")
    alt = as_image(alternate, "alternate")
    if ref.shape != alt.shape:
        raise ValueError(f"reference and alternate must have the same shape; got {ref.shape} and {alt.shape}")
    h, w = ref.shape
    need = params.min_size(step)
    if min(h, w) < need:
        raise ValueError(f"reference is {h}×{w} on the plane grid; alignment with levels={params.levels}, "
                         f"coarse_tile={params.coarse_tile} (finest tile {params.tile_for_step(step)} at step {step})"
                         f" needs at least {need}×{need}")
    return ref, alt, step
