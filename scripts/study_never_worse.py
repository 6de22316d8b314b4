"""Never worse than plain accumulation, by every path: the denoiser's gain over the identity per window.

Three ways a user reaches the guarded denoiser (``spikeref.denoise.guard``), each scored against the same
plain accumulation of the same planes (the *identity*), as a gain in dB:

* ``api``: the README's call, ``sr.Denoiser.load()(sr.bayer_planes(rates), mode="visible", window=W)`` on
  Eq. 4 rates (the bundled count network, its guard on, nothing else passed); identity: the rates;
* ``cli``: what ``spikeref denoise -W W`` runs (``Denoiser.frames`` of the stream with the hot pixels it
  finds, ``spikeref.hot_pixels.find_hot_pixels``, replaced); identity: the same windows' rates, repaired
  the same way;
* ``pipeline``: ``spikeref.pipeline.Reconstructor`` with ``ReconstructParams(window=W)`` (K = L = 3, the
  defaults: window charges and the charge network, ``--accumulate count`` adds the count path); identity:
  the same settings with ``denoise=False``.

``--former`` adds the same paths with the guard as it was before 2026-11-27 (the plane's own σ when no
short window is given; the whole carried excess when one is), emulated in :func:`former_denoiser`;
``--proposed`` the pipeline on charges with the output guard's floor at the support (:func:`proposed_denoiser`;
proposed, then made on 2026-11-27: the current pipeline gives the same).

Recordings and scoring (one scoring throughout: ``spikeref.metrics.psnr_after_gain``, one least-squares gain
for the whole image — per channel for colour — data range the truth's peak, an 8-pixel border left out):

* ``spikingsim``: the real outdoor recording ``../shared/data/real/spikingsim_real_spike.npz`` (500 planes,
  monochrome, near static); pseudo ground truth the mean of planes 300–500 with the recording's 4 hot pixels
  repaired (``HotPixelRepair(find_hot_pixels(spikes))``, as ``tests/test_pipeline.py``); windows ``k·W`` from
  plane 0 that end by plane 300 (at most 6), disjoint from the truth; W = 500 is the one window of the whole
  recording, which *contains* the truth's planes (marked ``overlap``: its shared noise favours the identity).
  Pipeline at W = 50: its one frame (3) needs planes 0–350 and is scored against the mean of planes 350–500.
* ``uhsr``: Spike-Zoo's real low-light recording ``spikezoo_uhsr.npz`` (200 planes, 250×250, monochrome; the
  bundled count network saw it, unlabeled, in training); windows from the first half, truth the mean of the
  second half (planes 100–200; no hot pixel found); W ≥ 200 has no disjoint truth and is not scored.
  Pipeline: W = 5, 10 frames inside planes 0–100; W = 20 frame 3 (planes 0–140) against the mean of
  planes 140–200; W = 50 needs 350 planes and is not scored.
* ``heldout``: the held-out simulated scenes of ``scripts/eval_guard.py --set heldout`` (the four
  ``scripts/heldout_scenes/*.toml``, seed 11, and the four ``scripts/denoiser_scenes/heldout_*.toml``,
  seed 8), windows at planes 300 and 420 (where they fit), Ψ then scored against the exact ground truth of
  the window; ``api`` and ``cli`` only.  Gains are per scene (mean of the windows); the table gives the mean
  and the worst scene.

    python scripts/study_never_worse.py [--sets spikingsim,uhsr,heldout] [--paths api,cli,pipeline]
        [--windows 5,10,20,50,100,200,500] [--accumulate charge,count] [--former] [--proposed] [--json OUT.json]
    python scripts/study_never_worse.py --fixed-pattern
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REAL = ROOT.parent / "shared" / "data" / "real"
BORDER = 8
WINDOWS = (5, 10, 20, 50, 100, 200, 500)
MAX_WINDOWS = 6  # windows (or pipeline frames) scored per recording and W
HELDOUT_STARTS = (300, 420)
#: recording: (file, key, planes-last, truth planes, windows end by)
RECORDINGS = {"spikingsim": ("spikingsim_real_spike.npz", "arr_0", True, (300, 500), 300),
              "uhsr": ("spikezoo_uhsr.npz", "spk", False, (100, 200), 100)}
#: recordings also scored on one window of all their planes, which contains the truth's (the issue's W = 500)
WHOLE = ("spikingsim",)


def score(truth: np.ndarray, image: np.ndarray) -> float:
    from spikeref.metrics import psnr_after_gain

    crop = (slice(BORDER, -BORDER), slice(BORDER, -BORDER))
    t = np.asarray(truth, np.float64)[crop]
    return psnr_after_gain(t, np.asarray(image, np.float64)[crop], float(t.max()), per_channel=t.ndim == 3)


def former_denoiser(path=None):
    """The bundled (or named) network with the guard as it was before 2026-11-27 (:class:`FormerDenoiser`)."""
    from spikeref.denoise.denoiser import Denoiser

    class FormerDenoiser(Denoiser):
        """The guard before 2026-11-27: without ``short`` the plane's own σ at every window; with it, the whole
        excess the short window measures (``carried_excess_variance``, not ``CARRY_FRACTION`` of it), whatever
        the two windows' lengths."""

        def __call__(self, planes, mode=None, window=None, guard=None, short=None, short_window=None,
                     accumulate="count"):
            from spikeref.denoise.guard import carried_excess_variance, sure_blend

            if (self.guard if guard is None else guard) != "sure":
                return super().__call__(planes, mode, window, guard="off", accumulate=accumulate)
            plain = copy.copy(self)  # the network alone: no guard, no shrinkage
            plain.guard, plain.shrink = "off", False
            carried = None if short is None else carried_excess_variance(short, short_window, window, accumulate)
            return sure_blend(np.asarray(planes), lambda z: plain(z, mode, window=window), self.guard_radius,
                              window=window, carried=carried, accumulate=accumulate)[0]

    return FormerDenoiser.load(path)


