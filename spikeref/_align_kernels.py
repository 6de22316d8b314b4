"""The kernels of the alignment (:mod:`spikeref.align` reads like HDR+ and the paper; the speed is here).

Tile distances and the coarse-to-fine search, the three-candidate upsampling, the quadratic sub-pixel
fit, Lucas–Kanade steps, the Jacobi sweeps of the regularised field, the dense flow from tile vectors,
the pyramid's blur and the zero-motion test's sums.  Nothing here checks its arguments: the public
functions of :mod:`spikeref.align` do; the oracles are :mod:`spikeref.oracles.align`.
"""

from __future__ import annotations

import numpy as np

from spikeref._jit import njit, prange

__all__ = [
    "PYRAMID_KERNEL", "PD_TOLERANCE", "SLACK", "bilinear3", "bilinear_cell", "block_distances", "block_distances_l1_l2",
    "blur_decimate_kernel", "box_sums", "choose_offset", "dense_flow", "fit_offset", "fitted", "gradient",
    "integral_image", "interp_index", "jacobi_sweeps", "lucas_kanade", "nearest_tiles", "search_fit_tiles",
    "search_tiles", "subpixel_fit", "three_distances", "tile_distance", "tile_sums_from_integral", "upsample_tiles",
    "window_distances",
    "zero_test_terms",
]

#: The 5-tap binomial blur of the pyramid (σ = 1), applied separably.
PYRAMID_KERNEL = (1.0, 4.0, 6.0, 4.0, 1.0)

#: The sub-pixel fit's ``A`` counts as positive definite when its smaller eigenvalue exceeds this
#: fraction of the largest of the nine distances: a guard against round-off on degenerate surfaces
#: (e.g. a tile whose samples are all clamped to one edge row, where ``A`` is singular).
PD_TOLERANCE = 1e-9

#: The sub-pixel offset is accepted when ``|u*| ≤ 1 + SLACK`` in both components; the slack keeps the
#: decision the same in the kernel and the oracle when ``|u*| = 1`` exactly (quantised input).
SLACK = 1e-9


@njit(inline="always")
def tile_distance(ref, alt, oy, ox, tile, dy, dx, l2):
    """Σ over the tile at ``(oy, ox)`` of ``|ref(p) − alt(p + (dy, dx))|`` (or its square), clamped samples."""
    h, w = alt.shape
    total = 0.0
    if oy + dy >= 0 and oy + dy + tile <= h and ox + dx >= 0 and ox + dx + tile <= w:
        # the whole shifted tile is inside: no clamping, the same sums in the same order
        for y in range(oy, oy + tile):
            r = ref[y, ox:ox + tile]
            a = alt[y + dy, ox + dx:ox + dx + tile]
            for x in range(tile):
                d = np.float64(r[x]) - np.float64(a[x])
                if l2:
                    total += d * d
                else:
                    total += abs(d)
        return total
    for y in range(oy, oy + tile):
        yy = min(max(y + dy, 0), h - 1)
        for x in range(ox, ox + tile):
            xx = min(max(x + dx, 0), w - 1)
            d = np.float64(ref[y, x]) - np.float64(alt[yy, xx])
            if l2:
                total += d * d
            else:
                total += abs(d)
    return total


@njit(inline="always")
def term(d, l2):
    """One sample's share of a tile distance: ``d²`` (L2) or ``|d|`` (L1)."""
    return d * d if l2 else abs(d)


