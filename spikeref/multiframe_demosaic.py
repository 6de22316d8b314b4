r"""A multi-frame demosaic: every merged window's raw Bayer samples, gathered at full resolution (not in the paper).

Eq. 13 demosaics the merged frame: ``Ψ`` interpolates each colour from its own quarter (or half) of the pixels, so
the frame is bounded by ``Ψ`` of the truth (the ladder's ``limit``), and resampling each window's half-resolution
planes before the merge (Eq. 14–15, :mod:`spikeref.compose`) blurs and aliases what the windows' sub-pixel
motion had sampled.  When the scene moves, the windows sample it at other phases of the colour filter array: a
point that fell on a red site in one window falls on a green one in the next.  Burst photography uses that
(Wronski et al., *Handheld multi-frame super-resolution*, 2019: each raw sample splatted with a kernel at its
aligned position); this module does the same with the windows and weights of the robust merge
(:mod:`spikeref.merge`), gathering instead of splatting.

For full-resolution pixel ``X = (Y, X)`` of the reference window and colour ``ch``, with ``x = ⌊X/2⌋`` its 2×2
cell on the plane grid:

.. math::

    \hat I_{ch}(X) = \frac{\sum_j ω_j(x) \sum_{c:\,col(c) = ch} \sum_{q ∈ N_c(X'_j)} g(|P_c(q) − X'_j|)\,
                     s_{j,c}(q) / W}
                    {\sum_j ω_j(x) \sum_{c:\,col(c) = ch} \sum_{q ∈ N_c(X'_j)} g(|P_c(q) − X'_j|)},
    \qquad X'_j = X + 2\,(p_j(x) − x),

with ``p_j(x)`` the position (plane pixels) of the cell's content in window ``j`` (:func:`spikeref.compose.
composed_samples`' ``positions``, :func:`~spikeref.compose.chained_samples`' beyond the support), ``ω_j`` its
final weight in the robust merge (:func:`spikeref.merge.robust_merge` with ``final_weights=True``), ``s_{j,c}``
window ``j``'s count (or charge) in Bayer plane ``c``, whose pixel ``q`` lies at ``P_c(q) = 2q + o_c`` full-
resolution pixels (``o_c`` the plane's offset in the 2×2 cell), ``N_c(X')`` the 2×2 pixels of plane ``c`` around
``X'`` and ``g(d) = exp(−d² / 2σ_c²)``: ``σ_c = σ / √m_c`` (``σ`` = :attr:`MultiframeParams.sigma`, full-resolution
pixels; ``m_c`` the planes of ``c``'s colour — the kernel scaled to the spacing of the colour's sites, 2 pixels for
red and blue, √2 for green — so that with one window each colour keeps its own sites' values, as ``Ψ`` does).

Interpretations:

* One displacement per 2×2 cell (the flows are estimated on the 2×2 luma), nearest cell: no interpolation of the
  position field.
* The weights are the merge's, so a window the merge refused at a cell adds nothing there, and the frame's noise is
  the merge's; with one window (or windows that did not move) this is a Gaussian-weighted interpolation of each
  colour from its own sites, close to ``Ψ`` (bilinear).
* Where no sample of a colour has weight (``Σ ω g`` = 0: every window refused and outside), the pixel takes
  ``fallback`` (the pipeline gives ``Ψ`` of the merged planes).
* Rates are not clipped; the pipeline adds the denoiser's change ``Ψ[D(I) − I]`` of the merged planes.

**What it adds, shrunk where it is noise** (:func:`shrink_increment`, the pipeline's next step).  The gathered frame
is sharper than ``Ψ`` of the merge but noisier: each window contributes mostly its nearest sites, where the merge's
cubic resampling averages several (and the merge's denoiser sees only the merged planes).  Its increment
``d = Î − Ψ(I)`` is real detail where the windows' phases differ and noise where they do not, so it is kept by a
local Wiener gain, ``Ψ(I) + g d`` with ``g = clip(1 − σ_ch² / box(d²), 0, 1)`` per pixel and colour: ``σ_ch`` the
increment's own noise, estimated per colour from the whole frame (:func:`spikeref.denoise.guard.noise_sigma`,
Immerkær's truncated estimate), ``box`` the mean over :data:`SHRINK_BOX` × :data:`SHRINK_BOX` pixels.  Measured on
the benchmark scenes (``docs/results.md``, "The multi-frame demosaic"): mean +0.07 dB, low light +0.28; twice
``σ²`` made no difference (29.59 both).

**Where the merge took few windows** (the pipeline passes the merge's effective number of windows ``n(x)``,
:func:`spikeref.merge.robust_merge`'s ``windows``).  ``σ_ch`` is the frame's typical noise, set by the pixels where
the merge took many windows; the increment's noise variance falls as ``1/n``, so :func:`multiframe_frame` scales
``σ_ch²`` by ``median(n) / n(x)`` (a moving edge merged from one window keeps less of its noisier increment).
And where ``n`` is about one window the gathered frame holds only the reference's own samples, an interpolation of
the same sites as ``Ψ`` with another kernel, whose increment over ``Ψ`` is no detail: the increment is weighted by
``clip((n − 1) / (n_g − 1), 0, 1)``, ``n_g`` = :data:`GATHER_RAMP` windows.  Measured on the bench at the defaults
(``docs/results.md``, "Where the merge took one window"): both together 31.01 → 31.03 dB, the fan 24.75 → 24.85,
the embedded sample 28.32 → 28.40.  Before the reference was sampled at its own pixels (30.98): the scaled ``σ²``
alone 31.00, the ramp alone 31.00 (``n_g`` = 8: 30.98), both 31.01, both with ``(median(n)/n)²`` 30.94.

**Where the windows add no phase, Ψ's correction of the colours: Malvar–He–Cutler** (:func:`phase_diversity`, the
pipeline's last step).  Where the scene holds still, every window samples the reference's own CFA phases: the
gathered frame is then an interpolation of each colour from its own sites, as Ψ (bilinear) is, and a demosaic that
uses the other colours' detail (Malvar, He & Cutler 2004, :func:`spikeref.demosaic.demosaic_mhc`) does better.
Where the windows moved by sub-pixel steps, they sampled the other phases and MHC's correction (a guess of the
missing colours from the others' gradients) would add on top of what was measured.  So the frame adds MHC's
correction of the merged planes, ``MHC(I) − Ψ(I)``, weighted per 2×2 cell by ``1 − δ(x)``:

.. math::

    δ(x) = \frac{\sum_j ω_j(x)\, \min(1, \lVert e_j(x) \rVert)}{\sum_j ω_j(x)}, \qquad
    e_j(x) = \text{distance of } 2\,(p_j(x) − x) \text{ to the nearest even integer, per axis},

the merge's share of weight on windows whose content lies off the reference's CFA lattice (full-resolution
pixels; 0 where every window is at the reference's phase — a static scene — or where no window has weight, 1
where they all lie a pixel off).  MHC's correction assumes that the colours share their detail, which saturated
colours do not: it is also scaled by ``1 − s/2``, ``s`` the local saturation of ``Ψ(I)``'s colour
(:func:`colour_saturation`; half the correction where one channel is 0).  Measured on the benchmark scenes
(``docs/results.md``, "Where the windows add no phase"): the bench mean +1.4 dB; ``1 − clip(δ / δ_0)`` with
``δ_0`` = 0.25, 0.5, 0.75, 1, 1.5, 2 gave 30.99, 31.13, 31.22, 31.26, 31.16, 31.06 dB, so ``δ_0 = 1`` (no
parameter); ``1 − clip(s / s_0)`` with ``s_0`` = 1, 1.5, 2, 4, ∞ gave 31.16, 31.30, 31.34, 31.36, 31.32 on the
bench, the fan 24.73 to 24.40 and the embedded sample 28.13 to 27.62: ``s_0 = 2`` for the sample and the fan.

**Directional where the colours share their detail** (:func:`colour_detail_ratio`,
:func:`spikeref.directional_demosaic.demosaic_ddfapd`).  MHC's fixed filters read across an edge; the
directional demosaic of Menon, Andriani & Calvagno (2007) interpolates along it, and on the exact mosaics of the
eight benchmark scenes it is 1.2 dB above MHC on the mean (3.1 above Ψ).  It assumes, more strongly than MHC, that
the colours share their detail, and it loses where they do not (the fan's red-and-white checkerboard).  So the
correction is ``M' − Ψ(I)`` with ``M' = MHC(I) + a (DDFAPD(I) − MHC(I))`` before the Wiener gain,
``a = clip(1 − ρ/ρ₀, 0, 1)``, ``ρ`` the share of ``Ψ(I)``'s local detail its colours do not share and ``ρ₀`` =
:data:`DETAIL_GATE`.  Measured on the benchmark scenes at the defaults (``docs/results.md``, "The directional
demosaic where the colours share their detail"): 31.03 → 31.63 dB; the directional demosaic alone in place of MHC
31.73 but the fan 24.85 → 24.62; gated by the saturation instead, ``clip(1 − s/s₁)``, ``s₁`` = 0.7 / 1: 31.57 /
31.64 with the fan 24.85 / 24.82 (with a Wiener gain for each demosaic, ``s₁`` = 1.5: 31.69, the fan 24.77); by
``ρ`` with ``ρ₀`` = 1 / 1.25: 31.56 / 31.63, the fan 24.86 / 24.84.

The literal oracles are :func:`spikeref.oracles.multiframe_demosaic.multiframe_demosaic_oracle` and
:func:`~spikeref.oracles.multiframe_demosaic.phase_diversity_oracle`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scipy.ndimage import uniform_filter

from spikeref._checks import finite_number
from spikeref._jit import njit, prange
from spikeref.bayer import bayer_mosaic, cfa_channels
from spikeref.demosaic import demosaic
from spikeref.denoise.guard import noise_sigma

__all__ = ["MultiframeParams", "multiframe_demosaic", "multiframe_frame", "shrink_increment", "phase_diversity",
           "colour_saturation", "colour_detail_ratio", "plane_channels", "DETAIL_GATE",
           "colour_planes", "plane_sigmas", "PLANE_OFFSETS", "SHRINK_BOX", "SATURATION_BOX", "GATHER_RAMP"]

#: Side (full-resolution pixels) of the box over which :func:`shrink_increment` measures the increment's energy.
SHRINK_BOX = 5

#: Side (full-resolution pixels) of the box over which :func:`colour_saturation` averages the frame's colour
#: (and :func:`colour_detail_ratio` its detail).
SATURATION_BOX = 5

#: ``ρ₀``: the directional demosaic's share of the correction is ``clip(1 − ρ/ρ₀, 0, 1)``, ``ρ`` the
#: :func:`colour_detail_ratio` of ``Ψ(I)``; the rest is Malvar–He–Cutler's (module doc; chosen on the benchmark
#: scenes, ``docs/results.md``).
DETAIL_GATE = 1.25

#: Effective windows ``n_g`` of the merge at which :func:`multiframe_frame` keeps the gathered frame's increment in
#: full (from none at one window; module doc, "Where the merge took few windows").
GATHER_RAMP = 4.0

#: Offsets ``(dy, dx)`` of the four Bayer planes in the 2×2 cell, in :func:`spikeref.bayer.bayer_planes`' order.
PLANE_OFFSETS = ((0, 0), (0, 1), (1, 0), (1, 1))


@dataclass(frozen=True)
class MultiframeParams:
    """Parameters of :func:`multiframe_demosaic`.

    Attributes
    ----------
    sigma : float
        ``σ`` of the Gaussian kernel for red and blue in full-resolution pixels (green's is ``σ/√2``): 0.6, chosen on
        the benchmark scenes among 0.45, 0.6 and 0.75 (means 29.39, 29.48, 29.18 dB with one σ for all colours; the
        held-out set run once, ``docs/results.md``, "The multi-frame demosaic").
    """

    sigma: float = 0.6

    def __post_init__(self):
        finite_number(self.sigma, "sigma", positive=True)


@njit(parallel=True)
def _multiframe_kernel(counts, positions, weights, inv_window, channel, offsets, power, k_base, fallback, out):
    """The module's sum for every full-resolution pixel; ``out`` ``(2h, 2w, 3)`` float32.

    Cell by cell: a window's position is the cell's, so the four pixels of the cell and the four planes share the
    Gaussian's separable factors ``exp(−k dy²)`` and ``exp(−k dx²)`` (``k = 1/(2σ²)`` of red and blue), three
    row and three column offsets ``e = r − o ∈ {−1, 0, 1}`` (pixel parity minus plane offset) with two sites each;
    a plane whose colour has ``m`` planes takes their ``m``-th power (``σ_c = σ/√m``): 12 exponentials per window
    and cell instead of 64.
    """
    n, nc, h, w = counts.shape
    for cy in prange(h):
        num = np.zeros((2, 2, 3))
        den = np.zeros((2, 2, 3))
        fy = np.zeros(3, np.int64)
        fx = np.zeros(3, np.int64)
        gy = np.zeros((3, 2))
        gx = np.zeros((3, 2))
        for cx in range(w):
            num[:] = 0.0
            den[:] = 0.0
            for j in range(n):
                wj = weights[j, cy, cx]
                py = positions[j, 0, cy, cx]
                px = positions[j, 1, cy, cx]
                if not wj > 0.0 or np.isnan(py) or np.isnan(px):
                    continue
                for ei in range(3):  # e = ei − 1
                    e = ei - 1.0
                    fy[ei] = int(np.floor(py + 0.5 * e))
                    fx[ei] = int(np.floor(px + 0.5 * e))
                    for a in range(2):
                        dy = 2.0 * (fy[ei] + a) - 2.0 * py - e
                        dx = 2.0 * (fx[ei] + a) - 2.0 * px - e
                        gy[ei, a] = np.exp(-k_base * dy * dy)
                        gx[ei, a] = np.exp(-k_base * dx * dx)
                for c in range(nc):
                    oy = offsets[c, 0]
                    ox = offsets[c, 1]
                    ch = channel[c]
                    m = power[c]
                    for ry in range(2):
                        ey = ry - oy + 1
                        for rx in range(2):
                            ex = rx - ox + 1
                            acc = 0.0
                            wsum = 0.0
                            for a in range(2):
                                qy = fy[ey] + a
                                if qy < 0 or qy >= h:
                                    continue
                                for b in range(2):
                                    qx = fx[ex] + b
                                    if qx < 0 or qx >= w:
                                        continue
                                    g = gy[ey, a] * gx[ex, b]
                                    if m == 2:  # green (a Bayer colour has one or two planes)
                                        g = g * g
                                    acc += g * counts[j, c, qy, qx]
                                    wsum += g
                            num[ry, rx, ch] += wj * acc
                            den[ry, rx, ch] += wj * wsum
            for ry in range(2):
                for rx in range(2):
                    yy = 2 * cy + ry
                    xx = 2 * cx + rx
                    for ch in range(3):
                        if den[ry, rx, ch] > 0.0:
                            out[yy, xx, ch] = num[ry, rx, ch] * inv_window / den[ry, rx, ch]
                        else:
                            out[yy, xx, ch] = fallback[yy, xx, ch]


@njit(parallel=True)
def _phase_diversity_kernel(positions, weights, out):
    """:func:`phase_diversity` for every cell; ``out`` ``(h, w)`` float64."""
    n, _, h, w = positions.shape
    for y in prange(h):
        for x in range(w):
            share = 0.0
            total = 0.0
            for j in range(n):
                uy = 2.0 * (float(positions[j, 0, y, x]) - y)  # float64, with or without the JIT
                ux = 2.0 * (float(positions[j, 1, y, x]) - x)
                if np.isnan(uy) or np.isnan(ux):
                    continue
                ey = abs(uy - 2.0 * np.floor(uy / 2.0 + 0.5))  # the distance to the nearest even integer
                ex = abs(ux - 2.0 * np.floor(ux / 2.0 + 0.5))
                off = min(1.0, np.sqrt(ey * ey + ex * ex))
                wj = float(weights[j, y, x])
                share += wj * off
                total += wj
            out[y, x] = share / total if total > 0.0 else 0.0


def plane_channels(cfa: str) -> np.ndarray:
    """The colour (0 R, 1 G, 2 B) of each Bayer plane of ``cfa`` (``"RGGB"`` …), in :data:`PLANE_OFFSETS` order:
    :func:`spikeref.bayer.cfa_channels` as the kernel's ``int64`` array."""
    return np.array(cfa_channels(cfa), np.int64)


def colour_planes(channel: np.ndarray) -> np.ndarray:
    """``m_c`` of each plane: how many planes carry its colour (1 for red and blue, 2 for green)."""
    channel = np.asarray(channel)
    return np.array([np.count_nonzero(channel == ch) for ch in channel], np.int64)


def plane_sigmas(channel: np.ndarray, sigma: float) -> np.ndarray:
    """``σ_c`` of each plane: ``σ / √m_c`` (:func:`colour_planes`; the green sites lie √2 apart, the red and the blue
    ones 2)."""
    return sigma / np.sqrt(colour_planes(channel))


def multiframe_demosaic(counts, positions, weights, window: float, cfa: str, fallback,
                        params: MultiframeParams = MultiframeParams()) -> np.ndarray:
    """The reference frame in full-resolution RGB from every merged window's raw Bayer samples (module doc).

    Parameters
    ----------
    counts : ndarray ``(n, 4, h, w)`` float
        Each window's count (or charge) per Bayer plane (:func:`spikeref.bayer.bayer_planes`).
    positions : ndarray ``(n, 2, h, w)`` float
        Where each cell's content is in window ``j``, ``(y, x)`` in plane pixels; NaN: nowhere (not used).
    weights : ndarray ``(n, h, w)`` float ≥ 0
        Each window's weight per cell (the robust merge's final weights).
    window : float
        ``W``, the planes each window integrates (rates are ``counts / W``).
    cfa : str
        The colour filter array (``"RGGB"``, ``"BGGR"``, ``"GRBG"``, ``"GBRG"``).
    fallback : ndarray ``(2h, 2w, 3)`` float
        What a pixel takes where no sample of a colour has weight (the pipeline: ``Ψ`` of the merged planes).
    params : MultiframeParams

    Returns
    -------
    ndarray ``(2h, 2w, 3) float32``
        Rates (spikes per readout), linear RGB.
    """
    c = np.asarray(counts)
    if c.ndim != 4 or c.shape[1] != 4 or not np.issubdtype(c.dtype, np.number):
        raise ValueError(f"counts must be (n, 4, h, w) numbers; got shape {c.shape}")
    n, _, h, w = c.shape
    pos = np.asarray(positions)
    if pos.shape != (n, 2, h, w):
        raise ValueError(f"positions must have shape ({n}, 2, {h}, {w}); got {pos.shape}")
    wt = np.asarray(weights)
    if wt.shape != (n, h, w) or not np.all(np.isfinite(wt)) or wt.min(initial=0.0) < 0:
        raise ValueError(f"weights must be finite, non-negative, of shape ({n}, {h}, {w}); got {wt.shape}")
    finite_number(window, "window", positive=True)
    channel = plane_channels(cfa)
    fb = np.asarray(fallback)
    if fb.shape != (2 * h, 2 * w, 3):
        raise ValueError(f"fallback must have shape ({2 * h}, {2 * w}, 3); got {fb.shape}")
    if not isinstance(params, MultiframeParams):
        raise TypeError(f"params must be a MultiframeParams; got {type(params).__name__}")
    out = np.empty((2 * h, 2 * w, 3), np.float32)
    _multiframe_kernel(np.ascontiguousarray(c, dtype=np.float32), np.ascontiguousarray(pos, dtype=np.float32),
                       np.ascontiguousarray(wt, dtype=np.float32), 1.0 / float(window), channel,
                       np.array(PLANE_OFFSETS, np.int64), colour_planes(channel), 1.0 / (2.0 * params.sigma ** 2),
                       np.ascontiguousarray(fb, dtype=np.float32), out)
    return out


def shrink_increment(rgb, base, box: int = SHRINK_BOX, relative=None) -> np.ndarray:
    """``base + g (rgb − base)``, the increment kept by a local Wiener gain (module doc).

    Parameters
    ----------
    rgb, base : ndarray ``(H, W, 3)`` float
        The gathered frame (:func:`multiframe_demosaic`) and ``Ψ`` of the merged planes.
    box : int
        Odd side of the box of the increment's local energy, full-resolution pixels.
    relative : ndarray ``(H, W)`` float ≥ 0, optional
        A factor on ``σ_ch²`` per pixel (:func:`multiframe_frame`: ``median(n) / n``, the noise of a pixel merged
        from ``n`` windows relative to the frame's typical one); default 1.

    Returns
    -------
    ndarray ``(H, W, 3) float32``
        ``base + g d`` with ``d = rgb − base`` and ``g = clip(1 − r σ_ch² / box(d²), 0, 1)`` per pixel and colour
        (``σ_ch`` :func:`~spikeref.denoise.guard.noise_sigma` of ``d``'s colour, ``r`` = ``relative``; ``box``
        SciPy's ``uniform_filter``, ``mode="reflect"``; ``g = 0`` where ``box(d²) = 0``).
    """
    a = np.asarray(rgb, dtype=np.float64)
    b = np.asarray(base, dtype=np.float64)
    if a.ndim != 3 or a.shape[-1] != 3 or b.shape != a.shape:
        raise ValueError(f"rgb and base must be (H, W, 3) of one shape; got {a.shape} and {b.shape}")
    if isinstance(box, bool) or not isinstance(box, (int, np.integer)) or box < 1 or box % 2 == 0:
        raise ValueError(f"box must be an odd whole number ≥ 1; got {box!r}")
    d = (a - b).transpose(2, 0, 1)
    s2 = noise_sigma(d)[:, None, None] ** 2
    if relative is not None:
        r = np.asarray(relative, dtype=np.float64)
        if r.shape != a.shape[:2] or not np.all(np.isfinite(r)) or r.min(initial=0.0) < 0:
            raise ValueError(f"relative must be finite, non-negative, of shape {a.shape[:2]}; got {r.shape}")
        s2 = s2 * r[None]
    energy = uniform_filter(d * d, size=(1, box, box), mode="reflect")
    with np.errstate(divide="ignore", invalid="ignore"):
        gain = np.where(energy > 0, np.clip(1.0 - s2 / np.where(energy > 0, energy, 1.0), 0.0, 1.0), 0.0)
    return (b + (gain * d).transpose(1, 2, 0)).astype(np.float32)


def phase_diversity(positions, weights) -> np.ndarray:
    """``δ(x)``: the merge's share of weight on windows off the reference's CFA lattice, per 2×2 cell (module doc).

    Parameters
    ----------
    positions : ndarray ``(n, 2, h, w)`` float
        Where each cell's content is in window ``j``, ``(y, x)`` in plane pixels; NaN: nowhere (not counted).
        Read as float32, as the pipeline keeps them.
    weights : ndarray ``(n, h, w)`` float ≥ 0
        Each window's final weight per cell (:func:`spikeref.merge.robust_merge` with ``final_weights=True``);
        read as float32.

    Returns
    -------
    ndarray ``(h, w) float64``
        In ``[0, 1]``; 0 where no window has weight.
    """
    pos = np.asarray(positions)
    if pos.ndim != 4 or pos.shape[1] != 2 or not np.issubdtype(pos.dtype, np.number):
        raise ValueError(f"positions must be (n, 2, h, w) numbers; got shape {pos.shape}")
    n, _, h, w = pos.shape
    wt = np.asarray(weights)
    if wt.shape != (n, h, w) or not np.all(np.isfinite(wt)) or wt.min(initial=0.0) < 0:
        raise ValueError(f"weights must be finite, non-negative, of shape ({n}, {h}, {w}); got {wt.shape}")
    out = np.empty((h, w), np.float64)
    # float32 as the pipeline keeps them (one kernel signature; float32 → float64 is exact in the arithmetic)
    _phase_diversity_kernel(np.ascontiguousarray(positions, dtype=np.float32),
                            np.ascontiguousarray(weights, dtype=np.float32), out)
    return out


def colour_saturation(rgb, box: int = SATURATION_BOX) -> np.ndarray:
    """The local saturation of the frame's colour, ``(max − min) / max`` of its box-averaged RGB, ``(H, W)`` in [0, 1].

    Where the colour is saturated (one channel far above the others) the colours do not share their detail, which
    is what Malvar–He–Cutler's correction assumes; the pipeline scales that correction by ``1 − s/2`` (module doc).

    Parameters
    ----------
    rgb : ndarray ``(H, W, 3)`` float
        Linear RGB (the pipeline: ``Ψ`` of the merged planes); negative values count as 0.
    box : int
        Odd side of the box (SciPy's ``uniform_filter``, ``mode="reflect"``), full-resolution pixels.

    Returns
    -------
    ndarray ``(H, W) float32``
        0 where the box-averaged colour is grey or black, 1 where one channel is 0.
    """
    a = np.asarray(rgb)
    if a.ndim != 3 or a.shape[-1] != 3 or not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"rgb must be (H, W, 3) numbers; got shape {a.shape}")
    if isinstance(box, bool) or not isinstance(box, (int, np.integer)) or box < 1 or box % 2 == 0:
        raise ValueError(f"box must be an odd whole number ≥ 1; got {box!r}")
    planes = np.ascontiguousarray(np.maximum(a, 0).transpose(2, 0, 1), dtype=np.float32)  # channel-first: fast
    r, g, b = uniform_filter(planes, size=(1, box, box), mode="reflect")
    hi = np.maximum(np.maximum(r, g), b)
    lo = np.minimum(np.minimum(r, g), b)
    out = np.zeros_like(hi)
    np.divide(hi - lo, hi, out=out, where=hi > 0)
    return out


