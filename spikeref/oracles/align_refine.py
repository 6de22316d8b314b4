"""Oracle of the alignment's sub-pixel refinement (:mod:`spikeref.align`, §4.2 / supplement §8, and issue 32).

From each tile's integer vector, transcribed without the package's kernels: HDR+'s quadratic fit
(:func:`quadratic_offset_oracle`: ``numpy.linalg.lstsq`` on the 9 × 6 design matrix, accepted within
:data:`PD_TOLERANCE` and :data:`SLACK`), and the options beyond HDR+
(``docs/spec/align.md#lucas-kanade-refinement`` and ``#regularised-tile-field``):
``AlignParams(refine="lk")`` by :func:`lucas_kanade_oracle` (the gradient by :func:`gradient_oracle`
pixel by pixel, every sample by :func:`bilinear_oracle` as a sum over its four weighted taps
(:func:`bilinear_taps`), the 2 × 2 Gauss–Newton system solved by ``numpy.linalg.solve``), and
``smoothness`` by :func:`regularise_oracle` (each Jacobi update solved as a 2 × 2 system;
``sweeps=None`` gives the exact minimiser of the stated energy instead, from the whole ``2N × 2N``
system), each tile weighted by its information over its mean noise variance
(:func:`tile_noise_oracle` of :func:`spikeref.oracles.align_noise.noise_map_oracle`);
:func:`refine_lk_oracle` puts them together for a tile field.  The constants of the specification
(:data:`PD_TOLERANCE`, :data:`SLACK`, :data:`LK_ITERATIONS`, :data:`SMOOTHNESS_SWEEPS`,
:data:`MIN_VARIANCE`) are written out here; ``tests/test_align.py`` holds them equal to
:mod:`spikeref.align`'s.
"""

from __future__ import annotations

import numpy as np

from spikeref.oracles.align_noise import noise_map_oracle

__all__ = [
    "PD_TOLERANCE",
    "SLACK",
    "LK_ITERATIONS",
    "SMOOTHNESS_SWEEPS",
    "MIN_VARIANCE",
    "quadratic_offset_oracle",
    "gradient_oracle",
    "bilinear_cell",
    "bilinear_taps",
    "bilinear_oracle",
    "lucas_kanade_oracle",
    "tile_noise_oracle",
    "regularise_oracle",
    "refine_lk_oracle",
]

#: The sub-pixel fit's ``A`` counts as positive definite when its smaller eigenvalue exceeds this
#: fraction of the largest of the nine distances (and Lucas–Kanade's ``G`` when ``det G`` exceeds
#: it times ``(trace G)²``): the specification's value, stated here on its own so that the oracle does
#: not share a constant with the kernel it checks (``tests/test_align.py`` holds the two equal).
PD_TOLERANCE = 1e-9

#: The sub-pixel offset is accepted when ``|u*| ≤ 1 + SLACK`` in both components.
SLACK = 1e-9

#: Gauss–Newton steps per tile of ``refine="lk"``.
LK_ITERATIONS = 2
#: Jacobi sweeps of the regularised tile field (``smoothness > 0``).
SMOOTHNESS_SWEEPS = 30
#: A tile's mean noise variance is taken as at least this (so that ``J = G / v`` stays finite).
MIN_VARIANCE = 1e-20


# ----------------------------------------------------------------------------- HDR+'s quadratic fit
def quadratic_offset_oracle(d):
    """Least-squares fit ``D(u) ≈ ½uᵀAu + bᵀu + c`` on the grid ``u ∈ {−1,0,1}²``; ``u* = −A⁻¹b``,
    or None when ``A`` is not positive definite (smaller eigenvalue ≤ ``PD_TOLERANCE`` × the largest distance)
    or ``|u*| > 1`` (+ ``SLACK``) in a component."""
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


# ----------------------------------------------------------------------------- Lucas–Kanade refinement
def gradient_oracle(image):
    """``(g_y, g_x)`` of ``image``, float64: central differences ``(P[y+1] − P[y−1]) / 2`` inside, one-sided
    ``P[1] − P[0]`` and ``P[n−1] − P[n−2]`` on the first and last row (column); 0 along an axis of length 1."""
    img = np.asarray(image, np.float64)
    h, w = img.shape
    gy = np.zeros((h, w))
    gx = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            if h > 1:
                if y == 0:
                    gy[y, x] = img[1, x] - img[0, x]
                elif y == h - 1:
                    gy[y, x] = img[h - 1, x] - img[h - 2, x]
                else:
                    gy[y, x] = (img[y + 1, x] - img[y - 1, x]) / 2.0
            if w > 1:
                if x == 0:
                    gx[y, x] = img[y, 1] - img[y, 0]
                elif x == w - 1:
                    gx[y, x] = img[y, w - 1] - img[y, w - 2]
                else:
                    gx[y, x] = (img[y, x + 1] - img[y, x - 1]) / 2.0
    return gy, gx


