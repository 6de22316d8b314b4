"""Reproduce the bundled denoiser weights (``spikeref/denoise/weights/``) on a CPU.

1. Simulate the training scenes ``scripts/denoiser_scenes/train_*.toml`` (seed 7) into
   ``--data-dir`` unless the files are there: five procedural scenes and seven photographs bundled
   with scikit-image (the ``test`` extra) under motion — rocket, hubble_deep_field,
   immunohistochemistry, retina, gravel, brick and grass, reserved for training (no photograph
   of the benchmark or of a held-out set).
2. Add the real monochrome spikes of ``../shared/data/real/`` when that folder exists (each 2×2
   phase of a monochrome recording is a one-channel image with genuine sensor noise):
   ``spikezoo_uhsr.npz`` (real, low light) and ``spikezoo_data_reds_sim_250x400.dat`` (another
   simulator, a natural REDS frame). ``spikingsim_real_spike.npz`` is never trained on: it is
   the real-data test. Without ``../shared`` the run trains on the simulated scenes only, and
   the weights' metadata list the files used.
3. Train with :func:`spikeref.denoise.train.train` — reading spikes only — and write
   ``b2u_w<C>.npz`` (+ checkpoint) into ``--out``; with ``--snapshots N`` also a weights file
   every ``steps/N`` steps (``snap_w<C>_<step>.npz``, metadata ``train_seconds``) for the
   PSNR-against-wall-time curve (``scripts/train_curve.py``).

Objectives (``--objective``):

* ``b2u`` (default): the paper's Blind2Unblind loss (Eq. 10–12) on the data of steps 1–2.
* ``pairs`` (not in the paper; the bundled ``pairs_w16_charge``): Noise2Noise on the static twins of
  the simulated scenes (``scripts/denoiser_scenes/train_static_*.toml``, 1000 planes each, simulated
  into ``--data-dir`` if missing; no real recording, as those move) — one window against the spike
  count of every plane it did not read.  Writes ``pairs_w<C>[_charge].npz``:

    python scripts/train_denoiser.py --objective pairs --accumulate charge --steps 4000

Recipes (``--recipe``; ``--probe`` times the two with the b2u objective):

* ``cpu`` (default): one of the 16 blind-spot masks per image and step, loss on its hidden
  pixels (``TrainConfig.masks_per_step = 1``), 64×64 plane crops, 16 crops (64 images) a step.
* ``paper``: the full Ω of Eq. 10 (16 masks), 128×128 crops, 8 crops a step — the recipe of the
  weights bundled before 2026-11-24 (one H100).

A run may span several sittings: run the same command again and it resumes from the checkpoint
(the crops drawn are those of an uninterrupted run).

    python scripts/train_denoiser.py --recipe cpu --channels 16 --steps 6000 --out out/weights
    python scripts/train_denoiser.py --probe 20      # seconds per step of both recipes, interleaved

On a GPU (``--device cuda``; the bundled weights are all CPU runs, and stay reproducible without one), a
large-budget run in one command, stopped after ``--minutes`` of training wall time and written then:

    python scripts/train_denoiser.py --device cuda --minutes 10 --objective pairs --accumulate charge \
        --recipe paper --channels 32 --steps 20000 --out out/gpu

``--minutes`` checks the clock every 100 steps (the learning-rate schedule is that of ``--steps``); run the same
command again to go on from the checkpoint.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scripts" / "denoiser_scenes"
REAL = ROOT.parent / "shared" / "data" / "real"
SEED = 7
RECIPES = {
    "cpu": dict(masks_per_step=1, patch=64, batch=16, lr=1e-3),
    "paper": dict(masks_per_step=16, patch=128, batch=8, lr=1e-3),
}


def simulate_missing(data_dir: Path, static: bool = False) -> list[Path]:
    """The training scenes' streams (the static twins ``train_static_*.toml`` with ``static``), simulated if missing."""
    data_dir.mkdir(parents=True, exist_ok=True)
    out = []
    scenes = sorted(SCENES.glob("train_static_*.toml")) if static else \
        [s for s in sorted(SCENES.glob("train_*.toml")) if not s.stem.startswith("train_static_")]
    for scene in scenes:
        dat = data_dir / (scene.stem + ".dat")
        if not dat.is_file():
            print(f"simulating {scene.name}", flush=True)
            subprocess.run([sys.executable, "-m", "spikeref.cli", "simulate", str(scene), "-o", str(dat),
                            "--seed", str(SEED)], check=True, stderr=subprocess.DEVNULL)
        out.append(dat)
    return out


