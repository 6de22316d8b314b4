"""``spikeref calibrate``: the hot-pixel map of a dark recording, for ``--hot-pixels MAP.npz``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spikeref.cli.arguments import DefaultsHelpFormatter, check_int
from spikeref.cli.errors import CliError, output_phase
from spikeref.cli.inputs import add_input_options, open_input
from spikeref.cli.outputs import check_output_file

__all__ = ["CALIBRATE_MIN_EXCESS", "cmd_calibrate", "add_parser"]


#: ``calibrate``'s least excess over the same-colour reference, spikes per readout: in a dark recording no scene can
#: mimic a defect, so the statistical test (6 σ in the stretch, half the blocks) decides, down to a weak leak.
CALIBRATE_MIN_EXCESS = 0.02


def cmd_calibrate(args) -> int:
    """``spikeref calibrate DARK -o map.npz``: the hot pixels of a (dark) recording, as a map."""
    from spikeref.hot_pixels import HotPixelParams, hot_pixel_excess, save_hot_pixel_map

    check_output_file(args.output, "-o/--output", (".npz",), "hot-pixel map")
    check_int(args.planes, "--planes", 8, "a number of readouts ≥ 8")
    stream = open_input(args)
    if stream.height % 2 or stream.width % 2:
        raise CliError(f"the recording must have even height and width (2×2 phases); got {stream.height}×"
                       f"{stream.width}")
    if len(stream) < 8:
        raise CliError(f"{len(stream)} planes: too few to tell a hot pixel (at least 8)")
    found = hot_pixel_excess(stream, params=HotPixelParams(planes=args.planes, min_excess=CALIBRATE_MIN_EXCESS))
    mask, excess = found["hot"], found["excess"]
    planes = min(args.planes, len(stream))
    with output_phase():
        save_hot_pixel_map(args.output, mask, planes=planes, height=stream.height, width=stream.width,
                           source=str(stream.path.name if stream.path else ""))
    n = int(mask.sum())
    share = 100.0 * n / mask.size
    print(f"{stream.path.name if stream.path else 'stream'}: {n} hot pixels ({share:.3f} % of {mask.size}) in "
          f"{planes} planes" + (f"; their excess over their colour {float(excess[mask].min()):.2f}–"
                                f"{float(excess[mask].max()):.2f} spikes per readout" if n else ""))
    print(f"wrote {args.output}: use it with spikeref reconstruct/denoise --hot-pixels {args.output}",
          file=sys.stderr)
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref calibrate`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("calibrate", help="a hot-pixel map from a dark recording, for --hot-pixels MAP.npz",
                       description="Find the hot pixels of a sensor in a recording made with the lens covered (or "
                                   "of any static scene): pixels that fire far above their same-colour neighbours "
                                   "in every block of the stretch and alone (spikeref.hot_pixels). Writes a map "
                                   "that reconstruct and denoise apply with --hot-pixels MAP.npz.",
                       formatter_class=DefaultsHelpFormatter)
    add_input_options(p)
    p.add_argument("-o", "--output", type=Path, required=True, help="the map to write (.npz)")
    p.add_argument("--planes", type=int, default=20000,
                   help="readouts read from the start of the recording (at most; 20000 = 1 s at 20 kHz)")
    p.set_defaults(func=cmd_calibrate)
    return [p]
