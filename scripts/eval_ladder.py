"""The stage ladder on the held-out natural-motion scenes, and the targets of the method-quality issues.

The held-out scenes (``scripts/heldout_scenes/*.toml``: other photographs, other motions — affine,
zoom out, a second layer with rotation, a fast pan —, more noise than the benchmark, simulation
seed 11) were fixed before any tuning and are never used to choose a parameter.  Scoring as
``spikeref bench --ladder``: the frame centred on each scored instant, Ψ of the output in linear
RGB against the exact ground truth of the 10-plane window.

    python scripts/eval_ladder.py [--frames 4] [--out held_out_ladder.md] [--png held_out_ladder.png]
    python scripts/eval_ladder.py --set bench --support 20 --rungs true_flow_support,limit

``--set bench`` runs the benchmark scenes instead (seed 0, as ``spikeref bench --ladder``); ``--support`` sets
``ReconstructParams.support`` for the method's rungs and the ``true_flow_support`` rung; ``--rungs`` runs only
those rungs (the table beside the ladder needs ``ours`` and ``limit``).

Prints the ladder and, for W/K/L = 10/3/3, ours − TFP(W=100), ours − BM3D on one window and
ours − the limit (means over the scenes).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scripts" / "heldout_scenes"
SEED = 11


def main() -> None:
    from spikeref.bench.ladder import ladder_markdown, plot_ladder, run_ladder
    from spikeref.bench.runner import load_bench_scene

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=4, help="scored frames per scene")
    ap.add_argument("--out", type=Path, default=None, help="write the Markdown here too")
    ap.add_argument("--png", type=Path, default=None, help="draw the ladder here (needs matplotlib)")
    ap.add_argument("--accumulate", choices=("count", "charge"), default=None,
                    help="ReconstructParams.accumulate of the method's rungs (default: the package's default)")
    ap.add_argument("--weights", default=None, help="denoiser weights (.npz or a bundled name; default bundled)")
    ap.add_argument("--set", choices=("heldout", "bench"), default="heldout",
                    help="the held-out scenes (default, seed 11) or the benchmark scenes (seed 0)")
    ap.add_argument("--support", type=int, default=None,
                    help="ReconstructParams.support of the method's rungs and of the true_flow_support rung")
    ap.add_argument("--rungs", default=None, help="comma-separated rungs to run (default: all)")
    ap.add_argument("--dark-calibration", action="store_true",
                    help="subtract each scene's dark level, calibrated on a dark recording of its sensor "
                         "(spikeref bench --ladder --dark-calibration), from every rung but the noise-free ones and "
                         "from TFP(W=100)")
    args = ap.parse_args()
    from spikeref.bench.ladder import RUNGS
    from spikeref.denoise.denoiser import Denoiser

    folder, seed = (SCENES, SEED) if args.set == "heldout" else (ROOT / "spikeref" / "bench" / "scenes", 0)
    scenes = [load_bench_scene(p) for p in sorted(folder.glob("*.toml"))]
    params = {"accumulate": args.accumulate} if args.accumulate else {}
    if args.support is not None:
        params["support"] = args.support
    rungs = RUNGS if args.rungs is None else tuple(r.strip() for r in args.rungs.split(","))
    res = run_ladder(scenes, seed=seed, frames=args.frames, params=params or None, rungs=rungs,
                     denoiser=Denoiser.load(args.weights) if args.weights else None,
                     dark_calibration=args.dark_calibration)
    text = ladder_markdown(res)
    if {"ours", "limit"} <= set(res["rungs"]):  # the table beside the ladder needs both
        text += _beside_the_ladder(res, scenes, seed, args.frames)
    print(text)
    if args.out:
        args.out.write_text(text)
    if args.png:
        plot_ladder(res, args.png)


def _beside_the_ladder(res: dict, scenes, seed: int, frames: int) -> str:
    """TFP(W=100) per scene (the paper's Table 1 reference) and ours against it, BM3D on one window and the limit."""
    from spikeref.accumulate import accumulate
    from spikeref.bayer import demosaic_bilinear
    from spikeref.bench.runner import score_centres
    from spikeref.dark_level import subtract_dark_level
    from spikeref.metrics import psnr

    tfp100 = {}
    for sc in scenes:
        sc.simulate(seed)
        dark = res["dark_levels"].get(sc.key)  # the ladder's calibration (with --dark-calibration)
        scores = []
        for t in score_centres(len(sc.stream), frames):
            ref = sc.reference(t)
            img = demosaic_bilinear(accumulate(sc.stream, 100, start=t - 50, count=1)[0], sc.stream.cfa)
            if dark is not None:
                img = subtract_dark_level(img, dark, sc.stream.cfa)
            scores.append(psnr(ref, img, float(ref.max())))
        tfp100[sc.key] = float(np.mean(scores))
        sc.stream = None
    by = {(r["scene"], r["rung"]): r["psnr"] for r in res["rows"]}
    keys = [sc.key for sc in scenes]
    lines = ["", "| scene | TFP(W=100) | ours − TFP(W=100) | ours − BM3D on W | ours − limit |",
             "|---|---:|---:|---:|---:|"]
    for k in keys:
        ours = by[(k, "ours")]
        lines.append(f"| {k} | {tfp100[k]:.2f} | {ours - tfp100[k]:+.2f} | "
                     f"{ours - by.get((k, 'bm3d'), np.nan):+.2f} | {ours - by[(k, 'limit')]:+.2f} |")
    m = {r: float(np.mean([by[(k, r)] for k in keys])) for r in ("ours", "bm3d", "limit") if (keys[0], r) in by}
    t100 = float(np.mean(list(tfp100.values())))
    lines.append(f"| **mean** | {t100:.2f} | **{m['ours'] - t100:+.2f}** | "
                 f"**{m['ours'] - m.get('bm3d', np.nan):+.2f}** | **{m['ours'] - m['limit']:+.2f}** |")
    return "\n".join(lines) + ("\n\nTargets (issue: stage ladder): ours ≥ TFP(W=100) + 2.0, ≥ BM3D + 2.0, "
                               "≥ limit − 2.0 dB.\n")


if __name__ == "__main__":
    main()
