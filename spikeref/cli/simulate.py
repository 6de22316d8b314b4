"""``spikeref simulate``: a scene (TOML) through the simulated camera into a ``.dat`` file, with ground truth."""

from __future__ import annotations

import argparse
from pathlib import Path

from spikeref.cli.arguments import DefaultsHelpFormatter, check_int, check_seed
from spikeref.cli.errors import CliError, output_phase
from spikeref.cli.outputs import check_output_dir, check_output_file

__all__ = ["parse_effects_option", "cmd_simulate", "add_parser"]


def parse_effects_option(text: str | None):
    """``--effects``: ``scene`` (keep the scene's), ``none``, or ``name[:param=value...][,name...]``."""
    if text is None or text.strip().lower() == "scene":
        return None
    if text.strip().lower() == "none":
        return {}
    spec = {}
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        name, *params = item.split(":")
        table = {}
        for param in params:
            key, eq, value = param.partition("=")
            if not eq:
                raise CliError(f"--effects: expected param=value in {item!r}; got {param!r}")
            try:
                table[key.strip()] = float(value)
            except ValueError:
                raise CliError(f"--effects: {name}.{key.strip()} must be a number; got {value!r}") from None
        spec[name.strip()] = table
    return spec


def cmd_simulate(args) -> int:
    from spikeref.simulate.effects import parse_effects
    from spikeref.simulate.recording import simulate_to_dat
    from spikeref.simulate.scenes import load_scene

    if args.output.suffix.lower() != ".dat":
        raise CliError(f"-o/--output must be a .dat file; got {args.output.name!r}")
    check_output_file(args.output, "-o/--output", (".dat",), "spike output")
    if args.gt is not None:
        if args.gt.suffix.lower() != ".npz":
            raise CliError(f"--gt: ground truth goes to a .npz file; got {args.gt.name!r}")
        check_output_file(args.gt, "--gt", (".npz",), "ground truth")
    check_output_dir(args.gt_exr, "--gt-exr")
    check_int(args.planes, "--planes", 1, "a positive number of planes")
    check_int(args.gt_window, "--gt-window", 1, "a positive number of planes")
    check_int(args.chunk_planes, "--chunk-planes", 1, "a positive number of planes")
    check_seed(args.seed)
    scene = load_scene(args.scene)
    effects = parse_effects_option(args.effects)
    if effects is not None:
        effects = parse_effects(effects)
    with output_phase():
        for path in (args.output, args.gt):
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
        meta = simulate_to_dat(scene, args.output, seed=args.seed, planes=args.planes, effects=effects,
                               gt_path=args.gt, gt_window=args.gt_window, gt_exr_dir=args.gt_exr,
                               chunk_planes=args.chunk_planes, progress=True)
    dur_ms = meta["planes"] / meta["rate_hz"] * 1000
    listed = ", ".join(meta["effects"]) or "none (noise-free)"
    print(f"wrote {args.output}: {meta['planes']} planes ({dur_ms:.2f} ms) of {meta['height']}×{meta['width']}, "
          f"cfa {meta['cfa']}, seed {meta['seed']}, effects: {listed}")
    if args.gt is not None:
        print(f"ground truth {args.gt}: frames of {args.gt_window} planes, rate units (alpha*L/E_th)")
    if args.gt_exr is not None:
        print(f"ground-truth EXR frames in {args.gt_exr}")
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref simulate`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("simulate", help="simulate a scene (TOML) into a .dat spike file, with ground truth",
                       description="Simulate a chromatic spike camera (Eq. 1–3 and the effects the scene lists, "
                                   "Eq. 5–9) looking at a scene described in TOML (see examples/scenes/), and write "
                                   "the spikes as .dat with a NAME.json sidecar. Time is in readouts (planes) at "
                                   "the camera's rate (20 000 planes/s by default). Ground truth is the mean linear "
                                   "RGB radiance over each window, in rate units (spikes per readout).",
                       formatter_class=DefaultsHelpFormatter)
    p.add_argument("scene", type=Path, help="scene file (.toml), e.g. examples/scenes/fan.toml")
    p.add_argument("-o", "--output", type=Path, required=True, help="spike file to write (.dat)")
    p.add_argument("--gt", type=Path, default=None,
                   help="also write ground truth frames (n, H, W, 3) float32 to this .npz")
    p.add_argument("--gt-exr", type=Path, default=None, help="also write ground-truth frames as EXR into this folder")
    p.add_argument("--gt-window", type=int, default=10,
                   help="ground-truth window W in planes (10 planes = 0.5 ms → 2000 FPS)")
    p.add_argument("--planes", type=int, default=None, help="number of planes (readouts); default: the scene's")
    p.add_argument("--seed", type=int, default=0, help="random seed of the noise effects")
    p.add_argument("--effects", default="scene",
                   help="'scene' (the scene's effects), 'none' (noise-free), or a list such as "
                        "'random_phase,dark_current:gamma=0.002,inherent_noise:mu=2000:sigma=200'; effects: "
                        "threshold_fpn(sigma), random_phase, hot_pixels(fraction,rate), "
                        "shot_noise(photons_per_threshold), dark_current(gamma), inherent_noise(mu,sigma,fraction)")
    p.add_argument("--chunk-planes", type=int, default=None,
                   help="planes per chunk (memory only; the output does not depend on it); default ≈16 M pixels")
    p.set_defaults(func=cmd_simulate)
    return [p]
