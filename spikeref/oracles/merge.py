"""Literal oracle of the robust merge and its adaptive support (:mod:`spikeref.merge`), pixel by pixel.

Written from the module's docstring, one pixel, plane and window at a time in Python floats; the box means
average the pixels of the box that lie inside the image.  Slow: for the small inputs of the
golden case and the tests.
"""

from __future__ import annotations

import math

import numpy as np

from spikeref.oracles.case import OracleCase

__all__ = ["robust_merge_oracle", "GOLDEN_CASES"]


def _box(img, y, x, box):
    """Mean of ``img`` over the pixels of the ``box × box`` window around ``(y, x)`` that lie inside the image."""
    return _box_sum_count(img, y, x, box)[0] / _box_sum_count(img, y, x, box)[1]


def _box_sum_count(img, y, x, box):
    h, w = img.shape
    r = box // 2
    total, count = 0.0, 0
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            if 0 <= y + dy < h and 0 <= x + dx < w:
                total += img[y + dy, x + dx]
                count += 1
    return total, count


def _robustness(d, u, base, p, y, x):
    """``r_j`` at ``(y, x)`` of windows with differences ``d`` ``(n, C, h, w)`` and variances ``u``."""
    n, nc = d.shape[:2]
    m = _box_sum_count(d[0, 0], y, x, p.box)[1]  # the box's pixels inside the plane
    out = []
    for j in range(n):
        big_q = 0.0
        big_p = 0.0
        for c in range(nc):
            q = np.minimum(d[j, c] ** 2 / u[j, c], p.clip ** 2)
            big_q += _box_sum_count(q, y, x, p.box)[0]
            sd = np.sqrt(u[j, c])
            mean_d = _box(np.clip(d[j, c], -p.clip * sd, p.clip * sd), y, x, p.box)
            big_p += mean_d ** 2 / (u[j, c, y, x] / m)
        z = max((big_q - nc * m) / math.sqrt(2.0 * nc * m), (big_p - nc) / math.sqrt(2.0 * nc))
        r = min(max(2.0 - z / p.z, 0.0), 1.0)
        out.append(r if base[j, y, x] > 0 else 0.0)
    return np.array(out)


