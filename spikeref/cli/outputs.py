"""The checks of an output file or folder, made before anything is written, and the ``wrote PATH`` lines."""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

from spikeref.cli.errors import CliError

__all__ = ["check_folder_can_exist", "check_output_file", "check_video", "check_output_dir", "say_written"]


def check_folder_can_exist(folder: Path, flag: str, target: Path, *, new: bool = False) -> None:
    """Refuse unless ``folder`` is a writable folder — or, with ``new`` (a folder the run makes: ``--exr-dir``,
    ``--out``), unless its parent is.

    The rule for outputs: spikeref makes at most the one folder an option names, inside a folder that exists; it
    never makes missing parents (``-o /nonexistent/dir/out.mp4`` is a typo to be told of, not a tree to be made
    at the root of the file system).
    """
    p = Path(os.path.abspath(folder))
    if not p.exists():
        ancestor = p.parent
        while not ancestor.exists() and ancestor.parent != ancestor:
            ancestor = ancestor.parent
        if not ancestor.is_dir():
            raise CliError(f"{flag} {target}: cannot write there ({ancestor} is not a folder)")
        if not new or not p.parent.exists():
            missing = p if not new else p.parent
            raise CliError(f"{flag} {target}: the folder {missing} does not exist (make it first: spikeref makes no "
                           f"missing parent folders)")
        p = p.parent
    if not p.is_dir():
        raise CliError(f"{flag} {target}: cannot write there ({p} is not a folder)")
    if not os.access(p, os.W_OK | os.X_OK):
        raise CliError(f"{flag} {target}: cannot write there ({p} is not writable)")
    try:  # the permission bits do not tell everything (root, read-only mounts, /proc): make a file and remove it
        fd, probe = tempfile.mkstemp(dir=p, prefix=".spikeref-probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise CliError(f"{flag} {target}: cannot write there (cannot make a file in {p}: {exc.strerror or exc})") \
            from None


def check_output_file(path: Path | None, flag: str, suffixes: tuple[str, ...], kind: str) -> None:
    """An output file: the right suffix, not an existing folder, in a folder that can be made."""
    if path is None:
        return
    if path.suffix.lower() not in suffixes:
        raise CliError(f"{kind} must end in {' or '.join(suffixes)}; got {path.name!r}")
    if path.is_dir():
        raise CliError(f"{flag} {path}: is a folder, not a {kind}")
    check_folder_can_exist(path.parent, flag, path)


def check_video(path: Path | None, flag: str = "-o/--output") -> None:
    check_output_file(path, flag, (".mp4", ".gif"), "video output")


def check_output_dir(path: Path | None, flag: str) -> None:
    """An output folder: a folder, or absent inside an existing folder (it is made when the run starts)."""
    if path is None:
        return
    if path.exists() and not path.is_dir():
        raise CliError(f"{flag} {path}: cannot write there ({path} is not a folder)")
    check_folder_can_exist(path, flag, path, new=True)


def say_written(*paths) -> None:
    """``wrote PATH`` on stderr for each output written (``None``: not asked for), as every writing command says."""
    for path in paths:
        if path is not None:
            print(f"wrote {path}", file=sys.stderr)
