"""Eq. 4: accumulate spikes over a temporal window into firing rates.

.. math:: I_c(x, t) = \\frac{M_c}{W} \\sum_{\\tau} S_c(x, \\tau)

``W`` is the window: the number of readouts (spike planes) summed, ``window`` in the code.  In an array shape
such as ``(T, H, W)`` the letters name the axes (readouts, height, width), as everywhere in the package.

Interpretation (``docs/spec/accumulate.md``; ``docs/equations.md``, "Interpretations"): the paper writes
``τ = t − W/2 … t + W/2``, which is ``W + 1`` readouts; here the window is exactly ``window`` readouts, and frame
``k`` of a stream covers readouts ``[start + k·window, start + (k+1)·window)`` — the paper's ``I(x, t)`` at the
window's centre ``t = start + (k + ½)·window``.  The rate ``count / window`` lies in ``[0, 1]`` (at most one
spike per readout).  ``M_c``, which the paper calls the channel's "maximum dynamic range", is a per-channel gain
here (1 unless calibrated; ``docs/equations.md``).

The sums are made by two kernels in :mod:`spikeref._accumulate_kernels`: one over unpacked ``(T, H, W) uint8``
arrays, and one with bit-sliced counters that reads the packed ``.dat`` bytes of a memory-mapped stream
directly, without unpacking a plane.  The oracle :func:`spikeref.oracles.accumulate.accumulate_oracle` is the
sum written out.
"""

from __future__ import annotations

import numpy as np

from spikeref._accumulate_kernels import count_windows, counts_to_rates
from spikeref.bayer import cfa_channel_map
from spikeref.stream import SpikeStream, as_stream

__all__ = ["window_counts", "accumulate", "accumulate_window", "channel_gain_map"]


def _check_window_args(stream: SpikeStream, window, start, count):
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)):
        raise TypeError(f"window must be an integer number of planes; got {window!r}")
    if window < 1:
        raise ValueError(f"window must be at least 1 plane; got {window}")
    if not isinstance(start, (int, np.integer)) or start < 0:
        raise ValueError(f"start must be a non-negative plane index; got {start!r}")
    if start >= len(stream):
        raise ValueError(f"start={start} is at or past the end of the stream ({len(stream)} planes)")
    available = (len(stream) - start) // window
    if count is None:
        count = available
        if count < 1:
            raise ValueError(
                f"window={window} is longer than the {len(stream) - start} planes available "
                f"from plane {start} (the stream has {len(stream)} planes)"
            )
    elif not isinstance(count, (int, np.integer)) or count < 1:
        raise ValueError(f"count must be a positive number of windows; got {count!r}")
    elif count > available:
        raise ValueError(
            f"{count} windows of {window} planes from plane {start} need {start + count * window} planes; "
            f"the stream has {len(stream)}"
        )
    return int(window), int(start), int(count)


def _check_out(out, shape, dtype, name="out"):
    if out is None:
        return np.empty(shape, dtype=dtype)
    if not isinstance(out, np.ndarray) or out.shape != shape or out.dtype != dtype or not out.flags.c_contiguous:
        got = f"{out.dtype} {out.shape}" if isinstance(out, np.ndarray) else type(out).__name__
        raise ValueError(f"{name} must be a C-contiguous {np.dtype(dtype)} array of shape {shape}; got {got}")
    return out


def window_counts(spikes, window: int, start: int = 0, count: int | None = None, out=None) -> np.ndarray:
    """Spike counts of consecutive windows: the sum in Eq. 4, before scaling.

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
        A packed (``.dat``) stream is counted from its bytes without unpacking.
    window : int
        Readouts per window (≥ 1), the paper's ``W``.
    start : int
        First readout of the first window.
    count : int, optional
        Number of windows; default all whole windows after ``start``.
    out : ndarray, optional
        Buffer to write into (shape ``(count, H, W)``, the dtype below), so a
        streaming caller can reuse memory.

    Returns
    -------
    ndarray ``(count, H, W)``, the smallest of ``uint8`` (``window ≤ 255``), ``uint16``, ``uint32`` that holds
    ``window``: ``out[k] = Σ_{τ ∈ [start + k·window, start + (k+1)·window)} S(x, τ)``.
    """
    stream = as_stream(spikes)
    window, start, count = _check_window_args(stream, window, start, count)
    dtype = np.uint8 if window <= 0xFF else (np.uint16 if window <= 0xFFFF else np.uint32)
    out = _check_out(out, (count, stream.height, stream.width), dtype)
    return count_windows(stream, window, start, count, out)


def channel_gain_map(height: int, width: int, gains, cfa: str | None) -> np.ndarray | float:
    """Per-pixel ``M_c`` of Eq. 4 from per-channel gains ``(M_R, M_G, M_B)``.

    A scalar gain is returned as a float (it applies to every pixel).
    """
    if gains is None:
        return 1.0
    g = np.asarray(gains, dtype=np.float64)
    if g.ndim == 0:
        if not np.isfinite(g) or g <= 0:
            raise ValueError(f"gains must be positive and finite; got {gains!r}")
        return float(g)
    if g.shape != (3,) or not np.all(np.isfinite(g)) or np.any(g <= 0):
        raise ValueError(f"gains must be a positive scalar or (M_R, M_G, M_B); got {gains!r}")
    if cfa is None:
        raise ValueError("per-channel gains need a Bayer pattern: pass cfa='RGGB' (or the stream's cfa)")
    return g[cfa_channel_map(height, width, cfa)].astype(np.float32)


def accumulate(
    spikes, window: int, start: int = 0, count: int | None = None, gains=None, cfa: str | None = None,
    out=None,
) -> np.ndarray:
    """Eq. 4 for a whole stream: one firing-rate frame per window.

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
    window : int
        Readouts per window, the paper's ``W``; frame ``k`` covers ``[start + k·window, start + (k+1)·window)``.
        At 20 kHz, ``window = 10`` is 0.5 ms and gives 2000 frames/s.
    start, count : int
        First plane and number of frames (default: every whole window).
    gains : None, float or (M_R, M_G, M_B)
        ``M_c``; ``None`` means 1 (the rate itself).
    cfa : str, optional
        Pattern for per-channel gains; defaults to the stream's.
    out : ndarray, optional
        ``(count, H, W) float32`` buffer to reuse.

    Returns
    -------
    ndarray ``(count, H, W) float32``: ``I_c = M_c · count / window`` (in ``[0, 1]`` when ``M_c = 1``).
    """
    stream = as_stream(spikes, cfa=cfa)
    counts = window_counts(stream, window, start, count)
    gain = channel_gain_map(stream.height, stream.width, gains, cfa or stream.cfa)
    gain_map = np.asarray(np.asarray(gain, dtype=np.float64) / window, dtype=np.float32).reshape(
        (1, 1) if np.ndim(gain) == 0 else (stream.height, stream.width)
    )
    out = _check_out(out, counts.shape, np.float32)
    counts_to_rates(counts, gain_map, out)
    return out


def accumulate_window(spikes, *, start: int, window: int, gains=None, cfa: str | None = None) -> np.ndarray:
    """Eq. 4 for one window ``[start, start + window)`` → ``(H, W) float32``.

    ``start`` and ``window`` are keyword-only: :func:`accumulate` takes ``(window, start)`` and
    :meth:`SpikeStream.window` ``(start, length)``, so a positional call would be easy to get backwards.
    """
    return accumulate(spikes, window, start=start, count=1, gains=gains, cfa=cfa)[0]


from spikeref._callable import make_module_callable  # noqa: E402

make_module_callable(__name__, "accumulate")  # `sr.accumulate(...)` works whichever import came first