def training_streams(data_dir: Path, real: bool = True, min_side: int = 0, static: bool = False):
    """The streams trained on (those at least ``min_side`` pixels high and wide), and their description.

    With ``static`` (the pairs objective), the static twins of the simulated scenes and no real
    recording: the real ones move, and a pair's target needs a scene that does not.
    """
    from spikeref.stream import open_spike_file
    from spikeref.stream import SpikeStream

    streams = [open_spike_file(p) for p in simulate_missing(data_dir, static=static)]
    if real and not static and REAL.is_dir():
        uhsr = REAL / "spikezoo_uhsr.npz"
        if uhsr.is_file():
            streams.append(SpikeStream.from_array(np.load(uhsr)["spk"], cfa=None, path=uhsr))
        reds = REAL / "spikezoo_data_reds_sim_250x400.dat"
        if reds.is_file():
            streams.append(open_spike_file(reds, height=250, width=400))
    for s in [s for s in streams if min(s.height, s.width) < min_side]:
        print(f"note: {Path(s.path).name} ({s.height}×{s.width}) is smaller than the {min_side}-pixel crop: left out")
    streams = [s for s in streams if min(s.height, s.width) >= min_side]
    described = [{"file": Path(s.path).name, "planes": len(s), "height": s.height, "width": s.width}
                 for s in streams]
    return streams, described


def config(recipe: str, channels: int, steps: int, checkpoint_every: int, accumulate: str = "count",
           lam_end: float | None = None, objective: str = "b2u", exposure_channel: bool = False):
    from spikeref.denoise.train import TrainConfig

    more = {} if lam_end is None else {"lam_end": lam_end}
    return TrainConfig(width=channels, steps=steps, checkpoint_every=checkpoint_every, accumulate=accumulate,
                       objective=objective, exposure_channel=exposure_channel, **RECIPES[recipe], **more)