@njit(inline="always")
def block_distances(ref, alt, oy, ox, tile, qy, qx, l2, d, i0, j0):
    """``d[i0 + a, j0 + b]`` = :func:`tile_distance` at the offset ``(qy + a − 1, qx + b − 1)``, ``a, b ∈ {0, 1, 2}``.

    The nine sums run side by side, each adding the same terms in the same order as :func:`tile_distance`
    (so the same float64 values): nine independent chains where one offset at a time is a single chain.
    A block with any of its nine shifted tiles partly outside the image clamps every sample, as
    :func:`tile_distance`'s clamped loop does (clamping changes no sample that lies inside).
    """
    h, w = alt.shape
    s00 = s01 = s02 = s10 = s11 = s12 = s20 = s21 = s22 = 0.0
    if oy + qy - 1 < 0 or oy + qy + 1 + tile > h or ox + qx - 1 < 0 or ox + qx + 1 + tile > w:
        # some shifted tile is partly outside: every sample clamped (a no-op for the samples inside), as
        # tile_distance's clamped loop, the nine sums still side by side
        for y in range(oy, oy + tile):
            a0 = alt[min(max(y + qy - 1, 0), h - 1)]
            a1 = alt[min(max(y + qy, 0), h - 1)]
            a2 = alt[min(max(y + qy + 1, 0), h - 1)]
            for x in range(ox, ox + tile):
                rv = np.float64(ref[y, x])
                xa = min(max(x + qx - 1, 0), w - 1)
                xb = min(max(x + qx, 0), w - 1)
                xc = min(max(x + qx + 1, 0), w - 1)
                s00 += term(rv - np.float64(a0[xa]), l2)
                s01 += term(rv - np.float64(a0[xb]), l2)
                s02 += term(rv - np.float64(a0[xc]), l2)
                s10 += term(rv - np.float64(a1[xa]), l2)
                s11 += term(rv - np.float64(a1[xb]), l2)
                s12 += term(rv - np.float64(a1[xc]), l2)
                s20 += term(rv - np.float64(a2[xa]), l2)
                s21 += term(rv - np.float64(a2[xb]), l2)
                s22 += term(rv - np.float64(a2[xc]), l2)
    else:
        for y in range(oy, oy + tile):
            r = ref[y, ox:ox + tile]
            a0 = alt[y + qy - 1, ox + qx - 1:ox + qx + tile + 1]
            a1 = alt[y + qy, ox + qx - 1:ox + qx + tile + 1]
            a2 = alt[y + qy + 1, ox + qx - 1:ox + qx + tile + 1]
            for x in range(tile):  # LLVM takes the test of l2 out of the loop
                rv = np.float64(r[x])
                s00 += term(rv - np.float64(a0[x]), l2)
                s01 += term(rv - np.float64(a0[x + 1]), l2)
                s02 += term(rv - np.float64(a0[x + 2]), l2)
                s10 += term(rv - np.float64(a1[x]), l2)
                s11 += term(rv - np.float64(a1[x + 1]), l2)
                s12 += term(rv - np.float64(a1[x + 2]), l2)
                s20 += term(rv - np.float64(a2[x]), l2)
                s21 += term(rv - np.float64(a2[x + 1]), l2)
                s22 += term(rv - np.float64(a2[x + 2]), l2)
    d[i0, j0] = s00
    d[i0, j0 + 1] = s01
    d[i0, j0 + 2] = s02
    d[i0 + 1, j0] = s10
    d[i0 + 1, j0 + 1] = s11
    d[i0 + 1, j0 + 2] = s12
    d[i0 + 2, j0] = s20
    d[i0 + 2, j0 + 1] = s21
    d[i0 + 2, j0 + 2] = s22


@njit(inline="always")
def block_distances_l1_l2(ref, alt, oy, ox, tile, qy, qx, d1, d2):
    """:func:`block_distances` with L1 into ``d1`` and L2 into ``d2`` (``(3, 3)`` each) from one read of the samples."""
    h, w = alt.shape
    if oy + qy - 1 < 0 or oy + qy + 1 + tile > h or ox + qx - 1 < 0 or ox + qx + 1 + tile > w:
        block_distances(ref, alt, oy, ox, tile, qy, qx, False, d1, 0, 0)
        block_distances(ref, alt, oy, ox, tile, qy, qx, True, d2, 0, 0)
        return
    s00 = s01 = s02 = s10 = s11 = s12 = s20 = s21 = s22 = 0.0
    q00 = q01 = q02 = q10 = q11 = q12 = q20 = q21 = q22 = 0.0
    for y in range(oy, oy + tile):
        r = ref[y, ox:ox + tile]
        a0 = alt[y + qy - 1, ox + qx - 1:ox + qx + tile + 1]
        a1 = alt[y + qy, ox + qx - 1:ox + qx + tile + 1]
        a2 = alt[y + qy + 1, ox + qx - 1:ox + qx + tile + 1]
        for x in range(tile):
            rv = np.float64(r[x])
            e = rv - np.float64(a0[x])
            s00 += abs(e)
            q00 += e * e
            e = rv - np.float64(a0[x + 1])
            s01 += abs(e)
            q01 += e * e
            e = rv - np.float64(a0[x + 2])
            s02 += abs(e)
            q02 += e * e
            e = rv - np.float64(a1[x])
            s10 += abs(e)
            q10 += e * e
            e = rv - np.float64(a1[x + 1])
            s11 += abs(e)
            q11 += e * e
            e = rv - np.float64(a1[x + 2])
            s12 += abs(e)
            q12 += e * e
            e = rv - np.float64(a2[x])
            s20 += abs(e)
            q20 += e * e
            e = rv - np.float64(a2[x + 1])
            s21 += abs(e)
            q21 += e * e
            e = rv - np.float64(a2[x + 2])
            s22 += abs(e)
            q22 += e * e
    d1[0, 0] = s00
    d1[0, 1] = s01
    d1[0, 2] = s02
    d1[1, 0] = s10
    d1[1, 1] = s11
    d1[1, 2] = s12
    d1[2, 0] = s20
    d1[2, 1] = s21
    d1[2, 2] = s22
    d2[0, 0] = q00
    d2[0, 1] = q01
    d2[0, 2] = q02
    d2[1, 0] = q10
    d2[1, 1] = q11
    d2[1, 2] = q12
    d2[2, 0] = q20
    d2[2, 1] = q21
    d2[2, 2] = q22


