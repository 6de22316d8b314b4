"""A timing-aware Eq. 4: the charge a pixel integrated over a window, from its spike times.

Not in the paper.  Eq. 4 counts the spikes of a window, ``I = n / W``.  An integrate-and-fire
pixel (Eq. 1–2) of constant rate ``p`` fires almost periodically, so the count's error is mostly
the quantisation of the charge left over at the window's two edges: ``n`` is the integral of the
rate over ``[s, s + W)`` only up to ±1 spike (variance ``≈ 1 / (6 W²)`` in rate units).  Where the
pixel is in its inter-spike interval at each edge is visible in the spike times around it, so the
charge integrated over the window can be read more finely:

.. math::

    c = n + \\varphi(s + W) - \\varphi(s), \\qquad
    \\varphi(b) = \\frac{b - t_{\\mathrm{prev}} - \\tfrac12}{t_{\\mathrm{next}} - t_{\\mathrm{prev}}},

with ``n`` the spikes of readouts ``[s, s + W)`` (Eq. 4's count), ``t_prev < b ≤ t_next`` the last
spike before the boundary ``b`` and the first at or after it, and ``φ(b)`` the fraction of that
interval elapsed at ``b``: the cumulative charge is interpolated linearly between threshold
crossings, a crossing seen in readout ``t`` taken at ``t + ½`` (the middle of the readout).  The
rate is ``c / W`` — still the mean over exactly ``[s, s + W)``; the planes outside the window only
locate its edges.  For an ideal pixel the error falls from the count's ``√(1/6)/W`` to about
``p·√(1/6)/W`` (``scripts/study_window_timing.py``, ``docs/results.md``).

Interpretations (the choices where no paper says):

* **Margin** ``M`` (default :data:`DEFAULT_MARGIN` = 200 readouts, 10 ms at 20 kHz): ``t_prev`` is
  looked for in ``[b − M, b)`` and ``t_next`` in ``[b, b + M)``, clipped to the stream.  Where either
  is missing (a dark pixel, or the stream's ends), ``φ(b) = ½`` — the mean of a uniform phase, which
  is the count's own assumption: such a boundary adds no information and no bias.  However far the
  bracketing spikes are, ``φ`` stays in ``(0, 1)``: a stale interval (the pixel's rate changed) costs
  at most the count's own ±1.  ``M`` was chosen on the benchmark (tuning) scenes at ``W = 10``
  among ``W``, 100, 200 and 300 readouts (``docs/results.md``); a dim pixel's phase needs a long
  margin.
* Each boundary has one ``φ``, shared by the windows on either side, so the charges of adjacent
  windows add up to the charge of their union (what the pipeline's warps and sums rely on).
* ``c`` is clipped below at 0 (possible only where one edge fell back to ½).

The literal oracle is :func:`spikeref.oracles.charge.window_charge_oracle`.
"""

from __future__ import annotations

import numpy as np

from spikeref._jit import njit, prange
from spikeref.stream import as_stream

__all__ = ["window_charge", "charge_rates", "DEFAULT_MARGIN", "WINDOWS_PER_CALL", "ACCUMULATE"]

#: What a window can contribute, wherever a caller chooses (``accumulate=``): Eq. 4's count or this charge.
ACCUMULATE = ("count", "charge")

#: How far (readouts) from a window boundary its bracketing spikes are looked for (module docstring).
DEFAULT_MARGIN = 200
#: Windows a streaming caller asks for in one call: each call reads its windows' planes plus a margin on
#: either side, so asking one window at a time would read ``W + 2M`` planes per window.
WINDOWS_PER_CALL = 16


