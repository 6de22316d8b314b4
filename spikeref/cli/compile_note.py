"""The one line a command says before its first run sits silent while Numba compiles its kernels."""

from __future__ import annotations

import sys

__all__ = ["FIRST_RUN_COMPILE_S", "compiling_note"]


#: Seconds a command's first run spends compiling its Numba kernels, measured with an empty cache on two
#: cores (``scripts/first_run_compile.py``; ``docs/results.md``, "First run: what Numba compiles").
FIRST_RUN_COMPILE_S = {"reconstruct": 40, "denoise": 15, "baseline": 8, "noise-check": 6, "bench": 60}


def compiling_note(args, tag: str) -> None:
    """Say once, before a run sits silent while Numba compiles, that it does and for about how long.

    Nothing when the kernels of ``tag`` are already cached for this install (:func:`spikeref._jit.is_warm`); the
    command records that they are once it ends well (``main`` calls :func:`spikeref._jit.mark_warm`).
    """
    from spikeref import _jit

    if not _jit.numba_available or _jit.is_warm(tag):
        return
    seconds = FIRST_RUN_COMPILE_S[args.command]
    if _jit.caching_enabled:
        print(f"compiling kernels once, about {seconds} s on two cores (cached in {_jit.cache_dir} for later runs)",
              file=sys.stderr)
    else:
        print(f"compiling kernels, about {seconds} s on two cores (the kernel cache is off, so every run compiles: "
              f"SPIKEREF_NUMBA_CACHE=0 or no writable cache folder)", file=sys.stderr)
    args.compile_tag = tag