def bilinear_cell(shape, y, x):
    """``((y0, x0), (y1, x1), f_y, f_x)`` of a bilinear sample at ``(y, x)``, the position clamped to
    ``[0, h − 1] × [0, w − 1]``: ``y0 = ⌊y⌋``, ``f_y = y − y0``, ``y1 = y0 + 1`` (the last row again past it,
    where ``f_y = 0``); the same along ``x``."""
    h, w = shape
    y = min(max(y, 0.0), h - 1.0)
    x = min(max(x, 0.0), w - 1.0)
    y0, x0 = int(np.floor(y)), int(np.floor(x))
    return (y0, x0), (min(y0 + 1, h - 1), min(x0 + 1, w - 1)), y - y0, x - x0


def bilinear_taps(shape, y, x):
    """The four ``((row, column), weight)`` taps of a bilinear sample at ``(y, x)`` (:func:`bilinear_cell`),
    in the order ``(y0, x0), (y0, x1), (y1, x0), (y1, x1)``, each weight the product of its two 1-D weights."""
    (y0, x0), (y1, x1), fy, fx = bilinear_cell(shape, y, x)
    return [((yy, xx), wy * wx) for yy, wy in ((y0, 1.0 - fy), (y1, fy)) for xx, wx in ((x0, 1.0 - fx), (x1, fx))]


def bilinear_oracle(image, y, x):
    """``Σ`` weight · ``image[tap]`` over the four taps of the bilinear sample at ``(y, x)`` (clamped), float64."""
    return sum(weight * float(image[tap]) for tap, weight in bilinear_taps(np.shape(image), y, x))


def lucas_kanade_oracle(ref, alt, oy, ox, tile, start, iterations=LK_ITERATIONS, gradient=None):
    """Gauss–Newton steps of a translation for the tile at ``(oy, ox)``: ``(u (2,) float64, info (3,) float64)``.

    From ``u = start``, each step sums over the tile's pixels ``p`` whose moved position ``p + u`` lies in
    ``[0, h − 1] × [0, w − 1]`` (the others are left out): ``a = alt(p + u)`` and ``g = ∇alt(p + u)``
    (both bilinear samples; the gradient images by :func:`gradient_oracle` of ``alt``),
    ``G = Σ g gᵀ``, ``b = Σ g (ref(p) − a)``.  If ``det G > PD_TOLERANCE · (trace G)²`` (and ``> 0``) the step
    ``Δ = G⁻¹ b`` is added, each component clipped to ``[−1, 1]``; otherwise the steps stop.
    ``info = (G_yy, G_yx, G_xx)`` of the last ``G`` summed (the tile's information, before the noise).
    ``gradient``: ``gradient_oracle(alt)`` when already made.
    """
    h, w = alt.shape
    gy, gx = gradient_oracle(alt) if gradient is None else gradient
    u = np.array(start, np.float64)
    info = np.zeros(3)
    for _ in range(iterations):
        g_mat = np.zeros((2, 2))
        b = np.zeros(2)
        for y in range(oy, oy + tile):
            for x in range(ox, ox + tile):
                py, px = y + u[0], x + u[1]
                if not (0.0 <= py <= h - 1.0 and 0.0 <= px <= w - 1.0):
                    continue  # the moved sample lies outside the image: left out
                g = np.array([bilinear_oracle(gy, py, px), bilinear_oracle(gx, py, px)])
                e = float(ref[y, x]) - bilinear_oracle(alt, py, px)
                g_mat += np.outer(g, g)
                b += g * e
        info = np.array([g_mat[0, 0], g_mat[0, 1], g_mat[1, 1]])
        det = g_mat[0, 0] * g_mat[1, 1] - g_mat[0, 1] * g_mat[1, 0]
        if not (det > PD_TOLERANCE * np.trace(g_mat) ** 2 and det > 0.0):
            break  # singular (no texture, or an edge in one direction only): keep the vector
        u = u + np.clip(np.linalg.solve(g_mat, b), -1.0, 1.0)
    return u, info


def tile_noise_oracle(noise_map, tile, shape):
    """``(ty, tx)``: the mean of ``noise_map`` over each level-0 tile (``tile × tile`` pixels, stride ``tile/2``)."""
    ty, tx = shape
    s = tile // 2
    out = np.zeros((ty, tx))
    for i in range(ty):
        for j in range(tx):
            total = 0.0
            for y in range(i * s, i * s + tile):
                for x in range(j * s, j * s + tile):
                    total += float(noise_map[y, x])
            out[i, j] = total / (tile * tile)
    return out


