"""Score the progressive warping against the baselines on held-out simulated scenes with ground truth.

Scenes: ``scripts/denoiser_scenes/heldout_*.toml`` (never used to train the bundled weights),
simulated with seed 8 into ``--data-dir`` when missing (2000 planes, 256×256, RGGB, realistic
noise).  For ``--frames`` frame numbers ``k`` spread over each recording, every method gives
the colour frame at the centre of window ``k`` (planes ``[kW, (k+1)W)``), compared with the
ground truth of that window (mean radiance, rate units):

* ``TFP W=10`` — window ``k``; ``TFP W=100`` — the 100 planes centred on it;
* ``TFI``, ``TFSTP`` — at the window's centre plane;
* ``ours`` — ``R_L`` of :mod:`spikeref.pipeline` (W = 10, K = 3, L = 3, bundled denoiser,
  ``visible``), and ``ours L=l`` for every step ``l`` (Fig. 5).

PSNR and SSIM (:mod:`spikeref.metrics`: Gaussian σ = 1.5, population covariance, mean of the
RGB channels — scikit-image's settings, equal to 1e-9) use ``data_range`` = the ground-truth
frame's maximum.  For the translating texture, whose motion is
known exactly, the end-point error of the flow ``F_l(k, k±1)`` per step ``l`` is reported
(plane pixels, 16-pixel border left out).

    python scripts/eval_pipeline.py --json out/eval_pipeline.json [--flow-frames smoothed]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scripts" / "denoiser_scenes"
SEED = 8


def main() -> None:
    from spikeref.accumulate import accumulate
    from spikeref.baselines import tfi, tfstp
    from spikeref.bayer import demosaic_bilinear
    from spikeref.denoise.denoiser import Denoiser
    from spikeref.stream import open_spike_file
    from spikeref.metrics import psnr, ssim
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.simulate.scenes import load_scene
    from spikeref.simulate.simulator import ground_truth

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=4, help="frames per scene")
    ap.add_argument("--weights", type=Path, default=None, help="denoiser weights (default: bundled)")
    ap.add_argument("--mode", default="visible")
    ap.add_argument("--data-dir", type=Path, default=ROOT / ".heldout_data")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--flow-frames", default="denoised", choices=["denoised", "smoothed"],
                    help="what the flow is estimated on (spikeref.pipeline.ReconstructParams)")
    args = ap.parse_args()
    W, K, L = 10, 3, 3
    den = Denoiser.load(args.weights)
    args.data_dir.mkdir(parents=True, exist_ok=True)

    rows, epe, seconds = [], {}, []
    for toml in sorted(SCENES.glob("heldout_*.toml")):
        scene = load_scene(toml)
        dat = args.data_dir / (toml.stem + ".dat")
        if not dat.is_file():
            subprocess.run([sys.executable, "-m", "spikeref.cli", "simulate", str(toml), "-o", str(dat),
                            "--seed", str(SEED)], check=True)
        stream = open_spike_file(dat)
        cfa = stream.cfa
        params = ReconstructParams(window=W, K=K, L=L, mode=args.mode, flow_frames=args.flow_frames,
                                   accumulate="count")  # the count network by default
        rec = Reconstructor(stream, params, den)
        avail = rec.frames_available
        ks = np.linspace(max(avail.start, 6), avail.stop - 6, args.frames).round().astype(int)
        known = getattr(scene.content, "velocity", None)
        for k in ks:
            centre = k * W + W // 2
            gt = ground_truth(scene, W, planes=(k + 1) * W, start=k * W)[0].astype(np.float64)
            t0 = time.perf_counter()
            (f,) = list(rec.frames(int(k), int(k) + 1, keep_steps=True))
            seconds.append(time.perf_counter() - t0)
            images = {
                "TFP W=10": demosaic_bilinear(accumulate(stream, W, start=k * W, count=1)[0], cfa),
                "TFP W=100": demosaic_bilinear(accumulate(stream, 100, start=centre - 50, count=1)[0], cfa),
                "TFI": demosaic_bilinear(tfi(stream, times=[centre])[0], cfa),
                "TFSTP": demosaic_bilinear(tfstp(stream, times=[centre])[0], cfa),
                **{f"ours L={level}": s for level, s in enumerate(f.steps)},
            }
            for name, img in images.items():
                rows.append((toml.stem, int(k), name, psnr(gt, img, float(gt.max())), ssim(gt, img, float(gt.max()))))
            if known is not None:
                vx, vy = known  # image pixels per second; content moves +v (alternate[y+dy] = reference[y])
                per_window = np.array([vy, vx]) * W / stream.rate_hz / 2  # plane pixels per window
                for (level, i), fl in f.flows.items():
                    err = np.hypot(fl[0] - i * per_window[0], fl[1] - i * per_window[1])[16:-16, 16:-16]
                    epe.setdefault(level, []).append(float(err.mean()))
        print(f"{toml.stem} done", file=sys.stderr, flush=True)

    methods = list(dict.fromkeys(r[2] for r in rows))
    mean = {m: (float(np.mean([r[3] for r in rows if r[2] == m])), float(np.mean([r[4] for r in rows if r[2] == m])))
            for m in methods}
    print(f"Mean over {len(set(r[0] for r in rows))} held-out scenes × {args.frames} frames (W = 10 ground truth)")
    print("| method | PSNR (dB) | SSIM |\n|---|---|---|")
    for m in methods:
        print(f"| {m} | {mean[m][0]:.2f} | {mean[m][1]:.3f} |")
    ours = f"ours L={L}"
    for ref in ("TFP W=100", "TFP W=10"):
        print(f"ours − {ref}: {mean[ours][0] - mean[ref][0]:+.2f} dB, {mean[ours][1] - mean[ref][1]:+.3f} SSIM")
    print("\nPer scene, PSNR (dB):")
    for scene in dict.fromkeys(r[0] for r in rows):
        print(f"  {scene}: " + "; ".join(
            f"{m} {np.mean([r[3] for r in rows if r[0] == scene and r[2] == m]):.1f}" for m in methods))
    if epe:
        print("\nFlow end-point error on the translating texture (plane pixels): "
              + ", ".join(f"F_{level} {np.mean(v):.3f}" for level, v in sorted(epe.items())))
    print(f"\nseconds per frame (keep_steps, whole support recomputed per call): {np.median(seconds):.2f}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"rows": rows, "mean": mean,
                                         "epe": {str(k): float(np.mean(v)) for k, v in epe.items()}}, indent=1))


if __name__ == "__main__":
    main()