def probe(streams, steps: int, channels: int) -> dict:
    """Median seconds per step of each recipe, the recipes' steps interleaved (same load for both)."""
    import torch

    from spikeref.denoise.torch_unet import TorchUNet
    from spikeref.denoise.train import CropSampler, train_step

    rng = np.random.default_rng(0)
    runs = {}
    for name in RECIPES:
        cfg = config(name, channels, 1000, 1000)
        torch.manual_seed(0)
        model = TorchUNet(cfg.spec).to(memory_format=torch.channels_last)
        runs[name] = (cfg, model, torch.optim.Adam(model.parameters(), lr=cfg.lr),
                      CropSampler(streams, cfg.patch, cfg.window_min, cfg.window_max, domain=cfg.input_domain), [])
    for i in range(steps + 2):
        for cfg, model, opt, sampler, times in runs.values():
            t0 = time.perf_counter()
            train_step(model, opt, sampler, rng, cfg, cfg.lam_start)
            if i >= 2:  # the first two steps of each recipe set up oneDNN's kernels
                times.append(time.perf_counter() - t0)
    return {name: statistics.median(run[4]) for name, run in runs.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data-dir", type=Path, default=ROOT / ".train_data")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "weights")
    ap.add_argument("--recipe", choices=sorted(RECIPES), default="cpu")
    ap.add_argument("--channels", type=int, default=16, help="U-Net width")
    ap.add_argument("--steps", type=int, default=6000, help="optimiser steps of the schedule")
    ap.add_argument("--stop-after", type=int, default=None, help="stop after this many steps (resume later)")
    ap.add_argument("--snapshots", type=int, default=0, help="write this many evenly spaced weight snapshots")
    ap.add_argument("--no-real", action="store_true", help="leave out ../shared/data/real even if present")
    ap.add_argument("--accumulate", choices=["count", "charge"], default="count",
                    help="what a window gives the network: its spike count (Eq. 4) or the timing-aware charge "
                         "(spikeref.charge; weights for --accumulate charge)")
    ap.add_argument("--lam-end", type=float, default=None,
                    help="λ of Eq. 12 at the end of the schedule (default TrainConfig's 20; λ rises from 2)")
    ap.add_argument("--objective", choices=["b2u", "pairs"], default="b2u",
                    help="b2u: the paper's Blind2Unblind loss (Eq. 10-12) on the moving scenes and real recordings; "
                         "pairs: Noise2Noise on the static twins of the simulated scenes (train_static_*.toml), "
                         "one window against the count of the planes it did not read (not in the paper)")
    ap.add_argument("--exposure-channel", action="store_true",
                    help="give the network a second input channel, log10 of the window's length in planes "
                         "(TrainConfig.exposure_channel; not in the paper); the file name gains _exp")
    ap.add_argument("--device", choices=["cpu", "cuda"], default="cpu",
                    help="where to train (default cpu: every bundled network is a CPU run)")
    ap.add_argument("--minutes", type=float, default=None,
                    help="stop after this many minutes of training wall time (checked every 100 steps) and write "
                         "the weights; the schedule stays that of --steps")
    ap.add_argument("--probe", type=int, default=0, metavar="N",
                    help="only measure the median seconds per step of both recipes over N interleaved steps")
    args = ap.parse_args()
    if args.minutes is not None and not args.minutes > 0:
        ap.error(f"--minutes must be a positive number of minutes; got {args.minutes}")
    if args.device == "cuda":
        import torch

        if not torch.cuda.is_available():
            ap.error("--device cuda: PyTorch sees no CUDA device here (torch.cuda.is_available() is False); "
                     "train on the CPU (--device cpu) or on a machine with a GPU")
    from spikeref.denoise.train import train

    side = 2 * max(r["patch"] for r in RECIPES.values()) if args.probe else 2 * RECIPES[args.recipe]["patch"]
    streams, described = training_streams(args.data_dir, real=not args.no_real, min_side=side,
                                          static=args.objective == "pairs")
    if args.probe:
        per_step = probe(streams, args.probe, args.channels)
        print(" ".join(f"{k}: {v:.3f} s/step" for k, v in per_step.items())
              + f"; paper / cpu = {per_step['paper'] / per_step['cpu']:.1f}×")
        return
    cfg = config(args.recipe, args.channels, args.steps, checkpoint_every=max(1, min(500, args.steps // 20)),
                 accumulate=args.accumulate, lam_end=args.lam_end, objective=args.objective,
                 exposure_channel=args.exposure_channel)
    args.out.mkdir(parents=True, exist_ok=True)
    output = args.out / (f"{args.objective}_w{args.channels}.npz" if args.recipe == "cpu"
                         else f"{args.objective}_paper_w{args.channels}.npz")
    if args.accumulate == "charge":
        output = output.with_name(output.stem + "_charge.npz")
    if args.exposure_channel:
        output = output.with_name(output.stem + "_exp.npz")
    command = "python scripts/train_denoiser.py " + " ".join(sys.argv[1:])
    describe = {"command": command, "recipe": args.recipe, "data": described}
    last = args.steps if args.stop_after is None else min(args.steps, args.stop_after)
    snap_marks = {round(args.steps * k / max(1, args.snapshots)) for k in range(1, args.snapshots + 1)}
    marks = sorted(snap_marks | (set(range(100, last, 100)) if args.minutes is not None else set()))  # the clock
    t0 = time.time()
    for mark in [m for m in marks if m < last] + [last]:
        summary = train(streams, output, cfg, resume=True, describe=describe, stop_after=mark, device=args.device)
        if args.minutes is not None and time.time() - t0 >= 60 * args.minutes and mark != last:
            print(f"step {summary['steps']}: {args.minutes:g} minutes spent; stopping (run again to go on)",
                  flush=True)
            break
        if mark in snap_marks or (mark == last and mark != args.steps):
            snap = args.out / f"snap_{output.stem}_{mark:06d}.npz"
            snap.write_bytes(output.read_bytes())
        print(f"step {summary['steps']}: loss {summary['final_loss']:.4g}, {summary['seconds']:.0f} s of training",
              flush=True)
    print(f"wrote {output} in {time.time() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main()