def robust_merge_oracle(samples, weights, noise, reference, core, params, final_weights=False):
    """:func:`spikeref.merge.robust_merge`, pixel by pixel (float64; returns the estimate unclipped to float32);
    with ``final_weights``, also each window's final weight."""
    s = np.asarray(samples, dtype=np.float64)
    base = np.asarray(weights, dtype=np.float64)
    v = np.asarray(noise, dtype=np.float64)
    n, nc, h, w = s.shape
    core = np.asarray(core, dtype=bool)
    idx = [j for j in range(n) if core[j]]
    ref = idx.index(reference)
    cb = base[idx].copy()
    cb[ref] = np.maximum(cb[ref], 1e-12)
    m = len(idx)
    p = params
    # the core rounds: every pixel needs its neighbours' differences (the box), so each round is made whole
    est = s[reference].copy()
    share = np.zeros((m, h, w))
    share[ref] = 1.0
    omega = share.copy()
    for _ in range(p.iterations):
        u = np.empty((m, nc, h, w))
        for j in range(m):
            for c in range(nc):
                v_est = v[c] * (share ** 2).sum(axis=0)
                u[j, c] = np.maximum(v[c] + v_est - 2.0 * share[j] * v[c], 1e-12)
        d = s[idx] - est[None]
        r = np.zeros((m, h, w))
        for y in range(h):
            for x in range(w):
                r[:, y, x] = _robustness(d, u, cb, p, y, x)
        r[ref] = 1.0
        omega = cb * r
        share = omega / omega.sum(axis=0)
        est = sum(share[j][None] * s[idx[j]] for j in range(m))
    weight_sum = omega.sum(axis=0)
    weight_sq = (omega * omega).sum(axis=0)
    unit = cb.sum(axis=0) / np.maximum((cb > 0).sum(axis=0), 1)
    c_core = np.maximum(1.0 - 2.0 * share + (share ** 2).sum(axis=0)[None], 1e-12)
    resid = np.zeros((nc, h, w))
    for j in range(m):
        for c in range(nc):
            resid[c] += omega[j] * np.minimum((s[idx[j], c] - est[c]) ** 2, p.clip ** 2 * v[c] * c_core[j])
    dof = (omega * c_core).sum(axis=0)
    v_hat = np.empty((nc, h, w))
    for c in range(nc):
        for y in range(h):
            for x in range(w):
                # the floor phi v, in full where the merge's rate p gives at most one spike a window (p W <= 1),
                # falling as 1 / (p W) above (window = W; 0: in full everywhere)
                spikes = est[c, y, x] * p.window
                floor = p.noise_floor * v[c, y, x] / (max(1.0, spikes) if p.window > 0 else 1.0)
                v_hat[c, y, x] = max(_box(resid[c], y, x, p.box) / max(_box(dof, y, x, p.box), 1e-12), floor)
    final = np.zeros((n, h, w))
    for j in range(m):
        final[idx[j]] = omega[j]
    vbar = v.mean(axis=0)
    alive = np.ones((h, w), bool)
    dist = np.abs(np.arange(n) - reference)
    for lo, hi in p.shells:
        sh = [j for j in range(n) if not core[j] and lo <= dist[j] <= hi]
        if not sh:
            continue
        d = s[sh] - est[None]
        u = np.empty(d.shape)
        u_hat = np.empty(d.shape)
        for c in range(nc):
            u[:, c] = np.maximum(v[c] + v[c] * weight_sq / np.maximum(weight_sum, 1e-12) ** 2, 1e-12)[None]
            u_hat[:, c] = (v_hat[c] + v_hat[c] * weight_sq / np.maximum(weight_sum, 1e-12) ** 2)[None]
        rs = np.zeros((len(sh), h, w))
        for y in range(h):
            for x in range(w):
                rs[:, y, x] = _robustness(d, u, base[sh], p, y, x)
        passing = rs > 0
        sq = np.minimum(d * d, p.clip ** 2 * u)
        excess_planes = ((sq - u_hat) * passing[:, None]).sum(axis=0)  # (C, h, w)
        count_map = passing.astype(np.float64).sum(axis=0)
        take = np.zeros((h, w), bool)
        for y in range(h):
            for x in range(w):
                excess = np.mean([_box(excess_planes[c], y, x, p.box) for c in range(nc)])
                count = _box(count_map, y, x, p.box)
                bias2 = max(excess / max(count, 1e-12), 0.0)
                add = rs[:, y, x] * unit[y, x]
                new_sum = weight_sum[y, x] + add.sum()
                new_sq = weight_sq[y, x] + (add * add).sum()
                share_new = add.sum() / max(new_sum, 1e-12)
                gain = vbar[y, x] * (weight_sq[y, x] / max(weight_sum[y, x], 1e-12) ** 2
                                     - new_sq / max(new_sum, 1e-12) ** 2)
                take[y, x] = alive[y, x] and passing[:, y, x].any() and p.safety * bias2 * share_new ** 2 < gain
        alive &= take
        for y in range(h):
            for x in range(w):
                if not take[y, x]:
                    continue
                add = rs[:, y, x] * unit[y, x]
                new_sum = weight_sum[y, x] + add.sum()
                final[sh, y, x] = add
                for c in range(nc):
                    est[c, y, x] = (est[c, y, x] * weight_sum[y, x] + sum(add[i] * s[sh[i], c, y, x]
                                                                           for i in range(len(sh)))) / new_sum
                weight_sq[y, x] += (add * add).sum()
                weight_sum[y, x] = new_sum
    windows = weight_sum * weight_sum / np.maximum(weight_sq, 1e-12)
    if final_weights:
        return np.clip(est, 0.0, 1.0), windows, final
    return np.clip(est, 0.0, 1.0), windows


