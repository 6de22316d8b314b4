"""What stands between a perfect alignment and the limit: resampling, noise, and BM3D told the true σ.

``python scripts/study_limit_gap.py [--set bench|heldout]`` warps, at the ladder's four scored frames of
every scene with a motion model (W/K/L = 10/3/3, the binomial weights of Eq. 14–15), the support's
window charges with the exact motion (:func:`spikeref.bench.ladder.true_flow_frame`), and the same
support's noise-free windows (each window's exact ground truth, mosaicked), and prints per scene the
PSNR (dB, Ψ in linear RGB against the 10-plane ground truth, as the ladder) of

* ``limit``: Ψ of the noise-free mosaic of the reference window;
* ``clean``: the noise-free windows through the true-flow warp (what resampling costs);
* ``tf``: the charges through the true-flow warp (the ladder's "true flow");
* ``bm3d``: ``tf`` then BM3D with a blind σ (the ladder's "true flow + BM3D");
* ``bm3d_true_sigma`` and ``bm3d_2x_sigma``: ``tf`` then BM3D told the σ of ``tf − clean`` (the noise
  actually left after the merge, which no user knows), and twice it;
* ``noise_rel``: that σ over the mean of the reference window's noise-free planes.

The held-out set is ``scripts/heldout_scenes`` at seed 11, the bench the benchmark's scenes at seed 0.
Needs the test and peers extras (photographs from scikit-image, the ``bm3d`` package); about 2 min
per set on two cores.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from spikeref.bayer import bayer_planes, demosaic_bilinear
from spikeref.bench.ladder import (
    binomial_weights, clean_window_counts, has_true_flow, psi, psnr_score, true_flow_frame,
)
from spikeref.bench.runner import bench_scenes, load_bench_scene, score_centres
from spikeref.charge import window_charge
from spikeref.denoise.peers import PeerDenoiser
from spikeref.simulate.camera import mosaic_radiance

HELDOUT = Path(__file__).resolve().parent / "heldout_scenes"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", choices=("bench", "heldout"), default="bench", help="which scene set (default bench)")
    args = ap.parse_args(argv)
    if args.set == "bench":
        scenes, seed = bench_scenes(), 0
    else:
        scenes, seed = [load_bench_scene(p) for p in sorted(HELDOUT.glob("*.toml"))], 11
    w, K, L = 10, 3, 3
    reach = L * ((K - 1) // 2)
    weights = binomial_weights(K, L)
    blind = PeerDenoiser("bm3d")
    per_scene = {}
    for sc in scenes:
        if not has_true_flow(sc.scene.content):
            continue
        sc.simulate(seed)
        cfa = sc.stream.cfa

        centres = score_centres(len(sc.stream), 4)
        offset = (centres[0] - w // 2) % w
        view = sc.stream.slice(offset)
        rows = []
        for t in centres:
            first = (t - w // 2 - offset) // w - reach
            start = offset + first * w
            truth = sc.reference(t)
            clean = clean_window_counts(sc.scene, cfa, w, start, 2 * reach + 1)
            clean_tf = true_flow_frame(clean, sc.scene.content, w, start, reach, weights)
            charges = bayer_planes(window_charge(view, w, start=first * w, count=2 * reach + 1), cfa)
            tf = true_flow_frame(charges, sc.scene.content, w, start, reach, weights)
            sigma = float(np.std(tf - clean_tf))
            rows.append({
                "limit": psnr_score(truth, demosaic_bilinear(mosaic_radiance(truth, cfa).astype(np.float32), cfa)),
                "clean": psnr_score(truth, psi(clean_tf, cfa)),
                "tf": psnr_score(truth, psi(tf, cfa)),
                "bm3d": psnr_score(truth, psi(blind(tf), cfa)),
                "bm3d_true_sigma": psnr_score(truth, psi(PeerDenoiser("bm3d", sigma=sigma)(tf), cfa)),
                "bm3d_2x_sigma": psnr_score(truth, psi(PeerDenoiser("bm3d", sigma=2 * sigma)(tf), cfa)),
                "noise_rel": sigma / float(clean[reach].mean() / w),
            })
        per_scene[sc.key] = {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}
        print(sc.key, "  ".join(f"{k} {v:.3f}" if k == "noise_rel" else f"{k} {v:.2f}"
                                for k, v in per_scene[sc.key].items()), flush=True)
        sc.stream = None
    keys = next(iter(per_scene.values()))
    print(f"mean of {len(per_scene)}", "  ".join(
        f"{k} {np.mean([r[k] for r in per_scene.values()]):.2f}" for k in keys))


if __name__ == "__main__":
    main()
