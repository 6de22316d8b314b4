"""Motion between frames for progressive warping (§4.2): HDR+ hierarchical tile alignment.

The paper estimates the flow ``F_l`` of Eq. 14–15 with "off-the-shelf" multi-frame alignment
(supplement §8, "Progressive warping", citing HDR+): a 4-level Gaussian pyramid (scales 1, ½,
¼, ⅛), matching searched from the coarsest level to the finest, and *larger patches for the
noisy early steps, progressively smaller later*.  This module is that alignment, after
Hasinoff et al. 2016, "Burst photography for high dynamic range and low-light imaging on
mobile cameras", §4 and its supplement, run on one single-channel image per frame on the
Bayer-plane grid (``h × w = H/2 × W/2``; the pipeline feeds the 2×2 :func:`luma` of the
denoised planes ``D(I_l)``).

Flow convention
---------------
The flow is ``(2, h, w)`` float32, ``(dy, dx)`` in pixels of the plane grid, with

    ``alternate[y + dy, x + dx] ≈ reference[y, x]``

so backward warping of ``alternate`` by the flow (:func:`spikeref.warp.warp_bilinear`)
reproduces ``reference``.  It is the ``F(x, t, t')`` of Eq. 14–15 with ``t`` the reference
window and ``t'`` the alternate's.

Interpretations (``docs/equations.md``; the paper names HDR+ and the pyramid, nothing finer)
-------------------------------------------------------------------------------
* **Pyramid.**  Level 0 is the image (float32).  Level ``k+1`` is level ``k`` blurred by the
  separable 5-tap binomial ``[1, 4, 6, 4, 1] / 16`` (a Gaussian of σ = 1 pixel; borders
  replicate the edge pixel), vertical pass then horizontal pass in float64, then every
  second pixel kept (rows and columns 0, 2, 4, …), so a level of size ``n`` gives
  ``ceil(n / 2)`` and level-``(k+1)`` pixel ``p`` sits at level-``k`` pixel ``2p``.
* **Tiles.**  At every level tiles overlap by half: the tile size ``T`` is
  ``params.tile_for_step(step)`` at level 0 and ``params.coarse_tile`` at coarser levels,
  the stride is ``T / 2``, and there are ``(n − T) // (T/2) + 1`` tiles per axis of a level
  of size ``n`` (only tiles entirely inside the image; a right or bottom strip narrower than
  the stride belongs to no tile and takes the flow of the outermost tiles).  **Tile centres
  are in pixel-index coordinates**: tile ``i`` covers pixels ``i·T/2 … i·T/2 + T − 1`` and
  its centre is ``i·T/2 + (T − 1)/2``.
* **Minimum frame size.**  Every level ``k`` must hold one tile at scale ``2^−k`` exactly:
  ``min(h, w) ≥ coarse_tile · 2^(levels−1)`` (when ``levels > 1``) and ``≥`` the finest tile
  (:meth:`AlignParams.min_size`; 64 plane pixels with the defaults).  This is slightly
  conservative (odd sizes round up under decimation).  The pipeline aligns smaller frames with
  :meth:`AlignParams.fitted` (fewer levels, smaller finest tiles; zero flow where not even one
  tile fits) and says so in a warning.
* **Search.**  Coarse to fine; at the coarsest level the search centre is 0.  At level ``k``
  every integer offset ``u = g + d``, ``d ∈ [−r_k, r_k]²`` around the centre ``g`` is tried,
  ``r_k = params.search_radius[k]``.  The distance is the sum over the tile of
  ``(ref(p) − alt(p + u))²`` (L2) at every level but the finest, and of ``|ref(p) − alt(p + u)|``
  (L1) at the finest (as HDR+), accumulated in float64 in raster order.  Samples of
  ``alternate`` outside the image take the nearest edge pixel (clamped coordinates).
* **Ties** (so that results are deterministic and flat input gives zero flow): the smallest
  distance wins; among equal distances the offset closest to the search centre
  (smallest ``dy² + dx²``); among those the first in raster order of ``(dy, dx)`` starting
  at ``(−r, −r)``.
* **Upsampling between levels (HDR+'s 3-candidate rule).**  Vectors of level ``k+1`` are
  integers and are multiplied by 2.  A level-``k`` tile centre ``c`` sits at ``c / 2`` on the
  level-``(k+1)`` grid; per axis, the nearest coarse tile centre is found, and its neighbour
  on the side of ``c / 2`` (clamped at the borders).  The candidates are, in this order, the
  nearest coarse tile ``(m_y, m_x)``, its horizontal neighbour ``(m_y, n_x)`` and its vertical
  neighbour ``(n_y, m_x)``.  The candidate whose doubled vector has the smallest L1 distance
  for the fine tile at level ``k`` becomes the search centre (the first in that order on a
  tie).  With even tile sizes ``c / 2`` never coincides with a coarse centre nor lies halfway
  between two, so "nearest" and "side" are always defined.
* **Sub-pixel (finest level, ``params.subpixel``).**  Around the best integer offset the 3×3
  L2 distances ``D(dy, dx)``, ``dy, dx ∈ {−1, 0, 1}``, are fitted by least squares with
  ``D ≈ ½ uᵀAu + bᵀu + c`` (HDR+ supplement; here in closed form); the vector moves by
  ``u* = −A⁻¹b`` when ``A`` is positive definite and ``|u*_y|, |u*_x| ≤ 1``, else it stays on the
  integer.  "Positive definite" has a relative tolerance (:data:`PD_TOLERANCE`) so that
  round-off on a singular ``A`` never passes, and ``≤ 1`` a slack (:data:`SLACK`) so that
  ``|u*| = 1`` exactly is accepted whatever the round-off.  An exact match (``D(0, 0) = 0``)
  is kept as it is: the fit cannot improve on it, and ``reference == alternate`` then gives
  exactly zero flow.
* **Per-pixel flow** (:func:`flow_from_tiles`): the tile vectors, placed at the tile centres,
  are interpolated bilinearly; beyond the outermost centres the nearest centre's value is
  used (clamped).
* **Reach.**  The pyramid finds displacements up to ``Σ_k r_k 2^k`` plane pixels
  (1 + 8 + 16 + 32 = 57 with the defaults); beyond that the flow is finite but wrong.

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
  (:func:`level_noise_factors`).  Zero is tried at every level, even outside the search window
  around the centre, so that a spurious coarse vector is not handed down to every finer tile.

(The noise model — :func:`level_noise_factors`, :func:`local_noise`, :func:`estimate_noise_correlation`,
:data:`MIN_CORRELATION`, :func:`zero_motion_test` — is in :mod:`spikeref.align_noise`.)
``v`` is a per-pixel map at level 0 (``noise``; default :func:`local_noise` of the two images,
Immerkær's estimator over a 15×15 box: spike noise depends on the rate) carried to level ``k`` by
the pyramid's blur; ``ρ`` is ``correlation`` (default :func:`estimate_noise_correlation`), clipped
below at :data:`MIN_CORRELATION`.  With ``noise = 0`` the option is the plain search with zero motion
as one more candidate at every level.  The sub-pixel fit is unchanged.

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
then costs more than alignment gains).  :func:`align` (and the pipeline, on the raw 2×2 luma) sets the
dense flow to zero at pixels where the zero offset explains the two frames better than the flow by
more than ``z`` standard deviations of what noise gives, summed over a :data:`ZERO_TEST_BOX`-pixel box
(:func:`zero_motion_test`: the expected noise-only difference of the two squared residuals — bilinear
interpolation lowers the noise of the warped frame, and adjacent windows' noise is anti-correlated at
the zero offset — is taken out, and its variance under Gaussian noise scales the threshold).  Where the
data cannot tell the two apart (flat regions), the flow is kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spikeref._align_kernels import (
    PD_TOLERANCE, PYRAMID_KERNEL, SLACK, blur_decimate_kernel, dense_flow, gradient, jacobi_sweeps, lucas_kanade,
    search_tiles, subpixel_fit, upsample_tiles,
)
from spikeref.align_noise import (
    ZERO_TEST_BOX, apply_zero_motion, as_image, checked_correlation, level_noise_factors,
    noise_map, search_thresholds, tile_sums,
)

__all__ = [
    "PYRAMID_KERNEL",
    "PD_TOLERANCE",
    "SLACK",
    "REFINES",
    "LK_ITERATIONS",
    "SMOOTHNESS_SWEEPS",
    "AlignParams",
    "DEFAULT_PARAMS",
    "luma",
    "gaussian_pyramid",
    "align",
    "align_tiles",
    "flow_from_tiles",
]

#: The sub-pixel refinements of :attr:`AlignParams.refine`.
REFINES = ("quadratic", "lk")
#: Gauss–Newton steps of ``refine="lk"`` per tile.
LK_ITERATIONS = 2
#: Jacobi sweeps of the regularisation of ``refine="lk"`` with ``smoothness > 0``.
SMOOTHNESS_SWEEPS = 30


# ----------------------------------------------------------------------------- parameters
def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _int_tuple(name: str, value, *, minimum: int, even: bool) -> tuple[int, ...]:
    if _is_int(value) or isinstance(value, (str, bytes)):
        raise ValueError(f"{name} must be a non-empty tuple of integers; got {value!r}")
    try:
        items = tuple(value)
    except TypeError:
        raise ValueError(f"{name} must be a non-empty tuple of integers; got {value!r}") from None
    if not items:
        raise ValueError(f"{name} must be a non-empty tuple of integers; got {value!r}")
    for v in items:
        if not _is_int(v) or v < minimum or (even and v % 2):
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
        for the noisiest frames, those of step 0.  Measured (``docs/results.md``, "Alignment
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
        gives, over a :data:`ZERO_TEST_BOX`-pixel box.  ``None`` (default): off.
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
        if not _is_int(self.levels) or self.levels < 1:
            raise ValueError(f"levels must be an integer ≥ 1; got {self.levels!r}")
        object.__setattr__(self, "levels", int(self.levels))
        object.__setattr__(self, "tile_by_step", _int_tuple("tile_by_step", self.tile_by_step, minimum=2, even=True))
        if not _is_int(self.coarse_tile) or self.coarse_tile < 2 or self.coarse_tile % 2:
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
        _check_step(step)
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
            estimate, :func:`local_noise`, needs 3×3 pixels).  The pipeline then uses zero flow.
        """
        for name, v in (("height", height), ("width", width)):
            if not _is_int(v) or v < 1:
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


