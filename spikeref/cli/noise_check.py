"""``spikeref noise-check``: the noise ratio per Bayer channel against the window W (Fig. 4a)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spikeref.cli.arguments import DefaultsHelpFormatter, check_float, check_int, int_list
from spikeref.cli.compile_note import compiling_note
from spikeref.cli.errors import CliError, output_phase
from spikeref.cli.inputs import add_input_options, open_input
from spikeref.cli.outputs import check_output_file

__all__ = ["cmd_noise_check", "add_parser", "NOISE_CHECK_WINDOWS"]


def cmd_noise_check(args) -> int:
    import importlib.util

    from spikeref.noise_check import noise_check, plot_noise_check

    for w in args.windows:
        check_int(w, "--windows", 1, "a positive number of planes each")
    check_int(args.start, "--start", 0, "a plane index ≥ 0")
    check_int(args.planes, "--planes", 1, "a positive number of planes")
    check_float(args.min_rate, "--min-rate", positive=False)
    if args.plot is not None:
        if args.plot.suffix.lower() != ".png":
            raise CliError(f"--plot must end in .png; got {args.plot.name!r}")
        check_output_file(args.plot, "--plot", (".png",), "plot")
        if importlib.util.find_spec("matplotlib") is None:
            raise CliError("--plot needs matplotlib: pip install 'spikeref[plot]'")
    stream = open_input(args)
    compiling_note(args, "noise-check")
    result = noise_check(stream, windows=args.windows, start=args.start, planes=args.planes,
                         min_rate=args.min_rate, progress=True)
    print(f"noise ratio I_c / E[I_c] - 1 of {stream.path or 'the input'} (Fig. 4a; the scene must be static)")
    print(result.table())
    if args.plot is not None:
        with output_phase():
            args.plot.parent.mkdir(parents=True, exist_ok=True)
            plot_noise_check(result, args.plot)
        print(f"plot: {args.plot}")
    for line in result.warnings:  # a channel resting on too few pixels (also marked in the table and plot)
        print(f"warning: {line}", file=sys.stderr)
    return 0


#: :data:`spikeref.noise_check.DEFAULT_WINDOWS`, restated so that ``--help`` loads no Numba kernel (a test holds
#: the two equal).
NOISE_CHECK_WINDOWS = (5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000)


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref noise-check`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("noise-check", help="Fig. 4a: noise ratio per Bayer channel against the window W",
                       description="On a static recording, accumulate windows of W planes (Eq. 4) and report "
                                   "the noise ratio I_c / E[I_c] - 1 per channel (R, G, B; the two G planes "
                                   "pooled): its mean absolute value and standard deviation over frames and "
                                   "pixels. E[I_c] is each pixel's rate over the whole span (the longest "
                                   "window). Pixels with fewer than 20 spikes in the span are left out.",
                       formatter_class=DefaultsHelpFormatter)
    add_input_options(p, optional_file=True)
    p.add_argument("--windows", type=int_list, default=NOISE_CHECK_WINDOWS,
                   help="window lengths W in planes, comma-separated (5 planes = 0.25 ms at 20 kHz)")
    p.add_argument("--start", type=int, default=0, help="first plane of the analysed span")
    p.add_argument("--planes", type=int, default=None, help="planes in the span (default: to the end)")
    p.add_argument("--min-rate", type=float, default=None,
                   help="leave out pixels below this rate, spikes/readout (default: 20 spikes in the span)")
    p.add_argument("--plot", type=Path, default=None, help="also write the curve as a PNG (needs spikeref[plot])")
    p.set_defaults(func=cmd_noise_check)
    return [p]
