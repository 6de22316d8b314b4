"""Classic spike-camera reconstructions used as baselines (paper §5.2, Table 1).

* **TFP** — texture from playback (Zhu et al. 2019): the firing rate over a
  window, i.e. Eq. 4 with ``M_c = 1``.
* **TFI** — texture from inter-spike intervals (Zhu et al. 2019): the inverse
  of the interval between the spikes around time ``t``.
* **TFSTP** — texture from short-term plasticity (Zheng et al. 2023): the
  steady state of a Tsodyks–Markram synapse driven by each pixel's spikes.

They are defined for monochrome streams.  For a Bayer stream
(:func:`bayer_baseline`) each is applied to the mosaic — every pixel on its
own, so per Bayer plane — and the result demosaicked with Ψ, as the paper
does to compare them on chromatic spikes.
"""

from __future__ import annotations

import numpy as np

from spikeref.accumulate import accumulate
from spikeref.bayer import demosaic_bilinear

__all__ = ["tfp", "bayer_baseline", "BASELINES"]


def tfp(spikes, window: int, start: int = 0, count: int | None = None) -> np.ndarray:
    """TFP: firing rate of each pixel over consecutive windows of ``window`` planes.

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
    window : int
        Planes per window; frame ``k`` covers ``[start + kW, start + (k+1)W)``.

    Returns
    -------
    ndarray ``(count, H, W) float32`` in ``[0, 1]`` (spikes per readout).

    Notes
    -----
    SpikeCV's ``TFP.spikes2images`` averages ``2h+1`` planes centred on each
    output time; ``tfp(spikes, 2h+1, start=t-h, count=1)`` is that frame.
    """
    return accumulate(spikes, window, start=start, count=count)


def bayer_baseline(frames: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Demosaic baseline frames computed on a mosaic: ``(..., H, W)`` → ``(..., H, W, 3)`` (Ψ)."""
    return demosaic_bilinear(frames, cfa)


BASELINES = ("tfp",)
