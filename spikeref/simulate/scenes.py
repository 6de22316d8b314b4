"""Scenes for the simulator: procedural radiance over time with exact ground truth.

A :class:`Scene` holds what the camera looks at (its *content*), the camera (Eq. 1–3
parameters, :class:`spikeref.simulate.camera.Camera`) and the noise effects to run
(:mod:`spikeref.simulate.effects`).  Content types (the ``type`` of a scene file):

=======================  ======================  ==============================================================
``type``                 class                   what it shows
=======================  ======================  ==============================================================
``uniform``              :class:`Uniform`        a flat field of one colour (a grey card for the noise check)
``color_chart``          :class:`ColorChart`     the 24 ColorChecker colours, 4 × 6 patches on a dark board
``translating_texture``  :class:`TranslatingTexture`  a periodic colour texture sliding at a fixed velocity
``fan``                  :class:`FanOverToys`    a fast rotating fan over a still background of toys (Fig. 7a)
``hdr_lamp``             :class:`HDRLamp`        a lamp ≥ 10⁴ × brighter than a textured deep shadow beside it
``video``                :class:`VideoFrames`    a user's frames, interpolated linearly to the readout rate
=======================  ======================  ==============================================================

Units and conventions
---------------------
* ``radiance(times)`` takes a 1-D array of times in **readouts** (planes; 1 readout =
  1 / ``rate_hz`` s = 50 µs at 20 kHz; fractional times are instants inside a readout) and
  returns linear RGB ``(n, H, W, 3) float32``, finite and ≥ 0.  Row 0 is the top of the image.
* Radiance is in rate units: with the default camera (``α = E_th = 1``) it *is* the firing
  rate in spikes per readout, which saturates at 1.  ``brightness`` is the radiance of a
  white (reflectance 1) surface; procedural scenes keep radiance ≤ 0.95.
* Velocities are given per **second** (pixels per second, revolutions per second).  Each
  content carries the readout rate ``rate_hz`` as a field (default 20 000) to convert them;
  :func:`scene_from_dict` sets it from ``[camera] rate_hz``, and :class:`Scene` refuses a
  content whose ``rate_hz`` differs from its camera's.  Keeping the rate on the content makes
  ``radiance(t)`` self-contained: the same object gives the same ground truth everywhere.
* ``height`` and ``width`` are even (a Bayer sensor).  Content objects are frozen; static
  layers are rendered once on first use and cached (they are derived from the fields).

Scene files (TOML)
------------------
::

    name = "fan over toys"
    description = "..."
    planes = 2000                  # readouts to simulate (required)
    [camera]                       # optional: fields of Camera; cfa = "mono" for no CFA
    cfa = "RGGB"
    substeps = 4
    [content]
    type = "fan"                   # one of CONTENT_TYPES
    height = 256
    width = 256
    brightness = 0.5
    revolutions_per_second = 25.0
    [effects.random_phase]         # one table per effect with its parameters; empty = defaults
    [effects.dark_current]
    gamma = 0.002

The ``content`` table takes the fields of the content class (except ``rate_hz``); lists
become tuples.  A ``video`` content takes instead ``path`` (a video file, a folder of images or
a glob; relative to the scene file's folder), ``fps`` (source frame rate, required),
``brightness`` (radiance of a white pixel, default 0.5), ``srgb`` (decode sRGB to linear,
default true), ``max_frames`` and an optional resize ``height``/``width`` (even; area average
when shrinking, bilinear when enlarging; giving one keeps the aspect ratio, rounded to even).
Without a resize, a source of odd height or width loses its **last row or column**.  Errors
are ``ValueError`` naming the file and the field path (``content.revolutions_per_second``).
"""

from __future__ import annotations

import math
import sys
from dataclasses import asdict, dataclass, field, fields
from functools import cached_property
from pathlib import Path
from typing import ClassVar

import numpy as np
from scipy import sparse

from spikeref.io.frames import read_frames
from spikeref.simulate.camera import Camera
from spikeref.simulate.effects import parse_effects
from spikeref.simulate.motion import Motion, layer_flow
from spikeref.tonemap import srgb_decode

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "SceneContent",
    "Uniform",
    "ColorChart",
    "TranslatingTexture",
    "FanOverToys",
    "HDRLamp",
    "VideoFrames",
    "ImageMotion",
    "CONTENT_TYPES",
    "COLORCHECKER_SRGB",
    "Scene",
    "scene_from_dict",
    "scene_to_dict",
    "load_scene",
]

#: The 24 ColorChecker Classic patches in 8-bit sRGB, row by row (published reference values).
COLORCHECKER_SRGB = (
    (115, 82, 68), (194, 150, 130), (98, 122, 157), (87, 108, 67), (133, 128, 177), (103, 189, 170),
    (214, 126, 44), (80, 91, 166), (193, 90, 99), (94, 60, 108), (157, 188, 64), (224, 163, 46),
    (56, 61, 150), (70, 148, 73), (175, 54, 60), (231, 199, 31), (187, 86, 149), (8, 133, 161),
    (243, 243, 242), (200, 200, 200), (160, 160, 160), (122, 122, 121), (85, 85, 85), (52, 52, 52),
)


# ----------------------------------------------------------------------------- validation
def _is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _number(name: str, value, minimum=None, maximum=None, open_min=False) -> float:
    """``float(value)`` if it is a finite number in range, else ``ValueError`` naming ``content.<name>``."""
    ok = _is_number(value) and math.isfinite(value)
    if ok and minimum is not None:
        ok = value > minimum if open_min else value >= minimum
    if ok and maximum is not None:
        ok = value <= maximum
    if not ok:
        if minimum == 0 and maximum is None:
            what = "positive and finite" if open_min else "finite and ≥ 0"
        elif minimum is None and maximum is None:
            what = "a finite number"
        else:
            lo = "-inf" if minimum is None else minimum
            what = f"a finite number in {'(' if open_min else '['}{lo}, {maximum}]"
        raise ValueError(f"content.{name} must be {what}; got {value!r}")
    return float(value)


def _integer(name: str, value, minimum: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"content.{name} must be an integer ≥ {minimum}; got {value!r}")
    return int(value)


def _even_size(name: str, value) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 2 or value % 2:
        raise ValueError(f"content.{name} must be an even integer ≥ 2 (a Bayer sensor); got {value!r}")
    return int(value)


def _numbers(name: str, value, count: int, what: str, minimum=None) -> tuple:
    """``count`` finite numbers from a sequence, else ``ValueError`` naming ``content.<name>`` and ``what``."""
    try:
        values = tuple(value)
    except TypeError:
        values = ()
    if len(values) != count:
        raise ValueError(f"content.{name} must be {what}; got {value!r}")
    return tuple(_number(name, v, minimum=minimum) for v in values)


def _rgb(name: str, value) -> tuple:
    return _numbers(name, value, 3, "3 values (R, G, B)", minimum=0)


def _xy(name: str, value) -> tuple:
    return _numbers(name, value, 2, "(x, y) in pixels")


def _box(h: int, w: int, cy: float, cx: float, half_h: float, half_w: float) -> tuple:
    """Row and column slices of the pixels whose centres lie within ``half_h``/``half_w`` of ``(cy, cx)``."""
    return (slice(max(0, math.floor(cy - half_h)), max(0, min(h, math.ceil(cy + half_h)))),
            slice(max(0, math.floor(cx - half_w)), max(0, min(w, math.ceil(cx + half_w)))))


def _view_points(h: int, w: int) -> np.ndarray:
    """``(x, y)`` of every pixel of an ``h × w`` view: ``(h, w, 2) float64`` (pixel centres at integers)."""
    yy, xx = np.mgrid[0:h, 0:w]
    return np.stack([xx, yy], axis=-1).astype(np.float64)


def _in_view(points: np.ndarray, h: int, w: int) -> np.ndarray:
    """Whether ``(x, y)`` positions ``(..., 2)`` lie on an ``h × w`` view (pixel centres at integers)."""
    x, y = points[..., 0], points[..., 1]
    return (x >= -0.5) & (x <= w - 0.5) & (y >= -0.5) & (y <= h - 0.5)


def _coverage(signed_distance):
    """Anti-aliased coverage of a shape from its signed distance (pixels, < 0 inside): a 1-pixel ramp."""
    return np.clip(0.5 - signed_distance, 0.0, 1.0)


