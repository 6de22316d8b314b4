"""Validation PSNR against training wall time: score weight snapshots in denoise mode.

Each ``*.npz`` weight file given (e.g. the snapshots ``scripts/train_denoiser.py --snapshots``
writes, whose metadata hold ``train_seconds``) is scored the way ``scripts/eval_guard.py``
scores a denoiser — the network in visible mode on the four Bayer planes of one W-plane window
(Eq. 4), Ψ, PSNR in linear RGB against the exact ground truth after a least-squares gain per
channel, 8-pixel border left out, mean over windows (planes 300 and 420 on) and scenes — without
the guard, so that the curve shows the network itself.

The scenes are the benchmark's (``spikeref/bench/scenes/``, seed 0): the *tuning* set. The
held-out sets (``scripts/heldout_scenes/``, ``scripts/denoiser_scenes/heldout_*.toml``) are never
read here.

    python scripts/train_curve.py out/run/*.npz [--windows 10,50] [--scenes astronaut_pan,...] [--csv F]
    python scripts/train_curve.py --plot docs/train_curve.png --csv F      # the figure from the rows in F

``--accumulate charge`` scores on the windows' charges (``spikeref.charge``) instead of Eq. 4's rates,
for the networks trained on them: ``docs/train_curve_charge.png`` compares the blind-spot loss
(``b2u_w16_charge``'s run) with the pairs objective (``pairs_w16_charge``'s) on the same input.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

DEFAULT_SCENES = "translation,hdr,astronaut_pan,coffee_spin,occlusion"


def main() -> None:
    from eval_guard import scene_cases, score  # scripts/eval_guard.py, beside this file

    from spikeref.bayer import bayer_mosaic, demosaic_bilinear
    from spikeref.denoise.denoiser import Denoiser

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("weights", type=Path, nargs="*")
    ap.add_argument("--windows", default="10,50")
    ap.add_argument("--scenes", default=DEFAULT_SCENES)
    ap.add_argument("--csv", type=Path, default=None, help="append rows (file, seconds, steps, W, PSNR) here")
    ap.add_argument("--plot", type=Path, default=None, help="draw PSNR against training seconds from --csv (PNG)")
    ap.add_argument("--accumulate", choices=("count", "charge"), default="count",
                    help="score on Eq. 4's rates (count) or the windows' charges (charge)")
    args = ap.parse_args()
    if args.plot:
        plot(args.csv, args.plot)
        return
    windows = [int(w) for w in args.windows.split(",")]
    data = list(scene_cases("bench", windows, args.scenes.split(","), accumulate=args.accumulate))
    rows = []
    identity = {w: np.mean([score(t, demosaic_bilinear(bayer_mosaic(p), cfa)) for _, ww, p, t, cfa in data if ww == w])
                for w in windows}
    print("identity (TFP(W)): " + ", ".join(f"W={w} {v:.2f}" for w, v in identity.items()))
    for path in args.weights:
        den = Denoiser.load(path, guard="off", shrink=False)
        meta = den.unet.meta
        res = {}
        for _, w, planes, truth, cfa in data:
            out = den(planes, window=w)
            image = demosaic_bilinear(bayer_mosaic(np.asarray(out, np.float32)), cfa)
            res.setdefault(w, []).append(score(truth, image))
        secs, steps = meta.get("train_seconds", float("nan")), meta.get("steps_run", -1)
        line = ", ".join(f"W={w} {np.mean(v):.2f}" for w, v in res.items())
        print(f"{path.name}: {steps} steps, {secs} s: {line}", flush=True)
        for w, v in res.items():
            rows.append((path.name, secs, steps, w, round(float(np.mean(v)), 3)))
    if args.csv:
        new = not args.csv.exists()
        with open(args.csv, "a", newline="") as fh:
            writer = csv.writer(fh)
            if new:
                writer.writerow(("file", "train_seconds", "steps", "W", "psnr_db"))
            writer.writerows(rows)


def plot(table: Path, out: Path) -> None:
    """PSNR against training wall time, one line per recipe (from the snapshot file names) and W."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(csv.DictReader(open(table)))
    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=110)
    def recipe_of(name: str) -> str:
        return "pairs" if "_pairs_" in name else "paper" if "_paper_" in name else "cpu"

    labels = {"paper": ("paper recipe (16 masks, 128² crops)", "s--"),
              "cpu": ("blind-spot loss, CPU recipe (1 mask, 64² crops)", "o-"),
              "pairs": ("pairs objective (Noise2Noise, static streams)", "^-.")}
    for recipe, (label, style) in labels.items():
        for w, colour in (("10", "C0"), ("50", "C1")):
            pts = sorted((float(r["train_seconds"]), float(r["psnr_db"])) for r in rows
                         if r["W"] == w and r["file"].startswith("snap_") and recipe_of(r["file"]) == recipe)
            if pts:
                ax.plot([p[0] / 60 for p in pts], [p[1] for p in pts], style, color=colour, label=f"{label}, W = {w}")
    ax.set_xlabel("training wall time, one thread (min)")
    ax.set_ylabel("PSNR, denoise mode (dB)")
    ax.set_title("Validation (benchmark scenes) against training time", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
