"""Literal NumPy transcription of the U-Net forward pass (:mod:`spikeref.denoise.unet`).

Channel-first, one layer per line, every convolution a plain sum over its 9 taps
(:func:`conv3x3_oracle`), max-pooling and nearest upsampling written out.  It imports nothing
from the network it checks.
Slow; it freezes ``golden/unet_forward.npz``, which the fast network and the PyTorch twin
(:mod:`spikeref.denoise.torch_unet`) must both reproduce.
"""

from __future__ import annotations

import numpy as np

from spikeref.oracles.case import OracleCase

__all__ = ["unet_forward_oracle", "conv3x3_oracle", "GOLDEN_CASES", "layer_names", "unet_params_from_inputs"]


def conv3x3_oracle(x: np.ndarray, weight: np.ndarray, bias: np.ndarray, slope: float | None) -> np.ndarray:
    """A 3×3 convolution with zero padding, then LeakyReLU: ``out[n, o] = b[o] + Σ_c Σ_(dy,dx) w[o, c, dy, dx] ·
    x[n, c, y + dy − 1, x + dx − 1]``, one sum per tap, in float32 as the network runs.

    ``x`` is ``(N, Cin, H, W)``, ``weight`` PyTorch's ``(Cout, Cin, 3, 3)``; returns ``(N, Cout, H, W)``;
    ``slope = None`` leaves out the LeakyReLU (the last layer).
    """
    n, cin, h, w = x.shape
    padded = np.zeros((n, cin, h + 2, w + 2), dtype=np.float32)
    padded[:, :, 1:-1, 1:-1] = x
    out = np.empty((n, weight.shape[0], h, w), dtype=np.float32)
    out[...] = bias[None, :, None, None]
    for dy in range(3):
        for dx in range(3):
            tap = padded[:, :, dy : dy + h, dx : dx + w]
            out += np.einsum("oc,nchw->nohw", weight[:, :, dy, dx].astype(np.float32), tap)
    if slope is not None:
        out = np.where(out >= 0, out, out * np.float32(slope)).astype(np.float32)
    return out


def _conv(params, name, x, slope):
    return conv3x3_oracle(x, params[f"{name}.weight"], params[f"{name}.bias"], slope)


def _max_pool(x):
    n, c, h, w = x.shape
    out = np.empty((n, c, h // 2, w // 2), dtype=x.dtype)
    for y in range(h // 2):
        for x_ in range(w // 2):
            out[:, :, y, x_] = x[:, :, 2 * y : 2 * y + 2, 2 * x_ : 2 * x_ + 2].max(axis=(2, 3))
    return out


def _upsample_nearest(x):
    n, c, h, w = x.shape
    out = np.empty((n, c, 2 * h, 2 * w), dtype=x.dtype)
    for dy in range(2):
        for dx in range(2):
            out[:, :, dy::2, dx::2] = x
    return out


def unet_forward_oracle(params: dict, images: np.ndarray, depth: int = 5, slope: float = 0.1,
                        level: float | None = None) -> np.ndarray:
    """``f_θ(images)`` for ``(N, H, W)`` images: reflect-pad bottom/right to ``2**depth``, run, crop.

    ``level``: for weights whose ``head0`` reads two channels, the exposure channel's value, a constant
    second channel over the padded image."""
    n, h, w = images.shape
    m = 2**depth
    x = np.pad(images.astype(np.float32), ((0, 0), (0, (-h) % m), (0, (-w) % m)), mode="reflect")[:, None]
    if np.asarray(params["head0.weight"]).shape[1] == 2:
        x = np.concatenate([x, np.full_like(x, np.float32(level))], axis=1)
    x = _conv(params, "head0", x, slope)
    x = _conv(params, "head1", x, slope)
    skips = [x]
    for k in range(1, depth + 1):
        x = _max_pool(x)
        x = _conv(params, f"enc{k}a", x, slope)
        x = _conv(params, f"enc{k}b", x, slope)
        skips.append(x)
    for k in range(depth, 0, -1):
        x = np.concatenate([_upsample_nearest(x), skips[k - 1]], axis=1)
        x = _conv(params, f"dec{k}a", x, slope)
        x = _conv(params, f"dec{k}b", x, slope)
    x = _conv(params, "tail0", x, slope)
    x = _conv(params, "tail1", x, slope)
    x = _conv(params, "tail2", x, None)
    return x[:, 0, :h, :w]


# ----------------------------------------------------------------------------- the golden cases
def layer_names(depth: int = 5) -> list[str]:
    """The convolutions in the order they run (each has ``<name>.weight`` and ``<name>.bias``)."""
    return (["head0", "head1"] + [f"enc{k}{p}" for k in range(1, depth + 1) for p in "ab"]
            + [f"dec{k}{p}" for k in range(depth, 0, -1) for p in "ab"] + ["tail0", "tail1", "tail2"])


def unet_params_from_inputs(inputs: dict) -> dict:
    """The network's arrays of a golden case's inputs, stored there as ``param_<layer>.<weight|bias>``."""
    return {k[len("param_"):]: v for k, v in inputs.items() if k.startswith("param_")}


def _random_params(width: int, depth: int, seed: int) -> dict:
    """He-normal weights, ``N(0, 2/(9·C_in))``, and biases ``N(0, 0.01²)``, float32, drawn layer by layer in
    running order from ``default_rng(seed)`` (the draws of :meth:`spikeref.denoise.unet.UNet.random`)."""
    rng = np.random.default_rng(seed)
    cin = dict.fromkeys(layer_names(depth), width)
    cin["head0"] = 1
    cin.update({f"dec{k}a": 2 * width for k in range(1, depth + 1)})
    cin["tail2"] = width // 2
    cout = dict.fromkeys(layer_names(depth), width)
    cout.update({"tail1": width // 2, "tail2": 1})
    params = {}
    for name in layer_names(depth):
        std = np.sqrt(2.0 / (9 * cin[name]))
        params[f"{name}.weight"] = (rng.standard_normal((cout[name], cin[name], 3, 3)) * std).astype(np.float32)
        params[f"{name}.bias"] = (rng.standard_normal(cout[name]) * 0.01).astype(np.float32)
    return params


def _inputs_unet():
    images = np.random.default_rng(11).random((2, 37, 50)).astype(np.float32) * 0.5
    return {"images": images, **{f"param_{k}": v for k, v in _random_params(8, 5, 10).items()}}


GOLDEN_CASES = (
    OracleCase(
        "unet_forward", "§4.1 f_θ (supplement §8)", "spikeref.denoise.unet.UNet",
        "spikeref.oracles.unet.unet_forward_oracle",
        "The 25-convolution U-Net (width 8, depth 5, LeakyReLU 0.1) with fixed random weights on two 37×50 "
        "images (padded at the bottom and right to 64×64 whole-sample symmetrically, NumPy's 'reflect': row 37 "
        "reads row 35; cropped back). tests/test_unet.py also holds the PyTorch twin to it.",
        _inputs_unet,
        lambda i: {"output": unet_forward_oracle(unet_params_from_inputs(i), i["images"])},
        rtol=1e-4, atol=1e-5, params={"width": 8, "depth": 5, "negative_slope": 0.1},
        spec="docs/spec/unet.md#unet_forward",
    ),
)
