"""Scenes for the simulator: procedural radiance over time, described in TOML (§5.1, DESIGN §5).

A :class:`Scene` holds what to look at (its *content*), the camera (Eq. 1–3 parameters)
and the noise effects to run (:mod:`spikeref.simulate.effects`).  Content types:

========================  =====================================================================
``uniform``               a flat field of one colour (a grey card; the noise-check target)
``color_chart``           a static 4×6 chart of the 24 ColorChecker colours on a dark board
``translating_texture``   a periodic procedural colour texture sliding at a fixed velocity
``fan``                   a fast rotating fan over a still background of colourful toys (Fig. 7a)
``hdr_lamp``              a lamp ≥ 10⁴ brighter than a textured deep shadow beside it
``video``                 frames of a user's video or image sequence, interpolated to 20 kHz
========================  =====================================================================

Units
-----
* ``radiance(times)`` takes times in **readouts** (1/20 000 s at the default rate; fractional
  times are instants inside a readout) and returns linear RGB ``(n, H, W, 3) float32``.
* Radiance is scaled so that with the default camera (``α = E_th = 1``) it *is* the firing
  rate in spikes per readout; ``brightness`` is the radiance of a white (reflectance 1)
  surface.  A pixel saturates at rate 1, so the procedural scenes stay below it.
* Velocities in scene files are in pixels per second and revolutions per second; content
  converts them with its ``rate_hz`` (the camera's readout rate).

TOML layout
-----------
::

    name = "fan over toys"
    planes = 2000                 # readouts to simulate
    [camera]                      # fields of spikeref.simulate.camera.Camera; cfa = "mono" for none
    cfa = "RGGB"
    substeps = 4
    [content]
    type = "fan"
    height = 256
    width = 256
    [effects.random_phase]        # one table per effect, with its parameters
    [effects.dark_current]
    gamma = 0.002
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field, fields
from functools import cached_property
from pathlib import Path
from typing import ClassVar

import numpy as np

from spikeref.simulate.camera import Camera
from spikeref.simulate.effects import parse_effects
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


def _finite(name, value, lo=None, hi=None, lo_open=False):
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    ok = ok and math.isfinite(value)
    if ok and lo is not None:
        ok = value > lo if lo_open else value >= lo
    if ok and hi is not None:
        ok = value <= hi
    if not ok:
        rng = ""
        if lo is not None or hi is not None:
            rng = f" in {'(' if lo_open else '['}{lo if lo is not None else '-inf'}, {hi if hi is not None else 'inf'}]"
        raise ValueError(f"content.{name} must be a finite number{rng}; got {value!r}")


def _coverage(signed_distance):
    """Anti-aliased coverage of a shape from the signed distance (pixels, < 0 inside): a 1-px ramp."""
    return np.clip(0.5 - signed_distance, 0.0, 1.0)


@dataclass(frozen=True)
class SceneContent:
    """Base of all content: size and brightness; subclasses define :meth:`radiance`.

    Attributes
    ----------
    height, width : int
        Image size in pixels (even, for a Bayer sensor).
    brightness : float
        Radiance of a white surface (rate units, ≥ 0).
    rate_hz : float
        Readout rate used to convert velocities given per second (the camera's).
    """

    height: int = 256
    width: int = 256
    brightness: float = 0.5
    rate_hz: float = 20000.0
    static: ClassVar[bool] = False
    type_name: ClassVar[str] = ""

    def __post_init__(self):
        for name in ("height", "width"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 2 or v % 2:
                raise ValueError(f"content.{name} must be an even integer ≥ 2 (a Bayer sensor); got {v!r}")
        _finite("brightness", self.brightness, lo=0.0)
        _finite("rate_hz", self.rate_hz, lo=0.0, lo_open=True)

    def radiance(self, times) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _times(self, times) -> np.ndarray:
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
        if t.ndim != 1:
            raise ValueError(f"times must be a 1-D array of readouts; got shape {t.shape}")
        return t

    def _repeat(self, image: np.ndarray, n: int) -> np.ndarray:
        return np.broadcast_to(image.astype(np.float32), (n,) + image.shape).copy()


@dataclass(frozen=True)
class Uniform(SceneContent):
    """A flat field: every pixel has radiance ``brightness · color`` (static).

    Attributes
    ----------
    color : tuple of 3 floats
        Linear reflectance per channel (≥ 0).
    """

    color: tuple = (1.0, 1.0, 1.0)
    static: ClassVar[bool] = True
    type_name: ClassVar[str] = "uniform"

    def __post_init__(self):
        super().__post_init__()
        c = tuple(self.color)
        if len(c) != 3:
            raise ValueError(f"content.color must have 3 values (R, G, B); got {self.color!r}")
        for v in c:
            _finite("color", v, lo=0.0)
        object.__setattr__(self, "color", tuple(float(v) for v in c))

    def radiance(self, times) -> np.ndarray:
        t = self._times(times)
        image = np.empty((self.height, self.width, 3), dtype=np.float32)
        image[...] = np.asarray(self.color, dtype=np.float32) * np.float32(self.brightness)
        return self._repeat(image, t.size)


@dataclass(frozen=True)
class ColorChart(SceneContent):
    """The 24 ColorChecker colours, 4 rows × 6 patches, on a dark board (static).

    Patch values are the published 8-bit sRGB references, decoded to linear; the white
    patch (reflectance ≈ 0.9) is ``0.9 · brightness``.

    Attributes
    ----------
    board : float
        Linear reflectance of the board between patches.
    """

    board: float = 0.03
    static: ClassVar[bool] = True
    type_name: ClassVar[str] = "color_chart"

    def __post_init__(self):
        super().__post_init__()
        _finite("board", self.board, lo=0.0, hi=1.0)

    @cached_property
    def _image(self) -> np.ndarray:
        h, w = self.height, self.width
        patches = srgb_decode(np.asarray(COLORCHECKER_SRGB, dtype=np.float64) / 255.0).reshape(4, 6, 3)
        patches *= 0.9 / patches[3, 0].max()  # white patch → reflectance 0.9
        img = np.full((h, w, 3), self.board, dtype=np.float64)
        cell_h, cell_w = h / 4.0, w / 6.0
        yy = np.arange(h)[:, None] + 0.5
        xx = np.arange(w)[None, :] + 0.5
        for r in range(4):
            for c in range(6):
                # a patch fills the central 80 % of its cell; anti-aliased edges
                cy, cx = (r + 0.5) * cell_h, (c + 0.5) * cell_w
                sd = np.maximum(np.abs(yy - cy) - 0.4 * cell_h, np.abs(xx - cx) - 0.4 * cell_w)
                cov = _coverage(sd)[..., None]
                img = img * (1 - cov) + patches[r, c] * cov
        return (img * self.brightness).astype(np.float32)

    def radiance(self, times) -> np.ndarray:
        return self._repeat(self._image, self._times(times).size)


def _fractal_texture(size: int, rng: np.random.Generator) -> np.ndarray:
    """A periodic ``(size, size, 3)`` colour texture in [0.05, 0.95]: 1/f noise plus hard-edged shapes."""
    fy = np.fft.fftfreq(size)[:, None]
    fx = np.fft.fftfreq(size)[None, :]
    f = np.sqrt(fy**2 + fx**2)
    f[0, 0] = 1.0
    amp = 1.0 / f**1.6
    amp[0, 0] = 0.0
    chans = []
    for _ in range(3):
        phase = np.exp(2j * np.pi * rng.random((size, size)))
        field_ = np.real(np.fft.ifft2(amp * phase))
        chans.append((field_ - field_.mean()) / field_.std())
    mix = np.array([[0.8, 0.2, 0.0], [0.1, 0.8, 0.1], [0.0, 0.3, 0.7]])
    tex = np.stack(chans, axis=-1) @ mix.T
    tex = 0.5 + 0.17 * tex
    # hard-edged discs and bars, drawn on the torus so the texture stays periodic
    yy, xx = np.mgrid[0:size, 0:size] + 0.5
    for _ in range(max(4, size // 24)):
        cy, cx = rng.random(2) * size
        dy = (yy - cy + size / 2) % size - size / 2
        dx = (xx - cx + size / 2) % size - size / 2
        color = rng.random(3) ** 1.5
        if rng.random() < 0.5:
            sd = np.hypot(dy, dx) - rng.uniform(0.03, 0.09) * size
        else:
            sd = np.maximum(np.abs(dy) - rng.uniform(0.02, 0.1) * size, np.abs(dx) - rng.uniform(0.01, 0.05) * size)
        cov = _coverage(sd)[..., None]
        tex = tex * (1 - cov) + color * cov
    return np.clip(tex, 0.05, 0.95)


@dataclass(frozen=True)
class TranslatingTexture(SceneContent):
    """A periodic procedural colour texture translating at a constant velocity.

    Radiance at pixel ``(y, x)`` and time ``t`` is the texture at ``(y − v_y t, x − v_x t)``
    (content moves by ``+v``), sampled bilinearly with wrap-around; an integer shift is exact.

    Attributes
    ----------
    velocity : tuple ``(v_x, v_y)``
        Pixels per second (2000 px/s = 1 px per 10 readouts at 20 kHz).
    texture_size : int
        Side of the square periodic texture in pixels.
    seed : int
        Seed of the procedural texture (not of the noise).
    """

    velocity: tuple = (2000.0, 600.0)
    texture_size: int = 256
    seed: int = 0
    type_name: ClassVar[str] = "translating_texture"

    def __post_init__(self):
        super().__post_init__()
        v = tuple(self.velocity)
        if len(v) != 2:
            raise ValueError(f"content.velocity must be (v_x, v_y) in pixels/second; got {self.velocity!r}")
        for c in v:
            _finite("velocity", c)
        object.__setattr__(self, "velocity", tuple(float(c) for c in v))
        if isinstance(self.texture_size, bool) or not isinstance(self.texture_size, (int, np.integer)) \
                or self.texture_size < 8:
            raise ValueError(f"content.texture_size must be an integer ≥ 8; got {self.texture_size!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"content.seed must be a non-negative integer; got {self.seed!r}")

    @cached_property
    def texture(self) -> np.ndarray:
        """The periodic reflectance texture ``(S, S, 3) float64``."""
        return _fractal_texture(int(self.texture_size), np.random.default_rng(self.seed))

    def radiance(self, times) -> np.ndarray:
        t = self._times(times)
        tex = (self.texture * self.brightness).astype(np.float32)
        s = tex.shape[0]
        rows = np.arange(self.height)
        cols = np.arange(self.width)
        out = np.empty((t.size, self.height, self.width, 3), dtype=np.float32)
        for i, ti in enumerate(t):
            # a uniform translation: one integer shift and one pair of bilinear weights per axis
            dy = self.velocity[1] * ti / self.rate_hz
            dx = self.velocity[0] * ti / self.rate_hz
            iy, ix = math.floor(-dy), math.floor(-dx)
            fy, fx = np.float32(-dy - iy), np.float32(-dx - ix)
            y0 = (rows + iy) % s
            x0 = (cols + ix) % s
            band = tex[y0] * (1 - fy) + tex[(y0 + 1) % s] * fy if fy else tex[y0]
            out[i] = band[:, x0] * (1 - fx) + band[:, (x0 + 1) % s] * fx if fx else band[:, x0]
        return out


def _toys_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """A still life of colourful procedural toys on a soft gradient: reflectance ``(h, w, 3)``."""
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
        dy, dx = yy - cy, xx - cx
        kind = k % 5
        if kind == 0:  # ball with soft shading
            d = np.hypot(dy, dx)
            cov = _coverage(d - size)
            shade = np.clip(1.15 - 0.6 * np.hypot(dy + 0.4 * size, dx + 0.4 * size) / size, 0.35, 1.15)
            layer = color * shade[..., None]
        elif kind == 1:  # block
            cov = _coverage(np.maximum(np.abs(dy) - size * 0.8, np.abs(dx) - size * 0.6))
            layer = np.broadcast_to(color, img.shape)
        elif kind == 2:  # ring
            d = np.hypot(dy, dx)
            cov = _coverage(np.abs(d - size * 0.8) - size * 0.22)
            layer = np.broadcast_to(color, img.shape)
        elif kind == 3:  # striped box
            cov = _coverage(np.maximum(np.abs(dy) - size * 0.7, np.abs(dx) - size * 0.9))
            stripes = (np.floor((dx + dy) / max(2.0, size / 4)) % 2)[..., None]
            layer = color * (0.35 + 0.65 * stripes) + (1 - stripes) * 0.05
        else:  # checked cube
            cov = _coverage(np.maximum(np.abs(dy), np.abs(dx)) - size * 0.75)
            check = ((np.floor(dy / max(2.0, size / 3)) + np.floor(dx / max(2.0, size / 3))) % 2)[..., None]
            layer = color * check + (1 - check) * np.array([0.92, 0.92, 0.88])
        cov = cov[..., None]
        img = img * (1 - cov) + layer * cov
    return np.clip(img, 0.02, 0.95)


@dataclass(frozen=True)
class FanOverToys(SceneContent):
    """A fast rotating fan over a still, colourful background of toys (the paper's Fig. 7a).

    Attributes
    ----------
    revolutions_per_second : float
        Rotation speed (counter-clockwise on screen for positive values).
    blades : int
        Number of blades (≥ 1).
    radius : float
        Blade tip radius as a fraction of ``min(height, width)``.
    hub : float
        Hub radius as a fraction of the tip radius.
    blade_width : float
        Angular half-width of a blade at its tip, as a fraction of ``π / blades``.
    blade_color : tuple of 3 floats
        Linear reflectance of the blades.
    hub_color : tuple of 3 floats
        Linear reflectance of the hub.
    seed : int
        Seed of the toys' layout (not of the noise).
    """

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
        _finite("revolutions_per_second", self.revolutions_per_second)
        if isinstance(self.blades, bool) or not isinstance(self.blades, (int, np.integer)) or self.blades < 1:
            raise ValueError(f"content.blades must be a positive integer; got {self.blades!r}")
        _finite("radius", self.radius, lo=0.0, hi=1.0, lo_open=True)
        _finite("hub", self.hub, lo=0.0, hi=1.0)
        _finite("blade_width", self.blade_width, lo=0.0, hi=1.0, lo_open=True)
        for name in ("blade_color", "hub_color"):
            c = tuple(getattr(self, name))
            if len(c) != 3:
                raise ValueError(f"content.{name} must have 3 values (R, G, B); got {c!r}")
            for v in c:
                _finite(name, v, lo=0.0)
            object.__setattr__(self, name, tuple(float(v) for v in c))
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"content.seed must be a non-negative integer; got {self.seed!r}")

    @property
    def period_readouts(self) -> float:
        """Readouts per revolution (inf when still)."""
        rps = abs(self.revolutions_per_second)
        return math.inf if rps == 0 else self.rate_hz / rps

    @cached_property
    def _layers(self):
        h, w = self.height, self.width
        bg = _toys_background(h, w, np.random.default_rng(self.seed)) * self.brightness
        yy, xx = np.mgrid[0:h, 0:w] + 0.5
        cy, cx = h / 2.0, w / 2.0
        r = np.hypot(yy - cy, xx - cx)
        theta = np.arctan2(-(yy - cy), xx - cx)  # counter-clockwise on screen (row 0 at the top)
        tip = self.radius * min(h, w)
        hub = self.hub * tip
        sector = 2 * np.pi / self.blades
        # blade half-width grows from 40 % at the hub to 100 % at the tip
        half = self.blade_width * (sector / 2) * (0.4 + 0.6 * np.clip(r / tip, 0, 1))
        radial = _coverage(np.maximum(r - tip, hub * 0.5 - r))
        hub_cov = _coverage(r - hub)
        f32 = np.float32
        return (bg.astype(f32), r.astype(f32), theta, half.astype(f32), radial.astype(f32), hub_cov.astype(f32),
                (np.asarray(self.blade_color) * self.brightness).astype(f32),
                (np.asarray(self.hub_color) * self.brightness).astype(f32))

    def radiance(self, times) -> np.ndarray:
        t = self._times(times)
        bg, r, theta, half, radial, hub_cov, blade_rgb, hub_rgb = self._layers
        sector = 2 * np.pi / self.blades
        omega = 2 * np.pi * self.revolutions_per_second / self.rate_hz  # radians per readout
        out = np.empty((t.size, self.height, self.width, 3), dtype=np.float32)
        for i, ti in enumerate(t):
            rel = (np.mod(theta - omega * ti, sector) - sector / 2).astype(np.float32)  # from the nearest blade
            blade = _coverage((np.abs(rel) - half) * r) * radial
            cov = np.maximum(blade, hub_cov)[..., None]
            color = np.where((hub_cov >= blade)[..., None], hub_rgb, blade_rgb)
            out[i] = bg * (1 - cov) + color * cov
        return out


@dataclass(frozen=True)
class HDRLamp(SceneContent):
    """A lit lamp beside a deep shadow that still holds detail (static).

    A wall with mid-tones; on the left a lamp (a disc of radiance ``lamp`` with a glow);
    on the right an occluded alcove whose radiance is ``shadow`` times a texture between
    0.5 and 1.5 (stripes and a disc), so the ratio of the lamp to the darkest shadow pixel
    is ``lamp / (0.5 shadow)``.

    Attributes
    ----------
    lamp : float
        Radiance of the lamp (rate units; < 1 so it does not saturate).
    shadow : float
        Mean radiance in the alcove (rate units).
    """

    lamp: float = 0.9
    shadow: float = 5e-5
    brightness: float = 0.08
    static: ClassVar[bool] = True
    type_name: ClassVar[str] = "hdr_lamp"

    def __post_init__(self):
        super().__post_init__()
        _finite("lamp", self.lamp, lo=0.0, lo_open=True)
        _finite("shadow", self.shadow, lo=0.0, lo_open=True)

    @cached_property
    def _image(self) -> np.ndarray:
        h, w = self.height, self.width
        yy, xx = np.mgrid[0:h, 0:w] + 0.5
        # a warm wall with a gentle gradient and soft vertical panels (mid-tones)
        wall = np.stack([0.75 + 0.1 * xx / w, 0.6 + 0.05 * yy / h, 0.45 * np.ones_like(xx)], axis=-1)
        wall *= (0.7 + 0.3 * (np.floor(xx / max(2, w // 8)) % 2))[..., None]
        img = wall * self.brightness
        # the lamp and its glow
        ly, lx, lr = 0.4 * h, 0.25 * w, 0.09 * min(h, w)
        d = np.hypot(yy - ly, xx - lx)
        glow = 0.15 * self.lamp * np.exp(-np.maximum(d - lr, 0) / (0.12 * min(h, w)))
        img = img + glow[..., None] * np.array([1.0, 0.85, 0.6])
        cov = _coverage(d - lr)[..., None]
        img = img * (1 - cov) + self.lamp * np.array([1.0, 0.97, 0.9]) * cov
        # the deep-shadow alcove with detail: stripes and a disc, ±50 %
        x0, y0, y1 = 0.62 * w, 0.2 * h, 0.85 * h
        inside = (xx >= x0) & (yy >= y0) & (yy < y1)
        stripes = 0.5 + (np.floor((xx - x0) / max(2, w // 32)) % 2)
        disc = np.hypot(yy - 0.55 * h, xx - 0.8 * w) < 0.08 * min(h, w)
        detail = np.where(disc, 1.5 - 0.5 * (stripes - 0.5), stripes)
        tint = np.array([0.9, 1.0, 1.1])
        img = np.where(inside[..., None], self.shadow * detail[..., None] * tint / tint.mean(), img)
        return img.astype(np.float32)

    def radiance(self, times) -> np.ndarray:
        return self._repeat(self._image, self._times(times).size)


@dataclass(frozen=True)
class VideoFrames(SceneContent):
    """Frames of a video or image sequence, linearly interpolated in time to the readout rate.

    Attributes
    ----------
    frames : ndarray ``(N, H, W, 3)``
        Linear radiance of each source frame **before** ``brightness`` (e.g. decoded sRGB in
        [0, 1]); ``radiance = brightness · frames``.
    fps : float
        Source frame rate.  Source time of readout ``t`` is ``t / rate_hz · fps``; between
        frames the radiance is interpolated linearly; before the first and after the last
        frame it holds.
    source : str
        Where the frames came from (for the record).
    """

    frames: np.ndarray = field(default=None, repr=False, compare=False)
    fps: float = 30.0
    source: str = ""
    type_name: ClassVar[str] = "video"

    def __post_init__(self):
        frames = self.frames
        if frames is None:
            raise ValueError("content.frames is required: an (N, H, W, 3) array (or a path in a scene file)")
        frames = np.asarray(frames, dtype=np.float32)
        if frames.ndim != 4 or frames.shape[-1] != 3 or frames.shape[0] < 1:
            raise ValueError(f"content.frames must have shape (N, H, W, 3); got {frames.shape}")
        if not np.all(np.isfinite(frames)) or frames.min() < 0:
            raise ValueError("content.frames must be finite and non-negative")
        object.__setattr__(self, "frames", frames)
        object.__setattr__(self, "height", int(frames.shape[1]))
        object.__setattr__(self, "width", int(frames.shape[2]))
        super().__post_init__()
        _finite("fps", self.fps, lo=0.0, lo_open=True)

    def radiance(self, times) -> np.ndarray:
        t = self._times(times)
        n = self.frames.shape[0]
        s = np.clip(t / self.rate_hz * self.fps, 0.0, n - 1)
        i0 = np.floor(s).astype(np.int64)
        i1 = np.minimum(i0 + 1, n - 1)
        wgt = (s - i0).astype(np.float32)[:, None, None, None]
        out = self.frames[i0] * (1 - wgt) + self.frames[i1] * wgt
        return (out * np.float32(self.brightness)).astype(np.float32)


CONTENT_TYPES = {cls.type_name: cls for cls in (Uniform, ColorChart, TranslatingTexture, FanOverToys, HDRLamp,
                                                 VideoFrames)}


@dataclass(frozen=True)
class Scene:
    """What the simulator looks at, with which camera and which effects.

    Attributes
    ----------
    name : str
    content : SceneContent
        Radiance over time.
    planes : int
        Readouts to simulate (≥ 1).
    camera : Camera
        Eq. 1–3 parameters (threshold, α, rate, CFA, sub-steps).
    effects : dict
        ``{name: effect}`` from :func:`spikeref.simulate.effects.parse_effects`, applied in the
        order of :data:`spikeref.simulate.effects.EFFECTS`; empty for a noise-free scene.
    description : str
    """

    name: str
    content: SceneContent
    planes: int
    camera: Camera = field(default_factory=Camera)
    effects: dict = field(default_factory=dict)
    description: str = ""
    source: str = ""

    def __post_init__(self):
        if not isinstance(self.content, SceneContent):
            raise TypeError(f"content must be a SceneContent; got {type(self.content).__name__}")
        if isinstance(self.planes, bool) or not isinstance(self.planes, (int, np.integer)) or self.planes < 1:
            raise ValueError(f"planes must be a positive integer; got {self.planes!r}")
        if not isinstance(self.camera, Camera):
            raise TypeError(f"camera must be a Camera; got {type(self.camera).__name__}")
        object.__setattr__(self, "effects", parse_effects(self.effects))

    @property
    def height(self) -> int:
        return self.content.height

    @property
    def width(self) -> int:
        return self.content.width

    def radiance(self, times) -> np.ndarray:
        """The content's radiance ``(n, H, W, 3) float32`` at ``times`` (readouts)."""
        return self.content.radiance(times)


# ------------------------------------------------------------------------ scene files
_TOP_KEYS = {"name", "description", "planes", "camera", "content", "effects"}
_FILE_ONLY = {"video": {"path", "srgb", "max_frames"}}


def _coerce(cls, key, value):
    """Scene-file value → the field's Python type (lists → tuples); errors name the field."""
    default = {f.name: f.default for f in fields(cls)}.get(key)
    if isinstance(value, list):
        return tuple(value)
    if isinstance(default, bool):
        return value
    if isinstance(default, int) and isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def _load_video(table: dict, base_dir: Path | None, source: str) -> dict:
    from spikeref.io.frames import read_frames

    table = dict(table)
    if "path" not in table:
        raise ValueError(f"{source}: content.path is required for type 'video' (a video file, folder or glob)")
    path = Path(str(table.pop("path")))
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    srgb = table.pop("srgb", True)
    if not isinstance(srgb, bool):
        raise ValueError(f"{source}: content.srgb must be true or false; got {srgb!r}")
    max_frames = table.pop("max_frames", None)
    frames = read_frames(path, max_frames=max_frames)
    frames = frames.astype(np.float32)
    if frames.max() > 1.0 or np.issubdtype(frames.dtype, np.integer):
        frames = frames / 255.0
    if srgb:
        frames = srgb_decode(frames).astype(np.float32)
    h, w = table.pop("height", None), table.pop("width", None)
    if h is not None or w is not None:
        frames = _resize(frames, int(h or frames.shape[1]), int(w or frames.shape[2]))
    # a Bayer sensor needs even sizes: drop the last row/column if odd
    frames = frames[:, : frames.shape[1] // 2 * 2, : frames.shape[2] // 2 * 2]
    table["frames"] = frames
    table["source"] = str(path)
    return table


def _resize(frames: np.ndarray, h: int, w: int) -> np.ndarray:
    """Resize frames by averaging over each output pixel's footprint (area), via linear zoom of the integral."""
    from scipy import ndimage

    if h < 2 or w < 2:
        raise ValueError(f"content.height and content.width must be ≥ 2; got {h}×{w}")
    n, sh, sw, _ = frames.shape
    zoom = (1, h / sh, w / sw, 1)
    if h < sh or w < sw:  # pre-blur to avoid aliasing when shrinking
        sigma = (0, max(0.0, sh / h / 2 - 0.25), max(0.0, sw / w / 2 - 0.25), 0)
        frames = ndimage.gaussian_filter(frames, sigma)
    out = ndimage.zoom(frames, zoom, order=1, grid_mode=True, mode="nearest")
    return np.clip(out, 0, None).astype(np.float32)


def scene_from_dict(data: dict, source: str = "<dict>", base_dir=None) -> Scene:
    """Build a :class:`Scene` from the parsed TOML layout (see the module docstring).

    Errors are ``ValueError``/``TypeError`` naming ``source`` and the field path.
    """
    if not isinstance(data, dict):
        raise TypeError(f"{source}: a scene must be a table; got {type(data).__name__}")
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise ValueError(f"{source}: unknown field(s) {', '.join(sorted(unknown))}; a scene has "
                         f"{', '.join(sorted(_TOP_KEYS))}")
    base_dir = Path(base_dir) if base_dir is not None else None
    # camera
    cam_table = data.get("camera", {}) or {}
    if not isinstance(cam_table, dict):
        raise ValueError(f"{source}: camera must be a table")
    cam_fields = {f.name for f in fields(Camera)}
    for key in cam_table:
        if key not in cam_fields:
            raise ValueError(f"{source}: unknown field camera.{key}; camera takes {', '.join(sorted(cam_fields))}")
    cam_kw = dict(cam_table)
    if isinstance(cam_kw.get("cfa"), str) and cam_kw["cfa"].lower() == "mono":
        cam_kw["cfa"] = None
    try:
        camera = Camera(**cam_kw)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{source}: camera: {exc}") from None
    # content
    content_table = data.get("content")
    if not isinstance(content_table, dict):
        raise ValueError(f"{source}: a [content] table with a 'type' is required")
    content_table = dict(content_table)
    kind = content_table.pop("type", None)
    if kind not in CONTENT_TYPES:
        raise ValueError(f"{source}: content.type must be one of {', '.join(CONTENT_TYPES)}; got {kind!r}")
    cls = CONTENT_TYPES[kind]
    allowed = {f.name for f in fields(cls)} - {"rate_hz", "frames", "source"} | _FILE_ONLY.get(kind, set())
    for key in content_table:
        if key not in allowed:
            raise ValueError(f"{source}: unknown field content.{key}; {kind} takes {', '.join(sorted(allowed))}")
    try:
        if kind == "video":
            content_table = _load_video(content_table, base_dir, source)
        kw = {k: _coerce(cls, k, v) for k, v in content_table.items()}
        content = cls(rate_hz=camera.rate_hz, **kw)
    except FileNotFoundError as exc:
        raise FileNotFoundError(f"{source}: content.path: {exc}") from None
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{source}: {exc}") from None
    # effects
    try:
        effects = parse_effects(data.get("effects", {}) or {})
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{source}: effects: {exc}") from None
    planes = data.get("planes", 2000)
    if isinstance(planes, bool) or not isinstance(planes, int) or planes < 1:
        raise ValueError(f"{source}: planes must be a positive integer (readouts); got {planes!r}")
    name = data.get("name", Path(source).stem if source != "<dict>" else kind)
    description = data.get("description", "")
    if not isinstance(name, str) or not isinstance(description, str):
        raise ValueError(f"{source}: name and description must be strings")
    return Scene(name=name, content=content, planes=planes, camera=camera, effects=effects,
                 description=description, source=source)


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        if key != "effects" and isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value  # effects are replaced as a whole
    return out


def load_scene(path, overrides: dict | None = None) -> Scene:
    """Read a scene file (TOML).

    Parameters
    ----------
    path : str or Path
    overrides : dict, optional
        Merged over the file's tables (``{"planes": 100}``, ``{"content": {"width": 64}}``);
        an ``effects`` entry replaces the file's effects as a whole.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such scene file: {path}")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not a valid TOML scene file ({exc})") from None
    if overrides:
        data = _merge(data, overrides)
    return scene_from_dict(data, source=str(path), base_dir=path.parent)


def scene_to_dict(scene: Scene) -> dict:
    """The TOML layout of a procedural scene (inverse of :func:`scene_from_dict`).

    A ``video`` scene is written with its source path, which must still exist to reload it.
    """
    content = scene.content
    table = {"type": content.type_name}
    for f in fields(content):
        if f.name in ("rate_hz", "frames", "source"):
            continue
        value = getattr(content, f.name)
        table[f.name] = list(value) if isinstance(value, tuple) else value
    if isinstance(content, VideoFrames):
        table = {"type": "video", "path": content.source, "fps": content.fps, "brightness": content.brightness,
                 "srgb": True}
    cam = scene.camera
    camera = {"threshold": cam.threshold, "alpha": cam.alpha, "rate_hz": cam.rate_hz,
              "cfa": cam.cfa or "mono", "substeps": cam.substeps}
    effects = {name: dict(vars(effect)) for name, effect in scene.effects.items()}
    return {"name": scene.name, "description": scene.description, "planes": scene.planes, "camera": camera,
            "content": table, "effects": effects}

