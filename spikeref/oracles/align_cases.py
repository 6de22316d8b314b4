"""The inputs of the alignment's golden cases and how each side makes their outputs (§4.2 and beyond).

The three cases of :data:`spikeref.oracles.align.GOLDEN_CASES` (``golden/align_hdrplus.npz``,
``align_noise_aware.npz``, ``align_lk_regularised.npz``; ``docs/spec/align.md``): their inputs from
fixed seeds (:func:`inputs_hdrplus`, :func:`inputs_noise_aware`, :func:`inputs_lk`), their pinned
alignment settings (:data:`HDRPLUS_SETTINGS`, :data:`NOISE_AWARE_SETTINGS`, :data:`LK_SETTINGS`), and
the recipes that turn inputs into outputs given the functions to call (:func:`hdrplus_outputs`,
:func:`noise_aware_outputs`, :func:`lk_outputs`): the oracles of :mod:`spikeref.oracles.align` on one
side, the fast functions of :mod:`spikeref.align` on the other
(:mod:`spikeref.oracles.golden_cases`), so both run the same recipe.  No alignment is done here.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter, shift

__all__ = [
    "HDRPLUS_SETTINGS",
    "NOISE_AWARE_SETTINGS",
    "LK_SETTINGS",
    "inputs_hdrplus",
    "inputs_noise_aware",
    "inputs_lk",
    "hdrplus_outputs",
    "noise_aware_outputs",
    "lk_outputs",
]


#: The golden vectors' alignment parameters, pinned (the package default may change).
HDRPLUS_SETTINGS = {"levels": 4, "tile_by_step": (16, 16, 8), "coarse_tile": 8, "search_radius": (1, 4, 4, 4),
                    "subpixel": True}


def inputs_hdrplus():
    """A smooth texture and copies moved by known shifts: integer (3, −5), beyond the finest
    radius (−9, 14), and sub-pixel (0.5, −0.25) by bilinear resampling; 72×80 plane pixels."""
    rng = np.random.default_rng(13)
    big = gaussian_filter(rng.random((112, 120)), 1.5)
    ref = big[20:92, 20:100].astype(np.float32)
    shifts = np.array([[3.0, -5.0], [-9.0, 14.0], [0.5, -0.25]])
    # alternate[y + dy, x + dx] = reference[y, x]: the content moved by (dy, dx)
    alts = np.stack([shift(big, s, order=1, mode="nearest")[20:92, 20:100] for s in shifts]).astype(np.float32)
    return {"reference": ref, "alternates": alts, "shifts": shifts}


def hdrplus_outputs(i, tiles, dense, params):
    """For steps 0 and 2 and each alternate: the tile vectors ``tiles(…)[0]`` and the flow ``dense(…)``."""
    p = params(HDRPLUS_SETTINGS)
    out = {}
    for step in (0, 2):
        out[f"vectors_step{step}"] = np.stack([tiles(i["reference"], a, step, p)[0] for a in i["alternates"]])
        out[f"flow_step{step}"] = np.stack([dense(i["reference"], a, step, p) for a in i["alternates"]])
    return out


def inputs_noise_aware():
    """A noisy 48×64 scene, flat on the left (columns ≤ 20) and a smooth texture to the right (ramping in over
    columns 20 … 32), and four alternates: the same scene still, moved by (3, −5), moved by (0.5, −0.25)
    (bilinear resampling), and another scene (rough, unrelated: an occlusion or a cut). The noise variance
    follows the scene, ``0.004 × value``; the first three alternates' noise is correlated ``ρ = −½`` with the
    reference's at the same pixel, as the counts of adjacent spike windows are, the fourth's is independent.
    ``noise`` is the true mean variance of each pair; ``correlation`` is −0.7, below the clip at −½ on purpose.
    The fourth alternate's seed (18) was picked among 30 as one on which the zero candidate's correction in the
    upsampling and the noise pyramid's blur decide some vectors."""
    rng = np.random.default_rng(16)
    h, w, m = 48, 64, 16
    tex = gaussian_filter(rng.random((h + 2 * m, w + 2 * m)), 1.5)
    tex = (tex - tex.mean()) / tex.std()
    ramp = np.clip((np.arange(w + 2 * m) - m - 20) / 12.0, 0.0, 1.0)
    big = 0.35 + 0.1 * np.clip(tex, -3.0, 3.0) * ramp[None, :]  # 0.05 … 0.65
    shifts = np.array([[0.0, 0.0], [3.0, -5.0], [0.5, -0.25]])
    # alternate[y + dy, x + dx] = reference[y, x]: the content moved by (dy, dx)
    scenes = [big[m:m + h, m:m + w]] + [shift(big, s, order=1, mode="nearest")[m:m + h, m:m + w] for s in shifts]
    var = [0.004 * s for s in scenes]
    a = rng.standard_normal((h, w))
    ref = scenes[0] + np.sqrt(var[0]) * a
    alts = [scenes[n + 1] + np.sqrt(var[n + 1]) * (-0.5 * a + np.sqrt(0.75) * rng.standard_normal((h, w)))
            for n in range(3)]
    other_rng = np.random.default_rng(18)
    other = 0.35 + 0.1 * np.clip(other_rng.standard_normal((h, w)), -3.0, 3.0)
    alts.append(other + np.sqrt(0.004 * other) * other_rng.standard_normal((h, w)))
    var.append(0.004 * other)
    return {"reference": ref.astype(np.float32), "alternates": np.stack(alts).astype(np.float32),
            "noise": np.stack([0.5 * (var[0] + v) for v in var[1:]]), "correlation": np.float64(-0.7),
            "shifts": shifts}