# ----------------------------------------------------------------------------- content
@dataclass(frozen=True, kw_only=True)
class SceneContent:
    """Base of all content: image size and readout rate; subclasses define :meth:`radiance`.

    Attributes
    ----------
    height, width : int
        Image size in pixels, even (a Bayer sensor).
    rate_hz : float
        Readout rate in readouts per second, used to convert velocities given per second
        (set from the camera by :func:`scene_from_dict`).
    """

    height: int = 256
    width: int = 256
    rate_hz: float = 20000.0
    type_name: ClassVar[str] = ""

    def __post_init__(self):
        object.__setattr__(self, "height", _even_size("height", self.height))
        object.__setattr__(self, "width", _even_size("width", self.width))
        object.__setattr__(self, "rate_hz", _number("rate_hz", self.rate_hz, minimum=0, open_min=True))

    @property
    def static(self) -> bool:
        """True when the radiance does not depend on time (the simulator then renders it once)."""
        return False

    def radiance(self, times) -> np.ndarray:  # pragma: no cover - abstract
        """Linear RGB radiance ``(n, H, W, 3) float32`` (rate units) at ``times`` ``(n,)`` in readouts."""
        raise NotImplementedError

    def true_flow(self, t_ref: float, t_other: float, points: np.ndarray | None = None):
        """Exact backward flow between two times (readouts), or ``None`` where the content has no motion model.

        Returns ``(flow, visible)``: ``flow`` ``(..., 2) float64`` holds ``(dx, dy)`` in pixels such
        that the content seen at ``x`` at ``t_ref`` is at ``x + flow`` at ``t_other``; ``visible``
        ``(...) bool`` is False where that content is hidden or outside the view at ``t_other``.
        ``points`` ``(..., 2)`` of ``(x, y)`` (default: every pixel) says where to evaluate it.
        Static content has zero flow; moving contents with a motion model override this.
        """
        if not self.static:
            return None
        pts = _view_points(self.height, self.width) if points is None else np.asarray(points, dtype=np.float64)
        return np.zeros(pts.shape, np.float64), np.ones(pts.shape[:-1], bool)

    @staticmethod
    def _times(times) -> np.ndarray:
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
        if t.ndim != 1:
            raise ValueError(f"times must be a 1-D array of readouts; got shape {t.shape}")
        if not np.all(np.isfinite(t)):
            raise ValueError("times must be finite")
        return t

    @staticmethod
    def _repeat(image: np.ndarray, n: int) -> np.ndarray:
        return np.broadcast_to(image, (n,) + image.shape).copy()


@dataclass(frozen=True, kw_only=True)
class Uniform(SceneContent):
    """A flat field: every pixel has radiance ``brightness · color`` (static).

    Attributes
    ----------
    brightness : float
        Radiance of a white surface (rate units, ≥ 0).
    color : tuple of 3 floats
        Linear reflectance per channel (≥ 0).
    """

    brightness: float = 0.5
    color: tuple = (1.0, 1.0, 1.0)
    type_name: ClassVar[str] = "uniform"

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "brightness", _number("brightness", self.brightness, minimum=0))
        object.__setattr__(self, "color", _rgb("color", self.color))

    @property
    def static(self) -> bool:
        return True

    def radiance(self, times) -> np.ndarray:
        image = np.empty((self.height, self.width, 3), dtype=np.float32)
        image[...] = np.asarray(self.color, dtype=np.float32) * np.float32(self.brightness)
        return self._repeat(image, self._times(times).size)


@dataclass(frozen=True, kw_only=True)
class ColorChart(SceneContent):
    """The 24 ColorChecker colours, 4 rows × 6 patches, on a dark board (static).

    Patch colours are the published 8-bit sRGB values (:data:`COLORCHECKER_SRGB`) decoded to
    linear with :func:`spikeref.tonemap.srgb_decode` and scaled so that the white patch has
    reflectance 0.9, i.e. radiance ``0.9 · brightness``.  Each patch fills the central 80 % of
    its ``H/4 × W/6`` cell, with anti-aliased edges.

    Attributes
    ----------
    brightness : float
        Radiance of a white surface (rate units, ≥ 0).
    board : float
        Linear reflectance of the board between the patches, in [0, 1].
    """

    brightness: float = 0.5
    board: float = 0.03
    type_name: ClassVar[str] = "color_chart"

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "brightness", _number("brightness", self.brightness, minimum=0))
        object.__setattr__(self, "board", _number("board", self.board, minimum=0, maximum=1))

    @property
    def static(self) -> bool:
        return True

    @staticmethod
    def patch_reflectances() -> np.ndarray:
        """Linear reflectance of the 24 patches, ``(4, 6, 3) float64`` (white patch 0.9)."""
        patches = srgb_decode(np.asarray(COLORCHECKER_SRGB, dtype=np.float64) / 255.0).reshape(4, 6, 3)
        return patches * (0.9 / patches[3, 0].max())

    @property
    def patch_centers(self) -> np.ndarray:
        """Centre of each patch in pixel coordinates ``(4, 6, 2)`` as (row, column); pixel ``i`` spans [i, i+1)."""
        rows = (np.arange(4) + 0.5) * self.height / 4.0
        cols = (np.arange(6) + 0.5) * self.width / 6.0
        return np.stack(np.broadcast_arrays(rows[:, None], cols[None, :]), axis=-1)

    @cached_property
    def _image(self) -> np.ndarray:
        h, w = self.height, self.width
        patches = self.patch_reflectances()
        img = np.full((h, w, 3), self.board, dtype=np.float64)
        cell_h, cell_w = h / 4.0, w / 6.0
        for r in range(4):
            for c in range(6):
                cy, cx = (r + 0.5) * cell_h, (c + 0.5) * cell_w
                box = _box(h, w, cy, cx, 0.4 * cell_h + 1, 0.4 * cell_w + 1)  # the patch and its edge ramp
                yy = np.arange(h)[box[0], None] + 0.5
                xx = np.arange(w)[None, box[1]] + 0.5
                sd = np.maximum(np.abs(yy - cy) - 0.4 * cell_h, np.abs(xx - cx) - 0.4 * cell_w)
                cov = _coverage(sd)[..., None]
                img[box] = img[box] * (1 - cov) + patches[r, c] * cov
        return (img * self.brightness).astype(np.float32)

    def radiance(self, times) -> np.ndarray:
        return self._repeat(self._image, self._times(times).size)