@njit(inline="always")
def window_distances(ref, alt, oy, ox, tile, cy, cx, radius, l2, d):
    """``d[dy + radius, dx + radius]`` = :func:`tile_distance` at ``(cy + dy, cx + dx)`` for ``|dy|, |dx| ≤ radius``.

    In 3×3 blocks (:func:`block_distances`), one offset at a time where ``2·radius + 1`` leaves a remainder.
    """
    n = 2 * radius + 1
    for i in range(0, n, 3):
        for j in range(0, n, 3):
            if i + 3 <= n and j + 3 <= n:
                block_distances(ref, alt, oy, ox, tile, cy + i - radius + 1, cx + j - radius + 1, l2, d, i, j)
            else:
                for a in range(i, min(i + 3, n)):
                    for b in range(j, min(j + 3, n)):
                        d[a, b] = tile_distance(ref, alt, oy, ox, tile, cy + a - radius, cx + b - radius, l2)


@njit(parallel=True)
def search_tiles(ref, alt, tile, centre, radius, l2, bias, thresh, out):
    """Integer search: ``out[i, j] = centre[i, j] + argmin_d distance``; ``centre, out (ny, nx, 2) int64``.

    Noise-aware search (``bias``, ``thresh (ny, nx) float64``; zeros and −1 turn it off): the zero
    offset's distance is lowered by ``bias[i, j]`` (the excess that anti-correlated noise gives it),
    and where ``thresh[i, j] ≥ 0`` the zero vector (whether or not it lies in the search window), else
    the centre, is kept unless the best distance is lower than its distance by more than
    ``thresh[i, j]``.
    """
    ny, nx = centre.shape[0], centre.shape[1]
    stride = tile // 2
    for t in prange(ny * nx):
        i = t // nx
        j = t % nx
        oy = i * stride
        ox = j * stride
        cy = centre[i, j, 0]
        cx = centre[i, j, 1]
        d = np.empty((2 * radius + 1, 2 * radius + 1))
        window_distances(ref, alt, oy, ox, tile, cy, cx, radius, l2, d)
        by, bx = choose_offset(ref, alt, oy, ox, tile, cy, cx, radius, l2, d, bias[i, j], thresh[i, j])
        out[i, j, 0] = cy + by
        out[i, j, 1] = cx + bx


@njit(inline="always")
def choose_offset(ref, alt, oy, ox, tile, cy, cx, radius, l2, d, bias, thresh):
    """The offset ``(by, bx)`` from the centre that :func:`search_tiles` picks, given the distances ``d``.

    The smallest distance (the zero vector's lowered by ``bias``), the shorter offset on a tie; with
    ``thresh ≥ 0`` the zero vector, else the centre, unless the best is lower by more than ``thresh``.
    """
    best = np.inf
    by = 0
    bx = 0
    bn = 0
    at_centre = np.inf
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            dist = d[dy + radius, dx + radius]
            if cy + dy == 0 and cx + dx == 0:
                dist -= bias
            n2 = dy * dy + dx * dx
            if n2 == 0:
                at_centre = dist
            if dist < best or (dist == best and n2 < bn):
                best = dist
                by = dy
                bx = dx
                bn = n2
    if thresh >= 0.0:
        at_zero = tile_distance(ref, alt, oy, ox, tile, 0, 0, l2) - bias
        if at_zero - best <= thresh:  # zero motion first …
            return -cy, -cx
        if at_centre - best <= thresh:  # … then the search centre
            return 0, 0
    return by, bx


