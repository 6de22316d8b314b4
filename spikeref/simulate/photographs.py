"""A photograph moving in front of the camera, optionally behind an occluding disc, with its exact flow.

The content type ``image`` of a scene file (:mod:`spikeref.simulate.scenes`): :class:`ImageMotion`
moves a background photograph by a parametric :class:`~spikeref.simulate.motion.Motion`
(translation, rotation and zoom) and, when given, a foreground disc cut out of a second photograph
by its own motion; :meth:`ImageMotion.true_flow` is the exact backward flow between any two times
and where it holds (the ground truth the alignment of §4.2 is measured against).  Reading the
photographs a scene file names is :func:`spikeref.simulate.scene_media.image_from_table`'s.  See
:mod:`spikeref.simulate.content` for the units and conventions every content follows.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import ClassVar

import numpy as np

from spikeref.simulate.content import (
    SceneContent, check_number, check_numbers, check_xy, coverage, in_view, view_points,
)
from spikeref.simulate.motion import Motion, layer_flow

__all__ = ["ImageMotion"]


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
        What the images were read from, for :func:`~spikeref.simulate.scenes.scene_to_dict` (``""`` when
        built from arrays).
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
        object.__setattr__(self, "origin", check_numbers("origin", origin, 2, "(x, y) in image pixels"))
        motion = Motion.from_table(self.motion, "content.motion")
        object.__setattr__(self, "motion", motion.with_center(view_centre))
        if self.fg_image is None:
            if self.fg_radius or self.fg_center is not None or self.fg_source_center is not None:
                raise ValueError("content.foreground fields were given without a foreground image")
            object.__setattr__(self, "fg_motion", Motion.from_table(self.fg_motion, "content.foreground.motion"))
            return
        fg = self._radiance_array("fg_image", self.fg_image)
        object.__setattr__(self, "fg_image", fg)
        object.__setattr__(self, "fg_radius", check_number("foreground.radius", self.fg_radius, minimum=0,
                                                         open_min=True))
        centre = view_centre if self.fg_center is None else check_xy("foreground.center", self.fg_center)
        source_centre = ((fg.shape[1] - 1) / 2.0, (fg.shape[0] - 1) / 2.0) if self.fg_source_center is None \
            else check_xy("foreground.source_center", self.fg_source_center)
        object.__setattr__(self, "fg_center", centre)
        object.__setattr__(self, "fg_source_center", source_centre)
        fg_motion = Motion.from_table(self.fg_motion, "content.foreground.motion")
        object.__setattr__(self, "fg_motion", fg_motion.with_center(centre))

    @property
    def static(self) -> bool:
        return self.motion.static and (self.fg_image is None or self.fg_motion.static)

    @cached_property
    def _view_points(self) -> np.ndarray:
        return view_points(self.height, self.width)

    def _fg_coverage(self, points: np.ndarray, seconds: float) -> tuple:
        """Foreground coverage in [0, 1] at view ``points`` and the layer positions at time 0."""
        q = self.fg_motion.inverse(points, seconds)
        d = np.hypot(q[..., 0] - self.fg_center[0], q[..., 1] - self.fg_center[1]) - self.fg_radius
        return coverage(d), q

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
        return flow, visible & in_view(target, self.height, self.width)
