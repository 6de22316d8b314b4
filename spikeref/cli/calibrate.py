"""``spikeref calibrate``: the hot pixels and the dark level of a dark recording, for ``--hot-pixels MAP.npz`` and
``--dark-level MAP.npz``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spikeref.cli.arguments import DefaultsHelpFormatter, check_int
from spikeref.cli.errors import CliError, output_phase
from spikeref.cli.inputs import add_input_options, open_input
from spikeref.cli.outputs import check_output_file

__all__ = ["cmd_calibrate", "add_parser"]


def cmd_calibrate(args) -> int:
    """``spikeref calibrate DARK -o map.npz``: the hot pixels and the dark level of a dark recording, as a map."""
    from spikeref.dark_level import DARK_LEVEL_MAX, calibrate_dark
    from spikeref.hot_pixels import save_hot_pixel_map

    check_output_file(args.output, "-o/--output", (".npz",), "hot-pixel map")
    check_int(args.planes, "--planes", 8, "a number of readouts ≥ 8")
    stream = open_input(args)
    if stream.height % 2 or stream.width % 2:
        raise CliError(f"the recording must have even height and width (2×2 phases); got {stream.height}×"
                       f"{stream.width}")
    if len(stream) < 8:
        raise CliError(f"{len(stream)} planes: too few to tell a hot pixel (at least 8)")
    found = calibrate_dark(stream, planes=args.planes)
    mask, excess, level, planes = found["hot"], found["excess"], found["dark_level"], found["planes"]
    with output_phase():
        save_hot_pixel_map(args.output, mask, planes=planes, height=stream.height, width=stream.width,
                           source=str(stream.path.name if stream.path else ""), dark_level=level)
    n = int(mask.sum())
    share = 100.0 * n / mask.size
    print(f"{stream.path.name if stream.path else 'stream'}: {n} hot pixels ({share:.3f} % of {mask.size}) in "
          f"{planes} planes" + (f"; their excess over their colour {float(excess[mask].min()):.2f}–"
                                f"{float(excess[mask].max()):.2f} spikes per readout" if n else ""))
    print("dark level (Eq. 9's E[N]/W, spikes per readout, per 2×2 phase): "
          + ", ".join(f"{v:.5f}" for v in level))
    if level.max() > DARK_LEVEL_MAX:
        print(f"warning: a dark level of {level.max():.4f} spikes per readout is not a dark recording's (above "
              f"{DARK_LEVEL_MAX}): --dark-level will refuse this map; its hot pixels still apply", file=sys.stderr)
    print(f"wrote {args.output}: use it with spikeref reconstruct --hot-pixels {args.output} --dark-level "
          f"{args.output} (denoise: --hot-pixels)", file=sys.stderr)
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref calibrate`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("calibrate", help="hot pixels and the dark level from a dark recording, for --hot-pixels "
                                         "MAP.npz and --dark-level MAP.npz",
                       description="Calibrate a sensor from a recording made with the lens covered: its hot pixels, "
                                   "which fire far above their same-colour neighbours in every block of the stretch "
                                   "and alone (spikeref.hot_pixels), and its dark level, the mean rate of each 2×2 "
                                   "phase's other pixels in spikes per readout (what the sensor fires without "
                                   "light, Eq. 9's E[N]/W: spikeref.dark_level). Writes a map that reconstruct and "
                                   "denoise apply with --hot-pixels MAP.npz, and reconstruct subtracts the dark "
                                   "level of with --dark-level MAP.npz. Only the hot pixels apply to a recording of "
                                   "a static scene.",
                       formatter_class=DefaultsHelpFormatter)
    add_input_options(p)
    p.add_argument("-o", "--output", type=Path, required=True, help="the map to write (.npz)")
    p.add_argument("--planes", type=int, default=20000,
                   help="readouts read from the start of the recording (at most; 20000 = 1 s at 20 kHz)")
    p.set_defaults(func=cmd_calibrate)
    return [p]
