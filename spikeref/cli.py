"""``spikeref`` command line: inspect spike files, run baselines (and later the method).

Every subcommand prints ``--help`` with units and defaults.  Spike files are
``.dat`` (no header: give ``--height/--width``, or keep a ``NAME.json`` with
``{"height":…, "width":…, "cfa":…}`` beside ``NAME.dat``), ``.npy`` or ``.npz``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

__all__ = ["main", "build_parser"]

SAMPLE = Path(__file__).resolve().parent / "data" / "sample.dat"


class CliError(Exception):
    """An error to report as one line, without a traceback."""


# ----------------------------------------------------------------------------- input
def _add_input_options(p: argparse.ArgumentParser, optional_file: bool = False) -> None:
    if optional_file:
        p.add_argument("file", nargs="?", type=Path, default=None,
                       help="spike file (.dat, .npy, .npz); default: the embedded sample")
    else:
        p.add_argument("file", type=Path, help="spike file (.dat, .npy, .npz)")
    p.add_argument("--height", type=int, default=None,
                   help="image height in pixels (.dat only; default from NAME.json, else 250)")
    p.add_argument("--width", type=int, default=None,
                   help="image width in pixels (.dat only; default from NAME.json, else 400)")
    p.add_argument("--file-width", type=int, default=None,
                   help="stored row width when rows are padded, e.g. 1024 for some 1000×1000 cameras")
    p.add_argument("--cfa", default=None,
                   help="Bayer pattern of the upright image: RGGB, BGGR, GRBG, GBRG, or 'mono' "
                        "(default from NAME.json, else mono)")
    p.add_argument("--rate-hz", type=float, default=None,
                   help="readout rate in planes per second (default 20000)")


def _sidecar(path: Path) -> dict:
    meta_path = path.with_suffix(".json")
    if meta_path.is_file():
        try:
            return json.loads(meta_path.read_text())
        except json.JSONDecodeError as exc:
            raise CliError(f"{meta_path}: not valid JSON ({exc})") from None
    return {}


def open_input(args):
    """Open the stream named by the parsed input options."""
    from spikeref.io.dat import load_spikes

    path = args.file if getattr(args, "file", None) is not None else SAMPLE
    if not path.exists():
        raise CliError(f"no such file: {path}")
    meta = _sidecar(path) if path.suffix.lower() == ".dat" else {}
    cfa = args.cfa if args.cfa is not None else meta.get("cfa")
    if isinstance(cfa, str) and cfa.lower() == "mono":
        cfa = None
    kw = {"rate_hz": args.rate_hz or meta.get("rate_hz", 20000.0)}
    if path.suffix.lower() == ".dat":
        kw["file_width"] = args.file_width or meta.get("file_width")
        height = args.height or meta.get("height", 250)
        width = args.width or meta.get("width", 400)
        return load_spikes(path, height=height, width=width, cfa=cfa, **kw)
    return load_spikes(path, cfa=cfa, **kw)


# ------------------------------------------------------------------------------ info
def cmd_info(args) -> int:
    from tqdm import tqdm

    from spikeref.accumulate import window_counts
    from spikeref.bayer import bayer_planes

    stream = open_input(args)
    t, h, w = stream.shape
    print(f"file        {stream.path}")
    print(f"planes      {t}")
    stored = f" (stored rows {stream.file_width} wide)" if stream.file_width != w else ""
    print(f"size        {h} × {w} pixels{stored}")
    print(f"cfa         {stream.cfa or 'mono'}")
    print(f"rate        {stream.rate_hz:g} planes/s")
    print(f"duration    {stream.duration_s * 1000:.3f} ms")
    chunk = 2000
    total = np.zeros((h, w), dtype=np.float64)
    for start in tqdm(range(0, t, chunk), desc="counting", unit="chunk", disable=None, leave=False):
        n = min(chunk, t - start)
        total += window_counts(stream, n, start=start, count=1)[0]
    rates = total / t
    print(f"mean rate   {rates.mean():.5f} spikes/readout over all pixels")
    if h % 2 == 0 and w % 2 == 0:
        names = list(stream.cfa) if stream.cfa else ["(0,0)", "(0,1)", "(1,0)", "(1,1)"]
        per_plane = bayer_planes(rates).mean(axis=(-1, -2))
        print("per Bayer plane (spikes/readout):")
        for pos, (name, r) in enumerate(zip(names, per_plane, strict=True)):
            print(f"  plane {pos} at ({pos // 2},{pos % 2}) {name:>5}: {r:.5f}")
    return 0


# -------------------------------------------------------------------------- baseline
def cmd_baseline(args) -> int:
    from spikeref.render import render_baseline

    stream = open_input(args)
    render_baseline(
        stream, args.method, args.output, exr_dir=args.exr_dir, window=args.window, every=args.every,
        fps=args.fps, half=args.half, progress=True,
    )
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="spikeref",
        description="Colour video from mosaicked chromatic spikes (Yang et al., ECCV 2024), on a CPU.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("info", help="planes, size, duration and mean firing rate per Bayer plane",
                       description="Print what a spike file holds: planes, size, duration (at the readout "
                                   "rate), and the mean firing rate (spikes per readout, 0…1) per Bayer plane.")
    _add_input_options(p, optional_file=True)
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("baseline", help="TFP / TFI / TFSTP reconstruction to MP4 (+ EXR frames)",
                       description="Reconstruct with a classic baseline (per Bayer plane, then bilinear "
                                   "demosaic Ψ for colour streams) and write a video and optionally EXR frames.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("method", choices=["tfp", "tfi", "tfstp"], help="baseline to run")
    _add_input_options(p, optional_file=True)
    p.add_argument("-o", "--output", type=Path, required=True, help="video file (.mp4 or .gif)")
    p.add_argument("--exr-dir", type=Path, default=None, help="also write linear EXR frames here")
    p.add_argument("-W", "--window", type=int, default=10,
                   help="TFP window in planes (10 planes = 0.5 ms at 20 kHz → 2000 FPS)")
    p.add_argument("--every", type=int, default=None,
                   help="TFI/TFSTP: output one frame every this many planes (default: the window)")
    p.add_argument("--fps", type=float, default=30.0, help="playback rate of the video file")
    p.add_argument("--half", action="store_true", help="write float16 EXR (default float32)")
    p.set_defaults(func=cmd_baseline)
    return parser


def _version() -> str:
    from spikeref import __version__

    return __version__


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        return args.func(args)
    except (CliError, ValueError, TypeError, FileNotFoundError, OSError) as exc:
        print(f"spikeref {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
