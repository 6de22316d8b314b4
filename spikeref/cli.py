"""``spikeref`` command line: inspect, simulate, run baselines, denoise, train.

Every subcommand prints ``--help`` with units and defaults.  Spike files are
``.dat`` (no header: give ``--height/--width``, or keep a ``NAME.json`` with
``{"height":…, "width":…, "cfa":…}`` beside ``NAME.dat``; ``--rows top-down`` for files that store their
rows top-down), ``.npy`` or ``.npz`` (``--key`` names the ``.npz`` array, ``--axes HWT`` reads planes-last
arrays such as SpikingSIM's).  ``docs/inputs.md`` names the options for each toolkit's layout.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib.util
import math
import os
import select
import shlex
import signal
import sys
import tempfile
import threading
import warnings
from pathlib import Path

import numpy as np

__all__ = ["main", "build_parser", "CliError", "RunFailed", "Interrupted"]

SAMPLE = Path(__file__).resolve().parent / "data" / "sample.dat"


class CliError(Exception):
    """An error to report as one line, without a traceback; exit status 2 (the command was refused).

    Every command checks all its arguments and inputs before it creates a folder, opens an
    output, starts a progress bar or a Dask cluster, so a refused command leaves the disk as
    it found it.
    """

    status = 2


class RunFailed(CliError):
    """The run had started and an OS error stopped it (a full disk, an unwritable folder): exit status 1."""

    status = 1


class Interrupted(CliError):
    """SIGINT (Ctrl-C) or SIGTERM stopped the run: exit status 130."""

    status = 130


class _Terminated(KeyboardInterrupt):
    """Raised in the main thread by SIGTERM (a batch scheduler's stop); handled like Ctrl-C."""


def _signal_name(exc: BaseException) -> str:
    return "SIGTERM" if isinstance(exc, _Terminated) else "SIGINT"


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """While a command runs, SIGTERM raises :class:`_Terminated` in the main thread (once), like Ctrl-C."""
    previous = None
    if threading.current_thread() is threading.main_thread():
        fired = []

        def handler(signum, frame):
            if not fired:  # a second SIGTERM during the clean-up does not interrupt the clean-up
                fired.append(signum)
                raise _Terminated()

        try:
            previous = signal.signal(signal.SIGTERM, handler)
        except (ValueError, OSError):  # pragma: no cover - no signals here (an embedded interpreter)
            previous = None
    try:
        yield
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


# ----------------------------------------------------------------------------- checks
# Zero is a value like any other, never "not given": options left out are None.
class _DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """argparse's "(default: X)" only where the help does not already say the default, and never "None"."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.default is None or action.default is False or action.default == argparse.SUPPRESS \
                or "default" in text.lower():
            return text
        if isinstance(action.default, (tuple, list)):  # written as the option takes it: comma-separated
            return f"{text} (default: {','.join(map(str, action.default))})"
        return super()._get_help_string(action)


def _check_int(value, flag: str, minimum: int = 1, what: str = "a positive whole number") -> None:
    """Refuse an integer option below ``minimum`` (``None``: not given, nothing to check)."""
    if value is not None and value < minimum:
        raise CliError(f"{flag} must be {what}; got {value}")


def _check_float(value, flag: str, positive: bool = True) -> None:
    """Refuse a float option that is not finite, or not > 0 (``positive``) / not ≥ 0."""
    if value is None:
        return
    if not math.isfinite(value) or value < 0 or (positive and value == 0):
        raise CliError(f"{flag} must be a finite number {'>' if positive else '≥'} 0; got {value:g}")


def _check_folder_can_exist(folder: Path, flag: str, target: Path, *, new: bool = False) -> None:
    """Refuse unless ``folder`` is a writable folder — or, with ``new`` (a folder the run makes: ``--exr-dir``,
    ``--out``), unless its parent is.

    The rule for outputs: spikeref makes at most the one folder an option names, inside a folder that exists; it
    never makes missing parents (``-o /nonexistent/dir/out.mp4`` is a typo to be told of, not a tree to be made
    at the root of the file system).
    """
    p = Path(os.path.abspath(folder))
    if not p.exists():
        ancestor = p.parent
        while not ancestor.exists() and ancestor.parent != ancestor:
            ancestor = ancestor.parent
        if not ancestor.is_dir():
            raise CliError(f"{flag} {target}: cannot write there ({ancestor} is not a folder)")
        if not new or not p.parent.exists():
            missing = p if not new else p.parent
            raise CliError(f"{flag} {target}: the folder {missing} does not exist (make it first: spikeref makes no "
                           f"missing parent folders)")
        p = p.parent
    if not p.is_dir():
        raise CliError(f"{flag} {target}: cannot write there ({p} is not a folder)")
    if not os.access(p, os.W_OK | os.X_OK):
        raise CliError(f"{flag} {target}: cannot write there ({p} is not writable)")
    try:  # the permission bits do not tell everything (root, read-only mounts, /proc): make a file and remove it
        fd, probe = tempfile.mkstemp(dir=p, prefix=".spikeref-probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise CliError(f"{flag} {target}: cannot write there (cannot make a file in {p}: {exc.strerror or exc})") \
            from None


def _check_output_file(path: Path | None, flag: str, suffixes: tuple[str, ...], kind: str) -> None:
    """An output file: the right suffix, not an existing folder, in a folder that can be made."""
    if path is None:
        return
    if path.suffix.lower() not in suffixes:
        raise CliError(f"{kind} must end in {' or '.join(suffixes)}; got {path.name!r}")
    if path.is_dir():
        raise CliError(f"{flag} {path}: is a folder, not a {kind}")
    _check_folder_can_exist(path.parent, flag, path)


def _check_video(path: Path | None, flag: str = "-o/--output") -> None:
    _check_output_file(path, flag, (".mp4", ".gif"), "video output")


def _check_output_dir(path: Path | None, flag: str) -> None:
    """An output folder: a folder, or absent inside an existing folder (it is made when the run starts)."""
    if path is None:
        return
    if path.exists() and not path.is_dir():
        raise CliError(f"{flag} {path}: cannot write there ({path} is not a folder)")
    _check_folder_can_exist(path, flag, path, new=True)


def _hot_pixel_option(value):
    """``--hot-pixels``: ``auto``/``off`` (None returned) or a map file (its path, checked to exist)."""
    if value is None or value in ("auto", "off"):
        return None
    path = Path(value)
    if path.suffix.lower() != ".npz":
        raise CliError(f"--hot-pixels must be auto, off or a map .npz (spikeref calibrate); got {value!r}")
    if not path.is_file():
        raise CliError(f"--hot-pixels {value}: no such file (make one with spikeref calibrate DARK -o {value})")
    return path


def _hot_pixel_map(path, stream):
    """The map of ``--hot-pixels MAP.npz`` for ``stream`` (its size checked), or None."""
    if path is None:
        return None
    from spikeref.hot_pixels import load_hot_pixel_map

    try:
        return load_hot_pixel_map(path, (stream.height, stream.width))
    except ValueError as exc:
        raise CliError(f"--hot-pixels {exc}") from None


def _say_hot_pixels(mask, source) -> None:
    """One line when hot pixels are replaced: how many and from where."""
    if mask is not None and mask.any():
        where = f"from {source}" if source is not None else "found in the recording (--hot-pixels off keeps them)"
        print(f"hot pixels: {int(mask.sum())} replaced by their same-colour neighbours in every window, {where}",
              file=sys.stderr)


def _check_seed(value) -> None:
    _check_int(value, "--seed", 0, "a whole number ≥ 0")


#: Seconds a command's first run spends compiling its Numba kernels, measured with an empty cache on two
#: cores (``scripts/first_run_compile.py``; ``docs/results.md``, "First run: what Numba compiles").
FIRST_RUN_COMPILE_S = {"reconstruct": 40, "denoise": 15, "baseline": 8, "noise-check": 6, "bench": 60}


def _compiling_note(args, tag: str) -> None:
    """Say once, before a run sits silent while Numba compiles, that it does and for about how long.

    Nothing when the kernels of ``tag`` are already cached for this install (:func:`spikeref._jit.is_warm`); the
    command records that they are once it ends well (``main`` calls :func:`spikeref._jit.mark_warm`).
    """
    from spikeref import _jit

    if not _jit.numba_available or _jit.is_warm(tag):
        return
    seconds = FIRST_RUN_COMPILE_S[args.command]
    if _jit.caching_enabled:
        print(f"compiling kernels once, about {seconds} s on two cores (cached in {_jit.cache_dir} for later runs)",
              file=sys.stderr)
    else:
        print(f"compiling kernels, about {seconds} s on two cores (the kernel cache is off, so every run compiles: "
              f"SPIKEREF_NUMBA_CACHE=0 or no writable cache folder)", file=sys.stderr)
    args.compile_tag = tag


def _bundled_weights_by_default(args, accumulate: str) -> None:
    """Without ``--weights``: the bundled network trained on what the windows give (count or charge)."""
    from spikeref.denoise.denoiser import bundled_weights

    if args.weights is None:
        args.weights = bundled_weights(accumulate).stem  # the bundled name, as a user would give it


def _load_denoiser(weights, *, accumulate: str | None = None, **kw):
    """``Denoiser.load`` with a damaged weights file reported as one line (before any output is opened).

    With ``accumulate`` (what the windows will give), a note when the weights were trained on the other
    (their metadata's ``accumulate``; weights without it were trained on counts).
    """
    from spikeref.denoise.denoiser import WEIGHTS_DIR, Denoiser

    try:  # a damaged file: the reader's one-line ValueError, which main reports
        den = Denoiser.load(weights, **kw)
    except FileNotFoundError:
        names = ", ".join(sorted(p.stem for p in WEIGHTS_DIR.glob("*.npz")))
        raise CliError(f"--weights {weights}: no such weights file, nor a bundled name ({names})") from None
    trained = den.unet.meta.get("accumulate", "count")
    if accumulate is not None and trained != accumulate:
        what = {"count": "Eq. 4 windows (counts)", "charge": "window charges"}
        warnings.warn(f"--weights {weights} was trained on {what[trained]}; the windows here give {what[accumulate]} "
                      f"(--accumulate {accumulate}): expect a worse denoiser", UserWarning, stacklevel=2)
    return den


def _os_error_text(exc: OSError) -> str:
    """``PATH: reason`` of an OS error (the path the error is about, when it names one)."""
    if exc.filename is not None and exc.strerror:
        return f"{exc.filename}: {exc.strerror}"
    return str(exc)


def _continue_hint(exc: BaseException) -> str:
    """How the one line of a failed run leads to the resume command."""
    code = getattr(exc, "errno", None)
    if code in (errno.ENOSPC, errno.EDQUOT):
        return "once there is space, continue with"
    if code in (errno.EACCES, errno.EPERM, errno.EROFS):
        return "once the folder is writable, continue with"
    return "then continue with"


def _resume_command(args, exr_dir: Path | None = None) -> str:
    """The command line that continues this run: the same arguments plus ``--resume``.

    ``exr_dir`` is the folder the frames went to; it is named when the run chose it itself
    (``-o rec.mp4`` on Dask writes ``rec_exr/``), because ``--resume`` needs ``--exr-dir``.
    """
    argv = list(getattr(args, "argv", None) or [args.command])
    if exr_dir is not None and getattr(args, "exr_dir", None) is None and getattr(args, "output", None) is not None:
        argv += ["--exr-dir", str(exr_dir)]
    if "--resume" not in argv:
        argv.append("--resume")
    return "spikeref " + shlex.join(argv)


@contextlib.contextmanager
def _output_phase():
    """Around the part of a command that writes: an OS error there is a failed run (exit 1), not a refusal."""
    try:
        yield
    except OSError as exc:
        raise RunFailed(f"{_os_error_text(exc)}; every file already written is whole") from exc


# ----------------------------------------------------------------------------- input
def _add_input_options(p: argparse.ArgumentParser, optional_file: bool = False) -> None:
    if optional_file:
        p.add_argument("file", nargs="?", type=Path, default=None,
                       help="spike file (.dat, .npy, .npz); default: the embedded sample")
    else:
        p.add_argument("file", type=Path, help="spike file (.dat, .npy, .npz)")
    p.add_argument("--height", type=int, default=None,
                   help="image height in pixels (.dat only; default from NAME.json, else 250)")
    p.add_argument("--width", type=int, default=None,
                   help="image width in pixels (.dat only; default from NAME.json, else 400)")
    p.add_argument("--file-width", type=int, default=None,
                   help="stored row width when rows are padded, e.g. 1024 for some 1000×1000 cameras")
    p.add_argument("--rows", choices=["bottom-up", "top-down"], default=None,
                   help=".dat only: the order the file stores the image rows in; bottom-up is the spike camera's "
                        "(SpikeCV, Spike-Zoo), top-down SSL-CSC's simulated recordings (default from NAME.json, "
                        "else bottom-up; docs/inputs.md)")
    p.add_argument("--cfa", default=None,
                   help="Bayer pattern of the upright image: RGGB, BGGR, GRBG, GBRG, 'mono', or 'auto' (read from "
                        "the spikes: spikeref.cfa_detect; one line says what and how sure) (default from NAME.json, "
                        "else mono; a pattern the data contradict gets one warning line)")
    p.add_argument("--rate-hz", type=float, default=None,
                   help="readout rate in planes per second (default 20000)")
    p.add_argument("--key", default=None,
                   help=".npz only: the key of the spike array (default 'spikes', else 'spk' as Spike-Zoo's, else the "
                        "file's only array)")
    p.add_argument("--axes", choices=["THW", "HWT"], default="THW",
                   help=".npy/.npz only: the array's axis order, planes first (THW, default) or last (HWT, as "
                        "SpikingSIM's samples); `spikeref info FILE` prints the planes and size it reads")


def _add_hot_pixel_option(p: argparse.ArgumentParser, command: str) -> None:
    p.add_argument("--hot-pixels", default=None, metavar="auto|off|MAP.npz",
                   help="pixels that fire far above their light at the same place in every window: auto ("
                        f"{'the default but with --paper' if command == 'reconstruct' else 'default'}: found in the "
                        "recording's first "
                        "2000 planes and replaced in every window by the mean of their same-colour neighbours, "
                        "before the denoiser and the alignment; not in the paper; spikeref.hot_pixels), off, or a "
                        "map made from a dark recording by spikeref calibrate")


def _check_input_options(args) -> None:
    """The numeric input options: a given 0 is refused, never read as "not given" (then from NAME.json)."""
    for name, flag in (("height", "--height"), ("width", "--width"), ("file_width", "--file-width")):
        _check_int(getattr(args, name, None), flag, 1, "a positive number of pixels")
    _check_float(getattr(args, "rate_hz", None), "--rate-hz")


def open_input(args, *, check_cfa: bool = True):
    """Open the stream named by the parsed input options (sizes from the NAME.json sidecar if not given).

    ``--cfa auto`` reads the pattern from the data; a given (or the sidecar's) pattern that the data contradict
    gets one warning line (:func:`_check_cfa`).  ``check_cfa=False`` leaves both to the caller (``info``, which
    decides from the counts it makes anyway); ``--cfa auto`` then opens the stream as mono.
    """
    from spikeref.bayer import CFA_PATTERNS, validate_cfa
    from spikeref.io.dat import sidecar_path
    from spikeref.stream import open_spike_file

    _check_input_options(args)
    path = args.file if getattr(args, "file", None) is not None else SAMPLE
    if not path.exists():
        raise CliError(f"no such file: {path}")
    cfa = args.cfa
    auto = cfa is not None and cfa.lower() == "auto"
    if auto:
        cfa = "mono"  # the sidecar's pattern is not taken either: the data decide (below)
    elif cfa is not None and cfa.lower() != "mono":
        try:
            validate_cfa(cfa)
        except ValueError:
            raise CliError(f"--cfa {cfa}: not a colour pattern; give one of {', '.join(CFA_PATTERNS)} or mono "
                           f"(or auto: read it from the data)") from None
    _warn_options_not_applying(path, args)
    stream = open_spike_file(path, height=args.height, width=args.width, cfa=cfa,
                             file_width=args.file_width, rate_hz=args.rate_hz, key=args.key, axes=args.axes,
                             rows=getattr(args, "rows", None))
    _warn_planes_last(stream, path, args)
    if check_cfa:
        _check_cfa(stream, args, auto)
    if path.suffix.lower() == ".dat" and (args.height is None or args.width is None) \
            and not sidecar_path(path).is_file():
        print(f"note: {path.name} has no {sidecar_path(path).name} beside it: read as "
              f"{stream.height}×{stream.width} {stream.cfa or 'mono'} (give --height/--width/--cfa if it is not)",
              file=sys.stderr)
    return stream


def _cfa_source(args, stream) -> str:
    """Where the pattern the stream was opened with came from, for the ``info`` line and the warning."""
    from spikeref.io.dat import read_sidecar, sidecar_path

    if args.cfa is not None:
        return "as given"
    path = Path(stream.path) if stream.path is not None else None
    if path is not None and path.suffix.lower() == ".dat" and read_sidecar(path).get("cfa") is not None:
        return f"from {sidecar_path(path).name}"
    return "none given"


def _cfa_contradiction(stream, args, guess) -> str:
    """The one ``warning:`` line for a pattern whose green sites the data contradict."""
    confident = f"detected {guess.pattern}, green sites confidence {guess.green_confidence:.2f}"
    if stream.cfa is None:
        return (f"warning: the spikes look like a Bayer mosaic ({confident}) but are read as mono; "
                f"--cfa auto or --cfa {guess.pattern} reads them in colour")
    where = {"main": "(0,0)/(1,1)", "anti": "(0,1)/(1,0)"}
    given = f"--cfa {stream.cfa}" if args.cfa is not None else f"the cfa {stream.cfa} {_cfa_source(args, stream)}"
    from spikeref.cfa_detect import green_diagonal

    return (f"warning: {given} puts green at {where[green_diagonal(stream.cfa)]}, the spikes at "
            f"{where[guess.green_diagonal]} ({confident}); going on with {stream.cfa} (--cfa auto uses the data's)")


def _check_cfa(stream, args, auto: bool, guess=None):
    """Read the CFA phase from the data once (``guess``: already read); ``--cfa auto`` uses it (one line on
    stderr, and ``args.cfa`` becomes the pattern so that whatever opens the file again — Dask's workers, the
    run record — opens it alike); a pattern the data contradict gets one ``warning:`` line.  Returns the guess
    (``None`` for an odd size, which has no 2×2 cells)."""
    from spikeref.cfa_detect import detect_cfa, green_sites_contradict

    if stream.height % 2 or stream.width % 2:
        if auto:
            raise CliError(f"--cfa auto: a {stream.height}×{stream.width} image has no whole 2×2 cells; give "
                           f"--cfa mono")
        return None
    guess = detect_cfa(stream) if guess is None else guess
    if auto:
        stream.cfa = None if guess.pattern == "mono" else guess.pattern
        args.cfa = guess.pattern
        print(f"cfa auto: detected {guess.pattern}, confidence {guess.confidence:.2f} over {guess.planes} planes "
              f"— {guess.describe()}", file=sys.stderr)
    elif green_sites_contradict(stream.cfa, guess):
        print(_cfa_contradiction(stream, args, guess), file=sys.stderr)
    return guess


def _warn_options_not_applying(path: Path, args) -> None:
    """One ``warning:`` line for ``.dat`` options given for an array file (they would be ignored).

    ``--key`` and ``--axes HWT`` for a ``.dat`` are refused by :func:`spikeref.stream.load_spikes`, not warned.
    """
    if path.suffix.lower() not in (".npy", ".npz"):
        return
    given = [flag for flag, name in (("--height", "height"), ("--width", "width"), ("--file-width", "file_width"),
                                     ("--rows", "rows")) if getattr(args, name, None) is not None]
    if given:
        print(f"warning: {', '.join(given)} {'is' if len(given) == 1 else 'are'} for .dat files and ignored for "
              f"{path.name}: an array file holds its own size, row 0 at the top", file=sys.stderr)


def _warn_planes_last(stream, path: Path, args) -> None:
    """One ``warning:`` line when an array file read planes first (``--axes THW``) looks planes-last.

    The rule (:func:`spikeref.stream.planes_last_suspected`) reads the spikes: a pixel's spike train is
    anticorrelated from one readout to the next (integrate and fire) and neighbouring pixels are not, so
    the axis that behaves like time is found whatever the shape.
    """
    from spikeref.stream import planes_last_suspected

    if path.suffix.lower() not in (".npy", ".npz") or args.axes != "THW" or stream.array is None:
        return
    if planes_last_suspected(stream.array):
        t, h, w = stream.shape
        print(f"warning: {path.name} looks stored planes-last: its last axis ({w} long) behaves like time "
              f"(a pixel's spikes, anticorrelated from one readout to the next) and its first ({t}) does not; "
              f"read as {t} planes of {h}×{w} it gives streaks: give --axes HWT", file=sys.stderr)


def _axes_said(stream, args) -> str:
    """How an array file's axes were read, for the lines that give its size ("" for a .dat)."""
    if stream.path is None or Path(stream.path).suffix.lower() not in (".npy", ".npz"):
        return ""
    return " (planes first, --axes THW)" if args.axes == "THW" else " (stored planes-last, --axes HWT)"


# ------------------------------------------------------------------------------ info
#: ``spikeref info`` without ``--stats`` counts at most this many planes …
INFO_SAMPLE_PLANES = 1000
#: … and at most this many bytes of packed planes (so very large frames stay bounded too) …
INFO_SAMPLE_BYTES = 128 << 20
#: … in this many contiguous blocks spread evenly over the file.
INFO_SAMPLE_BLOCKS = 20


def _info_sample(t: int, plane_bytes: int) -> list[tuple[int, int]]:
    """``(start, length)`` blocks of planes that ``spikeref info`` counts by default: all planes when the
    file is within the budget, else ``INFO_SAMPLE_BLOCKS`` equal blocks evenly spread from the first plane
    to the last (non-overlapping, at most ``INFO_SAMPLE_PLANES`` planes and ``INFO_SAMPLE_BYTES`` bytes)."""
    budget = max(1, min(INFO_SAMPLE_PLANES, INFO_SAMPLE_BYTES // max(1, plane_bytes)))
    if t <= budget:
        return [(0, t)]
    blocks = min(INFO_SAMPLE_BLOCKS, budget)
    length = budget // blocks
    starts = np.rint(np.linspace(0, t - length, blocks)).astype(np.int64)
    return [(int(s), length) for s in starts]


def cmd_info(args) -> int:
    if not getattr(args, "json", False):
        return _cmd_info(args, {})
    import io
    import json

    facts: dict = {}
    with contextlib.redirect_stdout(io.StringIO()):  # --json: the same facts, as one JSON object only
        _cmd_info(args, facts)
    print(json.dumps(facts, ensure_ascii=False))
    return 0


def _cmd_info(args, facts: dict) -> int:
    """``spikeref info``: print the report and fill ``facts`` (``--json``'s object) with what it says."""
    from tqdm import tqdm

    from spikeref.accumulate import window_counts
    from spikeref.bayer import bayer_planes
    from spikeref.cfa_detect import cfa_from_counts
    from spikeref.pipeline import ReconstructParams, frame_range

    auto = args.cfa is not None and args.cfa.lower() == "auto"
    # a .dat is memory-mapped: nothing below reads spikes until the statistics, which the CFA phase is read from
    stream = open_input(args, check_cfa=False)
    source = "read from the data below" if auto else _cfa_source(args, stream)
    t, h, w = stream.shape
    plane_bytes = -(-h * stream.file_width // 8)  # a .dat plane's bytes (whole there); an array's, rounded up
    print(f"file        {stream.path}")
    if stream.path is not None and Path(stream.path).is_file():
        print(f"file size   {Path(stream.path).stat().st_size} bytes")
    print(f"planes      {t}")
    stored = f" (stored rows {stream.file_width} wide)" if stream.file_width != w else ""
    print(f"size        {h} × {w} pixels{stored}")
    if stream.is_packed:
        print(f"rows        stored {stream.rows}" + (" (the spike camera's; --rows top-down if the image is "
                                                        "upside down)" if stream.rows == "bottom-up" else ""))
    print(f"plane size  {plane_bytes} bytes packed")
    print(f"cfa         {'auto' if auto else stream.cfa or 'mono'} ({source})")
    if _axes_said(stream, args):
        how = "planes first; --axes HWT reads a planes-last array" if args.axes == "THW" else "planes last"
        print(f"axes        {args.axes} ({how})")
    print(f"rate        {stream.rate_hz:g} planes/s")
    print(f"duration    {stream.duration_s * 1000:.3f} ms")
    defaults = ReconstructParams()
    avail = frame_range(t, defaults.window, defaults.K, defaults.L)
    print(f"frames      {avail.start}:{avail.stop} for reconstruct at W={defaults.window}, K={defaults.K}, "
          f"L={defaults.L} (--frames; the first {avail.start} windows are the first frame's context)"
          if len(avail) else f"frames      none for reconstruct at W={defaults.window}, K={defaults.K}, "
          f"L={defaults.L}: it needs {defaults.support_windows * defaults.window} planes")
    sys.stdout.flush()  # the layout shows at once, before any counting
    chunk = 2000
    blocks = [(s, min(chunk, t - s)) for s in range(0, t, chunk)] if args.stats else _info_sample(t, plane_bytes)
    counted = sum(n for _, n in blocks)
    if counted == t:
        print(f"statistics  over all {t} planes")
    else:
        b0, n0 = blocks[0]
        bl, _ = blocks[-1]
        print(f"statistics  over {counted} of {t} planes: {len(blocks)} blocks of {n0} planes evenly spread "
              f"(planes {b0}–{b0 + n0 - 1}, …, {bl}–{bl + n0 - 1}); --stats counts them all")
    total = np.zeros((h, w), dtype=np.float64)
    bar = tqdm(total=counted, desc="counting", unit="plane", disable=None if args.stats else True, leave=False)
    with bar:
        for start, n in blocks:
            total += window_counts(stream, n, start=start, count=1)[0]
            bar.update(n)
    rates = total / counted
    print(f"mean rate   {rates.mean():.5f} spikes/readout over all pixels")
    guess, per_plane, hot, hot_planes = None, None, None, 0
    if h % 2 or w % 2:
        print("cfa detected mono, confidence 0.00 — an odd height or width has no whole 2×2 cells")
    else:
        from spikeref.hot_pixels import HotPixelParams, find_hot_pixels

        guess = cfa_from_counts(total, counted)  # from the counts above: no plane is read twice
        if auto:
            stream.cfa = None if guess.pattern == "mono" else guess.pattern
        else:
            _check_cfa(stream, args, False, guess)  # a pattern the data contradict: one warning line
        names = list(stream.cfa) if stream.cfa else [""] * 4  # a mono sensor's 2×2 phases have no colour
        per_plane = bayer_planes(rates).mean(axis=(-1, -2))
        print("per Bayer plane (spikes/readout):" if stream.cfa else "per 2×2 phase (spikes/readout):")
        for pos, (name, r) in enumerate(zip(names, per_plane, strict=True)):
            print(f"  plane {pos} at ({pos // 2},{pos % 2}){' ' + name if name else ''}: {r:.5f}")
        print(f"cfa detected {guess.pattern}, confidence {guess.confidence:.2f} — {guess.describe()}")
        # hot pixels as reconstruct and denoise find them (their first planes), within info's budget
        hot_planes = max(1, min(HotPixelParams().planes, t, INFO_SAMPLE_BYTES // max(1, plane_bytes)))
        hot = find_hot_pixels(stream, params=HotPixelParams(planes=hot_planes))
        n_hot = int(hot.sum())
        print(f"hot pixels  {n_hot} found in planes 0–{hot_planes - 1}" + (
            f" ({100.0 * n_hot / hot.size:.3f} %; reconstruct and denoise replace them, --hot-pixels off keeps them)"
            if n_hot else ""))
    facts.update({
        "hot_pixels": int(hot.sum()) if hot is not None else None, "hot_pixel_planes": hot_planes,
        "file": str(stream.path) if stream.path is not None else None,
        "file_size": Path(stream.path).stat().st_size if stream.path is not None and Path(stream.path).is_file()
        else None,
        "planes": t, "height": h, "width": w, "file_width": stream.file_width,
        "rows": stream.rows if stream.is_packed else None, "plane_bytes": plane_bytes,
        "cfa": "auto" if auto else stream.cfa or "mono",  # as given or from the sidecar, before any detection
        "cfa_source": "auto" if auto else source, "cfa_used": stream.cfa or "mono",
        "cfa_detected": guess.pattern if guess is not None else "mono",
        "cfa_confidence": guess.confidence if guess is not None else 0.0,
        "cfa_green_confidence": guess.green_confidence if guess is not None else 0.0,
        "cfa_features": guess.as_dict() if guess is not None else None,
        "axes": args.axes if _axes_said(stream, args) else None,
        "rate_hz": stream.rate_hz, "duration_ms": stream.duration_s * 1000,
        "frames": [avail.start, avail.stop], "frames_at": {"W": defaults.window, "K": defaults.K, "L": defaults.L},
        "statistics_planes": counted, "mean_rate": float(rates.mean()),
        "phase_rates": [float(r) for r in per_plane] if per_plane is not None else None,
    })
    return 0


# -------------------------------------------------------------------------- baseline
def cmd_baseline(args) -> int:
    from spikeref.baseline_stream import baseline_frame_count
    from spikeref.render import render_baseline

    if args.output is None and args.exr_dir is None:  # as reconstruct: a video and its EXR frames, named here
        args.output, args.exr_dir = Path(f"{args.method}.mp4"), Path(f"{args.method}_exr")
    _check_video(args.output)
    _check_output_dir(args.exr_dir, "--exr-dir")
    _check_int(args.window, "-W/--window", 1, "a positive number of planes")
    _check_int(args.every, "--every", 1, "a positive number of planes")
    _check_float(args.fps, "--fps")
    stream = open_input(args)
    if args.method == "tfp" and args.window > len(stream):
        raise CliError(f"window={args.window} is longer than the stream ({len(stream)} planes)")
    total = baseline_frame_count(len(stream), args.method, args.window, args.every)
    frames = _frames_within(args.frames, range(total), "there are frames 0:{stop}")
    _compiling_note(args, f"baseline-{args.method}")
    with _output_phase():
        render_baseline(
            stream, args.method, args.output, exr_dir=args.exr_dir, window=args.window, every=args.every,
            fps=args.fps, half=args.half, progress=True, frames=frames,
        )
    _say_written(args.output, args.exr_dir)
    return 0


def _say_written(*paths) -> None:
    """``wrote PATH`` on stderr for each output written (``None``: not asked for), as every writing command says."""
    for path in paths:
        if path is not None:
            print(f"wrote {path}", file=sys.stderr)


# -------------------------------------------------------------------------- denoise
def _frames_within(text: str | None, avail: range, outside: str) -> range:
    """``--frames``: ``a:b`` (frame numbers, b excluded; a missing end is ``avail``'s) inside ``avail``, or ``N``,
    the first ``N`` frames of ``avail`` (a count past the end is cut to the end); not given (None), all of ``avail``.
    An empty range or one outside ``avail`` is refused, the latter with ``outside`` (formatted with ``start`` and
    ``stop`` of ``avail``)."""
    if text is None:
        return avail
    text = str(text).strip()
    if ":" not in text:
        try:
            n = int(text)
        except ValueError:
            raise CliError(f"--frames must be a:b (frame numbers, b excluded) or a number of frames; "
                           f"got {text!r}") from None
        _check_int(n, "--frames", 1, "a positive number of frames")
        return range(avail.start, min(avail.start + n, avail.stop))
    a, b = parse_frames_option(text)
    a = avail.start if a is None else a
    b = avail.stop if b is None else b
    if a >= b:
        raise CliError(f"--frames {a}:{b}: an empty range (the first frame must come before the end, which is "
                       f"excluded; {outside.format(start=avail.start, stop=avail.stop)})")
    if a < avail.start or b > avail.stop:
        raise CliError(f"--frames {a}:{b}: {outside.format(start=avail.start, stop=avail.stop)}")
    return range(a, b)


def cmd_denoise(args) -> int:
    import itertools

    from tqdm import tqdm

    from spikeref.render import FrameSink

    if args.output is None and args.exr_dir is None:  # as reconstruct: a video and its EXR frames, named here
        args.output, args.exr_dir = Path("denoised.mp4"), Path("denoised_exr")
    _check_video(args.output)
    _check_output_dir(args.exr_dir, "--exr-dir")
    _check_int(args.window, "-W/--window", 1, "a positive number of planes")
    _check_int(args.start, "--start", 0, "a plane index ≥ 0")
    _check_float(args.lam, "--lam", positive=False)
    _check_float(args.fps, "--fps")
    stream = open_input(args)
    if args.start >= len(stream):
        raise CliError(f"--start {args.start}: the stream has {len(stream)} planes")
    total = (len(stream) - args.start) // args.window
    if total < 1:
        raise CliError(f"no whole window of {args.window} planes from plane {args.start} "
                       f"(the stream has {len(stream)} planes)")
    frames = _frames_within(args.frames, range(total), "there are frames 0:{stop} (whole windows from --start)")
    _bundled_weights_by_default(args, args.accumulate)
    den = _load_denoiser(args.weights, accumulate=args.accumulate, mode=args.mode, lam=args.lam,
                         shrink=not args.no_shrink, guard=args.guard)
    from spikeref.hot_pixels import hot_pixels_to_replace

    hot_map = _hot_pixel_option(args.hot_pixels)
    hot = hot_pixels_to_replace(stream, "off" if args.hot_pixels == "off" else "auto", _hot_pixel_map(hot_map, stream))
    _say_hot_pixels(hot, hot_map)
    _compiling_note(args, f"denoise-{args.accumulate}")
    made = den.frames(stream, args.window, start=args.start + frames.start * args.window, count=len(frames),
                      accumulate=args.accumulate, hot_pixels=hot)
    first = next(made, None)  # the generator's own checks (and the first frame) before any output is opened
    with _output_phase():
        with FrameSink(args.output, args.exr_dir, fps=args.fps, half=args.half) as sink, \
                tqdm(total=len(frames), desc=f"denoise ({args.mode})", unit="frame", disable=None) as bar:
            for k, frame in itertools.chain([first] if first is not None else [], made):
                sink.add(frames.start + k, frame)  # frame k covers planes start + kW … start + (k + 1)W − 1
                bar.update(1)
    _say_written(args.output, args.exr_dir)
    return 0


# -------------------------------------------------------------------------- reconstruct
def parse_frames_option(text: str | None):
    """``--frames a:b`` (either end may be left out) → ``(a, b)`` with ``None`` for a missing end."""
    if text is None:
        return None, None
    parts = text.split(":")
    if len(parts) != 2:
        raise CliError(f"--frames must look like a:b (frame numbers, b excluded); got {text!r}")
    try:
        return tuple(int(v) if v.strip() else None for v in parts)
    except ValueError:
        raise CliError(f"--frames must look like a:b with integer frame numbers; got {text!r}") from None


def _frames_in(args, avail: range, params) -> range:
    """The ``--frames`` of ``args`` (``a:b`` or ``N``) inside the frames ``avail`` the stream has, or a refusal."""
    return _frames_within(args.frames, avail, "this stream has frames {start}:{stop}" +
                          f" (W={args.window}, K={args.K}, L={args.L}: frame k needs windows k−{params.reach} … "
                          f"k+{params.reach})")


def _frames_written(exr_dir: Path | None, frames: range) -> int:
    """How many of ``frames`` have their EXR file in ``exr_dir`` (written by Dask workers, say)."""
    from spikeref.render import exr_name

    if exr_dir is None or not exr_dir.is_dir():
        return 0
    return sum((exr_dir / exr_name(k)).is_file() for k in frames)


def _stopped(args, exc: BaseException, exr_dir: Path | None, frames: range, written: int) -> CliError:
    """The one line for a reconstruction stopped by a signal or an OS error: what is on disk, how to continue.

    ``written`` frames of ``frames`` are whole in ``exr_dir`` (atomic writes); ``--resume`` skips them.
    """
    if isinstance(exc, KeyboardInterrupt):
        cls, what, hint = Interrupted, f"interrupted ({_signal_name(exc)})", "continue with"
    else:
        cls, what = RunFailed, (_os_error_text(exc) if isinstance(exc, OSError) else str(exc))
        hint = _continue_hint(exc)
    if exr_dir is None:
        return cls(f"{what}; no frame was kept (the video is written at the end, and there is no --exr-dir): "
                   "run the command again, with --exr-dir DIR to make it resumable")
    on_disk = f"{written} of {len(frames)} frames written to {exr_dir}"
    if cls is Interrupted:
        return cls(f"{what} with {on_disk}; {hint}: {_resume_command(args, exr_dir)}")
    return cls(f"{what}; {on_disk}; {hint}: {_resume_command(args, exr_dir)}")


def cmd_reconstruct(args) -> int:
    import time

    from tqdm import tqdm

    from spikeref.io.exr import read_exr
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.render import FrameSink, exr_name, frame_runs, frames_on_disk

    video, exr_dir = args.output, args.exr_dir
    if video is None and exr_dir is None:
        video, exr_dir = Path("reconstruction.mp4"), Path("reconstruction_exr")
    if args.resume and exr_dir is None:
        raise CliError("--resume needs --exr-dir (the frames already written are found there)")
    if args.paper and args.preset not in (None, "paper"):
        raise CliError(f"--paper is --preset paper; give one of --paper and --preset {args.preset}")
    preset = "paper" if args.paper else (args.preset or "default")
    args.paper = preset == "paper"
    chosen = {k: v for k, v in (("flow_frames", args.flow_frames), ("warp", args.warp), ("resample", args.resample),
                                ("demosaic", args.demosaic), ("accumulate", args.accumulate)) if v is not None}
    if args.no_denoiser:
        chosen["denoise"] = False
    if args.merge is not None:
        chosen["merge"] = args.merge
    if args.support is not None:
        if args.merge in ("binomial", "robust"):
            raise CliError("--support applies to --merge adaptive (the default on window charges)")
        _check_int(args.support, "--support", 1, "a positive number of windows")
        chosen["support"] = args.support
    hot_map = _hot_pixel_option(args.hot_pixels)
    if args.hot_pixels is not None:  # a map replaces the search; auto/off as given (the paper's preset: off)
        chosen["hot_pixels"] = "off" if hot_map is not None else args.hot_pixels
    for value, flag, low in ((args.window, "-W/--window", 1), (args.K, "-K", 1), (args.L, "-L", 0)):
        _check_int(value, flag, low, f"a whole number ≥ {low}")
    if args.K % 2 == 0:
        raise CliError(f"-K must be odd (the reference is the middle window); got {args.K}")
    params = ReconstructParams.preset(preset, window=args.window, K=args.K, L=args.L, mode=args.mode,
                                      align=not args.no_align, **chosen)
    if args.resample is not None and (params.warp == "progressive" or not params.align):
        raise CliError(f"--resample {args.resample} applies to the composed and chained warps; this run "
                       f"{'aligns nothing' if not params.align else 'uses the progressive warp'}")
    if not params.denoise:
        given = [flag for flag, on in (("--weights", args.weights is not None), ("--guard", args.guard is not None),
                                       ("--no-shrink", args.no_shrink)) if on]
        if given:
            raise CliError(f"{'--no-denoiser' if args.no_denoiser else '--preset ' + preset} runs no network: "
                           f"{' and '.join(given)} {'does' if len(given) == 1 else 'do'} not apply")
    _bundled_weights_by_default(args, params.accumulate)
    _check_float(args.fps, "--fps")
    _check_video(video)
    _check_output_dir(exr_dir, "--exr-dir")
    guard = args.guard or ("off" if args.paper else "sure")
    shrink = not (args.no_shrink or args.paper)
    if args.workers is not None or args.scheduler is not None:
        if args.profile:
            raise CliError("--profile times one process; run without --workers/--scheduler")
        return _reconstruct_on_dask(args, params, video, exr_dir, guard, shrink, hot_map)
    stream = open_input(args)
    den = _load_denoiser(args.weights, accumulate=params.accumulate, mode=args.mode, shrink=shrink,
                         guard=guard) if params.denoise else None
    rec = Reconstructor(stream, params, den, hot_pixels=_hot_pixel_map(hot_map, stream))
    frames = _frames_in(args, rec.frames_available, params)
    a, b = frames.start, frames.stop
    done = set()
    if exr_dir is not None:
        with _output_phase():
            _check_resume_record(exr_dir, _run_record(stream, params, args, guard, shrink, rec.hot_pixel_mask,
                                                      hot_map), args.resume)
    if args.resume:
        done, bad = frames_on_disk(exr_dir, frames, stream.height, stream.width)
        if bad:
            print(f"{len(bad)} frame files in {exr_dir} are empty, unreadable or of another size "
                  f"(first: {exr_name(bad[0])}); they are computed again", file=sys.stderr)
    fps_out = stream.rate_hz / args.window
    parts = [f"W={args.window}, K={args.K}, L={args.L}",
             "window charges" if params.accumulate == "charge" else "Eq. 4 counts"]
    parts += [args.mode] if params.denoise else []
    warp = params.warp + (" warp" if params.warp == "progressive" else f" warp ({params.resample} samples)")
    parts += ["no alignment"] if args.no_align else [f"flow on {params.flow_frames} frames", warp]
    parts += ["the paper's procedure"] if args.paper else []
    parts += [f"the {preset} preset"] if preset in ("fast", "fastest") else []
    parts += ["Malvar–He–Cutler demosaic"] if params.demosaic == "mhc" else []
    parts += [f"guard {guard}", f"weights {Path(str(args.weights)).stem}"] if params.denoise else ["no denoiser"]
    print(f"{stream.path.name if stream.path else 'stream'}: {len(stream)} planes of {stream.height}×{stream.width}"
          f"{_axes_said(stream, args)} {stream.cfa or 'mono'} → frames {a}:{b} at {fps_out:g} FPS ({', '.join(parts)})"
          + (f"; {len(done)} already written" if done else ""), file=sys.stderr)
    _say_hot_pixels(rec.hot_pixel_mask, hot_map)
    _compiling_note(args, f"reconstruct-{preset}")
    written = len(done)  # whole EXR frames of a:b in exr_dir, for the line of an interrupted or failed run
    t_loop = time.perf_counter()
    try:
        with FrameSink(video, exr_dir, fps=args.fps, half=args.half) as sink, \
                tqdm(total=b - a, desc="reconstruct", unit="frame", disable=None) as bar:
            for lo, hi, on_disk in frame_runs(a, b, done):
                if on_disk:  # --resume: read back what an earlier run wrote (the video needs every frame)
                    for k in range(lo, hi):
                        if video is not None:
                            sink.add(k, read_exr(exr_dir / exr_name(k)), on_disk=True)
                        bar.update(1)
                    continue
                for frame in rec.frames(lo, hi):
                    with rec.timed("write"):
                        sink.add(frame.index, frame.rgb)
                    written += exr_dir is not None
                    bar.update(1)
    except (KeyboardInterrupt, OSError) as exc:  # the frames on disk are whole (atomic writes): say how to go on
        if exr_dir is not None and not exr_dir.is_dir():
            written = 0  # the folder itself is gone
        raise _stopped(args, exc, exr_dir, frames, written) from exc
    loop_s = time.perf_counter() - t_loop  # includes closing the video (its last frames are encoded there)
    _say_written(video, exr_dir)
    if args.profile:
        print(f"where the time went (frames made here: {rec.frames_made}; 'write' = EXR and video; "
              f"'other' = the rest of the loop, closing the video included):", file=sys.stderr)
        print(rec.profile(total=loop_s).table(), file=sys.stderr)
    return 0


def _run_record(stream, params, args, guard, shrink, hot_mask=None, hot_map=None) -> dict:
    """How this run makes its frames, for the EXR folder's record (``--resume`` refuses other settings).

    The hot pixels are recorded by what was replaced (named only when some were), not by the option, so a
    folder of frames made before the option existed, of a recording without hot pixels, resumes as before.
    """
    from dataclasses import asdict

    path = Path(stream.path) if stream.path is not None else None
    record = {"input": {"name": path.name if path else None,
                        "bytes": path.stat().st_size if path and path.is_file() else None,
                        "planes": len(stream), "height": stream.height, "width": stream.width, "cfa": stream.cfa},
              "params": {k: v for k, v in asdict(params).items()
                         if k != "hot_pixels" and not (params.merge_used == "binomial" and k in ("merge", "support"))}}
    if params.merge_used != "binomial":  # the merge that ran, not "auto"
        record["params"]["merge"] = params.merge_used
    if hot_mask is not None and hot_mask.any():
        record["hot_pixels"] = {"replaced": int(hot_mask.sum()),
                                "from": str(hot_map) if hot_map is not None else "the recording"}
    if stream.rows == "top-down":  # named only when not the default, so records of bottom-up runs stay as they were
        record["input"]["rows"] = stream.rows
    if params.denoise:
        record["denoiser"] = {"weights": str(args.weights), "guard": guard, "shrink": shrink}
    return record


def _check_resume_record(exr_dir, record, resume: bool) -> None:
    """Refuse a folder whose frames were made with other settings; then record this run's.

    With ``--resume`` any other settings are refused; without it too when the folder holds frames (this
    run would overwrite some of them and leave the rest: one folder would mix two settings).
    """
    from spikeref.render import EXR_FRAMES, RUN_RECORD, run_record_differences, write_run_record

    differ = run_record_differences(exr_dir, record)
    if differ:
        shown = ", ".join(differ[:6]) + (f" and {len(differ) - 6} more" if len(differ) > 6 else "")
        if resume:
            raise CliError(f"--resume: the frames in {exr_dir} were made with other settings ({shown}; see "
                           f"{RUN_RECORD} there): resume with the same options, or write to another --exr-dir")
        if any(Path(exr_dir).glob(EXR_FRAMES)):
            raise CliError(f"--exr-dir {exr_dir} holds frames made with other settings ({shown}; see {RUN_RECORD} "
                           f"there): this run would mix its frames with them. Write to another --exr-dir, or "
                           f"delete that folder's frames first")
    write_run_record(exr_dir, record)


def _reconstruct_on_dask(args, params, video, exr_dir, guard, shrink, hot_map) -> int:
    import time

    from spikeref.distributed import ChunkError, assemble_video, reconstruct_distributed
    from spikeref.pipeline import frame_range

    if args.workers is not None and args.scheduler is not None:
        raise CliError("give --workers (a local cluster) or --scheduler (an existing one), not both")
    if args.workers is not None and args.workers < 1:
        raise CliError(f"--workers must be at least 1; got {args.workers}")
    if importlib.util.find_spec("distributed") is None:  # refused before any output exists
        raise CliError(f"{'--workers' if args.workers is not None else '--scheduler'} needs Dask: "
                       f"pip install 'spikeref[dask]'")
    if args.chunk_frames < 1:
        raise CliError(f"--chunk-frames: chunk_frames must be a positive integer (frames per task); "
                       f"got {args.chunk_frames}")
    if exr_dir is None:  # workers write EXR frames; the video is assembled from them
        exr_dir = video.with_name(video.stem + "_exr")
        _check_output_dir(exr_dir, "-o/--output")
    stream = open_input(args)
    frames = _frames_in(args, frame_range(len(stream), params.window, params.K, params.L), params)
    if params.denoise:  # refused here, not on every worker
        _load_denoiser(args.weights, accumulate=params.accumulate, mode=params.mode, guard=guard, shrink=shrink)
    from spikeref.hot_pixels import find_hot_pixels

    # found once here, in the recording's first planes, and sent to every chunk (a map, even an empty one, is used
    # as it is: the chunks search for none)
    hot = _hot_pixel_map(hot_map, stream)
    if hot is None and params.hot_pixels == "auto":
        hot = find_hot_pixels(stream)
    _say_hot_pixels(hot, hot_map)
    with _output_phase():
        _check_resume_record(exr_dir, _run_record(stream, params, args, guard, shrink, hot, hot_map), args.resume)
    open_kwargs = {"height": args.height, "width": args.width, "cfa": args.cfa, "file_width": args.file_width,
                   "rate_hz": args.rate_hz, "key": args.key, "axes": args.axes, "rows": args.rows}
    where = f"{args.workers} local workers" if args.workers is not None else f"scheduler {args.scheduler}"
    print(f"{stream.path.name}: frames {frames.start}:{frames.stop} in chunks of {args.chunk_frames} on {where}"
          f" → {exr_dir}", file=sys.stderr)
    t0 = time.perf_counter()
    try:
        summaries = reconstruct_distributed(stream.path, exr_dir, params, open_kwargs=open_kwargs,
                                            weights=args.weights, frames=frames, chunk_frames=args.chunk_frames,
                                            workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                                            half=args.half, guard=guard, shrink=shrink, hot_pixels=hot)
    except (KeyboardInterrupt, OSError, ChunkError) as exc:  # frames already written stay: --resume goes on
        raise _stopped(args, exc, exr_dir, frames, _frames_written(exr_dir, frames)) from exc
    wall = time.perf_counter() - t0
    made = sum(s["written"] for s in summaries)
    if summaries:
        busy = sum(s["seconds"] for s in summaries)
        peak = max(s["peak_rss_mib"] for s in summaries)
        print(f"{made} frames written by {len(summaries)} chunks in {wall:.1f} s ({made / wall:.2f} frames/s); "
              f"{busy:.1f} s inside the tasks; peak memory of a worker {peak:.0f} MiB", file=sys.stderr)
    else:
        print("every frame was already on disk (--resume)", file=sys.stderr)
    if video is not None:
        try:
            assemble_video(exr_dir, frames, video, fps=args.fps)
        except (KeyboardInterrupt, OSError) as exc:
            raise _stopped(args, exc, exr_dir, frames, _frames_written(exr_dir, frames)) from exc
        print(f"wrote {video}", file=sys.stderr)
    print(f"wrote {exr_dir}", file=sys.stderr)
    return 0


# -------------------------------------------------------------------------- bench
def _comma_list(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def cmd_bench(args) -> int:
    import datetime
    import platform
    import time

    from spikeref.bench import BENCH_VERSION, bench_scenes, grid_settings, parse_grid, run_bench, write_report

    if args.ladder:
        return _cmd_ladder(args)
    grid = parse_grid(quick=args.quick, methods=args.methods, modes=args.modes, W=args.W, K=args.K, L=args.L,
                      align=args.align, frames=args.frames, scenes=args.scenes, flow_frames=args.flow_frames)
    scenes = bench_scenes(grid.scenes)  # unknown scene names fail here, before any work
    if args.sheet_scene is None:
        args.sheet_scene = "fan" if "fan" in [s.key for s in scenes] else scenes[0].key
    if args.sheet_scene not in [s.key for s in scenes]:
        raise CliError(f"--sheet-scene {args.sheet_scene!r} is not among the scenes run "
                       f"({', '.join(s.key for s in scenes)})")
    settings = grid_settings(grid)
    if not settings:
        raise CliError("nothing to run: --methods leaves no method")
    _check_seed(args.seed)
    out = args.out
    _check_output_dir(out, "--out")
    from spikeref.pipeline import DEFAULT_ACCUMULATE

    _bundled_weights_by_default(args, DEFAULT_ACCUMULATE)  # the network for what the method's windows give
    den = _load_denoiser(args.weights) if any(s.method == "ours" for s in settings) else None
    _writable_dir(out, "--out")  # the last check, and the first thing made: every argument is good
    print(f"bench v{BENCH_VERSION}: {len(settings)} settings × {len(scenes)} scenes, {grid.frames} scored frames "
          f"each → {out}", file=sys.stderr)
    t0 = time.perf_counter()
    _compiling_note(args, "bench")
    result = run_bench(grid, seed=args.seed, denoiser=den, progress=not args.no_progress,
                       sheet_scene=args.sheet_scene)
    elapsed = time.perf_counter() - t0
    sizes = " / ".join(dict.fromkeys(f"{s.scene.height}×{s.scene.width}" for s in scenes))
    meta = {"bench_version": BENCH_VERSION, "grid": "quick grid" if args.quick else "full grid",
            "when": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, {elapsed:.0f} s",
            "size": sizes, "frames": grid.frames,
            "denoiser": str(args.weights or "bundled default"), "sheet_scene": args.sheet_scene}
    with _output_phase():
        written = write_report(result, out, meta)
    print((out / "results.md").read_text(), file=sys.stdout)
    for path in written.values():
        print(f"wrote {path}", file=sys.stderr)
    return 0


def _writable_dir(out: Path, option: str) -> None:
    try:  # the output folder must be writable before minutes of work start
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".spikeref-bench-probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise CliError(f"{option} {out}: cannot write there ({exc.strerror or exc})") from None


def _cmd_ladder(args) -> int:
    """``spikeref bench --ladder``: the stage ladder (ladder.csv, ladder.md, ladder.png)."""
    import csv
    import datetime
    import platform
    import time

    from spikeref.bench import BENCH_VERSION, bench_scenes
    from spikeref.bench.ladder import LadderSetting, ladder_markdown, plot_ladder, run_ladder
    from spikeref.io.atomic import atomic_write

    for name in ("quick", "methods", "modes", "align", "flow_frames"):
        if getattr(args, name):
            raise CliError(f"--{name.replace('_', '-')} does not apply to --ladder (it runs every rung)")
    frames = 4 if args.frames is None else args.frames
    if isinstance(frames, bool) or not 1 <= frames <= 8:
        raise CliError(f"--frames must be 1…8; got {frames}")
    try:
        settings = [LadderSetting(w, k, lv) for w in (args.W or [10]) for k in (args.K or [3])
                    for lv in (args.L or [3])]
    except TypeError as exc:  # pragma: no cover - argparse gives ints
        raise CliError(str(exc)) from None
    for st in settings:
        if st.window < 1 or st.K < 1 or st.K % 2 == 0 or st.L < 1:
            raise CliError(f"--ladder needs W ≥ 1, odd K ≥ 3 and L ≥ 1; got {st.name}")
    try:
        scenes = bench_scenes(tuple(args.scenes or ()))
    except ValueError as exc:
        raise CliError(f"--scenes: {exc}") from None
    _check_seed(args.seed)
    out = args.out
    _check_output_dir(out, "--out")
    # without --weights each rung loads the bundled network for what its windows give (count or charge)
    den = _load_denoiser(args.weights) if args.weights is not None else None
    _writable_dir(out, "--out")  # the last check, and the first thing made: every argument is good
    print(f"bench v{BENCH_VERSION} ladder: {len(settings)} setting(s) × {len(scenes)} scenes, {frames} scored frames "
          f"each → {out}", file=sys.stderr)
    from spikeref.denoise.peers import peer_available

    missing = [name for name in ("bm3d", "nlm") if not peer_available(name)]
    if missing:
        print(f"note: the {' and '.join(m.upper() for m in missing)} rungs are left out: they need the peers extra "
              f"(bm3d, scikit-image, PyWavelets): pip install \"spikeref[peers]\"", file=sys.stderr)
    _compiling_note(args, "bench-ladder")
    t0 = time.perf_counter()
    result = run_ladder(scenes, settings, seed=args.seed, denoiser=den, frames=frames,
                        progress=not args.no_progress)
    elapsed = time.perf_counter() - t0
    head = (f"# spikeref bench --ladder (bench v{BENCH_VERSION}, seed {args.seed}, "
            f"{datetime.datetime.now():%Y-%m-%d %H:%M}, {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} CPUs, {elapsed:.0f} s)\n\n")
    text = head + ladder_markdown(result)
    with _output_phase():
        def write_csv(tmp):
            with open(tmp, "w", newline="") as fh:
                writer = csv.DictWriter(fh, fieldnames=list(result["rows"][0]))
                writer.writeheader()
                writer.writerows(result["rows"])

        atomic_write(out / "ladder.csv", write_csv)
        atomic_write(out / "ladder.md", lambda tmp: Path(tmp).write_text(text))
        written = [out / "ladder.csv", out / "ladder.md"]
        if plot_ladder(result, out / "ladder.png"):
            written.append(out / "ladder.png")
    print(text)
    for path in written:
        print(f"wrote {path}", file=sys.stderr)
    return 0


# -------------------------------------------------------------------------- train
def cmd_train(args) -> int:
    for flag, value in (("--channels", args.channels), ("--steps", args.steps), ("--batch", args.batch),
                        ("--patch", args.patch), ("--window-min", args.window_min),
                        ("--window-max", args.window_max), ("--checkpoint-every", args.checkpoint_every),
                        ("--stop-after", args.stop_after), ("--masks-per-step", args.masks_per_step)):
        _check_int(value, flag)
    if args.masks_per_step > 16:
        raise CliError(f"--masks-per-step must be at most 16 (the blind-spot cell has 16 masks); "
                       f"got {args.masks_per_step}")
    if args.patch % 32:
        raise CliError(f"--patch must be a multiple of 32 (the U-Net halves it 5 times); got {args.patch}")
    if args.window_max < args.window_min:
        raise CliError(f"--window-max ({args.window_max}) must be ≥ --window-min ({args.window_min})")
    _check_float(args.lr, "--lr", positive=False)
    _check_seed(args.seed)
    _check_input_options(args)
    _check_output_file(args.output, "-o/--output", (".npz",), "weights output")
    checkpoint = args.checkpoint if args.checkpoint is not None else args.output.with_name(args.output.name + ".ckpt")
    if checkpoint.is_dir():
        raise CliError(f"--checkpoint {checkpoint}: is a folder, not a file")
    _check_folder_can_exist(checkpoint.parent, "--checkpoint", checkpoint)
    for path in args.data:
        if not path.exists():
            raise CliError(f"no such file: {path}")
    try:
        from spikeref.denoise.train import TrainConfig, train
    except ImportError as exc:
        raise CliError(f"training needs PyTorch: pip install 'spikeref[train]' ({exc})") from None
    from spikeref.stream import open_spike_file

    streams = [open_spike_file(path, height=args.height, width=args.width, file_width=args.file_width,
                               rows=args.rows) for path in args.data]
    cfg = TrainConfig(width=args.channels, steps=args.steps, batch=args.batch, patch=args.patch, lr=args.lr,
                      window_min=args.window_min, window_max=args.window_max,
                      input_domain=args.input_domain, checkpoint_every=args.checkpoint_every,
                      masks_per_step=args.masks_per_step, seed=args.seed, accumulate=args.accumulate,
                      objective=args.objective)
    describe = {"command": "spikeref train " + " ".join(sys.argv[2:]) if len(sys.argv) > 2 else "spikeref train",
                "data": [{"file": Path(s.path).name, "planes": len(s), "height": s.height, "width": s.width}
                         for s in streams]}
    try:
        with _output_phase():
            for folder in {args.output.parent, checkpoint.parent}:
                folder.mkdir(parents=True, exist_ok=True)
            summary = train(streams, args.output, cfg, checkpoint=checkpoint, resume=args.resume,
                            device=args.device, describe=describe, stop_after=args.stop_after)
    except KeyboardInterrupt as exc:
        state = f"the last checkpoint is {checkpoint}" if checkpoint.is_file() else "no checkpoint was written yet"
        raise Interrupted(f"interrupted ({_signal_name(exc)}); {state}; continue with: "
                          f"{_resume_command(args)}") from exc
    print(f"wrote {args.output}: {summary['steps']} steps in {summary['seconds']:.1f} s, "
          f"final loss {summary['final_loss']:.4g}")
    return 0


# -------------------------------------------------------------------------- simulate
def parse_effects_option(text: str | None):
    """``--effects``: ``scene`` (keep the scene's), ``none``, or ``name[:param=value...][,name...]``."""
    if text is None or text.strip().lower() == "scene":
        return None
    if text.strip().lower() == "none":
        return {}
    spec = {}
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        name, *params = item.split(":")
        table = {}
        for param in params:
            key, eq, value = param.partition("=")
            if not eq:
                raise CliError(f"--effects: expected param=value in {item!r}; got {param!r}")
            try:
                table[key.strip()] = float(value)
            except ValueError:
                raise CliError(f"--effects: {name}.{key.strip()} must be a number; got {value!r}") from None
        spec[name.strip()] = table
    return spec


def cmd_simulate(args) -> int:
    from spikeref.simulate.effects import parse_effects
    from spikeref.simulate.recording import simulate_to_dat
    from spikeref.simulate.scenes import load_scene

    if args.output.suffix.lower() != ".dat":
        raise CliError(f"-o/--output must be a .dat file; got {args.output.name!r}")
    _check_output_file(args.output, "-o/--output", (".dat",), "spike output")
    if args.gt is not None:
        if args.gt.suffix.lower() != ".npz":
            raise CliError(f"--gt: ground truth goes to a .npz file; got {args.gt.name!r}")
        _check_output_file(args.gt, "--gt", (".npz",), "ground truth")
    _check_output_dir(args.gt_exr, "--gt-exr")
    _check_int(args.planes, "--planes", 1, "a positive number of planes")
    _check_int(args.gt_window, "--gt-window", 1, "a positive number of planes")
    _check_int(args.chunk_planes, "--chunk-planes", 1, "a positive number of planes")
    _check_seed(args.seed)
    scene = load_scene(args.scene)
    effects = parse_effects_option(args.effects)
    if effects is not None:
        effects = parse_effects(effects)
    with _output_phase():
        for path in (args.output, args.gt):
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
        meta = simulate_to_dat(scene, args.output, seed=args.seed, planes=args.planes, effects=effects,
                               gt_path=args.gt, gt_window=args.gt_window, gt_exr_dir=args.gt_exr,
                               chunk_planes=args.chunk_planes, progress=True)
    dur_ms = meta["planes"] / meta["rate_hz"] * 1000
    listed = ", ".join(meta["effects"]) or "none (noise-free)"
    print(f"wrote {args.output}: {meta['planes']} planes ({dur_ms:.2f} ms) of {meta['height']}×{meta['width']}, "
          f"cfa {meta['cfa']}, seed {meta['seed']}, effects: {listed}")
    if args.gt is not None:
        print(f"ground truth {args.gt}: frames of {args.gt_window} planes, rate units (alpha*L/E_th)")
    if args.gt_exr is not None:
        print(f"ground-truth EXR frames in {args.gt_exr}")
    return 0


# ----------------------------------------------------------------------- noise-check
def _int_list(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated whole numbers of planes; got {text!r}") from None


def cmd_noise_check(args) -> int:
    import importlib.util

    from spikeref.noise_check import noise_check, plot_noise_check

    for w in args.windows:
        _check_int(w, "--windows", 1, "a positive number of planes each")
    _check_int(args.start, "--start", 0, "a plane index ≥ 0")
    _check_int(args.planes, "--planes", 1, "a positive number of planes")
    _check_float(args.min_rate, "--min-rate", positive=False)
    if args.plot is not None:
        if args.plot.suffix.lower() != ".png":
            raise CliError(f"--plot must end in .png; got {args.plot.name!r}")
        _check_output_file(args.plot, "--plot", (".png",), "plot")
        if importlib.util.find_spec("matplotlib") is None:
            raise CliError("--plot needs matplotlib: pip install 'spikeref[plot]'")
    stream = open_input(args)
    _compiling_note(args, "noise-check")
    result = noise_check(stream, windows=args.windows, start=args.start, planes=args.planes,
                         min_rate=args.min_rate, progress=True)
    print(f"noise ratio I_c / E[I_c] - 1 of {stream.path or 'the input'} (Fig. 4a; the scene must be static)")
    print(result.table())
    if args.plot is not None:
        with _output_phase():
            args.plot.parent.mkdir(parents=True, exist_ok=True)
            plot_noise_check(result, args.plot)
        print(f"plot: {args.plot}")
    for line in result.warnings:  # a channel resting on too few pixels (also marked in the table and plot)
        print(f"warning: {line}", file=sys.stderr)
    return 0


# --------------------------------------------------------------------------- calibrate
#: ``calibrate``'s least excess over the same-colour reference, spikes per readout: in a dark recording no scene can
#: mimic a defect, so the statistical test (6 σ in the stretch, half the blocks) decides, down to a weak leak.
CALIBRATE_MIN_EXCESS = 0.02


def cmd_calibrate(args) -> int:
    """``spikeref calibrate DARK -o map.npz``: the hot pixels of a (dark) recording, as a map."""
    from spikeref.hot_pixels import HotPixelParams, hot_pixel_excess, save_hot_pixel_map

    _check_output_file(args.output, "-o/--output", (".npz",), "hot-pixel map")
    _check_int(args.planes, "--planes", 8, "a number of readouts ≥ 8")
    stream = open_input(args)
    if stream.height % 2 or stream.width % 2:
        raise CliError(f"the recording must have even height and width (2×2 phases); got {stream.height}×"
                       f"{stream.width}")
    if len(stream) < 8:
        raise CliError(f"{len(stream)} planes: too few to tell a hot pixel (at least 8)")
    found = hot_pixel_excess(stream, params=HotPixelParams(planes=args.planes, min_excess=CALIBRATE_MIN_EXCESS))
    mask, excess = found["hot"], found["excess"]
    planes = min(args.planes, len(stream))
    with _output_phase():
        save_hot_pixel_map(args.output, mask, planes=planes, height=stream.height, width=stream.width,
                           source=str(stream.path.name if stream.path else ""))
    n = int(mask.sum())
    share = 100.0 * n / mask.size
    print(f"{stream.path.name if stream.path else 'stream'}: {n} hot pixels ({share:.3f} % of {mask.size}) in "
          f"{planes} planes" + (f"; their excess over their colour {float(excess[mask].min()):.2f}–"
                                f"{float(excess[mask].max()):.2f} spikes per readout" if n else ""))
    print(f"wrote {args.output}: use it with spikeref reconstruct/denoise --hot-pixels {args.output}",
          file=sys.stderr)
    return 0


# ------------------------------------------------------------------------------ golden
def cmd_golden(args) -> int:
    from spikeref import golden_check as gc

    action = getattr(args, "golden_command", None)
    if action is None:
        args.golden_parser.print_help()
        return 2
    golden = gc.find_golden(args.golden)
    if action == "list":
        rows = gc.list_cases(golden)
        fmt = gc.load_manifest(golden).get("format", 1)
        print(f"{sum(r['frozen'] for r in rows)} golden cases in {golden} (manifest format {fmt}). A port passes "
              "a case when every out_* array is within |got - expected| <= atol + rtol*|expected|.")
        print(gc.cases_table(rows, verbose=args.verbose))
        return 0
    if action == "check":
        cases = _comma_list(args.cases) if args.cases is not None else None
        results = gc.check_port(args.dir, golden, cases=cases)
        print(f"golden check of {args.dir} against {golden}")
        print(gc.results_table(results))
        return 0 if all(r.passed for r in results) else 1
    # export
    _check_output_dir(args.dir, "DIR")
    gc.load_manifest(golden)  # a malformed manifest is refused before anything is written
    with _output_phase():
        written = gc.export_cases(args.dir, args.format, golden, outputs=args.with_outputs)
    folders = len({p.parent for p in written if p.name == "case.json"})
    what = "inputs and expected outputs" if args.with_outputs else "inputs"
    print(f"wrote the {what} of {folders} cases as .{args.format} ({len(written)} files) under {args.dir}; "
          f"the description of each case is in <case>/case.json, the manifest in {args.dir / 'manifest.json'}")
    return 0


class _Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors are one line (exit 2), like the commands' own errors."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="spikeref",
        description="Colour video from mosaicked chromatic spikes (Yang et al., ECCV 2024), on a CPU.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("info", help="planes, size, duration and mean firing rate per Bayer plane",
                       description="Print what a spike file holds: planes, size, duration (at the readout "
                                   "rate), and the mean firing rate (spikes per readout, 0…1) per Bayer plane. "
                                   "The layout comes from the file size alone; the rates from a bounded sample "
                                   "of planes spread over the file, or from every plane with --stats; the CFA "
                                   "phase (which 2×2 sites are green, red, blue, or mono) from the same counts.")
    _add_input_options(p, optional_file=True)
    p.add_argument("--stats", action="store_true",
                   help="count every plane (streamed, with a progress bar) instead of a sample of at most "
                        f"{INFO_SAMPLE_PLANES} planes / {INFO_SAMPLE_BYTES >> 20} MiB spread over the file")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object and nothing else on stdout: height, width, planes, cfa (as given or "
                        "from NAME.json; mono for none), cfa_detected (RGGB, BGGR, GRBG, GBRG or mono, read from the "
                        "counted planes), cfa_confidence (0-1), rate_hz, duration_ms, file, phase_rates, ...")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("baseline", help="TFP / TFI / TFSTP reconstruction to MP4 (+ EXR frames)",
                       description="Reconstruct with a classic baseline (per Bayer plane, then bilinear "
                                   "demosaic Ψ for colour streams) and write a video and/or EXR frames (without "
                                   "-o/--exr-dir: METHOD.mp4 and METHOD_exr/).",
                       formatter_class=_DefaultsHelpFormatter)
    p.add_argument("method", choices=["tfp", "tfi", "tfstp"], help="baseline to run")
    _add_input_options(p, optional_file=True)
    p.add_argument("-o", "--output", type=Path, default=None, help="video file (.mp4 or .gif)")
    p.add_argument("--exr-dir", type=Path, default=None, help="also write linear EXR frames here")
    p.add_argument("-W", "--window", type=int, default=10,
                   help="TFP window in planes (10 planes = 0.5 ms at 20 kHz → 2000 FPS)")
    p.add_argument("--every", type=int, default=None,
                   help="TFI/TFSTP: output one frame every this many planes (default: the window)")
    p.add_argument("--frames", default=None,
                   help="frame numbers a:b (b excluded; TFP frame k is planes kW … (k+1)W − 1, TFI/TFSTP frame k "
                        "is plane k·every), or N for the first N (default all); TFSTP still filters every "
                        "plane before the first")
    p.add_argument("--fps", type=float, default=30.0, help="playback rate of the video file")
    p.add_argument("--half", action="store_true", help="write float16 EXR (default float32)")
    p.set_defaults(func=cmd_baseline)

    p = sub.add_parser("denoise", help="denoised colour frames Ψ[D(I)] of a spike file to MP4 / EXR",
                       description="Accumulate windows of W planes (Eq. 4), denoise the four Bayer planes with the "
                                   "self-supervised U-Net (§4.1; bundled weights unless --weights) and demosaic "
                                   "(Ψ). Frames are linear RGB in spikes per readout; the video uses one exposure. "
                                   "Without -o/--exr-dir it writes denoised.mp4 and denoised_exr/.",
                       formatter_class=_DefaultsHelpFormatter)
    _add_input_options(p, optional_file=True)
    p.add_argument("-o", "--output", type=Path, default=None, help="video file (.mp4 or .gif)")
    p.add_argument("--exr-dir", type=Path, default=None, help="also write linear EXR frames here")
    p.add_argument("-W", "--window", type=int, default=10,
                   help="window in planes (10 planes = 0.5 ms at 20 kHz → 2000 FPS)")
    p.add_argument("--mode", choices=["visible", "blind", "mixed"], default="visible",
                   help="visible: one network pass; blind: Eq. 10-11, 16 passes; mixed: (D + λf)/(1 + λ)")
    p.add_argument("--lam", type=float, default=2.0, help="λ of the mixed mode")
    _add_hot_pixel_option(p, "denoise")
    p.add_argument("--guard", choices=["sure", "off"], default="sure",
                   help="sure: blend the network's output with its input by Stein's unbiased risk estimate, "
                        "per pixel, from the data's own noise level (one more network pass; not in the paper; "
                        "spikeref.denoise.guard; for W > 10 the noise is measured on the window's first 10 "
                        "planes, so texture is not read as noise); off: the network's output, then the shrinkage "
                        "below")
    p.add_argument("--accumulate", choices=["count", "charge"], default="count",
                   help="what each window gives: count (default; Eq. 4, its spikes / W) or charge (the charge its "
                        "pixels integrated, read from the spike times up to 200 readouts around the window's edges; "
                        "not in the paper; spikeref.charge); without --weights it uses the bundled pairs_w16_charge, "
                        "trained on window charges (b2u_w16 with counts)")
    p.add_argument("--no-shrink", action="store_true",
                   help="with --guard off, do not give back the residual above the exposure's binomial noise "
                        "(spikeref.denoise.shrinkage); --guard off --no-shrink is the paper's D(I) exactly")
    p.add_argument("--weights", type=Path, default=None,
                   help="weights .npz, or a bundled name: b2u_w16 (the default with counts: Eq. 4's counts, the "
                        "paper's Blind2Unblind loss) or pairs_w16_charge (the default with --accumulate charge: "
                        "trained on window charges by Noise2Noise pairs); each network is trained on what its path "
                        "gives it")
    p.add_argument("--start", type=int, default=0, help="first plane")
    p.add_argument("--frames", default=None,
                   help="frame numbers a:b (b excluded; frame k is planes start + kW … start + (k+1)W − 1), or N for "
                        "the first N (default: every whole window)")
    p.add_argument("--fps", type=float, default=30.0, help="playback rate of the video file")
    p.add_argument("--half", action="store_true", help="write float16 EXR (default float32)")
    p.set_defaults(func=cmd_denoise)

    p = sub.add_parser("reconstruct", help="colour HDR video by progressive warping (Eq. 13-15) to MP4 + EXR",
                       description="Reconstruct linear colour HDR frames R_L = Ψ[D(I_L)] (§4.2, Fig. 3b): windows "
                                   "of W planes are accumulated (by default their charge, read from the spike times "
                                   "around each window; Eq. 4's count with --accumulate count or --paper), denoised "
                                   "(§4.1) and aligned (HDR+ tiles); "
                                   "step 1 warps the spike planes of K windows (Eq. 14), steps 2…L warp K frames of "
                                   "the previous step (Eq. 15). One frame per window: 20000/W FPS; frame k is "
                                   "centred on window k (planes kW … (k+1)W − 1) and needs ((K−1)L+1)·W planes around "
                                   "it. Without FILE the embedded sample is used. Without -o/--exr-dir it writes "
                                   "reconstruction.mp4 and reconstruction_exr/. EXR frames are linear float RGB in "
                                   "spikes per readout, named frame_NNNNNN.exr by frame number.",
                       formatter_class=_DefaultsHelpFormatter)
    _add_input_options(p, optional_file=True)
    p.add_argument("-o", "--output", type=Path, default=None, help="video file (.mp4 or .gif), one exposure")
    p.add_argument("--exr-dir", type=Path, default=None, help="folder for linear EXR frames")
    p.add_argument("-W", "--window", type=int, default=10,
                   help="window in planes (10 planes = 0.5 ms at 20 kHz → 2000 FPS)")
    p.add_argument("-K", type=int, default=3, help="frames warped together at each step (odd)")
    p.add_argument("-L", type=int, default=3, help="warping steps (0: denoised TFP only)")
    p.add_argument("--mode", choices=["visible", "blind", "mixed"], default="visible",
                   help="denoiser inference: visible (1 pass), blind (Eq. 10-11, 16 passes), mixed (17)")
    p.add_argument("--paper", action="store_true",
                   help="the paper's procedure exactly: flows on the denoised frames, the plain HDR+ search, "
                        "Eq. 14-15 step by step, the network's D(I) without guard or shrinkage (the defaults go "
                        "beyond the paper where the stage ladder measured a gain: docs/results.md)")
    p.add_argument("--preset", choices=["default", "fast", "fastest", "paper"], default=None,
                   help="named settings (options given with it win): default (the defaults below); fast (the "
                        "defaults with --warp chained: only the step-0 flows estimated and composed; faster, at "
                        "about the defaults' accuracy); fastest (fast with --no-denoiser: faster still, a little "
                        "under the defaults in low light); paper (= --paper). Their measured frames/s and dB: "
                        "README.md, 'Fast preset', and docs/results.md, 'Speed'")
    p.add_argument("--no-denoiser", action="store_true",
                   help="D is the identity: no network pass, no weights (not in the paper; with window charges the "
                        "network gains little on the benchmark for about half the frame time: docs/results.md)")
    p.add_argument("--profile", action="store_true",
                   help="after the run, print to stderr where the time went: seconds, %% of the run's time and "
                        "milliseconds per frame for accumulate (Eq. 4), network (the U-Net's passes), guard (the "
                        "rest of the denoiser), align, warp (Eq. 14-15), demosaic, write (EXR/video) and other")
    p.add_argument("--guard", choices=["sure", "off"], default=None,
                   help="sure (default): blend the network's output with its input by Stein's unbiased risk "
                        "estimate, per pixel, from the data's own noise level (one more network pass; not in the "
                        "paper; spikeref.denoise.guard); off: the network's output, then the shrinkage below")
    p.add_argument("--no-shrink", action="store_true",
                   help="with --guard off, do not give back the residual above the exposure's binomial noise "
                        "(spikeref.denoise.shrinkage); --guard off --no-shrink is the paper's D(I) exactly")
    p.add_argument("--no-align", action="store_true", help="zero flow (plain accumulation over the support)")
    p.add_argument("--merge", choices=["adaptive", "robust", "binomial"], default=None,
                   help="how the aligned windows are merged (composed or chained warp): adaptive (default with "
                        "window charges: each window weighed by how well it agrees with the reference beyond the "
                        "noise, so misaligned and occluded samples drop out, and windows beyond Eq. 14-15's support "
                        "added where they keep agreeing, up to --support windows each side), robust (the same "
                        "weights at Eq. 14-15's support), binomial (Eq. 14-15's weights; the default with "
                        "--accumulate count, --preset fast and --paper). Not in the paper; spikeref.merge; what each "
                        "buys and costs: docs/results.md, 'The robust merge'")
    p.add_argument("--support", type=int, default=None,
                   help="with the adaptive merge: the farthest window a pixel may collect, in windows each side of "
                        "the reference (default 10: 100 planes at W = 10)")
    _add_hot_pixel_option(p, "reconstruct")
    p.add_argument("--flow-frames", choices=["denoised", "smoothed"], default=None,
                   help="what each step's flow is estimated on: smoothed (default; a Gaussian of σ = 1 "
                        "Bayer-plane pixel on the raw frames, one denoiser pass per frame, not in the paper) or "
                        "denoised (the paper, Fig. 3b: L+1 denoiser passes per frame)")
    p.add_argument("--warp", choices=["composed", "progressive", "chained"], default=None,
                   help="how the output is warped: composed (default; the step flows composed, each spike window "
                        "resampled once with a cubic, not in the paper), progressive (Eq. 14-15 step by step) or "
                        "chained (only the step-0 flows composed: no frame or flow of later steps, faster, same "
                        "accuracy on the benchmark; not in the paper)")
    p.add_argument("--resample", choices=["window", "path"], default=None,
                   help="with the composed or chained warp: window (default; each spike window sampled once, at the "
                        "mean composed position of its paths: a faster warp, the same accuracy on the benchmark, "
                        "docs/results.md) or path (once per path, the composed warp before 2026-11-24)")
    p.add_argument("--demosaic", choices=["bilinear", "mhc"], default=None,
                   help="the output frame's demosaic: bilinear (default; the paper's Ψ, Eq. 13) or mhc "
                        "(Malvar-He-Cutler 5x5 filters: sharper on photographs, not in the paper; docs/results.md)")
    p.add_argument("--accumulate", choices=["charge", "count"], default=None,
                   help="what each window contributes: charge (default; the charge its pixels integrated, read from "
                        "the spike times up to 200 readouts around the window's edges: the count's ±1 quantisation "
                        "at the edges falls by about the firing rate; not in the paper; spikeref.charge, "
                        "docs/results.md) or count (Eq. 4, its spikes; the paper's, and --paper's)")
    p.add_argument("--weights", type=Path, default=None,
                   help="denoiser weights .npz, or a bundled name: pairs_w16_charge (the default with charges: "
                        "trained on window charges by Noise2Noise pairs) or b2u_w16 (the default with counts and "
                        "--paper: Eq. 4's counts, the paper's Blind2Unblind loss); each network is trained on what "
                        "its path gives it")
    p.add_argument("--frames", default=None, help="frame numbers a:b to reconstruct (b excluded; default all), "
                   "or N for the first N; "
                   "chunks give exactly the frames of a full run")
    p.add_argument("--resume", action="store_true",
                   help="skip frames whose EXR file exists in --exr-dir (an interrupted run loses nothing)")
    p.add_argument("--fps", type=float, default=30.0, help="playback rate of the video file")
    p.add_argument("--half", action="store_true", help="write float16 EXR (default float32)")
    p.add_argument("--workers", type=int, default=None,
                   help="reconstruct in chunks on a local Dask cluster of this many worker processes "
                        "(needs spikeref[dask]); EXR frames are written by the workers, the video assembled after")
    p.add_argument("--scheduler", default=None,
                   help="address of an existing Dask scheduler (e.g. tcp://host:8786) instead of --workers; "
                        "input and output paths must be visible to every worker")
    p.add_argument("--chunk-frames", type=int, default=64,
                   help="output frames per Dask task; each task re-reads (K-1)·L windows of overlap")
    p.set_defaults(func=cmd_reconstruct)

    p = sub.add_parser("bench", help="accuracy against seconds per frame of every method and setting "
                                     "(table, CSV, Pareto plot, contact sheet)",
                       description="Run TFP (W=10, W=100), TFI, TFSTP and the progressive warping over its "
                                   "settings (denoiser mode visible/mixed/blind, L = 0…3, K = 3, 5, W = 10, 20 "
                                   "planes, alignment on/off, flow on denoised or smoothed frames, and the "
                                   "fast preset, reconstruct --preset fast) on the "
                                   "versioned benchmark scenes (static, translation, fan, hdr, low_light, and "
                                   "the photographs astronaut_pan, coffee_spin, occlusion with the test extra; "
                                   "128×128 or 128×160 pixels, 800 planes = 40 ms, "
                                   "simulated with realistic noise). Every method is scored at the same instants "
                                   "against the 2000-FPS ground truth (PSNR, SSIM, PU21-PSNR, PU21-SSIM) and "
                                   "timed in seconds per output frame in this process. Writes results.csv, "
                                   "results.md, contact_sheet.png and (with spikeref[plot]) pareto.png. "
                                   "The full grid (52 settings) takes ~5 min on 2 cores; --quick (16 settings, "
                                   "2 frames per scene) under 3 min.",
                       formatter_class=_DefaultsHelpFormatter)
    p.add_argument("--quick", action="store_true",
                   help="the quick grid: L axis at K=3, W=10 plus K=5, W=20, no alignment, smoothed flow frames "
                        "one at a time at L=3; mixed and blind at L=0; 2 scored frames per scene")
    p.add_argument("--out", type=Path, default=Path("spikeref-bench"), help="output folder")
    p.add_argument("--methods", type=_comma_list, default=None,
                   help="comma-separated subset of tfp10,tfp100,tfi,tfstp,ours (default: all)")
    p.add_argument("--modes", type=_comma_list, default=None, help="denoiser modes of ours: visible,mixed,blind")
    p.add_argument("-W", type=_int_list, default=None, help="windows W of ours in planes: 10,20")
    p.add_argument("-K", type=_int_list, default=None, help="frames per step K of ours: 3,5")
    p.add_argument("-L", type=_int_list, default=None, help="steps L of ours: 0,1,2,3")
    p.add_argument("--align", type=_comma_list, default=None, help="alignment of ours: on,off")
    p.add_argument("--flow-frames", type=_comma_list, default=None,
                   help="what the flow of ours is estimated on: denoised (the paper), smoothed (the speed option)")
    p.add_argument("--frames", type=int, default=None, help="scored frames per scene, 1…8 (full 4, quick 2)")
    p.add_argument("--scenes", type=_comma_list, default=None,
                   help="comma-separated subset of static,translation,fan,hdr,low_light,astronaut_pan,"
                        "coffee_spin,occlusion")
    p.add_argument("--sheet-scene", default=None, help="scene shown on the contact sheet (default: fan)")
    p.add_argument("--seed", type=int, default=0, help="simulation seed of the scenes")
    p.add_argument("--weights", default=None, help="denoiser weights (.npz or a bundled name; default bundled)")
    p.add_argument("--ladder", action="store_true",
                   help="the stage ladder instead of the grid: per scene, TFP(W), BM3D / NLM on one window "
                        "(extra peers), the denoiser on one window, TFP(support), no alignment, no denoiser, "
                        "ours, the true-flow ceiling (alone, with the denoiser, with BM3D, on noise-free "
                        "windows), and the limit (the noise-free mosaic through Ψ), plus the flow's end-point "
                        "error per step; at W/K/L from -W/-K/-L (default 10/3/3). Writes ladder.csv, ladder.md "
                        "and (with spikeref[plot]) ladder.png into --out; about 100 s on 2 cores with the "
                        "peers extra. With --ladder, -W/-K/-L, --scenes, --frames, --seed, --weights, --out and "
                        "--no-progress apply; --quick, --methods, --modes, --align and --flow-frames are refused")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("train", help="train the denoiser on unlabeled spike files (needs spikeref[train])",
                       description="Self-supervised training of the denoising U-Net (Blind2Unblind: blind-spot "
                                   "volume Eq. 10-11, re-visible loss Eq. 12 with λ 2→20). Reads spike files only, "
                                   "never ground truth. Writes NumPy weights for `spikeref denoise --weights`, and "
                                   "a checkpoint every --checkpoint-every steps; --resume continues from it. The "
                                   "defaults are the CPU recipe of the bundled b2u_w16 (about 50 minutes on two "
                                   "cores; OMP_NUM_THREADS=1 when other jobs share them); the paper's recipe is "
                                   "--masks-per-step 16 --patch 128 --batch 8. --objective pairs (not in the "
                                   "paper) trains by Noise2Noise pairs of windows of recordings of scenes that do "
                                   "not move, as the bundled charge network pairs_w16_charge was "
                                   "(scripts/train_denoiser.py).",
                       formatter_class=_DefaultsHelpFormatter)
    p.add_argument("data", type=Path, nargs="+", help="spike files (.dat with NAME.json, .npy, .npz), colour or mono")
    p.add_argument("-o", "--output", type=Path, required=True, help="weights file to write (.npz)")
    p.add_argument("--channels", type=int, default=16, help="U-Net channel width C")
    p.add_argument("--steps", type=int, default=4000, help="optimiser steps")
    p.add_argument("--batch", type=int, default=16, help="crops per step (each gives its four 2×2 phases)")
    p.add_argument("--patch", type=int, default=64, help="training image side on the plane grid, pixels "
                   "(multiple of 32; the mosaic crop is twice this)")
    p.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (cosine decay to 1 %%)")
    p.add_argument("--window-min", type=int, default=5, help="shortest window W, planes")
    p.add_argument("--window-max", type=int, default=200, help="longest window W, planes (log-uniform draw)")
    p.add_argument("--seed", type=int, default=0, help="seed of crops, augmentation and initial weights")
    p.add_argument("--input-domain", choices=["count", "rate"], default="count",
                   help="what the network sees: spike counts I·W (noise level nearly independent of W) or "
                        "firing rates I")
    p.add_argument("--checkpoint", type=Path, default=None, help="checkpoint file (default: OUTPUT.ckpt)")
    p.add_argument("--checkpoint-every", type=int, default=500, help="steps between checkpoints")
    p.add_argument("--masks-per-step", type=int, default=1,
                   help="how many of the 16 blind-spot masks (Eq. 10) each image runs per step, drawn at random; "
                        "the loss is taken on their hidden pixels. 16 is the paper's full volume; 1 is an order of "
                        "magnitude cheaper per step (the CPU recipe: scripts/train_denoiser.py)")
    p.add_argument("--accumulate", choices=["count", "charge"], default="count",
                   help="what a window gives the network: its spike count (Eq. 4) or the timing-aware charge "
                        "(weights for --accumulate charge of denoise and reconstruct)")
    p.add_argument("--objective", choices=["b2u", "pairs"], default="b2u",
                   help="b2u: the paper's Blind2Unblind self-supervision (Eq. 10-12); pairs (not in the paper): "
                        "Noise2Noise on recordings of scenes that do not move, one window against the spike count "
                        "of every plane it did not read (each file at least --window-max + 500 planes long)")
    p.add_argument("--resume", action="store_true", help="continue from the checkpoint if it exists")
    p.add_argument("--stop-after", type=int, default=None,
                   help="stop after this many of the --steps schedule's steps and write the weights "
                        "(with --resume from a checkpoint at that step: export it without training)")
    p.add_argument("--device", default=None, help="torch device, e.g. cpu or cuda (default: cuda if available)")
    p.add_argument("--height", type=int, default=None, help="image height of .dat files without NAME.json")
    p.add_argument("--width", type=int, default=None, help="image width of .dat files without NAME.json")
    p.add_argument("--file-width", type=int, default=None, help="stored row width of padded .dat rows")
    p.add_argument("--rows", choices=["bottom-up", "top-down"], default=None,
                   help="the order .dat files store the image rows in (default from NAME.json, else bottom-up, "
                        "the spike camera's; docs/inputs.md)")
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("simulate", help="simulate a scene (TOML) into a .dat spike file, with ground truth",
                       description="Simulate a chromatic spike camera (Eq. 1–3 and the effects the scene lists, "
                                   "Eq. 5–9) looking at a scene described in TOML (see examples/scenes/), and write "
                                   "the spikes as .dat with a NAME.json sidecar. Time is in readouts (planes) at "
                                   "the camera's rate (20 000 planes/s by default). Ground truth is the mean linear "
                                   "RGB radiance over each window, in rate units (spikes per readout).",
                       formatter_class=_DefaultsHelpFormatter)
    p.add_argument("scene", type=Path, help="scene file (.toml), e.g. examples/scenes/fan.toml")
    p.add_argument("-o", "--output", type=Path, required=True, help="spike file to write (.dat)")
    p.add_argument("--gt", type=Path, default=None,
                   help="also write ground truth frames (n, H, W, 3) float32 to this .npz")
    p.add_argument("--gt-exr", type=Path, default=None, help="also write ground-truth frames as EXR into this folder")
    p.add_argument("--gt-window", type=int, default=10,
                   help="ground-truth window W in planes (10 planes = 0.5 ms → 2000 FPS)")
    p.add_argument("--planes", type=int, default=None, help="number of planes (readouts); default: the scene's")
    p.add_argument("--seed", type=int, default=0, help="random seed of the noise effects")
    p.add_argument("--effects", default="scene",
                   help="'scene' (the scene's effects), 'none' (noise-free), or a list such as "
                        "'random_phase,dark_current:gamma=0.002,inherent_noise:mu=2000:sigma=200'; effects: "
                        "threshold_fpn(sigma), random_phase, hot_pixels(fraction,rate), "
                        "shot_noise(photons_per_threshold), dark_current(gamma), inherent_noise(mu,sigma,fraction)")
    p.add_argument("--chunk-planes", type=int, default=None,
                   help="planes per chunk (memory only; the output does not depend on it); default ≈16 M pixels")
    p.set_defaults(func=cmd_simulate)

    from spikeref.noise_check import DEFAULT_WINDOWS

    p = sub.add_parser("noise-check", help="Fig. 4a: noise ratio per Bayer channel against the window W",
                       description="On a static recording, accumulate windows of W planes (Eq. 4) and report "
                                   "the noise ratio I_c / E[I_c] - 1 per channel (R, G, B; the two G planes "
                                   "pooled): its mean absolute value and standard deviation over frames and "
                                   "pixels. E[I_c] is each pixel's rate over the whole span (the longest "
                                   "window). Pixels with fewer than 20 spikes in the span are left out.",
                       formatter_class=_DefaultsHelpFormatter)
    _add_input_options(p, optional_file=True)
    p.add_argument("--windows", type=_int_list, default=DEFAULT_WINDOWS,
                   help="window lengths W in planes, comma-separated (5 planes = 0.25 ms at 20 kHz)")
    p.add_argument("--start", type=int, default=0, help="first plane of the analysed span")
    p.add_argument("--planes", type=int, default=None, help="planes in the span (default: to the end)")
    p.add_argument("--min-rate", type=float, default=None,
                   help="leave out pixels below this rate, spikes/readout (default: 20 spikes in the span)")
    p.add_argument("--plot", type=Path, default=None, help="also write the curve as a PNG (needs spikeref[plot])")
    p.set_defaults(func=cmd_noise_check)

    p = sub.add_parser("calibrate", help="a hot-pixel map from a dark recording, for --hot-pixels MAP.npz",
                       description="Find the hot pixels of a sensor in a recording made with the lens covered (or "
                                   "of any static scene): pixels that fire far above their same-colour neighbours "
                                   "in every block of the stretch and alone (spikeref.hot_pixels). Writes a map "
                                   "that reconstruct and denoise apply with --hot-pixels MAP.npz.",
                       formatter_class=_DefaultsHelpFormatter)
    _add_input_options(p)
    p.add_argument("-o", "--output", type=Path, required=True, help="the map to write (.npz)")
    p.add_argument("--planes", type=int, default=20000,
                   help="readouts read from the start of the recording (at most; 20000 = 1 s at 20 kHz)")
    p.set_defaults(func=cmd_calibrate)

    p = sub.add_parser("golden", help="list the golden cases, check a port's outputs against them, export "
                                      "their inputs for a port without Python",
                       description="The golden vectors (golden/ in the repository: one .npz per equation with its "
                                   "inputs in_* and the oracle's outputs out_*, and manifest.json) are the acceptance "
                                   "test of a port. A port passes a case when every out_* array it computes from the "
                                   "in_* arrays is within |got - expected| <= atol + rtol*|expected| (the case's "
                                   "tolerance, in the arrays' own units). See golden/README.md.")
    p.set_defaults(func=cmd_golden, golden_parser=p)
    gsub = p.add_subparsers(dest="golden_command", metavar="ACTION")
    golden_help = ("the golden folder (default: golden/ beside the installed package's source, i.e. the "
                   "repository's; needed when the package was installed with pip install .)")
    g = gsub.add_parser("list", help="each case, its equation and its tolerance",
                        description="Print each golden case: its name, the paper's equation, its tolerance (rtol "
                                    "relative, atol absolute, in the arrays' units) and the out_* arrays a port "
                                    "must produce, from golden/manifest.json and the registry "
                                    "spikeref/oracles/golden_cases.py (a disagreement between them is noted).")
    g.add_argument("--golden", type=Path, default=None, metavar="DIR", help=golden_help)
    g.add_argument("-v", "--verbose", action="store_true",
                   help="also each case's inputs and outputs (shape and dtype), Python function, oracle, "
                        "description and specification")
    g = gsub.add_parser("check", help="compare a port's outputs with the golden ones; exit 1 on any failure",
                        description="Compare a port's outputs with the stored ones and print a pass/fail table with "
                                    "the worst error of every array: max |got - expected|, and where the element "
                                    "furthest outside atol + rtol*|expected| is, with both values. DIR holds, per "
                                    "case, either NAME.npz (the case's file name in manifest.json) with the out_* "
                                    "arrays under the same keys, or a folder NAME/ with out_KEY.npy, or out_KEY.bin "
                                    "(raw little-endian, C order) with its header out_KEY.json "
                                    '({"dtype": "float32", "shape": [2, 64, 64, 3]}). A copy of golden/ passes. '
                                    "Exit status 0 when every case passes, 1 when one fails or is missing, 2 when the "
                                    "command is refused.")
    g.add_argument("dir", type=Path, metavar="DIR", help="folder of the port's outputs")
    g.add_argument("--golden", type=Path, default=None, metavar="DIR", help=golden_help)
    g.add_argument("--cases", default=None,
                   help="comma-separated case names to check (default: every case; a case with no output fails)")
    g = gsub.add_parser("export", help="write every case's inputs as .npy or raw .bin files for a port",
                        description="Write every golden case's inputs into DIR/NAME/ (NAME: the case's file name "
                                    "without .npz) as in_KEY.npy (--format npy), or as raw little-endian C-order "
                                    "in_KEY.bin each with a JSON header in_KEY.json giving dtype (uint8, int64, "
                                    "float32, float64…) and shape (--format bin; for ports in C, CUDA or on an FPGA "
                                    "that have no NumPy). Also DIR/manifest.json (a copy) and DIR/NAME/case.json (the "
                                    "case's parameters, tolerance and the list of its array files). A port that writes "
                                    "its outputs beside them as out_KEY.npy or out_KEY.bin + out_KEY.json is checked "
                                    "with spikeref golden check DIR. Files of the same names are replaced.")
    g.add_argument("dir", type=Path, metavar="DIR", help="folder to write (made if missing)")
    g.add_argument("--format", choices=["npy", "bin"], default="npy",
                   help="npy (default): NumPy .npy files; bin: raw little-endian bytes with a JSON header each")
    g.add_argument("--with-outputs", action="store_true",
                   help="also write the expected out_* arrays (for a port whose own test compares them)")
    g.add_argument("--golden", type=Path, default=None, metavar="DIR", help=golden_help)

    debug_help = "on an error or an interruption, show the Python traceback (also: SPIKEREF_DEBUG=1)"
    parser.add_argument("--debug", action="store_true", help=debug_help)
    for p in [*sub.choices.values(), *gsub.choices.values()]:  # also after the command; the top level's value stands
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=debug_help)
    return parser


def _version() -> str:
    from spikeref import __version__

    return __version__


def main(argv=None) -> int:
    """Run ``spikeref`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status.

    0: done. 1: the run started and an OS error stopped it (a full disk, an unwritable folder);
    the frames already written are whole and ``--resume`` continues. 2: refused (a bad argument
    or input), before anything was written. 130: interrupted by SIGINT (Ctrl-C) or SIGTERM.
    Each failure is one line on stderr; ``--debug`` or ``SPIKEREF_DEBUG=1`` raises instead, with
    the traceback. Bad usage exits through ``SystemExit(2)`` (argparse), also with one line.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    args.argv = argv
    debug = bool(getattr(args, "debug", False)) or os.environ.get("SPIKEREF_DEBUG", "").strip() not in ("", "0")
    from spikeref.distributed import ChunkError  # no Dask import: the module loads it when a cluster is made

    with warnings.catch_warnings():
        warnings.showwarning = _one_line_notes(args.command, warnings.showwarning)
        try:
            with _sigterm_as_interrupt():
                status = args.func(args)
            if status == 0 and getattr(args, "compile_tag", None):
                from spikeref import _jit

                _jit.mark_warm(args.compile_tag)  # its kernels are cached now: the next run says nothing
            return status
        except Interrupted as exc:
            if debug:
                raise
            print(f"spikeref {args.command}: {exc}", file=sys.stderr)
            return exc.status
        except BrokenPipeError as exc:
            if not _stdout_closed():  # a pipe of our own (not the reader of our output) broke: an error
                if debug:
                    raise
                print(f"spikeref {args.command}: error: {exc}", file=sys.stderr)
                return 2
            # the reader of our output went away (`spikeref info | head -1`): nothing is wrong, say nothing
            with contextlib.suppress(OSError):
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
            return 0
        except KeyboardInterrupt as exc:
            if debug:
                raise
            print(f"spikeref {args.command}: interrupted ({_signal_name(exc)}); files already written are whole",
                  file=sys.stderr)
            return Interrupted.status
        except (CliError, ChunkError, ValueError, TypeError, FileNotFoundError, OSError, ImportError) as exc:
            if debug:
                raise
            print(f"spikeref {args.command}: error: {exc}", file=sys.stderr)
            return getattr(exc, "status", 2)


def _stdout_closed() -> bool:
    """Whether the reader of standard output has gone: a flush raises ``BrokenPipeError``, or (nothing left to
    flush) polling the pipe reports an error."""
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        return True
    except (OSError, ValueError):
        return False
    try:
        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(events & select.POLLERR for _, events in poll.poll(0))
    except (AttributeError, OSError, ValueError):  # no poll (Windows), or no real file behind stdout
        return False


def _one_line_notes(command: str, show):
    """A ``warnings.showwarning`` that prints spikeref's own ``UserWarning`` as ``spikeref CMD: note: …``.

    Such a warning is a note to the user (say, that small frames were aligned with a smaller
    pyramid), not a fault to trace; any other warning goes to ``show``.
    """
    package = Path(__file__).resolve().parent

    def show_note(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, UserWarning) and Path(filename).resolve().is_relative_to(package):
            print(f"spikeref {command}: note: {message}", file=sys.stderr if file is None else file)
        else:
            show(message, category, filename, lineno, file, line)

    return show_note


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