@njit(parallel=True)
def search_fit_tiles(ref, alt, tile, centre, bias, thresh, vectors, out):
    """The finest level of the paper's alignment in one pass: :func:`search_tiles` with radius 1 and L1
    distances into ``vectors``, then :func:`subpixel_fit`'s L2 fit into ``out`` (the same values as the
    two kernels).  The nine L2 distances around the centre are summed beside the nine L1 ones (from the
    same samples, each in its own order) and serve the fit where the search keeps the centre.
    """
    ny, nx = centre.shape[0], centre.shape[1]
    stride = tile // 2
    for t in prange(ny * nx):
        i = t // nx
        j = t % nx
        oy = i * stride
        ox = j * stride
        cy = centre[i, j, 0]
        cx = centre[i, j, 1]
        d1 = np.empty((3, 3))
        d2 = np.empty((3, 3))
        block_distances_l1_l2(ref, alt, oy, ox, tile, cy, cx, d1, d2)
        by, bx = choose_offset(ref, alt, oy, ox, tile, cy, cx, 1, False, d1, bias[i, j], thresh[i, j])
        if by != 0 or bx != 0:
            block_distances(ref, alt, oy, ox, tile, cy + by, cx + bx, True, d2, 0, 0)
        vectors[i, j, 0] = cy + by
        vectors[i, j, 1] = cx + bx
        out[i, j, 0], out[i, j, 1] = fitted(d2, cy + by, cx + bx)


@njit(inline="always")
def nearest_tiles(c, coarse_tile, count):
    """Nearest coarse tile to the fine centre ``c`` (fine pixel-index coordinates) and its neighbour on ``c``'s side."""
    stride = coarse_tile // 2
    pos = (0.5 * c - 0.5 * (coarse_tile - 1)) / stride  # in units of coarse tiles, 0 = first centre
    m = int(np.floor(pos + 0.5))
    m = min(max(m, 0), count - 1)
    n = m + 1 if pos > m else m - 1
    n = min(max(n, 0), count - 1)
    return m, n


@njit(inline="always")
def three_distances(ref, alt, oy, ox, tile, cand, out):
    """``out[k]`` = :func:`tile_distance` (L1) at the offset ``cand[k]``, ``k = 0, 1, 2``: the three sums side by
    side, each in :func:`tile_distance`'s order, where all three shifted tiles lie inside the image."""
    h, w = alt.shape
    inside = True
    for k in range(3):
        qy = oy + cand[k, 0]
        qx = ox + cand[k, 1]
        inside = inside and qy >= 0 and qy + tile <= h and qx >= 0 and qx + tile <= w
    if not inside:
        for k in range(3):
            out[k] = tile_distance(ref, alt, oy, ox, tile, cand[k, 0], cand[k, 1], False)
        return
    s0 = s1 = s2 = 0.0
    for y in range(oy, oy + tile):
        r = ref[y, ox:ox + tile]
        a0 = alt[y + cand[0, 0], ox + cand[0, 1]:ox + cand[0, 1] + tile]
        a1 = alt[y + cand[1, 0], ox + cand[1, 1]:ox + cand[1, 1] + tile]
        a2 = alt[y + cand[2, 0], ox + cand[2, 1]:ox + cand[2, 1] + tile]
        for x in range(tile):
            rv = np.float64(r[x])
            s0 += abs(rv - np.float64(a0[x]))
            s1 += abs(rv - np.float64(a1[x]))
            s2 += abs(rv - np.float64(a2[x]))
    out[0] = s0
    out[1] = s1
    out[2] = s2


@njit(parallel=True)
def upsample_tiles(ref, alt, tile, coarse, coarse_tile, bias, out):
    """3-candidate upsampling: ``out (ny, nx, 2)`` = the best of 3 doubled coarse vectors (L1 at this level).

    A zero candidate's distance is lowered by ``bias[i, j]`` (noise-aware search; zeros: off).
    """
    ny, nx = out.shape[0], out.shape[1]
    my, mx = coarse.shape[0], coarse.shape[1]
    stride = tile // 2
    for t in prange(ny * nx):
        i = t // nx
        j = t % nx
        oy = i * stride
        ox = j * stride
        ay, by_ = nearest_tiles(oy + 0.5 * (tile - 1), coarse_tile, my)
        ax, bx_ = nearest_tiles(ox + 0.5 * (tile - 1), coarse_tile, mx)
        cand = np.empty((3, 2), np.int64)
        dists = np.empty(3)
        cand[0, 0], cand[0, 1] = 2 * coarse[ay, ax, 0], 2 * coarse[ay, ax, 1]
        cand[1, 0], cand[1, 1] = 2 * coarse[ay, bx_, 0], 2 * coarse[ay, bx_, 1]
        cand[2, 0], cand[2, 1] = 2 * coarse[by_, ax, 0], 2 * coarse[by_, ax, 1]
        three_distances(ref, alt, oy, ox, tile, cand, dists)
        best = np.inf
        vy = 0
        vx = 0
        for k in range(3):
            uy = cand[k, 0]
            ux = cand[k, 1]
            dist = dists[k]
            if uy == 0 and ux == 0:
                dist -= bias[i, j]
            if dist < best:
                best = dist
                vy = uy
                vx = ux
        out[i, j, 0] = vy
        out[i, j, 1] = vx


