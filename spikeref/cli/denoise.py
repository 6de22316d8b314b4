"""``spikeref denoise``: the denoised colour frames Ψ[D(I)] of a spike file to a video and EXR frames."""

from __future__ import annotations

import argparse
from pathlib import Path

from spikeref.cli import weights
from spikeref.cli.arguments import DefaultsHelpFormatter, check_float, check_int, frames_within
from spikeref.cli.compile_note import compiling_note
from spikeref.cli.errors import CliError, output_phase
from spikeref.cli.inputs import (
    add_hot_pixel_option, add_input_options, hot_pixel_map, hot_pixel_option, open_input, say_hot_pixels,
)
from spikeref.cli.outputs import check_output_dir, check_video, say_written

__all__ = ["cmd_denoise", "add_parser"]


def cmd_denoise(args) -> int:
    import itertools

    from tqdm import tqdm

    from spikeref.render import FrameSink

    if args.output is None and args.exr_dir is None:  # as reconstruct: a video and its EXR frames, named here
        args.output, args.exr_dir = Path("denoised.mp4"), Path("denoised_exr")
    check_video(args.output)
    check_output_dir(args.exr_dir, "--exr-dir")
    check_int(args.window, "-W/--window", 1, "a positive number of planes")
    check_int(args.start, "--start", 0, "a plane index ≥ 0")
    check_float(args.fps, "--fps")
    stream = open_input(args)
    if args.start >= len(stream):
        raise CliError(f"--start {args.start}: the stream has {len(stream)} planes")
    total = (len(stream) - args.start) // args.window
    if total < 1:
        raise CliError(f"no whole window of {args.window} planes from plane {args.start} "
                       f"(the stream has {len(stream)} planes)")
    frames = frames_within(args.frames, range(total), "there are frames 0:{stop} (whole windows from --start)")
    weights.bundled_weights_by_default(args, args.accumulate)
    den = weights.load_denoiser(args.weights, accumulate=args.accumulate, shrink=not args.no_shrink,
                                guard=args.guard)
    from spikeref.hot_pixels import hot_pixels_to_replace

    hot_map = hot_pixel_option(args.hot_pixels)
    hot = hot_pixels_to_replace(stream, "off" if args.hot_pixels == "off" else "auto", hot_pixel_map(hot_map, stream))
    say_hot_pixels(hot, hot_map)
    compiling_note(args, f"denoise-{args.accumulate}")
    made = den.frames(stream, args.window, start=args.start + frames.start * args.window, count=len(frames),
                      accumulate=args.accumulate, hot_pixels=hot)
    first = next(made, None)  # the generator's own checks (and the first frame) before any output is opened
    with output_phase():
        with FrameSink(args.output, args.exr_dir, fps=args.fps, half=args.half) as sink, \
                tqdm(total=len(frames), desc="denoise", unit="frame", disable=None) as bar:
            for k, frame in itertools.chain([first] if first is not None else [], made):
                sink.add(frames.start + k, frame)  # frame k covers planes start + kW … start + (k + 1)W − 1
                bar.update(1)
    say_written(args.output, args.exr_dir)
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref denoise`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("denoise", help="denoised colour frames Ψ[D(I)] of a spike file to MP4 / EXR",
                       description="Accumulate windows of W planes (Eq. 4), denoise the four Bayer planes with the "
                                   "self-supervised U-Net (§4.1; bundled weights unless --weights) and demosaic "
                                   "(Ψ). Frames are linear RGB in spikes per readout; the video uses one exposure. "
                                   "Without -o/--exr-dir it writes denoised.mp4 and denoised_exr/.",
                       formatter_class=DefaultsHelpFormatter)
    add_input_options(p, optional_file=True)
    p.add_argument("-o", "--output", type=Path, default=None, help="video file (.mp4 or .gif)")
    p.add_argument("--exr-dir", type=Path, default=None, help="also write linear EXR frames here")
    p.add_argument("-W", "--window", type=int, default=10,
                   help="window in planes (10 planes = 0.5 ms at 20 kHz → 2000 FPS)")
    add_hot_pixel_option(p, "denoise")
    p.add_argument("--guard", choices=["sure", "off"], default="sure",
                   help="sure: blend the network's output with its input by Stein's unbiased risk estimate, "
                        "per pixel, from the data's own noise level (one more network pass; not in the paper; "
                        "spikeref.denoise.guard; for W > 10 the noise is measured on the window's first 10 "
                        "planes, so texture is not read as noise); off: the network's output, then the shrinkage "
                        "below")
    p.add_argument("--accumulate", choices=["count", "charge"], default="count",
                   help="what each window gives: count (default; Eq. 4, its spikes / W) or charge (the charge its "
                        "pixels integrated, read from the spike times up to 200 readouts around the window's edges; "
                        "not in the paper; spikeref.charge); without --weights it uses the bundled pairs_w16_charge, "
                        "trained on window charges (b2u_w16 with counts)")
    p.add_argument("--no-shrink", action="store_true",
                   help="with --guard off, do not give back the residual above the exposure's binomial noise "
                        "(spikeref.denoise.shrinkage); --guard off --no-shrink is the paper's D(I) exactly")
    p.add_argument("--weights", type=Path, default=None,
                   help="weights .npz, or a bundled name: b2u_w16 (the default with counts: Eq. 4's counts, the "
                        "paper's Blind2Unblind loss) or pairs_w16_charge (the default with --accumulate charge: "
                        "trained on window charges by Noise2Noise pairs); each network is trained on what its path "
                        "gives it")
    p.add_argument("--start", type=int, default=0, help="first plane")
    p.add_argument("--frames", default=None,
                   help="frame numbers a:b (b excluded; frame k is planes start + kW … start + (k+1)W − 1), or N for "
                        "the first N (default: every whole window)")
    p.add_argument("--fps", type=float, default=30.0, help="playback rate of the video file")
    p.add_argument("--half", action="store_true", help="write float16 EXR (default float32)")
    p.set_defaults(func=cmd_denoise)
    return [p]
