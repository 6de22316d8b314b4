"""``SpikeStream``: a spike recording held in memory or memory-mapped.

A stream is a sequence of binary planes ``S(x, τ)`` read out at ``rate_hz``
(20 000 planes/s for the spike camera, §3).  In memory it is a ``(T, H, W)
uint8`` array of 0/1, row 0 at the top.  From a ``.dat`` file it is the
memory-mapped packed bytes ``(T, H*Wf/8) uint8`` (the layout is :mod:`spikeref.io.dat`'s):
nothing is read until a window is asked for, so a 25 GB recording opens
instantly and is read one window at a time.  :func:`read_dat`, :func:`load_spikes` and
:func:`open_spike_file` open spike files as streams.
"""

from __future__ import annotations

import mmap
from pathlib import Path
from typing import Iterator

import numpy as np

from spikeref.bayer import validate_cfa
from spikeref.io.dat import check_rows, check_spikes, map_dat, plane_nbytes, read_sidecar, sidecar_path, unpack_planes
from spikeref.io.npz import NUMPY_READ_ERRORS

__all__ = ["SpikeStream", "as_stream", "read_dat", "load_spikes", "open_spike_file", "NPZ_SPIKE_KEYS", "ARRAY_AXES",
           "planes_last_suspected"]


class SpikeStream:
    """Binary spike planes with their geometry, colour pattern and clock.

    Build one with :meth:`from_array`, :meth:`from_packed` or
    :func:`spikeref.read_dat`.

    Attributes
    ----------
    height, width : int
        Upright image size in pixels.
    cfa : str or None
        Bayer pattern (``RGGB``…) of the upright image, ``None`` for mono.
    rate_hz : float
        Readout rate in planes per second.
    path : Path or None
        The file the stream was read from, if any.
    rows : str or None
        For packed ``.dat`` bytes, the order they store the rows in: ``"bottom-up"`` (the spike
        camera's) or ``"top-down"``; ``None`` for an in-memory array (upright).  Windows and counts
        are upright either way.
    """

    def __init__(
        self,
        *,
        array: np.ndarray | None,
        packed: np.ndarray | None,
        height: int,
        width: int,
        file_width: int,
        col_offset: int,
        cfa: str | None,
        rate_hz: float,
        path: Path | None,
        rows: str | None = None,
    ):
        if (array is None) == (packed is None):
            raise ValueError("exactly one of array and packed must be given")
        rows = None if packed is None else check_rows("bottom-up" if rows is None else rows)
        if cfa is not None:
            cfa = validate_cfa(cfa)
        if not np.isfinite(rate_hz) or rate_hz <= 0:
            raise ValueError(f"rate_hz must be a positive number of planes per second; got {rate_hz!r}")
        self._array = array
        self._packed = packed
        self.height = int(height)
        self.width = int(width)
        self.file_width = int(file_width)
        self.col_offset = int(col_offset)
        self.cfa = cfa
        self.rate_hz = float(rate_hz)
        self.path = Path(path) if path is not None else None
        self.rows = rows

    # ------------------------------------------------------------------ build
    @classmethod
    def from_array(cls, spikes, cfa: str | None = None, rate_hz: float = 20000.0, path=None, check: bool = True):
        """Wrap a ``(T, H, W)`` array of 0/1 (uint8 or bool); no copy when uint8."""
        arr = check_spikes(spikes, check_values=check)
        _, h, w = arr.shape
        return cls(
            array=arr, packed=None, height=h, width=w, file_width=w, col_offset=0,
            cfa=cfa, rate_hz=rate_hz, path=path,
        )

    @classmethod
    def from_packed(
        cls, packed, height: int, width: int, file_width: int | None = None, col_offset: int = 0,
        cfa: str | None = None, rate_hz: float = 20000.0, path=None, rows: str = "bottom-up",
    ):
        """Wrap packed ``.dat`` bytes ``(T, H*Wf/8) uint8`` (a memmap or an array).

        ``rows`` is the order the bytes store the rows in: ``"bottom-up"`` (the spike camera's,
        default) or ``"top-down"`` (checked by the constructor).
        """
        file_width = width if file_width is None else file_width
        nbytes = plane_nbytes(height, file_width)
        packed = np.asarray(packed) if not isinstance(packed, np.memmap) else packed
        if packed.dtype != np.uint8 or packed.ndim != 2 or packed.shape[1] != nbytes:
            raise ValueError(f"packed must be uint8 of shape (T, {nbytes}); got {packed.dtype} {packed.shape}")
        return cls(
            array=None, packed=packed, height=height, width=width, file_width=file_width,
            col_offset=col_offset, cfa=cfa, rate_hz=rate_hz, path=path, rows=rows,
        )

    # ------------------------------------------------------------- properties
    def __len__(self) -> int:
        data = self._array if self._array is not None else self._packed
        return int(data.shape[0])

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(T, H, W)``."""
        return (len(self), self.height, self.width)

    @property
    def duration_s(self) -> float:
        """Recording length in seconds, ``T / rate_hz``."""
        return len(self) / self.rate_hz

    @property
    def is_packed(self) -> bool:
        """True when the planes are packed ``.dat`` bytes (e.g. memory-mapped)."""
        return self._packed is not None

    @property
    def packed(self) -> np.ndarray | None:
        """The packed bytes ``(T, H*Wf/8)`` or ``None`` for an in-memory array."""
        return self._packed

    @property
    def array(self) -> np.ndarray | None:
        """The unpacked ``(T, H, W) uint8`` array or ``None`` for a packed stream."""
        return self._array

    def __repr__(self) -> str:
        where = f" from {self.path.name}" if self.path else ""
        kind = f"packed, rows {self.rows}" if self.is_packed else "array"
        return (
            f"SpikeStream({len(self)} planes of {self.height}×{self.width}, cfa={self.cfa}, "
            f"{self.rate_hz:g} Hz, {kind}{where})"
        )

    # ---------------------------------------------------------------- access
    def _check_range(self, start: int, length: int) -> None:
        if not isinstance(start, (int, np.integer)) or not isinstance(length, (int, np.integer)):
            raise TypeError(f"start and length must be integers; got {start!r}, {length!r}")
        if length < 1:
            raise ValueError(f"length must be at least 1 plane; got {length}")
        if start < 0 or start + length > len(self):
            raise ValueError(
                f"planes [{start}, {start + length}) are outside the stream of {len(self)} planes"
            )

    def window(self, start: int, length: int) -> np.ndarray:
        """Planes ``[start, start + length)`` as an upright ``(length, H, W) uint8`` array.

        For a packed stream only those planes are read and unpacked.
        """
        self._check_range(start, length)
        if self._array is not None:
            return self._array[start : start + length]
        return unpack_planes(
            np.asarray(self._packed[start : start + length]),
            self.height, self.width, self.file_width, self.col_offset, self.rows,
        )

    def slice(self, start: int, stop: int | None = None) -> "SpikeStream":
        """The planes ``[start, stop)`` as a stream of their own (a view: nothing is copied or read).

        Plane ``start`` becomes plane 0 of the new stream, so its windows ``[kW, (k+1)W)``
        are planes ``[start + kW, start + (k+1)W)`` here: this shifts the window grid.
        """
        stop = len(self) if stop is None else stop
        if not isinstance(stop, (int, np.integer)):
            raise TypeError(f"stop must be an integer plane index; got {stop!r}")
        self._check_range(start, int(stop) - int(start))
        return SpikeStream(
            array=self._array[start:stop] if self._array is not None else None,
            packed=self._packed[start:stop] if self._packed is not None else None,
            height=self.height, width=self.width, file_width=self.file_width, col_offset=self.col_offset,
            cfa=self.cfa, rate_hz=self.rate_hz, path=self.path, rows=self.rows,
        )

    def release(self, start: int, length: int) -> None:
        """Drop the memory-mapped pages of planes ``[start, start + length)`` from this process.

        Pages of a memory-mapped ``.dat`` that were read stay in the process's resident set
        (RSS) until the kernel needs the memory, so RSS would grow with the part of the
        recording already read.  Streaming readers call this on planes they are done with
        (``madvise(MADV_DONTNEED)``; the file is read-only, so a later read simply maps the
        pages again from the page cache).  A no-op for in-memory streams and where the
        platform has no ``madvise``.
        """
        self._check_range(start, length)
        packed = self._packed
        mm = getattr(packed, "_mmap", None)
        if mm is None or not hasattr(mm, "madvise"):
            return

        base = np.frombuffer(mm, dtype=np.uint8).ctypes.data
        lo = packed[start:].ctypes.data - base
        hi = lo + length * packed.shape[1]
        page = mmap.PAGESIZE
        lo, hi = (lo // page) * page, min(-(-hi // page) * page, len(mm))
        if hi > lo:
            try:
                mm.madvise(mmap.MADV_DONTNEED, lo, hi - lo)
            except (OSError, ValueError):  # pragma: no cover - platform without the advice
                pass

    def windows(self, length: int, start: int = 0) -> Iterator[np.ndarray]:
        """Iterate over consecutive whole windows ``[start + kW, start + (k+1)W)``."""
        if not isinstance(length, (int, np.integer)) or length < 1:
            raise ValueError(f"window length must be a positive integer; got {length!r}")
        for s in range(start, len(self) - length + 1, length):
            yield self.window(s, length)

    def __iter__(self):
        raise TypeError("iterate over stream.windows(W) (planes are read one window at a time)")


def as_stream(spikes, cfa: str | None = None) -> SpikeStream:
    """Return ``spikes`` if it is a stream, else wrap a ``(T, H, W)`` array."""
    if isinstance(spikes, SpikeStream):
        return spikes
    return SpikeStream.from_array(spikes, cfa=cfa)


def read_dat(
    path,
    height: int = 250,
    width: int = 400,
    cfa: str | None = None,
    *,
    file_width: int | None = None,
    col_offset: int = 0,
    rate_hz: float = 20000.0,
    rows: str = "bottom-up",
):
    """Memory-map a ``.dat`` spike file as a :class:`~spikeref.stream.SpikeStream`.

    Parameters
    ----------
    path : str or Path
    height, width : int
        Image size in pixels (the file has no header; 250×400 classic mono
        cameras, 1000×1000 colour cameras).
    cfa : str or None
        Bayer pattern of the upright image (``RGGB``…); ``None`` for mono.
    file_width : int, optional
        Stored row width when rows are wider than the image (e.g. 1024);
        columns ``[col_offset, col_offset + width)`` are kept.
    rate_hz : float
        Readout rate, planes per second (20 000 for the spike camera).
    rows : {"bottom-up", "top-down"}
        The order the file stores the rows in: ``"bottom-up"`` (the spike camera's, default: stored
        row ``r`` is image row ``H - 1 - r``) or ``"top-down"`` (stored row ``r`` is image row ``r``).
        The stream is upright either way.  ``docs/inputs.md`` names each toolkit's order.

    Raises
    ------
    FileNotFoundError, ValueError
        The message names the file, the expected plane size and the size found; ``rows`` other
        than the two orders is a ValueError naming it.
    """
    path = Path(path)
    rows = check_rows(rows)
    file_width = width if file_width is None else file_width
    if file_width < width + col_offset or col_offset < 0:
        raise ValueError(
            f"file_width ({file_width}) must be at least width + col_offset ({width} + {col_offset})"
        )
    packed = map_dat(path, height, file_width)
    return SpikeStream.from_packed(
        packed,
        height=height,
        width=width,
        file_width=file_width,
        col_offset=col_offset,
        cfa=cfa,
        rate_hz=rate_hz,
        path=path,
        rows=rows,
    )


def _optional_count(name: str, value):
    """``value`` if it is a whole number ≥ 1, None if it is None (not given); else a ValueError naming ``name``.

    0 is a value, never "not given": it is refused, not replaced by a default.
    """
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be a whole number ≥ 1, or None for the default; got {value!r}")
    return int(value)


def _optional_rate(name: str, value):
    """``value`` if it is a finite number > 0, None if it is None (not given); else a ValueError naming ``name``."""
    if value is None:
        return None
    if (isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))
            or not np.isfinite(value) or value <= 0):
        raise ValueError(f"{name} must be a positive number of planes per second, or None for the default; "
                         f"got {value!r}")
    return float(value)


#: The ``.npz`` keys :func:`load_spikes` takes for the spikes when none is named, in this order (``spk`` is
#: Spike-Zoo's).
NPZ_SPIKE_KEYS = ("spikes", "spk")
#: The axis orders an array file may have: ``THW`` (planes first, the package's) or ``HWT`` (SpikingSIM's).
ARRAY_AXES = ("THW", "HWT")


#: :func:`planes_last_suspected` judges an axis only when it has at least this many entries …
PLANES_LAST_MIN_LENGTH = 32
#: … and suspects planes last when the last axis's lag-1 correlation is at most this (and twice the first's).
PLANES_LAST_CORRELATION = -0.03


def _lag1_correlation(spikes, axis: int, long: int = 512, short: int = 32) -> float | None:
    """The lag-1 correlation of 0/1 ``spikes`` along ``axis``, over a centred block (at most ``long`` entries
    along ``axis``, ``short`` along the others), each line centred on its even and its odd entries apart;
    None when the axis is shorter than :data:`PLANES_LAST_MIN_LENGTH` or the block is constant."""
    moved = np.moveaxis(spikes, axis, -1)
    if moved.shape[-1] < PLANES_LAST_MIN_LENGTH:
        return None
    block = []
    for d, n in enumerate(moved.shape):
        k = min(n, long if d == moved.ndim - 1 else short)
        block.append(slice((n - k) // 2, (n - k) // 2 + k))
    r = np.array(moved[tuple(block)], dtype=np.float64)  # a copy (centred in place), never a view of the input
    for parity in (slice(0, None, 2), slice(1, None, 2)):
        r[..., parity] -= r[..., parity].mean(axis=-1, keepdims=True)
    energy = float((r * r).sum())
    if energy == 0.0:
        return None
    return float((r[..., :-1] * r[..., 1:]).sum()) / energy


def planes_last_suspected(spikes) -> bool:
    """True when a ``(T, H, W)`` array read planes first looks like planes-last ``(H, W, T)`` data.

    The rule reads the spikes, not the shape (250 planes of 400×500 and 250×400 pixels over 500
    planes are both plausible shapes).  A spike-camera pixel integrates and fires: below one spike
    per two readouts it never fires twice in a row, above it never stays silent twice in a row, so
    its spike train is anticorrelated at lag 1 (about −r/(1−r) at rate r < ½), while neighbouring
    pixels fire with independent phases at similar rates (correlation ≥ 0).  Each line is centred on
    its even and odd entries apart, so a Bayer mosaic's alternation of two colours along a row or a
    column is not taken for time.  The array is suspected planes last when the lag-1 correlation
    along its last axis is at most :data:`PLANES_LAST_CORRELATION` (−0.03; independent random 0/1 of
    32 entries and more stay within ±0.015) and at least twice that along its first axis (a
    planes-first array's first axis is its time: the most anticorrelated).  When the first or the last
    axis is shorter than :data:`PLANES_LAST_MIN_LENGTH`, or the spikes do not vary, nothing is judged
    (False).  Very dim recordings (a few spikes per hundred readouts) are anticorrelated too little to
    be judged: Spike-Zoo's UHSR clip, 0.03 spikes per readout, gives −0.026 along its time axis.

    Parameters
    ----------
    spikes : array_like ``(A, B, C)`` of 0/1
        The array as it would be read, planes first.  Only a centred block of at most
        512 × 32 × 32 entries per axis tested is read (a memory-mapped ``.npy`` stays on disk).

    Returns
    -------
    bool
    """
    arr = np.asarray(spikes)
    if arr.ndim != 3:
        raise ValueError(f"spikes must have 3 axes; got shape {arr.shape}")
    last = _lag1_correlation(arr, -1)
    if last is None or last > PLANES_LAST_CORRELATION:
        return False
    first = _lag1_correlation(arr, 0)
    return first is not None and last <= 2 * first


def _read_array_file(path: Path, read):
    """``read()`` of NumPy's reader, with a damaged or foreign ``.npy``/``.npz`` file (truncated, not NumPy's,
    holding Python objects) reported as one ``ValueError`` that names it."""
    try:
        return read()
    except NUMPY_READ_ERRORS as exc:
        why = "not NumPy array data" if "pickle" in str(exc) else str(exc)
        raise ValueError(f"{path}: not a readable {path.suffix.lower()} spike file ({why})") from None


def _npz_spikes(path: Path, key: str | None) -> np.ndarray:
    """The spikes' array of an ``.npz`` file: ``key``, else the first of :data:`NPZ_SPIKE_KEYS`, else its only one."""
    data = _read_array_file(path, lambda: np.load(path))
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise ValueError(f"{path}: holds one array, as a .npy file does: name it .npy")
    with data:
        keys = list(data.files)
        if key is None:
            key = next((k for k in NPZ_SPIKE_KEYS if k in keys), keys[0] if len(keys) == 1 else None)
            if key is None:
                raise ValueError(f"{path}: no key {' or '.join(map(repr, NPZ_SPIKE_KEYS))} and more than one "
                                 f"array; found keys {keys}: name the spikes' key")
        elif key not in keys:
            raise ValueError(f"{path}: no key {key!r}; found keys {keys}")
        return _read_array_file(path, lambda: data[key])  # a member is read (and may be cut short) here


