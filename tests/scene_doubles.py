"""Minimal scenes for simulator tests: a flat field and a moving sinusoid (no procedural content)."""

from dataclasses import dataclass, field

import numpy as np

from spikeref.simulate.camera import Camera
from spikeref.simulate.effects import parse_effects


@dataclass(frozen=True)
class Flat:
    """Constant radiance ``rgb`` (rate units) everywhere, or a per-pixel ``(H, W, 3)`` map."""

    height: int
    width: int
    rgb: object = (0.3, 0.2, 0.1)
    static = True

    def radiance(self, times):
        img = np.broadcast_to(np.asarray(self.rgb, dtype=np.float32), (self.height, self.width, 3))
        return np.broadcast_to(img, (len(times),) + img.shape).copy()


@dataclass(frozen=True)
class Drifting:
    """A colour sinusoid drifting right at ``speed`` pixels per readout."""

    height: int
    width: int
    speed: float = 0.05
    static = False

    def radiance(self, times):
        x = np.arange(self.width, dtype=np.float64)[None, None, :]
        t = np.asarray(times, dtype=np.float64)[:, None, None]
        v = 0.5 + 0.4 * np.sin((x - self.speed * t) / 4.0)
        v = np.broadcast_to(v, (len(times), self.height, self.width))
        return np.stack([v, 0.5 * v, 1.0 - v], axis=-1).astype(np.float32)


@dataclass(frozen=True)
class SceneDouble:
    content: object
    planes: int = 64
    camera: Camera = field(default_factory=Camera)
    effects: dict = field(default_factory=dict)
    name: str = "double"


def scene(content, planes=64, effects=None, **camera):
    return SceneDouble(content=content, planes=planes, camera=Camera(**camera), effects=parse_effects(effects or {}))
