"""Atomic file output: write to a temporary file beside the target, then rename.

Every writer in :mod:`spikeref.io` goes through here, so an interrupted or
failed write never leaves a partial file under the final name.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["atomic_write", "publish", "temporary_beside"]


def temporary_beside(path) -> Path:
    """Create an empty temporary file in ``path``'s folder (which must exist)."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise FileNotFoundError(f"output folder does not exist: {directory}")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part" + path.suffix, dir=directory)
    os.close(fd)
    return Path(tmp)


def _default_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def publish(tmp, path) -> None:
    """Give a finished temporary file the usual permissions, flush it to disk and rename it to ``path``.

    The flush (``fsync``) before the rename means that after a power loss ``path`` holds either
    the old file or the whole new one, never an empty or partial file under the final name.
    """
    os.chmod(tmp, _default_mode())
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)


def atomic_write(path, write_fn) -> Path:
    """Call ``write_fn(tmp_path)`` then rename ``tmp_path`` over ``path``.

    The temporary file lives in the target's folder (so the rename is atomic
    on POSIX) and is removed if ``write_fn`` raises: no partial file is left.
    """
    path = Path(path)
    tmp = temporary_beside(path)
    try:
        write_fn(tmp)
        publish(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