def load_spikes(path, height: int | None = None, width: int | None = None, cfa: str | None = None, *,
                key: str | None = None, axes: str = "THW", rows: str | None = None, **kw):
    """Open a spike file by its suffix: ``.dat`` (memory-mapped), ``.npy`` or ``.npz``.

    ``.npy`` holds one array; ``.npz`` the array ``key``, by default the first of :data:`NPZ_SPIKE_KEYS`
    it has, else its only array.  ``axes`` says how that array is ordered: ``"THW"`` (planes first) or
    ``"HWT"`` (planes last, as SpikingSIM's samples); the stream is always ``(T, H, W)``.  For ``.dat``
    the size must be given; ``None`` (not given) means the default 250×400, and 0 is refused
    (ValueError naming the argument); ``rows`` is the order the ``.dat`` stores its rows in
    (``"bottom-up"``, the default for ``None``, or ``"top-down"``; :func:`read_dat`).  ``key`` and
    ``axes`` are for array files only (refused for a ``.dat``); the sizes and ``rows`` are for ``.dat``
    only (an array holds its own size, row 0 at the top) and are not used for an array file.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    height, width = _optional_count("height", height), _optional_count("width", width)
    rows = None if rows is None else check_rows(rows)
    if axes not in ARRAY_AXES:
        raise ValueError(f"axes must be one of {', '.join(ARRAY_AXES)}; got {axes!r}")
    if key is not None and not isinstance(key, str):
        raise TypeError(f"key must be a string or None; got {type(key).__name__}")
    if path.is_dir():
        raise ValueError(f"{path} is a folder; give a spike file in it (.dat, .npy or .npz)")
    if not path.is_file():
        raise FileNotFoundError(f"no such spike file: {path}")
    if suffix == ".dat":
        if key is not None or axes != "THW":
            raise ValueError(f"{path}: key and axes are for .npy/.npz files; a .dat file is planes of rows")
        return read_dat(path, 250 if height is None else height, 400 if width is None else width, cfa,
                        rows="bottom-up" if rows is None else rows, **kw)
    if suffix == ".npy":
        if key is not None:
            raise ValueError(f"{path}: a .npy file holds one array; key is for .npz files")
        arr = _read_array_file(path, lambda: np.load(path, mmap_mode="r"))
    elif suffix == ".npz":
        arr = _npz_spikes(path, key)
    else:
        raise ValueError(f"{path}: unknown spike file type {suffix!r} (expected .dat, .npy or .npz)")
    if axes == "HWT":
        if np.ndim(arr) != 3:
            raise ValueError(f"spikes in {path.name} must have shape (H, W, T) with axes='HWT'; got shape "
                             f"{np.shape(arr)}")
        arr = np.moveaxis(arr, -1, 0)
    arr = check_spikes(arr, name=f"spikes in {path.name}")
    return SpikeStream.from_array(arr, cfa=cfa, path=path, **{k: v for k, v in kw.items() if k == "rate_hz"})


def open_spike_file(path, height: int | None = None, width: int | None = None, cfa: str | None = None,
                    file_width: int | None = None, rate_hz: float | None = None, key: str | None = None,
                    axes: str = "THW", rows: str | None = None):
    """Open a spike file, taking what is not given from its ``NAME.json`` sidecar (``.dat``).

    Arguments override the sidecar; without either, ``.dat`` defaults to 250×400 mono at
    20 kHz.  ``cfa="mono"`` means no colour filter.

    Parameters
    ----------
    path : str or Path
        A ``.dat``, ``.npy`` or ``.npz`` spike file.
    height, width, file_width : int or None
        Image size and stored row width in pixels (``.dat`` only); ``None`` means not given
        (the sidecar's value, else 250×400 and ``file_width = width``).
    cfa : str or None
        Bayer pattern (``"RGGB"`` …) or ``"mono"``; ``None`` means not given.
    rate_hz : float or None
        Readout rate, planes per second; ``None`` means not given (the sidecar's, else 20 000).
    key, axes : str
        For ``.npy``/``.npz`` files: the ``.npz`` key of the spikes and the array's axis order
        (:func:`load_spikes`).
    rows : {"bottom-up", "top-down"} or None
        For ``.dat`` files: the order the file stores its rows in (:func:`read_dat`); ``None`` means
        not given (the sidecar's ``"rows"``, else ``"bottom-up"``, the spike camera's).

    Raises
    ------
    ValueError
        A size of 0 or less, a non-integer size or a rate that is not a positive number: 0 is a
        value, never "not given"; the message names the argument.  A ``rows`` (or a sidecar's
        ``"rows"``) other than the two orders, naming it.
    """
    path = Path(path)
    height, width = _optional_count("height", height), _optional_count("width", width)
    file_width, rate_hz = _optional_count("file_width", file_width), _optional_rate("rate_hz", rate_hz)
    rows = None if rows is None else check_rows(rows)
    meta = read_sidecar(path) if path.suffix.lower() == ".dat" else {}
    cfa = cfa if cfa is not None else meta.get("cfa")
    if isinstance(cfa, str) and cfa.lower() == "mono":
        cfa = None
    kw = {"rate_hz": rate_hz if rate_hz is not None else meta.get("rate_hz", 20000.0)}
    if path.suffix.lower() == ".dat":
        kw["file_width"] = file_width if file_width is not None else meta.get("file_width")
        if rows is None and "rows" in meta:
            rows = check_rows(meta["rows"], name=f"{sidecar_path(path)}: rows")
        kw["rows"] = rows
        return load_spikes(path, height=height if height is not None else meta.get("height", 250),
                           width=width if width is not None else meta.get("width", 400), cfa=cfa, key=key,
                           axes=axes, **kw)
    return load_spikes(path, cfa=cfa, key=key, axes=axes, **kw)