@njit(inline="always")
def fit_offset(d):
    """Least-squares fit of ``½uᵀAu + bᵀu + c`` to the 3×3 distances ``d[dy+1, dx+1]``; ``(u*_y, u*_x, ok)``.

    Closed form of the normal equations on the 3×3 grid: ``b`` and ``A_xy`` from the odd moments,
    ``A_yy = (Σ rows ±1)/3 − 2 (Σ row 0)/3`` (and the same for columns).  ``ok`` is False unless
    ``A`` is positive definite — its smaller eigenvalue above :data:`PD_TOLERANCE` times the largest
    of the nine distances — and ``|u*| ≤ 1`` (+ :data:`SLACK`) in both components.
    """
    r_m = d[0, 0] + d[0, 1] + d[0, 2]
    r_0 = d[1, 0] + d[1, 1] + d[1, 2]
    r_p = d[2, 0] + d[2, 1] + d[2, 2]
    c_m = d[0, 0] + d[1, 0] + d[2, 0]
    c_0 = d[0, 1] + d[1, 1] + d[2, 1]
    c_p = d[0, 2] + d[1, 2] + d[2, 2]
    b_y = (r_p - r_m) / 6.0
    b_x = (c_p - c_m) / 6.0
    a_yy = (r_m + r_p) / 3.0 - 2.0 * r_0 / 3.0
    a_xx = (c_m + c_p) / 3.0 - 2.0 * c_0 / 3.0
    a_xy = (d[2, 2] - d[2, 0] - d[0, 2] + d[0, 0]) / 4.0
    scale = 0.0
    for a in range(3):
        for b in range(3):
            scale = max(scale, d[a, b])
    smallest = 0.5 * (a_yy + a_xx - np.sqrt((a_yy - a_xx) ** 2 + 4.0 * a_xy * a_xy))
    if not smallest > PD_TOLERANCE * scale:
        return 0.0, 0.0, False
    det = a_yy * a_xx - a_xy * a_xy
    u_y = -(a_xx * b_y - a_xy * b_x) / det
    u_x = -(a_yy * b_x - a_xy * b_y) / det
    if abs(u_y) <= 1.0 + SLACK and abs(u_x) <= 1.0 + SLACK:
        return u_y, u_x, True
    return 0.0, 0.0, False


@njit(parallel=True)
def subpixel_fit(ref, alt, tile, best, out):
    """``out (ny, nx, 2) float32`` = integer ``best`` + the quadratic-fit offset where accepted."""
    ny, nx = best.shape[0], best.shape[1]
    stride = tile // 2
    for t in prange(ny * nx):
        i = t // nx
        j = t % nx
        oy = i * stride
        ox = j * stride
        by = best[i, j, 0]
        bx = best[i, j, 1]
        d = np.empty((3, 3))
        block_distances(ref, alt, oy, ox, tile, by, bx, True, d, 0, 0)
        out[i, j, 0], out[i, j, 1] = fitted(d, by, bx)


@njit(inline="always")
def fitted(d, by, bx):
    """The integer vector ``(by, bx)`` plus the quadratic fit's offset on its L2 distances ``d``, where accepted."""
    if d[1, 1] == 0.0:
        return np.float64(by), np.float64(bx)
    u_y, u_x, ok = fit_offset(d)
    if ok:
        return by + u_y, bx + u_x
    return np.float64(by), np.float64(bx)


@njit
def gradient(img, gy, gx):
    """Central differences of ``img`` (one-sided at the border, as ``numpy.gradient``) into ``gy, gx`` (float64)."""
    h, w = img.shape
    for y in range(h):
        for x in range(w):
            if h == 1:
                gy[y, x] = 0.0
            elif y == 0:
                gy[y, x] = np.float64(img[1, x]) - np.float64(img[0, x])
            elif y == h - 1:
                gy[y, x] = np.float64(img[h - 1, x]) - np.float64(img[h - 2, x])
            else:
                gy[y, x] = 0.5 * (np.float64(img[y + 1, x]) - np.float64(img[y - 1, x]))
            if w == 1:
                gx[y, x] = 0.0
            elif x == 0:
                gx[y, x] = np.float64(img[y, 1]) - np.float64(img[y, 0])
            elif x == w - 1:
                gx[y, x] = np.float64(img[y, w - 1]) - np.float64(img[y, w - 2])
            else:
                gx[y, x] = 0.5 * (np.float64(img[y, x + 1]) - np.float64(img[y, x - 1]))


