"""Fig. 4a on any static recording: the noise ratio ``I_c / E[I_c] − 1`` per channel against ``W``.

The paper (§4.1) checks that short-window frames are zero-mean around their expectation
(Eq. 9: ``E[I_c] = L + E[N]/W``) and that the spread falls as the window grows.  Here
``I_c = count / W`` (Eq. 4, ``M_c = 1``) over consecutive windows ``[start + kW,
start + (k+1)W)`` and the expectation ``E[I_c]`` of each pixel is estimated by the longest
window available: the whole analysed span (``total count / planes``).  The scene must be
static over the span; motion shows up as a ratio that does not fall with ``W``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spikeref.accumulate import window_counts
from spikeref.bayer import cfa_channel_map
from spikeref.stream import as_stream

__all__ = ["DEFAULT_WINDOWS", "NoiseCheck", "noise_check", "plot_noise_check"]

#: Windows of Fig. 4a, in planes (0.25 ms … 0.5 s at 20 kHz).
DEFAULT_WINDOWS = (5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000)

#: Pixel budget of one chunk of frames (memory bound).
_CHUNK_ELEMENTS = 1 << 23


@dataclass(frozen=True)
class NoiseCheck:
    """Noise-ratio statistics per window and channel (Fig. 4a).

    Attributes
    ----------
    windows : tuple of int
        ``W`` values evaluated, in planes (those ≤ the span).
    skipped : tuple of int
        Requested ``W`` that give fewer than two frames in the span.
    channels : tuple of str
        ``("R", "G", "B")`` for a Bayer stream (both G planes pooled), ``("mono",)`` otherwise.
    mean_ratio : ndarray ``(n_windows, n_channels)``
        Mean of ``I/E − 1`` over frames and pixels.  Zero by construction when ``W`` divides
        the span (the frames tile the window that defines ``E``); it is kept for spans that
        ``W`` does not divide, not as evidence.
    mean_abs_ratio : ndarray ``(n_windows, n_channels)``
        Mean of ``|I/E − 1|``: the curve of Fig. 4a.
    std_ratio : ndarray ``(n_windows, n_channels)``
        Standard deviation of ``I/E − 1`` (population, over frames and pixels).
    frames : ndarray ``(n_windows,)``
        Windows averaged at each ``W``.
    expected_rate : ndarray ``(n_channels,)``
        Mean ``E[I_c]`` over the pixels used, spikes per readout.
    pixels : ndarray ``(n_channels,)``
        Pixels used per channel.
    planes : int
        Planes analysed.
    rate_hz : float
        Readout rate (to express ``W`` in milliseconds).
    """

    windows: tuple
    skipped: tuple
    channels: tuple
    mean_ratio: np.ndarray
    mean_abs_ratio: np.ndarray
    std_ratio: np.ndarray
    frames: np.ndarray
    expected_rate: np.ndarray
    pixels: np.ndarray
    planes: int
    rate_hz: float = 20000.0

    def table(self) -> str:
        """A Markdown table: ``W``, its duration, frames, and per channel mean ``|I/E − 1|`` and its std."""
        head = "| W (planes) | ms | frames | " + " | ".join(
            f"{c} mean abs | {c} std" for c in self.channels) + " |"
        rule = "|" + " --- |" * (3 + 2 * len(self.channels))
        lines = [head, rule]
        for i, w in enumerate(self.windows):
            cells = []
            for c in range(len(self.channels)):
                cells += [f"{self.mean_abs_ratio[i, c]:.4f}", f"{self.std_ratio[i, c]:.4f}"]
            lines.append(f"| {w} | {w / self.rate_hz * 1000:g} | {int(self.frames[i])} | " + " | ".join(cells) + " |")
        rates = ", ".join(f"{c} {r:.4f}" for c, r in zip(self.channels, self.expected_rate, strict=True))
        used = ", ".join(f"{c} {int(n)}" for c, n in zip(self.channels, self.pixels, strict=True))
        lines.append("")
        lines.append(f"expectation: the {self.planes}-plane mean; E[I_c] (spikes/readout): {rates}; pixels: {used}")
        if self.skipped:
            lines.append(f"skipped (fewer than 2 windows in the span): W = {', '.join(str(w) for w in self.skipped)}")
        return "\n".join(lines)


def _positive_int(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be a positive integer; got {value!r}")
    return int(value)


def noise_check(spikes, windows=DEFAULT_WINDOWS, cfa: str | None = None, start: int = 0, planes: int | None = None,
                min_rate: float | None = None, progress: bool = False) -> NoiseCheck:
    """Noise ratio ``I_c / E[I_c] − 1`` of a static recording per channel and window (Fig. 4a, Eq. 4, Eq. 9).

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W) uint8``
        A packed ``.dat`` stream is counted from its bytes (memory bounded by chunks).
    windows : sequence of int
        ``W`` values in planes; those that give fewer than two frames in the span are skipped
        (and listed): with one frame the ratio is zero by construction.
    cfa : str, optional
        Bayer pattern (default: the stream's; ``None`` and no stream CFA → one ``mono`` channel).
    start, planes : int
        The analysed span ``[start, start + planes)`` (default: to the end).
    min_rate : float, optional
        Pixels whose expectation is below this rate (spikes per readout) are left out, since
        ``I/E`` is meaningless near ``E = 0``.  Default ``20 / planes``: at least 20 spikes in
        the span, so the expectation itself is known to about ±22 %.
    progress : bool
        Show a progress bar over windows.

    Returns
    -------
    NoiseCheck
    """
    stream = as_stream(spikes, cfa=cfa) if not hasattr(spikes, "window") else spikes
    cfa = cfa if cfa is not None else stream.cfa
    if isinstance(windows, (int, np.integer)):
        windows = (windows,)
    windows = tuple(_positive_int("windows", w) for w in windows)
    if not windows:
        raise ValueError("windows must list at least one window length")
    if isinstance(start, bool) or not isinstance(start, (int, np.integer)) or not 0 <= start < len(stream):
        raise ValueError(f"start must lie in [0, {len(stream)}); got {start!r}")
    span = len(stream) - start if planes is None else _positive_int("planes", planes)
    if start + span > len(stream):
        raise ValueError(f"planes: the span [{start}, {start + span}) runs past the stream's {len(stream)} planes")
    if min_rate is None:
        min_rate = 20.0 / span
    if not (isinstance(min_rate, (int, float, np.floating)) and math.isfinite(min_rate) and min_rate >= 0):
        raise ValueError(f"min_rate must be a non-negative number; got {min_rate!r}")
    h, w = stream.height, stream.width
    if cfa is not None:
        channel = cfa_channel_map(h, w, cfa).astype(np.int64).ravel()
        names = ("R", "G", "B")
    else:
        channel = np.zeros(h * w, dtype=np.int64)
        names = ("mono",)
    nch = len(names)
    total = window_counts(stream, span, start=start, count=1)[0].astype(np.float64).ravel()
    expected = total / span
    used = np.flatnonzero((expected >= min_rate) & (expected > 0))
    ch_used = channel[used]
    pix = np.bincount(ch_used, minlength=nch).astype(np.int64)
    exp_rate = np.bincount(ch_used, weights=expected[used], minlength=nch) / np.maximum(pix, 1)

    todo = tuple(wn for wn in windows if 2 * wn <= span)
    skipped = tuple(wn for wn in windows if 2 * wn > span)
    mean = np.full((len(todo), nch), np.nan)
    mean_abs = np.full((len(todo), nch), np.nan)
    std = np.full((len(todo), nch), np.nan)
    frames = np.zeros(len(todo), dtype=np.int64)
    from tqdm import tqdm

    inv = 1.0 / expected[used]
    for i, wn in enumerate(tqdm(todo, desc="noise check", unit="window", disable=not progress, leave=False)):
        n = span // wn
        frames[i] = n
        s1 = np.zeros(nch)
        sa = np.zeros(nch)
        s2 = np.zeros(nch)
        step = max(1, _CHUNK_ELEMENTS // (h * w))
        for k in range(0, n, step):
            c = min(step, n - k)
            counts = window_counts(stream, wn, start=start + k * wn, count=c).reshape(c, -1)[:, used]
            ratio = counts * (inv / wn) - 1.0
            s1 += np.bincount(ch_used, weights=ratio.sum(axis=0), minlength=nch)
            sa += np.bincount(ch_used, weights=np.abs(ratio).sum(axis=0), minlength=nch)
            s2 += np.bincount(ch_used, weights=(ratio * ratio).sum(axis=0), minlength=nch)
        denom = np.where(pix > 0, n * pix, np.nan)
        mean[i] = s1 / denom
        mean_abs[i] = sa / denom
        std[i] = np.sqrt(np.maximum(s2 / denom - mean[i] ** 2, 0.0))
    return NoiseCheck(windows=todo, skipped=skipped, channels=names, mean_ratio=mean, mean_abs_ratio=mean_abs,
                      std_ratio=std, frames=frames, expected_rate=exp_rate, pixels=pix, planes=int(span),
                      rate_hz=float(getattr(stream, "rate_hz", 20000.0)))


def plot_noise_check(result: NoiseCheck, path) -> Path:
    """Fig. 4a as a PNG: mean ``|I/E − 1|`` and its std against ``W`` (log axes), per channel."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ImportError("the noise-check plot needs matplotlib: pip install 'spikeref[plot]'") from None
    from spikeref.io.atomic import atomic_write

    colors = {"R": "tab:red", "G": "tab:green", "B": "tab:blue", "mono": "black"}
    fig, ax = plt.subplots(figsize=(6, 4), dpi=120)
    w = np.asarray(result.windows)
    for c, name in enumerate(result.channels):
        ax.plot(w, result.mean_abs_ratio[:, c], "o-", color=colors[name], label=f"{name}: mean |I/E − 1|")
        ax.plot(w, result.std_ratio[:, c], "x--", color=colors[name], alpha=0.6, label=f"{name}: std")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("window W (planes)")
    ax.set_ylabel("noise ratio I_c / E[I_c] − 1")
    ax.set_title(f"noise check (Fig. 4a): expectation over {result.planes} planes")
    ax.legend(fontsize=7)
    fig.tight_layout()
    path = Path(path)

    def _write(tmp):
        fig.savefig(tmp, format="png")

    try:
        atomic_write(path, _write)
    finally:
        plt.close(fig)
    return path