def proposed_denoiser(path, K: int = 3, L: int = 3):
    """The bundled (or named) network as the pipeline would call it with the change proposed on 2026-11-27 (since
    made in ``spikeref/pipeline.py``, which now passes the same ``floor_window``: kept to reproduce the study's
    table): on window charges, the output's guard takes its floor at the support,
    ``floor_window = ((K − 1)L + 1)·W``, since a merge of consecutive charges shares their inner edges.  ``W`` is
    read from ``short_window``, which the pipeline sets to its window for the output's guard."""
    from spikeref.denoise.denoiser import Denoiser

    class ProposedDenoiser(Denoiser):
        def __call__(self, planes, mode=None, window=None, guard=None, short=None, short_window=None,
                     accumulate="count", floor_window=None):
            if accumulate == "charge" and short_window is not None and floor_window is None:
                floor_window = ((K - 1) * L + 1) * short_window
            return super().__call__(planes, mode, window, guard, short, short_window, accumulate, floor_window)

    return ProposedDenoiser.load(path)


def load_recording(name: str) -> np.ndarray:
    file, key, planes_last, _, _ = RECORDINGS[name]
    with np.load(REAL / file) as data:
        spikes = data[key]
    return np.ascontiguousarray(spikes.transpose(2, 0, 1) if planes_last else spikes)


