"""Oracle for the CFA phase decision (:mod:`spikeref.cfa_detect`), written out pair by pair.

Not an equation of the paper: the paper's camera is RGGB by construction.  The fast module sums
per-pixel maps with NumPy and filters with SciPy; here every Gaussian tap, every diagonal pair of the
mosaic and every tile is a loop, so the rule can be read next to ``spikeref/cfa_detect.py``'s
docstring.  The defaults are written out (:data:`DEFAULTS`), not imported; a test holds them equal to
:class:`spikeref.cfa_detect.CfaDetectParams`.
"""

import math

import numpy as np

__all__ = ["DEFAULTS", "gaussian_reflect_oracle", "diagonal_pairs_oracle", "cfa_from_counts_oracle"]

#: The decision's constants (``CfaDetectParams``' defaults, read side).
DEFAULTS = {"band": (1.0, 4.0), "tiles": 4, "decide_z": 3.0, "corr_tolerance": 0.05, "mean_tolerance": 0.01,
            "power_corr_ratio": 0.8, "power_contrast": 0.05, "red_prior": 0.8}


def _reflect(i, n):
    """SciPy's ``reflect`` extension (``d c b a | a b c d | d c b a``), repeated as far as needed."""
    i = i % (2 * n)
    return i if i < n else 2 * n - 1 - i


def gaussian_reflect_oracle(image, sigma):
    """SciPy's ``gaussian_filter(image, sigma, mode="reflect")`` written out: taps ``exp(−x² / 2σ²)`` for
    ``|x| ≤ int(4σ + 0.5)``, normalised to sum 1, along the rows' axis and then the columns'."""
    radius = int(4.0 * sigma + 0.5)
    taps = [math.exp(-0.5 * x * x / (sigma * sigma)) for x in range(-radius, radius + 1)]
    total = sum(taps)
    taps = [t / total for t in taps]
    h, w = image.shape
    down = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            down[y, x] = sum(taps[k + radius] * image[_reflect(y + k, h), x] for k in range(-radius, radius + 1))
    out = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            out[y, x] = sum(taps[k + radius] * down[y, _reflect(x + k, w)] for k in range(-radius, radius + 1))
    return out


def diagonal_pairs_oracle(band_mosaic, diagonal, rows=None, cols=None):
    """The ``(u, v)`` pairs of one diagonal: every interior pixel of phase (1,1) (``"main"``) or (1,0)
    (``"anti"``) with each of its four diagonal neighbours (phase (0,0), resp. (0,1)).

    Interior: Bayer-plane row ``i`` in ``1 … h−2`` and column ``j`` in ``1 … w−2`` (the pixel at mosaic
    ``(2i + 1, 2j + 1)``, resp. ``(2i + 1, 2j)``); ``rows``/``cols`` restrict ``i − 1`` and ``j − 1`` to a
    tile's ranges.
    """
    hh, ww = band_mosaic.shape[0] // 2, band_mosaic.shape[1] // 2
    rows = range(hh - 2) if rows is None else rows
    cols = range(ww - 2) if cols is None else cols
    pairs = []
    for i0 in rows:
        for j0 in cols:
            i, j = i0 + 1, j0 + 1
            y, x = 2 * i + 1, (2 * j + 1 if diagonal == "main" else 2 * j)
            for dy in (-1, 1):
                for dx in (-1, 1):
                    pairs.append((band_mosaic[y, x], band_mosaic[y + dy, x + dx]))
    return pairs


def _pearson(pairs):
    n = len(pairs)
    if n == 0:
        return None
    mu = sum(p[0] for p in pairs) / n
    mv = sum(p[1] for p in pairs) / n
    var_u = sum((p[0] - mu) ** 2 for p in pairs) / n
    var_v = sum((p[1] - mv) ** 2 for p in pairs) / n
    if not (var_u > 1e-12 and var_v > 1e-12):  # a band-passed phase under 1e-6 spikes has no texture
        return None
    cov = sum((p[0] - mu) * (p[1] - mv) for p in pairs) / n
    return max(-1.0, min(1.0, cov / math.sqrt(var_u * var_v)))


def _fisher(r):
    return math.atanh(max(-0.9999, min(0.9999, r)))


def _phi(x):
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


def _contrast(a, b):
    s = a + b
    if s <= 0:
        return 0.0, math.inf
    c = (a - b) / s
    return c, math.sqrt(max(1.0 - c * c, 1.0 / s) / s)


def _excess(value, tolerance, se):
    return max(abs(value) - tolerance, 0.0) / se if math.isfinite(se) else 0.0


