"""Eq. 14–15 with the step flows composed: each spike window resampled once (not in the paper).

The paper's progressive warping (Fig. 3(b)) resamples the data at every step: Eq. 14 warps the
spike windows onto ``I_1``, each Eq. 15 step warps the previous step's frames again.  ``I_L(k)``
is therefore the average, over every **path** ``π = (i_L, …, i_1)`` (``i ∈ {−h … h}``) of the
``K^L`` paths through the steps, of window ``k + Σ i`` resampled ``L`` times in a row —
bilinearly each time, which blurs the detail of natural images (the stage ladder in
``docs/results_history.md``: on the photographs it costs 1–2 dB against the true-flow ceiling, while
the flows themselves are nearly right).

This module computes the same average with the same flows, but **moves the sample positions
instead of the data**: along a path, the position starts at the pixel ``x``, is moved by the
step-``L−1`` flow of the reference frame, then by the step-``L−2`` flow of the frame reached,
sampled at the moved position (bilinear interpolation of the *flow*, which is smooth), and so
on down to step 0; the spike window reached is then sampled **once**, at the composed position,
with the Catmull–Rom cubic (Keys' kernel with ``a = −½``; it passes through the samples and
keeps detail that bilinear sampling would blur):

.. math::

    I_L(x, k) = \\frac{\\sum_\\pi v_\\pi(x)\\, S_{k+Σπ}(x_\\pi)}{W \\sum_\\pi v_\\pi(x)},
    \\qquad x_\\pi = x_{L} ,\\; x_0 = x,\\; x_{m+1} = x_m + F_{L-1-m}(x_m;\\, k_m, k_m + i_{L-m}),

where ``S_j`` is window ``j``'s spike count, ``k_m`` the frame reached after ``m`` hops and
``v_π(x) ∈ {0, 1}`` says whether ``x_π`` lies inside the plane (``−½ ≤ y ≤ h − ½``, the same for
``x``).  Every path weighs the same, so window ``j`` carries the weight of Eq. 14–15's
binomial count of paths that end in it.

Interpretations
---------------
* Flows are sampled bilinearly at a moved position, clamped to the grid beyond its border
  (the flow of the outermost pixel continues).
* The cubic taps beyond the border take the nearest edge pixel (clamped).  A position outside
  the plane is dropped (``v_π = 0``) and the average renormalised over the paths left, as
  :mod:`spikeref.warp` drops samples outside the image.
* A hop with ``i = 0`` does not move (the reference frame's zero flow).
* The cubic's negative lobes can overshoot at sharp edges: the result is clipped to ``[0, 1]``
  spikes per readout, the range of a rate.
* Paths are enumerated with :func:`path_table`; the literal oracle is
  :func:`spikeref.oracles.compose.composed_warp_oracle`.

One sample per window (``resample="window"``, the pipeline's default since 2026-11-24)
------------------------------------------------------------------------------------------
The paths that end in the same window estimate the same displacement along different routes; their
positions differ by the flows' errors.  Sampling the window at each of them and averaging blurs by
that spread; sampling it **once**, at the mean of those positions (the paths inside the plane only),
weighted by their number, keeps the binomial weights of Eq. 14–15 and costs one cubic per window
instead of one per path (7 against 27 at ``K = 3, L = 3``):

.. math::

    I_L(x, k) = \\frac{\\sum_j n_j(x)\\, S_j(\\bar x_j)}{W \\sum_j n_j(x)},
    \\qquad \\bar x_j = \\frac{1}{n_j(x)} \\sum_{π → j,\\ v_π(x) = 1} x_π,

``n_j(x)`` the number of paths ending in window ``j`` whose position lies inside the plane.  The
positions are summed in path order.  Measured (``docs/results_history.md``, "One sample per window"): the same
PSNR as one sample per path on the benchmark and held-out means (+0.02 and +0.00 dB), the warp 2.1× faster.
"""

from __future__ import annotations

import itertools

import numpy as np

from spikeref._jit import njit, prange

__all__ = ["path_table", "composed_warp", "composed_samples", "chained_samples", "catmull_rom_weights", "RESAMPLES"]


@njit(inline="always")
def _cr(t):
    """Catmull–Rom weights of the four taps at offsets −1, 0, 1, 2 for a fraction ``t ∈ [0, 1)``."""
    t2 = t * t
    t3 = t2 * t
    return (-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2)


