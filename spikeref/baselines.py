"""Classic spike-camera reconstructions used as baselines (paper §5.2, Table 1).

* **TFP** — texture from playback (Zhu et al. 2019): the firing rate over a
  window, i.e. Eq. 4 with ``M_c = 1``.
* **TFI** — texture from inter-spike intervals (Zhu et al. 2019): the inverse
  of the interval between the two spikes around time ``t``.
* **TFSTP** — texture from short-term plasticity (Zheng et al. 2023): a
  Tsodyks–Markram synapse per pixel, driven by its spikes; the firing rate is
  read back from the synapse's steady-state relations.

All three are defined for monochrome streams and return **linear rates in
spikes per readout** (``[0, 1]``), so they can be compared with each other
and with the method.  For a Bayer stream each pixel is processed on its own
(so per Bayer plane) and the result is demosaicked with Ψ
(:func:`bayer_baseline`), as the paper does in Table 1.

Compatibility with SpikeCV (``spkProc/reconstruction``), stated so results
can be compared with that library:

* SpikeCV's TFP frame at ``t`` with half window ``h`` is
  ``255 · tfp(spikes, 2h + 1, start=t - h, count=1)``.
* SpikeCV's TFI image is ``255 / interval`` cast to ``uint8``, where the
  interval at ``t`` is the one that ends at the first spike at or after ``t``,
  and 257 where no spike precedes it or none follows: ``255 · tfi`` here.
* SpikeCV's TFSTP image is the *sum* of the two rate estimates, min–max
  normalised and histogram-equalised for display; here it is their *mean*,
  kept linear.  SpikeCV's code writes ``F`` for ``f`` in the facilitation
  estimate; the paper's relation (with ``f``) is used here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from spikeref._jit import njit, prange
from spikeref.accumulate import accumulate
from spikeref.bayer import demosaic_bilinear
from spikeref.stream import SpikeStream, as_stream

__all__ = [
    "tfp",
    "tfi",
    "tfstp",
    "STPParams",
    "TFSTPState",
    "TFI_BOUNDARY_INTERVAL",
    "TFI_MAX_INTERVAL",
    "bayer_baseline",
    "streamed_baseline",
    "BASELINES",
]

BASELINES = ("tfp", "tfi", "tfstp")

#: Interval (readouts) SpikeCV uses where no spike precedes or follows ``t``.
TFI_BOUNDARY_INTERVAL = 257
#: Longest interval TFI resolves; longer ones count as unknown (rate 1/257).
#: SpikeCV's uint8 output is 0 for any interval ≥ 256, so this changes none of
#: its values, and it makes chunked processing exact with a 256-plane margin.
TFI_MAX_INTERVAL = 256


# ----------------------------------------------------------------------------- TFP
def tfp(spikes, window: int, start: int = 0, count: int | None = None) -> np.ndarray:
    """TFP: firing rate of each pixel over consecutive windows of ``window`` planes.

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
    window : int
        Planes per window; frame ``k`` covers ``[start + kW, start + (k+1)W)``.
    start, count : int
        First plane, number of frames (default: all whole windows).

    Returns
    -------
    ndarray ``(count, H, W) float32`` in ``[0, 1]`` (spikes per readout); Eq. 4 with ``M_c = 1``.
    """
    return accumulate(spikes, window, start=start, count=count)


# ----------------------------------------------------------------------------- TFI
def _times_array(times, n_planes: int, name: str = "times") -> np.ndarray:
    if times is None:
        return np.arange(n_planes, dtype=np.int64)
    t = np.asarray(times)
    if t.ndim != 1 or not np.issubdtype(t.dtype, np.integer):
        raise TypeError(f"{name} must be a 1-D sequence of integer plane indices")
    if t.size == 0:
        raise ValueError(f"{name} is empty")
    if np.any(np.diff(t) < 0):
        raise ValueError(f"{name} must be sorted in increasing order")
    if t[0] < 0 or t[-1] >= n_planes:
        raise ValueError(f"{name} must lie in [0, {n_planes}); got {t[0]}…{t[-1]}")
    return t.astype(np.int64)


@njit(parallel=True)
def _tfi(spikes, plane0, times, max_interval, boundary, out):
    # spikes (n, H, W) = planes [plane0, plane0 + n) of the stream; times: sorted absolute indices.
    # For t: n = first spike at or after t, p = last spike before n; rate = 1/(n - p), or
    # 1/boundary when p or n does not exist or n - p > max_interval.
    # Pass 1 (forward) records at each spike the interval it closes; pass 2 (backward) carries the
    # interval of the next spike back to every requested time.  Both walk rows of planes in order.
    n_planes, h, w = spikes.shape
    n_times = times.shape[0]
    for y in prange(h):
        closing = np.empty((n_planes, w), dtype=np.int32)
        last = np.full(w, -(max_interval + 1), dtype=np.int64)  # as if the last spike were too far back
        for i in range(n_planes):
            t = plane0 + i
            for x in range(w):  # branch-free so the loop vectorises
                d = t - last[x]
                closing[i, x] = d if d <= max_interval else boundary
                last[x] = t if spikes[i, y, x] else last[x]
        current = np.full(w, boundary, dtype=np.int32)  # interval closed by the next spike
        inv = np.empty(w, dtype=np.float32)
        k = n_times - 1
        for i in range(n_planes - 1, -1, -1):
            t = plane0 + i
            for x in range(w):
                current[x] = closing[i, x] if spikes[i, y, x] else current[x]
            if k >= 0 and times[k] == t:
                for x in range(w):
                    inv[x] = np.float32(1.0) / np.float32(current[x])
                while k >= 0 and times[k] == t:
                    for x in range(w):
                        out[k, y, x] = inv[x]
                    k -= 1


def tfi(spikes, times=None) -> np.ndarray:
    """TFI: ``1 / ISI`` at each requested plane (Zhu et al. 2019; SpikeCV's convention).

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
    times : sequence of int, optional
        Sorted plane indices to reconstruct (default: every plane).

    Returns
    -------
    ndarray ``(len(times), H, W) float32``: spikes per readout, ``1 / interval``
    where the interval (in readouts) is the one ending at the first spike at or
    after ``t``.  Where no spike precedes that spike, none follows ``t``, or the
    interval exceeds :data:`TFI_MAX_INTERVAL`, the interval is 257 (SpikeCV's
    boundary value), i.e. a rate of ``1/257``.  Never NaN or inf.

    Notes
    -----
    Only planes ``[min(times) − 256, max(times) + 257)`` are read, so a packed
    stream can be processed in chunks with identical results.
    """
    stream = as_stream(spikes)
    t = _times_array(times, len(stream))
    lo = max(0, int(t[0]) - TFI_MAX_INTERVAL)
    hi = min(len(stream), int(t[-1]) + TFI_MAX_INTERVAL + 1)
    planes = np.ascontiguousarray(stream.window(lo, hi - lo))
    out = np.empty((t.size, stream.height, stream.width), dtype=np.float32)
    _tfi(planes, lo, t, TFI_MAX_INTERVAL, TFI_BOUNDARY_INTERVAL, out)
    return out


# --------------------------------------------------------------------------- TFSTP
@dataclass(frozen=True)
class STPParams:
    """Tsodyks–Markram synapse parameters of TFSTP (SpikeCV's defaults).

    Attributes
    ----------
    u0 : float
        Resting release probability ``U`` (0 < u0 < 1).
    D : float
        Depression (recovery) time constant, in readouts.
    F : float
        Facilitation time constant, in readouts.
    f : float
        Facilitation increment per spike (0 < f < 1).
    """

    u0: float = 0.15
    D: float = 1.0
    F: float = 10.0
    f: float = 0.15

    def __post_init__(self):
        for name in ("u0", "f"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0 < v < 1):
                raise ValueError(f"{name} must lie in (0, 1); got {v!r}")
        for name in ("D", "F"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive time constant in readouts; got {v!r}")


class TFSTPState:
    """Per-pixel synapse state, float64, for chunked (causal) processing.

    ``R`` and ``u`` are the synapse variables; ``decay_D`` and ``decay_F`` hold
    ``exp(−Δ/D)`` and ``exp(−Δ/F)`` for ``Δ`` = (planes processed) − (index of the last
    spike + 1), i.e. the factors the next spike will use one plane later; ``rate`` caches the
    read-out (negative: stale).  Starts at ``R = 1``, ``u = u0``, no spike (SpikeCV's initial
    state).  TFSTP is causal, so a stream processed chunk by chunk with one state gives the
    same frames as one pass.
    """

    def __init__(self, height: int, width: int, params: STPParams = STPParams()):
        self.params = params
        self.R = np.ones((height, width), dtype=np.float64)
        self.u = np.full((height, width), params.u0, dtype=np.float64)
        self.decay_D = np.ones((height, width), dtype=np.float64)  # Δ = 0 before plane 0
        self.decay_F = np.ones((height, width), dtype=np.float64)
        self.rate = np.zeros((height, width), dtype=np.float64)  # cached read-out; < 0: stale
        self.next_plane = 0


#: Decay factors are kept at or above this: ``exp(−Δ/τ)`` below it changes no float64 sum with
#: the O(1) terms it multiplies, and the floor keeps the products out of the slow subnormals.
_DECAY_FLOOR = 1e-300
_LN2 = 0.6931471805599453
_SQRT2 = 1.4142135623730951
_SQRT_HALF = 0.7071067811865476
_SMALLEST_NORMAL = 2.2250738585072014e-308


@njit(error_model="numpy")
def _split_exponent(values, exponent_bits, n):
    # values[:n] (positive normal floats) → their mantissas in [1, 2), in place; exponent_bits[:n]
    # gets the bit pattern of the float 2^52 + (biased exponent), so that a difference of two such
    # floats is the exact difference of exponents.  Integer shifts and masks only: it vectorises
    # (int64 → float64 conversion does not, on AVX2).
    bits = values.view(np.uint64)
    for i in range(n):
        b = bits[i]
        exponent_bits[i] = (b >> np.uint64(52)) | np.uint64(0x4330000000000000)
        bits[i] = (b & np.uint64(0x000FFFFFFFFFFFFF)) | np.uint64(0x3FF0000000000000)


@njit(error_model="numpy")
def _log_ratio(num, den, num_exponent, den_exponent, n):
    # num[:n] ← ln(num/den) for the values split by _split_exponent (den is clobbered).  The ratio
    # of the two mantissas is folded into [√½, √2) by halving or doubling the numerator (exact),
    # then ln = Δe·ln 2 + 2 atanh(s) with s = (m − d)/(m + d), |s| < 0.172 — one division, no ratio
    # formed first — and the atanh series to s^11 (absolute error < 1e-10, far below the float32
    # output's rounding for the |ln| ≥ 0.1 the read-out meets).  Two short loops, not one long one:
    # the long one was bound by its dependency chain on this CPU.
    e_num = num_exponent.view(np.float64)
    e_den = den_exponent.view(np.float64)
    for i in range(n):
        m = num[i]
        d = den[i]
        high = m > _SQRT2 * d
        low = m < _SQRT_HALF * d
        m = m * 0.5 if high else m
        m = m * 2.0 if low else m
        e = e_num[i] - e_den[i] + (1.0 if high else 0.0) - (1.0 if low else 0.0)
        num[i] = (m - d) / (m + d)
        den[i] = e * _LN2
    for i in range(n):
        s = num[i]
        s2 = s * s
        num[i] = s * (2.0 + s2 * (2.0 / 3 + s2 * (2.0 / 5 + s2 * (2.0 / 7 + s2 * (2.0 / 9 + s2 * (2.0 / 11))))))
        num[i] += den[i]


@njit(parallel=True, error_model="numpy")
def _tfstp(spikes, plane0, times, u0, D, F, f, R, u, decay_D, decay_F, rate, out):
    # Per row, per plane: every pixel's synapse is updated branch-free and kept only where it
    # fired (a blend), so the loop vectorises; the decay factors since the last spike are carried
    # as running products (one multiply per plane) instead of exp(−Δ/τ) at each spike.  The
    # read-out (two logarithms) is cached in `rate` and redone at an output time only for the
    # pixels that fired since (rate < 0), compacted into contiguous buffers and computed there in
    # short vectorised loops.  error_model="numpy": no zero-division checks, which would stop the
    # vectorisation (no denominator here can be zero: undefined ratios get stand-ins 1/2).
    n_planes, h, w = spikes.shape
    n_times = times.shape[0]
    c_d = np.exp(-1.0 / D)
    c_f = np.exp(-1.0 / F)
    for y in prange(h):
        idx = np.empty(w, dtype=np.int64)
        num_u = np.empty(w, dtype=np.float64)
        den_u = np.empty(w, dtype=np.float64)
        num_r = np.empty(w, dtype=np.float64)
        den_r = np.empty(w, dtype=np.float64)
        ok_u = np.empty(w, dtype=np.float64)
        ok_r = np.empty(w, dtype=np.float64)
        exp_num_u = np.empty(w, dtype=np.uint64)
        exp_den_u = np.empty(w, dtype=np.uint64)
        exp_num_r = np.empty(w, dtype=np.uint64)
        exp_den_r = np.empty(w, dtype=np.uint64)
        Ry = R[y]
        uy = u[y]
        dDy = decay_D[y]
        dFy = decay_F[y]
        ratey = rate[y]
        stale_bits = ratey.view(np.uint64)
        k = 0
        for i in range(n_planes):
            t = plane0 + i
            row = spikes[i, y]
            for x in range(w):
                # fired = 1 or 0; keep·old + fired·new is exactly one of the two (no rounding)
                fired = np.float64(row[x])
                keep = 1.0 - fired
                ed = max(dDy[x] * c_d, _DECAY_FLOOR)
                ef = max(dFy[x] * c_f, _DECAY_FLOOR)
                r_old = Ry[x]
                u_old = uy[x]
                Ry[x] = keep * r_old + fired * (1.0 - (1.0 - r_old * (1.0 - u_old)) * ed)
                uy[x] = keep * u_old + fired * (u0 + (u_old + f * (1.0 - u_old) - u0) * ef)
                dDy[x] = keep * ed + fired
                dFy[x] = keep * ef + fired
                ratey[x] = keep * ratey[x] - fired
            if k < n_times and times[k] == t:
                n = 0
                for x in range(w):  # compact the stale pixels (rate < 0: its sign bit)
                    idx[n] = x
                    n += np.int64(stale_bits[x] >> np.uint64(63))
                for m in range(n):
                    x = idx[m]
                    uu = uy[x]
                    rr = Ry[x]
                    # the two ratios of the oracle, (u − u0)/(u + f(1 − u) − u0) and
                    # (1 − R)/(1 − R(1 − u)), defined where 0 < ratio < 1; stand-in 1/2 elsewhere.
                    # Numerators are differences of O(1) floats, so normal or 0 — except for a
                    # subnormal u0, where a subnormal `a` counts as 0 (its ratio is < 1e-292).
                    a = uu - u0
                    b = uu + f * (1.0 - uu) - u0
                    c = 1.0 - rr
                    d = 1.0 - rr * (1.0 - uu)
                    good_u = (a >= _SMALLEST_NORMAL) & (a < b)
                    good_r = (c >= _SMALLEST_NORMAL) & (c < d)
                    ok_u[m] = 1.0 if good_u else 0.0
                    ok_r[m] = 1.0 if good_r else 0.0
                    num_u[m] = a if good_u else 1.0
                    den_u[m] = b if good_u else 2.0
                    num_r[m] = c if good_r else 1.0
                    den_r[m] = d if good_r else 2.0
                _split_exponent(num_u, exp_num_u, n)
                _split_exponent(den_u, exp_den_u, n)
                _split_exponent(num_r, exp_num_r, n)
                _split_exponent(den_r, exp_den_r, n)
                _log_ratio(num_u, den_u, exp_num_u, exp_den_u, n)
                _log_ratio(num_r, den_r, exp_num_r, exp_den_r, n)
                for m in range(n):
                    # the two steady-state estimates of 1/Δ, −1/(F ln q_u) and −1/(D ln q_r) (each 0
                    # where undefined), averaged over one division, clipped to one spike per readout
                    lu = num_u[m]
                    lr = num_r[m]
                    den_u[m] = min(-0.5 * (ok_u[m] * D * lr + ok_r[m] * F * lu) / (F * D * lu * lr), 1.0)
                for m in range(n):
                    ratey[idx[m]] = den_u[m]
                while k < n_times and times[k] == t:
                    for x in range(w):
                        out[k, y, x] = ratey[x]
                    k += 1


def tfstp(spikes, times=None, params: STPParams = STPParams(), state: TFSTPState | None = None) -> np.ndarray:
    """TFSTP: firing rate read from a short-term-plasticity synapse per pixel (Zheng et al. 2023).

    At every spike (interval ``Δt`` readouts since the previous one, or since
    the start of the stream for the first) the synapse is updated with the
    *previous* ``u``::

        R ← 1 − (1 − R (1 − u)) · exp(−Δt / D)
        u ← u0 + (u + f (1 − u) − u0) · exp(−Δt / F)

    and at an output time the rate is the mean of the two estimates ``1/Δ``
    obtained by inverting these relations at their fixed point.

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
    times : sequence of int, optional
        Sorted plane indices to output, after that plane's update (default all).
    params : STPParams
        ``u0 = 0.15, D = 1, F = 10, f = 0.15`` (SpikeCV's defaults; time in readouts).
    state : TFSTPState, optional
        Continue from this state (for chunked processing); it is updated in
        place.  Without it the synapses start at rest at plane 0.

    Returns
    -------
    ndarray ``(len(times), H, W) float32`` in ``[0, 1]`` (spikes per readout);
    0 where a pixel has not fired yet.
    """
    stream = as_stream(spikes)
    if state is None:
        state = TFSTPState(stream.height, stream.width, params)
    params = state.params
    t = _times_array(times, len(stream))
    if t[0] < state.next_plane:
        raise ValueError(f"times must not go back before plane {state.next_plane} (TFSTP is causal)")
    lo, hi = state.next_plane, int(t[-1]) + 1
    out = np.empty((t.size, stream.height, stream.width), dtype=np.float32)
    planes = np.ascontiguousarray(stream.window(lo, hi - lo))
    _tfstp(planes, lo, t, params.u0, params.D, params.F, params.f, state.R, state.u, state.decay_D,
           state.decay_F, state.rate, out)
    state.next_plane = hi
    return out


# ------------------------------------------------------------------- colour, stream
def bayer_baseline(frames: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Demosaic baseline frames computed on a mosaic: ``(..., H, W)`` → ``(..., H, W, 3)`` (Ψ)."""
    return demosaic_bilinear(frames, cfa)


def streamed_baseline(stream: SpikeStream, method: str, every: int, finish: Callable = lambda f: f,
                      chunk_frames: int = 32) -> Iterator[tuple[int, np.ndarray]]:
    """Yield ``(index, frame)`` of TFI or TFSTP at planes ``0, every, 2·every, …``, chunk by chunk.

    Output frame ``k`` is the reconstruction at plane ``k · every``; ``finish``
    is applied to each chunk (e.g. Ψ for colour).  Memory is bounded by the
    chunk, whatever the stream's length; results equal one pass over the stream.
    """
    if method not in ("tfi", "tfstp"):
        raise ValueError(f"streamed_baseline runs 'tfi' or 'tfstp'; got {method!r}")
    stream = as_stream(stream)
    all_times = np.arange(0, len(stream), every, dtype=np.int64)
    state = TFSTPState(stream.height, stream.width) if method == "tfstp" else None
    for first in range(0, all_times.size, chunk_frames):
        times = all_times[first : first + chunk_frames]
        frames = tfi(stream, times) if method == "tfi" else tfstp(stream, times, state=state)
        frames = finish(frames)
        for i in range(times.size):
            yield first + i, frames[i]
