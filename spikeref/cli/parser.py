"""``build_parser``: the ``spikeref`` command line, each command's options added by the command's own module."""

from __future__ import annotations

import argparse

from spikeref.cli import baseline, bench, calibrate, denoise, golden, info, noise_check, reconstruct, simulate, train

__all__ = ["build_parser"]


class _Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors are one line (exit 2), like the commands' own errors."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="spikeref",
        description="Colour video from mosaicked chromatic spikes (Yang et al., ECCV 2024), on a CPU.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    # in the order of `spikeref --help`; each returns its parsers (golden's with its actions')
    commands = (info, baseline, denoise, reconstruct, bench, train, simulate, noise_check, calibrate, golden)
    parsers = [p for command in commands for p in command.add_parser(sub)]

    debug_help = "on an error or an interruption, show the Python traceback (also: SPIKEREF_DEBUG=1)"
    parser.add_argument("--debug", action="store_true", help=debug_help)
    for p in parsers:  # also after the command; the top level's value stands
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=debug_help)
    return parser


def _version() -> str:
    from spikeref import __version__

    return __version__