@njit(inline="always")
def bilinear_cell(sy, sx, h, w):
    """The bilinear cell of a position ``(sy, sx)`` already clamped to the ``h × w`` grid:
    ``(y0, x0, y1, x1, fy, fx)``, the far corner clamped too (a position on the last row or column)."""
    y0 = min(int(np.floor(sy)), h - 1)
    x0 = min(int(np.floor(sx)), w - 1)
    return y0, x0, min(y0 + 1, h - 1), min(x0 + 1, w - 1), sy - y0, sx - x0


@njit(inline="always")
def bilinear3(img, gy, gx, y, x):
    """Bilinear samples of ``img`` and its two gradient images at ``(y, x)``, clamped to the grid."""
    h, w = img.shape
    yc = min(max(y, 0.0), h - 1.0)
    xc = min(max(x, 0.0), w - 1.0)
    y0, x0, y1, x1, fy, fx = bilinear_cell(yc, xc, h, w)
    w00 = (1.0 - fy) * (1.0 - fx)
    w01 = (1.0 - fy) * fx
    w10 = fy * (1.0 - fx)
    w11 = fy * fx
    a = w00 * img[y0, x0] + w01 * img[y0, x1] + w10 * img[y1, x0] + w11 * img[y1, x1]
    b = w00 * gy[y0, x0] + w01 * gy[y0, x1] + w10 * gy[y1, x0] + w11 * gy[y1, x1]
    c = w00 * gx[y0, x0] + w01 * gx[y0, x1] + w10 * gx[y1, x0] + w11 * gx[y1, x1]
    return a, b, c


@njit(parallel=True)
def lucas_kanade(ref, alt, gy, gx, tile, best, iterations, out, info):
    """``out (ny, nx, 2) float64``: ``best`` refined by Gauss–Newton steps of a translation per tile.

    ``info (ny, nx, 3)`` receives ``(Σ g_y², Σ g_y g_x, Σ g_x²)`` of the last step (the tile's
    Lucas–Kanade information, before dividing by the noise).  A step whose 2×2 system is singular
    (relative tolerance :data:`PD_TOLERANCE` on the determinant) leaves the vector as it is; a step
    is clamped to ``±1`` pixel per component.  Samples whose moved position lies outside ``alt``
    are left out of the sums.
    """
    ny, nx = best.shape[0], best.shape[1]
    h, w = alt.shape
    stride = tile // 2
    for t in prange(ny * nx):
        i = t // nx
        j = t % nx
        oy = i * stride
        ox = j * stride
        uy = np.float64(best[i, j, 0])
        ux = np.float64(best[i, j, 1])
        syy = 0.0
        syx = 0.0
        sxx = 0.0
        for it in range(iterations):
            syy = 0.0
            syx = 0.0
            sxx = 0.0
            ry = 0.0
            rx = 0.0
            iy = int(uy)
            ix = int(ux)
            for y in range(oy, oy + tile):
                py = y + uy
                if py < 0.0 or py > h - 1.0:  # samples outside the image are left out
                    continue
                for x in range(ox, ox + tile):
                    px = x + ux
                    if px < 0.0 or px > w - 1.0:
                        continue
                    if it == 0:  # the integer vector: the samples themselves (what bilinear gives there)
                        a = np.float64(alt[y + iy, x + ix])
                        ay = gy[y + iy, x + ix]
                        ax = gx[y + iy, x + ix]
                    else:
                        a, ay, ax = bilinear3(alt, gy, gx, py, px)
                    e = np.float64(ref[y, x]) - a
                    syy += ay * ay
                    syx += ay * ax
                    sxx += ax * ax
                    ry += ay * e
                    rx += ax * e
            det = syy * sxx - syx * syx
            if not det > PD_TOLERANCE * (syy + sxx) ** 2 or det <= 0.0:
                break
            dy = (sxx * ry - syx * rx) / det
            dx = (syy * rx - syx * ry) / det
            uy += min(max(dy, -1.0), 1.0)
            ux += min(max(dx, -1.0), 1.0)
        out[i, j, 0] = uy
        out[i, j, 1] = ux
        info[i, j, 0] = syy
        info[i, j, 1] = syx
        info[i, j, 2] = sxx