def _check_step(step) -> int:
    if not _is_int(step) or step < 0:
        raise ValueError(f"step must be an integer ≥ 0 (the pipeline step l); got {step!r}")
    return int(step)


# ----------------------------------------------------------------------------- kernels


def _regularise(vectors: np.ndarray, info: np.ndarray, variance: np.ndarray, lam: float,
                sweeps: int = SMOOTHNESS_SWEEPS) -> np.ndarray:
    """Tile vectors pulled towards their 4-neighbours by their confidence (``refine="lk"``, ``smoothness``).

    :data:`SMOOTHNESS_SWEEPS` Jacobi sweeps from ``û`` towards the minimiser of
    ``Σ_i (u_i − û_i)ᵀ J_i (u_i − û_i) + λ Σ_{i~j} |u_i − u_j|²`` (not run to convergence: the sweeps
    are the definition), ``J_i`` the tile's Lucas–Kanade information over its mean noise variance
    (each tile: ``u_i = (J_i + λ n_i I)⁻¹ (J_i û_i + λ Σ_j u_j)``, ``n_i`` its neighbours).
    """
    ny, nx = vectors.shape[:2]
    if ny * nx == 1 or lam <= 0:
        return vectors
    out = np.empty_like(vectors)
    jacobi_sweeps(np.ascontiguousarray(vectors, np.float64), np.ascontiguousarray(info, np.float64),
            np.ascontiguousarray(np.maximum(variance, 1e-20), np.float64), float(lam), int(sweeps), out)
    return out


