"""Oracle for Eq. 1–3: a spike camera pixel, readout by readout."""

import numpy as np

__all__ = ["fire_oracle", "mosaic_radiance_oracle"]


def fire_oracle(charge, threshold, phase):
    """Integrate ``charge[t]`` (``α·L`` per readout) from ``phase``; fire when ``E ≥ E_th``.

    ``threshold`` is one value or one per pixel ``(H, W)``.

    At a spike the accumulator keeps ``E mod E_th`` (Eq. 1); one spike at most
    per readout (Eq. 2).  Returns ``(T, H, W) uint8``.
    """
    t_total, h, w = charge.shape
    thresholds = np.broadcast_to(np.asarray(threshold, dtype=np.float64), (h, w))
    spikes = np.zeros((t_total, h, w), dtype=np.uint8)
    for y in range(h):
        for x in range(w):
            threshold = thresholds[y, x]
            energy = float(phase[y, x])
            for t in range(t_total):
                energy += float(charge[t, y, x])
                if energy >= threshold:
                    spikes[t, y, x] = 1
                    energy -= threshold
                    if energy >= threshold:
                        energy = energy % threshold
    return spikes


def mosaic_radiance_oracle(rgb, cfa):
    """Eq. 3: behind the CFA, pixel ``(y, x)`` sees the channel its filter letter names.

    ``cfa`` is a 4-letter pattern of the upright image's top-left 2×2 cell, read row-major.
    """
    h, w, _ = rgb.shape
    channel = {"R": 0, "G": 1, "B": 2}
    out = np.zeros((h, w), dtype=np.float64)
    for y in range(h):
        for x in range(w):
            letter = cfa[2 * (y % 2) + (x % 2)]
            out[y, x] = rgb[y, x, channel[letter]]
    return out
