"""Oracle for the residual shrinkage (:mod:`spikeref.denoise.shrinkage`; not in the paper)."""

import numpy as np

__all__ = ["shrink_residual_oracle"]


def shrink_residual_oracle(noisy, denoised, window, radius=1):
    """``D + g (I − D)`` with ``g = max(0, 1 − σ²/mean_box(r²))``, ``σ² = p(1 − p)/W``, pixel by pixel."""
    noisy = np.asarray(noisy, dtype=np.float64)
    denoised = np.asarray(denoised, dtype=np.float64)
    shape = noisy.shape
    I_all = noisy.reshape((-1,) + shape[-2:])
    D_all = denoised.reshape((-1,) + shape[-2:])
    out = np.zeros_like(I_all)
    for c in range(I_all.shape[0]):
        residual = I_all[c] - D_all[c]
        padded = np.pad(residual ** 2, radius, mode="symmetric")  # half-sample symmetric, like Ψ
        h, w = residual.shape
        for y in range(h):
            for x in range(w):
                energy = padded[y:y + 2 * radius + 1, x:x + 2 * radius + 1].mean()
                p = min(max(D_all[c, y, x], 1 / (2 * window)), 1 - 1 / (2 * window))
                sigma2 = p * (1 - p) / window
                gain = max(0.0, 1 - sigma2 / energy) if energy > 0 else 0.0
                out[c, y, x] = D_all[c, y, x] + gain * residual[y, x]
    return out.reshape(shape)