def regularise_oracle(vectors, info, variance, lam, sweeps=SMOOTHNESS_SWEEPS):
    """The tile field minimising ``E(u) = Σ_i (u_i − û_i)ᵀ J_i (u_i − û_i) + λ Σ_{i~j} |u_i − u_j|²``.

    ``û = vectors (ty, tx, 2)``, ``J_i = [[G_yy, G_yx], [G_yx, G_xx]] / max(v_i, MIN_VARIANCE)`` from
    ``info (ty, tx, 3)`` and ``variance (ty, tx)``; ``i ~ j`` the 4-neighbour pairs of the tile grid.
    ``sweeps`` Jacobi sweeps from ``û``: every tile at once, ``u_i ← (J_i + λ n_i I)⁻¹ (J_i û_i + λ Σ_{j~i} u_j)``
    with the neighbours' values of the previous sweep (``n_i`` their number; ``∂E/∂u_i = 0`` for fixed
    neighbours).  ``sweeps=None``: the exact minimiser, from the whole linear system.  A single tile,
    or ``λ ≤ 0``, keeps ``û``.  float64.
    """
    hat = np.asarray(vectors, np.float64)
    ty, tx = hat.shape[:2]
    if ty * tx == 1 or lam <= 0:
        return hat.copy()
    jac = np.zeros((ty, tx, 2, 2))
    for i in range(ty):
        for j in range(tx):
            v = max(float(variance[i, j]), MIN_VARIANCE)
            jac[i, j] = np.array([[info[i, j, 0], info[i, j, 1]], [info[i, j, 1], info[i, j, 2]]]) / v

    def neighbours(i, j):
        return [(a, b) for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)) if 0 <= a < ty and 0 <= b < tx]

    if sweeps is None:  # ∇E = 0: (J + λ L ⊗ I₂) u = J û, L the grid's graph Laplacian
        n = ty * tx
        system = np.zeros((2 * n, 2 * n))
        rhs = np.zeros(2 * n)
        for i in range(ty):
            for j in range(tx):
                k = i * tx + j
                system[2 * k:2 * k + 2, 2 * k:2 * k + 2] += jac[i, j]
                rhs[2 * k:2 * k + 2] = jac[i, j] @ hat[i, j]
                for a, b in neighbours(i, j):
                    m = a * tx + b
                    system[2 * k:2 * k + 2, 2 * k:2 * k + 2] += lam * np.eye(2)
                    system[2 * k:2 * k + 2, 2 * m:2 * m + 2] -= lam * np.eye(2)
        return np.linalg.solve(system, rhs).reshape(ty, tx, 2)
    cur = hat.copy()
    for _ in range(sweeps):
        new = np.zeros_like(cur)
        for i in range(ty):
            for j in range(tx):
                near = neighbours(i, j)
                pull = sum((cur[a, b] for a, b in near), np.zeros(2))
                new[i, j] = np.linalg.solve(jac[i, j] + lam * len(near) * np.eye(2), jac[i, j] @ hat[i, j] + lam * pull)
        cur = new
    return cur


def refine_lk_oracle(ref, alt, tile, vectors, shape, smoothness, noise):
    """``(ty, tx, 2) float32``: every tile's integer vector refined by :func:`lucas_kanade_oracle`, then the field
    regularised by :func:`regularise_oracle` when ``smoothness > 0``.

    Parameters
    ----------
    ref, alt : ndarray ``(h, w)``
        The level-0 images.
    tile : int
        Tile side (stride ``tile/2``).
    vectors : mapping
        ``vectors[i, j]`` the integer vector ``(vy, vx)`` of tile ``(i, j)``.
    shape : tuple ``(ty, tx)``
        The tile grid.
    smoothness : float
        ``λ`` of :func:`regularise_oracle` (0: no regularisation).
    noise : float, ndarray or None
        The level-0 noise variance, as :func:`~spikeref.oracles.align_noise.noise_map_oracle` takes it.
    """
    ty, tx = shape
    gradient = gradient_oracle(alt)
    refined = np.zeros((ty, tx, 2))
    info = np.zeros((ty, tx, 3))
    for i in range(ty):
        for j in range(tx):
            refined[i, j], info[i, j] = lucas_kanade_oracle(ref, alt, i * (tile // 2), j * (tile // 2), tile,
                                                            vectors[i, j], gradient=gradient)
    if smoothness > 0:
        variance = tile_noise_oracle(noise_map_oracle(noise, ref, alt), tile, shape)
        refined = regularise_oracle(refined, info, variance, smoothness)
    return refined.astype(np.float32)