def colour_detail_ratio(rgb, box: int = SATURATION_BOX) -> np.ndarray:
    """The share of the frame's local detail that its colours do not share, ``(H, W)`` in [0, 1].

    ``h = rgb − box₃(rgb)`` per channel (the 3 × 3 mean, mirrored borders: the detail), and over the ``box`` ×
    ``box`` window ``ρ = box(e_c) / box(h_G² + e_c)`` with ``e_c = ((h_R − h_G)² + (h_B − h_G)²) / 2``: 0 where the
    three channels carry the same detail (grey or tinted texture), 1/3 on a red-and-white checkerboard, 1 where
    only red or blue varies; 0 where the window is flat.  The directional demosaic, like Malvar–He–Cutler,
    assumes shared detail; the pipeline weights it by ``clip(1 − ρ/ρ₀, 0, 1)`` (module doc).

    Parameters
    ----------
    rgb : ndarray ``(H, W, 3)`` float
        Linear RGB (the pipeline: ``Ψ`` of the merged planes); negative values count as 0.
    box : int
        Odd side of the window, full-resolution pixels.

    Returns
    -------
    ndarray ``(H, W) float32``
    """
    a = np.asarray(rgb)
    if a.ndim != 3 or a.shape[-1] != 3 or not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"rgb must be (H, W, 3) numbers; got shape {a.shape}")
    if isinstance(box, bool) or not isinstance(box, (int, np.integer)) or box < 1 or box % 2 == 0:
        raise ValueError(f"box must be an odd whole number ≥ 1; got {box!r}")
    b = np.maximum(a, 0).astype(np.float64)
    h = b - uniform_filter(b, size=(3, 3, 1), mode="reflect")
    shared = uniform_filter(h[..., 1] ** 2, box, mode="reflect")
    apart = uniform_filter(((h[..., 0] - h[..., 1]) ** 2 + (h[..., 2] - h[..., 1]) ** 2) / 2, box, mode="reflect")
    total = shared + apart
    out = np.zeros_like(total)
    np.divide(apart, total, out=out, where=total > 0)
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def _on_pixels(cells: np.ndarray) -> np.ndarray:
    """A map ``(h, w)`` of the 2×2 cells as ``(2h, 2w)`` full-resolution pixels (each cell's value on its four)."""
    return np.repeat(np.repeat(cells, 2, axis=0), 2, axis=1)


