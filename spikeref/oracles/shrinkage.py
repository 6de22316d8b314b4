"""Oracle for the residual shrinkage (:mod:`spikeref.denoise.shrinkage`; not in the paper)."""

import numpy as np

from spikeref.oracles.case import OracleCase

__all__ = ["shrink_residual_oracle", "box3_mean", "GOLDEN_CASES"]


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


# ----------------------------------------------------------------------------- the golden cases
def box3_mean(a):
    """3×3 mean of each plane ``(n, h, w)``, half-sample symmetric border: the golden cases' linear stand-in
    for the network (here and in :mod:`spikeref.oracles.guard`)."""
    h, w = a.shape[-2:]
    padded = np.pad(a, ((0, 0), (1, 1), (1, 1)), mode="symmetric")
    return sum(padded[:, dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)) / 9.0


def _inputs_shrinkage():
    """float32 rates of W = 10 and W = 200 windows of four 7×9 planes with a step edge, and a 3×3 box
    blur of them standing in for D(I) (so the residual is large at the edge, noise elsewhere).

    The last plane's first two rows have ``I = D`` exactly (zero residual energy, gain 0), and one
    pixel per window sits at each clip bound of ``p`` (0 and 1).
    """
    rng = np.random.default_rng(11)
    truth = np.where(np.arange(9) < 4, 0.15, 0.6) + np.linspace(0.0, 0.3, 4 * 7).reshape(4, 7, 1)
    out = {}
    for w in (10, 200):
        noisy = rng.binomial(w, truth) / w
        denoised = box3_mean(noisy)
        denoised[3, :2] = noisy[3, :2]
        denoised[0, 0, 0], denoised[3, 6, 8] = 0.0, 1.0
        out[f"noisy_w{w}"] = noisy.astype(np.float32)
        out[f"denoised_w{w}"] = denoised.astype(np.float32)
    return out


def _shrinkage_outputs(i, shrink):
    return {f"w{w}": shrink(i[f"noisy_w{w}"], i[f"denoised_w{w}"], w) for w in (10, 200)}


GOLDEN_CASES = (
    OracleCase(
        "shrinkage_residual", "— (not in the paper; after Eq. 10–11's D)",
        "spikeref.denoise.shrinkage.shrink_residual", "spikeref.oracles.shrinkage.shrink_residual_oracle",
        "D + g·(I − D), g = max(0, 1 − σ²/mean₃ₓ₃ r²), σ² = p(1 − p)/W with p = D clipped to [1/2W, 1 − 1/2W], "
        "3×3 box half-sample symmetric at the border, g = 0 where the box's residual energy is 0; four 7×9 "
        "planes (float32) at W = 10 and W = 200; the oracle computes in float64.",
        _inputs_shrinkage,
        lambda i: _shrinkage_outputs(i, shrink_residual_oracle),
        rtol=1e-6, atol=1e-7, params={"radius": 1, "windows": [10, 200], "dtype": "float32"},
        spec="docs/spec/denoise.md#shrinkage_residual",
        outputs=_shrinkage_outputs,
    ),
)
