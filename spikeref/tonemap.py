"""Linear HDR → display: one exposure for a whole video, then sRGB encoding.

Reconstructed frames are linear firing rates (or radiance), float32, with no
upper bound.  For display the whole video is scaled by **one** exposure
(chosen once, e.g. from the first frames, so brightness does not flicker from
frame to frame), clipped to ``[0, 1]`` and encoded with the sRGB transfer
function (IEC 61966-2-1).  HDR values are kept unclipped in EXR files.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Exposure", "choose_exposure", "srgb_encode", "srgb_decode", "tonemap"]


@dataclass(frozen=True)
class Exposure:
    """A fixed linear gain applied before display encoding.

    Attributes
    ----------
    gain : float
        Multiplier on linear values; ``gain * value = 1`` is display white.
    """

    gain: float = 1.0

    def __post_init__(self):
        if not np.isfinite(self.gain) or self.gain <= 0:
            raise ValueError(f"exposure gain must be positive and finite; got {self.gain!r}")


def choose_exposure(frames, percentile: float = 99.5, target: float = 0.9) -> Exposure:
    """Exposure that maps the ``percentile`` of all values in ``frames`` to ``target``.

    ``frames`` is any array of linear values (one frame or many; colour or
    mono).  Non-finite values are ignored.  An all-dark input gets gain 1.
    """
    if not 0 < percentile <= 100:
        raise ValueError(f"percentile must be in (0, 100]; got {percentile}")
    values = np.asarray(frames, dtype=np.float64).ravel()
    values = values[np.isfinite(values)]
    level = float(np.percentile(values, percentile)) if values.size else 0.0
    if level <= 0:
        return Exposure(1.0)
    return Exposure(target / level)


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """sRGB opto-electronic transfer function on values in ``[0, 1]`` (clipped)."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """Inverse of :func:`srgb_encode`."""
    v = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def tonemap(frame: np.ndarray, exposure: Exposure | float = 1.0) -> np.ndarray:
    """Linear frame ``(H, W)`` or ``(H, W, 3)`` → display ``uint8`` sRGB of the same shape.

    NaN is shown as black and +inf as white, so a broken pixel is visible but
    never crashes a writer.
    """
    gain = exposure.gain if isinstance(exposure, Exposure) else Exposure(float(exposure)).gain
    with np.errstate(over="ignore", invalid="ignore"):  # huge values → inf → white, as documented
        x = np.nan_to_num(np.asarray(frame, dtype=np.float64) * gain, nan=0.0, posinf=1.0, neginf=0.0)
    return np.round(srgb_encode(x) * 255.0).astype(np.uint8)
