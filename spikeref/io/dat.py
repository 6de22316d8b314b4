"""The spike-camera ``.dat`` layout, and writing ``.dat``/``.npy``/``.npz`` spike files.

This module handles bytes only; opening a file as a stream is :mod:`spikeref.stream`'s.

Layout (the one SpikeCV, Spike-Zoo and Spk2ImgNet read; ``docs/spec/io.md``)
-----------------------------------------------------------------
* no header; the file is a sequence of planes, each ``H·Wf/8`` bytes where
  ``Wf`` is the stored row width (``Wf = W`` except on cameras that store
  wider rows, e.g. 1024-wide rows for a 1000×1000 sensor);
* inside a plane pixels are row-major; pixel ``p`` is bit ``p % 8`` of byte
  ``p // 8`` (LSB first);
* rows are stored bottom-up: stored row ``r`` is image row ``H - 1 - r`` (``rows="bottom-up"``, the
  default and the spike camera's); files written top-down (stored row ``r`` is image row ``r``, as
  SSL-CSC's simulated recordings) are read with ``rows="top-down"`` (``docs/inputs.md``).

Reading never loads the file: :func:`map_dat` memory-maps it (and
:func:`spikeref.stream.read_dat` wraps the map in a :class:`~spikeref.stream.SpikeStream`);
planes are unpacked only when a window is asked for, and Eq. 4 counts are taken from the packed bytes directly
(:func:`spikeref.accumulate.accumulate`).  Writing is atomic: a temporary
file in the same folder, renamed over the target when complete.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from spikeref.io.atomic import atomic_write, publish, temporary_beside

__all__ = [
    "ROW_ORDERS",
    "check_rows",
    "sidecar_path",
    "plane_nbytes",
    "check_spikes",
    "pack_planes",
    "unpack_planes",
    "map_dat",
    "write_dat",
    "DatWriter",
    "read_sidecar",
    "save_spikes",
]


#: The row orders a ``.dat`` file may store: ``"bottom-up"`` (the spike camera's and the default: stored row
#: ``r`` is image row ``H - 1 - r``) and ``"top-down"`` (stored row ``r`` is image row ``r``).
ROW_ORDERS = ("bottom-up", "top-down")


def check_rows(rows, name: str = "rows") -> str:
    """Validate a stored row order and return it in lower case (``"bottom-up"`` or ``"top-down"``).

    Raises
    ------
    TypeError
        ``rows`` is not a string; the message names ``name``.
    ValueError
        Any other string; the message names ``name`` and the two orders.
    """
    if not isinstance(rows, str):
        raise TypeError(f"{name} must be one of {', '.join(map(repr, ROW_ORDERS))}; got {type(rows).__name__}")
    if rows.lower() not in ROW_ORDERS:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, ROW_ORDERS))} (the order the .dat stores "
                         f"the image rows in); got {rows!r}")
    return rows.lower()


def plane_nbytes(height: int, width: int) -> int:
    """Bytes of one stored plane, ``height * width / 8``; raises if not whole."""
    for name, v in (("height", height), ("width", width)):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1:
            raise ValueError(f"{name} must be a positive integer; got {v!r}")
    if (height * width) % 8:
        raise ValueError(
            f"a .dat plane of {height}×{width} pixels is not a whole number of bytes "
            f"(height*width = {height * width} is not a multiple of 8)"
        )
    return height * width // 8


def check_spikes(spikes, name: str = "spikes", check_values: bool = True) -> np.ndarray:
    """Validate a ``(T, H, W)`` array of 0/1 spikes and return it as uint8."""
    arr = np.asarray(spikes)
    if arr.ndim != 3:
        raise ValueError(f"{name} must have shape (T, H, W); got shape {arr.shape}")
    if arr.dtype == bool:
        return arr.view(np.uint8)
    if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise TypeError(f"{name} must be uint8 0/1 (or bool, integer or float holding only 0 and 1); "
                        f"got dtype {arr.dtype}")
    if check_values and arr.size:
        if arr.dtype == np.uint8:
            bad = arr.max() > 1
        else:
            bad = bool(np.any((arr != 0) & (arr != 1)))
        if bad:
            raise ValueError(f"{name} must contain only 0 and 1 (one bit per pixel and readout)")
    return arr.astype(np.uint8, copy=False)


def pack_planes(spikes: np.ndarray, rows: str = "bottom-up") -> np.ndarray:
    """Pack upright ``(T, H, W)`` 0/1 planes into the ``.dat`` byte layout ``(T, H*W/8) uint8``.

    ``rows`` is the order the rows are stored in: ``"bottom-up"`` (the spike camera's, default) or
    ``"top-down"``.
    """
    rows = check_rows(rows)
    spikes = check_spikes(spikes)
    t, h, w = spikes.shape
    plane_nbytes(h, w)
    stored = (spikes[:, ::-1, :] if rows == "bottom-up" else spikes).reshape(t, h * w)
    return np.packbits(stored, axis=1, bitorder="little")


def unpack_planes(
    packed: np.ndarray, height: int, width: int, file_width: int | None = None, col_offset: int = 0,
    rows: str = "bottom-up",
) -> np.ndarray:
    """Inverse of :func:`pack_planes`: ``(T, H*Wf/8) uint8`` → upright ``(T, H, W) uint8``.

    ``file_width`` (default ``width``) is the stored row width; columns
    ``[col_offset, col_offset + width)`` of each stored row are kept.  ``rows`` is the stored row
    order, ``"bottom-up"`` (default) or ``"top-down"``; the result is upright either way.
    """
    rows = check_rows(rows)
    file_width = width if file_width is None else file_width
    nbytes = plane_nbytes(height, file_width)
    packed = np.asarray(packed)
    if packed.ndim != 2 or packed.shape[1] != nbytes:
        raise ValueError(f"packed must have shape (T, {nbytes}); got {packed.shape}")
    bits = np.unpackbits(packed, axis=1, bitorder="little").reshape(-1, height, file_width)
    if rows == "bottom-up":
        bits = bits[:, ::-1]
    return np.ascontiguousarray(bits[:, :, col_offset : col_offset + width])


def map_dat(path, height: int = 250, file_width: int = 400) -> np.ndarray:
    """Memory-map a ``.dat`` spike file as its packed planes ``(T, height·file_width/8) uint8``.

    Nothing is read: the bytes stay on disk until a window is asked for.  The file must hold a
    whole number of planes.  :func:`spikeref.stream.read_dat` wraps the result in a
    :class:`~spikeref.stream.SpikeStream`.

    Raises
    ------
    FileNotFoundError, ValueError
        The message names the file, the expected plane size and the size found.
    """
    path = Path(path)
    nbytes = plane_nbytes(height, file_width)
    if not path.is_file():
        raise FileNotFoundError(f"no such .dat file: {path}")
    size = path.stat().st_size
    if size == 0:
        raise ValueError(f"{path}: the file is empty (expected planes of {nbytes} bytes)")
    if size % nbytes:
        raise ValueError(
            f"{path}: size {size} bytes is not a whole number of {height}×{file_width} planes "
            f"({nbytes} bytes each; {size // nbytes} whole planes and {size % nbytes} bytes left over). "
            "Check --height/--width (and --file-width for cameras with padded rows)."
        )
    return np.memmap(path, dtype=np.uint8, mode="r", shape=(size // nbytes, nbytes))


class DatWriter:
    """Write a ``.dat`` file plane chunk by plane chunk, atomically.

    Planes go to a temporary file beside ``path``; :meth:`close` renames it to ``path``,
    :meth:`abort` (or an exception inside a ``with`` block) removes it, so no partial file
    is ever left under the final name.  Memory is bounded by the chunks appended.

    Parameters
    ----------
    path : str or Path
    height, width : int
        Plane size; ``height · width`` must be a multiple of 8.
    rows : {"bottom-up", "top-down"}
        The order the rows are stored in (default ``"bottom-up"``, the spike camera's).
    """

    def __init__(self, path, height: int, width: int, rows: str = "bottom-up"):
        self.path = Path(path)
        self.height, self.width = int(height), int(width)
        self.rows = check_rows(rows)
        plane_nbytes(self.height, self.width)
        self.planes = 0
        self._tmp = temporary_beside(self.path)
        self._fh = open(self._tmp, "wb")

    def append(self, spikes: np.ndarray) -> None:
        """Append ``(n, H, W)`` 0/1 planes."""
        spikes = check_spikes(spikes)
        if spikes.shape[1:] != (self.height, self.width):
            raise ValueError(
                f"planes must be {self.height}×{self.width} to go into {self.path.name}; got {spikes.shape[1:]}"
            )
        self._fh.write(pack_planes(spikes, self.rows).tobytes())
        self.planes += spikes.shape[0]

    def close(self) -> Path:
        """Finish: flush and rename to the final path."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None
            publish(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the temporary file; the final path is left as it was."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None
            Path(self._tmp).unlink(missing_ok=True)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:
            self.abort()
        return False


def write_dat(path, spikes, chunk_planes: int = 4096, rows: str = "bottom-up") -> Path:
    """Write spikes in the ``.dat`` layout, atomically.

    Parameters
    ----------
    path : str or Path
    spikes : ndarray ``(T, H, W)`` 0/1, or a :class:`~spikeref.stream.SpikeStream`
        Upright planes.  A stream (anything with ``height``, ``width``, ``len()`` and
        ``window(start, n)``) is written window by window, memory bounded by ``chunk_planes``.
    rows : {"bottom-up", "top-down"}
        The order the rows are stored in (default ``"bottom-up"``, the spike camera's).
    """
    rows = check_rows(rows)
    if isinstance(spikes, np.ndarray) or not hasattr(spikes, "window"):
        spikes = check_spikes(spikes)
        height, width, total = spikes.shape[1], spikes.shape[2], spikes.shape[0]
        def window(start, n):
            return spikes[start:start + n]
    else:
        height, width, total, window = spikes.height, spikes.width, len(spikes), spikes.window
    with DatWriter(path, height, width, rows) as writer:
        for start in range(0, total, chunk_planes):
            writer.append(window(start, min(chunk_planes, total - start)))
    return Path(path)


def sidecar_path(path) -> Path:
    """``NAME.json`` beside ``NAME.dat``: the size and CFA the ``.dat`` cannot hold."""
    return Path(path).with_suffix(".json")


def read_sidecar(path) -> dict:
    """The ``NAME.json`` beside a ``NAME.dat`` (sizes, CFA, rate written by ``spikeref simulate``; ``rows`` where
    the file stores its rows top-down), or ``{}``."""
    meta_path = sidecar_path(path)
    if not meta_path.is_file():
        return {}
    try:
        meta = json.loads(meta_path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{meta_path}: not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise ValueError(f"{meta_path}: expected a JSON object")
    return meta


def save_spikes(path, spikes) -> Path:
    """Save spikes as ``.dat``, ``.npy`` or ``.npz`` (key ``spikes``), atomically."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".dat":
        return write_dat(path, spikes)
    arr = check_spikes(spikes if isinstance(spikes, np.ndarray) else spikes.window(0, len(spikes)))
    if suffix in (".npy", ".npz"):

        def _write(tmp):
            with open(tmp, "wb") as fh:
                if suffix == ".npy":
                    np.save(fh, arr)
                else:
                    np.savez_compressed(fh, spikes=arr)

        return atomic_write(path, _write)
    raise ValueError(f"{path}: unknown spike file type {suffix!r} (expected .dat, .npy or .npz)")
