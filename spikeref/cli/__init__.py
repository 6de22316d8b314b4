"""``spikeref`` command line: inspect, simulate, run baselines, denoise, train.

Every subcommand prints ``--help`` with units and defaults.  Spike files are
``.dat`` (no header: give ``--height/--width``, or keep a ``NAME.json`` with
``{"height":…, "width":…, "cfa":…}`` beside ``NAME.dat``; ``--rows top-down`` for files that store their
rows top-down), ``.npy`` or ``.npz`` (``--key`` names the ``.npz`` array, ``--axes HWT`` reads planes-last
arrays such as SpikingSIM's).  ``docs/inputs.md`` names the options for each toolkit's layout.

One module per command, each with its sub-parser (``add_parser``) and its ``cmd_*`` function, which imports the
library code it runs (Numba kernels, the pipeline, the denoiser) only when it runs, so that ``--help`` and a
refused argument answer at once: :mod:`~spikeref.cli.info`, :mod:`~spikeref.cli.baseline`,
:mod:`~spikeref.cli.denoise`, :mod:`~spikeref.cli.reconstruct` (with its Dask path and the run record of
``--resume``), :mod:`~spikeref.cli.bench` (with ``--ladder``), :mod:`~spikeref.cli.train`,
:mod:`~spikeref.cli.simulate`, :mod:`~spikeref.cli.noise_check`, :mod:`~spikeref.cli.calibrate`,
:mod:`~spikeref.cli.golden`.  What several commands share: :mod:`~spikeref.cli.errors` (the errors, the signals
that stop a run), :mod:`~spikeref.cli.arguments` (argument checks and types), :mod:`~spikeref.cli.inputs`
(opening the input, its CFA, its hot pixels), :mod:`~spikeref.cli.outputs` (output checks),
:mod:`~spikeref.cli.weights` (``--weights``), :mod:`~spikeref.cli.compile_note` (the first run's compile line)
and :mod:`~spikeref.cli.parser` (:func:`build_parser`).
"""

from __future__ import annotations

import contextlib
import os
import select
import sys
import warnings
from pathlib import Path

from spikeref.cli.errors import CliError, Interrupted, RunFailed, signal_name, sigterm_as_interrupt
from spikeref.cli.inputs import SAMPLE, open_input
from spikeref.cli.parser import build_parser

__all__ = ["main", "build_parser", "CliError", "RunFailed", "Interrupted", "SAMPLE", "open_input"]


def main(argv=None) -> int:
    """Run ``spikeref`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status.

    0: done. 1: the run started and an OS error stopped it (a full disk, an unwritable folder);
    the frames already written are whole and ``--resume`` continues. 2: refused (a bad argument
    or input), before anything was written. 130: interrupted by SIGINT (Ctrl-C) or SIGTERM.
    Each failure is one line on stderr; ``--debug`` or ``SPIKEREF_DEBUG=1`` raises instead, with
    the traceback. Bad usage exits through ``SystemExit(2)`` (argparse), also with one line.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    args.argv = argv
    debug = bool(getattr(args, "debug", False)) or os.environ.get("SPIKEREF_DEBUG", "").strip() not in ("", "0")
    from spikeref.distributed import ChunkError  # no Dask import: the module loads it when a cluster is made

    with warnings.catch_warnings():
        warnings.showwarning = _one_line_notes(args.command, warnings.showwarning)
        try:
            with sigterm_as_interrupt():
                status = args.func(args)
            if status == 0 and getattr(args, "compile_tag", None):
                from spikeref import _jit

                _jit.mark_warm(args.compile_tag)  # its kernels are cached now: the next run says nothing
            return status
        except Interrupted as exc:
            if debug:
                raise
            print(f"spikeref {args.command}: {exc}", file=sys.stderr)
            return exc.status
        except BrokenPipeError as exc:
            if not _stdout_closed():  # a pipe of our own (not the reader of our output) broke: an error
                if debug:
                    raise
                print(f"spikeref {args.command}: error: {exc}", file=sys.stderr)
                return 2
            # the reader of our output went away (`spikeref info | head -1`): nothing is wrong, say nothing
            with contextlib.suppress(OSError):
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
            return 0
        except KeyboardInterrupt as exc:
            if debug:
                raise
            print(f"spikeref {args.command}: interrupted ({signal_name(exc)}); files already written are whole",
                  file=sys.stderr)
            return Interrupted.status
        except (CliError, ChunkError, ValueError, TypeError, FileNotFoundError, OSError, ImportError) as exc:
            if debug:
                raise
            print(f"spikeref {args.command}: error: {exc}", file=sys.stderr)
            return getattr(exc, "status", 2)


def _stdout_closed() -> bool:
    """Whether the reader of standard output has gone: a flush raises ``BrokenPipeError``, or (nothing left to
    flush) polling the pipe reports an error."""
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        return True
    except (OSError, ValueError):
        return False
    try:
        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(events & select.POLLERR for _, events in poll.poll(0))
    except (AttributeError, OSError, ValueError):  # no poll (Windows), or no real file behind stdout
        return False


def _one_line_notes(command: str, show):
    """A ``warnings.showwarning`` that prints spikeref's own ``UserWarning`` as ``spikeref CMD: note: …``.

    Such a warning is a note to the user (say, that small frames were aligned with a smaller
    pyramid), not a fault to trace; any other warning goes to ``show``.
    """
    package = Path(__file__).resolve().parents[1]  # spikeref/, above this package

    def show_note(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, UserWarning) and Path(filename).resolve().is_relative_to(package):
            print(f"spikeref {command}: note: {message}", file=sys.stderr if file is None else file)
        else:
            show(message, category, filename, lineno, file, line)

    return show_note
