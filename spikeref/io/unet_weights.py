"""The denoiser's weights file (``.npz``): the bytes of :meth:`spikeref.denoise.unet.UNet.load` and ``save``.

Format ``"spikeref-unet-1"``: ``format``, ``width``, ``depth``, ``negative_slope``, for each layer
``<name>.weight`` ``(out, in, 3, 3) float32`` and ``<name>.bias`` ``(out,) float32`` (PyTorch's
layout), and ``meta`` (a JSON string: how the weights were made); ``in_channels`` (2) only in the file
of a network with an exposure channel (:attr:`spikeref.denoise.unet.UNetSpec.in_channels`; absent
means 1).  Which layers a network of a given shape has, and their shapes, is checked by
:class:`~spikeref.denoise.unet.UNet`.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from spikeref.io.atomic import atomic_write
from spikeref.io.npz import NUMPY_READ_ERRORS

__all__ = ["WEIGHTS_FORMAT", "read_unet_weights", "write_unet_weights"]

WEIGHTS_FORMAT = "spikeref-unet-1"


def read_unet_weights(path) -> tuple[dict, dict[str, np.ndarray], dict]:
    """Read a weights file: ``(shape, arrays, meta)``.

    ``shape`` holds ``width``, ``depth`` (int) and ``negative_slope`` (float); ``arrays`` the layers'
    arrays by name; ``meta`` the decoded JSON.  Raises ``FileNotFoundError`` for a missing file and
    ``ValueError`` (naming the file) for one that is not such an ``.npz``.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no weights file {path}")
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except NUMPY_READ_ERRORS as exc:
        raise ValueError(f"{path}: not a weights .npz ({exc})") from None
    fmt = str(data.pop("format", ""))
    if fmt != WEIGHTS_FORMAT:
        raise ValueError(f"{path}: format {fmt!r} is not {WEIGHTS_FORMAT!r}")
    try:
        shape = {"width": int(data.pop("width")), "depth": int(data.pop("depth")),
                 "negative_slope": float(data.pop("negative_slope"))}
    except KeyError as exc:
        raise ValueError(f"{path}: lacks {exc.args[0]!r}") from None
    if "in_channels" in data:  # only networks with an exposure channel write it
        shape["in_channels"] = int(data.pop("in_channels"))
    meta = json.loads(str(data.pop("meta", "{}")))
    return shape, data, meta


def write_unet_weights(path, shape: dict, arrays: dict[str, np.ndarray], meta: dict) -> Path:
    """Write a weights file atomically (``shape`` as :func:`read_unet_weights` returns it); returns the path."""
    path = Path(path)
    members = {
        "format": np.array(WEIGHTS_FORMAT), "width": np.array(shape["width"]), "depth": np.array(shape["depth"]),
        "negative_slope": np.array(shape["negative_slope"]), "meta": np.array(json.dumps(meta, sort_keys=True)),
        **({"in_channels": np.array(shape["in_channels"])} if shape.get("in_channels", 1) != 1 else {}),
        **arrays,
    }

    def write(tmp):
        with open(tmp, "wb") as f:
            np.savez(f, **members)

    return atomic_write(path, write)