#: The noise-aware case's alignment parameters: three levels for 48×64 frames, z = 3 (the pipeline's).
NOISE_AWARE_SETTINGS = {"levels": 3, "tile_by_step": (16, 8), "coarse_tile": 8, "search_radius": (1, 4, 4),
                        "subpixel": True, "prefer_centre": 3.0}


def noise_aware_outputs(i, tiles, noise_map, correlation, params):
    """The noise estimates of each pair, and ``tiles(ref, alt, step, params, **kw)[0]`` for each setting and step."""
    p = params(NOISE_AWARE_SETTINGS)
    ref = i["reference"]
    out = {"noise": np.stack([noise_map(ref, a) for a in i["alternates"]]),
           "correlation": np.array([correlation(ref, a) for a in i["alternates"]])}
    for setting in ("estimated", "given"):
        for step in (0, 1):
            vectors = []
            for n, a in enumerate(i["alternates"]):
                kw = {} if setting == "estimated" else {"noise": i["noise"][n], "correlation": float(i["correlation"])}
                vectors.append(tiles(ref, a, step, p, **kw)[0])
            out[f"vectors_{setting}_step{step}"] = np.stack(vectors)
    return out


def inputs_lk():
    """A 48×64 scene for ``AlignParams(refine="lk", smoothness=300, zero_test=2)``: a still background, flat in
    columns 0 … 12 and a smooth texture ramping in over columns 12 … 22, and a textured square object (rows
    14 … 37, columns 30 … 53). Alternates: 0 the same scene, still; 1 the object moved by (0.75, −1.5) (its
    texture and its edges), the background still; 2 the whole scene moved by (0.5, −0.25) (bilinear
    resampling). Raw frames: the scene plus Gaussian noise of variance ``0.003 ×`` its value, each alternate's
    noise correlated −½ with the reference's at the same pixel (adjacent spike windows). Flow frames (standing in
    for the denoised frames the pipeline aligns): the raw frames blurred by a Gaussian of σ = 1. ``noise`` is the
    true mean variance of each raw pair, ``correlation`` −½. The seed (48) was picked among 20 as the one whose
    closest zero-test decision lies furthest from its threshold (6.9·10⁻⁴ of it)."""
    rng = np.random.default_rng(48)
    h, w, m = 48, 64, 16
    big_h, big_w = h + 2 * m, w + 2 * m
    tex = gaussian_filter(rng.random((big_h, big_w)), 1.5)
    tex = (tex - tex.mean()) / tex.std()
    ramp = np.clip((np.arange(big_w) - m - 12) / 10.0, 0.0, 1.0)
    back = 0.4 + 0.1 * np.clip(tex, -3.0, 3.0) * ramp[None, :]
    obj = gaussian_filter(rng.random((big_h, big_w)), 1.0)
    obj = 0.45 + 0.12 * np.clip((obj - obj.mean()) / obj.std(), -3.0, 3.0)
    yy, xx = np.mgrid[0:big_h, 0:big_w]

    def scene(dy, dx):  # the object moved by (dy, dx): alternate[y + dy, x + dx] = reference[y, x] on it
        inside = (yy - m - dy >= 14) & (yy - m - dy < 38) & (xx - m - dx >= 30) & (xx - m - dx < 54)
        return np.where(inside, shift(obj, (dy, dx), order=1, mode="nearest"), back)

    still = scene(0.0, 0.0)
    scenes = [s[m:m + h, m:m + w] for s in (still, still, scene(0.75, -1.5),
                                            shift(still, (0.5, -0.25), order=1, mode="nearest"))]
    var = [0.003 * s for s in scenes]
    a = rng.standard_normal((h, w))
    raw_ref = (scenes[0] + np.sqrt(var[0]) * a).astype(np.float32)
    raw_alts = np.stack([scenes[n] + np.sqrt(var[n]) * (-0.5 * a + np.sqrt(0.75) * rng.standard_normal((h, w)))
                         for n in (1, 2, 3)]).astype(np.float32)
    ref = gaussian_filter(raw_ref.astype(np.float64), 1.0).astype(np.float32)
    alts = np.stack([gaussian_filter(r.astype(np.float64), 1.0) for r in raw_alts]).astype(np.float32)
    return {"reference": ref, "alternates": alts, "raw_reference": raw_ref, "raw_alternates": raw_alts,
            "noise": np.stack([0.5 * (var[0] + var[n]) for n in (1, 2, 3)]), "correlation": np.float64(-0.5),
            "shifts": np.array([[0.0, 0.0], [0.75, -1.5], [0.5, -0.25]])}


