"""Scenes for the simulator: what the camera looks at, with which camera and effects, and scene files.

A :class:`Scene` holds what the camera looks at (its *content*), the camera (Eq. 1–3
parameters, :class:`spikeref.simulate.camera.Camera`) and the noise effects to run
(:mod:`spikeref.simulate.effects`).  This module is the registry of the content types
(:data:`CONTENT_TYPES`, by the ``type`` of a scene file) and reads and writes scene files; the
contents themselves live by kind in their own modules:

=======================  ============================  ==============================================================
``type``                 class                         what it shows
=======================  ============================  ==============================================================
``uniform``              :class:`Uniform`              a flat field of one colour (a grey card for the noise check)
``color_chart``          :class:`ColorChart`           the 24 ColorChecker colours, 4 × 6 patches on a dark board
``translating_texture``  :class:`TranslatingTexture`   a periodic colour texture sliding at a fixed velocity
``fan``                  :class:`FanOverToys`          a fast rotating fan over a still background of toys (Fig. 7a)
``hdr_lamp``             :class:`HDRLamp`              a lamp ≥ 10⁴ × brighter than a textured deep shadow beside it
``video``                :class:`VideoFrames`          a user's frames, interpolated linearly to the readout rate
``image``                :class:`ImageMotion`          a photograph moving (translation, rotation, zoom), optionally
                                                       behind a moving disc cut out of another photograph
=======================  ============================  ==============================================================

The still procedural patterns (``uniform``, ``color_chart``, ``hdr_lamp``) are in
:mod:`spikeref.simulate.patterns`, the moving ones (``translating_texture``, ``fan``) in
:mod:`spikeref.simulate.moving_patterns`, ``video`` in :mod:`spikeref.simulate.video_frames` and
``image`` in :mod:`spikeref.simulate.photographs`.  Their base class, the checks of their fields
and the units and conventions they all follow (radiance in rate units at times in readouts,
velocities per second) are in :mod:`spikeref.simulate.content`; the video and photographs a scene
file names are read by :mod:`spikeref.simulate.scene_media`.

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
Without a resize, a source of odd height or width loses its **last row or column**.  An
``image`` content takes the fields :data:`~spikeref.simulate.scene_media.IMAGE_KEYS` (see
:func:`~spikeref.simulate.scene_media.image_from_table`).  Errors are ``ValueError`` naming the
file and the field path (``content.revolutions_per_second``).
"""

from __future__ import annotations

import sys
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from spikeref.simulate.camera import Camera
from spikeref.simulate.content import SceneContent, coerce_field
from spikeref.simulate.effects import parse_effects
from spikeref.simulate.moving_patterns import FanOverToys, TranslatingTexture
from spikeref.simulate.patterns import COLORCHECKER_SRGB, ColorChart, HDRLamp, Uniform
from spikeref.simulate.photographs import ImageMotion
from spikeref.simulate.scene_media import IMAGE_KEYS, VIDEO_KEYS, image_from_table, image_to_table, video_from_table
from spikeref.simulate.scene_media import SKIMAGE_PREFIX  # noqa: F401 - named here by spikeref.bench.runner
from spikeref.simulate.video_frames import VideoFrames

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


def _content_keys(cls) -> list[str]:
    if cls is VideoFrames:
        return list(VIDEO_KEYS)
    if cls is ImageMotion:
        return list(IMAGE_KEYS)
    return [f.name for f in fields(cls) if f.init and f.name != "rate_hz"]


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
            content = video_from_table(table, camera.rate_hz, base_dir)
        elif cls is ImageMotion:
            content = image_from_table(table, camera.rate_hz, base_dir)
        else:
            content = cls(rate_hz=camera.rate_hz, **{k: coerce_field(cls, k, v) for k, v in table.items()})
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
        table = image_to_table(content)
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
