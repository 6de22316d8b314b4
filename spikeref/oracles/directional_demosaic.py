"""Oracle for the Menon–Andriani–Calvagno directional demosaic (:mod:`spikeref.directional_demosaic`; beyond Ψ)."""

import numpy as np

from spikeref.oracles.bayer import CFA_PATTERNS, whole_sample_mirror
from spikeref.oracles.case import OracleCase

__all__ = ["demosaic_ddfapd_oracle", "GOLDEN_CASES"]

_GREEN = (-0.25, 0.5, 0.5, 0.5, -0.25)


def demosaic_ddfapd_oracle(mosaic, cfa="RGGB"):
    """Pixel by pixel, the four steps of the module doc of :mod:`spikeref.directional_demosaic`, ≥ 0.

    Every read beyond the border is mirrored about the edge pixels (index −1 → 1, ``H`` → ``H − 2``, repeated),
    whatever it reads: the mosaic, a colour difference, a variation or an estimate of step 3.
    """
    m = np.asarray(mosaic, dtype=np.float64)
    h, w = m.shape

    def colour(y, x):
        return cfa[(y % 2) * 2 + (x % 2)]

    def get(a, y, x):
        return a[whole_sample_mirror(y, h), whole_sample_mirror(x, w)]

    # step 1: the filter along the row (H) and along the column (V)
    f = {"H": np.zeros((h, w)), "V": np.zeros((h, w))}
    for y in range(h):
        for x in range(w):
            f["H"][y, x] = sum(k * get(m, y, x + i - 2) for i, k in enumerate(_GREEN))
            f["V"][y, x] = sum(k * get(m, y + i - 2, x) for i, k in enumerate(_GREEN))
    # step 2: colour differences X − G, their variation two pixels on, the weighted window
    c = {d: np.zeros((h, w)) for d in "HV"}
    for d in "HV":
        for y in range(h):
            for x in range(w):
                c[d][y, x] = f[d][y, x] - m[y, x] if colour(y, x) == "G" else m[y, x] - f[d][y, x]
    var = {"H": np.zeros((h, w)), "V": np.zeros((h, w))}
    for y in range(h):
        for x in range(w):
            var["H"][y, x] = abs(c["H"][y, x] - get(c["H"], y, x + 2))
            var["V"][y, x] = abs(c["V"][y, x] - get(c["V"], y + 2, x))
    rows = np.zeros((h, w), dtype=bool)
    for y in range(h):
        for x in range(w):
            d_h = d_v = 0.0
            for a, weight in ((-2, 1.0), (0, 3.0), (2, 1.0)):  # rows (columns) two apart: pairs x−2→x, x→x+2
                for b in (-2, 0):
                    d_h += weight * get(var["H"], y + a, x + b)
                    d_v += weight * get(var["V"], y + b, x + a)
            for a in (-1, 1):  # the rows (columns) next to it: the pair x−1 → x+1
                d_h += get(var["H"], y + a, x - 1)
                d_v += get(var["V"], y - 1, x + a)
            rows[y, x] = d_h <= d_v
    g = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            g[y, x] = m[y, x] if colour(y, x) == "G" else (f["H"] if rows[y, x] else f["V"])[y, x]
    # step 3: R and B at the green pixels, from the two neighbours holding the colour
    est = {"R": np.zeros((h, w)), "B": np.zeros((h, w))}
    diff = {k: np.zeros((h, w)) for k in "RB"}
    for y in range(h):
        for x in range(w):
            if colour(y, x) in "RB":
                diff[colour(y, x)][y, x] = m[y, x] - g[y, x]
    for y in range(h):
        for x in range(w):
            for k in "RB":
                if colour(y, x) == k:
                    est[k][y, x] = m[y, x]
                elif colour(y, x) == "G":
                    if k in cfa[(y % 2) * 2:(y % 2) * 2 + 2]:  # the row holds the colour
                        mean = 0.5 * (get(diff[k], y, x - 1) + get(diff[k], y, x + 1))
                    else:
                        mean = 0.5 * (get(diff[k], y - 1, x) + get(diff[k], y + 1, x))
                    est[k][y, x] = g[y, x] + mean
    # step 4: R at B and B at R from R − B of the two green neighbours along the chosen direction
    rb = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            if colour(y, x) == "G":
                rb[y, x] = est["R"][y, x] - est["B"][y, x]
    out = np.zeros((h, w, 3))
    for y in range(h):
        for x in range(w):
            if rows[y, x]:
                mean = 0.5 * (get(rb, y, x - 1) + get(rb, y, x + 1))
            else:
                mean = 0.5 * (get(rb, y - 1, x) + get(rb, y + 1, x))
            r, b = est["R"][y, x], est["B"][y, x]
            if colour(y, x) == "B":
                r = m[y, x] + mean
            elif colour(y, x) == "R":
                b = m[y, x] - mean
            out[y, x] = (max(r, 0.0), max(g[y, x], 0.0), max(b, 0.0))
    return out


# ----------------------------------------------------------------------------- the golden cases
def _inputs():
    rng = np.random.default_rng(43)
    yy, xx = np.mgrid[0:10, 0:12]
    # a random field plus an oblique edge, so that both directions are chosen somewhere; and a grey quadratic
    # 10 + 3x² + y² in whole numbers (exact arithmetic), whose colour differences are constant along both axes away
    # from the right and bottom borders: δ_H = δ_V = 0 there, and the tie rule (the rows) decides the green
    return {"mosaic": 0.3 * rng.random((10, 12)) + 0.6 * (2 * yy + xx > 14),
            "quadratic": (10 + 3 * xx ** 2 + yy ** 2).astype(np.float64)}


def _outputs(i, demosaic):
    return {**{f"rgb_{c.lower()}": demosaic(i["mosaic"], c) for c in CFA_PATTERNS},
            "rgb_quadratic": demosaic(i["quadratic"], "RGGB")}


GOLDEN_CASES = (
    OracleCase(
        "demosaic_ddfapd", "— (not in the paper; the multi-frame demosaic's correction, ReconstructParams("
        "demosaic=\"ddfapd\"), beyond Eq. 13's Ψ)",
        "spikeref.directional_demosaic.demosaic_ddfapd",
        "spikeref.oracles.directional_demosaic.demosaic_ddfapd_oracle",
        "Menon–Andriani–Calvagno (2007) directional demosaic, without its refining step, of a 10×12 mosaic "
        "(random plus an oblique edge) with each of the four patterns, and of a grey quadratic 10 + 3x² + y² (RGGB: "
        "ties, where the rows decide): green along the rows and the columns by "
        "[−¼, ½, ½, ½, −¼], the direction whose colour differences vary less over the 5×5 window, red and blue "
        "through their differences with the green; mirrored about the edge pixels, negative results clipped to 0.",
        _inputs, lambda i: _outputs(i, demosaic_ddfapd_oracle), rtol=1e-10, atol=1e-12,
        params={"cfas": list(CFA_PATTERNS)},
        spec="docs/spec/bayer.md#demosaic_ddfapd",
        outputs=_outputs,
    ),
)
