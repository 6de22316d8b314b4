"""Oracles for Eq. 10–11: the masked volume and mask-aware averaging, pixel by pixel."""

import numpy as np

__all__ = ["masked_volume_oracle", "mask_aware_average_oracle"]

_W = [[0.5, 1.0, 0.5], [1.0, 0.0, 1.0], [0.5, 1.0, 0.5]]


def masked_volume_oracle(image, hs=4, ws=4):
    """``Ω_i``: copy of the ``(H, W)`` image; in every ``hs × ws`` cell the pixel at ``(i // ws, i % ws)``
    is replaced by the weighted mean of its in-image neighbours (weights ``_W``)."""
    h, w = image.shape
    volume = np.zeros((hs * ws, h, w))
    for i in range(hs * ws):
        for y in range(h):
            for x in range(w):
                if y % hs == i // ws and x % ws == i % ws:
                    num = den = 0.0
                    for dy in (-1, 0, 1):
                        for dx in (-1, 0, 1):
                            if 0 <= y + dy < h and 0 <= x + dx < w:
                                num += _W[dy + 1][dx + 1] * image[y + dy, x + dx]
                                den += _W[dy + 1][dx + 1]
                    volume[i, y, x] = num / den
                else:
                    volume[i, y, x] = image[y, x]
    return volume


def mask_aware_average_oracle(outputs, hs=4, ws=4):
    """Eq. 11: at each pixel, the mean of ``outputs[i]`` over the masks ``i`` that hide it."""
    c, h, w = outputs.shape
    out = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            total = count = 0.0
            for i in range(c):
                if y % hs == i // ws and x % ws == i % ws:
                    total += outputs[i, y, x]
                    count += 1
            out[y, x] = total / count
    return out
