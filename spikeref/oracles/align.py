"""Oracle of the HDR+ tile alignment (:mod:`spikeref.align`): tiles, offsets and pixels one at a time.

A literal transcription of the module's description, written without its kernels:
the pyramid pixel by pixel, every tile and every offset in plain loops, nearest coarse tiles
by ``argmin`` over all coarse centres, the sub-pixel quadratic by ``numpy.linalg.lstsq`` on the
9 × 6 design matrix, and the per-pixel flow by ``numpy.interp`` (clamped linear interpolation)
along each axis.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "gaussian_pyramid_oracle",
    "tile_distance_oracle",
    "nearest_tiles_oracle",
    "quadratic_offset_oracle",
    "align_tiles_oracle",
    "flow_from_tiles_oracle",
    "align_oracle",
]

_TAPS = (1.0, 4.0, 6.0, 4.0, 1.0)


def _default_params():
    from spikeref.align import AlignParams

    return AlignParams()


def gaussian_pyramid_oracle(image, levels):
    """Level 0 = ``image``; level ``k+1``: blur each column then each row by ``[1,4,6,4,1]/16`` with the
    edge pixel replicated, keep rows and columns 0, 2, 4, …  float64 arithmetic, float32 levels."""
    pyramid = [np.asarray(image, np.float32)]
    for _ in range(levels - 1):
        img = pyramid[-1]
        h, w = img.shape
        vertical = np.zeros((h, w))
        for y in range(h):
            for x in range(w):
                total = 0.0
                for k, tap in enumerate(_TAPS):
                    yy = min(max(y + k - 2, 0), h - 1)
                    total += tap * float(img[yy, x])
                vertical[y, x] = total / 16.0
        rows = vertical[0::2]
        both = np.zeros(rows.shape)
        for y in range(rows.shape[0]):
            for x in range(w):
                total = 0.0
                for k, tap in enumerate(_TAPS):
                    xx = min(max(x + k - 2, 0), w - 1)
                    total += tap * rows[y, xx]
                both[y, x] = total / 16.0
        pyramid.append(both[:, 0::2].astype(np.float32))
    return pyramid


def tile_distance_oracle(ref, alt, oy, ox, tile, dy, dx, norm):
    """Σ over the ``tile × tile`` tile at ``(oy, ox)`` of ``|ref(p) − alt(p + (dy, dx))|^norm`` (norm 1 or 2),
    ``alt`` sampled at clamped coordinates, in float64."""
    h, w = alt.shape
    ys = np.clip(np.arange(oy, oy + tile) + dy, 0, h - 1)
    xs = np.clip(np.arange(ox, ox + tile) + dx, 0, w - 1)
    diff = ref[oy:oy + tile, ox:ox + tile].astype(np.float64) - alt[np.ix_(ys, xs)].astype(np.float64)
    return float(np.sum(np.abs(diff))) if norm == 1 else float(np.sum(diff * diff))


def _centres(size, tile):
    """Tile centres (pixel-index coordinates) of the tiles that fit in ``size`` pixels with stride ``tile/2``."""
    stride = tile // 2
    count = (size - tile) // stride + 1
    return np.array([i * stride + (tile - 1) / 2 for i in range(count)])


def nearest_tiles_oracle(fine_centre, coarse_size, coarse_tile):
    """The coarse tile whose centre is nearest to ``fine_centre / 2`` and its neighbour on that side (clamped)."""
    centres = _centres(coarse_size, coarse_tile)
    c = fine_centre / 2
    m = int(np.argmin(np.abs(centres - c)))
    n = m + 1 if c > centres[m] else m - 1
    return m, min(max(n, 0), len(centres) - 1)


def quadratic_offset_oracle(d):
    """Least-squares fit ``D(u) ≈ ½uᵀAu + bᵀu + c`` on the grid ``u ∈ {−1,0,1}²``; ``u* = −A⁻¹b``,
    or None when ``A`` is not positive definite (smaller eigenvalue ≤ ``PD_TOLERANCE`` × the largest distance)
    or ``|u*| > 1`` (+ ``SLACK``) in a component."""
    from spikeref.align import PD_TOLERANCE, SLACK

    rows, values = [], []
    for i, uy in enumerate((-1, 0, 1)):
        for j, ux in enumerate((-1, 0, 1)):
            rows.append([0.5 * uy * uy, uy * ux, 0.5 * ux * ux, uy, ux, 1.0])
            values.append(d[i][j])
    (a_yy, a_xy, a_xx, b_y, b_x, _c), *_ = np.linalg.lstsq(np.array(rows), np.array(values), rcond=None)
    a = np.array([[a_yy, a_xy], [a_xy, a_xx]])
    if np.min(np.linalg.eigvalsh(a)) <= PD_TOLERANCE * np.max(d):
        return None
    u = -np.linalg.solve(a, [b_y, b_x])
    if np.max(np.abs(u)) > 1 + SLACK:
        return None
    return u


def _search_oracle(ref, alt, oy, ox, tile, centre, radius, norm):
    """Best ``centre + d``, ``d ∈ [−r, r]²``: smallest distance, then closest to the centre, then raster order."""
    best = None
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            dist = tile_distance_oracle(ref, alt, oy, ox, tile, centre[0] + dy, centre[1] + dx, norm)
            key = (dist, dy * dy + dx * dx)
            if best is None or key < best[0]:  # strict: the earlier one in raster order stays on a full tie
                best = (key, (centre[0] + dy, centre[1] + dx))
    return best[1]


def align_tiles_oracle(reference, alternate, step=0, params=None):
    """``(vectors (ty, tx, 2) float32, tile)``: coarse-to-fine search with 3-candidate upsampling, then sub-pixel."""
    params = _default_params() if params is None else params
    tile = params.tile_by_step[min(step, len(params.tile_by_step) - 1)]
    ref_pyr = gaussian_pyramid_oracle(reference, params.levels)
    alt_pyr = gaussian_pyramid_oracle(alternate, params.levels)
    coarse = None  # {(i, j): (vy, vx)} of the previous level, and its image size and tile size
    for k in range(params.levels - 1, -1, -1):
        ref, alt = ref_pyr[k], alt_pyr[k]
        t = tile if k == 0 else params.coarse_tile
        cy, cx = _centres(ref.shape[0], t), _centres(ref.shape[1], t)
        vectors = {}
        for i in range(len(cy)):
            for j in range(len(cx)):
                oy, ox = i * (t // 2), j * (t // 2)
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
                        if best is None or dist < best[0]:
                            best = (dist, u)
                    centre = best[1]
                vectors[i, j] = _search_oracle(ref, alt, oy, ox, t, centre, params.search_radius[k],
                                               1 if k == 0 else 2)
        coarse = (vectors, ref.shape)
    ref, alt = ref_pyr[0], alt_pyr[0]
    ty, tx = len(_centres(ref.shape[0], tile)), len(_centres(ref.shape[1], tile))
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
    cy, cx = _centres(h, tile), _centres(w, tile)
    vectors = np.asarray(vectors, np.float64)
    out = np.zeros((2, h, w))
    for c in range(2):
        columns = np.array([np.interp(np.arange(h), cy, vectors[:, j, c]) for j in range(len(cx))])  # (tx, h)
        for y in range(h):
            out[c, y] = np.interp(np.arange(w), cx, columns[:, y])
    return out.astype(np.float32)


def align_oracle(reference, alternate, step=0, params=None):
    """``flow_from_tiles_oracle(*align_tiles_oracle(...), shape)``."""
    vectors, tile = align_tiles_oracle(reference, alternate, step, params)
    return flow_from_tiles_oracle(vectors, tile, np.shape(reference))
