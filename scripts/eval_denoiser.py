"""Score the denoiser on held-out simulated scenes: PSNR/SSIM of Ψ[D(I)] and of Ψ[I] (TFP) vs ground truth.

The scenes ``scripts/denoiser_scenes/heldout_*.toml`` are never used in training (the
training scenes are ``train_*.toml``: other seeds, layouts, speeds, brightness, and no colour
chart at all).  For every scene, window ``W`` and start plane (``--frames`` starts spread over
the recording), the frame ``I`` (Eq. 4) is compared with the exact ground truth (mean radiance
over the same window, in rate units):

* ``tfp``: ``Ψ[I]``;
* ``<weights>/<mode>``: ``Ψ[D(I)]`` for each weights file and inference mode, with the residual
  shrinkage (the default, :mod:`spikeref.denoise.shrinkage`) and, named ``<weights>-noshrink``,
  without it (the paper's ``D(I)``).

PSNR and SSIM use ``data_range`` = the ground-truth frame's maximum (so a dim scene is not
flattered by the rate scale's 1.0), from :mod:`spikeref.metrics`; its SSIM (Gaussian weights,
σ = 1.5, mean of the RGB channels) equals scikit-image's ``structural_similarity`` with those
settings to 1e-9 (``tests/test_metrics.py``).

    python scripts/eval_denoiser.py --weights out/my_weights.npz --json out/eval.json
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
WINDOWS = (10, 20, 50, 100, 200)


def main() -> None:
    from spikeref.accumulate import accumulate
    from spikeref.bayer import bayer_mosaic, bayer_planes, demosaic_bilinear
    from spikeref.denoise.denoiser import DEFAULT_WEIGHTS, Denoiser
    from spikeref.stream import open_spike_file
    from spikeref.metrics import psnr, ssim
    from spikeref.simulate.scenes import load_scene
    from spikeref.simulate.simulator import ground_truth

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", type=Path, nargs="+", default=[DEFAULT_WEIGHTS])
    ap.add_argument("--modes", default="visible,blind,mixed")
    ap.add_argument("--windows", default=",".join(map(str, WINDOWS)))
    ap.add_argument("--frames", type=int, default=3, help="frames per scene and window")
    ap.add_argument("--shrink", default="on,off",
                    help="residual shrinkage after the network (spikeref.denoise.shrinkage): on, off or on,off; "
                         "'off' is the paper's D(I), named <weights>-noshrink")
    ap.add_argument("--data-dir", type=Path, default=ROOT / ".heldout_data")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    modes = args.modes.split(",")
    windows = [int(w) for w in args.windows.split(",")]
    stems = [p.stem for p in args.weights]  # name by folder too where two files share a name
    shrinks = args.shrink.split(",")
    if not shrinks or any(v not in ("on", "off") for v in shrinks):
        ap.error(f"--shrink must be on, off or on,off; got {args.shrink!r}")
    denoisers = {(f"{p.parent.name}/{p.stem}" if stems.count(p.stem) > 1 else p.stem)
                 + ("" if v == "on" else "-noshrink"): Denoiser.load(p, shrink=v == "on")
                 for p in args.weights for v in shrinks}
    args.data_dir.mkdir(parents=True, exist_ok=True)

    rows = []  # (scene, W, method, psnr, ssim)
    seconds = {}
    for toml in sorted(SCENES.glob("heldout_*.toml")):
        scene = load_scene(toml)
        dat = args.data_dir / (toml.stem + ".dat")
        if not dat.is_file():
            subprocess.run([sys.executable, "-m", "spikeref.cli", "simulate", str(toml), "-o", str(dat),
                            "--seed", str(SEED)], check=True)
        stream = open_spike_file(dat)
        for w in windows:
            starts = np.linspace(0, len(stream) - w, args.frames + 2)[1:-1].round().astype(int)
            for start in starts:
                gt = ground_truth(scene, w, planes=int(start) + w, start=int(start))[0].astype(np.float64)
                dr = float(gt.max())
                rates = accumulate(stream, w, start=int(start), count=1)[0]
                planes = bayer_planes(rates)

                def score(method, rgb, name=toml.stem, w=w, gt=gt, dr=dr):
                    rows.append((name, w, method, psnr(gt, rgb, dr), ssim(gt, rgb, dr)))

                score("tfp", demosaic_bilinear(rates, stream.cfa))
                for name, den in denoisers.items():
                    for mode in modes:
                        t0 = time.perf_counter()
                        clean = den(planes, mode, window=w)
                        seconds.setdefault(f"{name}/{mode}", []).append(time.perf_counter() - t0)
                        score(f"{name}/{mode}", demosaic_bilinear(bayer_mosaic(clean), stream.cfa))
        print(f"{toml.stem} done", file=sys.stderr, flush=True)

    methods = list(dict.fromkeys(r[2] for r in rows))
    table = {}
    for m in methods:
        for w in windows:
            sel = [r for r in rows if r[2] == m and r[1] == w]
            table[(m, w)] = (float(np.mean([r[3] for r in sel])), float(np.mean([r[4] for r in sel])))
    head = "| method | " + " | ".join(f"W={w}" for w in windows) + " |"
    print("Mean PSNR (dB) / SSIM over the held-out scenes")
    print(head)
    print("|" + "---|" * (len(windows) + 1))
    for m in methods:
        print(f"| {m} | " + " | ".join(f"{table[(m, w)][0]:.2f} / {table[(m, w)][1]:.3f}" for w in windows) + " |")
    print("\nPer scene, PSNR (dB):")
    for scene in dict.fromkeys(r[0] for r in rows):
        print(f"  {scene}: " + "; ".join(
            f"{m} " + " ".join(f"{np.mean([r[3] for r in rows if r[0] == scene and r[2] == m and r[1] == w]):.1f}"
                               for w in windows) for m in methods))
    print("\nseconds per 256×256 frame (4 planes of 128×128): " + ", ".join(
        f"{k} {np.median(v):.2f}" for k, v in seconds.items()))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({
            "rows": rows, "windows": windows,
            "mean": {f"{m}@{w}": table[(m, w)] for m in methods for w in windows},
            "seconds": {k: float(np.median(v)) for k, v in seconds.items()},
        }, indent=1))


if __name__ == "__main__":
    main()
