"""Procedural patterns in motion, with their exact flow: a sliding texture and a fan over toys (Fig. 7a).

Content types (the ``type`` of a scene file, see :mod:`spikeref.simulate.scenes`) drawn from their
fields alone, whose motion is known exactly (:meth:`~spikeref.simulate.content.SceneContent.true_flow`):

=======================  ============================  ========================================================
``type``                 class                         what it shows
=======================  ============================  ========================================================
``translating_texture``  :class:`TranslatingTexture`   a periodic colour texture sliding at a fixed velocity
``fan``                  :class:`FanOverToys`          a fast rotating fan over a still background of toys
                                                       (the paper's Fig. 7a)
=======================  ============================  ========================================================

Velocities are per second and converted with the content's ``rate_hz``; see
:mod:`spikeref.simulate.content` for the units and conventions every content follows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar

import numpy as np

from spikeref.simulate.content import (
    SceneContent, check_integer, check_number, check_rgb, coverage, in_view, pixel_box, view_points,
)

__all__ = ["TranslatingTexture", "FanOverToys"]


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
        cov = coverage(sd)[..., None]
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
        object.__setattr__(self, "brightness", check_number("brightness", self.brightness, minimum=0))
        try:
            v = tuple(self.velocity)
        except TypeError:
            v = ()
        if len(v) != 2:
            raise ValueError(f"content.velocity must be (v_x, v_y) in pixels/second; got {self.velocity!r}")
        object.__setattr__(self, "velocity", tuple(check_number("velocity", c) for c in v))
        object.__setattr__(self, "texture_size", check_integer("texture_size", self.texture_size, 8))
        object.__setattr__(self, "seed", check_integer("seed", self.seed, 0))

    @property
    def static(self) -> bool:
        return self.velocity == (0.0, 0.0)

    def true_flow(self, t_ref: float, t_other: float, points: np.ndarray | None = None):
        """The exact flow of a translation: ``v (t_other − t_ref)`` everywhere (see :meth:`SceneContent.true_flow`)."""
        pts = view_points(self.height, self.width) if points is None else np.asarray(points, dtype=np.float64)
        d = np.asarray(self.velocity) * (float(t_other) - float(t_ref)) / self.rate_hz
        flow = np.broadcast_to(d, pts.shape).copy()
        target = pts + flow
        return flow, in_view(target, self.height, self.width)

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
        box = pixel_box(h, w, cy, cx, 1.1 * size + 1, 1.1 * size + 1)  # every toy lies within 1.02 · size
        dy, dx = yy[box] - cy, xx[box] - cx
        kind = k % 5
        if kind == 0:  # ball, shaded as if lit from the top left
            d = np.hypot(dy, dx)
            cov = coverage(d - size)
            shade = np.clip(1.15 - 0.6 * np.hypot(dy + 0.4 * size, dx + 0.4 * size) / size, 0.35, 1.15)
            layer = color * shade[..., None]
        elif kind == 1:  # block
            cov = coverage(np.maximum(np.abs(dy) - size * 0.8, np.abs(dx) - size * 0.6))
            layer = np.broadcast_to(color, dy.shape + (3,))
        elif kind == 2:  # ring
            d = np.hypot(dy, dx)
            cov = coverage(np.abs(d - size * 0.8) - size * 0.22)
            layer = np.broadcast_to(color, dy.shape + (3,))
        elif kind == 3:  # box with diagonal stripes
            cov = coverage(np.maximum(np.abs(dy) - size * 0.7, np.abs(dx) - size * 0.9))
            stripes = (np.floor((dx + dy) / max(2.0, size / 4)) % 2)[..., None]
            layer = color * (0.35 + 0.65 * stripes) + (1 - stripes) * 0.05
        else:  # checked cube
            cov = coverage(np.maximum(np.abs(dy), np.abs(dx)) - size * 0.75)
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
        setattr_(self, "brightness", check_number("brightness", self.brightness, minimum=0))
        setattr_(self, "revolutions_per_second", check_number("revolutions_per_second", self.revolutions_per_second))
        setattr_(self, "blades", check_integer("blades", self.blades, 1))
        setattr_(self, "radius", check_number("radius", self.radius, minimum=0, maximum=1, open_min=True))
        setattr_(self, "hub", check_number("hub", self.hub, minimum=0, maximum=1))
        setattr_(self, "blade_width",
                 check_number("blade_width", self.blade_width, minimum=0, maximum=1, open_min=True))
        setattr_(self, "blade_color", check_rgb("blade_color", self.blade_color))
        setattr_(self, "hub_color", check_rgb("hub_color", self.hub_color))
        setattr_(self, "seed", check_integer("seed", self.seed, 0))

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
        blade = coverage((np.abs(rel) - half) * r) * radial
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
        radial = coverage(np.maximum(r - tip, hub * 0.5 - r))
        return r, theta, half, radial, coverage(r - hub)

    def true_flow(self, t_ref: float, t_other: float, points: np.ndarray | None = None):
        """The exact flow of the fan (see :meth:`SceneContent.true_flow`): a point covered by the fan at ``t_ref``
        (coverage ≥ ½) turns with it about the centre; a point of the background stays, and is hidden at
        ``t_other`` where the fan covers it then.  The blades are rigid: what they show stays visible."""
        pts = view_points(self.height, self.width) if points is None else np.asarray(points, dtype=np.float64)
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
        return flow, in_view(target, self.height, self.width) & ~hidden

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
            blade = coverage(dist) * lay.radial
            cov = np.maximum(blade, lay.hub)
            on_hub = lay.hub >= blade
            keep = 1 - cov
            box = out[i][lay.box]
            for k in range(3):  # per channel: 2-D operations are much faster than (h, w, 3) broadcasting
                box[..., k] = lay.background_planes[k] * keep + np.where(on_hub, lay.hub_rgb[k], lay.blade_rgb[k]) * cov
        return out
