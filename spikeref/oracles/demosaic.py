"""Oracle for the Malvar–He–Cutler demosaic (:mod:`spikeref.demosaic`; an option beyond the paper's Ψ)."""

import numpy as np

from spikeref.oracles.bayer import CFA_PATTERNS, whole_sample_mirror
from spikeref.oracles.case import OracleCase

__all__ = ["demosaic_mhc_oracle", "GOLDEN_CASES"]

_G_AT_RB = [[0, 0, -1, 0, 0], [0, 0, 2, 0, 0], [-1, 2, 4, 2, -1], [0, 0, 2, 0, 0], [0, 0, -1, 0, 0]]
_AT_G_ROW = [[0, 0, 0.5, 0, 0], [0, -1, 0, -1, 0], [-1, 4, 5, 4, -1], [0, -1, 0, -1, 0], [0, 0, 0.5, 0, 0]]
_AT_G_COL = [list(r) for r in zip(*_AT_G_ROW, strict=True)]
_AT_OPPOSITE = [[0, 0, -1.5, 0, 0], [0, 2, 0, 2, 0], [-1.5, 0, 6, 0, -1.5], [0, 2, 0, 2, 0], [0, 0, -1.5, 0, 0]]


def demosaic_mhc_oracle(mosaic, cfa="RGGB"):
    """Pixel by pixel: the sampled colour kept, the other two from the 5×5 filters (eighths), ≥ 0.

    Beyond the border the mosaic is mirrored about its edge pixels (index −1 → 1, ``H`` → ``H − 2``,
    repeated for small images).
    """
    m = np.asarray(mosaic, dtype=np.float64)
    h, w = m.shape
    colour = [[cfa[(y % 2) * 2 + (x % 2)] for x in range(w)] for y in range(h)]

    def at(y, x):
        return m[whole_sample_mirror(y, h), whole_sample_mirror(x, w)]

    def filt(kernel, y, x):
        return sum(kernel[i][j] * at(y + i - 2, x + j - 2) for i in range(5) for j in range(5)) / 8.0

    out = np.zeros((h, w, 3))
    for y in range(h):
        for x in range(w):
            here = colour[y][x]
            for c, name in enumerate("RGB"):
                if here == name:
                    v = m[y, x]
                elif name == "G":
                    v = filt(_G_AT_RB, y, x)
                elif here == "G":
                    v = filt(_AT_G_ROW if name in cfa[(y % 2) * 2:(y % 2) * 2 + 2] else _AT_G_COL, y, x)
                else:
                    v = filt(_AT_OPPOSITE, y, x)
                out[y, x, c] = max(v, 0.0)
    return out


# ----------------------------------------------------------------------------- the golden cases
def _inputs_mhc():
    return {"mosaic": np.random.default_rng(41).random((10, 12))}


def _mhc_outputs(i, demosaic):
    return {f"rgb_{c.lower()}": demosaic(i["mosaic"], c) for c in CFA_PATTERNS}


GOLDEN_CASES = (
    OracleCase(
        "demosaic_mhc", "— (not in the paper; ReconstructParams(demosaic=\"mhc\"), beyond Eq. 13's Ψ)",
        "spikeref.demosaic.demosaic_mhc", "spikeref.oracles.demosaic.demosaic_mhc_oracle",
        "Malvar–He–Cutler (2004) demosaic of a random 10×12 mosaic with each of the four patterns: the sampled "
        "colour kept, the others from the five 5×5 filters in eighths, the mosaic mirrored about its edge "
        "pixels (index −1 → 1), negative results clipped to 0.",
        _inputs_mhc, lambda i: _mhc_outputs(i, demosaic_mhc_oracle), rtol=1e-10, atol=1e-12,
        params={"cfas": list(CFA_PATTERNS)},
        spec="docs/spec/bayer.md#demosaic_mhc",
        outputs=_mhc_outputs,
    ),
)