def catmull_rom_weights(t: float) -> tuple:
    """The four Catmull–Rom weights (offsets −1, 0, 1, 2) at fraction ``t``; they sum to 1."""
    return tuple(float(v) for v in _cr(float(t)))


@njit(inline="always")
def _clamp(i, n):
    return 0 if i < 0 else (n - 1 if i >= n else i)


@njit(inline="always")
def _flow_at(bank, f, y, x, h, w):
    """Bilinear sample of flow ``f`` of ``bank`` at ``(y, x)``, clamped to the grid: ``(dy, dx)``."""
    yc = min(max(y, 0.0), h - 1.0)
    xc = min(max(x, 0.0), w - 1.0)
    y0 = int(np.floor(yc))
    x0 = int(np.floor(xc))
    y1 = min(y0 + 1, h - 1)
    x1 = min(x0 + 1, w - 1)
    fy = yc - y0
    fx = xc - x0
    dy = ((1 - fy) * ((1 - fx) * bank[f, 0, y0, x0] + fx * bank[f, 0, y0, x1])
          + fy * ((1 - fx) * bank[f, 0, y1, x0] + fx * bank[f, 0, y1, x1]))
    dx = ((1 - fy) * ((1 - fx) * bank[f, 1, y0, x0] + fx * bank[f, 1, y0, x1])
          + fy * ((1 - fx) * bank[f, 1, y1, x0] + fx * bank[f, 1, y1, x1]))
    return dy, dx


@njit(inline="always")
def _cubic_at(counts, t, sy, sx, h, w, weight, acc):
    """``acc[c] += weight · S_t(sy, sx)`` for every plane ``c``: Catmull–Rom, taps clamped to the grid."""
    y0 = int(np.floor(sy))
    x0 = int(np.floor(sx))
    wy = _cr(sy - y0)
    wx = _cr(sx - x0)
    xa = _clamp(x0 - 1, w)
    xb = _clamp(x0, w)
    xc = _clamp(x0 + 1, w)
    xd = _clamp(x0 + 2, w)
    for c in range(acc.shape[0]):
        s = 0.0
        for a in range(4):
            plane_row = counts[t, c, _clamp(y0 - 1 + a, h)]
            row = wx[0] * plane_row[xa] + wx[1] * plane_row[xb] + wx[2] * plane_row[xc] + wx[3] * plane_row[xd]
            s += wy[a] * row
        acc[c] += weight * s


@njit(inline="always")
def _path_positions(bank, hop_flow, hop_parent, hop_start, y, x, h, w, py, px):
    """Every node's position ``(py[q], px[q])`` of the hop tree for pixel ``(y, x)``: node ``q`` moves its parent's
    position (the pixel's for the first hop) by flow ``hop_flow[q]`` (``−1``: no move), hop by hop."""
    for m in range(hop_start.shape[0] - 1):
        for q in range(hop_start[m], hop_start[m + 1]):
            parent = hop_parent[q]
            sy = np.float64(y) if parent < 0 else py[parent]
            sx = np.float64(x) if parent < 0 else px[parent]
            f = hop_flow[q]
            if f >= 0:
                dy, dx = _flow_at(bank, f, sy, sx, h, w)
                sy += dy
                sx += dx
            py[q] = sy
            px[q] = sx


@njit(inline="always")
def _window_ends(leaf, targets, py, px, y, x, h, w, my, mx, kept):
    """Per window ``t``: the sum ``(my[t], mx[t])`` of the ends of its paths that lie inside the plane and their
    number ``kept[t]``, summed in path order (a path of no hops ends at the pixel)."""
    my[:] = 0.0
    mx[:] = 0.0
    kept[:] = 0.0
    for p in range(leaf.shape[0]):
        q = leaf[p]
        if q >= 0:
            sy = py[q]
            sx = px[q]
        else:
            sy = np.float64(y)
            sx = np.float64(x)
        if sy < -0.5 or sy > h - 0.5 or sx < -0.5 or sx > w - 0.5:
            continue
        t = targets[p]
        my[t] += sy
        mx[t] += sx
        kept[t] += 1.0


