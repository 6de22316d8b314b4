"""Oracle for the composed warp (:mod:`spikeref.compose`; not in the paper), pixel by pixel and path by path."""

import math

import numpy as np

__all__ = ["composed_warp_oracle"]


def _keys(t):
    """Keys' cubic convolution kernel with a = −1/2 (Catmull–Rom) at distance ``t``."""
    t = abs(t)
    if t < 1:
        return 1.5 * t ** 3 - 2.5 * t ** 2 + 1
    if t < 2:
        return -0.5 * t ** 3 + 2.5 * t ** 2 - 4 * t + 2
    return 0.0


def _bilinear_clamped(image, y, x):
    h, w = image.shape
    y = min(max(y, 0.0), h - 1.0)
    x = min(max(x, 0.0), w - 1.0)
    y0, x0 = math.floor(y), math.floor(x)
    y1, x1 = min(y0 + 1, h - 1), min(x0 + 1, w - 1)
    fy, fx = y - y0, x - x0
    return ((1 - fy) * (1 - fx) * image[y0, x0] + (1 - fy) * fx * image[y0, x1]
            + fy * (1 - fx) * image[y1, x0] + fy * fx * image[y1, x1])


def _cubic_clamped(image, y, x):
    h, w = image.shape
    y0, x0 = math.floor(y), math.floor(x)
    total = 0.0
    for yy in range(y0 - 1, y0 + 3):
        for xx in range(x0 - 1, x0 + 3):
            weight = _keys(y - yy) * _keys(x - xx)
            total += weight * image[min(max(yy, 0), h - 1), min(max(xx, 0), w - 1)]
    return total


def composed_warp_oracle(counts, bank, hops, targets, window, resample="path"):
    """``I_L(x) = Σ_π v_π S_{t_π}(x_π) / (W Σ_π v_π)``, clipped to [0, 1], ``x_π`` moved hop by hop along the flows.

    ``resample="window"``: ``I_L(x) = Σ_j n_j S_j(x̄_j) / (W Σ_j n_j)``, ``x̄_j`` the mean position of the
    ``n_j`` paths inside the plane that end in window ``j``.
    """
    counts = np.asarray(counts, dtype=np.float64)
    bank = np.asarray(bank, dtype=np.float64)
    n, nc, h, w = counts.shape
    out = np.zeros((nc, h, w))
    for y in range(h):
        for x in range(w):
            inside = []  # (window, position) of every path that ends inside the plane
            for path, target in zip(hops, targets, strict=True):
                sy, sx = float(y), float(x)
                for f in path:
                    if f >= 0:
                        dy = _bilinear_clamped(bank[f, 0], sy, sx)
                        dx = _bilinear_clamped(bank[f, 1], sy, sx)
                        sy, sx = sy + dy, sx + dx
                if -0.5 <= sy <= h - 0.5 and -0.5 <= sx <= w - 0.5:
                    inside.append((target, sy, sx))
            if not inside:
                continue
            total = np.zeros(nc)
            if resample == "path":
                for target, sy, sx in inside:
                    for c in range(nc):
                        total[c] += _cubic_clamped(counts[target, c], sy, sx)
            else:
                for j in sorted({t for t, _, _ in inside}):
                    ys = [sy for t, sy, _ in inside if t == j]
                    xs = [sx for t, _, sx in inside if t == j]
                    mean_y, mean_x = sum(ys) / len(ys), sum(xs) / len(xs)
                    for c in range(nc):
                        total[c] += len(ys) * _cubic_clamped(counts[j, c], mean_y, mean_x)
            out[:, y, x] = np.clip(total / len(inside) / window, 0.0, 1.0)  # a rate lies in [0, 1]
    return out
