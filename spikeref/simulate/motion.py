"""Parametric image motion for the simulator, and the exact flow it implies (issue: natural motion).

A :class:`Motion` moves a layer of content in the image plane.  A point of the layer that
sits at position ``p`` at time 0 sits at time ``t`` (seconds) at

.. math::

    x(t) = c + M(t)\\,(p - c) + v\\,t, \\qquad M(t) = \\exp(G\\,t),

with ``c`` the centre of the motion, ``v`` the translation velocity and ``G`` the 2×2
velocity gradient: ``G = z·I + ω·J + A`` for a zoom rate ``z`` (the scale grows as
``e^{z t}``), a rotation rate ``ω`` (``J`` the quarter turn) and any further affine rate ``A``.
Translation, rotation about a point, zoom about a point and affine motion are all of this
form; ``M(t)`` is the exact matrix exponential, so the motion is exact at every time (no
integration error) and invertible.

Coordinates are ``(x, y)`` in pixels of the full-resolution image: pixel ``(row, col)`` has
its centre at ``(x, y) = (col, row)``; ``+y`` is downwards, so a positive ``ω`` turns
clockwise on the screen.

The flow between two times (:func:`layer_flow`) is the exact **backward flow** of the
project's convention (:mod:`spikeref.align`): at a pixel ``x`` of the reference time, the
displacement ``x(t') − x`` to where the content seen there is at time ``t'``, so that
``frame_{t'}[x + F(x)] = frame_t[x]``.  :func:`plane_grid_points` gives the positions of the
Bayer-plane pixels, so the flow can be evaluated on the grid the pipeline works on (in plane
pixels: full-resolution displacement / 2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Motion", "layer_flow", "plane_grid_points", "plane_flow"]


def _finite(name: str, value) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number; got {value!r}")
    return float(value)


def _pair(name: str, value) -> tuple:
    try:
        values = tuple(value)
    except TypeError:
        values = ()
    if len(values) != 2:
        raise ValueError(f"{name} must be two numbers (x, y); got {value!r}")
    return tuple(_finite(name, v) for v in values)


def _expm2(g: np.ndarray) -> np.ndarray:
    """Exact exponential of a real 2×2 matrix (closed form through its eigenvalues)."""
    tr = 0.5 * (g[0, 0] + g[1, 1])
    b = g - tr * np.eye(2)  # trace-free part: b @ b = -det(b) * I
    delta = -float(b[0, 0] * b[1, 1] - b[0, 1] * b[1, 0])  # −det(b), written out (no LAPACK for a 2×2)
    if delta > 0:
        s = math.sqrt(delta)
        m = math.cosh(s) * np.eye(2) + (math.sinh(s) / s) * b
    elif delta < 0:
        s = math.sqrt(-delta)
        m = math.cos(s) * np.eye(2) + (math.sin(s) / s) * b
    else:
        m = np.eye(2) + b
    return math.exp(tr) * m


@dataclass(frozen=True)
class Motion:
    """A layer's motion: translation, rotation, zoom and affine rate about a centre.

    Attributes
    ----------
    velocity : tuple ``(v_x, v_y)``
        Translation, pixels per second (``+v_y`` downwards; 2000 px/s = 1 px per 10 readouts
        at 20 kHz).
    rotation : float
        Degrees per second, clockwise on the screen (``+y`` downwards).
    zoom : float
        Logarithmic scale rate per second: the layer's scale is ``exp(zoom · t)`` (0.5 /s grows it
        by 0.0025 % per readout at 20 kHz).
    affine : tuple ``((a, b), (c, d))``
        A further velocity gradient per second, added to the rotation and zoom (``G`` of the
        module docstring); ``((s, 0), (0, -s))`` stretches along ``x`` and squeezes along ``y``.
    center : tuple ``(x, y)`` or None
        Centre of rotation, zoom and affine motion, in pixels at time 0; ``None`` (default):
        the layer's own centre, set by the content that owns the motion (:meth:`with_center`).
    """

    velocity: tuple = (0.0, 0.0)
    rotation: float = 0.0
    zoom: float = 0.0
    affine: tuple = ((0.0, 0.0), (0.0, 0.0))
    center: tuple | None = None

    def __post_init__(self):
        object.__setattr__(self, "velocity", _pair("motion.velocity", self.velocity))
        object.__setattr__(self, "rotation", _finite("motion.rotation", self.rotation))
        object.__setattr__(self, "zoom", _finite("motion.zoom", self.zoom))
        try:
            rows = tuple(tuple(r) for r in self.affine)
        except TypeError:
            rows = ()
        if len(rows) != 2 or any(len(r) != 2 for r in rows):
            raise ValueError(f"motion.affine must be a 2×2 matrix ((a, b), (c, d)) per second; got {self.affine!r}")
        object.__setattr__(self, "affine", tuple(tuple(_finite("motion.affine", v) for v in r) for r in rows))
        if self.center is not None:
            object.__setattr__(self, "center", _pair("motion.center", self.center))

    @classmethod
    def from_table(cls, table, name: str = "motion") -> "Motion":
        """A motion from a scene file's table (``velocity``, ``rotation``, ``zoom``, ``affine``, ``center``)."""
        if table is None:
            return cls()
        if isinstance(table, Motion):
            return table
        if not isinstance(table, dict):
            raise ValueError(f"{name} must be a table of velocity, rotation, zoom, affine, center; got {table!r}")
        allowed = ("velocity", "rotation", "zoom", "affine", "center")
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            raise ValueError(f"unknown field {name}.{unknown[0]}; a motion takes {', '.join(allowed)}")
        try:
            return cls(**table)
        except ValueError as exc:
            raise ValueError(str(exc).replace("motion.", f"{name}.", 1)) from None

    def to_table(self) -> dict:
        """The scene-file table of this motion (the inverse of :meth:`from_table`)."""
        out = {"velocity": list(self.velocity), "rotation": self.rotation, "zoom": self.zoom,
               "affine": [list(r) for r in self.affine]}
        if self.center is not None:
            out["center"] = list(self.center)
        return out

    def with_center(self, center) -> "Motion":
        """This motion with ``center`` filled in where it was ``None``."""
        if self.center is not None:
            return self
        return Motion(self.velocity, self.rotation, self.zoom, self.affine, tuple(center))

    @property
    def static(self) -> bool:
        """True when nothing moves."""
        return (self.velocity == (0.0, 0.0) and self.rotation == 0.0 and self.zoom == 0.0
                and self.affine == ((0.0, 0.0), (0.0, 0.0)))

    @property
    def gradient(self) -> np.ndarray:
        """``G`` (2×2, per second) acting on ``(x, y)``."""
        w = math.radians(self.rotation)
        return (np.array(self.affine, dtype=np.float64) + self.zoom * np.eye(2)
                + w * np.array([[0.0, -1.0], [1.0, 0.0]]))

    def matrix(self, seconds: float) -> np.ndarray:
        """``M(t) = exp(G t)``."""
        return _expm2(self.gradient * float(seconds))

    def _center(self) -> np.ndarray:
        if self.center is None:
            raise ValueError("the motion's center is not set (use with_center)")
        return np.asarray(self.center, dtype=np.float64)

    def forward(self, points: np.ndarray, seconds: float) -> np.ndarray:
        """Positions at time ``t`` of the layer points at ``points`` (``(..., 2)`` x, y) at time 0."""
        c = self._center()
        m = self.matrix(seconds)
        v = np.asarray(self.velocity) * float(seconds)
        return (np.asarray(points, dtype=np.float64) - c) @ m.T + c + v

    def inverse(self, points: np.ndarray, seconds: float) -> np.ndarray:
        """Layer positions at time 0 of what is seen at ``points`` (``(..., 2)`` x, y) at time ``t``."""
        c = self._center()
        m_inv = self.matrix(-float(seconds))
        v = np.asarray(self.velocity) * float(seconds)
        return (np.asarray(points, dtype=np.float64) - c - v) @ m_inv.T + c


