r"""A robust, motion-adaptive merge of the aligned windows (not in the paper; §4.2's pseudo-long exposure, made robust).

Eq. 14–15 average the ``(K−1)L + 1`` windows of the support with fixed binomial weights, wherever the pixel is:
at 10/3/3 about 52 planes of light in every output pixel, and every misaligned or occluded sample averaged in.
This module weighs each window's sample by how well it agrees with the reference, relative to the noise the
frames show, in the manner of burst photography's robust merges (HDR+; Wronski et al., *Handheld multi-frame
super-resolution*), and lets the support grow beyond Eq. 14–15's where the samples keep agreeing.

Inputs are what :func:`spikeref.compose.composed_samples` (and :func:`~spikeref.compose.chained_samples` beyond
the support) give: window ``j``'s rate ``s_j(x)`` resampled once at its composed position, per Bayer plane
``c``, and whether it lies inside the plane; and ``v_c(x)``, the noise variance of one window's rate
(:func:`spikeref.align_noise.local_noise` of the reference window: Immerkær's estimate, which also holds the
fixed-pattern and resampling differences two windows show).

**The test of a window** (one decision per window and pixel, all four planes together).  Against the current
estimate ``e`` (first the reference window itself, then the merge), with ``u_j = v + v_e − 2 a_j v`` the
variance of ``s_j − e`` (``a_j`` the share of ``s_j`` in ``e``, ``v_e = v Σ a_j²``), over the
``B × B`` box around ``x`` (``B`` = :attr:`MergeParams.box`; ``box`` means over its ``m`` pixels inside the
plane, ``m = B²`` away from the border):

.. math::

    Q_j = \sum_c \sum_{box} \min\left(\frac{(s_j − e)^2}{u_j}, κ^2\right), \qquad
    P_j = \sum_c \frac{\big(\operatorname{mean}_{box} \operatorname{clip}(s_j − e, ±κ\sqrt{u_j})\big)^2}{u_j / m},

``Q`` about χ² with ``4m`` degrees of freedom and ``P`` with 4 where ``s_j`` agrees (``κ`` =
:attr:`MergeParams.clip`: a lone spurious spike in either window counts at most ``κ²``, so it cannot throw a
window out), ``z_j = max((Q_j − 4m)/\sqrt{8m}, (P_j − 4)/\sqrt 8)``, and the window's robustness
``r_j = clip(2 − z_j / z_0, 0, 1)``: 1 up to ``z_0`` = :attr:`MergeParams.z`, 0 from ``2 z_0``.  The
reference window always has ``r = 1``.  Two rounds (:attr:`MergeParams.iterations`), each
``e = Σ r_j s_j / Σ r_j`` over the windows inside the plane, every window with weight 1 (not Eq. 14–15's
binomial one: the robustness decides what a window is worth).

**The adaptive support** (:attr:`MergeParams.shells`): beyond the core windows (those of Eq. 14–15's support),
shells of windows at larger distances ``|j − k|`` are offered in turn, each shell window weighing what a core
window weighs on average (``Σ_core ω / n_core``).  Each passes the test above against the current estimate
(with ``u_j = v + v_e``: a shell window is not part of ``e``), and the shell is taken where the mean squared
error falls by its own estimate:

.. math::

    λ \, b^2 \, a_{shell}^2 < \bar v \left(\frac{Σω²}{(Σω)²} − \frac{Σω'^2}{(Σω')^2}\right),

``a_shell`` the share of the shell's windows in the new estimate, ``ω'`` the weights with them, ``v̄`` the planes'
mean of ``v`` (the noise a longer average removes), ``λ`` = :attr:`MergeParams.safety`, and ``b²`` the shell's
bias: over the box, the planes and its passing windows, the mean of ``min((s_j − e)², κ² u_j) − û_j``, clipped
at 0, where ``û_j = v̂ + v̂ Σω²/(Σω)²`` measures the noise by how the **core** windows scatter about their merge,
``v̂ = max(box(Σ_core ω_j min((s_j − e)², κ² v c_j)) / box(Σ_core ω_j c_j), φ v)``, ``c_j = 1 − 2a_j + Σa²`` (the
variance of ``s_j − e`` in units of ``v``; the same truncation on both sides), never under ``φ`` times the model's
noise (``φ`` = :attr:`MergeParams.noise_floor`, 1; with :attr:`MergeParams.window` ``W > 0``,
``φ v / max(1, e W)``: in full up to one spike a window).  A shell is so judged by how much worse than the
core it agrees with the merge, whatever the noise model misses (the fixed pattern and the resampling in Immerkær's
estimate make ``v`` too large on bright textured content, which hid the drift of chained flows on rotation and
zoom), and at least what the model says: in low light the core windows share their inter-spike intervals (a
window charge interpolates the phase between spikes that lie windows apart) and scatter less than independent
windows would, and the scatter alone refused the shells that pay there (low light +0.17 dB at ``φ = 0``, +2.7 at
``φ = 1``; ``docs/results.md``, "The adaptive merge as the default").  Once a shell is refused at a pixel no
further one is offered there.  A static pixel so collects up to
``2·max(shells) + 1`` windows; a moving edge, an occlusion or a flow that has drifted only what agrees.

The estimate is clipped to ``[0, 1]`` spikes per readout (the cubic may overshoot), as
:func:`spikeref.compose.composed_warp`'s.  The literal oracle is :func:`spikeref.oracles.merge.robust_merge_oracle`.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from spikeref._checks import finite_number, whole_number
from spikeref._merge_kernels import robust_merge_kernel, workspace_size

__all__ = ["MergeParams", "robust_merge", "default_shells", "MERGES"]

#: ``ReconstructParams.merge``: Eq. 14–15's binomial average, the robust merge at its support, or with the
#: adaptive support.
MERGES = ("binomial", "robust", "adaptive")


@dataclass(frozen=True)
class MergeParams:
    """Parameters of :func:`robust_merge` (module doc).

    Attributes
    ----------
    box : int
        Odd side ``B`` of the box a window's agreement is summed over, in Bayer-plane pixels.
    z : float
        ``z_0``: a window whose statistic passes it loses weight, linearly to none at ``2 z_0``.
    clip : float
        ``κ``: the most one pixel and plane adds to ``Q`` (in units of its variance, squared).
    iterations : int
        Rounds of reweighting over the core windows.
    shells : tuple of (int, int)
        The adaptive support's shells: windows ``lo ≤ |j − k| ≤ hi`` each, offered in order; ``()`` (the
        ``"robust"`` merge) offers none.
    safety : float
        ``λ``: how much more a shell's bias counts than its variance gain.
    noise_floor : float
        ``φ``: the core's scatter ``v̂`` a shell is judged against is at least ``φ v`` (the noise model); 0 judges
        by the scatter alone (the rule until 2026-11-28).
    window : float
        ``W``, the readouts (planes) each sample's window integrates, or 0 (default: not said).  With ``W > 0`` the
        floor is ``φ v / max(1, e W)``: in full where the merge's rate ``e`` gives at most one spike a window,
        falling as ``1/(e W)`` above — the floor is for window charges that share inter-spike intervals, which
        they do only where spikes are sparse (the pipeline passes its window; ``docs/results.md``, "The adaptive
        merge as the default").
    """

    box: int = 5
    z: float = 3.0
    clip: float = 3.0
    iterations: int = 2
    shells: tuple = ()
    safety: float = 4.0
    noise_floor: float = 1.0
    window: float = 0.0

    def __post_init__(self):
        if whole_number(self.box, "box", 1, "an odd whole number ≥ 1") % 2 == 0:
            raise ValueError(f"box must be an odd whole number ≥ 1; got {self.box!r}")
        whole_number(self.iterations, "iterations", 1, "a whole number ≥ 1")
        for name in ("z", "clip", "safety"):
            finite_number(getattr(self, name), name, positive=True)
        finite_number(self.noise_floor, "noise_floor")
        finite_number(self.window, "window")
        shells = tuple(tuple(int(b) for b in sh) for sh in self.shells)
        last = 0
        for lo, hi in shells:
            if not last < lo <= hi:
                raise ValueError(f"shells must be increasing, disjoint (lo, hi) ranges of window distances ≥ 1; "
                                 f"got {self.shells!r}")
            last = hi
        object.__setattr__(self, "shells", shells)

    @property
    def reach(self) -> int:
        """The farthest window distance the shells offer (0 without shells)."""
        return self.shells[-1][1] if self.shells else 0


def default_shells(core_reach: int, support: int) -> tuple:
    """Shells from just beyond the core (``core_reach`` windows each side) to ``support``, each about half as
    long again as the distance it starts at (at least three windows): ``(4, 6), (7, 10), (11, 16), (17, 20)`` for
    3 and 20."""
    shells, lo = [], core_reach + 1
    while lo <= support:
        hi = min(support, lo + max(2, lo // 2))
        shells.append((lo, hi))
        lo = hi + 1
    return tuple(shells)


_WORK = threading.local()


def _workspace(size: int) -> np.ndarray:
    """The kernel's buffers, kept per thread between calls: fresh memory of this size costs a page fault per page at
    every call (a third of the merge's time at 250×400)."""
    work = getattr(_WORK, "array", None)
    if work is None or work.size < size:
        work = _WORK.array = np.empty(size)
    return work[:size]


def robust_merge(samples, weights, noise, reference: int, core, params: MergeParams = MergeParams(),
                 check: bool = True, final_weights: bool = False) -> tuple:
    """The robust merge of aligned windows, with the adaptive support when ``params.shells`` are given.

    Parameters
    ----------
    samples : ndarray ``(n, C, h, w)`` float
        Each window's rate at its aligned position (:func:`spikeref.compose.composed_samples`, then
        :func:`~spikeref.compose.chained_samples` for windows beyond the support).
    weights : ndarray ``(n, h, w)`` float ≥ 0
        Each window's base weight where it agrees: Eq. 14–15's path counts for the core windows
        (:func:`~spikeref.compose.composed_samples`' ``kept``), 0 where a window's position left the plane;
        a shell window's is taken as 1 where it lies inside the plane and scaled to the core's mean weight.
    noise : ndarray ``(C, h, w)`` float
        Noise variance of one window's rate per plane and pixel (module doc).
    reference : int
        Index of the reference window ``k`` in ``samples``.
    core : ndarray ``(n,)`` bool
        The windows merged first (Eq. 14–15's support); the others are offered shell by shell, by their
        distance ``|j − reference|``.
    params : MergeParams
    check : bool
        Check the arguments (default).  ``False`` skips the checks of values (finite, non-negative), which read
        every sample: for callers that made the arrays themselves (:class:`spikeref.pipeline.Reconstructor`).
    final_weights : bool
        Also return each window's final weight ``ω`` (what :mod:`spikeref.multiframe_demosaic` merges the windows'
        raw samples with).

    Returns
    -------
    estimate : ndarray ``(C, h, w) float32``
        The merged rates, clipped to ``[0, 1]``.
    windows : ndarray ``(h, w) float32``
        The effective number of windows merged, ``(Σ ω)² / Σ ω²`` over the final weights ``ω`` (times ``W``: the
        pseudo-exposure in planes).  Eq. 14–15's binomial weights at 10/3/3 give 27² / 141 = 5.17.
    final : ndarray ``(n, h, w) float32``, with ``final_weights=True``
        Each window's weight ``ω`` in the estimate (``estimate = Σ ω s / Σ ω`` before the clip): base weight ×
        robustness for the core windows, the unit weight × robustness for a shell's where the shell was taken,
        else 0.
    """
    if not check:
        out = _robust_merge(np.asarray(samples), np.asarray(weights), np.asarray(noise), int(reference),
                            np.asarray(core, dtype=bool), params)
        return out if final_weights else out[:2]
    s = np.asarray(samples)
    if not np.issubdtype(s.dtype, np.number) or np.issubdtype(s.dtype, np.complexfloating):
        raise TypeError(f"samples must be real numbers; got {s.dtype}")
    if s.ndim != 4:
        raise ValueError(f"samples must have shape (n, C, h, w); got {s.shape}")
    n, nc, h, w = s.shape
    base = np.asarray(weights)
    if not np.issubdtype(base.dtype, np.number) or np.issubdtype(base.dtype, np.complexfloating):
        raise TypeError(f"weights must be real numbers; got {base.dtype}")
    if base.shape != (n, h, w) or not np.all(np.isfinite(base)) or base.min(initial=0.0) < 0:
        raise ValueError(f"weights must be finite, non-negative, of shape ({n}, {h}, {w}); got {base.shape}")
    v = np.asarray(noise, dtype=np.float64)
    if v.shape != (nc, h, w) or not np.all(np.isfinite(v)) or v.min(initial=0.0) < 0:
        raise ValueError(f"noise must be a finite, non-negative ({nc}, {h}, {w}) variance map")
    if isinstance(reference, bool) or not isinstance(reference, (int, np.integer)) or not 0 <= reference < n:
        raise ValueError(f"reference must index the windows (0 … {n - 1}); got {reference!r}")
    core = np.asarray(core, dtype=bool)
    if core.shape != (n,) or not core[reference]:
        raise ValueError(f"core must be ({n},) bools that include the reference window")
    if not isinstance(params, MergeParams):
        raise TypeError(f"params must be a MergeParams; got {type(params).__name__}")
    if not np.all(np.isfinite(s)):
        raise ValueError("samples must be finite")
    out = _robust_merge(s, base, v, int(reference), core, params)
    return out if final_weights else out[:2]


def _robust_merge(s: np.ndarray, base: np.ndarray, v: np.ndarray, reference: int, core: np.ndarray,
                  params: MergeParams) -> tuple:
    """:func:`robust_merge` on arguments it has checked (or the pipeline made): ``s`` float32 or float64 (``base``
    is taken in the same type, one compiled kernel per type)."""
    n, nc, h, w = s.shape
    dist = np.abs(np.arange(n) - reference)
    idx = np.flatnonzero(core).astype(np.int64)
    shells = [np.flatnonzero(~core & (dist >= lo) & (dist <= hi)) for lo, hi in params.shells]
    shell_start = np.cumsum([0] + [sh.size for sh in shells]).astype(np.int64)
    shell_idx = np.concatenate(shells + [np.zeros(0, np.int64)]).astype(np.int64)
    if s.dtype not in (np.float32, np.float64):
        s = s.astype(np.float64)
    work = _workspace(workspace_size(idx.size, max((sh.size for sh in shells), default=0), nc, h, w))
    est, windows, final = np.empty((nc, h, w)), np.empty((h, w)), np.empty((n, h, w))
    robust_merge_kernel(np.ascontiguousarray(s), np.ascontiguousarray(base, dtype=s.dtype),
                        np.ascontiguousarray(v, dtype=np.float64), reference, idx,
                        int(np.flatnonzero(idx == reference)[0]), shell_start, shell_idx, int(params.box),
                        float(params.z), float(params.clip), int(params.iterations), float(params.safety),
                        float(params.noise_floor), float(params.window), work, est, windows, final)
    return np.clip(est, 0.0, 1.0).astype(np.float32), windows.astype(np.float32), final.astype(np.float32)
