"""``spikeref train``: self-supervised training of the denoiser on unlabeled spike files (needs PyTorch)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spikeref.cli.arguments import DefaultsHelpFormatter, check_float, check_int, check_seed
from spikeref.cli.errors import CliError, Interrupted, output_phase, resume_command, signal_name
from spikeref.cli.inputs import check_input_options
from spikeref.cli.outputs import check_folder_can_exist, check_output_file

__all__ = ["cmd_train", "add_parser"]


def cmd_train(args) -> int:
    for flag, value in (("--channels", args.channels), ("--steps", args.steps), ("--batch", args.batch),
                        ("--patch", args.patch), ("--window-min", args.window_min),
                        ("--window-max", args.window_max), ("--checkpoint-every", args.checkpoint_every),
                        ("--stop-after", args.stop_after), ("--masks-per-step", args.masks_per_step)):
        check_int(value, flag)
    if args.masks_per_step > 16:
        raise CliError(f"--masks-per-step must be at most 16 (the blind-spot cell has 16 masks); "
                       f"got {args.masks_per_step}")
    if args.patch % 32:
        raise CliError(f"--patch must be a multiple of 32 (the U-Net halves it 5 times); got {args.patch}")
    if args.window_max < args.window_min:
        raise CliError(f"--window-max ({args.window_max}) must be ≥ --window-min ({args.window_min})")
    check_float(args.lr, "--lr", positive=False)
    check_seed(args.seed)
    check_input_options(args)
    check_output_file(args.output, "-o/--output", (".npz",), "weights output")
    checkpoint = args.checkpoint if args.checkpoint is not None else args.output.with_name(args.output.name + ".ckpt")
    if checkpoint.is_dir():
        raise CliError(f"--checkpoint {checkpoint}: is a folder, not a file")
    check_folder_can_exist(checkpoint.parent, "--checkpoint", checkpoint)
    for path in args.data:
        if not path.exists():
            raise CliError(f"no such file: {path}")
    try:
        from spikeref.denoise.train import TrainConfig, train
    except ImportError as exc:
        raise CliError(f"training needs PyTorch: pip install 'spikeref[train]' ({exc})") from None
    from spikeref.stream import open_spike_file

    streams = [open_spike_file(path, height=args.height, width=args.width, file_width=args.file_width,
                               rows=args.rows) for path in args.data]
    cfg = TrainConfig(width=args.channels, steps=args.steps, batch=args.batch, patch=args.patch, lr=args.lr,
                      window_min=args.window_min, window_max=args.window_max,
                      input_domain=args.input_domain, checkpoint_every=args.checkpoint_every,
                      masks_per_step=args.masks_per_step, seed=args.seed, accumulate=args.accumulate,
                      objective=args.objective)
    describe = {"command": "spikeref train " + " ".join(sys.argv[2:]) if len(sys.argv) > 2 else "spikeref train",
                "data": [{"file": Path(s.path).name, "planes": len(s), "height": s.height, "width": s.width}
                         for s in streams]}
    try:
        with output_phase():
            for folder in {args.output.parent, checkpoint.parent}:
                folder.mkdir(parents=True, exist_ok=True)
            summary = train(streams, args.output, cfg, checkpoint=checkpoint, resume=args.resume,
                            device=args.device, describe=describe, stop_after=args.stop_after)
    except KeyboardInterrupt as exc:
        state = f"the last checkpoint is {checkpoint}" if checkpoint.is_file() else "no checkpoint was written yet"
        raise Interrupted(f"interrupted ({signal_name(exc)}); {state}; continue with: "
                          f"{resume_command(args)}") from exc
    print(f"wrote {args.output}: {summary['steps']} steps in {summary['seconds']:.1f} s, "
          f"final loss {summary['final_loss']:.4g}")
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref train`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("train", help="train the denoiser on unlabeled spike files (needs spikeref[train])",
                       description="Self-supervised training of the denoising U-Net (Blind2Unblind: blind-spot "
                                   "volume Eq. 10-11, re-visible loss Eq. 12 with λ 2→20). Reads spike files only, "
                                   "never ground truth. Writes NumPy weights for `spikeref denoise --weights`, and "
                                   "a checkpoint every --checkpoint-every steps; --resume continues from it. The "
                                   "defaults are the CPU recipe of the bundled b2u_w16 (about 50 minutes on two "
                                   "cores; OMP_NUM_THREADS=1 when other jobs share them); the paper's recipe is "
                                   "--masks-per-step 16 --patch 128 --batch 8. --objective pairs (not in the "
                                   "paper) trains by Noise2Noise pairs of windows of recordings of scenes that do "
                                   "not move, as the bundled charge network pairs_w16_charge was "
                                   "(scripts/train_denoiser.py).",
                       formatter_class=DefaultsHelpFormatter)
    p.add_argument("data", type=Path, nargs="+", help="spike files (.dat with NAME.json, .npy, .npz), colour or mono")
    p.add_argument("-o", "--output", type=Path, required=True, help="weights file to write (.npz)")
    p.add_argument("--channels", type=int, default=16, help="U-Net channel width C")
    p.add_argument("--steps", type=int, default=4000, help="optimiser steps")
    p.add_argument("--batch", type=int, default=16, help="crops per step (each gives its four 2×2 phases)")
    p.add_argument("--patch", type=int, default=64, help="training image side on the plane grid, pixels "
                   "(multiple of 32; the mosaic crop is twice this)")
    p.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (cosine decay to 1 %%)")
    p.add_argument("--window-min", type=int, default=5, help="shortest window W, planes")
    p.add_argument("--window-max", type=int, default=200, help="longest window W, planes (log-uniform draw)")
    p.add_argument("--seed", type=int, default=0, help="seed of crops, augmentation and initial weights")
    p.add_argument("--input-domain", choices=["count", "rate"], default="count",
                   help="what the network sees: spike counts I·W (noise level nearly independent of W) or "
                        "firing rates I")
    p.add_argument("--checkpoint", type=Path, default=None, help="checkpoint file (default: OUTPUT.ckpt)")
    p.add_argument("--checkpoint-every", type=int, default=500, help="steps between checkpoints")
    p.add_argument("--masks-per-step", type=int, default=1,
                   help="how many of the 16 blind-spot masks (Eq. 10) each image runs per step, drawn at random; "
                        "the loss is taken on their hidden pixels. 16 is the paper's full volume; 1 is an order of "
                        "magnitude cheaper per step (the CPU recipe: scripts/train_denoiser.py)")
    p.add_argument("--accumulate", choices=["count", "charge"], default="count",
                   help="what a window gives the network: its spike count (Eq. 4) or the timing-aware charge "
                        "(weights for --accumulate charge of denoise and reconstruct)")
    p.add_argument("--objective", choices=["b2u", "pairs"], default="b2u",
                   help="b2u: the paper's Blind2Unblind self-supervision (Eq. 10-12); pairs (not in the paper): "
                        "Noise2Noise on recordings of scenes that do not move, one window against the spike count "
                        "of every plane it did not read (each file at least --window-max + 500 planes long)")
    p.add_argument("--resume", action="store_true", help="continue from the checkpoint if it exists")
    p.add_argument("--stop-after", type=int, default=None,
                   help="stop after this many of the --steps schedule's steps and write the weights "
                        "(with --resume from a checkpoint at that step: export it without training)")
    p.add_argument("--device", default=None, help="torch device, e.g. cpu or cuda (default: cuda if available)")
    p.add_argument("--height", type=int, default=None, help="image height of .dat files without NAME.json")
    p.add_argument("--width", type=int, default=None, help="image width of .dat files without NAME.json")
    p.add_argument("--file-width", type=int, default=None, help="stored row width of padded .dat rows")
    p.add_argument("--rows", choices=["bottom-up", "top-down"], default=None,
                   help="the order .dat files store the image rows in (default from NAME.json, else bottom-up, "
                        "the spike camera's; docs/inputs.md)")
    p.set_defaults(func=cmd_train)
    return [p]
