"""The denoising U-Net ``f_θ`` of §4.1, inference in NumPy and Numba (no autograd, no deep-learning framework).

Architecture (supplement §8: 5 encoder and 5 decoder blocks of two 3×3 convolutions with
LeakyReLU, skip connections, head and tail — 25 convolutions):

=============  =====================================  ===================  ==========
layer          operation                              channels in → out    resolution
=============  =====================================  ===================  ==========
``head0/1``    conv, conv                             1 → C → C            1
``enc{k}a/b``  max-pool 2×2, conv, conv (k = 1…5)     C → C → C            1/2^k
``dec{k}a/b``  nearest ×2, concat skip, conv, conv    2C → C → C           1/2^(k−1)
``tail0/1/2``  conv, conv, conv (the last linear)     C → C → C/2 → 1      1
=============  =====================================  ===================  ==========

``C`` is :attr:`UNetSpec.width`, the hidden channels (not the paper's ``C = h_s × w_s`` of §4.1, the cells of
the blind-spot mask); every convolution is 3×3 with zero padding 1 and a bias, followed by LeakyReLU (slope
:attr:`UNetSpec.negative_slope`) except ``tail2``.  The skip of decoder block ``k`` is the output of encoder
block ``k − 1`` (the head for ``k = 1``).  The same network runs on each of the four Bayer planes.

Input and output are one-channel images in the domain the weights were trained in, their ``meta``
``input_domain``: ``"count"`` (spike counts ``I·W``; every bundled network) or ``"rate"`` (spikes per readout).
:class:`spikeref.denoise.denoiser.Denoiser` scales a frame into that domain and back, and runs ``f_θ`` inside
Eq. 10–11 (:mod:`spikeref.denoise.blindspot`) or on the frame itself (visible mode).

Any input size is accepted: the image is padded at the bottom and right to a multiple of ``2^depth`` (32),
whole-sample symmetric (NumPy's ``"reflect"``, ``docs/spec/README.md``), and the output cropped back.

:func:`spikeref.oracles.unet.unet_forward_oracle` is the same network written as plain loops, for reading.
Here each convolution is :func:`spikeref.denoise.conv.conv_padded` on zero-bordered, channel-first activations,
and a pass takes its buffers from a per-thread pool that the pass before filled (:func:`release_buffers` frees
it), in :mod:`spikeref.denoise._unet_kernels`.

The weights file (``.npz``, PyTorch's layout, with a JSON ``meta`` saying how the weights were made)
is read and written by :mod:`spikeref.io.unet_weights`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spikeref.denoise._unet_kernels import buffers, maxpool_into, release_buffers, upsample_into
from spikeref.denoise.conv import conv_padded
from spikeref.io.unet_weights import WEIGHTS_FORMAT, read_unet_weights, write_unet_weights

__all__ = ["UNetSpec", "UNet", "layer_shapes", "exposure_level", "release_buffers", "WEIGHTS_FORMAT"]


@dataclass(frozen=True)
class UNetSpec:
    """Shape of the U-Net.

    Parameters
    ----------
    width : int
        Channels ``C`` of the hidden layers (even, ≥ 2); 32 by default, 16 in every bundled network.
        Blind2Unblind (the paper's ref. [31]) uses 48; the paper gives none.  A smaller width is faster on a CPU
        (``docs/results_history.md``).
    depth : int
        Encoder (and decoder) blocks; the input is padded to a multiple of ``2**depth``.
        The paper's network has 5.
    negative_slope : float
        Slope of LeakyReLU for negative inputs (0.1 by default; the paper gives none).
    in_channels : {1, 2}
        1 (default, the paper's network): the image alone.  2 (not in the paper): the image and an
        *exposure channel*, the constant :func:`exposure_level` of the window behind it, so that one
        network can tell a short noisy window from a long clean one of the same count
        (``docs/results_history.md``, "The exposure as an input channel").
    """

    width: int = 32
    depth: int = 5
    negative_slope: float = 0.1
    in_channels: int = 1

    def __post_init__(self):
        for name in ("width", "depth"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"UNetSpec.{name} must be a positive integer; got {v!r}")
        if self.width < 2 or self.width % 2:
            raise ValueError(f"UNetSpec.width must be even and ≥ 2; got {self.width}")
        if isinstance(self.in_channels, bool) or self.in_channels not in (1, 2):
            raise ValueError(f"UNetSpec.in_channels must be 1 or 2 (the image, and the exposure channel); "
                             f"got {self.in_channels!r}")
        if not (np.isfinite(self.negative_slope) and 0 <= self.negative_slope < 1):
            raise ValueError(f"UNetSpec.negative_slope must lie in [0, 1); got {self.negative_slope!r}")

    @property
    def multiple(self) -> int:
        """Input sizes are padded to a multiple of this (``2**depth``)."""
        return 2**self.depth


def exposure_level(window: float) -> float:
    """The exposure channel's value for a window of ``window`` planes: ``log10(window)`` (1 at 10 planes).

    Constant over the image (:attr:`UNetSpec.in_channels` = 2).  A logarithm because the noise of a window's
    count relative to its signal falls as a power of ``W``; the training windows span 5–200 planes (0.7–2.3).
    """
    w = float(window)
    if not (np.isfinite(w) and w > 0):
        raise ValueError(f"window must be a positive number of planes; got {window!r}")
    return float(np.log10(w))


def layer_shapes(spec: UNetSpec) -> dict[str, tuple[int, int]]:
    """``{name: (in_channels, out_channels)}`` of the convolutions, in the order they run."""
    c = spec.width
    shapes = {"head0": (spec.in_channels, c), "head1": (c, c)}
    for k in range(1, spec.depth + 1):
        shapes[f"enc{k}a"] = (c, c)
        shapes[f"enc{k}b"] = (c, c)
    for k in range(spec.depth, 0, -1):
        shapes[f"dec{k}a"] = (2 * c, c)
        shapes[f"dec{k}b"] = (c, c)
    shapes["tail0"] = (c, c)
    shapes["tail1"] = (c, c // 2)
    shapes["tail2"] = (c // 2, 1)
    return shapes


# ----------------------------------------------------------------------------- the network
class UNet:
    """The U-Net with fixed weights; ``net(batch)`` maps ``(N, h, w)`` images to ``(N, h, w)``.

    Build it with :meth:`load` (a weights ``.npz``), :meth:`from_params` (a dict of PyTorch-layout
    arrays) or :meth:`random` (He-initialised, for tests and benchmarks).
    """

    def __init__(self, spec: UNetSpec, params: dict[str, np.ndarray], meta: dict | None = None):
        if not isinstance(spec, UNetSpec):
            raise TypeError(f"spec must be a UNetSpec; got {type(spec).__name__}")
        self.spec = spec
        self.meta = dict(meta or {})
        self.params: dict[str, np.ndarray] = {}
        for name, (cin, cout) in layer_shapes(spec).items():
            for part, shape in (("weight", (cout, cin, 3, 3)), ("bias", (cout,))):
                key = f"{name}.{part}"
                if key not in params:
                    raise ValueError(f"params lack {key!r} (a width-{spec.width}, depth-{spec.depth} U-Net)")
                arr = np.asarray(params[key])
                if arr.shape != shape:
                    raise ValueError(f"params[{key!r}] must have shape {shape}; got {arr.shape}")
                if not np.issubdtype(arr.dtype, np.floating) or not np.all(np.isfinite(arr)):
                    raise ValueError(f"params[{key!r}] must be finite floating point")
                self.params[key] = np.ascontiguousarray(arr, dtype=np.float32)
        extra = sorted(set(params) - set(self.params))
        if extra:
            raise ValueError(f"params hold unknown arrays {extra[:4]} for a depth-{spec.depth} U-Net")

    # -- construction ---------------------------------------------------------------------------
    @classmethod
    def from_params(cls, params: dict[str, np.ndarray], spec: UNetSpec | None = None, meta=None) -> "UNet":
        """From PyTorch-layout arrays; the spec is read from ``head0.weight`` and the layer names if not given."""
        if spec is None:
            width, cin = (int(v) for v in np.asarray(params["head0.weight"]).shape[:2])
            depth = sum(1 for k in params if k.startswith("enc") and k.endswith("a.weight"))
            spec = UNetSpec(width=width, depth=depth, in_channels=cin)
        return cls(spec, params, meta)

    @classmethod
    def random(cls, spec: UNetSpec | None = None, seed: int = 0) -> "UNet":
        """He-normal weights and small random biases (a fixed function for tests and benchmarks)."""
        spec = spec or UNetSpec()
        rng = np.random.default_rng(seed)
        params = {}
        for name, (cin, cout) in layer_shapes(spec).items():
            std = np.sqrt(2.0 / (9 * cin))
            params[f"{name}.weight"] = (rng.standard_normal((cout, cin, 3, 3)) * std).astype(np.float32)
            params[f"{name}.bias"] = (rng.standard_normal(cout) * 0.01).astype(np.float32)
        return cls(spec, params, {"source": f"UNet.random(seed={seed})"})

    @classmethod
    def load(cls, path) -> "UNet":
        """Read a weights ``.npz`` (:mod:`spikeref.io.unet_weights`)."""
        shape, arrays, meta = read_unet_weights(path)
        try:
            return cls(UNetSpec(**shape), arrays, meta)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None

    def save(self, path) -> Path:
        """Write the weights ``.npz`` (atomically; :mod:`spikeref.io.unet_weights`)."""
        shape = {"width": self.spec.width, "depth": self.spec.depth, "negative_slope": self.spec.negative_slope}
        if self.spec.in_channels != 1:  # files of one-channel networks stay as they were
            shape["in_channels"] = self.spec.in_channels
        return write_unet_weights(path, shape, self.params, self.meta)

    @property
    def n_parameters(self) -> int:
        return int(sum(a.size for a in self.params.values()))

    def __repr__(self) -> str:
        s = self.spec
        return f"UNet(width={s.width}, depth={s.depth}, parameters={self.n_parameters})"

    # -- inference ------------------------------------------------------------------------------
    def __call__(self, batch, level: float | None = None) -> np.ndarray:
        """``f_θ`` on a batch of one-channel images.

        Parameters
        ----------
        batch : ndarray ``(N, h, w)`` or ``(h, w)``, float
            Bayer planes in the weights' domain (counts or rates, module docstring); any ``h, w ≥ 1``.
        level : float, optional
            The exposure channel's value (:func:`exposure_level` of the window), for a network with
            ``spec.in_channels == 2``, where it is required; a one-channel network refuses it.

        Returns
        -------
        ndarray, the shape of ``batch``, ``float32``.
        """
        x = np.asarray(batch)
        if x.ndim not in (2, 3):
            raise ValueError(f"batch must have shape (N, H, W) or (H, W); got {x.shape}")
        if not np.issubdtype(x.dtype, np.floating):
            raise TypeError(f"batch must be floating point (counts or rates); got {x.dtype}")
        if x.size == 0:
            raise ValueError(f"batch is empty: shape {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError("batch must be finite")
        if self.spec.in_channels == 2:
            if level is None:
                raise ValueError("this network reads an exposure channel: pass level=exposure_level(window)")
            if (isinstance(level, bool) or not isinstance(level, (int, float, np.integer, np.floating))
                    or not np.isfinite(level)):
                raise ValueError(f"level must be a finite number; got {level!r}")
        elif level is not None:
            raise ValueError("level= is for a network with an exposure channel (spec.in_channels == 2)")
        single = x.ndim == 2
        x = x[None] if single else x
        n, h, w = x.shape
        m = self.spec.multiple
        ph, pw = (-h) % m, (-w) % m
        xp = np.pad(x.astype(np.float32), ((0, 0), (0, ph), (0, pw)), mode="reflect")  # a side of 1 repeats
        out = self._forward(xp, keep=(h, w), level=level)[:, :h, :w]
        return np.ascontiguousarray(out[0] if single else out)

    def _forward(self, x: np.ndarray, keep: tuple[int, int] | None = None, level: float | None = None) -> np.ndarray:
        """The layers on a padded batch ``(N, h, w)`` float32 (``level``: the exposure channel's value).

        Activations are kept channel-first with a zero border of one pixel, ``(N, C, H + 2, W + 2)``, so
        each convolution reads its input in place.  ``keep = (h0, w0)``: only the output's first ``h0``
        rows and ``w0`` columns are wanted, so the layers after the last upsampling make only those and one
        more row and column per layer still to come (columns up to a multiple of 16), each wanted pixel the
        same value as without ``keep``; the other pixels are unset or computed from unset ones.
        """
        slope = self.spec.negative_slope
        params = self.params
        n, h, w = x.shape
        if h % self.spec.multiple or w % self.spec.multiple:  # __call__ pads; pooling needs it
            raise ValueError(f"_forward needs sizes that are multiples of {self.spec.multiple}; got {h}×{w}")
        h0, w0 = (h, w) if keep is None else keep
        pool = buffers()
        pool.start((n, h, w))

        def region(after):  # what the output needs of a layer with `after` layers to come (columns in 16s)
            return min(h, h0 + after), min(w, -(-(w0 + after) // 16) * 16)

        def conv(name, t, act=True, skip=None, after=None):
            """The layer on ``t`` (then ``skip``'s channels), then ``t``'s buffer is released."""
            weight, bias = params[f"{name}.weight"], params[f"{name}.bias"]
            out = conv_padded(t, weight, bias, slope if act else None,
                               pool.take(t.shape[0], weight.shape[0], t.shape[2] - 2, t.shape[3] - 2),
                               skip=skip, region=None if after is None else region(after))
            pool.give(t)
            return out

        t = pool.take(n, self.spec.in_channels, h, w)
        t[:, 0, 1:-1, 1:-1] = x
        if self.spec.in_channels == 2:
            t[:, 1, 1:-1, 1:-1] = np.float32(level)
        t = conv("head1", conv("head0", t))
        skips = [t]
        for k in range(1, self.spec.depth + 1):
            c, hh, ww = t.shape[1], t.shape[2] - 2, t.shape[3] - 2
            pooled = pool.take(n, c, hh // 2, ww // 2)
            maxpool_into(t, pooled)
            t = conv(f"enc{k}b", conv(f"enc{k}a", pooled))
            skips.append(t)
        skips.pop()  # the bottleneck is t itself
        for k in range(self.spec.depth, 0, -1):
            skip = skips.pop()
            c, hh, ww = t.shape[1], skip.shape[2] - 2, skip.shape[3] - 2
            last = k == 1  # full resolution: five layers to go (dec1a, dec1b, tail0, tail1, tail2)
            up = pool.take(n, c, hh, ww)
            upsample_into(t, *(region(5) if last else (hh, ww)), up)
            pool.give(t)
            t = conv(f"dec{k}a", up, skip=skip, after=4 if last else None)  # [nearest ×2 of t, skip]
            pool.give(skip)
            t = conv(f"dec{k}b", t, after=3 if last else None)
        t = conv("tail2", conv("tail1", conv("tail0", t, after=2), after=1), act=False, after=0)
        out = t[:, 0, 1:-1, 1:-1].copy()  # the caller's own array: the buffer goes back to the pool
        pool.give(t)
        return out
