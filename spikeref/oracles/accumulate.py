"""Oracle for Eq. 4: I_c(x, t) = M_c / W · Σ_τ S_c(x, τ)."""

import numpy as np

__all__ = ["accumulate_oracle"]


def accumulate_oracle(spikes, window, start=0, gain=1.0):
    """Frame ``k`` = ``gain / W`` × the number of spikes in planes ``[start + kW, start + (k+1)W)``.

    ``spikes`` is ``(T, H, W)`` 0/1; returns float64 ``(K, H, W)`` with
    ``K = (T - start) // W``.
    """
    t_total, h, w = spikes.shape
    n_frames = (t_total - start) // window
    frames = np.zeros((n_frames, h, w), dtype=np.float64)
    for k in range(n_frames):
        for y in range(h):
            for x in range(w):
                count = 0
                for tau in range(start + k * window, start + (k + 1) * window):
                    count += int(spikes[tau, y, x])
                frames[k, y, x] = gain / window * count
    return frames