def cfa_from_counts_oracle(counts, planes, **settings):
    """The decision of :func:`spikeref.cfa_detect.cfa_from_counts`, step by step.

    ``counts`` ``(H, W)`` spikes per pixel over ``planes`` planes (``H``, ``W`` even); ``settings``
    override :data:`DEFAULTS`.  Returns a dict with the :class:`~spikeref.cfa_detect.CfaGuess` fields.
    """
    s = dict(DEFAULTS, **settings)
    k, tol_c, tol_m = s["decide_z"], s["corr_tolerance"], s["mean_tolerance"]
    counts = np.asarray(counts, dtype=np.float64)
    H, W = counts.shape
    h, w = H // 2, W // 2
    positions = ((0, 0), (0, 1), (1, 0), (1, 1))

    # the four phases' spikes and means
    totals = [sum(counts[y, x] for y in range(py, H, 2) for x in range(px, W, 2)) for py, px in positions]
    means = tuple(t / (h * w * planes) for t in totals)

    # texture: band-pass each phase on its own grid, put them back in the mosaic, correlate diagonal pairs
    r_main = r_anti = 0.0
    dz, se_t = 0.0, math.inf
    if h >= 3 and w >= 3:
        band = np.zeros((H, W))
        for py, px in positions:
            phase = counts[py::2, px::2]
            fine = gaussian_reflect_oracle(phase, s["band"][0]) if s["band"][0] > 0 else phase
            band[py::2, px::2] = fine - gaussian_reflect_oracle(phase, s["band"][1])
        rm, ra = _pearson(diagonal_pairs_oracle(band, "main")), _pearson(diagonal_pairs_oracle(band, "anti"))
        if rm is None or ra is None:
            r_main, r_anti = rm or 0.0, ra or 0.0
        else:
            r_main, r_anti = rm, ra
            dz = _fisher(rm) - _fisher(ra)
            ty, tx = min(s["tiles"], h - 2), min(s["tiles"], w - 2)
            gaps = []
            for a in range(ty):
                for b in range(tx):
                    rows = range(a * (h - 2) // ty, (a + 1) * (h - 2) // ty)
                    cols = range(b * (w - 2) // tx, (b + 1) * (w - 2) // tx)
                    tm = _pearson(diagonal_pairs_oracle(band, "main", rows, cols))
                    ta = _pearson(diagonal_pairs_oracle(band, "anti", rows, cols))
                    gaps.append(_fisher(tm or 0.0) - _fisher(ta or 0.0))
            n_pairs = 4 * (h - 2) * (w - 2)
            floor = math.sqrt(2.0 / (n_pairs - 3)) if n_pairs > 3 else math.inf
            if len(gaps) > 1:
                mean_gap = sum(gaps) / len(gaps)
                spread = math.sqrt(sum((g - mean_gap) ** 2 for g in gaps) / (len(gaps) - 1)) / math.sqrt(len(gaps))
            else:
                spread = 0.0
            se_t = max(spread, floor)

    z_t = math.copysign(_excess(dz, tol_c, se_t), dz)
    c_main, se_main = _contrast(totals[0], totals[3])
    c_anti, se_anti = _contrast(totals[1], totals[2])
    c_diag, se_diag = _contrast(totals[0] + totals[3], totals[1] + totals[2])
    agree = abs(c_anti) - abs(c_main)
    z_m = math.copysign(_excess(agree, tol_m, math.hypot(se_main, se_anti)), agree)
    z_means = max(_excess(c_main, tol_m, se_main), _excess(c_anti, tol_m, se_anti), _excess(c_diag, tol_m, se_diag))
    z_colour = max(abs(z_t), z_means)
    z = (z_t + z_m) / math.sqrt(2.0)
    out = {"corr_main": r_main, "corr_anti": r_anti, "phase_means": means, "planes": planes,
           "texture_z": z_t, "means_z": z_m, "colour_z": z_colour}

    if z_colour <= k:  # the four phases behave alike
        r_hi = min(max(r_main, r_anti, 0.0), 0.9999)
        dz_colour = _fisher(r_hi) - _fisher(s["power_corr_ratio"] * r_hi)
        se_means = max(se_main, se_anti, se_diag)
        power_t = _phi((dz_colour - tol_c) / se_t - k) if math.isfinite(se_t) else 0.0
        power_m = _phi((s["power_contrast"] - tol_m) / se_means - k) if math.isfinite(se_means) else 0.0
        return dict(out, pattern="mono", confidence=_phi(k - z_colour) * max(power_t, power_m),
                    green_confidence=0.0)

    main_green = (z, dz, agree) > (0.0, 0.0, 0.0)
    green_conf = _phi(abs(z)) * _phi(z_colour - k)
    if main_green:
        pattern = "GRBG" if totals[1] >= totals[2] else "GBRG"
        c_rb, se_rb = c_anti, se_anti
    else:
        pattern = "RGGB" if totals[0] >= totals[3] else "BGGR"
        c_rb, se_rb = c_main, se_main
    z_rb = abs(c_rb) / se_rb if math.isfinite(se_rb) else 0.0
    rb_conf = 0.5 + (s["red_prior"] - 0.5) * (2.0 * _phi(z_rb) - 1.0)
    return dict(out, pattern=pattern, confidence=green_conf * rb_conf, green_confidence=green_conf)