# ----------------------------------------------------------------------------- checks
def _check_params(params) -> AlignParams:
    if not isinstance(params, AlignParams):
        raise TypeError(f"params must be an AlignParams; got {type(params).__name__}")
    return params


def _tile_count(size: int, tile: int) -> int:
    return (size - tile) // (tile // 2) + 1


# ----------------------------------------------------------------------------- public
def luma(planes) -> np.ndarray:
    """The 2×2 luma on the plane grid: the mean of the four Bayer planes.

    Parameters
    ----------
    planes : ndarray ``(..., 4, h, w)``, real
        Bayer planes (R, G1, G2, B in CFA-position order, ``docs/spec/README.md``), e.g. the denoised
        firing rates ``D(I_l)``.

    Returns
    -------
    ndarray ``(..., h, w)`` float32
        ``(P_0 + P_1 + P_2 + P_3) / 4`` (computed in float64): the mean of each 2×2 Bayer
        cell, the image :func:`align` works on.
    """
    arr = np.asarray(planes)
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"planes must be a real numeric array; got dtype {arr.dtype}")
    if arr.ndim < 3 or arr.shape[-3] != 4:
        raise ValueError(f"planes must have shape (..., 4, h, w) (four Bayer planes); got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("planes must be finite (no NaN or inf)")
    return arr.mean(axis=-3, dtype=np.float64).astype(np.float32)


def _blur_decimate(image: np.ndarray) -> np.ndarray:
    """One pyramid step: 5-tap binomial blur (vertical, then horizontal; edge replicate), keep even rows/cols.

    Only the kept rows and columns are computed, with the arithmetic of the whole-image NumPy
    expression (``(k0·p0 + k1·p1 + k2·p2 + k3·p3 + k4·p4) / 16`` in float64, left to right), so the
    result is the same to the bit.
    """
    img = np.ascontiguousarray(image)
    h, w = img.shape
    out = np.empty(((h + 1) // 2, (w + 1) // 2), np.float32)
    blur_decimate_kernel(img, out)
    return out


def gaussian_pyramid(image, levels: int) -> list[np.ndarray]:
    """Gaussian pyramid with scales ``1, ½, …, 2^−(levels−1)`` (supplement §8).

    Parameters
    ----------
    image : ndarray ``(h, w)`` float
        Finite image on the plane grid.
    levels : int
        Number of levels, ≥ 1.

    Returns
    -------
    list of ndarray float32
        ``levels`` arrays; level 0 is ``image`` as float32; level ``k+1`` is level ``k`` blurred
        by ``[1, 4, 6, 4, 1] / 16`` along each axis (σ = 1, edge-replicate borders, float64
        arithmetic) then decimated to rows and columns ``0, 2, 4, …`` (size ``ceil(n / 2)``).
    """
    img = as_image(image, "image")
    if not _is_int(levels) or levels < 1:
        raise ValueError(f"levels must be an integer ≥ 1; got {levels!r}")
    pyramid = [img]
    for _ in range(int(levels) - 1):
        pyramid.append(_blur_decimate(pyramid[-1]))
    return pyramid


def align_tiles(reference, alternate, step: int = 0, params: AlignParams = DEFAULT_PARAMS, noise=None,
                correlation=None) -> tuple[np.ndarray, int]:
    """Tile vectors of the finest level (HDR+ §4): the motion of each tile of ``reference`` in ``alternate``.

    Parameters
    ----------
    reference, alternate : ndarray ``(h, w)`` float32 or float64
        Finite single-channel images on the plane grid (e.g. :func:`luma` of denoised planes),
        same shape, ``min(h, w) ≥ params.min_size(step)``.
    step : int
        Pipeline step ``l`` (≥ 0); picks the finest tile size ``params.tile_for_step(step)``.
    params : AlignParams
        Pyramid, tile and search settings.
    noise : float or ndarray ``(h, w)``, optional
        Per-pixel noise variance of each image (used only with ``params.prefer_centre > 0``);
        default: :func:`local_noise` of the two images, averaged.
    correlation : float, optional
        Correlation of the two images' noise at the same pixel (used only with
        ``params.prefer_centre > 0``; clipped below at :data:`MIN_CORRELATION`); default:
        :func:`estimate_noise_correlation`.

    Returns
    -------
    vectors : ndarray ``(ty, tx, 2)`` float32
        ``(dy, dx)`` in plane pixels per finest-level tile, ``ty = (h − T) // (T/2) + 1`` (and the
        same for ``tx``); tile ``(i, j)`` covers rows ``i·T/2 … i·T/2 + T − 1`` and
        ``alternate[p + v] ≈ reference[p]`` on it.  Integers unless sub-pixel refinement moved them.
    tile : int
        The finest tile size ``T`` used.

    Raises
    ------
    TypeError
        Non-floating input or ``params`` not an :class:`AlignParams`.
    ValueError
        Non-2-D, non-finite or mismatched input, a bad ``step``, or a frame smaller than
        ``params.min_size(step)`` (the message gives the minimum).
    """
    vectors, tile, _ = _align_tiles(reference, alternate, step, params, noise, correlation)
    return vectors, tile


def _align_tiles(reference, alternate, step, params, noise, correlation):
    """:func:`align_tiles`, and the checked level-0 noise map (float64) when one was made, else None."""
    params = _check_params(params)
    step = _check_step(step)
    ref = as_image(reference, "reference")
    alt = as_image(alternate, "alternate")
    if ref.shape != alt.shape:
        raise ValueError(f"reference and alternate must have the same shape; got {ref.shape} and {alt.shape}")
    h, w = ref.shape
    tile = params.tile_for_step(step)
    need = params.min_size(step)
    if min(h, w) < need:
        raise ValueError(f"reference is {h}×{w} on the plane grid; alignment with levels={params.levels}, "
                         f"coarse_tile={params.coarse_tile} (finest tile {tile} at step {step}) needs at least "
                         f"{need}×{need}")
    ref_pyr = gaussian_pyramid(ref, params.levels)
    alt_pyr = gaussian_pyramid(alt, params.levels)
    noise_pyr = factors = noise0 = None
    rho = 0.0
    if params.prefer_centre > 0 or (params.subpixel and params.smoothness > 0):
        noise0 = noise_map(noise, ref.shape, ref, alt)
    elif noise is not None:  # validated even when unused
        noise_map(noise, ref.shape, ref, alt)
    if params.prefer_centre > 0:
        noise_pyr = [noise0]
        for _ in range(params.levels - 1):  # the local mean variance under each level's pixels
            noise_pyr.append(_blur_decimate(noise_pyr[-1]).astype(np.float64))
        factors = level_noise_factors(params.levels)
        rho = checked_correlation(correlation, ref, alt)
    elif correlation is not None:  # validated even when unused
        checked_correlation(correlation, ref, alt)
    vectors = None  # integer vectors of the previous (coarser) level
    for k in range(params.levels - 1, -1, -1):
        t = tile if k == 0 else params.coarse_tile
        r_img, a_img = ref_pyr[k], alt_pyr[k]
        shape = (_tile_count(r_img.shape[0], t), _tile_count(r_img.shape[1], t), 2)
        if noise_pyr is None:
            bias, thresh = np.zeros(shape[:2]), np.full(shape[:2], -1.0)
        else:
            bias, thresh = search_thresholds(noise_pyr[k], factors[k], t, shape[:2], k > 0, params.prefer_centre, rho)
        centre = np.zeros(shape, np.int64)
        if vectors is not None:
            up_bias = bias  # zeros when off; else the L1 bias, as the candidates are compared by L1
            if noise_pyr is not None and k > 0:
                up_bias = search_thresholds(noise_pyr[k], factors[k], t, shape[:2], False, 0.0, rho)[0]
            upsample_tiles(r_img, a_img, t, vectors, params.coarse_tile, up_bias, centre)
        vectors = np.empty(shape, np.int64)
        search_tiles(r_img, a_img, t, centre, params.search_radius[k], k > 0, bias, thresh, vectors)
    out = np.empty(vectors.shape, np.float32)
    if params.subpixel and params.refine == "lk":
        refined = np.empty(vectors.shape, np.float64)
        info = np.empty(vectors.shape[:2] + (3,), np.float64)
        gy = np.empty(alt_pyr[0].shape)
        gx = np.empty(alt_pyr[0].shape)
        gradient(alt_pyr[0], gy, gx)
        lucas_kanade(ref_pyr[0], alt_pyr[0], gy, gx, tile, vectors, LK_ITERATIONS, refined, info)
        if params.smoothness > 0:
            variance = tile_sums(noise0, tile, vectors.shape[:2]) / (tile * tile)
            refined = _regularise(refined, info, variance, params.smoothness)
        out[...] = refined
    elif params.subpixel:
        subpixel_fit(ref_pyr[0], alt_pyr[0], tile, vectors, out)
    else:
        out[...] = vectors
    return out, tile, noise0


def flow_from_tiles(vectors, tile: int, shape) -> np.ndarray:
    """Per-pixel flow from tile vectors: bilinear between tile centres, clamped beyond the outer ones.

    Parameters
    ----------
    vectors : ndarray ``(ty, tx, 2)`` float
        ``(dy, dx)`` per tile in plane pixels (:func:`align_tiles`).
    tile : int
        Tile size ``T`` (even, ≥ 2); tile ``i`` has its centre at ``i·T/2 + (T − 1)/2``
        (pixel-index coordinates).
    shape : (int, int)
        ``(h, w)`` of the frame; ``(ty, tx)`` must be the tile grid of that frame,
        ``ty = (h − T) // (T/2) + 1``.

    Returns
    -------
    ndarray ``(2, h, w)`` float32
        ``(dy, dx)`` per pixel, convention ``alternate[y + dy, x + dx] ≈ reference[y, x]``.
    """
    if not _is_int(tile) or tile < 2 or tile % 2:
        raise ValueError(f"tile must be an even integer ≥ 2; got {tile!r}")
    try:
        h, w = (int(s) for s in shape)
    except (TypeError, ValueError):
        raise ValueError(f"shape must be (h, w); got {shape!r}") from None
    if h < tile or w < tile:
        raise ValueError(f"shape {h}×{w} holds no tile of size {tile}")
    arr = np.asarray(vectors)
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"vectors must be a real numeric array; got dtype {arr.dtype}")
    grid = (_tile_count(h, tile), _tile_count(w, tile))
    if arr.shape != grid + (2,):
        raise ValueError(f"vectors must have shape {grid + (2,)} (the {grid[0]}×{grid[1]} tiles of size {tile} of a "
                         f"{h}×{w} frame, (dy, dx) each); got {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.all(np.isfinite(arr)):
        raise ValueError("vectors must be finite (no NaN or inf)")
    out = np.empty((2, h, w), np.float32)
    dense_flow(arr, int(tile), out)
    return out


def align(reference, alternate, step: int = 0, params: AlignParams = DEFAULT_PARAMS, noise=None,
          correlation=None, raw=None) -> np.ndarray:
    """Dense flow from ``reference`` to ``alternate``: HDR+ tile alignment, then bilinear interpolation.

    ``align(r, a, step, params) == flow_from_tiles(*align_tiles(r, a, step, params), r.shape)``.

    Parameters
    ----------
    reference, alternate : ndarray ``(h, w)`` float32 or float64
        Finite single-channel images on the plane grid, same shape,
        ``min(h, w) ≥ params.min_size(step)`` (64 with the defaults).
    step : int
        Pipeline step ``l`` (≥ 0): the finest tile size is ``params.tile_for_step(step)``.
    params : AlignParams
        Pyramid, tile and search settings.
    noise : float or ndarray ``(h, w)``, optional
        Per-pixel noise variance of the images, for ``params.prefer_centre > 0``
        (:func:`align_tiles`).
    correlation : float, optional
        Correlation of the images' noise at the same pixel, for ``params.prefer_centre > 0``
        (:func:`align_tiles`).
    raw : (ndarray, ndarray), optional
        The frames :func:`zero_motion_test` compares when ``params.zero_test`` is set (``noise`` and
        ``correlation`` describe them); default ``(reference, alternate)``.  The pipeline gives the
        2×2 luma before smoothing.

    Returns
    -------
    ndarray ``(2, h, w)`` float32
        ``(dy, dx)`` in plane pixels with ``alternate[y + dy, x + dx] ≈ reference[y, x]`` —
        ``F(x, t, t')`` of Eq. 14–15 for reference window ``t`` and alternate window ``t'``.
    """
    vectors, tile, noise0 = _align_tiles(reference, alternate, step, params, noise, correlation)
    h, w = np.shape(reference)
    out = np.empty((2, h, w), np.float32)
    dense_flow(vectors, tile, out)
    if params.zero_test is not None:
        r_img, a_img = (reference, alternate) if raw is None else raw
        r_img, a_img = as_image(r_img, "raw reference"), as_image(a_img, "raw alternate")
        if r_img.shape != (h, w) or a_img.shape != (h, w):
            raise ValueError(f"raw must be two images of the reference's shape {(h, w)}; got {r_img.shape} and "
                             f"{a_img.shape}")
        v = noise0 if noise is not None and noise0 is not None else noise_map(noise, (h, w), r_img, a_img)
        rho = checked_correlation(correlation, r_img, a_img)
        out = apply_zero_motion(out, r_img, a_img, params.zero_test, v, rho, ZERO_TEST_BOX)
    return out


from spikeref._callable import make_module_callable  # noqa: E402

make_module_callable(__name__, "align")  # `sr.align(...)` works whichever import came first
