"""Still procedural patterns: a flat field, the ColorChecker chart and a lamp beside a deep shadow.

Content types (the ``type`` of a scene file, see :mod:`spikeref.simulate.scenes`) whose radiance does
not change over time, made from their fields alone:

=======================  ======================  ==============================================================
``type``                 class                   what it shows
=======================  ======================  ==============================================================
``uniform``              :class:`Uniform`        a flat field of one colour (a grey card for the noise check)
``color_chart``          :class:`ColorChart`     the 24 ColorChecker colours, 4 × 6 patches on a dark board
``hdr_lamp``             :class:`HDRLamp`        a lamp ≥ 10⁴ × brighter than a textured deep shadow beside it
=======================  ======================  ==============================================================

Radiance is in rate units (spikes per readout with the default camera of Eq. 1–3); see
:mod:`spikeref.simulate.content` for the units and conventions every content follows.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar

import numpy as np

from spikeref.simulate.content import SceneContent, check_number, check_rgb, coverage, pixel_box
from spikeref.tonemap import srgb_decode

__all__ = ["Uniform", "ColorChart", "HDRLamp", "COLORCHECKER_SRGB"]

#: The 24 ColorChecker Classic patches in 8-bit sRGB, row by row (published reference values).
COLORCHECKER_SRGB = (
    (115, 82, 68), (194, 150, 130), (98, 122, 157), (87, 108, 67), (133, 128, 177), (103, 189, 170),
    (214, 126, 44), (80, 91, 166), (193, 90, 99), (94, 60, 108), (157, 188, 64), (224, 163, 46),
    (56, 61, 150), (70, 148, 73), (175, 54, 60), (231, 199, 31), (187, 86, 149), (8, 133, 161),
    (243, 243, 242), (200, 200, 200), (160, 160, 160), (122, 122, 121), (85, 85, 85), (52, 52, 52),
)


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
        object.__setattr__(self, "brightness", check_number("brightness", self.brightness, minimum=0))
        object.__setattr__(self, "color", check_rgb("color", self.color))

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
        object.__setattr__(self, "brightness", check_number("brightness", self.brightness, minimum=0))
        object.__setattr__(self, "board", check_number("board", self.board, minimum=0, maximum=1))

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
                box = pixel_box(h, w, cy, cx, 0.4 * cell_h + 1, 0.4 * cell_w + 1)  # the patch and its edge ramp
                yy = np.arange(h)[box[0], None] + 0.5
                xx = np.arange(w)[None, box[1]] + 0.5
                sd = np.maximum(np.abs(yy - cy) - 0.4 * cell_h, np.abs(xx - cx) - 0.4 * cell_w)
                cov = coverage(sd)[..., None]
                img[box] = img[box] * (1 - cov) + patches[r, c] * cov
        return (img * self.brightness).astype(np.float32)

    def radiance(self, times) -> np.ndarray:
        return self._repeat(self._image, self._times(times).size)


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
        object.__setattr__(self, "brightness", check_number("brightness", self.brightness, minimum=0))
        object.__setattr__(self, "lamp", check_number("lamp", self.lamp, minimum=0, open_min=True))
        object.__setattr__(self, "shadow", check_number("shadow", self.shadow, minimum=0, open_min=True))

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
        cov = coverage(d - lr)[..., None]
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