@njit
def jacobi_sweeps(hat, info, variance, lam, sweeps, out):
    """The Jacobi sweeps of the regularised tile field (``hat, out (ny, nx, 2)``, ``info (ny, nx, 3)``)."""
    ny, nx = hat.shape[0], hat.shape[1]
    cur = hat.copy()
    for _ in range(sweeps):
        for i in range(ny):
            for j in range(nx):
                sy = 0.0
                sx = 0.0
                n = 0
                if i > 0:
                    sy += cur[i - 1, j, 0]
                    sx += cur[i - 1, j, 1]
                    n += 1
                if i < ny - 1:
                    sy += cur[i + 1, j, 0]
                    sx += cur[i + 1, j, 1]
                    n += 1
                if j > 0:
                    sy += cur[i, j - 1, 0]
                    sx += cur[i, j - 1, 1]
                    n += 1
                if j < nx - 1:
                    sy += cur[i, j + 1, 0]
                    sx += cur[i, j + 1, 1]
                    n += 1
                v = variance[i, j]
                jyy = info[i, j, 0] / v
                jyx = info[i, j, 1] / v
                jxx = info[i, j, 2] / v
                ayy = jyy + lam * n
                axx = jxx + lam * n
                det = ayy * axx - jyx * jyx
                by = jyy * hat[i, j, 0] + jyx * hat[i, j, 1] + lam * sy
                bx = jyx * hat[i, j, 0] + jxx * hat[i, j, 1] + lam * sx
                out[i, j, 0] = (axx * by - jyx * bx) / det
                out[i, j, 1] = (ayy * bx - jyx * by) / det
        cur[...] = out


@njit(inline="always")
def interp_index(p, c0, stride, n):
    """Bilinear taps of pixel ``p`` between tile centres ``c0 + i·stride``, clamped beyond the outer ones."""
    t = (p - c0) / stride
    if t <= 0.0:
        return 0, 0, 0.0
    if t >= n - 1:
        return n - 1, n - 1, 0.0
    i0 = int(np.floor(t))
    return i0, i0 + 1, t - i0


@njit(parallel=True)
def dense_flow(vectors, tile, out):
    """``out (2, h, w) float32``: bilinear interpolation of ``vectors (ty, tx, 2)`` placed at the tile centres."""
    ty, tx = vectors.shape[0], vectors.shape[1]
    h, w = out.shape[1], out.shape[2]
    stride = tile // 2
    c0 = 0.5 * (tile - 1)
    cols0 = np.empty(w, np.int64)  # each column's interpolation, once for every row
    cols1 = np.empty(w, np.int64)
    fxs = np.empty(w)
    for x in range(w):
        cols0[x], cols1[x], fxs[x] = interp_index(x, c0, stride, tx)
    for y in prange(h):
        i0, i1, fy = interp_index(y, c0, stride, ty)
        for c in range(2):
            v00 = vectors[i0, :, c]
            v10 = vectors[i1, :, c]
            row = out[c, y]
            for x in range(w):
                j0 = cols0[x]
                j1 = cols1[x]
                fx = fxs[x]
                top = (1.0 - fx) * np.float64(v00[j0]) + fx * np.float64(v00[j1])
                bottom = (1.0 - fx) * np.float64(v10[j0]) + fx * np.float64(v10[j1])
                row[x] = (1.0 - fy) * top + fy * bottom


@njit(parallel=True)
def box_sums(values, half, out):
    """``out[p]`` = Σ of ``values`` over the ``(2·half + 1)²`` box around ``p``, the edge replicated (float64).

    Rows, then columns, each sum from 0 in the order of the offsets: a direct sum, not a running one, so a box
    of exact zeros sums to exactly 0 (SciPy's ``uniform_filter`` carries round-off of the values before it).
    """
    h, w = values.shape
    rows = np.empty((h, w))
    for y in prange(h):
        row = rows[y]
        row[:] = 0.0
        for dx in range(-half, half + 1):
            for x in range(w):
                row[x] += values[y, min(max(x + dx, 0), w - 1)]
    for y in prange(h):
        acc = out[y]
        acc[:] = 0.0
        for dy in range(-half, half + 1):
            src = rows[min(max(y + dy, 0), h - 1)]
            for x in range(w):
                acc[x] += src[x]


@njit
def tile_sums_from_integral(c, tile, out):
    """``out[i, j]`` = Σ over tile ``(i, j)`` (size ``tile``, stride ``tile/2``) from the integral image ``c``:
    ``((c[y1, x1] − c[y0, x1]) − c[y1, x0]) + c[y0, x0]``."""
    s = tile // 2
    for i in range(out.shape[0]):
        y0 = i * s
        for j in range(out.shape[1]):
            x0 = j * s
            out[i, j] = c[y0 + tile, x0 + tile] - c[y0, x0 + tile] - c[y0 + tile, x0] + c[y0, x0]