@njit(parallel=True)
def _composed_warp(counts, bank, hop_flow, hop_parent, hop_start, leaf, targets, inv_window, per_window, out):
    """counts (n, C, h, w), bank (nf, 2, h, w) → out (C, h, w).

    The paths' hops as a tree (:func:`_hop_tree`): node ``q`` of hop ``m`` (``hop_start[m] ≤ q <
    hop_start[m + 1]``) moves the position of its parent node (``hop_parent[q]``; ``−1``: the pixel)
    by flow ``hop_flow[q]`` (``−1``: no move); path ``p`` ends at node ``leaf[p]`` and samples window
    ``targets[p]``.  Paths that share their first hops share those positions; each path's position
    is the same sum, in the same order, as hop by hop along the path alone.  ``per_window``: each
    window is sampled once, at the mean position of its paths inside the plane, weighted by their number.
    """
    n, nc, h, w = counts.shape
    npath = leaf.shape[0]
    nnode = hop_flow.shape[0]
    for y in prange(h):
        acc = np.zeros(nc)
        py = np.empty(nnode)
        px = np.empty(nnode)
        my = np.empty(n)
        mx = np.empty(n)
        kept = np.empty(n)
        for x in range(w):
            _path_positions(bank, hop_flow, hop_parent, hop_start, y, x, h, w, py, px)
            acc[:] = 0.0
            wsum = 0.0
            if per_window:  # each window sampled once, at the mean end of its paths
                _window_ends(leaf, targets, py, px, y, x, h, w, my, mx, kept)
                for t in range(n):
                    if kept[t] > 0:
                        _cubic_at(counts, t, my[t] / kept[t], mx[t] / kept[t], h, w, kept[t], acc)
                        wsum += kept[t]
            else:
                for p in range(npath):
                    q = leaf[p]
                    if q >= 0:
                        sy = py[q]
                        sx = px[q]
                    else:  # a path of no hops
                        sy = np.float64(y)
                        sx = np.float64(x)
                    if sy < -0.5 or sy > h - 0.5 or sx < -0.5 or sx > w - 0.5:
                        continue
                    _cubic_at(counts, targets[p], sy, sx, h, w, 1.0, acc)
                    wsum += 1.0
            for c in range(nc):
                v = acc[c] * inv_window / wsum if wsum > 0 else 0.0
                out[c, y, x] = min(max(v, 0.0), 1.0)  # the cubic may overshoot; a rate lies in [0, 1]


@njit(parallel=True)
def _composed_samples(counts, bank, hop_flow, hop_parent, hop_start, leaf, targets, inv_window, out, kept_out,
                      pos_out):
    """As :func:`_composed_warp` with ``per_window``, but each window's sample kept apart: ``out`` ``(n, C, h, w)``
    (rates, not clipped), ``kept_out`` ``(n, h, w)`` (the paths inside the plane that end in it) and ``pos_out``
    ``(n, 2, h, w)`` (their mean end; NaN where none)."""
    n, nc, h, w = counts.shape
    nnode = hop_flow.shape[0]
    for y in prange(h):
        acc = np.zeros(nc)
        py = np.empty(nnode)
        px = np.empty(nnode)
        my = np.empty(n)
        mx = np.empty(n)
        kept = np.empty(n)
        for x in range(w):
            _path_positions(bank, hop_flow, hop_parent, hop_start, y, x, h, w, py, px)
            _window_ends(leaf, targets, py, px, y, x, h, w, my, mx, kept)
            for t in range(n):
                kept_out[t, y, x] = kept[t]
                if kept[t] > 0:
                    sy = my[t] / kept[t]
                    sx = mx[t] / kept[t]
                    pos_out[t, 0, y, x] = sy
                    pos_out[t, 1, y, x] = sx
                    acc[:] = 0.0
                    _cubic_at(counts, t, sy, sx, h, w, 1.0, acc)
                    for c in range(nc):
                        out[t, c, y, x] = acc[c] * inv_window
                else:
                    pos_out[t, 0, y, x] = np.nan
                    pos_out[t, 1, y, x] = np.nan
                    for c in range(nc):
                        out[t, c, y, x] = 0.0


