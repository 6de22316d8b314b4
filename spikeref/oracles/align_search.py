"""Oracle of the alignment's pyramid and integer tile search (:mod:`spikeref.align`, §4.2 / supplement §8).

HDR+'s tile search, written without the package's kernels: the Gaussian pyramid pixel by pixel
(:func:`gaussian_pyramid_oracle`, the ``[1,4,6,4,1]/16`` kernel of :data:`PYRAMID_TAPS`), the
distance of a tile to an offset copy (:func:`tile_distance_oracle`, L1 or L2, clamped sampling), the
tile grid (:func:`tile_centres`, stride ``tile/2``) and the nearest coarse tiles of the 3-candidate
upsampling by ``argmin`` over all coarse centres (:func:`nearest_tiles_oracle`), and the integer
search of one tile in plain loops: HDR+'s (:func:`search_oracle`) and the noise-aware one
(:func:`noise_aware_search_oracle`, ``AlignParams.prefer_centre > 0``; not in the paper or HDR+) with
its two override rules (zero motion first, then the search centre) as written in
``docs/spec/align.md#noise-aware-search``; the bias and threshold it takes are
:func:`spikeref.oracles.align_noise.bias_and_threshold_oracle`'s.  The coarse-to-fine walk that
puts these together is :func:`spikeref.oracles.align.align_tiles_oracle`.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "PYRAMID_TAPS",
    "blur_decimate_oracle",
    "gaussian_pyramid_oracle",
    "tile_distance_oracle",
    "tile_centres",
    "nearest_tiles_oracle",
    "search_oracle",
    "noise_aware_search_oracle",
]

#: The pyramid's binomial kernel ``[1, 4, 6, 4, 1]`` (divided by 16), HDR+'s.
PYRAMID_TAPS = (1.0, 4.0, 6.0, 4.0, 1.0)


# ----------------------------------------------------------------------------- the pyramid
def blur_decimate_oracle(img):
    """One pyramid step: blur each column then each row by ``[1,4,6,4,1]/16`` with the edge pixel replicated,
    keep rows and columns 0, 2, 4, …  float64 arithmetic on the values of ``img`` as they are, float32 result."""
    h, w = img.shape
    vertical = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            total = 0.0
            for k, tap in enumerate(PYRAMID_TAPS):
                yy = min(max(y + k - 2, 0), h - 1)
                total += tap * float(img[yy, x])
            vertical[y, x] = total / 16.0
    rows = vertical[0::2]
    both = np.zeros(rows.shape)
    for y in range(rows.shape[0]):
        for x in range(w):
            total = 0.0
            for k, tap in enumerate(PYRAMID_TAPS):
                xx = min(max(x + k - 2, 0), w - 1)
                total += tap * rows[y, xx]
            both[y, x] = total / 16.0
    return both[:, 0::2].astype(np.float32)


def gaussian_pyramid_oracle(image, levels):
    """Level 0 = ``image``; level ``k+1``: blur each column then each row by ``[1,4,6,4,1]/16`` with the
    edge pixel replicated, keep rows and columns 0, 2, 4, …  float64 arithmetic, float32 levels."""
    pyramid = [np.asarray(image, np.float32)]
    for _ in range(levels - 1):
        pyramid.append(blur_decimate_oracle(pyramid[-1]))
    return pyramid


# ----------------------------------------------------------------------------- tiles and the integer search
def tile_distance_oracle(ref, alt, oy, ox, tile, dy, dx, norm):
    """Σ over the ``tile × tile`` tile at ``(oy, ox)`` of ``|ref(p) − alt(p + (dy, dx))|^norm`` (norm 1 or 2),
    ``alt`` sampled at clamped coordinates, in float64."""
    h, w = alt.shape
    ys = np.clip(np.arange(oy, oy + tile) + dy, 0, h - 1)
    xs = np.clip(np.arange(ox, ox + tile) + dx, 0, w - 1)
    diff = ref[oy:oy + tile, ox:ox + tile].astype(np.float64) - alt[np.ix_(ys, xs)].astype(np.float64)
    return float(np.sum(np.abs(diff))) if norm == 1 else float(np.sum(diff * diff))


def tile_centres(size, tile):
    """Tile centres (pixel-index coordinates) of the tiles that fit in ``size`` pixels with stride ``tile/2``."""
    stride = tile // 2
    count = (size - tile) // stride + 1
    return np.array([i * stride + (tile - 1) / 2 for i in range(count)])


def nearest_tiles_oracle(fine_centre, coarse_size, coarse_tile):
    """The coarse tile whose centre is nearest to ``fine_centre / 2`` and its neighbour on that side (clamped)."""
    centres = tile_centres(coarse_size, coarse_tile)
    c = fine_centre / 2
    m = int(np.argmin(np.abs(centres - c)))
    n = m + 1 if c > centres[m] else m - 1
    return m, min(max(n, 0), len(centres) - 1)


def search_oracle(ref, alt, oy, ox, tile, centre, radius, norm):
    """Best ``centre + d``, ``d ∈ [−r, r]²``: smallest distance, then closest to the centre, then raster order."""
    best = None
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            dist = tile_distance_oracle(ref, alt, oy, ox, tile, centre[0] + dy, centre[1] + dx, norm)
            key = (dist, dy * dy + dx * dx)
            if best is None or key < best[0]:  # strict: the earlier one in raster order stays on a full tie
                best = (key, (centre[0] + dy, centre[1] + dx))
    return best[1]


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
