"""What every scene content shares: the base class, the checks of its fields, the anti-aliased drawing.

A scene's *content* is what the camera looks at (:class:`spikeref.simulate.scenes.Scene` adds the
camera of Eq. 1–3 and the noise effects of Eq. 5–9).  This module holds the base of every content
type, :class:`SceneContent`, the checks its fields go through (each ``ValueError`` names the field
as a scene file writes it, ``content.<name>``), and the geometry the procedural and photographic
contents draw with (a 1-pixel coverage ramp, the view's pixel grid).  The content types live by kind
in :mod:`~spikeref.simulate.patterns`, :mod:`~spikeref.simulate.moving_patterns`,
:mod:`~spikeref.simulate.video_frames` and :mod:`~spikeref.simulate.photographs`.

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
  :func:`~spikeref.simulate.scenes.scene_from_dict` sets it from ``[camera] rate_hz``, and
  :class:`~spikeref.simulate.scenes.Scene` refuses a content whose ``rate_hz`` differs from its
  camera's.  Keeping the rate on the content makes ``radiance(t)`` self-contained: the same object
  gives the same ground truth everywhere.
* ``height`` and ``width`` are even (a Bayer sensor).  Content objects are frozen; static
  layers are rendered once on first use and cached (they are derived from the fields).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

__all__ = [
    "SceneContent",
    "is_number",
    "check_number",
    "check_integer",
    "check_even_size",
    "check_numbers",
    "check_rgb",
    "check_xy",
    "coerce_field",
    "pixel_box",
    "view_points",
    "in_view",
    "coverage",
]


# ----------------------------------------------------------------------------- validation
def is_number(value) -> bool:
    """Whether ``value`` is a real number (a Python or NumPy integer or float, not a bool)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def check_number(name: str, value, minimum=None, maximum=None, open_min=False) -> float:
    """``float(value)`` if it is a finite number in range, else ``ValueError`` naming ``content.<name>``.

    Parameters
    ----------
    name : str
        The field, as a scene file names it below ``content``.
    value
        What was given.
    minimum, maximum : float, optional
        The range (``None``: unbounded on that side); ``maximum`` is inclusive.
    open_min : bool
        Whether ``minimum`` itself is excluded.
    """
    ok = is_number(value) and math.isfinite(value)
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


def check_integer(name: str, value, minimum: int) -> int:
    """``int(value)`` if it is an integer ≥ ``minimum`` (not a bool), else ``ValueError`` naming ``content.<name>``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"content.{name} must be an integer ≥ {minimum}; got {value!r}")
    return int(value)


def check_even_size(name: str, value) -> int:
    """``int(value)`` if it is an even integer ≥ 2 (a Bayer sensor's side), else ``ValueError`` naming it."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 2 or value % 2:
        raise ValueError(f"content.{name} must be an even integer ≥ 2 (a Bayer sensor); got {value!r}")
    return int(value)


def check_numbers(name: str, value, count: int, what: str, minimum=None) -> tuple:
    """``count`` finite numbers from a sequence, else ``ValueError`` naming ``content.<name>`` and ``what``."""
    try:
        values = tuple(value)
    except TypeError:
        values = ()
    if len(values) != count:
        raise ValueError(f"content.{name} must be {what}; got {value!r}")
    return tuple(check_number(name, v, minimum=minimum) for v in values)


def check_rgb(name: str, value) -> tuple:
    """Three finite numbers ≥ 0 ``(R, G, B)``, else ``ValueError`` naming ``content.<name>``."""
    return check_numbers(name, value, 3, "3 values (R, G, B)", minimum=0)


def check_xy(name: str, value) -> tuple:
    """Two finite numbers ``(x, y)`` (a position in pixels), else ``ValueError`` naming ``content.<name>``."""
    return check_numbers(name, value, 2, "(x, y) in pixels")


def coerce_field(cls, key: str, value):
    """A scene-file value as the field wants it: lists → tuples, ``256.0`` → 256 for integer fields.

    Parameters
    ----------
    cls : type
        The content class (a dataclass) whose field ``key`` receives ``value``.
    key : str
        The field's name.
    value
        The value as TOML gave it.
    """
    if isinstance(value, list):
        return tuple(value)
    kind = {f.name: f.type for f in fields(cls)}.get(key)
    if kind in ("int", int) and isinstance(value, float) and value.is_integer():
        return int(value)
    return value


# ----------------------------------------------------------------------------- drawing
def pixel_box(h: int, w: int, cy: float, cx: float, half_h: float, half_w: float) -> tuple:
    """Row and column slices of the pixels whose centres lie within ``half_h``/``half_w`` of ``(cy, cx)``."""
    return (slice(max(0, math.floor(cy - half_h)), max(0, min(h, math.ceil(cy + half_h)))),
            slice(max(0, math.floor(cx - half_w)), max(0, min(w, math.ceil(cx + half_w)))))


def view_points(h: int, w: int) -> np.ndarray:
    """``(x, y)`` of every pixel of an ``h × w`` view: ``(h, w, 2) float64`` (pixel centres at integers)."""
    yy, xx = np.mgrid[0:h, 0:w]
    return np.stack([xx, yy], axis=-1).astype(np.float64)


def in_view(points: np.ndarray, h: int, w: int) -> np.ndarray:
    """Whether ``(x, y)`` positions ``(..., 2)`` lie on an ``h × w`` view (pixel centres at integers)."""
    x, y = points[..., 0], points[..., 1]
    return (x >= -0.5) & (x <= w - 0.5) & (y >= -0.5) & (y <= h - 0.5)


def coverage(signed_distance):
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
        (set from the camera by :func:`~spikeref.simulate.scenes.scene_from_dict`).
    """

    height: int = 256
    width: int = 256
    rate_hz: float = 20000.0
    type_name: ClassVar[str] = ""

    def __post_init__(self):
        object.__setattr__(self, "height", check_even_size("height", self.height))
        object.__setattr__(self, "width", check_even_size("width", self.width))
        object.__setattr__(self, "rate_hz", check_number("rate_hz", self.rate_hz, minimum=0, open_min=True))

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
        pts = view_points(self.height, self.width) if points is None else np.asarray(points, dtype=np.float64)
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
