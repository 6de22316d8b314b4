"""Atomic file output: write to a temporary file beside the target, then rename.

Every writer in :mod:`spikeref.io` goes through here, so an interrupted or
failed write never leaves a partial file under the final name.  A failed write
(a full disk, a folder that is no longer writable, Ctrl-C) removes the temporary
file, and an OS error is raised as :class:`OSError` with its ``errno`` and the
*final* path as ``filename`` -- also when the writing library reports it as a
``RuntimeError`` with the system's message (OpenEXR does: "Failed to write pixel
data … No space left on device").
"""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path

__all__ = ["atomic_write", "publish", "temporary_beside"]

#: errors a writing library may report only as text (``os.strerror``), recognised in a ``RuntimeError``
_TEXT_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EACCES, errno.EPERM, errno.EIO,
                errno.ENOENT)


def temporary_beside(path) -> Path:
    """Create an empty temporary file in ``path``'s folder (which must exist)."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise FileNotFoundError(errno.ENOENT, "output folder does not exist", str(directory))
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


def _as_os_error(exc: BaseException, path: Path) -> OSError | None:
    """The :class:`OSError` that ``exc`` reports about writing ``path``, named by the final path; else ``None``."""
    if isinstance(exc, OSError):
        named = exc.filename is None or Path(exc.filename).name.startswith(f".{path.name}.")
        if exc.errno is None or not named:
            return None
        return OSError(exc.errno, exc.strerror or os.strerror(exc.errno), str(path))
    if isinstance(exc, RuntimeError):
        text = str(exc)
        for code in _TEXT_ERRNOS:
            if os.strerror(code) in text:
                return OSError(code, os.strerror(code), str(path))
    return None


def atomic_write(path, write_fn) -> Path:
    """Call ``write_fn(tmp_path)`` then rename ``tmp_path`` over ``path``.

    The temporary file lives in the target's folder (so the rename is atomic
    on POSIX) and is removed if ``write_fn`` raises: no partial file is left.

    Raises
    ------
    OSError
        The disk is full, the folder is not writable (or gone), ...: ``errno`` as the system
        gave it, ``filename`` the final ``path`` (not the temporary file's name), the original
        error as ``__cause__``.  A ``RuntimeError`` whose text is a system error message
        (``os.strerror``) becomes this ``OSError`` too; any other exception passes unchanged.
    """
    path = Path(path)
    tmp = None
    try:
        tmp = temporary_beside(path)
        write_fn(tmp)
        publish(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:  # gone with its folder, or the folder is no longer writable
                pass
        os_error = _as_os_error(exc, path) if isinstance(exc, Exception) else None
        if os_error is not None and (os_error.errno != getattr(exc, "errno", None) or
                                     os_error.filename != getattr(exc, "filename", None)):
            raise os_error from exc
        raise
    return path
