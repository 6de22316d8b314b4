"""Oracle of the HDR+ tile alignment (:mod:`spikeref.align`): tiles, offsets and pixels one at a time.

A literal transcription of the module's description, written without its kernels:
the pyramid pixel by pixel, every tile and every offset in plain loops, nearest coarse tiles
by ``argmin`` over all coarse centres, the sub-pixel quadratic by ``numpy.linalg.lstsq`` on the
9 × 6 design matrix, and the per-pixel flow by ``numpy.interp`` (clamped linear interpolation)
along each axis.

The noise-aware search (``AlignParams.prefer_centre > 0``; not in the paper or HDR+) is
transcribed the same way, without the package's code: Immerkær's response pixel by pixel
(:func:`immerkaer_response_oracle`), the 15 × 15 box of :func:`local_noise_oracle` as a sum over
its 225 clamped offsets, the pyramid's composite kernels by written-out convolutions
(:func:`level_noise_factors_oracle`), each tile's bias and threshold as plain sums over its
pixels, and the search's two override rules (zero motion first, then the search centre) as
written in ``docs/spec/align.md#noise-aware-search``.  Only the constants ``PD_TOLERANCE`` and
``SLACK`` of the sub-pixel fit, and the parameter class, come from :mod:`spikeref.align`.
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
    "immerkaer_response_oracle",
    "estimate_noise_oracle",
    "local_noise_oracle",
    "estimate_noise_correlation_oracle",
    "level_noise_factors_oracle",
    "noise_aware_search_oracle",
]

_TAPS = (1.0, 4.0, 6.0, 4.0, 1.0)


def _default_params():
    from spikeref.align import AlignParams

    return AlignParams()


def _blur_decimate_oracle(img):
    """One pyramid step: blur each column then each row by ``[1,4,6,4,1]/16`` with the edge pixel replicated,
    keep rows and columns 0, 2, 4, …  float64 arithmetic on the values of ``img`` as they are, float32 result."""
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
    return both[:, 0::2].astype(np.float32)


def gaussian_pyramid_oracle(image, levels):
    """Level 0 = ``image``; level ``k+1``: blur each column then each row by ``[1,4,6,4,1]/16`` with the
    edge pixel replicated, keep rows and columns 0, 2, 4, …  float64 arithmetic, float32 levels."""
    pyramid = [np.asarray(image, np.float32)]
    for _ in range(levels - 1):
        pyramid.append(_blur_decimate_oracle(pyramid[-1]))
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


def align_tiles_oracle(reference, alternate, step=0, params=None, noise=None, correlation=None):
    """``(vectors (ty, tx, 2) float32, tile)``: coarse-to-fine search with 3-candidate upsampling, then sub-pixel.

    With ``params.prefer_centre = z > 0`` the search is the noise-aware one
    (``docs/spec/align.md#noise-aware-search``): ``noise`` is the level-0 noise variance of each image
    (a number or an ``(h, w)`` map; default ``½ (local_noise(ref) + local_noise(alt))``) and
    ``correlation`` the correlation ``ρ`` of the two images' noise at the same pixel (default
    :func:`estimate_noise_correlation_oracle`), clipped below at −½.  Both are ignored when ``z = 0``.
    """
    params = _default_params() if params is None else params
    tile = params.tile_by_step[min(step, len(params.tile_by_step) - 1)]
    ref_pyr = gaussian_pyramid_oracle(reference, params.levels)
    alt_pyr = gaussian_pyramid_oracle(alternate, params.levels)
    z = params.prefer_centre
    if z > 0:
        noise_pyr, factors, rho = _noise_inputs_oracle(ref_pyr[0], alt_pyr[0], params.levels, noise, correlation)
    coarse = None  # {(i, j): (vy, vx)} of the previous level, and its image size and tile size
    for k in range(params.levels - 1, -1, -1):
        ref, alt = ref_pyr[k], alt_pyr[k]
        t = tile if k == 0 else params.coarse_tile
        cy, cx = _centres(ref.shape[0], t), _centres(ref.shape[1], t)
        vectors = {}
        for i in range(len(cy)):
            for j in range(len(cx)):
                oy, ox = i * (t // 2), j * (t // 2)
                if z > 0:
                    bias, thresh = _bias_and_threshold_oracle(noise_pyr[k], factors[k], oy, ox, t, k > 0, z, rho)
                    up_bias = _bias_and_threshold_oracle(noise_pyr[k], factors[k], oy, ox, t, False, z, rho)[0]
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


# ----------------------------------------------------------------------------- noise-aware search
#: ``ρ`` is clipped below at −½.
_MIN_CORRELATION = -0.5
#: Side of the box of :func:`local_noise_oracle`.
_BOX = 15


def immerkaer_response_oracle(image):
    """``|4·P[y, x] − 2·(4 edge neighbours) + (4 corner neighbours)|`` at every interior pixel, ``(h−2, w−2)`` float64.

    The three groups summed apart (in the order up, down, left, right and top-left, top-right,
    bottom-left, bottom-right), then combined as written: a flat image gives exactly 0.
    """
    img = np.asarray(image, np.float64)
    h, w = img.shape
    out = np.zeros((h - 2, w - 2))
    for y in range(1, h - 1):
        for x in range(1, w - 1):
            edges = img[y - 1, x] + img[y + 1, x] + img[y, x - 1] + img[y, x + 1]
            corners = img[y - 1, x - 1] + img[y - 1, x + 1] + img[y + 1, x - 1] + img[y + 1, x + 1]
            out[y - 1, x - 1] = abs(4.0 * img[y, x] - 2.0 * edges + corners)
    return out


def estimate_noise_oracle(image):
    """``(√(π/2) · mean(response) / 6)²`` of the float32 ``image`` (Immerkær 1996), a float."""
    r = immerkaer_response_oracle(np.asarray(image, np.float32))
    return float((np.sqrt(np.pi / 2.0) * (r.sum() / r.size) / 6.0) ** 2)


def local_noise_oracle(image, box=_BOX):
    """Per pixel ``(√(π/2) · m / 6)²``, ``m`` the mean of the response over the ``box × box`` box centred there.

    The ``(h−2, w−2)`` response is first padded by one pixel on each side by edge replicate to
    ``h × w``; the box then reads that map at clamped coordinates (edge replicate again).
    """
    r = immerkaer_response_oracle(np.asarray(image, np.float32))
    h, w = r.shape[0] + 2, r.shape[1] + 2
    padded = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            padded[y, x] = r[min(max(y - 1, 0), h - 3), min(max(x - 1, 0), w - 3)]
    half = box // 2
    total = np.zeros((h, w))
    for dy in range(-half, half + 1):  # Σ over the box's offsets, every pixel at once
        ys = np.clip(np.arange(h) + dy, 0, h - 1)
        for dx in range(-half, half + 1):
            xs = np.clip(np.arange(w) + dx, 0, w - 1)
            total += padded[np.ix_(ys, xs)]
    return (np.sqrt(np.pi / 2.0) * (total / (box * box)) / 6.0) ** 2


def estimate_noise_correlation_oracle(reference, alternate):
    """``clip(1 − σ²(R − A) / (σ²(R) + σ²(A)), −1, 1)``, 0 when ``σ²(R) + σ²(A) ≤ 0``; ``σ²`` =
    :func:`estimate_noise_oracle`, ``R − A`` of the float32 images taken in float64 and rounded to float32."""
    ref = np.asarray(reference, np.float32)
    alt = np.asarray(alternate, np.float32)
    total = estimate_noise_oracle(ref) + estimate_noise_oracle(alt)
    if total <= 0:
        return 0.0
    diff = (ref.astype(np.float64) - alt.astype(np.float64)).astype(np.float32)
    return min(max(1.0 - estimate_noise_oracle(diff) / total, -1.0), 1.0)


def level_noise_factors_oracle(levels):
    """``[(F_k, S_k)]`` for ``k = 0 … levels−1``: white noise of unit variance at level 0, seen at level ``k``.

    ``h_0 = [1]``, ``h_{k+1} = h_k ∗ up_k`` (``up_k`` = ``[1,4,6,4,1]/16`` with ``2^k − 1`` zeros between
    taps; full convolution); ``e_k = Σ h_k²``; ``ρ_k(m) = Σ_i h_k[i] h_k[i + m·2^k] / e_k`` for
    ``m = 0 … ⌈len(h_k)/2^k⌉ − 1``; ``F_k = e_k²``, ``S_k = (ρ_k(0)² + 2 Σ_{m≥1} ρ_k(m)²)²``.
    """
    h = [1.0]
    out = []
    for k in range(levels):
        spacing = 2 ** k
        energy = sum(v * v for v in h)
        count = (len(h) + spacing - 1) // spacing
        rho = []
        for m in range(count):
            total = 0.0
            for i in range(len(h) - m * spacing):
                total += h[i] * h[i + m * spacing]
            rho.append(total / energy)
        s1 = rho[0] ** 2 + 2.0 * sum(r * r for r in rho[1:])
        out.append((energy ** 2, s1 ** 2))
        up = [0.0] * (4 * spacing + 1)
        for n, tap in enumerate(_TAPS):
            up[n * spacing] = tap / 16.0
        conv = [0.0] * (len(h) + len(up) - 1)
        for i, a in enumerate(h):
            for j, b in enumerate(up):
                conv[i + j] += a * b
        h = conv
    return out


def _noise_inputs_oracle(ref, alt, levels, noise, correlation):
    """The noise pyramid ``V_0 … V_{levels−1}`` (float64 arrays), the factors ``(F_k, S_k)`` and the clipped ``ρ``.

    ``V_0`` is the noise map as given (float64, not rounded); ``V_{k+1}`` is the pyramid step of
    ``V_k`` (rounded to float32, then used as float64).
    """
    shape = ref.shape
    if noise is None:
        v0 = 0.5 * (local_noise_oracle(ref) + local_noise_oracle(alt))
    else:
        v0 = np.broadcast_to(np.asarray(noise, np.float64), shape).copy()
    pyramid = [v0]
    for _ in range(levels - 1):
        pyramid.append(_blur_decimate_oracle(pyramid[-1]).astype(np.float64))
    rho = estimate_noise_correlation_oracle(ref, alt) if correlation is None else float(correlation)
    return pyramid, level_noise_factors_oracle(levels), max(rho, _MIN_CORRELATION)


def _bias_and_threshold_oracle(var_k, factors, oy, ox, tile, l2, z, rho):
    """``(bias, thresh)`` of the tile at ``(oy, ox)`` of level ``k`` (variance map ``var_k``, factors ``(F_k, S_k)``).

    ``v = V_k · F_k`` per pixel, ``r = min(ρ, 0)``; L2 (levels ≥ 1): ``bias = −2r Σ v``,
    ``thresh = z √(12 S_k Σ v²)``; L1 (level 0): ``bias = √(2/π)(√(1 − r) − 1) Σ √(2v)``,
    ``thresh = z √(c_1 S_k Σ v)``, ``c_1 = 4 − (8/π)(√¾ + ½ arcsin ½)``.
    """
    f, s = factors
    r = min(rho, 0.0)
    sum_v = sum_v2 = sum_sqrt = 0.0
    for y in range(oy, oy + tile):
        for x in range(ox, ox + tile):
            v = float(var_k[y, x]) * f
            sum_v += v
            sum_v2 += v * v
            sum_sqrt += np.sqrt(2.0 * v)
    if l2:
        return -2.0 * r * sum_v, z * np.sqrt(12.0 * s * sum_v2)
    c1 = 4.0 - (8.0 / np.pi) * (np.sqrt(0.75) + 0.5 * np.arcsin(0.5))
    return np.sqrt(2.0 / np.pi) * (np.sqrt(1.0 - r) - 1.0) * sum_sqrt, z * np.sqrt(c1 * s * sum_v)


def noise_aware_search_oracle(ref, alt, oy, ox, tile, centre, radius, norm, bias, thresh):
    """The noise-aware integer search of one tile: ``(vy, vx)``.

    The plain search around ``centre`` (smallest distance, then closest to the centre, then raster
    order) with the zero offset's distance lowered by ``bias``; then zero motion if its (lowered)
    distance exceeds the best by at most ``thresh`` — whether or not zero lies in the window —, else
    the centre if its distance exceeds the best by at most ``thresh``, else the best offset.
    """
    best = None
    at_centre = None
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            u = (centre[0] + dy, centre[1] + dx)
            dist = tile_distance_oracle(ref, alt, oy, ox, tile, u[0], u[1], norm)
            if u == (0, 0):
                dist -= bias
            if (dy, dx) == (0, 0):
                at_centre = dist
            key = (dist, dy * dy + dx * dx)
            if best is None or key < best[0]:
                best = (key, u)
    best_dist = best[0][0]
    at_zero = tile_distance_oracle(ref, alt, oy, ox, tile, 0, 0, norm) - bias
    if at_zero - best_dist <= thresh:  # zero motion first …
        return (0, 0)
    if at_centre - best_dist <= thresh:  # … then the search centre
        return (int(centre[0]), int(centre[1]))
    return best[1]


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


def align_oracle(reference, alternate, step=0, params=None, noise=None, correlation=None):
    """``flow_from_tiles_oracle(*align_tiles_oracle(...), shape)``."""
    vectors, tile = align_tiles_oracle(reference, alternate, step, params, noise, correlation)
    return flow_from_tiles_oracle(vectors, tile, np.shape(reference))