@njit(parallel=True)
def _window_charge(planes, lo, start, window, count, margin, out):
    # planes (T, H, W) uint8 holding readouts [lo, lo + T) of the stream; out (count, H, W) float32:
    # out[k] = n_k + φ(b_{k+1}) − φ(b_k), b_j = start + j·window.  Times are relative to lo (int32).
    # Per row, two branch-free sweeps over the readouts: forwards, the last spike before each
    # boundary (and the counts); backwards, the first spike at or after it.  A missing spike is a
    # sentinel that fails the margin test, so φ falls back to ½.
    n_t = planes.shape[0]
    h = planes.shape[1]
    w = planes.shape[2]
    b0 = start - lo
    far = np.int32(1 << 30)
    for y in prange(h):
        last = np.full(w, -far, dtype=np.int32)
        before = np.empty((count + 1, w), dtype=np.int32)
        after = np.full((count + 1, w), far, dtype=np.int32)
        n = np.zeros((count, w), dtype=np.int32)
        for t in range(n_t):
            r = t - b0
            if r >= 0 and r % window == 0 and r // window <= count:
                before[r // window, :] = last
            row = planes[t, y]
            if 0 <= r < count * window:
                nk = n[r // window]
                for x in range(w):
                    nk[x] += row[x]
            tt = np.int32(t)
            for x in range(w):
                last[x] = tt if row[x] else last[x]
        if b0 + count * window == n_t:  # the last boundary is the stream's end: no spike after it
            before[count, :] = last
        nxt = np.full(w, far, dtype=np.int32)
        for t in range(n_t - 1, -1, -1):
            row = planes[t, y]
            tt = np.int32(t)
            for x in range(w):
                nxt[x] = tt if row[x] else nxt[x]
            r = t - b0
            if r >= 0 and r % window == 0 and r // window <= count:
                after[r // window, :] = nxt
        phi = np.empty((count + 1, w), dtype=np.float64)
        for j in range(count + 1):
            b = b0 + j * window
            for x in range(w):
                s = before[j, x]
                e = after[j, x]
                if s >= b - margin and e < b + margin:
                    phi[j, x] = (b - s - 0.5) / (e - s)
                else:
                    phi[j, x] = 0.5
        for k in range(count):
            for x in range(w):
                c = n[k, x] + phi[k + 1, x] - phi[k, x]
                out[k, y, x] = c if c > 0.0 else 0.0


def _check_int(value, name: str, low: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ValueError(f"{name} must be {what}; got {value!r}")
    return int(value)


def window_charge(spikes, window: int, start: int = 0, count: int | None = None,
                  margin: int | None = None) -> np.ndarray:
    """The charge each pixel integrated over windows of ``window`` readouts, from its spike times.

    Parameters
    ----------
    spikes : SpikeStream or array_like ``(T, H, W)`` of 0/1
        The spike planes (a packed ``.dat`` stream is read only where needed).
    window : int
        ``W``, readouts per window (≥ 1).
    start : int
        First readout of window 0; window ``k`` is ``[start + kW, start + (k+1)W)`` (Eq. 4's grid).
    count : int, optional
        Number of windows (default: every whole window from ``start``).
    margin : int, optional
        ``M``, how far (readouts) from a boundary its bracketing spikes are looked for
        (module docstring); default :data:`DEFAULT_MARGIN`.  ``0`` gives Eq. 4's count exactly.

    Returns
    -------
    ndarray ``(count, H, W)`` float32
        ``c = n + φ(s + W) − φ(s)`` per window, in spikes (threshold crossings); ``c / W`` is the
        window's firing rate (:func:`charge_rates`).
    """
    stream = as_stream(spikes)
    window = _check_int(window, "window", 1, "a positive number of readouts")
    start = _check_int(start, "start", 0, "a readout index ≥ 0")
    available = (len(stream) - start) // window if start <= len(stream) else 0
    if count is None:
        count = max(available, 1)  # none available: refused below as not fitting
    count = _check_int(count, "count", 1, "a positive number of windows (or None for all)")
    if count > available:
        raise ValueError(f"{count} windows of {window} readouts from readout {start} do not fit in the stream's "
                         f"{len(stream)} readouts")
    margin = DEFAULT_MARGIN if margin is None else _check_int(margin, "margin", 0, "a number of readouts ≥ 0")
    lo = max(0, start - margin)
    hi = min(len(stream), start + count * window + margin)
    planes = np.ascontiguousarray(stream.window(lo, hi - lo), dtype=np.uint8)
    out = np.empty((count, stream.height, stream.width), np.float32)
    _window_charge(planes, lo, start, window, count, margin, out)
    return out


def charge_rates(spikes, window: int, start: int = 0, count: int | None = None,
                 margin: int | None = None) -> np.ndarray:
    """:func:`window_charge` ``/ window``: firing rates ``(count, H, W) float32`` in spikes per readout."""
    charge = window_charge(spikes, window, start, count, margin)
    charge /= np.float32(window)
    return charge