@njit
def integral_image(values, c):
    """``c[1:, 1:] = cumsum(cumsum(values, axis=0), axis=1)`` (the same sums in the same order)."""
    h, w = values.shape
    for j in range(w):
        acc = 0.0
        for i in range(h):
            acc += values[i, j]
            c[i + 1, j + 1] = acc
    for i in range(h):
        acc = 0.0
        for j in range(w):
            acc += c[i + 1, j + 1]
            c[i + 1, j + 1] = acc


@njit(parallel=True)
def zero_test_terms(ref, alt, flow, noise, rho, d_out, var_out):
    """Per pixel: ``(r − a)² − (r − a_u)²`` less its noise-only mean, and that term's noise variance.

    ``a_u`` is ``alt`` sampled bilinearly at ``p + flow(p)`` (position clamped to the image).  With noise
    of variance ``v`` per image and correlation ``ρ`` at the same pixel: ``x = r − a`` has variance
    ``2v(1 − ρ)``, ``y = r − a_u`` has ``v(1 + Σw² − 2ρ w₀)`` (``w`` the bilinear weights, ``w₀`` that of
    the tap at ``p`` itself), ``cov(x, y) = v(1 + w₀)(1 − ρ)``; for Gaussian noise
    ``var(x² − y²) = 2σ_x⁴ + 2σ_y⁴ − 4 cov²``.
    """
    h, w = ref.shape
    for y in prange(h):
        for x in range(w):
            uy = np.float64(flow[0, y, x])
            ux = np.float64(flow[1, y, x])
            sy = min(max(y + uy, 0.0), h - 1.0)
            sx = min(max(x + ux, 0.0), w - 1.0)
            y0, x0, y1, x1, fy, fx = bilinear_cell(sy, sx, h, w)
            au = ((1.0 - fy) * ((1.0 - fx) * alt[y0, x0] + fx * alt[y0, x1])
                  + fy * ((1.0 - fx) * alt[y1, x0] + fx * alt[y1, x1]))
            r = np.float64(ref[y, x])
            dx0 = r - alt[y, x]
            dxu = r - au
            v = noise[y, x]
            sw2 = ((1.0 - fy) ** 2 + fy * fy) * ((1.0 - fx) ** 2 + fx * fx)
            w0 = max(0.0, 1.0 - abs(sy - y)) * max(0.0, 1.0 - abs(sx - x))
            s_x = 2.0 * v * (1.0 - rho)
            s_y = v * (1.0 + sw2 - 2.0 * rho * w0)
            c = v * (1.0 + w0) * (1.0 - rho)
            d_out[y, x] = dx0 * dx0 - dxu * dxu - (s_x - s_y)
            var_out[y, x] = max(2.0 * s_x * s_x + 2.0 * s_y * s_y - 4.0 * c * c, 0.0)


@njit
def blur_decimate_kernel(img, out):
    k0, k1, k2, k3, k4 = PYRAMID_KERNEL
    h, w = img.shape
    oh, ow = out.shape
    v = np.empty((oh, w))
    for i in range(oh):
        y = 2 * i
        r0 = max(y - 2, 0)
        r1 = max(y - 1, 0)
        r3 = min(y + 1, h - 1)
        r4 = min(y + 2, h - 1)
        for x in range(w):
            v[i, x] = (k0 * np.float64(img[r0, x]) + k1 * np.float64(img[r1, x]) + k2 * np.float64(img[y, x])
                       + k3 * np.float64(img[r3, x]) + k4 * np.float64(img[r4, x])) / 16.0
    for i in range(oh):
        for j in range(ow):
            x = 2 * j
            c0 = max(x - 2, 0)
            c1 = max(x - 1, 0)
            c3 = min(x + 1, w - 1)
            c4 = min(x + 2, w - 1)
            out[i, j] = (k0 * v[i, c0] + k1 * v[i, c1] + k2 * v[i, x] + k3 * v[i, c3] + k4 * v[i, c4]) / 16.0


def regularise(vectors: np.ndarray, info: np.ndarray, variance: np.ndarray, lam: float, sweeps: int) -> np.ndarray:
    """Tile vectors pulled towards their 4-neighbours by their confidence (``refine="lk"``, ``smoothness``).

    ``sweeps`` Jacobi sweeps (:data:`spikeref.align_params.SMOOTHNESS_SWEEPS`) from ``û`` towards the minimiser of
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
