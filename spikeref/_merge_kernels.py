"""The kernel of the robust merge (:mod:`spikeref.merge` states it; the speed is here).

One compiled pass per round instead of NumPy's temporaries: each window's test (its clipped squared
differences summed over the planes, its clipped differences per plane, their box sums) runs as one job per
window, the merge's sums as one job per row.  Box sums are separable prefix sums over the pixels inside the
plane.  Nothing here checks its arguments: :func:`spikeref.merge.robust_merge` does; the literal oracle is
:func:`spikeref.oracles.merge.robust_merge_oracle`.
"""

from __future__ import annotations

import numpy as np

from spikeref._jit import njit, prange

__all__ = ["robust_merge_kernel", "workspace_size"]


@njit
def _box_sum(a, rad, out, cum):
    """``out`` = the sum of ``a`` ``(h, w)`` over the pixels of the ``(2 rad + 1)²`` box that lie inside; ``cum``
    ``(h + 1, w + 1)`` scratch."""
    h, w = a.shape
    for x in range(w + 1):
        cum[0, x] = 0.0
    for y in range(h):  # cum[y + 1, x]: the column sums of the rows' box sums, rows 0 … y
        cum[y + 1, w] = 0.0
        run = 0.0
        for x in range(min(rad, w - 1) + 1):
            run += a[y, x]
        for x in range(w):
            cum[y + 1, x] = cum[y, x] + run
            if x + rad + 1 < w:
                run += a[y, x + rad + 1]
            if x - rad >= 0:
                run -= a[y, x - rad]
    for y in range(h):
        hi = min(y + rad, h - 1) + 1
        lo = max(y - rad, 0)
        for x in range(w):
            out[y, x] = cum[hi, x] - cum[lo, x]


@njit
def _inverse_and_limit(v, fac, iu, lim, ku, clip, want_ku):
    """``iu = 1 / u``, ``lim = κ √u`` and (``want_ku``) ``ku = κ² u`` ``(C, h, w)`` for the variance
    ``u = max(v · fac, 1e-12)``."""
    nc, h, w = v.shape
    for c in range(nc):
        for y in range(h):
            for x in range(w):
                u = max(v[c, y, x] * fac[y, x], 1e-12)
                iu[c, y, x] = 1.0 / u
                lim[c, y, x] = clip * np.sqrt(u)
                if want_ku:
                    ku[c, y, x] = clip * clip * u


@njit
def _robustness(sj, est, iu, lim, ku, valid, m, im, zq_scale, rad, z0, clip, r, sq, want_sq, scratch, cum):
    """``r`` ``(h, w)``: the robustness of window ``sj`` ``(C, h, w)`` against ``est``, their difference of
    variance ``1 / iu`` (``lim`` = κ times its deviation; module doc of :mod:`spikeref.merge`); 0 where ``valid``
    is 0.  ``m`` the box's pixel count, ``im = 1/m``, ``zq_scale = 1/√(2 C m)``; with ``want_sq`` also
    ``sq = Σ_c min(d², ku)`` (``ku = κ² u``).  ``scratch`` ``(4, h, w)`` and ``cum`` ``(h + 1, w + 1)`` its
    buffers."""
    nc, h, w = sj.shape
    k2 = clip * clip
    q = scratch[0]
    p = scratch[1]
    dc = scratch[2]
    box = scratch[3]
    for y in range(h):
        for x in range(w):
            q[y, x] = 0.0
            p[y, x] = 0.0
            if want_sq:
                sq[y, x] = 0.0
    for c in range(nc):
        for y in range(h):
            for x in range(w):
                d = sj[c, y, x] - est[c, y, x]
                q[y, x] += min(d * d * iu[c, y, x], k2)
                dc[y, x] = min(max(d, -lim[c, y, x]), lim[c, y, x])
                if want_sq:
                    sq[y, x] += min(d * d, ku[c, y, x])
        _box_sum(dc, rad, box, cum)
        for y in range(h):
            for x in range(w):
                p[y, x] += box[y, x] * box[y, x] * iu[c, y, x] * im[y, x]  # (mean d)² / (u / m)
    _box_sum(q, rad, box, cum)
    zp_scale = 1.0 / np.sqrt(2.0 * nc)
    iz0 = 1.0 / z0
    for y in range(h):
        for x in range(w):
            if valid[y, x] > 0:
                zq = (box[y, x] - nc * m[y, x]) * zq_scale[y, x]
                zp = (p[y, x] - nc) * zp_scale
                r[y, x] = min(max(2.0 - max(zq, zp) * iz0, 0.0), 1.0)
            else:
                r[y, x] = 0.0