def _inputs_merge():
    """Nine windows of four 9×10 Bayer planes: a smooth scene with noise; a block that two windows get wrong (an
    occluder: the core must drop it) and one far window wrong everywhere (a shell must be refused there);
    binomial-like core weights with one window leaving the plane at a corner."""
    rng = np.random.default_rng(48)
    n, nc, h, w = 9, 4, 9, 10
    scene = 0.3 + 0.2 * np.sin(np.arange(w)[None, :] / 3.0) * np.cos(np.arange(h)[:, None] / 4.0)
    samples = scene[None, None] + rng.normal(0.0, 0.03, size=(n, nc, h, w))
    samples[3, :, 2:6, 3:7] += 0.4  # a core window with an occluder in it
    samples[6, :, 5:9, 0:4] -= 0.25
    samples[0] += 0.2  # a far window that does not belong
    weights = np.zeros((n, h, w))
    weights[2:7] = np.array([1.0, 2.0, 3.0, 2.0, 1.0])[:, None, None]  # the core, Eq. 14–15-like
    weights[[0, 1, 7, 8]] = 1.0
    weights[2, :2, :2] = 0.0  # left the plane there
    noise = np.full((nc, h, w), 0.03 ** 2) * (1.0 + 0.5 * rng.random((nc, h, w)))
    core = np.zeros(n, bool)
    core[2:7] = True
    return {"samples": samples.astype(np.float32), "weights": weights.astype(np.float32),
            "noise": noise.astype(np.float32), "reference": np.int64(4), "core": core}


def _merge_outputs(i, merge, params_cls):
    out = {}
    for name, shells, window in (("robust", (), 0.0), ("adaptive", ((3, 3), (4, 4)), 0.0),
                                       ("adaptive_floor", ((3, 3), (4, 4)), 10.0)):
        params = params_cls(shells=shells, window=window)
        est, windows, final = merge(i["samples"], i["weights"], i["noise"], int(i["reference"]), i["core"], params,
                                    final_weights=True)
        out[f"estimate_{name}"] = np.asarray(est, np.float64)
        out[f"windows_{name}"] = np.asarray(windows, np.float64)
        if name == "adaptive_floor":  # the pipeline's: what the multi-frame demosaic weighs the windows by
            out[f"final_{name}"] = np.asarray(final, np.float64)
    return out


class _Params:
    """The defaults of :class:`spikeref.merge.MergeParams`, restated (an oracle module imports no fast code)."""

    def __init__(self, shells=(), window=0.0):
        self.box, self.z, self.clip, self.iterations, self.shells, self.safety = 5, 3.0, 3.0, 2, shells, 4.0
        self.noise_floor, self.window = 1.0, window


GOLDEN_CASES = (
    OracleCase(
        "robust_merge", "— (not in the paper; §4.2's pseudo-long exposure merged robustly, merge=\"robust\" / "
        "\"adaptive\")",
        "spikeref.merge.robust_merge", "spikeref.oracles.merge.robust_merge_oracle",
        "Nine aligned windows (four 9×10 Bayer planes of rates) of a smooth scene with noise, the core the middle "
        "five with Eq. 14–15-like weights 1, 2, 3, 2, 1 (window 2 outside the plane at a corner), an occluder in "
        "core window 3 and part of core window 6, far window 0 offset everywhere: the robust merge of the core "
        "(estimate_robust, windows_robust) and with the shells |j − k| = 3 and 4 offered (estimate_adaptive, "
        "windows_adaptive), and the same with the shells' noise floor falling above one spike a window of W = 10 "
        "readouts (estimate_adaptive_floor, windows_adaptive_floor; the pipeline's rule) with each window's final "
        "weight there (final_adaptive_floor, (9, 9, 10): what the multi-frame demosaic weighs the windows by). The "
        "oracle computes in float64 pixel by pixel, the fast function returns float32.",
        _inputs_merge, lambda i: _merge_outputs(i, robust_merge_oracle, _Params),
        rtol=1e-5, atol=1e-6,
        params={"box": 5, "z": 3.0, "clip": 3.0, "iterations": 2, "safety": 4.0,
                "shells_adaptive": "(3, 3), (4, 4)", "noise_floor": 1.0, "window_adaptive_floor": 10.0,
                "box_edges": "the mean of the box's pixels inside the plane"},
        spec="docs/spec/merge.md#robust_merge",
        outputs=_merge_outputs,
    ),
)
