"""The kernels of Eq. 14–15's warp (:mod:`spikeref.warp` reads like the paper; the speed is here).

Backward bilinear sampling of ``K`` frames, out-of-image taps dropped and the weights renormalised, each
output value summed by one job in a fixed order.  Nothing here checks its arguments: the public functions
of :mod:`spikeref.warp` do; the oracles are :mod:`spikeref.oracles.warp`.
"""

from __future__ import annotations

import numpy as np

from spikeref._jit import njit, prange

__all__ = ["four_taps", "taps", "warp_average_kernel", "warp_bilinear_kernel"]


@njit(inline="always")
def taps(y, x, dy, dx):
    """Integer corner and fractional parts of the sample at ``(y + dy, x + dx)``."""
    sy = y + dy
    sx = x + dx
    y0 = int(np.floor(sy))
    x0 = int(np.floor(sx))
    return y0, x0, sy - y0, sx - x0


@njit(inline="always")
def four_taps(acc, im, y0, x0, w00, w01, w10, w11):
    # acc + the four taps of one plane (float32 after every tap, in the order (0, 0), (0, 1), (1, 0), (1, 1))
    a = np.float32(acc + w00 * im[y0, x0])
    a = np.float32(a + w01 * im[y0, x0 + 1])
    a = np.float32(a + w10 * im[y0 + 1, x0])
    return np.float32(a + w11 * im[y0 + 1, x0 + 1])


@njit(parallel=True)
def warp_average_kernel(images, flows, out):
    """``out[c] = Σ_k s_k[c] / Σ_k w_k``: images ``(K, C, h, w)``, flows ``(K, 2, h, w)``, out ``(C, h, w)``.

    The sums are float32 after every tap, in the order tap (0, 0), (0, 1), (1, 0), (1, 1) per frame;
    a sample whose four taps are all inside takes a branch-free path that adds the same terms in
    that order (its zero weights add exact zeros: the same values, but a sum of negative zeros may
    now be +0), the others drop their outside and zero taps.  Four planes (the Bayer planes) keep
    their sums in registers (``C = 4``, 15 % faster); other ``C`` in a row's array.
    """
    n, nc, h, w = images.shape
    four = nc == 4
    for y in prange(h):
        acc = np.empty(nc, np.float32)
        for x in range(w):
            acc[:] = 0.0
            a0 = a1 = a2 = a3 = np.float32(0.0)  # acc[0 … 3] while four
            wsum = 0.0
            for k in range(n):
                y0, x0, fy, fx = taps(y, x, flows[k, 0, y, x], flows[k, 1, y, x])
                if y0 >= 0 and y0 + 1 < h and x0 >= 0 and x0 + 1 < w:
                    w00 = (1.0 - fy) * (1.0 - fx)
                    w01 = (1.0 - fy) * fx
                    w10 = fy * (1.0 - fx)
                    w11 = fy * fx
                    wsum = wsum + w00 + w01 + w10 + w11
                    if four:
                        a0 = four_taps(a0, images[k, 0], y0, x0, w00, w01, w10, w11)
                        a1 = four_taps(a1, images[k, 1], y0, x0, w00, w01, w10, w11)
                        a2 = four_taps(a2, images[k, 2], y0, x0, w00, w01, w10, w11)
                        a3 = four_taps(a3, images[k, 3], y0, x0, w00, w01, w10, w11)
                    else:
                        for c in range(nc):
                            acc[c] = four_taps(acc[c], images[k, c], y0, x0, w00, w01, w10, w11)
                    continue
                if four:
                    acc[0], acc[1], acc[2], acc[3] = a0, a1, a2, a3
                for ty in range(2):
                    yy = y0 + ty
                    if yy < 0 or yy >= h:
                        continue
                    wy = fy if ty else 1.0 - fy
                    for tx in range(2):
                        xx = x0 + tx
                        if xx < 0 or xx >= w:
                            continue
                        wt = wy * (fx if tx else 1.0 - fx)
                        if wt == 0.0:
                            continue
                        wsum += wt
                        for c in range(nc):
                            acc[c] += wt * images[k, c, yy, xx]
                if four:
                    a0, a1, a2, a3 = acc[0], acc[1], acc[2], acc[3]
            if four:
                acc[0], acc[1], acc[2], acc[3] = a0, a1, a2, a3
            for c in range(nc):
                out[c, y, x] = acc[c] / wsum if wsum > 0.0 else 0.0


@njit(parallel=True)
def warp_bilinear_kernel(image, flow, out, weight):
    """One image ``(C, h, w)``: partial sums ``out`` and in-image weights ``weight`` (not renormalised)."""
    nc, h, w = image.shape
    for y in prange(h):
        for x in range(w):
            for c in range(nc):
                out[c, y, x] = 0.0
            wsum = 0.0
            y0, x0, fy, fx = taps(y, x, flow[0, y, x], flow[1, y, x])
            for ty in range(2):
                yy = y0 + ty
                if yy < 0 or yy >= h:
                    continue
                wy = fy if ty else 1.0 - fy
                for tx in range(2):
                    xx = x0 + tx
                    if xx < 0 or xx >= w:
                        continue
                    wt = wy * (fx if tx else 1.0 - fx)
                    wsum += wt
                    for c in range(nc):
                        out[c, y, x] += wt * image[c, yy, xx]
            weight[y, x] = wsum