def multiframe_frame(counts, positions, weights, window: float, cfa: str, merged, denoised,
                     windows=None) -> np.ndarray:
    """The pipeline's output frame with the multi-frame demosaic (module doc), ``(2h, 2w, 3) float32``.

    ``B = Ψ(I)`` of the merged planes; the gathered frame's increment over ``B`` kept by its Wiener gain
    (:func:`multiframe_demosaic`, :func:`shrink_increment`) and, given ``windows``, weighted by
    ``clip((n − 1) / (n_g − 1), 0, 1)`` (:data:`GATHER_RAMP`); the correction ``M' − B``, ``M'`` Malvar–He–Cutler's
    frame moved toward the directional demosaic's by ``clip(1 − ρ/ρ₀, 0, 1)`` (:func:`colour_detail_ratio` of
    ``B``, :data:`DETAIL_GATE`), kept alike, scaled by ``1 − s/2`` (:func:`colour_saturation` of ``B``) and
    weighted per cell by ``1 − δ``
    (:func:`phase_diversity`); the denoiser's change ``Ψ[D(I) − I]``; the sum clipped at 0 (MHC overshoots at
    edges: a rate is never negative).

    Parameters
    ----------
    counts, positions, weights, window, cfa
        As :func:`multiframe_demosaic` (``weights``: the merge's final weights).
    merged, denoised : ndarray ``(4, h, w)`` float
        The merged Bayer planes ``I`` (rates) and the denoiser's ``D(I)``.
    windows : ndarray ``(h, w)`` float > 0, optional
        The merge's effective number of windows ``n`` per cell (:func:`spikeref.merge.robust_merge`'s
        ``windows``): the Wiener gains take ``σ_ch² · median(n) / n`` (module doc, "Where the merge took few
        windows").  Without it, the frame of the module doc before that paragraph.
    """
    mosaic = bayer_mosaic(merged, cfa)
    base = demosaic(mosaic, cfa, "bilinear")
    change = demosaic(bayer_mosaic(denoised - merged, cfa), cfa, "bilinear")
    relative = ramp = None
    if windows is not None:
        n = np.asarray(windows, dtype=np.float64)
        if n.shape != np.shape(merged)[1:] or not np.all(np.isfinite(n)) or n.min(initial=1.0) <= 0:
            raise ValueError(f"windows must be finite, positive, of shape {np.shape(merged)[1:]}; got {n.shape}")
        relative = _on_pixels(np.median(n) / n)
        ramp = _on_pixels(np.clip((n - 1.0) / (GATHER_RAMP - 1.0), 0.0, 1.0))[..., None]
    rgb = shrink_increment(multiframe_demosaic(counts, positions, weights, window, cfa, base), base,
                           relative=relative)
    if ramp is not None:  # about one window: the reference's own sites, which Ψ already interpolates
        rgb = (base + ramp * (rgb - base)).astype(np.float32)
    mhc = demosaic(mosaic, cfa, "mhc")
    shared = np.clip(1.0 - colour_detail_ratio(base) / DETAIL_GATE, 0.0, 1.0)[..., None]
    sharper = mhc + shared * (demosaic(mosaic, cfa, "ddfapd") - mhc)  # directional where the colours share detail
    correction = shrink_increment(sharper, base, relative=relative) - base
    correction *= (1 - colour_saturation(base) / 2)[..., None]  # MHC assumes the colours share their detail
    still = (1.0 - phase_diversity(positions, weights)).astype(np.float32)  # per 2×2 cell
    correction *= _on_pixels(still)[..., None]
    return np.maximum(rgb + correction + change, 0).astype(np.float32, copy=False)