@njit(parallel=True)
def _chained_samples(counts, start, flows, inv_window, out, valid, positions):
    """Continue positions ``start`` ``(2, h, w)`` (NaN: none) hop by hop along ``flows[i]`` (from the window before
    ``counts[i]`` to it) and sample each window there: ``out`` ``(m, C, h, w)`` rates, ``valid`` ``(m, h, w)``,
    ``positions`` ``(m, 2, h, w)`` (NaN where not valid)."""
    m, nc, h, w = counts.shape
    for y in prange(h):
        acc = np.zeros(nc)
        for x in range(w):
            sy = start[0, y, x]
            sx = start[1, y, x]
            ok = not (np.isnan(sy) or np.isnan(sx))
            for i in range(m):
                if ok:
                    dy, dx = _flow_at(flows, i, sy, sx, h, w)
                    sy += dy
                    sx += dx
                    ok = not (sy < -0.5 or sy > h - 0.5 or sx < -0.5 or sx > w - 0.5)
                if ok:
                    acc[:] = 0.0
                    _cubic_at(counts, i, sy, sx, h, w, 1.0, acc)
                    for c in range(nc):
                        out[i, c, y, x] = acc[c] * inv_window
                    valid[i, y, x] = 1.0
                    positions[i, 0, y, x] = sy
                    positions[i, 1, y, x] = sx
                else:
                    for c in range(nc):
                        out[i, c, y, x] = 0.0
                    valid[i, y, x] = 0.0
                    positions[i, 0, y, x] = np.nan
                    positions[i, 1, y, x] = np.nan


def _hop_tree(hops: np.ndarray):
    """The paths' hop sequences as a tree: paths with the same first ``m + 1`` hops share node ``q`` of hop ``m``.

    Returns ``(hop_flow, hop_parent, hop_start, leaf)`` for :func:`_composed_warp`.
    """
    npath, nhop = hops.shape
    flow, parent, start = [], [], [0]
    node_of = {}  # (hop, prefix) → node
    leaf = np.full(npath, -1, np.int64)
    for m in range(nhop):
        for p in range(npath):
            key = tuple(int(v) for v in hops[p, : m + 1])
            if key not in node_of:
                node_of[key] = len(flow)
                flow.append(key[-1])
                parent.append(node_of[key[:-1]] if m else -1)
        start.append(len(flow))
    if nhop:
        for p in range(npath):
            leaf[p] = node_of[tuple(int(v) for v in hops[p])]
    return (np.asarray(flow, np.int64), np.asarray(parent, np.int64), np.asarray(start, np.int64), leaf)


def path_table(K: int, L: int) -> list[tuple]:
    """The ``K^L`` paths ``(i_L, …, i_1)`` of Eq. 14–15, first hop first, ``i ∈ {−h … h}``."""
    h = (K - 1) // 2
    return list(itertools.product(range(-h, h + 1), repeat=L))


#: How :func:`composed_warp` samples the windows: once per path (``"path"``), or once per window at the mean
#: position of its paths (``"window"``; module docstring).
RESAMPLES = ("path", "window")


