"""The spike camera pixel, Eq. 1–3: integrate, fire, reset (§3, Fig. 2).

.. math::

    E(x, t) = \\int \\alpha L(x, t)\\,dt \\bmod E_{th}, \\qquad
    S(x, t) = 1 \\text{ if } E(x, t) \\ge E_{th} \\text{ else } 0

Units and interpretation
------------------------
* Time is counted in **readouts** (planes, 1/20 000 s).  Radiance ``L`` is
  linear and expressed so that ``α·L`` is the charge a pixel collects in one
  readout period; with ``α = E_th = 1`` a radiance of 0.25 fires every fourth
  readout and 1.0 fires at every readout (the rate saturates at 1).
* Behind the CFA (Eq. 3) a pixel integrates only its own channel ``c``.
* Reset is by subtraction (the ``mod E_th`` of Eq. 1): charge above the
  threshold is kept for the next cycle.  At most one spike is read out per
  readout; if more than ``E_th`` arrives within one readout the extra
  crossings are lost (the accumulator is reduced modulo ``E_th``), which is
  what makes the rate saturate at 1.
* Without effects the model is deterministic: a static pixel with initial
  charge ``φ`` fires exactly ``⌊(φ + αL·n)/E_th⌋`` times in its first ``n``
  readouts when ``αL ≤ E_th``.
* ``substeps > 1`` integrates radiance sampled at that many instants within
  each readout (for fast motion); the charge per readout is their mean.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spikeref._jit import njit, prange
from spikeref.bayer import cfa_channels, validate_cfa

__all__ = ["Camera", "fire", "mosaic_radiance"]


@dataclass(frozen=True)
class Camera:
    """Sensor parameters of Eq. 1–3.

    Attributes
    ----------
    threshold : float
        ``E_th`` (> 0), in the same charge unit as ``alpha · L``.
    alpha : float
        Conversion ratio ``α`` (≥ 0).
    rate_hz : float
        Readout rate in planes per second (20 000).
    cfa : str or None
        Bayer pattern of the upright image; ``None`` for a monochrome sensor.
    substeps : int
        Radiance samples integrated within each readout (≥ 1).
    """

    threshold: float = 1.0
    alpha: float = 1.0
    rate_hz: float = 20000.0
    cfa: str | None = "RGGB"
    substeps: int = 1

    def __post_init__(self):
        if not np.isfinite(self.threshold) or self.threshold <= 0:
            raise ValueError(f"threshold (E_th) must be positive and finite; got {self.threshold!r}")
        if not np.isfinite(self.alpha) or self.alpha < 0:
            raise ValueError(f"alpha must be non-negative and finite; got {self.alpha!r}")
        if not np.isfinite(self.rate_hz) or self.rate_hz <= 0:
            raise ValueError(f"rate_hz must be positive; got {self.rate_hz!r}")
        if not isinstance(self.substeps, (int, np.integer)) or self.substeps < 1:
            raise ValueError(f"substeps must be a positive integer; got {self.substeps!r}")
        if self.cfa is not None:
            object.__setattr__(self, "cfa", validate_cfa(self.cfa))


def mosaic_radiance(rgb: np.ndarray, cfa: str | None) -> np.ndarray:
    """Apply the CFA (Eq. 3): ``(..., H, W, 3)`` linear RGB → ``(..., H, W)`` per-pixel radiance.

    With ``cfa=None`` the input must already be ``(..., H, W)`` (monochrome).
    """
    rgb = np.asarray(rgb)
    if cfa is None:
        return rgb
    if rgb.ndim < 3 or rgb.shape[-1] != 3:
        raise ValueError(f"radiance for a colour sensor must have shape (..., H, W, 3); got {rgb.shape}")
    h, w = rgb.shape[-3:-1]
    if h % 2 or w % 2:
        raise ValueError(f"a Bayer sensor needs even height and width; got {h}×{w}")
    out = np.empty(rgb.shape[:-1], dtype=rgb.dtype)
    channels = cfa_channels(cfa)
    for pos, (dy, dx) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):  # one strided copy per Bayer position
        out[..., dy::2, dx::2] = rgb[..., dy::2, dx::2, channels[pos]]
    return out


@njit(parallel=True)
def _fire(charge_per_readout, thresholds, state, spikes):
    # charge_per_readout (T, H, W) float64 = α·L integrated over each readout
    # thresholds (H, W) float64 E_th per pixel; state (H, W) float64 accumulator, updated in place
    # spikes (T, H, W) uint8 out.  Rows in parallel; within a row, time outer and x inner so every
    # access runs along contiguous memory and the inner loop is branch-free (it vectorises).  The
    # rare case of more than one crossing in a readout (rate above 1) is fixed after the row.
    t_total, h, w = charge_per_readout.shape
    for y in prange(h):
        for t in range(t_total):
            several = False
            for x in range(w):
                threshold = thresholds[y, x]
                e = state[y, x] + charge_per_readout[t, y, x]
                fired = e >= threshold
                e = e - threshold if fired else e
                several |= e >= threshold
                spikes[t, y, x] = fired
                state[y, x] = e
            if several:  # only one spike is read out per readout: the extra crossings are lost
                for x in range(w):
                    if state[y, x] >= thresholds[y, x]:
                        state[y, x] = state[y, x] % thresholds[y, x]


def fire(charge: np.ndarray, threshold, state: np.ndarray, *, out: np.ndarray | None = None,
         check: bool = True) -> np.ndarray:
    """Integrate-and-fire over readouts (Eq. 1–2), continuing from ``state``.

    Parameters
    ----------
    charge : ndarray ``(T, H, W)``
        ``α·L`` collected in each readout (≥ 0, finite).
    threshold : float or ndarray ``(H, W)``
        ``E_th`` > 0, one value or one per pixel (threshold fixed-pattern noise).
    state : ndarray ``(H, W) float64``
        Accumulator at the start, in ``[0, E_th)``; updated in place so a long
        stream can be simulated chunk by chunk with identical results.
    out : ndarray ``(T, H, W) uint8``, optional
        Where to write the spikes (a block of a longer recording); a new array by default.
    check : bool
        ``False`` skips the scan of ``charge`` and ``threshold`` for finite, non-negative values,
        for a caller that has made sure of them (the simulator checks radiance per readout and
        every effect adds charge ≥ 0); shapes and dtypes are always checked.

    Returns
    -------
    ndarray ``(T, H, W) uint8`` of 0/1 (``out`` when given).
    """
    charge = np.ascontiguousarray(charge, dtype=np.float64)
    if charge.ndim != 3:
        raise ValueError(f"charge must have shape (T, H, W); got {charge.shape}")
    if check and (not np.all(np.isfinite(charge)) or (charge.size and charge.min() < 0)):
        raise ValueError("radiance must be finite and non-negative")
    thresholds = np.asarray(threshold, dtype=np.float64)
    # one writable C-contiguous (H, W) array, whatever was given: one compiled signature of the kernel
    thresholds = np.require(np.broadcast_to(thresholds, charge.shape[1:]) if thresholds.shape != charge.shape[1:]
                            else thresholds, requirements=["C", "W"])
    if check and (not np.all(np.isfinite(thresholds)) or np.any(thresholds <= 0)):
        raise ValueError("threshold must be positive and finite (every pixel)")
    if not isinstance(state, np.ndarray) or state.shape != charge.shape[1:] or state.dtype != np.float64:
        raise ValueError(f"state must be float64 of shape {charge.shape[1:]}; got {getattr(state, 'dtype', None)} "
                         f"{getattr(state, 'shape', None)}")
    if out is None:
        out = np.empty(charge.shape, dtype=np.uint8)
    elif (not isinstance(out, np.ndarray) or out.shape != charge.shape or out.dtype != np.uint8
          or not out.flags.writeable):
        raise ValueError(f"out must be a writable uint8 array of shape {charge.shape}; got "
                         f"{getattr(out, 'dtype', None)} {getattr(out, 'shape', None)}")
    _fire(charge, thresholds, state, out)
    return out