#: The case's alignment parameters: the pipeline's options (z = 3, Lucas–Kanade, λ = 300, zero test at 2σ)
#: on a three-level pyramid for 48×64 frames.
LK_SETTINGS = {"levels": 3, "tile_by_step": (16, 8), "coarse_tile": 8, "search_radius": (1, 4, 4), "subpixel": True,
               "prefer_centre": 3.0, "refine": "lk", "smoothness": 300.0, "zero_test": 2.0}


def lk_outputs(i, tiles, dense, params):
    """For steps 0 and 1 and each alternate: ``lk`` — the tile vectors with ``smoothness = 0`` (noise given);
    ``given`` — the vectors and the flow of the flow frames with the noise and correlation given and the zero
    test on the raw frames; ``estimated`` — the vectors and flow of the raw frames themselves, every noise
    quantity estimated from them."""
    full, plain = params(LK_SETTINGS), params({**LK_SETTINGS, "smoothness": 0.0, "zero_test": None})
    ref, raw_ref = i["reference"], i["raw_reference"]
    out = {}
    for step in (0, 1):
        lk, vg, fg, ve, fe = [], [], [], [], []
        for n in range(len(i["alternates"])):
            alt, raw_alt = i["alternates"][n], i["raw_alternates"][n]
            kw = {"noise": i["noise"][n], "correlation": float(i["correlation"])}
            lk.append(tiles(ref, alt, step, plain, **kw)[0])
            vg.append(tiles(ref, alt, step, full, **kw)[0])
            fg.append(dense(ref, alt, step, full, raw=(raw_ref, raw_alt), **kw))
            ve.append(tiles(raw_ref, raw_alt, step, full)[0])
            fe.append(dense(raw_ref, raw_alt, step, full))
        out[f"vectors_lk_step{step}"] = np.stack(lk)
        out[f"vectors_given_step{step}"] = np.stack(vg)
        out[f"flow_given_step{step}"] = np.stack(fg)
        out[f"vectors_estimated_step{step}"] = np.stack(ve)
        out[f"flow_estimated_step{step}"] = np.stack(fe)
    return out
