"""Oracles for the Bayer split and the bilinear demosaic Ψ (Eq. 13)."""

import numpy as np

from spikeref.oracles.case import OracleCase

__all__ = ["whole_sample_mirror", "bayer_planes_oracle", "demosaic_bilinear_oracle", "GOLDEN_CASES", "CFA_PATTERNS"]

_COLOUR = {"R": 0, "G": 1, "B": 2}


def bayer_planes_oracle(mosaic):
    """``planes[p, i, j] = mosaic[2i + p // 2, 2j + p % 2]`` for a 2-D mosaic."""
    h, w = mosaic.shape
    planes = np.zeros((4, h // 2, w // 2), dtype=mosaic.dtype)
    for p in range(4):
        for i in range(h // 2):
            for j in range(w // 2):
                planes[p, i, j] = mosaic[2 * i + p // 2, 2 * j + p % 2]
    return planes


def whole_sample_mirror(i, n):
    """Index ``i`` of an axis of length ``n`` mirrored about the edge pixels, repeated (``−1 → 1``, ``n → n − 2``;
    period ``2(n − 1)``): the border of the sharper demosaics, which keeps the CFA's parity."""
    if n == 1:
        return 0
    i %= 2 * (n - 1)
    return 2 * (n - 1) - i if i >= n else i


def demosaic_bilinear_oracle(mosaic, cfa="RGGB"):
    """Ψ, pixel by pixel: the weighted mean of the same-colour samples in the 3×3 window.

    Weights ``[[0,1,0],[1,4,1],[0,1,0]]`` for G and ``[[1,2,1],[2,4,2],[1,2,1]]``
    for R/B; outside the image the mosaic is mirrored half-sample
    symmetrically (index −1 reads 0, index H reads H−1).  Float64 throughout.
    """
    h, w = mosaic.shape
    colour_at = lambda y, x: _COLOUR[cfa[(y % 2) * 2 + (x % 2)]]  # noqa: E731
    mirror = lambda i, n: -i - 1 if i < 0 else (2 * n - i - 1 if i >= n else i)  # noqa: E731
    g_weights = [[0, 1, 0], [1, 4, 1], [0, 1, 0]]
    rb_weights = [[1, 2, 1], [2, 4, 2], [1, 2, 1]]
    rgb = np.zeros((h, w, 3), dtype=np.float64)
    for y in range(h):
        for x in range(w):
            for c in range(3):
                weights = g_weights if c == 1 else rb_weights
                total, norm = 0.0, 0.0
                for dy in (-1, 0, 1):
                    for dx in (-1, 0, 1):
                        yy, xx = mirror(y + dy, h), mirror(x + dx, w)
                        if colour_at(yy, xx) == c:
                            total += weights[dy + 1][dx + 1] * float(mosaic[yy, xx])
                            norm += weights[dy + 1][dx + 1]
                rgb[y, x, c] = total / norm
    return rgb


# ----------------------------------------------------------------------------- the golden cases
#: The four 2×2 colour filter arrays, in the order of the Ψ golden cases (written out: ``tests/test_bayer.py``
#: holds it equal to :data:`spikeref.bayer.CFA_PATTERNS`).
CFA_PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")


def _inputs_mosaic():
    return {"mosaic": np.random.default_rng(4).random((6, 8))}


GOLDEN_CASES = (
    OracleCase(
        "bayer_planes", "§4.1 (Fig. 3a)", "spikeref.bayer.bayer_planes", "spikeref.oracles.bayer.bayer_planes_oracle",
        "Mosaic → 4 planes ordered by position (0,0), (0,1), (1,0), (1,1).",
        _inputs_mosaic,
        lambda i: {"planes": bayer_planes_oracle(i["mosaic"])},
        spec="docs/spec/bayer.md#bayer_planes",
    ),
) + tuple(
    OracleCase(
        f"psi_{cfa.lower()}", "Eq. 13 (Ψ)", "spikeref.bayer.demosaic_bilinear",
        "spikeref.oracles.bayer.demosaic_bilinear_oracle",
        f"Bilinear demosaic of a {cfa} mosaic, normalised at the half-sample-symmetric border.",
        _inputs_mosaic,
        (lambda c: lambda i: {"rgb": demosaic_bilinear_oracle(i["mosaic"], c)})(cfa),
        atol=1e-12, params={"cfa": cfa}, spec="docs/spec/bayer.md#psi_rggb-psi_bggr-psi_grbg-psi_gbrg",
    )
    for cfa in CFA_PATTERNS
)
