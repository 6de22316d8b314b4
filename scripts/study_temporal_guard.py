"""Study (not in the package): the guard's noise variance from time instead of space.

``python scripts/study_temporal_guard.py MODE [BOX] [SCENES]`` runs the ladder's ``ours`` and ``no denoiser``
rungs (W/K/L = 10/3/3, the defaults) on the benchmark scenes (all, or a comma-separated subset) with the
output guard's per-pixel noise variance replaced, for the output frame only:

* ``default``: the package's guard, unchanged;
* ``temporal``: the spread of the support's windows once the composed warp has moved them onto the
  reference — each window warped along its own paths, the path-weighted variance across windows,
  times the merge's ``Σ w_j²``, averaged over a ``BOX × BOX`` box (default 9) — floored at the
  quantisation floor;
* ``max`` / ``min``: the larger / smaller of that and the package's variance.

It patches ``spikeref.pipeline_rings.FrameRings._composed`` and the guard's ``sure_blend`` in this process only.
Prints PSNR per scene and the mean of ``ours``.
"""
import statistics
import sys

import numpy as np
from scipy.ndimage import uniform_filter
import spikeref.pipeline_rings as pr
import spikeref.denoise.denoiser as dn
import spikeref.denoise.guard as gd
from spikeref.compose import composed_warp
from spikeref.bench.runner import bench_scenes
from spikeref.bench.ladder import run_ladder

MODE = sys.argv[1]  # "default" | "temporal" | "max" | "min"
BOX = int(sys.argv[2]) if len(sys.argv) > 2 else 9
STATE = {"var": None}

orig_composed = pr.FrameRings._composed
def composed(self, k, top):
    out = orig_composed(self, k, top)
    if MODE == "default":
        return out
    counts, bank, hops, targets = self.composed_inputs(k, top)  # the pipeline's own paths
    p = self.p
    per, weights = [], []
    for j in np.unique(targets):
        sel = targets == j
        per.append(composed_warp(counts, bank, hops[sel], targets[sel], p.window))
        weights.append(sel.sum())
    per = np.stack(per).astype(np.float64)
    wts = np.asarray(weights, float) / len(targets)
    mean = np.tensordot(wts, per, 1)
    var_w = np.tensordot(wts, (per - mean) ** 2, 1) / (1.0 - np.sum(wts ** 2))  # unbiased weighted variance
    var_merged = var_w * np.sum(wts ** 2)
    STATE["var"] = uniform_filter(var_merged, size=(1, BOX, BOX), mode="nearest")
    return out
pr.FrameRings._composed = composed

orig_blend = dn.sure_blend
def blend(noisy, denoise, radius=gd.DEFAULT_RADIUS, sigma=None, window=None, carried=None, accumulate="count"):
    v = STATE["var"]
    if v is None or MODE == "default" or v.shape != np.shape(noisy):
        return orig_blend(noisy, denoise, radius, sigma, window, carried, accumulate)
    STATE["var"] = None
    y = np.asarray(noisy, np.float32)
    f = np.asarray(denoise(y), np.float32)
    floor = gd.quantisation_variance(f, window, accumulate)
    if MODE == "temporal":
        variance = np.maximum(v, floor)
    else:  # max or min of the default's variance and the temporal one
        s2 = gd.noise_sigma(y) ** 2
        if carried is not None:
            s2 = np.minimum(s2, np.asarray(carried) + floor.reshape(y.shape[:-2] + (-1,)).mean(axis=-1))
        spatial = np.maximum(s2[..., None, None], floor)
        variance = np.maximum(spatial, v) if MODE == "max" else np.maximum(np.minimum(spatial, v), floor)
    eps = gd.probe_step(np.sqrt(variance.reshape(y.shape[:-2] + (-1,)).mean(axis=-1)))
    b = gd.rademacher_probe(y.shape)
    fb = np.asarray(denoise((y + (eps[..., None, None] * b)).astype(np.float32)), np.float32)
    alpha = gd.sure_alpha(y, f, fb, b, eps, np.sqrt(variance), radius)
    return (y + alpha * (f.astype(np.float64) - y)).astype(np.float32), alpha
dn.sure_blend = blend

scenes = bench_scenes([s for s in sys.argv[3].split(",")] if len(sys.argv) > 3 else ())
res = run_ladder(scenes, rungs=("ours", "no_denoiser"), progress=False, peers=())
rows = res["rows"]
for sc in dict.fromkeys(r["scene"] for r in rows):
    d = {r["rung"]: r["psnr"] for r in rows if r["scene"] == sc}
    print(f"{MODE:8s} {sc:14s} ours {d['ours']:.2f} noD {d['no_denoiser']:.2f} diff {d['ours']-d['no_denoiser']:+.2f}")
print(MODE, "mean ours", round(statistics.mean(r["psnr"] for r in rows if r["rung"] == "ours"), 3))