def composed_warp(counts, bank, hops, targets, window: float, resample: str = "path") -> np.ndarray:
    """``I_L`` of one frame from its spike windows and the composed step flows (module docstring).

    Parameters
    ----------
    counts : ndarray ``(n, C, h, w)``
        Spike counts of the ``n`` windows the paths end in (``C`` Bayer planes).
    bank : ndarray ``(nf, 2, h, w)`` float
        The step flows the paths use, ``(dy, dx)`` in plane pixels (:mod:`spikeref.align`'s
        convention).
    hops : ndarray ``(P, L)`` int
        For each path, the bank index of the flow of each hop in order (first hop = the output
        step's flow of the reference frame); ``−1`` for a hop that does not move.
    targets : ndarray ``(P,)`` int
        For each path, the index into ``counts`` of the window it ends in.
    window : float
        ``W``: the counts are divided by it (rates in spikes per readout).
    resample : {"path", "window"}
        ``"path"`` (default here, the formula above): every path samples its window at its own
        position.  ``"window"`` (the pipeline's default, :class:`~spikeref.pipeline.ReconstructParams`):
        every window is sampled once, at the mean of the positions of its paths inside the plane,
        weighted by their number (module docstring).

    Returns
    -------
    ndarray ``(C, h, w) float32``
    """
    c = np.asarray(counts)
    if c.ndim != 4:
        raise ValueError(f"counts must have shape (n, C, h, w); got {c.shape}")
    b = np.asarray(bank)
    if b.ndim != 4 or b.shape[1] != 2 or b.shape[2:] != c.shape[2:]:
        raise ValueError(f"bank must have shape (nf, 2, {c.shape[2]}, {c.shape[3]}); got {b.shape}")
    hp = np.asarray(hops)
    tg = np.asarray(targets)
    if hp.ndim != 2 or not np.issubdtype(hp.dtype, np.integer):
        raise ValueError(f"hops must be a (P, L) integer array; got {hp.shape} {hp.dtype}")
    if tg.shape != (hp.shape[0],) or not np.issubdtype(tg.dtype, np.integer):
        raise ValueError(f"targets must be a ({hp.shape[0]},) integer array; got {tg.shape} {tg.dtype}")
    if hp.size and (hp.min() < -1 or hp.max() >= b.shape[0]):
        raise ValueError(f"hops must index the bank (−1 … {b.shape[0] - 1})")
    if tg.size and (tg.min() < 0 or tg.max() >= c.shape[0]):
        raise ValueError(f"targets must index the counts (0 … {c.shape[0] - 1})")
    if isinstance(window, bool) or not np.isfinite(window) or window <= 0:
        raise ValueError(f"window must be a positive number of planes; got {window!r}")
    if resample not in RESAMPLES:
        raise ValueError(f"resample must be one of {', '.join(RESAMPLES)}; got {resample!r}")
    out = np.zeros(c.shape[1:], np.float32)
    hop_flow, hop_parent, hop_start, leaf = _hop_tree(hp)
    _composed_warp(np.ascontiguousarray(c, dtype=np.float32), np.ascontiguousarray(b, dtype=np.float32),
                   hop_flow, hop_parent, hop_start, leaf, np.ascontiguousarray(tg, dtype=np.int64),
                   1.0 / float(window), resample == "window", out)
    return out


def _check_counts_bank(c, b):
    if c.ndim != 4:
        raise ValueError(f"counts must have shape (n, C, h, w); got {c.shape}")
    if b.ndim != 4 or b.shape[1] != 2 or b.shape[2:] != c.shape[2:]:
        raise ValueError(f"flows must have shape (nf, 2, {c.shape[2]}, {c.shape[3]}); got {b.shape}")


def composed_samples(counts, bank, hops, targets, window: float, identity: int | None = None) -> tuple:
    """Each window of the support sampled once, at the mean end of its paths, kept apart (robust merge's input).

    The same positions and Catmull–Rom samples as :func:`composed_warp` with ``resample="window"``, whose frame
    is ``clip(Σ_j kept_j · samples_j / Σ_j kept_j, 0, 1)``; here the windows are not summed, so that
    :mod:`spikeref.merge` can weigh each by how well it agrees with the reference.

    Parameters
    ----------
    counts, bank, hops, targets, window
        As :func:`composed_warp`.
    identity : int, optional
        A window (index into ``counts``) sampled at its own pixels instead: ``counts[identity] / W`` at positions
        ``(y, x)``, its ``kept`` unchanged.  The pipeline passes the reference ``k``: paths that leave it and come
        back (``+1`` then ``−1``) compose two estimated flows whose errors do not cancel where the scene moves,
        so the mean end of its paths is not its own pixel there and the reference would be a displaced, resampled
        copy of itself — the very sample the robust merge tests every other window against (not in the paper;
        on the embedded sample 27.98 → 28.32 dB, ``docs/results.md``).

    Returns
    -------
    samples : ndarray ``(n, C, h, w) float32``
        Window ``j``'s rate (count / W) at its mean composed position; 0 where no path of it stays inside.
    kept : ndarray ``(n, h, w) float32``
        How many paths end in window ``j`` inside the plane (Eq. 14–15's binomial weight where all do).
    positions : ndarray ``(n, 2, h, w) float32``
        The mean position ``(y, x)`` in plane pixels; NaN where ``kept`` is 0.
    """
    c = np.asarray(counts)
    b = np.asarray(bank)
    _check_counts_bank(c, b)
    hp = np.asarray(hops)
    tg = np.asarray(targets)
    if hp.ndim != 2 or not np.issubdtype(hp.dtype, np.integer) or tg.shape != (hp.shape[0],):
        raise ValueError(f"hops must be (P, L) integers and targets (P,); got {hp.shape} and {tg.shape}")
    if hp.size and (hp.min() < -1 or hp.max() >= b.shape[0]) or tg.size and (tg.min() < 0 or tg.max() >= c.shape[0]):
        raise ValueError("hops must index the flows (−1 … nf − 1) and targets the counts (0 … n − 1)")
    if isinstance(window, bool) or not np.isfinite(window) or window <= 0:
        raise ValueError(f"window must be a positive number of planes; got {window!r}")
    n, nc, h, w = c.shape
    if identity is not None and (isinstance(identity, bool) or not isinstance(identity, (int, np.integer))
                                 or not 0 <= identity < n):
        raise ValueError(f"identity must index the windows (0 … {n - 1}); got {identity!r}")
    out = np.zeros((n, nc, h, w), np.float32)
    kept = np.zeros((n, h, w), np.float32)
    pos = np.zeros((n, 2, h, w), np.float32)
    hop_flow, hop_parent, hop_start, leaf = _hop_tree(hp)
    _composed_samples(np.ascontiguousarray(c, dtype=np.float32), np.ascontiguousarray(b, dtype=np.float32),
                      hop_flow, hop_parent, hop_start, leaf, np.ascontiguousarray(tg, dtype=np.int64),
                      1.0 / float(window), out, kept, pos)
    if identity is not None:
        out[identity] = (c[identity].astype(np.float64) * (1.0 / float(window))).astype(np.float32)
        pos[identity, 0] = np.arange(h, dtype=np.float32)[:, None]
        pos[identity, 1] = np.arange(w, dtype=np.float32)[None, :]
    return out, kept, pos


