"""Numba configuration shared by every kernel module.

Compiled kernels are cached in a per-user folder, never inside the package: an installed
package must stay as it was installed (a read-only ``site-packages`` would make Numba fail, and
cache files left in a writable one outlive an uninstall and shadow a later install).  The folder
is chosen when this module is first imported, before Numba is:

* ``NUMBA_CACHE_DIR`` when the user set it (caching is off if it cannot be created or written);
* else the user's cache folder (:func:`default_cache_dir`): ``$XDG_CACHE_HOME/spikeref/numba``,
  else ``~/.cache/spikeref/numba`` (``~/Library/Caches/spikeref/numba`` on macOS,
  ``%LOCALAPPDATA%\\spikeref\\numba`` on Windows), created on demand; if it cannot be created or
  written, caching is off (the kernels then compile in every process, nothing is written).

Numba reads ``NUMBA_CACHE_DIR`` when it configures itself (at import, and again before every
compilation), so the chosen folder is put into ``os.environ`` (child processes, Dask workers
among them, inherit it) and into ``numba.config`` (for a process that imported Numba before
spikeref).  Other Numba functions of the same process that ask for ``cache=True`` are then
cached in that folder too, each under its own sub-folder named after its source file.

``cache=True`` is never hard-coded: :func:`njit` passes :data:`caching_enabled`.  Set
``SPIKEREF_NUMBA_CACHE=0`` to turn caching off.  ``NUMBA_DISABLE_JIT=1`` is honoured by Numba
itself: the kernels then run as plain Python (slowly), which the tests use to check that oracle
and kernel agree.

Numba is a runtime dependency.  Where it is not installed (a training machine that only
runs :mod:`spikeref.denoise.train`, say), the package still imports and the kernels run as
plain Python, exactly as under ``NUMBA_DISABLE_JIT=1``.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import sys
from pathlib import Path

__all__ = ["njit", "prange", "caching_enabled", "cache_dir", "default_cache_dir", "numba_available", "is_warm",
           "mark_warm"]


def default_cache_dir() -> Path | None:
    """The per-user folder for spikeref's compiled kernels, or ``None`` when there is no home.

    ``$XDG_CACHE_HOME/spikeref/numba`` (an absolute ``XDG_CACHE_HOME`` only, as the XDG base
    directory specification says), else ``~/.cache/spikeref/numba``; on macOS
    ``~/Library/Caches/spikeref/numba`` and on Windows ``%LOCALAPPDATA%\\spikeref\\numba``.
    The folder is not created here.
    """
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "spikeref" / "numba"
    if sys.platform == "win32" and os.environ.get("LOCALAPPDATA"):
        return Path(os.environ["LOCALAPPDATA"]) / "spikeref" / "numba"
    try:
        home = Path.home()
    except (RuntimeError, KeyError, OSError):  # no HOME and no password-database entry
        return None
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / "spikeref" / "numba"
    return home / ".cache" / "spikeref" / "numba"


def _writable(directory: Path) -> bool:
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return directory.is_dir() and os.access(directory, os.W_OK | os.X_OK)


def _choose_cache_dir() -> Path | None:
    """Where compiled kernels go, or ``None`` for no caching (see the module doc)."""
    if importlib.util.find_spec("numba") is None or os.environ.get("SPIKEREF_NUMBA_CACHE", "1") == "0":
        return None
    if os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0"):
        return None
    user_dir = os.environ.get("NUMBA_CACHE_DIR")
    directory = Path(user_dir) if user_dir else default_cache_dir()
    if directory is None or not _writable(directory):
        return None
    return directory


#: The folder Numba caches spikeref's kernels in, or ``None`` when caching is off.
cache_dir: Path | None = _choose_cache_dir()
if cache_dir is not None and not os.environ.get("NUMBA_CACHE_DIR"):
    os.environ["NUMBA_CACHE_DIR"] = str(cache_dir)  # before Numba reads its configuration

try:
    import numba
except ImportError:  # pragma: no cover - exercised only on machines without Numba
    numba = None
    cache_dir = None

if cache_dir is not None and numba.config.CACHE_DIR != os.environ["NUMBA_CACHE_DIR"]:
    numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]  # Numba was imported before spikeref

numba_available: bool = numba is not None
#: Whether :func:`njit` asks Numba to cache (a writable :data:`cache_dir` exists).
caching_enabled: bool = cache_dir is not None
prange = numba.prange if numba is not None else range


def njit(*args, parallel: bool = False, **kwargs):
    """``numba.njit`` with ``cache`` decided at run time (see module doc).

    Used as ``@njit`` or ``@njit(parallel=True)``.
    """
    if numba is None:
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]
        return lambda function: function
    options = {"cache": caching_enabled, "nogil": True, "parallel": parallel}
    options.update(kwargs)
    if len(args) == 1 and callable(args[0]) and not kwargs:
        return numba.njit(**options)(args[0])
    return numba.njit(*args, **options)


def _warm_marker(tag: str) -> Path | None:
    """The file that says ``tag``'s kernels are in the cache for this package as it is on disk now.

    Its name hashes what Numba's own cache index checks (the source files' paths, sizes and modification
    times) and the Numba and Python versions: a reinstall elsewhere, an edit or an upgrade leaves it
    absent, as Numba's index would then be stale.  ``None`` when nothing is cached.
    """
    if cache_dir is None:
        return None
    return cache_dir / "warm" / f"{tag}-{_package_digest()}"


@functools.lru_cache(maxsize=1)
def _package_digest() -> str:
    """The package's source files (paths, sizes, modification times) and the Numba and Python versions, hashed:
    read once per process (a command asks before its run and again at its end)."""
    package = Path(__file__).resolve().parent
    digest = hashlib.sha1(f"{package}|{numba.__version__}|{sys.version_info[:2]}".encode())
    for path in sorted(package.rglob("*.py")):
        st = path.stat()
        digest.update(f"|{path.relative_to(package)}:{st.st_size}:{st.st_mtime_ns}".encode())
    return digest.hexdigest()[:20]


def is_warm(tag: str) -> bool:
    """Whether a run of ``tag`` (a command name) finished with this package's kernels cached (:func:`mark_warm`)."""
    marker = _warm_marker(tag)
    return marker is not None and marker.is_file()


def mark_warm(tag: str) -> None:
    """Record that ``tag`` ran to its end: its kernels are now in the cache (nothing when caching is off)."""
    marker = _warm_marker(tag)
    if marker is None:
        return
    try:
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.touch()
    except OSError:  # a cache folder that became read-only: the next run says it compiles again, no harm
        pass