def _fractal_texture(size: int, rng: np.random.Generator) -> np.ndarray:
    """A periodic ``(size, size, 3)`` colour reflectance in [0.05, 0.95]: 1/f noise plus hard-edged shapes.

    The noise is made in the Fourier domain (amplitude ∝ 1/f^1.6, random phases), so it tiles
    exactly; the discs and bars are drawn on the torus, so they tile too.
    """
    fy = np.fft.fftfreq(size)[:, None]
    fx = np.fft.fftfreq(size)[None, :]
    f = np.sqrt(fy**2 + fx**2)
    f[0, 0] = 1.0
    amp = 1.0 / f**1.6
    amp[0, 0] = 0.0
    chans = []
    for _ in range(3):
        phase = np.exp(2j * np.pi * rng.random((size, size)))
        noise = np.real(np.fft.ifft2(amp * phase))
        chans.append((noise - noise.mean()) / noise.std())
    mix = np.array([[0.8, 0.2, 0.0], [0.1, 0.8, 0.1], [0.0, 0.3, 0.7]])  # correlated channels, as in nature
    tex = 0.5 + 0.17 * (np.stack(chans, axis=-1) @ mix.T)
    yy, xx = np.mgrid[0:size, 0:size] + 0.5
    for _ in range(max(4, size // 24)):
        cy, cx = rng.random(2) * size
        dy = (yy - cy + size / 2) % size - size / 2  # shortest offset on the torus
        dx = (xx - cx + size / 2) % size - size / 2
        color = rng.random(3) ** 1.5
        if rng.random() < 0.5:
            sd = np.hypot(dy, dx) - rng.uniform(0.03, 0.09) * size
        else:
            sd = np.maximum(np.abs(dy) - rng.uniform(0.02, 0.1) * size, np.abs(dx) - rng.uniform(0.01, 0.05) * size)
        cov = _coverage(sd)[..., None]
        tex = tex * (1 - cov) + color * cov
    return np.clip(tex, 0.05, 0.95)


@dataclass(frozen=True, kw_only=True)
class TranslatingTexture(SceneContent):
    """A periodic procedural colour texture translating at a constant velocity.

    The radiance of pixel ``(y, x)`` at time ``t`` is the texture at ``(y − v_y t, x − v_x t)``
    (the content moves by ``+v``; ``+v_y`` is downwards), sampled bilinearly with wrap-around.
    When ``v t`` is a whole number of pixels the image is the texture shifted exactly.

    Attributes
    ----------
    brightness : float
        Radiance of a white surface (rate units, ≥ 0); the texture's reflectance is in [0.05, 0.95].
    velocity : tuple ``(v_x, v_y)``
        Pixels per second (2000 px/s = 1 px per 10 readouts at 20 kHz).
    texture_size : int
        Side of the square periodic texture in pixels (≥ 8); larger images repeat it.
    seed : int
        Seed of the procedural texture (not of the sensor noise).
    """

    brightness: float = 0.5
    velocity: tuple = (2000.0, 600.0)
    texture_size: int = 256
    seed: int = 0
    type_name: ClassVar[str] = "translating_texture"

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "brightness", _number("brightness", self.brightness, minimum=0))
        try:
            v = tuple(self.velocity)
        except TypeError:
            v = ()
        if len(v) != 2:
            raise ValueError(f"content.velocity must be (v_x, v_y) in pixels/second; got {self.velocity!r}")
        object.__setattr__(self, "velocity", tuple(_number("velocity", c) for c in v))
        object.__setattr__(self, "texture_size", _integer("texture_size", self.texture_size, 8))
        object.__setattr__(self, "seed", _integer("seed", self.seed, 0))

    @property
    def static(self) -> bool:
        return self.velocity == (0.0, 0.0)

    def true_flow(self, t_ref: float, t_other: float, points: np.ndarray | None = None):
        """The exact flow of a translation: ``v (t_other − t_ref)`` everywhere (see :meth:`SceneContent.true_flow`)."""
        pts = _view_points(self.height, self.width) if points is None else np.asarray(points, dtype=np.float64)
        d = np.asarray(self.velocity) * (float(t_other) - float(t_ref)) / self.rate_hz
        flow = np.broadcast_to(d, pts.shape).copy()
        target = pts + flow
        return flow, _in_view(target, self.height, self.width)

    @cached_property
    def texture(self) -> np.ndarray:
        """The periodic reflectance texture ``(S, S, 3) float64``, ``S = texture_size``."""
        return _fractal_texture(self.texture_size, np.random.default_rng(self.seed))

    @cached_property
    def _tiled(self) -> np.ndarray:
        # radiance of the texture tiled to (S + H + 1, S + W + 1): every integer shift is a slice
        s = self.texture_size
        reps = (-(-(s + self.height + 1) // s), -(-(s + self.width + 1) // s), 1)
        tiled = np.tile((self.texture * self.brightness).astype(np.float32), reps)
        return np.ascontiguousarray(tiled[: s + self.height + 1, : s + self.width + 1])

    def radiance(self, times) -> np.ndarray:
        t = self._times(times)
        tiled = self._tiled
        s, h, w = self.texture_size, self.height, self.width
        vx, vy = self.velocity
        out = np.empty((t.size, h, w, 3), dtype=np.float32)
        for i, ti in enumerate(t):
            # sample position of pixel (y, x) is (y + sy, x + sx): one integer offset and one weight per axis
            sy, sx = -vy * ti / self.rate_hz, -vx * ti / self.rate_hz
            iy, ix = math.floor(sy), math.floor(sx)
            fy, fx = np.float32(sy - iy), np.float32(sx - ix)
            y0, x0 = iy % s, ix % s
            band = tiled[y0:y0 + h, x0:x0 + w + 1]
            if fy:
                band = band * (1 - fy) + tiled[y0 + 1:y0 + h + 1, x0:x0 + w + 1] * fy
            if fx:
                np.multiply(band[:, :w], 1 - fx, out=out[i])
                out[i] += band[:, 1:] * fx
            else:
                out[i] = band[:, :w]
        return out


def _toys_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """A still life of colourful procedural toys on a soft gradient: reflectance ``(h, w, 3)`` in [0.02, 0.95]."""
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    gy, gx = yy / h, xx / w
    img = np.stack([0.35 + 0.25 * gx, 0.3 + 0.2 * (1 - gy), 0.45 - 0.2 * gx * gy], axis=-1)
    palette = np.array([[0.85, 0.1, 0.08], [0.95, 0.75, 0.05], [0.1, 0.55, 0.15], [0.08, 0.25, 0.8],
                        [0.75, 0.2, 0.65], [0.95, 0.45, 0.05], [0.1, 0.7, 0.75], [0.9, 0.9, 0.85]])
    scale = min(h, w)
    for k in range(14):
        color = palette[rng.integers(len(palette))]
        cy, cx = rng.uniform(0.05, 0.95) * h, rng.uniform(0.05, 0.95) * w
        size = rng.uniform(0.06, 0.16) * scale
        box = _box(h, w, cy, cx, 1.1 * size + 1, 1.1 * size + 1)  # every toy lies within 1.02 · size
        dy, dx = yy[box] - cy, xx[box] - cx
        kind = k % 5
        if kind == 0:  # ball, shaded as if lit from the top left
            d = np.hypot(dy, dx)
            cov = _coverage(d - size)
            shade = np.clip(1.15 - 0.6 * np.hypot(dy + 0.4 * size, dx + 0.4 * size) / size, 0.35, 1.15)
            layer = color * shade[..., None]
        elif kind == 1:  # block
            cov = _coverage(np.maximum(np.abs(dy) - size * 0.8, np.abs(dx) - size * 0.6))
            layer = np.broadcast_to(color, dy.shape + (3,))
        elif kind == 2:  # ring
            d = np.hypot(dy, dx)
            cov = _coverage(np.abs(d - size * 0.8) - size * 0.22)
            layer = np.broadcast_to(color, dy.shape + (3,))
        elif kind == 3:  # box with diagonal stripes
            cov = _coverage(np.maximum(np.abs(dy) - size * 0.7, np.abs(dx) - size * 0.9))
            stripes = (np.floor((dx + dy) / max(2.0, size / 4)) % 2)[..., None]
            layer = color * (0.35 + 0.65 * stripes) + (1 - stripes) * 0.05
        else:  # checked cube
            cov = _coverage(np.maximum(np.abs(dy), np.abs(dx)) - size * 0.75)
            check = ((np.floor(dy / max(2.0, size / 3)) + np.floor(dx / max(2.0, size / 3))) % 2)[..., None]
            layer = color * check + (1 - check) * np.array([0.92, 0.92, 0.88])
        cov = cov[..., None]
        img[box] = img[box] * (1 - cov) + layer * cov
    return np.clip(img, 0.02, 0.95)


@dataclass(frozen=True)
class _FanLayers:
    """What a fan renders from, precomputed once: the background and maps over the fan's bounding box."""

    background: np.ndarray  # (H, W, 3) float32 radiance of the toys
    box: tuple  # (row slice, column slice) outside which the fan never covers anything
    background_planes: np.ndarray  # (3, h, w) float32 background inside the box, one plane per channel
    r: np.ndarray  # (h, w) float32 distance to the axis, pixels
    theta: np.ndarray  # (h, w) float64 angle, counter-clockwise on screen, radians
    half: np.ndarray  # (h, w) float32 angular half-width of a blade at this radius, radians
    radial: np.ndarray  # (h, w) float32 coverage of the blades' annulus
    hub: np.ndarray  # (h, w) float32 coverage of the hub
    blade_rgb: np.ndarray  # (3,) float32 blade radiance
    hub_rgb: np.ndarray  # (3,) float32 hub radiance


@dataclass(frozen=True, kw_only=True)
class FanOverToys(SceneContent):
    """A fast rotating fan over a still, colourful background of toys (the paper's Fig. 7a).

    The fan turns about the image centre; its blades are opaque, widen from the hub to the
    tip and have anti-aliased edges (1-pixel coverage ramp from the signed distance).  The
    background (balls, blocks, rings, striped and checked boxes in saturated colours on a soft
    gradient) does not move; outside the blade tips it never changes.

    Attributes
    ----------
    brightness : float
        Radiance of a white surface (rate units, ≥ 0).
    revolutions_per_second : float
        Rotation speed; positive turns counter-clockwise on screen, negative clockwise, 0 is still.
    blades : int
        Number of blades (≥ 1).
    radius : float
        Blade tip radius as a fraction of ``min(height, width)``, in (0, 1].
    hub : float
        Hub radius as a fraction of the tip radius, in [0, 1].
    blade_width : float
        Angular half-width of a blade at its tip as a fraction of ``π / blades``, in (0, 1].
    blade_color, hub_color : tuple of 3 floats
        Linear reflectance of the blades and of the hub.
    seed : int
        Seed of the toys' layout (not of the sensor noise).
    """

    brightness: float = 0.5
    revolutions_per_second: float = 25.0
    blades: int = 4
    radius: float = 0.42
    hub: float = 0.18
    blade_width: float = 0.45
    blade_color: tuple = (0.8, 0.8, 0.78)
    hub_color: tuple = (0.12, 0.12, 0.14)
    seed: int = 0
    type_name: ClassVar[str] = "fan"

    def __post_init__(self):
        super().__post_init__()
        setattr_ = object.__setattr__
        setattr_(self, "brightness", _number("brightness", self.brightness, minimum=0))
        setattr_(self, "revolutions_per_second", _number("revolutions_per_second", self.revolutions_per_second))
        setattr_(self, "blades", _integer("blades", self.blades, 1))
        setattr_(self, "radius", _number("radius", self.radius, minimum=0, maximum=1, open_min=True))
        setattr_(self, "hub", _number("hub", self.hub, minimum=0, maximum=1))
        setattr_(self, "blade_width", _number("blade_width", self.blade_width, minimum=0, maximum=1, open_min=True))
        setattr_(self, "blade_color", _rgb("blade_color", self.blade_color))
        setattr_(self, "hub_color", _rgb("hub_color", self.hub_color))
        setattr_(self, "seed", _integer("seed", self.seed, 0))

    @property
    def static(self) -> bool:
        return self.revolutions_per_second == 0

    @property
    def period_readouts(self) -> float:
        """Readouts per revolution (``inf`` when still); the image repeats every ``period / blades``."""
        rps = abs(self.revolutions_per_second)
        return math.inf if rps == 0 else self.rate_hz / rps

    @property
    def tip_radius(self) -> float:
        """Blade tip radius in pixels; beyond ``tip_radius + 1`` from the centre the fan covers nothing."""
        return self.radius * min(self.height, self.width)

    @cached_property
    def background(self) -> np.ndarray:
        """The still toys, radiance ``(H, W, 3) float32``."""
        return self._layers.background

    @cached_property
    def _layers(self) -> _FanLayers:
        h, w = self.height, self.width
        bg = (_toys_background(h, w, np.random.default_rng(self.seed)) * self.brightness).astype(np.float32)
        yy, xx = np.mgrid[0:h, 0:w] + 0.5
        r, theta, half, radial, hub_cov = self._geometry(yy, xx)
        rows, cols = np.nonzero((radial > 0) | (hub_cov > 0))
        if rows.size:
            box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
        else:  # pragma: no cover - a fan always covers its centre pixels
            box = (slice(0, 0), slice(0, 0))
        f32 = np.float32
        return _FanLayers(
            background=bg, box=box,
            background_planes=np.ascontiguousarray(bg[box].transpose(2, 0, 1)),
            r=r[box].astype(f32), theta=np.ascontiguousarray(theta[box]), half=half[box].astype(f32),
            radial=radial[box].astype(f32), hub=hub_cov[box].astype(f32),
            blade_rgb=(np.asarray(self.blade_color) * self.brightness).astype(f32),
            hub_rgb=(np.asarray(self.hub_color) * self.brightness).astype(f32),
        )

    def _fan_coverage(self, x: np.ndarray, y: np.ndarray, t: float) -> np.ndarray:
        """Coverage (0…1) of the fan (blades or hub) at view points ``(x, y)`` (pixel centres at integers) at time
        ``t`` (readouts), by the formulas :meth:`radiance` draws with."""
        r, theta, half, radial, hub_cov = self._geometry(y + 0.5, x + 0.5)
        sector = 2 * np.pi / self.blades
        omega = 2 * np.pi * self.revolutions_per_second / self.rate_hz
        rel = np.mod(theta - omega * t, sector) - sector / 2
        blade = _coverage((np.abs(rel) - half) * r) * radial
        return np.maximum(blade, hub_cov)

    def _geometry(self, yy: np.ndarray, xx: np.ndarray) -> tuple:
        """At image positions ``(yy, xx)`` (pixel corners at integers): the radius and angle about the centre
        (counter-clockwise on screen, row 0 at the top), a blade's angular half-width there, the blades' radial
        coverage (hub to tip) and the hub's coverage."""
        cy, cx = self.height / 2.0, self.width / 2.0
        r = np.hypot(yy - cy, xx - cx)
        theta = np.arctan2(-(yy - cy), xx - cx)
        tip = self.tip_radius
        hub = self.hub * tip
        sector = 2 * np.pi / self.blades
        half = self.blade_width * (sector / 2) * (0.4 + 0.6 * np.clip(r / tip, 0, 1))  # 40 % at the axis
        radial = _coverage(np.maximum(r - tip, hub * 0.5 - r))
        return r, theta, half, radial, _coverage(r - hub)

    def true_flow(self, t_ref: float, t_other: float, points: np.ndarray | None = None):
        """The exact flow of the fan (see :meth:`SceneContent.true_flow`): a point covered by the fan at ``t_ref``
        (coverage ≥ ½) turns with it about the centre; a point of the background stays, and is hidden at
        ``t_other`` where the fan covers it then.  The blades are rigid: what they show stays visible."""
        pts = _view_points(self.height, self.width) if points is None else np.asarray(points, dtype=np.float64)
        x, y = pts[..., 0], pts[..., 1]
        cy, cx = self.height / 2.0 - 0.5, self.width / 2.0 - 0.5  # the centre in view coordinates
        dt = float(t_other) - float(t_ref)
        angle = 2 * np.pi * self.revolutions_per_second / self.rate_hz * dt  # counter-clockwise on screen
        ux, uy = x - cx, -(y - cy)
        rx = ux * np.cos(angle) - uy * np.sin(angle)
        ry = ux * np.sin(angle) + uy * np.cos(angle)
        on_fan = self._fan_coverage(x, y, float(t_ref)) >= 0.5
        flow = np.zeros(pts.shape, np.float64)
        flow[..., 0] = np.where(on_fan, cx + rx - x, 0.0)
        flow[..., 1] = np.where(on_fan, cy - ry - y, 0.0)
        target = pts + flow
        hidden = ~on_fan & (self._fan_coverage(x, y, float(t_other)) >= 0.5)
        return flow, _in_view(target, self.height, self.width) & ~hidden

    def radiance(self, times) -> np.ndarray:
        t = self._times(times)
        lay = self._layers
        sector = 2 * np.pi / self.blades
        omega = 2 * np.pi * self.revolutions_per_second / self.rate_hz  # radians per readout
        out = np.empty((t.size, self.height, self.width, 3), dtype=np.float32)
        out[...] = lay.background
        for i, ti in enumerate(t):
            # angle from the nearest blade's centre line: the only per-time work is this wrapped offset
            rel = np.mod(lay.theta - omega * ti, sector)
            rel -= sector / 2
            dist = np.abs(rel.astype(np.float32))
            dist -= lay.half
            dist *= lay.r  # ≈ distance in pixels from the blade's edge (< 0 inside)
            blade = _coverage(dist) * lay.radial
            cov = np.maximum(blade, lay.hub)
            on_hub = lay.hub >= blade
            keep = 1 - cov
            box = out[i][lay.box]
            for k in range(3):  # per channel: 2-D operations are much faster than (h, w, 3) broadcasting
                box[..., k] = lay.background_planes[k] * keep + np.where(on_hub, lay.hub_rgb[k], lay.blade_rgb[k]) * cov
        return out


@dataclass(frozen=True, kw_only=True)
class HDRLamp(SceneContent):
    """A lit lamp beside a deep shadow that still holds detail, mid-tones between (static).

    A warm wall with soft vertical panels (radiance about ``0.5–0.7 · brightness``); on the
    left a lamp, a disc of radiance ``lamp`` with an exponential glow; on the right an occluded
    alcove (:attr:`shadow_mask`) whose radiance is ``shadow`` times a pattern of stripes and a
    disc between 0.5 and 1.5 (times a slight blue tint, 0.9–1.1).  The ratio of the lamp to the
    darkest shadow pixel is ``lamp / (0.45 · shadow)`` (4 × 10⁴ with the defaults).

    Attributes
    ----------
    brightness : float
        Radiance of a white surface of the wall (rate units, ≥ 0).
    lamp : float
        Radiance of the lamp (rate units, > 0; keep it < 1 so it does not saturate).
    shadow : float
        Mean radiance in the alcove (rate units, > 0).
    """

    brightness: float = 0.08
    lamp: float = 0.9
    shadow: float = 5e-5
    type_name: ClassVar[str] = "hdr_lamp"

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "brightness", _number("brightness", self.brightness, minimum=0))
        object.__setattr__(self, "lamp", _number("lamp", self.lamp, minimum=0, open_min=True))
        object.__setattr__(self, "shadow", _number("shadow", self.shadow, minimum=0, open_min=True))

    @property
    def static(self) -> bool:
        return True

    @property
    def shadow_mask(self) -> np.ndarray:
        """Pixels of the deep-shadow alcove, ``(H, W) bool``."""
        return self._layers[1]

    @cached_property
    def _layers(self):
        h, w = self.height, self.width
        yy, xx = np.mgrid[0:h, 0:w] + 0.5
        wall = np.stack([0.75 + 0.1 * xx / w, 0.6 + 0.05 * yy / h, 0.45 * np.ones_like(xx)], axis=-1)
        wall *= (0.7 + 0.3 * (np.floor(xx / max(2, w // 8)) % 2))[..., None]
        img = wall * self.brightness
        ly, lx, lr = 0.4 * h, 0.25 * w, 0.09 * min(h, w)  # the lamp and its glow
        d = np.hypot(yy - ly, xx - lx)
        glow = 0.15 * self.lamp * np.exp(-np.maximum(d - lr, 0) / (0.12 * min(h, w)))
        img = img + glow[..., None] * np.array([1.0, 0.85, 0.6])
        cov = _coverage(d - lr)[..., None]
        img = img * (1 - cov) + self.lamp * np.array([1.0, 0.97, 0.9]) * cov
        x0, y0, y1 = 0.62 * w, 0.2 * h, 0.85 * h  # the alcove, with stripes and a disc (±50 %)
        inside = (xx >= x0) & (yy >= y0) & (yy < y1)
        stripes = 0.5 + (np.floor((xx - x0) / max(2, w // 32)) % 2)
        disc = np.hypot(yy - 0.55 * h, xx - 0.8 * w) < 0.08 * min(h, w)
        detail = np.where(disc, 1.5 - 0.5 * (stripes - 0.5), stripes)
        tint = np.array([0.9, 1.0, 1.1])
        img = np.where(inside[..., None], self.shadow * detail[..., None] * tint, img)
        return img.astype(np.float32), inside

    def radiance(self, times) -> np.ndarray:
        return self._repeat(self._layers[0], self._times(times).size)


@dataclass(frozen=True, kw_only=True)
class VideoFrames(SceneContent):
    """Frames of a video or image sequence, interpolated linearly in time to the readout rate.

    Readout time ``t`` is source time ``s = t · fps / rate_hz`` (in source frames, frame ``k``
    at ``s = k``); the radiance is ``(1 − f) · frames[⌊s⌋] + f · frames[⌊s⌋ + 1]`` with
    ``f = s − ⌊s⌋``, and holds the first frame before ``s = 0`` and the last after ``s = N − 1``.
    ``height`` and ``width`` come from the frames.  No file is read here: a scene file's
    ``video`` content is read, decoded and scaled by :func:`scene_from_dict`.

    Attributes
    ----------
    frames : ndarray ``(N, H, W, 3)``
        Linear radiance of each source frame (rate units, already scaled; finite, ≥ 0); kept
        as a read-only ``float32`` array.  Not part of equality.
    fps : float
        Source frame rate (frames per second, > 0).
    source : str
        The file, folder or glob the frames were read from ("" when built from an array).
    source_options : tuple of (key, value)
        The scene-file options used to read ``source`` (brightness, srgb, ...), for :func:`scene_to_dict`.
    """

    height: int = field(default=0, init=False)
    width: int = field(default=0, init=False)
    frames: np.ndarray = field(repr=False, compare=False)
    fps: float
    source: str = ""
    source_options: tuple = ()
    type_name: ClassVar[str] = "video"

    def __post_init__(self):
        frames = np.asarray(self.frames)
        if frames.ndim != 4 or frames.shape[-1] != 3 or frames.shape[0] < 1:
            raise ValueError(f"content.frames must have shape (N, H, W, 3) with N ≥ 1; got {frames.shape}")
        frames = np.ascontiguousarray(frames, dtype=np.float32).view()
        frames.flags.writeable = False
        if not np.all(np.isfinite(frames)) or frames.min() < 0:
            raise ValueError("content.frames must be finite and ≥ 0 (linear radiance)")
        object.__setattr__(self, "frames", frames)
        object.__setattr__(self, "height", int(frames.shape[1]))
        object.__setattr__(self, "width", int(frames.shape[2]))
        super().__post_init__()
        object.__setattr__(self, "fps", _number("fps", self.fps, minimum=0, open_min=True))

    @property
    def static(self) -> bool:
        return self.frames.shape[0] == 1

    def radiance(self, times) -> np.ndarray:
        t = self._times(times)
        last = self.frames.shape[0] - 1
        s = np.clip(t * self.fps / self.rate_hz, 0.0, last)
        out = np.empty((t.size, self.height, self.width, 3), dtype=np.float32)
        for i, si in enumerate(s):
            k = int(math.floor(si))
            f = np.float32(si - k)
            if f:
                np.multiply(self.frames[k], 1 - f, out=out[i])
                out[i] += self.frames[k + 1] * f
            else:
                out[i] = self.frames[k]
        return out


def _reflect_index(i: np.ndarray, n: int) -> np.ndarray:
    """Index ``i`` folded into ``[0, n)`` by half-sample symmetric mirroring (``-1 → 0``, ``n → n − 1``)."""
    r = np.mod(i, 2 * n)
    return np.where(r >= n, 2 * n - 1 - r, r)


def _sample_bilinear(image: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """``image`` ``(h, w, 3)`` at continuous ``(x, y)`` positions ``(..., 2)``: bilinear, mirrored beyond the border.

    Pixel ``(row, col)`` has its centre at ``(x, y) = (col, row)``.  The result is ``(..., 3) float32``.
    """
    h, w = image.shape[:2]
    x, y = xy[..., 0], xy[..., 1]
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None].astype(np.float32), (y - y0)[..., None].astype(np.float32)
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    xa, xb = _reflect_index(x0, w), _reflect_index(x0 + 1, w)
    ya, yb = _reflect_index(y0, h), _reflect_index(y0 + 1, h)
    top = image[ya, xa] * (1 - fx) + image[ya, xb] * fx
    bottom = image[yb, xa] * (1 - fx) + image[yb, xb] * fx
    return top * (1 - fy) + bottom * fy


@dataclass(frozen=True, kw_only=True)
class ImageMotion(SceneContent):
    """A photograph moving in front of the camera, optionally with a second layer occluding it.

    The background is ``image`` moved by ``motion`` (:class:`~spikeref.simulate.motion.Motion`:
    translation, rotation and zoom about a point, affine); the view's pixel ``(row, col)`` shows
    at time ``t`` the image at ``origin + motion⁻¹(t)(col, row)``, sampled bilinearly, with the
    image mirrored beyond its border (so the view never runs out of content).  A foreground
    layer, when given, is a disc of radius ``fg_radius`` cut out of ``fg_image`` around
    ``fg_source_center``, placed with its centre at ``fg_center`` (view pixels) at time 0 and
    moved by ``fg_motion``; its edge is anti-aliased over one pixel and it hides the background.

    The exact backward flow between any two times, on the full-resolution or the Bayer-plane
    grid, and where a layer is hidden, is :meth:`true_flow`.

    Attributes
    ----------
    image : ndarray ``(h, w, 3)``
        Linear radiance of the background photograph (rate units, already scaled; finite, ≥ 0;
        kept read-only ``float32``).  Not part of equality.
    origin : tuple ``(x, y)`` or None
        Image position of the view's pixel ``(0, 0)`` at time 0; ``None``: the view is centred
        on the image.
    motion : Motion
        The background's motion; its ``center`` defaults to the view's centre.
    fg_image : ndarray ``(h', w', 3)`` or None
        The foreground photograph (linear radiance); ``None``: one layer only.
    fg_radius : float
        Radius of the foreground disc in pixels (> 0 with a foreground).
    fg_center : tuple ``(x, y)`` or None
        Centre of the disc in view pixels at time 0 (``None``: the view's centre).
    fg_source_center : tuple ``(x, y)`` or None
        The point of ``fg_image`` shown at the disc's centre (``None``: the image's centre).
    fg_motion : Motion
        The foreground's motion; its ``center`` defaults to the disc's centre.
    source, source_options :
        What the images were read from, for :func:`scene_to_dict` (``""`` when built from arrays).
    """

    image: np.ndarray = field(repr=False, compare=False)
    origin: tuple | None = None
    motion: Motion = field(default_factory=Motion)
    fg_image: np.ndarray | None = field(default=None, repr=False, compare=False)
    fg_radius: float = 0.0
    fg_center: tuple | None = None
    fg_source_center: tuple | None = None
    fg_motion: Motion = field(default_factory=Motion)
    source: str = ""
    source_options: tuple = ()
    type_name: ClassVar[str] = "image"

    @staticmethod
    def _radiance_array(name: str, a) -> np.ndarray:
        a = np.asarray(a)
        if a.ndim != 3 or a.shape[-1] != 3 or a.shape[0] < 2 or a.shape[1] < 2:
            raise ValueError(f"content.{name} must have shape (h, w, 3) with h, w ≥ 2; got {a.shape}")
        a = np.ascontiguousarray(a, dtype=np.float32).view()
        a.flags.writeable = False
        if not np.all(np.isfinite(a)) or a.min() < 0:
            raise ValueError(f"content.{name} must be finite and ≥ 0 (linear radiance)")
        return a

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "image", self._radiance_array("image", self.image))
        view_centre = ((self.width - 1) / 2.0, (self.height - 1) / 2.0)
        if self.origin is None:
            ih, iw = self.image.shape[:2]
            origin = ((iw - self.width) / 2.0, (ih - self.height) / 2.0)
        else:
            origin = self.origin
        object.__setattr__(self, "origin", _numbers("origin", origin, 2, "(x, y) in image pixels"))
        motion = Motion.from_table(self.motion, "content.motion")
        object.__setattr__(self, "motion", motion.with_center(view_centre))
        if self.fg_image is None:
            if self.fg_radius or self.fg_center is not None or self.fg_source_center is not None:
                raise ValueError("content.foreground fields were given without a foreground image")
            object.__setattr__(self, "fg_motion", Motion.from_table(self.fg_motion, "content.foreground.motion"))
            return
        fg = self._radiance_array("fg_image", self.fg_image)
        object.__setattr__(self, "fg_image", fg)
        object.__setattr__(self, "fg_radius", _number("foreground.radius", self.fg_radius, minimum=0,
                                                         open_min=True))
        centre = view_centre if self.fg_center is None else _xy("foreground.center", self.fg_center)
        source_centre = ((fg.shape[1] - 1) / 2.0, (fg.shape[0] - 1) / 2.0) if self.fg_source_center is None \
            else _xy("foreground.source_center", self.fg_source_center)
        object.__setattr__(self, "fg_center", centre)
        object.__setattr__(self, "fg_source_center", source_centre)
        fg_motion = Motion.from_table(self.fg_motion, "content.foreground.motion")
        object.__setattr__(self, "fg_motion", fg_motion.with_center(centre))

    @property
    def static(self) -> bool:
        return self.motion.static and (self.fg_image is None or self.fg_motion.static)

    @cached_property
    def _view_points(self) -> np.ndarray:
        return _view_points(self.height, self.width)

    def _fg_coverage(self, points: np.ndarray, seconds: float) -> tuple:
        """Foreground coverage in [0, 1] at view ``points`` and the layer positions at time 0."""
        q = self.fg_motion.inverse(points, seconds)
        d = np.hypot(q[..., 0] - self.fg_center[0], q[..., 1] - self.fg_center[1]) - self.fg_radius
        return _coverage(d), q

    def radiance(self, times) -> np.ndarray:
        t = self._times(times)
        pts = self._view_points
        origin = np.asarray(self.origin)
        out = np.empty((t.size, self.height, self.width, 3), dtype=np.float32)
        for i, ti in enumerate(t):
            s = ti / self.rate_hz
            out[i] = _sample_bilinear(self.image, self.motion.inverse(pts, s) + origin)
            if self.fg_image is not None:
                cov, q = self._fg_coverage(pts, s)
                inside = cov > 0
                if np.any(inside):
                    shift = np.asarray(self.fg_source_center) - np.asarray(self.fg_center)
                    fg = _sample_bilinear(self.fg_image, q[inside] + shift)
                    a = cov[inside][:, None].astype(np.float32)
                    out[i][inside] = a * fg + (1 - a) * out[i][inside]
        return out

    def true_flow(self, t_ref: float, t_other: float, points: np.ndarray | None = None) -> tuple:
        """Exact backward flow from time ``t_ref`` to ``t_other`` (readouts) and where it holds.

        Parameters
        ----------
        t_ref, t_other : float
            Times in readouts (fractions allowed).
        points : ndarray ``(..., 2)`` of ``(x, y)``, optional
            Where to evaluate it (full-resolution pixels); default every pixel of the view.
            :func:`~spikeref.simulate.motion.plane_grid_points` gives the Bayer-plane grid.

        Returns
        -------
        flow : ndarray ``(..., 2) float64``
            ``(dx, dy)`` in full-resolution pixels: the content seen at ``x`` at ``t_ref`` is at
            ``x + flow`` at ``t_other``.  Where the foreground covers at least half of a pixel at
            ``t_ref`` it is the foreground's flow, elsewhere the background's.
        visible : ndarray ``(...) bool``
            False where that content is hidden at ``t_other`` (the other layer covers the target)
            or leaves the view.
        """
        pts = self._view_points if points is None else np.asarray(points, dtype=np.float64)
        s0, s1 = t_ref / self.rate_hz, t_other / self.rate_hz
        flow = layer_flow(self.motion, pts, s0, s1)
        if self.fg_image is not None:
            is_fg = self._fg_coverage(pts, s0)[0] >= 0.5
            flow = np.where(is_fg[..., None], layer_flow(self.fg_motion, pts, s0, s1), flow)
            fg_there = self._fg_coverage(pts + flow, s1)[0] >= 0.5
            visible = fg_there == is_fg
        else:
            visible = np.ones(pts.shape[:-1], dtype=bool)
        target = pts + flow
        return flow, visible & _in_view(target, self.height, self.width)




#: Content classes by their ``type`` in scene files.
CONTENT_TYPES = {cls.type_name: cls for cls in (Uniform, ColorChart, TranslatingTexture, FanOverToys, HDRLamp,
                                                 VideoFrames, ImageMotion)}


# ----------------------------------------------------------------------------- scene
@dataclass(frozen=True)
class Scene:
    """What the simulator looks at, with which camera and which effects.

    Attributes
    ----------
    name : str
    content : SceneContent
        Radiance over time; its ``rate_hz`` must equal the camera's.
    planes : int
        Readouts to simulate (≥ 1).
    camera : Camera
        Eq. 1–3 parameters (threshold, α, readout rate, CFA, sub-steps).
    effects : dict
        ``{name: effect}`` as made by :func:`spikeref.simulate.effects.parse_effects` (a raw
        ``{name: {param: value}}`` table is parsed); empty for a noise-free scene.
    description : str
    """

    name: str
    content: SceneContent
    planes: int
    camera: Camera = field(default_factory=Camera)
    effects: dict = field(default_factory=dict)
    description: str = ""

    def __post_init__(self):
        if not isinstance(self.name, str) or not isinstance(self.description, str):
            raise TypeError("name and description must be strings")
        if not isinstance(self.content, SceneContent):
            raise TypeError(f"content must be a SceneContent; got {type(self.content).__name__}")
        if isinstance(self.planes, (bool, np.bool_)) or not isinstance(self.planes, (int, np.integer)) \
                or self.planes < 1:
            raise ValueError(f"planes must be a positive integer (readouts); got {self.planes!r}")
        object.__setattr__(self, "planes", int(self.planes))
        if not isinstance(self.camera, Camera):
            raise TypeError(f"camera must be a Camera; got {type(self.camera).__name__}")
        if self.content.rate_hz != self.camera.rate_hz:
            raise ValueError(f"content.rate_hz ({self.content.rate_hz}) differs from camera.rate_hz "
                             f"({self.camera.rate_hz}); velocities would be converted at the wrong rate")
        object.__setattr__(self, "effects", parse_effects(self.effects))

    @property
    def height(self) -> int:
        """Image height in pixels."""
        return self.content.height

    @property
    def width(self) -> int:
        """Image width in pixels."""
        return self.content.width

    def radiance(self, times) -> np.ndarray:
        """The content's radiance ``(n, H, W, 3) float32`` (rate units) at ``times`` ``(n,)`` in readouts."""
        return self.content.radiance(times)


# ----------------------------------------------------------------------------- scene files
_TOP_KEYS = ("name", "description", "planes", "camera", "content", "effects")
_VIDEO_KEYS = ("path", "fps", "brightness", "srgb", "max_frames", "height", "width")


def _content_keys(cls) -> list[str]:
    if cls is VideoFrames:
        return list(_VIDEO_KEYS)
    if cls is ImageMotion:
        return list(_IMAGE_KEYS)
    return [f.name for f in fields(cls) if f.init and f.name != "rate_hz"]


def _coerce(cls, key: str, value):
    """A scene-file value as the field wants it: lists → tuples, ``256.0`` → 256 for integer fields."""
    if isinstance(value, list):
        return tuple(value)
    kind = {f.name: f.type for f in fields(cls)}.get(key)
    if kind in ("int", int) and isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def _resample_matrix(n_in: int, n_out: int):
    """Sparse ``(n_out, n_in)`` resampling along one axis: area average when shrinking, bilinear when enlarging."""
    rows, cols, vals = [], [], []
    if n_out <= n_in:
        scale = n_in / n_out
        for j in range(n_out):
            a, b = j * scale, (j + 1) * scale
            for i in range(int(math.floor(a)), min(int(math.ceil(b)), n_in)):
                overlap = min(b, i + 1) - max(a, i)
                if overlap > 0:
                    rows.append(j)
                    cols.append(i)
                    vals.append(overlap / scale)
    else:
        x = np.clip((np.arange(n_out) + 0.5) * n_in / n_out - 0.5, 0, n_in - 1)  # pixel centres aligned
        i0 = np.floor(x).astype(np.int64)
        i1 = np.minimum(i0 + 1, n_in - 1)
        rows = np.concatenate([np.arange(n_out), np.arange(n_out)])
        cols = np.concatenate([i0, i1])
        vals = np.concatenate([1 - (x - i0), x - i0])
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n_out, n_in))


def _video_from_table(table: dict, rate_hz: float, base_dir: Path | None) -> VideoFrames:
    """Read, decode, resize and scale a scene file's ``video`` content (the only file I/O of scenes)."""
    if "path" not in table:
        raise ValueError("content.path is required for type 'video' (a video file, a folder of images or a glob)")
    if "fps" not in table:
        raise ValueError("content.fps is required for type 'video' (the source frame rate, frames per second)")
    if not isinstance(table["path"], str) or not table["path"]:
        raise ValueError(f"content.path must be a non-empty string; got {table['path']!r}")
    fps = _number("fps", table["fps"], minimum=0, open_min=True)
    brightness = _number("brightness", table.get("brightness", 0.5), minimum=0)
    srgb = table.get("srgb", True)
    if not isinstance(srgb, bool):
        raise ValueError(f"content.srgb must be true or false; got {srgb!r}")
    max_frames = table.get("max_frames")
    if max_frames is not None:
        max_frames = _integer("max_frames", max_frames, 1)
    size = {k: _even_size(k, _coerce(SceneContent, k, table[k])) for k in ("height", "width") if k in table}
    path = Path(table["path"]).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    try:
        raw = read_frames(path, max_frames=max_frames)
    except FileNotFoundError as exc:
        raise FileNotFoundError(f"content.path: {exc}") from None
    except ValueError as exc:
        raise ValueError(f"content.path: {exc}") from None
    n, src_h, src_w, _ = raw.shape
    if np.issubdtype(raw.dtype, np.integer):
        unit = np.float32(1.0 / np.iinfo(raw.dtype).max)
    elif np.issubdtype(raw.dtype, np.floating):
        unit = np.float32(1.0)
        if not np.all(np.isfinite(raw)):
            raise ValueError(f"content.path: {path} holds non-finite values")
    else:
        raise ValueError(f"content.path: {path} holds {raw.dtype} pixels; expected integers or floats")
    if size:  # resize; one size given keeps the aspect ratio (rounded to even)
        h = size.get("height") or max(2, 2 * round(size["width"] * src_h / src_w / 2))
        w = size.get("width") or max(2, 2 * round(size["height"] * src_w / src_h / 2))
        along_y, along_x = _resample_matrix(src_h, h), _resample_matrix(src_w, w)
    else:  # a Bayer sensor needs even sizes: an odd source loses its last row or column
        h, w = src_h // 2 * 2, src_w // 2 * 2
        if h < 2 or w < 2:
            raise ValueError(f"content.path: frames of {src_h}×{src_w} are too small (at least 2×2)")
    frames = np.empty((n, h, w, 3), dtype=np.float32)
    for k in range(n):  # frame by frame: memory holds the source once, not a float copy of it
        linear = raw[k].astype(np.float32) * unit
        linear = srgb_decode(linear) if srgb else np.maximum(linear, 0)
        if size:
            linear = (along_y @ linear.reshape(src_h, -1)).reshape(h, src_w, 3)
            linear = (along_x @ linear.transpose(1, 0, 2).reshape(src_w, -1)).reshape(w, h, 3).transpose(1, 0, 2)
        else:
            linear = linear[:h, :w]
        frames[k] = linear * brightness
    options = {"brightness": table.get("brightness", 0.5), "srgb": srgb}
    options.update({k: table[k] for k in ("max_frames", "height", "width") if k in table})
    return VideoFrames(frames=frames, fps=fps, rate_hz=rate_hz, source=str(path),
                       source_options=tuple(sorted(options.items())))


_IMAGE_KEYS = ("path", "brightness", "srgb", "scale", "height", "width", "origin", "motion", "foreground")
_FOREGROUND_KEYS = ("path", "brightness", "srgb", "scale", "radius", "center", "source_center", "motion")
#: Scene files may name a photograph bundled with scikit-image as ``skimage:NAME`` (the test extra).
SKIMAGE_PREFIX = "skimage:"


def _resolve_image_path(text: str, base_dir: Path | None, name: str) -> Path:
    """A scene file's image path: a file (relative to the scene file's folder) or ``skimage:NAME``."""
    if not isinstance(text, str) or not text:
        raise ValueError(f"{name} must be a non-empty string; got {text!r}")
    if text.startswith(SKIMAGE_PREFIX):
        key = text[len(SKIMAGE_PREFIX):]
        try:
            import skimage.data
        except ImportError:
            raise ValueError(f"{name} = {text!r} needs scikit-image (pip install \"spikeref[test]\")") from None
        folder = Path(skimage.data.__file__).parent
        found = sorted(p for p in folder.iterdir() if p.stem == key and p.suffix.lower() in (".png", ".jpg"))
        if not found:
            names = sorted({p.stem for p in folder.iterdir() if p.suffix.lower() in (".png", ".jpg")})
            raise ValueError(f"{name}: scikit-image bundles no photograph {key!r}; it has {', '.join(names)}")
        return found[0]
    path = Path(text).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    return path


def _read_photograph(table: dict, base_dir: Path | None, name: str) -> tuple:
    """Read, decode (sRGB → linear), rescale (area average / bilinear) and scale one photograph to radiance.

    Returns the radiance ``(h, w, 3) float32`` and how to name the file again (``skimage:NAME`` as
    given, otherwise the resolved path).
    """
    if "path" not in table:
        raise ValueError(f"{name}.path is required (an image file, or skimage:NAME for a scikit-image photograph)")
    path = _resolve_image_path(table["path"], base_dir, f"{name}.path")
    brightness = _number("brightness", table.get("brightness", 0.5), minimum=0)
    srgb = table.get("srgb", True)
    if not isinstance(srgb, bool):
        raise ValueError(f"{name}.srgb must be true or false; got {srgb!r}")
    scale = table.get("scale", 1.0)
    if not _is_number(scale) or not math.isfinite(scale) or not 0 < scale <= 4:
        raise ValueError(f"{name}.scale must be a number in (0, 4]; got {scale!r}")
    try:
        raw = read_frames(path, max_frames=1)[0]
    except FileNotFoundError as exc:
        raise FileNotFoundError(f"{name}.path: {exc}") from None
    except ValueError as exc:
        raise ValueError(f"{name}.path: {exc}") from None
    if np.issubdtype(raw.dtype, np.integer):
        linear = raw.astype(np.float32) / np.float32(np.iinfo(raw.dtype).max)
    else:
        linear = raw.astype(np.float32)
        if not np.all(np.isfinite(linear)):
            raise ValueError(f"{name}.path: {path} holds non-finite values")
    linear = srgb_decode(linear) if srgb else np.maximum(linear, 0)
    src_h, src_w = linear.shape[:2]
    if scale != 1.0:
        h, w = max(2, round(src_h * scale)), max(2, round(src_w * scale))
        along_y, along_x = _resample_matrix(src_h, h), _resample_matrix(src_w, w)
        linear = (along_y @ linear.reshape(src_h, -1)).reshape(h, src_w, 3)
        linear = (along_x @ linear.transpose(1, 0, 2).reshape(src_w, -1)).reshape(w, h, 3).transpose(1, 0, 2)
    text = table["path"]
    return (linear * brightness).astype(np.float32), text if text.startswith(SKIMAGE_PREFIX) else str(path)


def _image_from_table(table: dict, rate_hz: float, base_dir: Path | None) -> ImageMotion:
    """Build a scene file's ``image`` content (reads the photographs: the scenes' only other file I/O)."""
    image, path = _read_photograph(table, base_dir, "content")
    if "height" not in table or "width" not in table:
        raise ValueError("content.height and content.width are required for type 'image' (the view, in pixels)")
    kw = {"height": _coerce(SceneContent, "height", table["height"]),
          "width": _coerce(SceneContent, "width", table["width"]),
          "origin": table.get("origin"), "motion": Motion.from_table(table.get("motion"), "content.motion")}
    fg_table = table.get("foreground")
    fg_options = None
    if fg_table is not None:
        if not isinstance(fg_table, dict):
            raise ValueError(f"content.foreground must be a table; got {fg_table!r}")
        unknown = sorted(set(fg_table) - set(_FOREGROUND_KEYS))
        if unknown:
            raise ValueError(f"unknown field content.foreground.{unknown[0]}; a foreground takes "
                             f"{', '.join(_FOREGROUND_KEYS)}")
        if "radius" not in fg_table:
            raise ValueError("content.foreground.radius is required (the disc's radius in pixels)")
        fg_image, fg_path = _read_photograph(fg_table, base_dir, "content.foreground")
        kw.update(fg_image=fg_image, fg_radius=fg_table["radius"], fg_center=fg_table.get("center"),
                  fg_source_center=fg_table.get("source_center"),
                  fg_motion=Motion.from_table(fg_table.get("motion"), "content.foreground.motion"))
        fg_options = {k: fg_table[k] for k in ("brightness", "srgb", "scale") if k in fg_table}
        fg_options["path"] = fg_path
    options = {k: table[k] for k in ("brightness", "srgb", "scale") if k in table}
    if fg_options is not None:
        options["foreground"] = tuple(sorted(fg_options.items()))
    return ImageMotion(image=image, rate_hz=rate_hz, source=path,
                       source_options=tuple(sorted(options.items())), **kw)


def _image_to_table(content: ImageMotion) -> dict:
    """The scene-file table of an ``image`` content read from files."""
    if not content.source:
        raise ValueError("an image content built from arrays has no file to refer to; save the images and "
                         "load them with a scene file")
    options = dict(content.source_options)
    table = {"type": "image", "path": content.source, "height": content.height, "width": content.width,
             "origin": list(content.origin), "motion": content.motion.to_table()}
    fg = options.pop("foreground", None)
    table.update(options)
    if fg is not None:
        fg = dict(fg)
        fg.update(radius=content.fg_radius, center=list(content.fg_center),
                  source_center=list(content.fg_source_center),
                  motion=content.fg_motion.to_table())
        table["foreground"] = fg
    return table


def scene_from_dict(data: dict, source: str = "<dict>", base_dir=None) -> Scene:
    """Build a :class:`Scene` from the scene-file layout (see the module docstring).

    Parameters
    ----------
    data : dict
        The parsed TOML: ``name``, ``description``, ``planes``, ``camera``, ``content``, ``effects``.
    source : str
        Where ``data`` came from; it starts every error message.
    base_dir : str or Path, optional
        Folder that a ``video`` content's relative ``path`` is relative to (the current folder if None).

    Raises
    ------
    ValueError
        A missing, unknown or invalid field; the message names ``source`` and the field path.
    FileNotFoundError
        A ``video`` content's path does not exist or holds no images.
    """
    if not isinstance(data, dict):
        raise ValueError(f"{source}: a scene must be a table; got {type(data).__name__}")
    unknown = sorted(set(data) - set(_TOP_KEYS))
    if unknown:
        raise ValueError(f"{source}: unknown field {', '.join(unknown)}; a scene has {', '.join(_TOP_KEYS)}")
    base_dir = Path(base_dir) if base_dir is not None else None

    cam_table = data.get("camera", {})
    if not isinstance(cam_table, dict):
        raise ValueError(f"{source}: camera must be a table; got {cam_table!r}")
    cam_fields = [f.name for f in fields(Camera) if f.init]
    for key in cam_table:
        if key not in cam_fields:
            raise ValueError(f"{source}: unknown field camera.{key}; camera takes {', '.join(cam_fields)}")
    cam_kw = dict(cam_table)
    if isinstance(cam_kw.get("cfa"), str) and cam_kw["cfa"].lower() == "mono":
        cam_kw["cfa"] = None
    try:
        camera = Camera(**cam_kw)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{source}: camera: {exc}") from None

    table = data.get("content")
    if not isinstance(table, dict):
        raise ValueError(f"{source}: a [content] table is required, with a type ({', '.join(CONTENT_TYPES)})")
    table = dict(table)
    kind = table.pop("type", None)
    if kind not in CONTENT_TYPES:
        raise ValueError(f"{source}: content.type must be one of {', '.join(CONTENT_TYPES)}; got {kind!r}")
    cls = CONTENT_TYPES[kind]
    allowed = _content_keys(cls)
    for key in table:
        if key not in allowed:
            raise ValueError(f"{source}: unknown field content.{key}; {kind} takes {', '.join(allowed)}")
    try:
        if cls is VideoFrames:
            content = _video_from_table(table, camera.rate_hz, base_dir)
        elif cls is ImageMotion:
            content = _image_from_table(table, camera.rate_hz, base_dir)
        else:
            content = cls(rate_hz=camera.rate_hz, **{k: _coerce(cls, k, v) for k, v in table.items()})
    except FileNotFoundError as exc:
        raise FileNotFoundError(f"{source}: {exc}") from None
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{source}: {exc}") from None

    effects = data.get("effects", {})
    if not isinstance(effects, dict):
        raise ValueError(f"{source}: effects must be a table of effect tables; got {effects!r}")
    try:
        effects = parse_effects(effects)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{source}: effects: {exc}") from None

    if "planes" not in data:
        raise ValueError(f"{source}: planes is required (the number of readouts to simulate)")
    planes = data["planes"]
    if isinstance(planes, bool) or not isinstance(planes, int) or planes < 1:
        raise ValueError(f"{source}: planes must be a positive integer (readouts); got {planes!r}")
    name = data.get("name", Path(source).stem if source != "<dict>" else kind)
    description = data.get("description", "")
    for key, value in (("name", name), ("description", description)):
        if not isinstance(value, str):
            raise ValueError(f"{source}: {key} must be a string; got {value!r}")
    return Scene(name=name, content=content, planes=planes, camera=camera, effects=effects, description=description)


def _merge(base: dict, over: dict) -> dict:
    """``over`` merged into ``base`` table by table; ``effects`` and a content of another type are replaced whole."""
    out = dict(base)
    for key, value in over.items():
        replace_whole = key == "effects" or (
            key == "content" and isinstance(value, dict) and "type" in value
            and value.get("type") != (out.get("content") or {}).get("type")
        )
        if not replace_whole and isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def load_scene(path, overrides: dict | None = None) -> Scene:
    """Read a scene file (TOML).

    Parameters
    ----------
    path : str or Path
        The scene file; a ``video`` content's relative path is relative to its folder.
    overrides : dict, optional
        Merged over the file's tables before building the scene: ``{"planes": 100}``,
        ``{"content": {"width": 64}}``, ``{"camera": {"substeps": 1}}``.  An ``effects`` entry
        replaces the file's effects as a whole (``{"effects": {}}`` gives a noise-free scene);
        a ``content`` entry with another ``type`` replaces the content table as a whole.

    Raises
    ------
    FileNotFoundError
        No such file (or a video content's frames are missing).
    ValueError
        The file is not valid TOML (the message names the file and the parser's message) or a
        field is missing, unknown or invalid (see :func:`scene_from_dict`).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such scene file: {path}")
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not a valid TOML scene file ({exc})") from None
    if overrides:
        data = _merge(data, overrides)
    return scene_from_dict(data, source=str(path), base_dir=path.parent)


def scene_to_dict(scene: Scene) -> dict:
    """The scene-file layout of ``scene``; :func:`scene_from_dict` of it rebuilds an equal scene.

    A ``video`` content is written as the path and options it was read with (the files must
    still be there to reload it); one built from an array cannot be written (``ValueError``).
    """
    content = scene.content
    if isinstance(content, VideoFrames):
        if not content.source:
            raise ValueError("a video content built from an array has no file to refer to; write its frames "
                             "to images and load them with a scene file")
        table = {"type": "video", "path": content.source, "fps": content.fps, **dict(content.source_options)}
    elif isinstance(content, ImageMotion):
        table = _image_to_table(content)
    else:
        table = {"type": content.type_name}
        for f in fields(content):
            if f.init and f.name != "rate_hz":
                value = getattr(content, f.name)
                table[f.name] = list(value) if isinstance(value, tuple) else value
    camera = {f.name: getattr(scene.camera, f.name) for f in fields(Camera) if f.init}
    if camera.get("cfa", "") is None:
        camera["cfa"] = "mono"
    effects = {name: {k: v for k, v in asdict(effect).items() if v is not None}  # None: not given (TOML has no null)
               for name, effect in scene.effects.items()}
    return {"name": scene.name, "description": scene.description, "planes": scene.planes, "camera": camera,
            "content": table, "effects": effects}
