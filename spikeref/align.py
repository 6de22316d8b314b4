"""Motion between frames for progressive warping (§4.2): HDR+ hierarchical tile alignment.

The paper estimates the flow ``F_l`` of Eq. 14–15 with "off-the-shelf" multi-frame alignment (supplement §8,
"Progressive warping", citing HDR+): a 4-level Gaussian pyramid (scales 1, ½, ¼, ⅛), matching searched from the
coarsest level to the finest, and *larger patches for the noisy early steps, progressively smaller later*.  This
module is that alignment, after Hasinoff et al. 2016, "Burst photography for high dynamic range and low-light
imaging on mobile cameras", §4 and its supplement, on one single-channel image per frame on the Bayer-plane grid
(``h × w = H/2 × W/2``).  The paper aligns the 2×2 :func:`~spikeref.bayer.luma` of the denoised planes ``D(I_l)``
(``flow_frames="denoised"``, ``ReconstructParams.paper()``); the package's default aligns a Gaussian-smoothed luma
of the planes before denoising (``flow_frames="smoothed"``, :func:`spikeref.pipeline.flow_luma`).

Flow convention
---------------
The flow is ``(2, h, w)`` float32, ``(dy, dx)`` in pixels of the plane grid, with
``alternate[y + dy, x + dx] ≈ reference[y, x]``, so backward warping of ``alternate`` by the flow
(:func:`spikeref.warp.warp_bilinear`) reproduces ``reference``: the ``F(x, t, t')`` of Eq. 14–15 with ``t`` the
reference window and ``t'`` the alternate's.

Interpretations (the paper names HDR+ and the pyramid, nothing finer)
---------------------------------------------------------------------
Each rule is written out exactly, for a port, in the section of ``docs/spec/align.md`` in brackets.

* [Pyramid] level ``k+1`` is level ``k`` blurred by ``[1, 4, 6, 4, 1] / 16`` per axis (edge-replicate,
  float64), every second row and column kept (``ceil(n / 2)``): :mod:`spikeref.pyramid`.
* [Tiles] size ``params.tile_for_step(step)`` at level 0, ``params.coarse_tile`` above, overlapping by
  half, only tiles wholly inside the level, tile ``i`` centred at ``i·T/2 + (T − 1)/2``.  Frames must
  hold one tile at every level (:meth:`AlignParams.min_size`: 64 plane pixels with the defaults).
* [Tile distance, Integer search] coarse to fine, every integer offset within
  ``params.search_radius[k]`` of the centre; L2 at the coarse levels, L1 at the finest (as HDR+),
  float64, raster order, samples outside the image clamped to the edge; ties go to the offset
  nearest the centre, then the first in raster order, so flat input gives zero flow.
* [Upsampling between levels, Choosing among the candidates] HDR+'s three candidates (the nearest
  coarse tile and its horizontal and vertical neighbours on the fine tile's side), doubled; the one
  with the smallest L1 distance becomes the search centre.
* [Sub-pixel fit] HDR+'s least-squares quadratic through the 3×3 L2 distances around the integer
  vector, kept when ``A`` is positive definite (:data:`PD_TOLERANCE`) and the move is within ±1
  pixel (:data:`SLACK`); an exact match stays as it is.
* [Per-pixel flow] the tile vectors at the tile centres, interpolated bilinearly; beyond the
  outermost centres the nearest centre's value.  The reach is ``Σ_k r_k 2^k`` plane pixels (57).

The options beyond HDR+ (a noise-aware search, Lucas–Kanade steps with a regularised tile field, a
per-pixel zero-motion test) are described with their parameters in :mod:`spikeref.align_params`.
"""

from __future__ import annotations

import numpy as np

from spikeref._align_kernels import (
    PD_TOLERANCE, SLACK, dense_flow, gradient, lucas_kanade, regularise, search_fit_tiles, search_tiles, subpixel_fit,
    upsample_tiles,
)
from spikeref.bayer import luma
from spikeref.align_params import DEFAULT_PARAMS, LK_ITERATIONS, REFINES, SMOOTHNESS_SWEEPS, AlignParams, check_pair
from spikeref.align_noise import (
    ZERO_TEST_BOX, apply_zero_motion, is_integer, level_noise_factors, noise_inputs, search_thresholds, tile_sums,
    zero_motion_inputs,
)
from spikeref.pyramid import PYRAMID_KERNEL, gaussian_pyramid, pyramid_levels

__all__ = [
    "align", "align_tiles", "flow_from_tiles", "luma", "gaussian_pyramid", "AlignParams", "DEFAULT_PARAMS",
    "PYRAMID_KERNEL", "PD_TOLERANCE", "SLACK", "REFINES", "LK_ITERATIONS", "SMOOTHNESS_SWEEPS",
]


def _tile_count(size: int, tile: int) -> int:
    return (size - tile) // (tile // 2) + 1


# ----------------------------------------------------------------------------- public
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
        Per-pixel noise variance of each image, used by the noise-aware search (``params.prefer_centre > 0``)
        and by the regularised Lucas–Kanade field (``refine="lk"`` with ``smoothness > 0``); default:
        :func:`spikeref.align_noise.local_noise` of the two images, averaged.  The pipeline gives the variance
        of the raw frames (before denoising or smoothing) whatever images it aligns.
    correlation : float, optional
        Correlation of the two images' noise at the same pixel (used only with ``params.prefer_centre > 0``;
        clipped below at :data:`spikeref.align_noise.MIN_CORRELATION`); default:
        :func:`spikeref.align_noise.estimate_noise_correlation`.

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
    ref, alt, step = check_pair(reference, alternate, step, params)
    return _tiles(ref, alt, step, params, *noise_inputs(ref, alt, params, noise, correlation))


