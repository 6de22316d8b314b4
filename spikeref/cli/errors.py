"""The errors of the ``spikeref`` commands, the signals that stop a run, and the command that continues it.

:func:`spikeref.cli.main` reports a :class:`CliError` as one line on stderr and exits with its ``status``."""

from __future__ import annotations

import contextlib
import shlex
import signal
import threading
from pathlib import Path

__all__ = ["CliError", "RunFailed", "Interrupted", "signal_name", "sigterm_as_interrupt", "os_error_text",
           "resume_command", "output_phase"]


class CliError(Exception):
    """An error to report as one line, without a traceback; exit status 2 (the command was refused).

    Every command checks all its arguments and inputs before it creates a folder, opens an
    output, starts a progress bar or a Dask cluster, so a refused command leaves the disk as
    it found it.
    """

    status = 2


class RunFailed(CliError):
    """The run had started and an OS error stopped it (a full disk, an unwritable folder): exit status 1."""

    status = 1


class Interrupted(CliError):
    """SIGINT (Ctrl-C) or SIGTERM stopped the run: exit status 130."""

    status = 130


class _Terminated(KeyboardInterrupt):
    """Raised in the main thread by SIGTERM (a batch scheduler's stop); handled like Ctrl-C."""


def signal_name(exc: BaseException) -> str:
    return "SIGTERM" if isinstance(exc, _Terminated) else "SIGINT"


@contextlib.contextmanager
def sigterm_as_interrupt():
    """While a command runs, SIGTERM raises :class:`_Terminated` in the main thread (once), like Ctrl-C."""
    previous = None
    if threading.current_thread() is threading.main_thread():
        fired = []

        def handler(signum, frame):
            if not fired:  # a second SIGTERM during the clean-up does not interrupt the clean-up
                fired.append(signum)
                raise _Terminated()

        try:
            previous = signal.signal(signal.SIGTERM, handler)
        except (ValueError, OSError):  # pragma: no cover - no signals here (an embedded interpreter)
            previous = None
    try:
        yield
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def os_error_text(exc: OSError) -> str:
    """``PATH: reason`` of an OS error (the path the error is about, when it names one)."""
    if exc.filename is not None and exc.strerror:
        return f"{exc.filename}: {exc.strerror}"
    return str(exc)


def resume_command(args, exr_dir: Path | None = None) -> str:
    """The command line that continues this run: the same arguments plus ``--resume``.

    ``exr_dir`` is the folder the frames went to; it is named when the run chose it itself
    (``-o rec.mp4`` on Dask writes ``rec_exr/``), because ``--resume`` needs ``--exr-dir``.
    """
    argv = list(getattr(args, "argv", None) or [args.command])
    if exr_dir is not None and getattr(args, "exr_dir", None) is None and getattr(args, "output", None) is not None:
        argv += ["--exr-dir", str(exr_dir)]
    if "--resume" not in argv:
        argv.append("--resume")
    return "spikeref " + shlex.join(argv)


@contextlib.contextmanager
def output_phase():
    """Around the part of a command that writes: an OS error there is a failed run (exit 1), not a refusal."""
    try:
        yield
    except OSError as exc:
        raise RunFailed(f"{os_error_text(exc)}; every file already written is whole") from exc