def layer_flow(motion: Motion, points: np.ndarray, t_ref: float, t_other: float) -> np.ndarray:
    """Exact backward flow ``x(t_other) − x`` at ``points`` seen at ``t_ref`` (seconds); ``(..., 2)`` (dx, dy)."""
    p = np.asarray(points, dtype=np.float64)
    return motion.forward(motion.inverse(p, t_ref), t_other) - p


def plane_grid_points(height: int, width: int, offset=None) -> np.ndarray:
    """Full-resolution ``(x, y)`` of the Bayer-plane pixels: ``(height/2, width/2, 2) float64``.

    ``offset=(dy, dx)`` in ``{0, 1}²`` gives the pixels of one Bayer plane (plane pixel
    ``(i, j)`` is pixel ``(2i + dy, 2j + dx)``); ``None`` (default) gives the centres of the
    2×2 cells, ``(2j + ½, 2i + ½)`` — where the 2×2 luma the alignment works on lives.
    """
    if offset is None:
        dy = dx = 0.5
    else:
        dy, dx = offset
    ii, jj = np.mgrid[0:height // 2, 0:width // 2]
    return np.stack([2.0 * jj + dx, 2.0 * ii + dy], axis=-1)


def plane_flow(content, t_ref: float, t_other: float, offset=None):
    """The exact backward flow on the Bayer-plane grid, in the pipeline's convention.

    Parameters
    ----------
    content : SceneContent
        A scene's content with a motion model (:meth:`SceneContent.true_flow`).
    t_ref, t_other : float
        Times in readouts (a window ``k`` of ``W`` planes is centred on ``(k + ½) W``).
    offset : tuple ``(dy, dx)`` in ``{0, 1}²`` or None
        Evaluate at the pixels of one Bayer plane; ``None``: at the 2×2 cell centres (what the
        alignment of the 2×2 luma estimates).

    Returns
    -------
    flow : ndarray ``(2, H/2, W/2) float32`` or None
        ``(dy, dx)`` in **plane pixels** (full-resolution displacement / 2), so that
        ``plane_{t_other}[y + dy, x + dx] = plane_{t_ref}[y, x]`` (:mod:`spikeref.align`);
        ``None`` when the content has no motion model (a user's video).
    visible : ndarray ``(H/2, W/2) bool`` or None
        False where the content is hidden (occlusion) or outside the view at ``t_other``.
    """
    pts = plane_grid_points(content.height, content.width, offset)
    got = content.true_flow(t_ref, t_other, pts)
    if got is None:
        return None, None
    flow, visible = got
    out = np.stack([flow[..., 1], flow[..., 0]]) / 2.0
    return out.astype(np.float32), np.asarray(visible, dtype=bool)
