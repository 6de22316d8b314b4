"""Numba configuration shared by every kernel module.

``cache=True`` is never hard-coded: on a read-only install Numba cannot write
its cache next to the source and the import would fail.  Instead, caching is
switched on at import time only when a writable cache location exists:

* ``NUMBA_CACHE_DIR`` when it is set and writable, else
* the package's own ``__pycache__`` when writable (editable installs, clones).

Set ``SPIKEREF_NUMBA_CACHE=0`` to turn caching off.  ``NUMBA_DISABLE_JIT=1``
is honoured by Numba itself: the kernels then run as plain Python (slowly),
which the tests use to check that oracle and kernel agree.

Numba is a runtime dependency.  Where it is not installed (a training machine that only
runs :mod:`spikeref.denoise.train`, say), the package still imports and the kernels run as
plain Python, exactly as under ``NUMBA_DISABLE_JIT=1``.
"""

from __future__ import annotations

import os
from pathlib import Path

try:
    import numba
except ImportError:  # pragma: no cover - exercised only on machines without Numba
    numba = None

__all__ = ["njit", "prange", "caching_enabled", "numba_available"]

numba_available: bool = numba is not None
prange = numba.prange if numba is not None else range


def _writable(directory: Path) -> bool:
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(directory, os.W_OK | os.X_OK)


def _decide_caching() -> bool:
    if numba is None or os.environ.get("SPIKEREF_NUMBA_CACHE", "1") == "0":
        return False
    if os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0"):
        return False
    env_dir = os.environ.get("NUMBA_CACHE_DIR")
    if env_dir:
        return _writable(Path(env_dir))
    return _writable(Path(__file__).resolve().parent / "__pycache__")


caching_enabled: bool = _decide_caching()


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
