"""The kernels of TFI and TFSTP (:mod:`spikeref.baselines` reads like the methods; the speed is here).

TFI scans each pixel's spikes once for the intervals around the asked times; TFSTP runs the
Tsodyks–Markram synapse per pixel and reads its rate back through logarithms of ratios computed in
batches (mantissa and exponent split, a short series for the mantissa's logarithm) so the loop
vectorises.  Nothing here checks its arguments: :func:`spikeref.baselines.tfi` and
:func:`spikeref.baselines.tfstp` do; the oracles are :mod:`spikeref.oracles.baselines`.
"""

from __future__ import annotations

import numpy as np

from spikeref._jit import njit, prange

__all__ = ["tfi_kernel", "tfstp_kernel", "split_exponent", "log_ratio"]


@njit(parallel=True)
def tfi_kernel(spikes, plane0, times, max_interval, boundary, out):
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


#: Decay factors are kept at or above this: ``exp(−Δ/τ)`` below it changes no float64 sum with
#: the O(1) terms it multiplies, and the floor keeps the products out of the slow subnormals.
_DECAY_FLOOR = 1e-300
_LN2 = 0.6931471805599453
_SQRT2 = 1.4142135623730951
_SQRT_HALF = 0.7071067811865476
_SMALLEST_NORMAL = 2.2250738585072014e-308


@njit(error_model="numpy")
def split_exponent(values, exponent_bits, n):
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
def log_ratio(num, den, num_exponent, den_exponent, n):
    # num[:n] ← ln(num/den) for the values split by split_exponent (den is clobbered).  The ratio
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
def tfstp_kernel(spikes, plane0, times, u0, D, F, f, R, u, decay_D, decay_F, rate, out):
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
                split_exponent(num_u, exp_num_u, n)
                split_exponent(den_u, exp_den_u, n)
                split_exponent(num_r, exp_num_r, n)
                split_exponent(den_r, exp_den_r, n)
                log_ratio(num_u, den_u, exp_num_u, exp_den_u, n)
                log_ratio(num_r, den_r, exp_num_r, exp_den_r, n)
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
