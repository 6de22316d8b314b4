"""Two convolutions the network does not use: the measured alternatives to :func:`spikeref.denoise.conv.conv3x3`.

``conv3x3_im2col`` (im2col + one BLAS matrix product per strip of rows, channel-last) was the
network's convolution until 2026-11-23; ``conv3x3_plain`` (one ``einsum`` per tap, no BLAS) is
the baseline of the speed ratio.  ``benchmarks/test_speed_unet.py`` times them against the
direct kernel; ``tests/test_unet.py`` holds all three to :func:`spikeref.oracles.unet.conv3x3_oracle`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["conv3x3_im2col", "conv3x3_plain"]

_STRIP_BYTES = 4 << 20  # im2col columns per strip of rows


def _leaky(x: np.ndarray, slope: float) -> None:
    """LeakyReLU in place."""
    if slope == 0:
        np.maximum(x, 0, out=x)
    else:
        np.maximum(x, x * slope, out=x)


def conv3x3_im2col(x: np.ndarray, wmat: np.ndarray, bias: np.ndarray, slope: float | None) -> np.ndarray:
    """3×3 convolution, zero padding 1, by im2col + BLAS in strips of rows (channel-last).

    The measured alternative to :func:`spikeref.denoise.conv.conv3x3` (``benchmarks/test_speed_unet.py``); the same
    values to float32 rounding, but BLAS sums in an order that depends on its thread count.

    Parameters
    ----------
    x : ndarray ``(N, H, W, Cin) float32``
        Channel-last input.
    wmat : ndarray ``(9·Cin, Cout) float32``
        Weights, row ``(3·dy + dx)·Cin + c`` holding tap ``(dy, dx)`` of input channel ``c``
        (from PyTorch's ``(Cout, Cin, 3, 3)``: ``w.transpose(2, 3, 1, 0).reshape(9 * Cin, Cout)``).
    bias : ndarray ``(Cout,) float32``
    slope : float or None
        LeakyReLU slope applied to the output, or ``None`` for a linear layer.

    Returns
    -------
    ndarray ``(N, H, W, Cout) float32``
        ``out[n, y, x, o] = b[o] + Σ_{c,dy,dx} w[o, c, dy, dx] · x[n, y+dy−1, x+dx−1, c]``
        (cross-correlation, as PyTorch's ``Conv2d``).
    """
    n, h, w, cin = x.shape
    cout = wmat.shape[1]
    xp = np.zeros((n, h + 2, w + 2, cin), dtype=np.float32)
    xp[:, 1:-1, 1:-1] = x
    out = np.empty((n, h, w, cout), dtype=np.float32)
    rows = int(max(1, min(h, _STRIP_BYTES // max(1, w * 9 * cin * 4))))
    cols = np.empty((rows, w, 9, cin), dtype=np.float32)
    for i in range(n):
        for r0 in range(0, h, rows):
            r1 = min(h, r0 + rows)
            m = r1 - r0
            c = cols[:m]
            for dy in range(3):
                for dx in range(3):
                    c[:, :, 3 * dy + dx, :] = xp[i, r0 + dy : r1 + dy, dx : dx + w, :]
            o = out[i, r0:r1].reshape(m * w, cout)
            np.matmul(c.reshape(m * w, 9 * cin), wmat, out=o)
            o += bias
            if slope is not None:
                _leaky(o, slope)
    return out


def conv3x3_plain(x: np.ndarray, weight: np.ndarray, bias: np.ndarray, slope: float | None) -> np.ndarray:
    """Plain NumPy reference of :func:`spikeref.denoise.conv.conv3x3`: channel-first, one ``einsum`` per tap, no BLAS.

    ``x`` is ``(N, Cin, H, W)``, ``weight`` PyTorch's ``(Cout, Cin, 3, 3)``; returns
    ``(N, Cout, H, W)``.  Slow and obviously correct; the baseline of the speed ratio.
    """
    n, cin, h, w = x.shape
    xp = np.zeros((n, cin, h + 2, w + 2), dtype=np.float32)
    xp[:, :, 1:-1, 1:-1] = x
    out = np.broadcast_to(bias[None, :, None, None], (n, weight.shape[0], h, w)).astype(np.float32)
    for dy in range(3):
        for dx in range(3):
            out += np.einsum("oc,nchw->nohw", weight[:, :, dy, dx], xp[:, :, dy : dy + h, dx : dx + w])
    if slope is not None:
        out = np.where(out >= 0, out, out * slope).astype(np.float32)
    return out
