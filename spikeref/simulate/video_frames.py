"""A user's video as scene content: its frames interpolated linearly in time to the readout rate.

The content type ``video`` of a scene file (:mod:`spikeref.simulate.scenes`): :class:`VideoFrames`
holds frames already read and scaled to radiance; reading them from a video file, a folder of
images or a glob, decoding sRGB and resizing is :func:`spikeref.simulate.scene_media.video_from_table`'s.
See :mod:`spikeref.simulate.content` for the units and conventions every content follows (the
radiance feeds Eq. 1–3 like any other content's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from spikeref.simulate.content import SceneContent, check_number

__all__ = ["VideoFrames"]


@dataclass(frozen=True, kw_only=True)
class VideoFrames(SceneContent):
    """Frames of a video or image sequence, interpolated linearly in time to the readout rate.

    Readout time ``t`` is source time ``s = t · fps / rate_hz`` (in source frames, frame ``k``
    at ``s = k``); the radiance is ``(1 − f) · frames[⌊s⌋] + f · frames[⌊s⌋ + 1]`` with
    ``f = s − ⌊s⌋``, and holds the first frame before ``s = 0`` and the last after ``s = N − 1``.
    ``height`` and ``width`` come from the frames.  No file is read here: a scene file's
    ``video`` content is read, decoded and scaled by :func:`~spikeref.simulate.scenes.scene_from_dict`.

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
        The scene-file options used to read ``source`` (brightness, srgb, ...), for
        :func:`~spikeref.simulate.scenes.scene_to_dict`.
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
        object.__setattr__(self, "fps", check_number("fps", self.fps, minimum=0, open_min=True))

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