def workspace_size(n_core: int, n_shell: int, nc: int, h: int, w: int) -> int:
    """Float64 values :func:`robust_merge_kernel` needs in ``work``: ``n_core`` core windows, at most ``n_shell``
    windows in one shell, ``nc`` planes of ``h × w``."""
    jobs = max(n_core, n_shell, 1)
    return h * w * (17 + 5 * n_core + 2 * n_core * nc + 5 * nc + 2 * max(n_shell, 1) + 4 * jobs) + \
        (h + 1) * (w + 1) * (1 + jobs)


@njit(parallel=True)
def robust_merge_kernel(s, base, v, reference, core, ref_pos, shell_start, shell_idx, box, z0, clip, iterations,
                        safety, noise_floor, window, work, est, windows, final):
    """:func:`spikeref.merge.robust_merge` (its module doc) on checked arrays.

    ``s`` ``(n, C, h, w)`` float32 or float64, ``base`` ``(n, h, w)`` and ``v`` ``(C, h, w)`` float64;
    ``core`` the core windows' indices (int64), ``ref_pos`` the reference's place among them; the shells'
    windows ``shell_idx[shell_start[i]:shell_start[i + 1]]``; ``work`` float64 of :func:`workspace_size`
    values, which every buffer is cut from.  Writes the unclipped estimate ``est`` ``(C, h, w)``, the effective
    number of windows ``windows`` ``(h, w)`` (float64) and each window's final weight ``final`` ``(n, h, w)``
    (float64; 0 for a window not merged there).  Nothing is allocated here or returned: an array made
    or returned by a parallel kernel makes Numba run Python code at every call, where a pending Ctrl-C would
    surface as a SystemError instead of a KeyboardInterrupt.
    """
    n, nc, h, w = s.shape
    nk = core.size
    hw = h * w
    shell_max = 1
    for si in range(shell_start.size - 1):
        shell_max = max(shell_max, shell_start[si + 1] - shell_start[si])
    flat = work[:17 * hw].reshape((17, h, w))  # one (h, w) buffer each
    m, im, zq_scale, sumsq, wsum, wsq, unit, dof = flat[0], flat[1], flat[2], flat[3], flat[4], flat[5], flat[6], \
        flat[7]
    alive, excess, count, ex_box, ct_box, shell_fac, dof_box, tmp = flat[8], flat[9], flat[10], flat[11], \
        flat[12], flat[13], flat[14], flat[15]
    uhat = flat[16]
    o = 17 * hw
    per_core = work[o:o + 5 * nk * hw].reshape((5, nk, h, w))
    cb, share, omega, r, fac = per_core[0], per_core[1], per_core[2], per_core[3], per_core[4]
    o += 5 * nk * hw
    per_core_plane = work[o:o + 2 * nk * nc * hw].reshape((2, nk, nc, h, w))
    core_iu, core_lim = per_core_plane[0], per_core_plane[1]
    o += 2 * nk * nc * hw
    per_plane = work[o:o + 5 * nc * hw].reshape((5, nc, h, w))
    resid, v_hat, s_iu, s_lim, s_ku = per_plane[0], per_plane[1], per_plane[2], per_plane[3], per_plane[4]
    o += 5 * nc * hw
    cum = work[o:o + (h + 1) * (w + 1)].reshape((h + 1, w + 1))
    o += (h + 1) * (w + 1)
    jobs = max(nk, shell_max)
    scratch = work[o:o + jobs * 4 * hw].reshape((jobs, 4, h, w))  # each parallel job's own buffers
    o += jobs * 4 * hw
    cums = work[o:o + jobs * (h + 1) * (w + 1)].reshape((jobs, h + 1, w + 1))
    o += jobs * (h + 1) * (w + 1)
    rs_all = work[o:]
    rad = box // 2
    k2 = clip * clip
    for y in prange(h):
        ny = min(y + rad, h - 1) - max(y - rad, 0) + 1
        for x in range(w):
            m[y, x] = ny * (min(x + rad, w - 1) - max(x - rad, 0) + 1)
            im[y, x] = 1.0 / m[y, x]
            zq_scale[y, x] = 1.0 / np.sqrt(2.0 * nc * m[y, x])
            dof[y, x] = 0.0
            alive[y, x] = 1.0
        for i in range(nk):
            for x in range(w):
                cb[i, y, x] = base[core[i], y, x]
                share[i, y, x] = 1.0 if i == ref_pos else 0.0
                omega[i, y, x] = 0.0
        for x in range(w):
            cb[ref_pos, y, x] = max(cb[ref_pos, y, x], 1e-12)  # the reference always counts
        for c in range(nc):
            for x in range(w):
                est[c, y, x] = s[reference, c, y, x]
                resid[c, y, x] = 0.0
    # the core: rounds of reweighting against the merge (rows in parallel, windows in the middle loop, so that
    # every inner loop runs along a row)
    for _ in range(iterations):
        for y in prange(h):
            for x in range(w):
                sumsq[y, x] = 0.0
            for i in range(nk):
                for x in range(w):
                    sumsq[y, x] += share[i, y, x] * share[i, y, x]
            for i in range(nk):
                for x in range(w):
                    fac[i, y, x] = 1.0 + sumsq[y, x] - 2.0 * share[i, y, x]
        for i in prange(nk):
            _inverse_and_limit(v, fac[i], core_iu[i], core_lim[i], s_ku, clip, False)
            _robustness(s[core[i]], est, core_iu[i], core_lim[i], s_ku, cb[i], m, im, zq_scale, rad, z0, clip, r[i],
                        r[i], False, scratch[i], cums[i])
        for y in prange(h):
            for x in range(w):
                r[ref_pos, y, x] = 1.0
                wsum[y, x] = 0.0
            for i in range(nk):
                for x in range(w):
                    omega[i, y, x] = cb[i, y, x] * r[i, y, x]
                    wsum[y, x] += omega[i, y, x]
            for i in range(nk):
                for x in range(w):
                    share[i, y, x] = omega[i, y, x] / wsum[y, x]
            for c in range(nc):
                for x in range(w):
                    est[c, y, x] = 0.0
                for i in range(nk):
                    for x in range(w):
                        est[c, y, x] += share[i, y, x] * s[core[i], c, y, x]
    # the core's weights, its scatter about its merge (v̂), and a shell window's unit weight
    for y in prange(h):
        for j in range(n):
            for x in range(w):
                final[j, y, x] = 0.0
        for i in range(nk):
            for x in range(w):
                final[core[i], y, x] = omega[i, y, x]
        for x in range(w):
            wsum[y, x] = 0.0
            wsq[y, x] = 0.0
            unit[y, x] = 0.0
            count[y, x] = 0.0  # core windows with a weight, for the unit
            sumsq[y, x] = 0.0
        for i in range(nk):
            for x in range(w):
                wsum[y, x] += omega[i, y, x]
                wsq[y, x] += omega[i, y, x] * omega[i, y, x]
                unit[y, x] += cb[i, y, x]
                if cb[i, y, x] > 0:
                    count[y, x] += 1.0
                sumsq[y, x] += share[i, y, x] * share[i, y, x]
        for x in range(w):
            unit[y, x] /= max(count[y, x], 1.0)
        for i in range(nk):
            for x in range(w):
                cc = max(1.0 - 2.0 * share[i, y, x] + sumsq[y, x], 1e-12)
                dof[y, x] += omega[i, y, x] * cc
                for c in range(nc):
                    d = s[core[i], c, y, x] - est[c, y, x]
                    resid[c, y, x] += omega[i, y, x] * min(d * d, k2 * v[c, y, x] * cc)
    n_shells = shell_start.size - 1
    if n_shells > 0:
        _box_sum(dof, rad, dof_box, cum)
        for c in range(nc):
            _box_sum(resid[c], rad, tmp, cum)
            for y in range(h):
                for x in range(w):
                    floor = noise_floor * v[c, y, x]
                    if window > 0.0:  # in full up to one spike a window, then as 1 / (p W)
                        floor /= max(1.0, est[c, y, x] * window)
                    v_hat[c, y, x] = max((tmp[y, x] / m[y, x]) / max(dof_box[y, x] / m[y, x], 1e-12), floor)
    for si in range(n_shells):
        sh = shell_idx[shell_start[si]:shell_start[si + 1]]
        ns = sh.size
        if ns == 0:
            continue
        for y in prange(h):
            for x in range(w):
                q = max(wsum[y, x], 1e-12)
                shell_fac[y, x] = 1.0 + wsq[y, x] / (q * q)  # u = v + v_e: a shell window is not part of e
        _inverse_and_limit(v, shell_fac, s_iu, s_lim, s_ku, clip, True)
        rs = rs_all[:ns * hw].reshape((ns, h, w))
        sqs = rs_all[ns * hw:2 * ns * hw].reshape((ns, h, w))
        for j in prange(ns):
            _robustness(s[sh[j]], est, s_iu, s_lim, s_ku, base[sh[j]], m, im, zq_scale, rad, z0, clip, rs[j], sqs[j],
                        True, scratch[j], cums[j])
        # the passing windows' excess over the core's scatter, their number and weights (sumsq: Σ add, tmp: Σ add²)
        for y in prange(h):
            for x in range(w):
                excess[y, x] = 0.0
                count[y, x] = 0.0
                sumsq[y, x] = 0.0
                tmp[y, x] = 0.0
            for x in range(w):  # Σ_c û_c, the core's scatter about a merge that the shell window is not part of
                q = max(wsum[y, x], 1e-12)
                rel = wsq[y, x] / (q * q)
                uh = 0.0
                for c in range(nc):
                    uh += v_hat[c, y, x] + v_hat[c, y, x] * rel
                uhat[y, x] = uh
            for j in range(ns):
                for x in range(w):
                    if rs[j, y, x] > 0:
                        count[y, x] += 1.0
                        a = rs[j, y, x] * unit[y, x]
                        sumsq[y, x] += a
                        tmp[y, x] += a * a
                        excess[y, x] += sqs[j, y, x] - uhat[y, x]
        _box_sum(excess, rad, ex_box, cum)
        _box_sum(count, rad, ct_box, cum)
        for y in prange(h):
            for x in range(w):
                bias2 = max((ex_box[y, x] / (m[y, x] * nc)) / max(ct_box[y, x] / m[y, x], 1e-12), 0.0)
                new_sum = wsum[y, x] + sumsq[y, x]
                new_sq = wsq[y, x] + tmp[y, x]
                share_new = sumsq[y, x] / max(new_sum, 1e-12)
                vbar = 0.0
                for c in range(nc):
                    vbar += v[c, y, x]
                vbar /= nc
                q = max(wsum[y, x], 1e-12)
                q2 = max(new_sum, 1e-12)
                gain = vbar * (wsq[y, x] / (q * q) - new_sq / (q2 * q2))
                take = alive[y, x] > 0 and count[y, x] > 0 and safety * bias2 * share_new * share_new < gain
                alive[y, x] = 1.0 if take else 0.0
                if take:
                    for c in range(nc):
                        est[c, y, x] *= wsum[y, x]
            for j in range(ns):
                for x in range(w):
                    if alive[y, x] > 0:
                        a = rs[j, y, x] * unit[y, x]
                        final[sh[j], y, x] = a
                        for c in range(nc):
                            est[c, y, x] += a * s[sh[j], c, y, x]
            for x in range(w):
                if alive[y, x] > 0:
                    new_sum = wsum[y, x] + sumsq[y, x]
                    for c in range(nc):
                        est[c, y, x] /= new_sum
                    wsq[y, x] += tmp[y, x]
                    wsum[y, x] = new_sum
    for y in prange(h):
        for x in range(w):
            windows[y, x] = wsum[y, x] * wsum[y, x] / max(wsq[y, x], 1e-12)
