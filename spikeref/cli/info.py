"""``spikeref info``: what a spike file holds, its firing rates per Bayer plane, its CFA phase and hot pixels."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

import numpy as np

from spikeref.cli.inputs import add_input_options, axes_said, cfa_source, check_cfa_phase, open_input

__all__ = ["INFO_SAMPLE_PLANES", "INFO_SAMPLE_BYTES", "INFO_SAMPLE_BLOCKS", "cmd_info", "add_parser"]


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
    source = "read from the data below" if auto else cfa_source(args, stream)
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
    if axes_said(stream, args):
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
            check_cfa_phase(stream, args, False, guess)  # a pattern the data contradict: one warning line
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
        "axes": args.axes if axes_said(stream, args) else None,
        "rate_hz": stream.rate_hz, "duration_ms": stream.duration_s * 1000,
        "frames": [avail.start, avail.stop], "frames_at": {"W": defaults.window, "K": defaults.K, "L": defaults.L},
        "statistics_planes": counted, "mean_rate": float(rates.mean()),
        "phase_rates": [float(r) for r in per_plane] if per_plane is not None else None,
    })
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref info`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("info", help="planes, size, duration and mean firing rate per Bayer plane",
                       description="Print what a spike file holds: planes, size, duration (at the readout "
                                   "rate), and the mean firing rate (spikes per readout, 0…1) per Bayer plane. "
                                   "The layout comes from the file size alone; the rates from a bounded sample "
                                   "of planes spread over the file, or from every plane with --stats; the CFA "
                                   "phase (which 2×2 sites are green, red, blue, or mono) from the same counts.")
    add_input_options(p, optional_file=True)
    p.add_argument("--stats", action="store_true",
                   help="count every plane (streamed, with a progress bar) instead of a sample of at most "
                        f"{INFO_SAMPLE_PLANES} planes / {INFO_SAMPLE_BYTES >> 20} MiB spread over the file")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object and nothing else on stdout: height, width, planes, cfa (as given or "
                        "from NAME.json; mono for none), cfa_detected (RGGB, BGGR, GRBG, GBRG or mono, read from the "
                        "counted planes), cfa_confidence (0-1), rate_hz, duration_ms, file, phase_rates, ...")
    p.set_defaults(func=cmd_info)
    return [p]
