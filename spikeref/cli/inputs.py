"""The input of the commands that read a spike file: its options, opening it, its CFA checked against the
data, and the hot pixels to replace in it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spikeref.cli.arguments import check_float, check_int
from spikeref.cli.errors import CliError

__all__ = ["SAMPLE", "add_input_options", "add_hot_pixel_option", "check_input_options", "open_input", "cfa_source",
           "check_cfa_phase", "axes_said", "calibration_map_path", "calibration_map", "hot_pixel_option",
           "hot_pixel_map", "say_hot_pixels"]

SAMPLE = Path(__file__).resolve().parents[1] / "data" / "sample.dat"


def add_input_options(p: argparse.ArgumentParser, optional_file: bool = False) -> None:
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


def add_hot_pixel_option(p: argparse.ArgumentParser, command: str) -> None:
    p.add_argument("--hot-pixels", default=None, metavar="auto|off|MAP.npz",
                   help="pixels that fire far above their light at the same place in every window: auto ("
                        f"{'the default but with --paper' if command == 'reconstruct' else 'default'}: found in the "
                        "recording's first "
                        "2000 planes and replaced in every window by the mean of their same-colour neighbours, "
                        "before the denoiser and the alignment; not in the paper; spikeref.hot_pixels), off, or a "
                        "map made from a dark recording by spikeref calibrate")


def check_input_options(args) -> None:
    """The numeric input options: a given 0 is refused, never read as "not given" (then from NAME.json)."""
    for name, flag in (("height", "--height"), ("width", "--width"), ("file_width", "--file-width")):
        check_int(getattr(args, name, None), flag, 1, "a positive number of pixels")
    check_float(getattr(args, "rate_hz", None), "--rate-hz")


def open_input(args, *, check_cfa: bool = True):
    """Open the stream named by the parsed input options (sizes from the NAME.json sidecar if not given).

    ``--cfa auto`` reads the pattern from the data; a given (or the sidecar's) pattern that the data contradict
    gets one warning line (:func:`check_cfa_phase`).  ``check_cfa=False`` leaves both to the caller (``info``, which
    decides from the counts it makes anyway); ``--cfa auto`` then opens the stream as mono.
    """
    from spikeref.bayer import CFA_PATTERNS, validate_cfa
    from spikeref.io.dat import sidecar_path
    from spikeref.stream import open_spike_file

    check_input_options(args)
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
        check_cfa_phase(stream, args, auto)
    if path.suffix.lower() == ".dat" and (args.height is None or args.width is None) \
            and not sidecar_path(path).is_file():
        print(f"note: {path.name} has no {sidecar_path(path).name} beside it: read as "
              f"{stream.height}×{stream.width} {stream.cfa or 'mono'} (give --height/--width/--cfa if it is not)",
              file=sys.stderr)
    return stream


def cfa_source(args, stream) -> str:
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
    given = f"--cfa {stream.cfa}" if args.cfa is not None else f"the cfa {stream.cfa} {cfa_source(args, stream)}"
    from spikeref.cfa_detect import green_diagonal

    return (f"warning: {given} puts green at {where[green_diagonal(stream.cfa)]}, the spikes at "
            f"{where[guess.green_diagonal]} ({confident}); going on with {stream.cfa} (--cfa auto uses the data's)")


def check_cfa_phase(stream, args, auto: bool, guess=None):
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


def axes_said(stream, args) -> str:
    """How an array file's axes were read, for the lines that give its size ("" for a .dat)."""
    if stream.path is None or Path(stream.path).suffix.lower() not in (".npy", ".npz"):
        return ""
    return " (planes first, --axes THW)" if args.axes == "THW" else " (stored planes-last, --axes HWT)"


def calibration_map_path(value, option: str, what: str) -> Path:
    """A ``spikeref calibrate`` map given to ``option``: its path, the suffix and the file checked before any work
    (``what``: what the option must be, for the message)."""
    path = Path(value)
    if path.suffix.lower() != ".npz":
        raise CliError(f"{option} must be {what}; got {value!r}")
    if not path.is_file():
        raise CliError(f"{option} {value}: no such file (make one with spikeref calibrate DARK -o {value})")
    return path


def calibration_map(load, path, stream, option: str):
    """``load(path, (H, W))`` of the map given to ``option`` for ``stream`` (its size checked), or None without
    one; the loader's ``ValueError`` or ``TypeError`` (a value of the wrong kind in the map) as a one-line error
    naming the option."""
    if path is None:
        return None
    try:
        return load(path, (stream.height, stream.width))
    except (ValueError, TypeError) as exc:
        raise CliError(f"{option} {exc}") from None


def hot_pixel_option(value):
    """``--hot-pixels``: ``auto``/``off`` (None returned) or a map file (its path, checked to exist)."""
    if value is None or value in ("auto", "off"):
        return None
    return calibration_map_path(value, "--hot-pixels", "auto, off or a map .npz (spikeref calibrate)")


def hot_pixel_map(path, stream):
    """The map of ``--hot-pixels MAP.npz`` for ``stream`` (its size checked), or None."""
    from spikeref.hot_pixels import load_hot_pixel_map

    return calibration_map(load_hot_pixel_map, path, stream, "--hot-pixels")


def say_hot_pixels(mask, source) -> None:
    """One line when hot pixels are replaced: how many and from where."""
    if mask is not None and mask.any():
        where = f"from {source}" if source is not None else "found in the recording (--hot-pixels off keeps them)"
        print(f"hot pixels: {int(mask.sum())} replaced by their same-colour neighbours in every window, {where}",
              file=sys.stderr)
