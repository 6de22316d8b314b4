"""``spikeref baseline``: a classic baseline (TFP, TFI, TFSTP) to a video and EXR frames."""

from __future__ import annotations

import argparse
from pathlib import Path

from spikeref.cli.arguments import DefaultsHelpFormatter, check_float, check_int, frames_within
from spikeref.cli.compile_note import compiling_note
from spikeref.cli.errors import CliError, output_phase
from spikeref.cli.inputs import add_input_options, open_input
from spikeref.cli.outputs import check_output_dir, check_video, say_written

__all__ = ["cmd_baseline", "add_parser"]


def cmd_baseline(args) -> int:
    from spikeref.baseline_stream import baseline_frame_count
    from spikeref.render import render_baseline

    if args.output is None and args.exr_dir is None:  # as reconstruct: a video and its EXR frames, named here
        args.output, args.exr_dir = Path(f"{args.method}.mp4"), Path(f"{args.method}_exr")
    check_video(args.output)
    check_output_dir(args.exr_dir, "--exr-dir")
    check_int(args.window, "-W/--window", 1, "a positive number of planes")
    check_int(args.every, "--every", 1, "a positive number of planes")
    check_float(args.fps, "--fps")
    stream = open_input(args)
    if args.method == "tfp" and args.window > len(stream):
        raise CliError(f"window={args.window} is longer than the stream ({len(stream)} planes)")
    total = baseline_frame_count(len(stream), args.method, args.window, args.every)
    frames = frames_within(args.frames, range(total), "there are frames 0:{stop}")
    compiling_note(args, f"baseline-{args.method}")
    with output_phase():
        render_baseline(
            stream, args.method, args.output, exr_dir=args.exr_dir, window=args.window, every=args.every,
            fps=args.fps, half=args.half, progress=True, frames=frames,
        )
    say_written(args.output, args.exr_dir)
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref baseline`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("baseline", help="TFP / TFI / TFSTP reconstruction to MP4 (+ EXR frames)",
                       description="Reconstruct with a classic baseline (per Bayer plane, then bilinear "
                                   "demosaic Ψ for colour streams) and write a video and/or EXR frames (without "
                                   "-o/--exr-dir: METHOD.mp4 and METHOD_exr/).",
                       formatter_class=DefaultsHelpFormatter)
    p.add_argument("method", choices=["tfp", "tfi", "tfstp"], help="baseline to run")
    add_input_options(p, optional_file=True)
    p.add_argument("-o", "--output", type=Path, default=None, help="video file (.mp4 or .gif)")
    p.add_argument("--exr-dir", type=Path, default=None, help="also write linear EXR frames here")
    p.add_argument("-W", "--window", type=int, default=10,
                   help="TFP window in planes (10 planes = 0.5 ms at 20 kHz → 2000 FPS)")
    p.add_argument("--every", type=int, default=None,
                   help="TFI/TFSTP: output one frame every this many planes (default: the window)")
    p.add_argument("--frames", default=None,
                   help="frame numbers a:b (b excluded; TFP frame k is planes kW … (k+1)W − 1, TFI/TFSTP frame k "
                        "is plane k·every), or N for the first N (default all); TFSTP still filters every "
                        "plane before the first")
    p.add_argument("--fps", type=float, default=30.0, help="playback rate of the video file")
    p.add_argument("--half", action="store_true", help="write float16 EXR (default float32)")
    p.set_defaults(func=cmd_baseline)
    return [p]
