"""Oracle of the HDR+ tile alignment (:mod:`spikeref.align`): tiles, offsets and pixels one at a time.

A literal transcription of the module's description (§4.2 / supplement §8), written without its
kernels.  This module holds the coarse-to-fine walk (:func:`align_tiles_oracle`: every tile of every
pyramid level, 3-candidate upsampling, then the sub-pixel step), the per-pixel flow by
``numpy.interp`` (clamped linear interpolation) along each axis (:func:`flow_from_tiles_oracle`), the
whole alignment with its zero-motion test (:func:`align_oracle`), the paper's parameters
(:data:`PAPER_ALIGN`) and the golden cases that freeze them all (:data:`GOLDEN_CASES`).  The pieces
they are made of are split where the alignment's description splits (every name this module defined
before the split — :data:`__all__` and the constants ``PD_TOLERANCE`` and ``SLACK`` — is still
imported from here):

* :mod:`spikeref.oracles.align_search` — the pyramid pixel by pixel, the tile distance, the nearest
  coarse tiles by ``argmin`` over all coarse centres, and the integer search of a tile in plain loops,
  HDR+'s and the noise-aware one (``AlignParams.prefer_centre > 0``; not in the paper or HDR+) with
  its two override rules (zero motion first, then the search centre) as written in
  ``docs/spec/align.md#noise-aware-search``;
* :mod:`spikeref.oracles.align_noise` — the noise model of the noise-aware options: Immerkær's
  response pixel by pixel, the 15 × 15 box of :func:`local_noise_oracle` as a sum over its 225
  clamped offsets, the pyramid's composite kernels by written-out convolutions
  (:func:`level_noise_factors_oracle`), each tile's bias and threshold as plain sums over its pixels;
* :mod:`spikeref.oracles.align_refine` — the sub-pixel step: HDR+'s quadratic by
  ``numpy.linalg.lstsq`` on the 9 × 6 design matrix, and two options of issue 32 (not in the paper or
  HDR+; ``docs/spec/align.md#lucas-kanade-refinement`` and ``#regularised-tile-field``):
  ``AlignParams(refine="lk")`` by :func:`lucas_kanade_oracle` and ``smoothness`` by
  :func:`regularise_oracle` (``sweeps=None`` gives the exact minimiser of the stated energy);
* :mod:`spikeref.oracles.align_zero_test` — the third option of issue 32, ``zero_test``
  (``docs/spec/align.md#per-pixel-zero-motion-test``), by :func:`zero_motion_test_oracle`;
* :mod:`spikeref.oracles.align_cases` — the golden cases' inputs, pinned settings and output recipes.

The constants of the specification (``PD_TOLERANCE``, ``SLACK``, :data:`LK_ITERATIONS`,
:data:`SMOOTHNESS_SWEEPS`, :data:`ZERO_TEST_BOX`, :data:`MIN_VARIANCE`) and the paper's parameters
(:data:`PAPER_ALIGN`) are written out in the oracles; ``tests/test_align.py`` holds them equal to
:mod:`spikeref.align`'s.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from spikeref.oracles.align_cases import (
    HDRPLUS_SETTINGS, LK_SETTINGS, NOISE_AWARE_SETTINGS, hdrplus_outputs, inputs_hdrplus, inputs_lk,
    inputs_noise_aware, lk_outputs, noise_aware_outputs,
)
from spikeref.oracles.align_noise import (
    bias_and_threshold_oracle, estimate_noise_correlation_oracle, estimate_noise_oracle, immerkaer_response_oracle,
    level_noise_factors_oracle, local_noise_oracle, noise_inputs_oracle,
)
from spikeref.oracles.align_refine import (
    LK_ITERATIONS, MIN_VARIANCE, SMOOTHNESS_SWEEPS, bilinear_oracle, gradient_oracle, lucas_kanade_oracle,
    quadratic_offset_oracle, refine_lk_oracle, regularise_oracle, tile_noise_oracle,
)
from spikeref.oracles.align_refine import PD_TOLERANCE, SLACK  # noqa: F401 - named here by tests/test_align.py
from spikeref.oracles.align_search import (
    gaussian_pyramid_oracle, nearest_tiles_oracle, noise_aware_search_oracle, search_oracle, tile_centres,
    tile_distance_oracle,
)
from spikeref.oracles.align_zero_test import ZERO_TEST_BOX, zero_motion_sums_oracle, zero_motion_test_oracle
from spikeref.oracles.case import OracleCase

__all__ = [
    "PAPER_ALIGN",
    "case_align_params",
    "gaussian_pyramid_oracle",
    "tile_distance_oracle",
    "nearest_tiles_oracle",
    "quadratic_offset_oracle",
    "align_tiles_oracle",
    "flow_from_tiles_oracle",
    "align_oracle",
    "immerkaer_response_oracle",
    "estimate_noise_oracle",
    "local_noise_oracle",
    "estimate_noise_correlation_oracle",
    "level_noise_factors_oracle",
    "noise_aware_search_oracle",
    "LK_ITERATIONS",
    "SMOOTHNESS_SWEEPS",
    "ZERO_TEST_BOX",
    "MIN_VARIANCE",
    "gradient_oracle",
    "bilinear_oracle",
    "lucas_kanade_oracle",
    "tile_noise_oracle",
    "regularise_oracle",
    "zero_motion_sums_oracle",
    "zero_motion_test_oracle", "GOLDEN_CASES"]

#: The paper's alignment parameters (§4.2, HDR+'s pyramid), as :class:`spikeref.align.AlignParams`
#: gives them by default; written out so the oracle reads no fast code (``tests/test_align.py``
#: holds the two equal).
PAPER_ALIGN = SimpleNamespace(levels=4, tile_by_step=(32, 16, 8), coarse_tile=8, search_radius=(1, 4, 4, 4),
                              subpixel=True, prefer_centre=0.0, refine="quadratic", smoothness=0.0, zero_test=None)


def _default_params():
    return PAPER_ALIGN


# ----------------------------------------------------------------------------- the alignment
def align_tiles_oracle(reference, alternate, step=0, params=None, noise=None, correlation=None):
    """``(vectors (ty, tx, 2) float32, tile)``: coarse-to-fine search with 3-candidate upsampling, then sub-pixel.

    With ``params.prefer_centre = z > 0`` the search is the noise-aware one
    (``docs/spec/align.md#noise-aware-search``): ``noise`` is the level-0 noise variance of each image
    (a number or an ``(h, w)`` map; default ``½ (local_noise(ref) + local_noise(alt))``) and
    ``correlation`` the correlation ``ρ`` of the two images' noise at the same pixel (default
    :func:`estimate_noise_correlation_oracle`), clipped below at −½.  Both are ignored when ``z = 0``.

    With ``params.subpixel`` and ``params.refine = "lk"`` the sub-pixel step is :func:`lucas_kanade_oracle`
    from each tile's integer vector instead of the quadratic fit; with ``params.smoothness = λ > 0`` the
    refined field is then :func:`regularise_oracle` with each tile's information over its mean noise
    variance (:func:`tile_noise_oracle` of the same ``noise``: given, or estimated from the two images).
    """
    params = _default_params() if params is None else params
    tile = params.tile_by_step[min(step, len(params.tile_by_step) - 1)]
    ref_pyr = gaussian_pyramid_oracle(reference, params.levels)
    alt_pyr = gaussian_pyramid_oracle(alternate, params.levels)
    z = params.prefer_centre
    if z > 0:
        noise_pyr, factors, rho = noise_inputs_oracle(ref_pyr[0], alt_pyr[0], params.levels, noise, correlation)
    coarse = None  # {(i, j): (vy, vx)} of the previous level, and its image size and tile size
    for k in range(params.levels - 1, -1, -1):
        ref, alt = ref_pyr[k], alt_pyr[k]
        t = tile if k == 0 else params.coarse_tile
        cy, cx = tile_centres(ref.shape[0], t), tile_centres(ref.shape[1], t)
        vectors = {}
        for i in range(len(cy)):
            for j in range(len(cx)):
                oy, ox = i * (t // 2), j * (t // 2)
                if z > 0:
                    bias, thresh = bias_and_threshold_oracle(noise_pyr[k], factors[k], oy, ox, t, k > 0, z, rho)
                    up_bias = bias_and_threshold_oracle(noise_pyr[k], factors[k], oy, ox, t, False, z, rho)[0]
                if coarse is None:
                    centre = (0, 0)
                else:
                    vecs, (ch, cw) = coarse
                    my, ny = nearest_tiles_oracle(cy[i], ch, params.coarse_tile)
                    mx, nx = nearest_tiles_oracle(cx[j], cw, params.coarse_tile)
                    best = None
                    for cand in ((my, mx), (my, nx), (ny, mx)):
                        u = (2 * vecs[cand][0], 2 * vecs[cand][1])
                        dist = tile_distance_oracle(ref, alt, oy, ox, t, u[0], u[1], 1)
                        if z > 0 and u == (0, 0):  # the zero candidate, corrected by the L1 bias of this level
                            dist -= up_bias
                        if best is None or dist < best[0]:
                            best = (dist, u)
                    centre = best[1]
                if z > 0:
                    vectors[i, j] = noise_aware_search_oracle(ref, alt, oy, ox, t, centre, params.search_radius[k],
                                                              1 if k == 0 else 2, bias, thresh)
                else:
                    vectors[i, j] = search_oracle(ref, alt, oy, ox, t, centre, params.search_radius[k],
                                                  1 if k == 0 else 2)
        coarse = (vectors, ref.shape)
    ref, alt = ref_pyr[0], alt_pyr[0]
    ty, tx = len(tile_centres(ref.shape[0], tile)), len(tile_centres(ref.shape[1], tile))
    if params.subpixel and params.refine == "lk":
        return refine_lk_oracle(ref, alt, tile, vectors, (ty, tx), params.smoothness, noise), tile
    out = np.zeros((ty, tx, 2), np.float32)
    for (i, j), (vy, vx) in vectors.items():
        out[i, j] = (vy, vx)
        if params.subpixel:
            oy, ox = i * (tile // 2), j * (tile // 2)
            d = [[tile_distance_oracle(ref, alt, oy, ox, tile, vy + a, vx + b, 2) for b in (-1, 0, 1)]
                 for a in (-1, 0, 1)]
            if d[1][1] == 0:  # an exact match stays
                continue
            u = quadratic_offset_oracle(d)
            if u is not None:
                out[i, j] = (vy + u[0], vx + u[1])
    return out, tile


def flow_from_tiles_oracle(vectors, tile, shape):
    """``(2, h, w)``: tile vectors at the tile centres, interpolated linearly along y then x (clamped at the ends)."""
    h, w = shape
    cy, cx = tile_centres(h, tile), tile_centres(w, tile)
    vectors = np.asarray(vectors, np.float64)
    out = np.zeros((2, h, w))
    for c in range(2):
        columns = np.array([np.interp(np.arange(h), cy, vectors[:, j, c]) for j in range(len(cx))])  # (tx, h)
        for y in range(h):
            out[c, y] = np.interp(np.arange(w), cx, columns[:, y])
    return out.astype(np.float32)


def align_oracle(reference, alternate, step=0, params=None, noise=None, correlation=None, raw=None):
    """``flow_from_tiles_oracle(*align_tiles_oracle(...), shape)``, then the zero-motion test if ``params.zero_test``.

    The test (:func:`zero_motion_test_oracle` with ``z = params.zero_test``) compares the frames ``raw``
    (default ``(reference, alternate)``), with the same ``noise`` and ``correlation`` (when not given:
    estimated from the ``raw`` frames).
    """
    params = _default_params() if params is None else params
    vectors, tile = align_tiles_oracle(reference, alternate, step, params, noise, correlation)
    flow = flow_from_tiles_oracle(vectors, tile, np.shape(reference))
    if params.zero_test is not None:
        r_raw, a_raw = (reference, alternate) if raw is None else raw
        flow = zero_motion_test_oracle(flow, r_raw, a_raw, params.zero_test, noise, correlation)
    return flow


# ----------------------------------------------------------------------------- the golden cases
def case_align_params(settings: dict) -> SimpleNamespace:
    """A case's alignment parameters: :data:`PAPER_ALIGN` with the case's ``settings``."""
    return SimpleNamespace(**{**vars(PAPER_ALIGN), **settings})


def _hdrplus_oracle(i):
    """As :func:`hdrplus_outputs`, each tile field found once and made dense by :func:`flow_from_tiles_oracle`."""
    p = case_align_params(HDRPLUS_SETTINGS)
    out = {}
    for step in (0, 2):
        vt = [align_tiles_oracle(i["reference"], a, step, p) for a in i["alternates"]]
        out[f"vectors_step{step}"] = np.stack([v for v, _ in vt])
        out[f"flow_step{step}"] = np.stack([flow_from_tiles_oracle(v, t, i["reference"].shape) for v, t in vt])
    return out


GOLDEN_CASES = (
    OracleCase(
        "align_hdrplus", "§4.2 / supplement §8 (HDR+ alignment)", "spikeref.align.align_tiles, spikeref.align.align",
        "spikeref.oracles.align.align_tiles_oracle",
        "Tile vectors and per-pixel flow (dy, dx) of three known shifts of a smooth texture (72×80 plane "
        "pixels), AlignParams(tile_by_step=(16, 16, 8)) (the default until 2026-11-23), at step 0 "
        "(16-pixel tiles) and step 2 (8-pixel tiles). Convention: "
        "alternate[y+dy, x+dx] ≈ reference[y, x]; in_shifts holds the true motion.",
        inputs_hdrplus, _hdrplus_oracle,
        rtol=1e-5, atol=1e-5,
        params={"levels": 4, "tile_by_step": [16, 16, 8], "coarse_tile": 8, "search_radius": [1, 4, 4, 4],
                "subpixel": True, "pyramid_kernel": [1, 4, 6, 4, 1]},
        spec="docs/spec/align.md#align_hdrplus",
        outputs=hdrplus_outputs, settings=HDRPLUS_SETTINGS,
    ),
    OracleCase(
        "align_noise_aware", "— (not in the paper or HDR+; §4.2's alignment with AlignParams(prefer_centre=3))",
        "spikeref.align.align_tiles (noise=, correlation=), local_noise, estimate_noise_correlation",
        "spikeref.oracles.align.align_tiles_oracle (prefer_centre > 0), local_noise_oracle, "
        "estimate_noise_correlation_oracle",
        "Tile vectors (dy, dx) of the noise-aware search (zero motion, else the search centre, kept unless the best "
        "offset beats it by more "
        "than z = 3 standard deviations of what noise explains; the zero offset's distance lowered by the excess "
        "that anti-correlated noise gives it) on a noisy 48×64 scene, flat on the left and textured on the right, "
        "against four alternates (still, moved by (3, −5), by (0.5, −0.25), whose noise is correlated −½ with "
        "the reference's; and an unrelated scene); AlignParams(levels=3, tile_by_step=(16, 8), coarse_tile=8, "
        "search_radius=(1, 4, 4), prefer_centre=3), steps 0 and 1, with the noise variance and correlation "
        "estimated from the images (out_noise, out_correlation) and given (in_noise; in_correlation = −0.7, "
        "clipped to −½). Convention: alternate[y+dy, x+dx] ≈ reference[y, x]; in_shifts holds the true motion "
        "of the first three.",
        inputs_noise_aware,
        lambda i: noise_aware_outputs(i, align_tiles_oracle,
                                       lambda r, a: 0.5 * (local_noise_oracle(r) + local_noise_oracle(a)),
                                       estimate_noise_correlation_oracle, case_align_params),
        rtol=1e-5, atol=1e-7,
        params={"levels": 3, "tile_by_step": [16, 8], "coarse_tile": 8, "search_radius": [1, 4, 4],
                "subpixel": True, "prefer_centre": 3.0, "pyramid_kernel": [1, 4, 6, 4, 1], "local_noise_box": 15,
                "min_correlation": -0.5},
        spec="docs/spec/align.md#align_noise_aware",
        outputs=noise_aware_outputs, settings=NOISE_AWARE_SETTINGS,
    ),
    OracleCase(
        "align_lk_regularised",
        "— (not in the paper or HDR+; §4.2's alignment with the pipeline's AlignParams(prefer_centre=3, refine=\"lk\", "
        "smoothness=300, zero_test=2))",
        "spikeref.align.align_tiles, spikeref.align.align (noise=, correlation=, raw=)",
        "spikeref.oracles.align.align_tiles_oracle (refine=\"lk\", smoothness > 0), "
        "spikeref.oracles.align.align_oracle (zero_test), lucas_kanade_oracle, regularise_oracle, "
        "zero_motion_test_oracle",
        "The alignment options of the default pipeline beyond HDR+: two Lucas–Kanade (Gauss–Newton) steps per tile "
        "from the integer vector instead of the quadratic fit (samples moved outside the image left out); the tile "
        "field regularised towards its 4-neighbours by each tile's information over its mean noise variance "
        "(λ = 300, 30 Jacobi sweeps); the dense flow set to zero per pixel where zero motion explains the raw "
        "frames better than the flow by 2σ of the noise over a 9×9 box. A 48×64 scene (flat left, textured "
        "right, a textured square object) against three alternates: still, the object moved by (0.75, −1.5), "
        "everything moved by (0.5, −0.25); noise correlated −½. AlignParams(levels=3, tile_by_step=(16, 8), "
        "coarse_tile=8, search_radius=(1, 4, 4), prefer_centre=3), steps 0 and 1; the tile vectors without the "
        "regularisation (lk), the vectors and flow of the blurred flow frames with the noise given and the zero "
        "test on the raw frames (given), and of the raw frames with every noise quantity estimated (estimated). "
        "Convention: alternate[y+dy, x+dx] ≈ reference[y, x]; in_shifts holds the true motion.",
        inputs_lk, lambda i: lk_outputs(i, align_tiles_oracle, align_oracle, case_align_params),
        rtol=1e-5, atol=1e-6,
        params={"levels": 3, "tile_by_step": [16, 8], "coarse_tile": 8, "search_radius": [1, 4, 4],
                "subpixel": True, "prefer_centre": 3.0, "refine": "lk", "lk_iterations": 2, "smoothness": 300.0,
                "smoothness_sweeps": 30, "zero_test": 2.0, "zero_test_box": 9, "pyramid_kernel": [1, 4, 6, 4, 1],
                "local_noise_box": 15, "min_correlation": -0.5, "pd_tolerance": 1e-9, "min_variance": 1e-20},
        spec="docs/spec/align.md#align_lk_regularised",
        outputs=lk_outputs, settings=LK_SETTINGS,
    ),
)