def real_api_cli(name, spikes, windows, paths, dens):
    """``{(path, W): [gains]}`` and ``{W: overlap?}`` for the api and cli paths on one recording."""
    from spikeref.bayer import bayer_mosaic, bayer_planes
    from spikeref.hot_pixels import HotPixelRepair, find_hot_pixels
    from spikeref.stream import SpikeStream

    _, _, _, (a, b), end = RECORDINGS[name]
    defects = find_hot_pixels(spikes)
    repair = HotPixelRepair(defects)
    truth = repair.mosaic(spikes[a:b].mean(axis=0, dtype=np.float64))
    stream = SpikeStream.from_array(spikes)
    gains, overlap = {}, {}
    for w in windows:
        if w <= end:  # windows before the truth's planes
            n, overlap[w] = min(MAX_WINDOWS, end // w), False
        elif w == len(spikes) and name in WHOLE:  # the whole recording, truth's planes included
            n, overlap[w] = 1, True
        else:
            continue
        rates = [spikes[k * w:(k + 1) * w].mean(axis=0, dtype=np.float64).astype(np.float32) for k in range(n)]
        for tag, den in dens.items():
            if "api" in paths:
                g = [score(truth, bayer_mosaic(den(bayer_planes(r), mode="visible", window=w))) - score(truth, r)
                     for r in rates]
                gains.setdefault((f"api{tag}", w), []).extend(g)
            if "cli" in paths:
                for (_, frame), r in zip(den.frames(stream, w, start=0, count=n, hot_pixels=defects), rates,
                                         strict=True):
                    base = score(truth, repair.mosaic(r.copy()))  # (the repair works in place)
                    gains.setdefault((f"cli{tag}", w), []).append(score(truth, frame) - base)
    return gains, overlap


def real_pipeline(name, spikes, windows, accumulates, dens_for):
    """``{(path, W): [gains]}`` of the pipeline (D on against D off, same settings) on one recording."""
    from spikeref.hot_pixels import HotPixelRepair, find_hot_pixels
    from spikeref.pipeline import ReconstructParams, Reconstructor, support_planes
    from spikeref.stream import SpikeStream

    _, _, _, (a, b), end = RECORDINGS[name]
    repair = HotPixelRepair(find_hot_pixels(spikes))
    gains, notes = {}, {}
    for w in windows:
        support = support_planes(w, 3, 3)
        if support <= end:  # frames inside the planes before the truth
            stop_plane, truth_from = end, a
        elif support < b:  # one frame, the truth from the planes after it
            stop_plane, truth_from = support, support
            notes[w] = f"truth planes {support}–{b}"
        else:
            continue
        truth = repair.mosaic(spikes[truth_from:b].mean(axis=0, dtype=np.float64))
        stream = SpikeStream.from_array(spikes[:stop_plane])
        for acc in accumulates:
            params = ReconstructParams(window=w, K=3, L=3, accumulate=acc)
            rec = Reconstructor(stream, ReconstructParams(window=w, K=3, L=3, accumulate=acc, denoise=False))
            frames = list(rec.frames_available)[:MAX_WINDOWS]
            plain = [score(truth, f.rgb) for f in rec.frames(frames[0], frames[-1] + 1)]
            for tag, den in dens_for(acc).items():
                made = Reconstructor(stream, params, den).frames(frames[0], frames[-1] + 1)
                ours = [score(truth, f.rgb) for f in made]
                gains.setdefault((f"pipeline {acc}{tag}", w), []).extend(np.subtract(ours, plain))
    return gains, notes


def heldout(windows, paths, dens):
    """``{(path, W): {scene: mean gain}}`` on the held-out simulated scenes."""
    from spikeref.accumulate import accumulate as eq4
    from spikeref.bayer import bayer_mosaic, bayer_planes, demosaic_bilinear
    from spikeref.bench.runner import load_bench_scene
    from spikeref.hot_pixels import HotPixelRepair, find_hot_pixels
    from spikeref.simulate.simulator import ground_truth

    scenes = [(load_bench_scene(p), 11) for p in sorted((ROOT / "scripts" / "heldout_scenes").glob("*.toml"))]
    scenes += [(load_bench_scene(p), 8) for p in sorted((ROOT / "scripts" / "denoiser_scenes").glob("heldout_*.toml"))]
    out = {}
    for sc, seed in scenes:
        t0 = time.perf_counter()
        sc.simulate(seed)
        stream, cfa = sc.stream, sc.stream.cfa
        defects = find_hot_pixels(stream)
        repair = HotPixelRepair(defects) if defects.any() else None
        for w in windows:
            per = {}
            for start in HELDOUT_STARTS:
                if start + w > len(stream):
                    continue
                truth = ground_truth(sc.scene, w, planes=start + w, start=start)[0]
                rates = eq4(stream, w, start=start, count=1)[0]
                base = score(truth, demosaic_bilinear(rates, cfa))
                fixed = rates if repair is None else repair.mosaic(rates.copy())  # (the repair works in place)
                base_cli = score(truth, demosaic_bilinear(fixed, cfa))
                for tag, den in dens.items():
                    if "api" in paths:
                        img = demosaic_bilinear(bayer_mosaic(den(bayer_planes(rates), mode="visible", window=w)), cfa)
                        per.setdefault(f"api{tag}", []).append(score(truth, img) - base)
                    if "cli" in paths:
                        (_, frame), = list(den.frames(stream, w, start=start, count=1, hot_pixels=defects))
                        per.setdefault(f"cli{tag}", []).append(score(truth, frame) - base_cli)
            for path, g in per.items():
                out.setdefault((path, w), {})[sc.key] = float(np.mean(g))
        print(f"  {sc.key}: {time.perf_counter() - t0:.0f} s", flush=True)
        sc.stream = None
    return out


def fixed_pattern() -> None:
    """What a long window of the real outdoor recording holds besides its temporal noise.

    The Bayer planes of the means of planes 0–250 and 250–500 (hot pixels repaired) through Immerkær's 3×3
    filter (``spikeref.noise_level.immerkaer_response``, which cancels locally linear signal and turns white noise
    of σ into 6σ): the mean product of the two responses / 36 is the variance of what the halves share at the
    finest scale (the pixels' fixed pattern and texture), half the mean squared difference / 36 that of the
    temporal noise of one half.  Regions in plane pixels: the flat board, the trees above it, the whole plane.
    """
    from spikeref.bayer import bayer_planes
    from spikeref.hot_pixels import HotPixelRepair, find_hot_pixels
    from spikeref.noise_level import immerkaer_response

    spikes = load_recording("spikingsim")
    repair = HotPixelRepair(find_hot_pixels(spikes))
    halves = [bayer_planes(repair.mosaic(spikes[a:a + 250].mean(axis=0, dtype=np.float64))) for a in (0, 250)]
    ra, rb = (immerkaer_response(h) for h in halves)
    print("\n| region (plane pixels) | mean rate | shared σ (fixed pattern + texture) | temporal σ at W = 250 |\n"
          "|---|---:|---:|---:|")
    for name, (ys, xs) in {"board (plane rows 53–100, columns 9–175)": (slice(52, 100), slice(8, 175)),
                           "trees (plane rows 3–45, columns 3–198)": (slice(2, 45), slice(2, 198)),
                           "whole plane": (slice(None), slice(None))}.items():
        a, b = ra[:, ys, xs], rb[:, ys, xs]
        shared = max(float(np.mean(a * b)) / 36.0, 0.0)
        temporal = float(np.mean((a - b) ** 2)) / 2.0 / 36.0
        rate = float(halves[0][:, 1:-1, 1:-1][:, ys, xs].mean())  # the responses cover the interior
        print(f"| {name} | {rate:.3f} | {np.sqrt(shared):.4f} | {np.sqrt(temporal):.4f} |")


def main() -> None:
    from spikeref.denoise.denoiser import Denoiser, bundled_weights

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sets", default="spikingsim,uhsr,heldout")
    ap.add_argument("--paths", default="api,cli,pipeline")
    ap.add_argument("--windows", default=",".join(map(str, WINDOWS)))
    ap.add_argument("--pipeline-windows", default="5,10,20,50")
    ap.add_argument("--accumulate", default="charge", help="the pipeline's: charge (its default), count or both")
    ap.add_argument("--former", action="store_true", help="also the guard as it was before 2026-11-27")
    ap.add_argument("--proposed", action="store_true",
                    help="also the pipeline on charges with its output's floor at the support (a proposed change)")
    ap.add_argument("--fixed-pattern", action="store_true",
                    help="only the real outdoor recording's fixed pattern against its temporal noise (fixed_pattern)")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    if args.fixed_pattern:
        fixed_pattern()
        return
    sets, paths = args.sets.split(","), args.paths.split(",")
    windows = [int(w) for w in args.windows.split(",")]
    pipe_windows = [int(w) for w in args.pipeline_windows.split(",")]
    accumulates = args.accumulate.split(",")
    dens = {"": Denoiser.load()}
    if args.former:
        dens[" (former)"] = former_denoiser()

    def dens_for(acc):
        out = {"": None}  # the pipeline's own default network for acc
        if args.former:
            out[" (former)"] = former_denoiser(bundled_weights(acc))
        if args.proposed and acc == "charge":
            out[" (proposed)"] = proposed_denoiser(bundled_weights(acc))
        return out

    rows = []  # (set, path, W, mean gain, worst gain, note)
    for name in [s for s in sets if s in RECORDINGS]:
        if not (REAL / RECORDINGS[name][0]).is_file():
            print(f"{name}: {REAL / RECORDINGS[name][0]} is not here; left out")
            continue
        t0 = time.perf_counter()
        spikes = load_recording(name)
        gains, overlap = real_api_cli(name, spikes, windows, paths, dens)
        for (path, w), g in gains.items():
            rows.append((name, path, w, float(np.mean(g)), float(np.min(g)), "overlap" if overlap[w] else ""))
        if "pipeline" in paths:
            pg, notes = real_pipeline(name, spikes, pipe_windows, accumulates, dens_for)
            for (path, w), g in pg.items():
                rows.append((name, path, w, float(np.mean(g)), float(np.min(g)), notes.get(w, "")))
        print(f"{name}: {time.perf_counter() - t0:.0f} s", flush=True)
    if "heldout" in sets:
        for (path, w), per in heldout(windows, [p for p in paths if p != "pipeline"], dens).items():
            worst = min(per, key=per.get)
            rows.append(("heldout", path, w, float(np.mean(list(per.values()))), per[worst], f"worst: {worst}"))
    print("\n| set | path | W | gain (mean) | gain (worst) | note |\n|---|---|---:|---:|---:|---|")
    for r in sorted(rows, key=lambda r: (r[0], r[1], r[2])):
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:+.2f} | {r[4]:+.2f} | {r[5]} |")
    bad = [r for r in rows if r[4] < -0.1 and "(former)" not in r[1] and "(proposed)" not in r[1]]
    print(f"\nworse than the identity by more than 0.1 dB (the current code): {len(bad)} of "
          f"{sum('(' not in r[1] for r in rows)} rows"
          + "".join(f"\n  {r[0]} {r[1]} W={r[2]}: {r[4]:+.2f}" for r in bad))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        keys = ("set", "path", "W", "mean", "worst", "note")
        args.json.write_text(json.dumps([dict(zip(keys, r, strict=True)) for r in rows], indent=1))


if __name__ == "__main__":
    main()
