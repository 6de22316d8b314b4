"""The U-Net of :mod:`spikeref.denoise.unet` in PyTorch, for training (extra ``train``).

Same layers, names and parameter layout as the NumPy network, so :func:`export_params`
gives arrays that :class:`spikeref.denoise.unet.UNet` runs unchanged (a test and the golden
file ``golden/unet_forward.npz`` hold the two forwards equal).  Inputs must already be a
multiple of ``2**depth`` in size (training crops are); the NumPy network pads for itself.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from spikeref.denoise.unet import UNet, UNetSpec, layer_shapes

__all__ = ["TorchUNet", "export_params", "to_numpy_unet"]


class TorchUNet(nn.Module):
    """``f_θ`` for training: ``(N, C_in, H, W)`` → ``(N, 1, H, W)``, ``H, W`` multiples of ``2**depth``.

    ``C_in`` is ``spec.in_channels``: the image, then (with 2) the exposure channel
    (:func:`spikeref.denoise.unet.exposure_level`, constant over the image).
    """

    def __init__(self, spec: UNetSpec | None = None):
        super().__init__()
        self.spec = spec or UNetSpec()
        self.convs = nn.ModuleDict(
            {name: nn.Conv2d(cin, cout, 3, padding=1) for name, (cin, cout) in layer_shapes(self.spec).items()}
        )
        for name, conv in self.convs.items():
            if name == "tail2":
                nn.init.kaiming_normal_(conv.weight, a=1.0)  # linear output layer
            else:
                nn.init.kaiming_normal_(conv.weight, a=self.spec.negative_slope, nonlinearity="leaky_relu")
            nn.init.zeros_(conv.bias)

    def _conv(self, name, x, act=True):
        x = self.convs[name](x)
        return F.leaky_relu(x, self.spec.negative_slope) if act else x

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        m = self.spec.multiple
        c = self.spec.in_channels
        if x.ndim != 4 or x.shape[1] != c or x.shape[2] % m or x.shape[3] % m:
            raise ValueError(f"input must be (N, {c}, H, W) with H, W multiples of {m}; got {tuple(x.shape)}")
        x = self._conv("head1", self._conv("head0", x))
        skips = [x]
        for k in range(1, self.spec.depth + 1):
            x = F.max_pool2d(x, 2)
            x = self._conv(f"enc{k}b", self._conv(f"enc{k}a", x))
            skips.append(x)
        skips.pop()
        for k in range(self.spec.depth, 0, -1):
            up = F.interpolate(x, scale_factor=2, mode="nearest")
            x = torch.cat([up, skips.pop()], dim=1)
            x = self._conv(f"dec{k}b", self._conv(f"dec{k}a", x))
        x = self._conv("tail1", self._conv("tail0", x))
        return self._conv("tail2", x, act=False)


def export_params(model: TorchUNet) -> dict[str, np.ndarray]:
    """``{"<layer>.weight": (out, in, 3, 3), "<layer>.bias": (out,)}`` float32 arrays of ``model``."""
    return {
        f"{name}.{part}": getattr(conv, part).detach().float().cpu().numpy().copy()
        for name, conv in model.convs.items()
        for part in ("weight", "bias")
    }


def to_numpy_unet(model: TorchUNet, meta: dict | None = None) -> UNet:
    """The NumPy :class:`UNet` with ``model``'s weights (write it with ``.save(path)``)."""
    return UNet(model.spec, export_params(model), meta)
