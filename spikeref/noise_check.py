"""Fig. 4a on any static recording: the noise ratio ``I_c / E[I_c] − 1`` per channel against ``W``.

§4.1 of the paper argues that a short-window frame ``I_c`` (Eq. 4) scatters around its
expectation ``E[I_c] = L + E[N]/W`` with zero mean (Eq. 9), and Fig. 4a shows the noise
ratio ``I_c / E[I_c] − 1`` shrinking as the window ``W`` grows.  This module measures that
curve on a recording:

* ``I_c = count / W`` (Eq. 4 with ``M_c = 1``) for the consecutive, non-overlapping windows
  ``[start + kW, start + (k+1)W)`` that fit in the analysed span ``[start, start + planes)``;
* ``E[I_c]`` of each pixel is estimated by the longest window available, the span itself:
  ``total count / planes``;
* the ratio ``ρ = I_c / E[I_c] − 1`` is summarised per Bayer channel (R, G, B with the two G
  planes pooled; one ``mono`` channel without a colour filter array) over all frames and
  pixels: its mean, mean absolute value (the curve of Fig. 4a) and standard deviation.

The scene must be static over the span: motion or flicker shows up as a ratio that stops
falling with ``W``.  For a pixel firing as independent Bernoulli trials of probability ``p``
the spread falls as ``1/√W`` (``Var ρ = (1 − p)/(pW)``); an integrate-and-fire pixel under
constant light fires almost periodically, so its ratio is mostly quantisation and falls
closer to ``1/W``.

Every count is read with :func:`spikeref.accumulate.window_counts` (packed ``.dat`` streams
are counted from their bytes) a chunk of frames at a time, and only running float64 sums of
``ρ``, ``|ρ|`` and ``ρ²`` are kept, so memory stays bounded however long the recording.

A channel's statistics are averages over its pixels, and in the long-window rows (one or two
frames per pixel, tied together by the pixel's own ``E``) each pixel adds about one independent
value, so a row's mean ``|ρ|`` or standard deviation is known to a relative standard error of
about ``1/√n`` with ``n`` pixels.  A channel with fewer than :data:`MIN_PIXELS` (100: about
10 %) is flagged in :attr:`NoiseCheck.warnings`, the table and the plot.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from spikeref._jit import njit, prange
from spikeref.accumulate import window_counts
from spikeref.bayer import cfa_channel_map, validate_cfa
from spikeref.io.atomic import atomic_write
from spikeref.stream import SpikeStream, as_stream

__all__ = ["DEFAULT_WINDOWS", "DEFAULT_MIN_SPIKES", "MIN_PIXELS", "NoiseCheck", "noise_check", "plot_noise_check"]

#: Windows of Fig. 4a, in planes (0.25 ms … 0.5 s at 20 000 planes/s).
DEFAULT_WINDOWS = (5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000)

#: With ``min_rate=None`` a pixel needs this many spikes in the span to be used.
DEFAULT_MIN_SPIKES = 20

#: A channel resting on fewer pixels than this is flagged (:attr:`NoiseCheck.warnings`).  Its
#: statistics average per-pixel values; at long windows (one or two frames per pixel) each
#: pixel gives about one independent value, so a row's mean ``|ρ|`` or standard deviation has a
#: relative standard error of about ``1/√n`` over ``n`` pixels: 10 % at 100 pixels, 58 % at 3.
#: (Measured on random subsets of ``spikingsim_real_spike.npz``: 0.5/√n to 1.15/√n, the top at
#: W = 250 of its 500 planes.)
MIN_PIXELS = 100

#: Pixel-frames counted at once (memory bound: 16 MiB of uint8 counts, 64 MiB of uint32).
_CHUNK_ELEMENTS = 1 << 24

_CHANNEL_NAMES = ("R", "G", "B")


@dataclass(frozen=True)
class NoiseCheck:
    """Noise-ratio statistics of a static recording per window and channel (Fig. 4a).

    ``ρ = I_c / E[I_c] − 1`` with ``I_c = count / W`` (Eq. 4, ``M_c = 1``) and ``E[I_c]``
    the pixel's rate over the whole analysed span.

    Attributes
    ----------
    windows : tuple of int
        ``W`` values evaluated, increasing, in planes: the requested ones that fit in the span.
    channels : tuple of str
        ``("R", "G", "B")`` for a Bayer stream (the two G planes pooled), ``("mono",)`` otherwise.
    mean_ratio : ndarray ``(n_windows, n_channels)``
        Mean of ``ρ`` over frames and used pixels (≈ 0: the zero-mean claim of Eq. 9).  When
        ``W`` divides the span the frames tile the window that defines ``E``, so this is 0 up to
        rounding by construction; otherwise it compares the covered planes with the whole span.
    mean_abs_ratio : ndarray ``(n_windows, n_channels)``
        Mean of ``|ρ|``: the curve of Fig. 4a.
    std_ratio : ndarray ``(n_windows, n_channels)``
        Standard deviation of ``ρ`` over frames and used pixels (population: divided by the
        number of values).
    frames : ndarray ``(n_windows,)`` int64
        Windows averaged at each ``W``: ``planes // W``.
    expected_rate : ndarray ``(n_channels,)``
        Mean ``E[I_c]`` over the used pixels, spikes per readout (``[0, 1]``).
    pixels : ndarray ``(n_channels,)`` int64
        Pixels used per channel.  A channel with none has NaN statistics.
    planes : int
        Planes analysed (the span).
    skipped : tuple of int
        Requested ``W`` longer than the span (not evaluated).
    rate_hz : float
        Readout rate, to express ``W`` in milliseconds.
    min_rate : float
        Rate threshold that was applied (pixels below it, and pixels that never fire, left out).
    start : int
        First plane of the span.
    min_pixels : int
        A channel with fewer used pixels than this is listed in :attr:`too_few_pixels` and
        :attr:`warnings` (default :data:`MIN_PIXELS`).

    Notes
    -----
    ``E`` is estimated from the same planes as the frames, which removes one degree of freedom
    per pixel: for independent noise the variance of ``ρ`` is ``(1 − W/planes)`` times that of
    the true ratio, so rows with ``W`` close to the span understate the spread, and
    ``W = planes`` (one frame, the span itself) is exactly 0.
    """

    windows: tuple[int, ...]
    channels: tuple[str, ...]
    mean_ratio: np.ndarray
    mean_abs_ratio: np.ndarray
    std_ratio: np.ndarray
    frames: np.ndarray
    expected_rate: np.ndarray
    pixels: np.ndarray
    planes: int
    skipped: tuple[int, ...] = ()
    rate_hz: float = 20000.0
    min_rate: float = 0.0
    start: int = 0
    min_pixels: int = MIN_PIXELS

    def _few(self) -> list[tuple[str, int]]:
        """``(channel, pixels used)`` of each channel resting on fewer than ``min_pixels``."""
        return [(c, int(n)) for c, n in zip(self.channels, self.pixels, strict=True) if n < self.min_pixels]

    @property
    def too_few_pixels(self) -> tuple[str, ...]:
        """Channels resting on fewer than ``min_pixels`` used pixels (none at all included)."""
        return tuple(c for c, _ in self._few())

    @property
    def warnings(self) -> tuple[str, ...]:
        """One sentence per channel of :attr:`too_few_pixels`: why its figures are not to be trusted.

        With ``n`` pixels a row's mean ``|ρ|`` or standard deviation has a relative standard error
        of about ``1/√n`` (see :data:`MIN_PIXELS`); a channel with no pixel has NaN statistics.
        """
        out = []
        for c, n in self._few():
            if n == 0:
                out.append(f"channel {c} has no pixel at or above min_rate ({self.min_rate:.3g} spikes/readout): "
                           f"its statistics are NaN")
            else:
                out.append(f"channel {c} rests on {n} pixel{'s' if n != 1 else ''} (fewer than {self.min_pixels}): "
                           f"its mean |ratio| and std are uncertain by about {100 / math.sqrt(n):.0f} % (1/√{n}); "
                           f"analyse a longer span or lower min_rate for more pixels")
        return tuple(out)

    def table(self) -> str:
        """The result as a Markdown table (also readable as plain text).

        One row per evaluated ``W``: its length in planes and in milliseconds at ``rate_hz``,
        the number of frames, then for each channel the mean of ``ρ``, the mean of ``|ρ|`` and
        the standard deviation of ``ρ``.  Footnotes give the expectation per channel, the
        pixels used, and the windows skipped because they are longer than the span.  A channel
        with too few pixels (:attr:`too_few_pixels`) is marked in the pixels line and gets a
        ``warning:`` footnote (:attr:`warnings`).
        """
        head = ["W (planes)", "ms", "frames"]
        for c in self.channels:
            head += [f"{c} mean", f"{c} mean abs", f"{c} std"]
        lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
        for i, w in enumerate(self.windows):
            cells = [str(w), f"{w / self.rate_hz * 1000:g}", str(int(self.frames[i]))]
            for c in range(len(self.channels)):
                cells += [
                    f"{self.mean_ratio[i, c]:+.2e}",
                    f"{self.mean_abs_ratio[i, c]:.4g}",
                    f"{self.std_ratio[i, c]:.4g}",
                ]
            lines.append("| " + " | ".join(cells) + " |")
        rates = ", ".join(f"{c} {r:.4g}" for c, r in zip(self.channels, self.expected_rate, strict=True))
        few = set(self.too_few_pixels)
        used = ", ".join(f"{c} {int(n)}" + (" (too few)" if c in few else "")
                         for c, n in zip(self.channels, self.pixels, strict=True))
        lines.append("")
        lines.append(
            f"E[I_c] = rate over the {self.planes}-plane span [{self.start}, {self.start + self.planes}) "
            f"(spikes/readout): {rates}"
        )
        lines.append(f"pixels used (long-window rate >= {self.min_rate:.3g} and > 0): {used}")
        if self.planes in self.windows:
            lines.append(f"W = {self.planes} is the span itself: its ratio is 0 by construction")
        if self.skipped:
            listed = ", ".join(str(w) for w in self.skipped)
            lines.append(f"skipped (longer than the {self.planes}-plane span): W = {listed}")
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


@njit(parallel=True)
def _ratio_sums(counts, total, span, window, s1, sa, s2):
    # counts (n, H, W) uint; total (H, W) int64 span counts, 0 where the pixel is not used.
    # ρ = count/W / (total/span) − 1 = (count·span − W·total) / (W·total): the numerator is an
    # exact integer, so a frame equal to its expectation gives exactly 0.
    n, h, w = counts.shape
    for y in prange(h):
        for k in range(n):
            for x in range(w):
                t = total[y, x]
                if t > 0:
                    q = (np.int64(counts[k, y, x]) * span - window * t) / (window * t)
                    s1[y, x] += q
                    sa[y, x] += abs(q)
                    s2[y, x] += q * q


def _is_int(value) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _check_windows(windows) -> tuple[int, ...]:
    if _is_int(windows):
        windows = (windows,)
    try:
        values = list(windows)
    except TypeError:
        raise TypeError(f"windows must be an integer or a sequence of integers; got {windows!r}") from None
    if not values:
        raise ValueError("windows must list at least one window length")
    for w in values:
        if not _is_int(w):
            raise TypeError(f"windows must hold integers (planes); got {w!r}")
        if w < 1:
            raise ValueError(f"windows must be a positive number of planes each; got {w}")
    return tuple(sorted({int(w) for w in values}))


def _check_span(stream: SpikeStream, start, planes) -> tuple[int, int]:
    total = len(stream)
    if total < 1:
        raise ValueError("the stream has no planes")
    if not _is_int(start):
        raise TypeError(f"start must be an integer plane index; got {start!r}")
    if not 0 <= start < total:
        raise ValueError(f"start must lie in [0, {total}) (the stream has {total} planes); got {start}")
    if planes is None:
        return int(start), total - int(start)
    if not _is_int(planes):
        raise TypeError(f"planes must be an integer number of planes or None; got {planes!r}")
    if planes < 1:
        raise ValueError(f"planes must be at least 1; got {planes}")
    if start + planes > total:
        raise ValueError(
            f"planes: the span [{start}, {start + planes}) runs past the end of the stream ({total} planes)"
        )
    return int(start), int(planes)


def _check_min_rate(min_rate, span: int) -> float:
    if min_rate is None:
        return DEFAULT_MIN_SPIKES / span
    if not isinstance(min_rate, numbers.Real) or isinstance(min_rate, bool):
        raise TypeError(f"min_rate must be a number (spikes per readout) or None; got {min_rate!r}")
    if not math.isfinite(min_rate) or min_rate < 0:
        raise ValueError(f"min_rate must be a finite, non-negative rate in spikes per readout; got {min_rate!r}")
    return float(min_rate)


def noise_check(
    spikes,
    windows=DEFAULT_WINDOWS,
    cfa: str | None = None,
    start: int = 0,
    planes: int | None = None,
    min_rate: float | None = None,
    progress: bool = False,
    min_pixels: int = MIN_PIXELS,
) -> NoiseCheck:
    """Noise ratio ``I_c / E[I_c] − 1`` of a static recording per channel and window (Fig. 4a).

    Checks the zero-mean noise of §4.1 (Eq. 9): frames of ``W`` planes, ``I_c = count / W``
    (Eq. 4, ``M_c = 1``), against each pixel's expectation estimated by the longest window
    available.

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
        A static recording.  A packed (memory-mapped ``.dat``) stream is counted from its
        bytes, a chunk of frames at a time; it is never unpacked whole.
    windows : int or sequence of int
        ``W`` values in planes (each ≥ 1); evaluated in increasing order, duplicates dropped.
        Frame ``k`` at window ``W`` covers planes ``[start + kW, start + (k+1)W)``; the
        ``planes // W`` whole windows inside the span are used.  A ``W`` longer than the span
        is skipped and listed in :attr:`NoiseCheck.skipped` (and in the table).
    cfa : str, optional
        Bayer pattern of the upright image (``RGGB``, ``BGGR``, ``GRBG``, ``GBRG``).  Default:
        the stream's; with neither, one ``mono`` channel.  Height and width must be even.
    start : int
        First plane of the analysed span.
    planes : int, optional
        Planes in the span (default: to the end of the stream).  The expectation ``E[I_c]`` is
        the rate over this same span: ``total count / planes``.
    min_rate : float, optional
        Pixels whose span rate is below this (spikes per readout), and pixels that never fire,
        are left out: ``I/E`` divides by ``E`` and a pixel near ``E = 0`` only adds its own
        estimation error.  Default ``DEFAULT_MIN_SPIKES / planes``, i.e. at least 20 spikes
        in the span, so each pixel's expectation is known to about ``1/√20 ≈ 22 %`` (one
        standard error for Poisson firing) or better.
    progress : bool
        Show a tqdm progress bar over the windows.
    min_pixels : int
        A channel with fewer used pixels is flagged in :attr:`NoiseCheck.warnings` (its
        statistics have a relative standard error of about ``1/√n``; see :data:`MIN_PIXELS`).
        It only flags: the statistics are computed all the same.

    Returns
    -------
    NoiseCheck
        Mean, mean absolute value and standard deviation of the ratio over frames and used
        pixels, computed exactly from float64 running sums of ``ρ``, ``|ρ|`` and ``ρ²``.

    Raises
    ------
    TypeError, ValueError
        For a bad argument (the message names it), odd image sides with a Bayer pattern, every
        window longer than the span, or no pixel reaching ``min_rate``.

    Notes
    -----
    ``ρ = count·planes / (W·total) − 1`` is formed from exact integers, so a frame whose count
    equals its expectation (e.g. a pixel firing every ``k`` readouts and ``W`` a multiple of
    ``k`` dividing the span) gives exactly 0.  When ``W`` divides the span the mean ratio is 0
    by construction (the frames add up to the expectation's window); see
    :class:`NoiseCheck` for the ``(1 − W/planes)`` shrink of the variance.
    """
    if not isinstance(spikes, (SpikeStream, np.ndarray)):
        raise TypeError(f"spikes must be a SpikeStream or a (T, H, W) uint8 array; got {type(spikes).__name__}")
    stream = as_stream(spikes)
    if cfa is None:
        cfa = stream.cfa
    elif not isinstance(cfa, str):
        raise TypeError(f"cfa must be a Bayer pattern string such as 'RGGB' or None; got {cfa!r}")
    if cfa is not None:
        cfa = validate_cfa(cfa)
    windows = _check_windows(windows)
    start, span = _check_span(stream, start, planes)
    min_rate = _check_min_rate(min_rate, span)
    if not isinstance(progress, (bool, np.bool_)):
        raise TypeError(f"progress must be True or False; got {progress!r}")
    if not _is_int(min_pixels):
        raise TypeError(f"min_pixels must be an integer number of pixels; got {min_pixels!r}")
    if min_pixels < 0:
        raise ValueError(f"min_pixels must be ≥ 0; got {min_pixels}")
    h, w = stream.height, stream.width
    if cfa is not None:
        if h % 2 or w % 2:
            raise ValueError(f"cfa={cfa!r} needs an even height and width; the stream is {h}×{w}")
        channel = cfa_channel_map(h, w, cfa).astype(np.intp).ravel()
        names = _CHANNEL_NAMES
    else:
        channel = np.zeros(h * w, dtype=np.intp)
        names = ("mono",)
    todo = tuple(x for x in windows if x <= span)
    skipped = tuple(x for x in windows if x > span)
    if not todo:
        raise ValueError(
            f"windows: every window ({', '.join(map(str, windows))}) is longer than the {span}-plane span"
        )

    # E[I_c]: the longest window available, the span itself.
    total = window_counts(stream, span, start=start, count=1)[0].astype(np.int64)
    used = (total > 0) & (total / span >= min_rate)
    if not used.any():
        raise ValueError(
            f"min_rate: no pixel reaches {min_rate:.3g} spikes/readout over the {span}-plane span "
            f"(the brightest has {int(total.max())} spikes); lower min_rate or analyse a longer span"
        )
    total_used = np.where(used, total, 0)
    flat_used = used.ravel()
    nch = len(names)
    pixels = np.bincount(channel[flat_used], minlength=nch).astype(np.int64)
    with np.errstate(invalid="ignore", divide="ignore"):
        expected_rate = np.bincount(channel[flat_used], weights=total.ravel()[flat_used], minlength=nch) / (
            pixels * float(span)
        )
    expected_rate[pixels == 0] = np.nan

    shape = (len(todo), nch)
    mean, mean_abs, std = np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan)
    frames = np.zeros(len(todo), dtype=np.int64)
    per_chunk = max(1, _CHUNK_ELEMENTS // (h * w))
    s1, sa, s2 = (np.zeros((h, w)) for _ in range(3))
    for i, win in enumerate(tqdm(todo, desc="noise check", unit="W", disable=not progress)):
        n = span // win
        frames[i] = n
        s1[:], sa[:], s2[:] = 0.0, 0.0, 0.0
        buf = None
        for k0 in range(0, n, per_chunk):
            c = min(per_chunk, n - k0)
            if buf is None:
                counts = window_counts(stream, win, start=start + k0 * win, count=c)
                buf = counts
            else:
                counts = window_counts(stream, win, start=start + k0 * win, count=c, out=buf[:c])
            _ratio_sums(counts, total_used, span, win, s1, sa, s2)
        with np.errstate(invalid="ignore", divide="ignore"):
            values = (pixels * n).astype(np.float64)
            m1 = np.bincount(channel[flat_used], weights=s1.ravel()[flat_used], minlength=nch) / values
            ma = np.bincount(channel[flat_used], weights=sa.ravel()[flat_used], minlength=nch) / values
            m2 = np.bincount(channel[flat_used], weights=s2.ravel()[flat_used], minlength=nch) / values
        mean[i], mean_abs[i] = m1, ma
        std[i] = np.sqrt(np.maximum(m2 - m1 * m1, 0.0))
    return NoiseCheck(
        windows=todo, channels=names, mean_ratio=mean, mean_abs_ratio=mean_abs, std_ratio=std, frames=frames,
        expected_rate=expected_rate, pixels=pixels, planes=span, skipped=skipped, rate_hz=float(stream.rate_hz),
        min_rate=min_rate, start=start, min_pixels=int(min_pixels),
    )


_COLORS = {"R": "tab:red", "G": "tab:green", "B": "tab:blue", "mono": "black"}


def plot_noise_check(result: NoiseCheck, path) -> Path:
    """Draw Fig. 4a from a :class:`NoiseCheck` and write it as a PNG, atomically.

    The x axis is the window ``W`` in planes (log scale); per channel (R red, G green, B blue,
    mono black) a solid line gives the mean ``|I_c / E[I_c] − 1|`` and a dashed line the mean
    ratio, which should lie on the grey zero line (Eq. 9).  A channel with too few pixels
    (:attr:`NoiseCheck.too_few_pixels`) says so in its legend entries and in the title.

    Parameters
    ----------
    result : NoiseCheck
    path : str or Path
        PNG file to write; its folder must exist.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ImportError
        When matplotlib is not installed (``pip install spikeref[plot]``).
    """
    if not isinstance(result, NoiseCheck):
        raise TypeError(f"result must be a NoiseCheck; got {type(result).__name__}")
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise ImportError("plot_noise_check needs matplotlib: pip install 'spikeref[plot]'") from None

    fig = Figure(figsize=(6.4, 4.2), dpi=120)
    ax = fig.add_subplot()
    x = np.asarray(result.windows)
    ax.axhline(0.0, color="0.6", linewidth=0.8)
    few = dict(result._few())  # channel: pixels used, of the channels on too few (NoiseCheck.too_few_pixels)
    for c, name in enumerate(result.channels):
        color = _COLORS[name]
        tag = f"{name} (only {few[name]} px)" if name in few else name
        ax.plot(x, result.mean_abs_ratio[:, c], "o-", color=color, label=f"{tag}: mean |I/E − 1|")
        ax.plot(x, result.mean_ratio[:, c], "--", color=color, alpha=0.7, label=f"{tag}: mean I/E − 1")
    ax.set_xscale("log")
    ax.set_xlabel(f"window W (planes; {1000 / result.rate_hz:g} ms each)")
    ax.set_ylabel("noise ratio I_c / E[I_c] − 1")
    title = f"Fig. 4a noise check: E over {result.planes} planes"
    if few:
        listed = ", ".join(f"{c} {n}" for c, n in few.items())
        title += f"\nwarning: too few pixels (< {result.min_pixels}): {listed}"
    ax.set_title(title, **({"color": "tab:red", "fontsize": 10} if few else {}))
    ax.legend(fontsize=7, ncol=max(1, len(result.channels)))
    fig.tight_layout()
    return atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png"))


from spikeref._callable import make_module_callable  # noqa: E402

make_module_callable(__name__, "noise_check")  # `sr.noise_check(...)` works whichever import came first
