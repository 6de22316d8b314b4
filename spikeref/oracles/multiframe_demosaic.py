"""Literal oracle of the multi-frame demosaic (:mod:`spikeref.multiframe_demosaic`), pixel by pixel.

Written from the module's docstring: for each full-resolution pixel and colour, every window, every Bayer plane of
that colour and the 2×2 sites of the plane around the moved position, in Python floats.  Slow: for the small
inputs of the golden case and the tests.
"""

from __future__ import annotations

import math

import numpy as np

from spikeref.oracles.case import OracleCase

__all__ = ["multiframe_demosaic_oracle", "phase_diversity_oracle", "GOLDEN_CASES"]

#: The Bayer planes' offsets in the 2×2 cell, restated (an oracle module imports no fast code).
OFFSETS = ((0, 0), (0, 1), (1, 0), (1, 1))


def multiframe_demosaic_oracle(counts, positions, weights, window, cfa, fallback, sigma=0.6):
    """:func:`spikeref.multiframe_demosaic.multiframe_demosaic` (float64, ``(2h, 2w, 3)``)."""
    s = np.asarray(counts, dtype=np.float64)
    pos = np.asarray(positions, dtype=np.float64)
    wt = np.asarray(weights, dtype=np.float64)
    n, nc, h, w = s.shape
    colour = ["RGB".index(ch) for ch in cfa.upper()]
    # each plane's kernel width: σ over the square root of the planes of its colour (green: two planes, √2 apart)
    sigma_c = [sigma / math.sqrt(colour.count(colour[c])) for c in range(nc)]
    out = np.empty((2 * h, 2 * w, 3))
    for big_y in range(2 * h):
        for big_x in range(2 * w):
            cell_y, cell_x = min(big_y // 2, h - 1), min(big_x // 2, w - 1)
            num, den = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
            for j in range(n):
                omega = wt[j, cell_y, cell_x]
                py, px = pos[j, 0, cell_y, cell_x], pos[j, 1, cell_y, cell_x]
                if not omega > 0 or math.isnan(py) or math.isnan(px):
                    continue
                # where the pixel's content is in window j, in full-resolution pixels
                target_y = big_y + 2.0 * (py - cell_y)
                target_x = big_x + 2.0 * (px - cell_x)
                for c in range(nc):
                    oy, ox = OFFSETS[c]
                    first_y = math.floor((target_y - oy) / 2.0)
                    first_x = math.floor((target_x - ox) / 2.0)
                    for qy in (first_y, first_y + 1):
                        for qx in (first_x, first_x + 1):
                            if not (0 <= qy < h and 0 <= qx < w):
                                continue
                            site_y, site_x = 2 * qy + oy, 2 * qx + ox  # the plane's pixel at full resolution
                            d2 = (site_y - target_y) ** 2 + (site_x - target_x) ** 2
                            g = math.exp(-d2 / (2 * sigma_c[c] ** 2))
                            num[colour[c]] += omega * g * s[j, c, qy, qx] / window
                            den[colour[c]] += omega * g
            for ch in range(3):
                out[big_y, big_x, ch] = num[ch] / den[ch] if den[ch] > 0 else fallback[big_y, big_x, ch]
    return out


def phase_diversity_oracle(positions, weights):
    """:func:`spikeref.multiframe_demosaic.phase_diversity`, cell by cell and window by window (float64 ``(h, w)``)."""
    pos = np.asarray(positions, dtype=np.float64)
    wt = np.asarray(weights, dtype=np.float64)
    n, _, h, w = pos.shape
    out = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            share, total = 0.0, 0.0
            for j in range(n):
                py, px = pos[j, 0, y, x], pos[j, 1, y, x]
                if math.isnan(py) or math.isnan(px):
                    continue
                # the content's offset in full-resolution pixels, and its distance to the nearest even integer
                offsets = []
                for moved in (2.0 * (py - y), 2.0 * (px - x)):
                    nearest_even = 2.0 * round(moved / 2.0)
                    offsets.append(abs(moved - nearest_even))
                off = min(1.0, math.hypot(offsets[0], offsets[1]))
                share += wt[j, y, x] * off
                total += wt[j, y, x]
            out[y, x] = share / total if total > 0 else 0.0
    return out


def _inputs():
    """Five windows of four 5×6 Bayer planes (counts over W = 10): a texture moving by sub-pixel steps; positions
    of a 0.3-px-per-window drift with one window NaN at a corner (left the plane), weights like a robust merge's
    (one window refused over a block), and a fallback that only the pixels with no weighted sample take."""
    rng = np.random.default_rng(50)
    n, h, w = 5, 5, 6
    counts = rng.integers(0, 11, size=(n, 4, h, w)).astype(np.float32)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    positions = np.empty((n, 2, h, w))
    for j in range(n):
        positions[j, 0] = yy + 0.2 * (j - 2)
        positions[j, 1] = xx + 0.3 * (j - 2) + 0.05 * rng.standard_normal((h, w))
    positions[0, :, :2, :2] = np.nan
    weights = np.tile(np.array([1.0, 2.0, 3.0, 2.0, 1.0])[:, None, None], (1, h, w))
    weights[3, 1:4, 2:5] = 0.0  # refused there
    weights[:, 4, 5] = 0.0  # no window at this cell: the fallback
    fallback = np.full((2 * h, 2 * w, 3), 0.25)
    return {"counts": counts, "positions": positions.astype(np.float32), "weights": weights.astype(np.float32),
            "window": np.float64(10.0), "fallback": fallback.astype(np.float32)}


def _outputs(i, demosaic, cfas=("RGGB", "GBRG")):
    return {f"rgb_{cfa.lower()}": np.asarray(demosaic(i["counts"], i["positions"], i["weights"], float(i["window"]),
                                                      cfa, i["fallback"]), np.float64)
            for cfa in cfas}


GOLDEN_CASES = (
    OracleCase(
        "multiframe_demosaic", "— (not in the paper; Eq. 13's Ψ replaced by every merged window's raw samples, "
        "demosaic=\"multiframe\")",
        "spikeref.multiframe_demosaic.multiframe_demosaic",
        "spikeref.oracles.multiframe_demosaic.multiframe_demosaic_oracle",
        "Five windows of four 5×6 Bayer planes of counts (W = 10), positions drifting 0.2 / 0.3 plane px per window "
        "with jitter (window 0 NaN at a corner), weights 1, 2, 3, 2, 1 with window 3 refused over a block and no "
        "window at cell (4, 5), σ = 0.6 full-resolution px: the (10, 12, 3) frame under RGGB (rgb_rggb) and GBRG "
        "(rgb_gbrg); the cell without a window takes the fallback 0.25. The oracle computes in float64, the fast "
        "function returns float32.",
        _inputs, lambda i: _outputs(i, multiframe_demosaic_oracle),
        rtol=1e-5, atol=1e-6,
        params={"sigma": 0.6, "sites": "the 2×2 pixels of each plane around the moved position",
                "cell": "nearest: (Y // 2, X // 2)"},
        spec="docs/spec/multiframe_demosaic.md#multiframe_demosaic",
        outputs=_outputs,
    ),
    OracleCase(
        "phase_diversity", "— (not in the paper; weights the demosaic correction (directional / Malvar–He–Cutler) "
        "added to the multi-frame demosaic)",
        "spikeref.multiframe_demosaic.phase_diversity",
        "spikeref.oracles.multiframe_demosaic.phase_diversity_oracle",
        "The multi-frame demosaic case's positions and weights (five windows of 5×6 cells drifting 0.2 / 0.3 plane "
        "px per window with jitter, window 0 NaN at a corner, window 3 refused over a block, no window at cell "
        "(4, 5)): δ per cell (delta), 0 at the cell without a window.",
        _inputs, lambda i: {"delta": phase_diversity_oracle(i["positions"], i["weights"])},
        rtol=1e-9, atol=1e-12,
        params={"lattice": "even full-resolution pixels (the reference's CFA phase)", "cap": 1.0},
        spec="docs/spec/multiframe_demosaic.md#phase_diversity",
        outputs=lambda i, fn: {"delta": np.asarray(fn(i["positions"], i["weights"]), np.float64)},
    ),
)