def chained_samples(counts, start, flows, window: float, positions: bool = False) -> tuple:
    """Windows beyond the composed support, reached by chaining step-0 flows from a position in the last one.

    Parameters
    ----------
    counts : ndarray ``(m, C, h, w)``
        The windows in the order the chain reaches them (outward from the support).
    start : ndarray ``(2, h, w)`` float
        Each pixel's position in the window before ``counts[0]`` (:func:`composed_samples`' ``positions`` of the
        support's last window); NaN: the chain does not start.
    flows : ndarray ``(m, 2, h, w)`` float
        ``flows[i]``: the step-0 flow from the window before ``counts[i]`` to it (:mod:`spikeref.align`'s
        convention), sampled bilinearly at the moved position, clamped to the grid.
    window : float
        ``W``.
    positions : bool
        Also return the chained positions.

    Returns
    -------
    samples : ndarray ``(m, C, h, w) float32``
        Catmull–Rom samples (rates) at the chained positions; 0 where not valid.
    valid : ndarray ``(m, h, w) float32``
        1 while the chain stays inside the plane (``[−½, h − ½] × [−½, w − ½]``), 0 from where it leaves.
    positions : ndarray ``(m, 2, h, w) float32``, with ``positions=True``
        The position ``(y, x)`` in plane pixels of each window's sample; NaN where not valid.
    """
    c = np.asarray(counts)
    f = np.asarray(flows)
    _check_counts_bank(c, f)
    if f.shape[0] != c.shape[0]:
        raise ValueError(f"flows must have one flow per window ({c.shape[0]}); got {f.shape[0]}")
    st = np.asarray(start)
    if st.shape != (2,) + c.shape[2:]:
        raise ValueError(f"start must have shape (2, {c.shape[2]}, {c.shape[3]}); got {st.shape}")
    if isinstance(window, bool) or not np.isfinite(window) or window <= 0:
        raise ValueError(f"window must be a positive number of planes; got {window!r}")
    m, nc, h, w = c.shape
    out = np.zeros((m, nc, h, w), np.float32)
    valid = np.zeros((m, h, w), np.float32)
    pos = np.full((m, 2, h, w), np.nan, np.float32)
    if m:
        _chained_samples(np.ascontiguousarray(c, dtype=np.float32), np.ascontiguousarray(st, dtype=np.float64),
                         np.ascontiguousarray(f, dtype=np.float32), 1.0 / float(window), out, valid, pos)
    return (out, valid, pos) if positions else (out, valid)