def _tiles(ref, alt, step, params, noise0, rho) -> tuple[np.ndarray, int]:
    """:func:`align_tiles` on checked images, with the noise map and correlation of
    :func:`spikeref.align_noise.noise_inputs`."""
    tile = params.tile_for_step(step)
    ref_pyr, alt_pyr = pyramid_levels(ref, params.levels), pyramid_levels(alt, params.levels)
    # the distances are float64 sums of float64 differences: the kernels read float64 copies (the same values)
    ref64, alt64 = [lvl.astype(np.float64) for lvl in ref_pyr], [lvl.astype(np.float64) for lvl in alt_pyr]
    noise_pyr = factors = None
    if params.prefer_centre > 0:  # the local mean variance under each level's pixels
        noise_pyr = [level.astype(np.float64, copy=False) for level in pyramid_levels(noise0, params.levels)]
        factors = level_noise_factors(params.levels)
    # HDR+ (§4): coarse to fine, each level's integer search centred on the upsampled coarser vectors.  With the
    # noise-aware search off, bias = 0 and thresh = −1 (the kernels' "off"); on, they come from the noise pyramid.
    vectors = None  # integer vectors of the previous (coarser) level
    fused_fit = params.subpixel and params.refine != "lk" and params.search_radius[0] == 1
    for k in range(params.levels - 1, -1, -1):
        size = tile if k == 0 else params.coarse_tile
        r_img, a_img = ref64[k], alt64[k]
        grid = (_tile_count(r_img.shape[0], size), _tile_count(r_img.shape[1], size))
        l2 = k > 0  # L2 distances at the coarse levels, L1 at the finest
        if noise_pyr is None:
            bias, thresh = np.zeros(grid), np.full(grid, -1.0)
        else:
            bias, thresh = search_thresholds(noise_pyr[k], factors[k], size, grid, l2=l2, z=params.prefer_centre,
                                             rho=rho)
        centre = np.zeros(grid + (2,), np.int64)
        if vectors is not None:
            up_bias = bias  # zeros when off; else the L1 bias, as the candidates are compared by L1
            if noise_pyr is not None and l2:
                up_bias = search_thresholds(noise_pyr[k], factors[k], size, grid, l2=False, z=0.0, rho=rho)[0]
            upsample_tiles(r_img, a_img, size, vectors, params.coarse_tile, up_bias, centre)
        vectors = np.empty(grid + (2,), np.int64)
        if k == 0 and fused_fit:  # the search and the quadratic fit in one pass (the same values)
            out = np.empty(vectors.shape, np.float32)
            search_fit_tiles(r_img, a_img, size, centre, bias, thresh, vectors, out)
            return out, tile
        search_tiles(r_img, a_img, size, centre, params.search_radius[k], l2, bias, thresh, vectors)
    # the sub-pixel step: HDR+'s quadratic fit (the paper's), or Lucas–Kanade with the regularised field (default)
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
            refined = regularise(refined, info, variance, params.smoothness, SMOOTHNESS_SWEEPS)
        out[...] = refined
    elif params.subpixel:
        subpixel_fit(ref64[0], alt64[0], tile, vectors, out)
    else:
        out[...] = vectors
    return out, tile


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
    if not is_integer(tile) or tile < 2 or tile % 2:
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

    Without the zero-motion test (``params.zero_test=None``, as HDR+),
    ``align(r, a, step, params) == flow_from_tiles(*align_tiles(r, a, step, params), r.shape)``.

    Parameters
    ----------
    reference, alternate, step, params, noise, correlation
        As in :func:`align_tiles`.
    raw : (ndarray, ndarray), optional
        The frames :func:`spikeref.align_noise.zero_motion_test` compares when ``params.zero_test`` is set
        (``noise`` and ``correlation`` describe them); default ``(reference, alternate)``.  The pipeline gives
        the 2×2 luma before smoothing.

    Returns
    -------
    ndarray ``(2, h, w)`` float32
        ``(dy, dx)`` in plane pixels with ``alternate[y + dy, x + dx] ≈ reference[y, x]`` —
        ``F(x, t, t')`` of Eq. 14–15 for reference window ``t`` and alternate window ``t'``.
    """
    ref, alt, step = check_pair(reference, alternate, step, params)
    noise0, rho = noise_inputs(ref, alt, params, noise, correlation)
    vectors, tile = _tiles(ref, alt, step, params, noise0, rho)
    h, w = ref.shape
    out = np.empty((2, h, w), np.float32)
    dense_flow(vectors, tile, out)
    if params.zero_test is None:
        return out
    r_img, a_img, v, r = zero_motion_inputs(raw, ref, alt, noise, correlation, noise0, rho)
    return apply_zero_motion(out, r_img, a_img, float(params.zero_test), v, r, ZERO_TEST_BOX)


from spikeref._callable import make_module_callable  # noqa: E402

make_module_callable(__name__, "align")  # `sr.align(...)` works whichever import came first
