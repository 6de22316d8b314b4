"""Denoise mode: identity (TFP), the network with and without the SURE guard, BM3D, NLM — on one W window.

Each denoiser is applied to the four Bayer planes of one W-plane window (Eq. 4 rates), the planes
are put back into the mosaic, demosaicked with Ψ and scored in linear RGB against the exact
ground truth of that window: PSNR with the ground truth's peak as the data range, after a
least-squares gain per channel (``spikeref.metrics.psnr_after_gain``), an 8-pixel border left
out, averaged over the windows (planes 300 and 420 on) and then over the scenes.  BM3D and NLM
(the ``peers`` extra) run off the shelf, σ estimated blind from each plane; they are left out
when not installed.  The guard runs as ``spikeref denoise`` runs it: for W > 10 it measures the
noise on the window's first 10 planes (``spikeref.denoise.guard.NOISE_WINDOW``); ``--plane-noise``
adds the guard with σ from the W-plane window itself (the former behaviour), ``--bare`` the guard as a
bare ``Denoiser()(planes, window=W)`` call runs it (no short window: the quantisation floor for W > 10).

Sets (``--set``):

* ``bench``: the benchmark scenes (``spikeref/bench/scenes/``, seed 0) — the tuning set;
* ``heldout``: never trained or tuned on, fixed before the denoiser was retrained — the four
  natural-motion scenes ``scripts/heldout_scenes/*.toml`` (other photographs and motions, more
  noise; seed 11) and the four procedural ``scripts/denoiser_scenes/heldout_*.toml`` (seed 8);
* ``real``: SpikingSIM's real outdoor recording in ``../shared/data/real/`` (monochrome, near
  static): windows from planes 0–200 (starts 0 and 100 … so that every W fits), the four 2×2
  phases denoised as planes and put back, scored without Ψ against the mean of planes 300–500
  (a pseudo ground truth with disjoint noise), one gain for the whole image.

``--weights`` names the networks to score (default: the bundled one); ``--speed`` adds the
seconds per 250×400 frame (four 125×200 planes) of the network (guarded and not) and BM3D, in
this run, with the threads torch/Numba have.

    python scripts/eval_guard.py [--set bench|heldout|real] [--windows 10,20,50,100,200] [--weights F ...]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REAL = ROOT.parent / "shared" / "data" / "real" / "spikingsim_real_spike.npz"
BORDER = 8
STARTS = (300, 420)
REAL_STARTS = (0, 100)  # windows of up to 100 planes fit twice in planes 0–200; W = 200 once


def score(truth: np.ndarray, image: np.ndarray) -> float:
    from spikeref.metrics import psnr_after_gain

    crop = (slice(BORDER, -BORDER), slice(BORDER, -BORDER))
    per_channel = np.ndim(truth) == 3
    return psnr_after_gain(np.asarray(truth, np.float64)[crop], np.asarray(image, np.float64)[crop],
                           float(truth.max()), per_channel=per_channel)


def scene_cases(which: str, windows, keys=(), short: int | None = None, accumulate: str = "count"):
    """``(scene key, W, planes (4, h, w), truth, cfa)`` of every window scored (``keys``: bench scenes only).

    With ``short`` (planes), each case has a sixth item: the Bayer planes of the window's first
    ``short`` planes (what the guard measures the noise on; ``spikeref.denoise.guard``).
    ``accumulate="charge"``: the window's timing-aware charge rates (``spikeref.charge``) instead
    of Eq. 4's.
    """
    from spikeref.charge import charge_rates
    from spikeref.accumulate import accumulate as eq4
    from spikeref.bayer import bayer_planes
    from spikeref.bench.runner import bench_scenes, load_bench_scene
    from spikeref.simulate.simulator import ground_truth

    if which == "bench":
        scenes = [(sc, 0) for sc in bench_scenes(tuple(keys))]
    else:
        scenes = [(load_bench_scene(p), 11) for p in sorted((ROOT / "scripts" / "heldout_scenes").glob("*.toml"))]
        scenes += [(load_bench_scene(p), 8)
                   for p in sorted((ROOT / "scripts" / "denoiser_scenes").glob("heldout_*.toml"))]
    for sc, seed in scenes:
        sc.simulate(seed)
        for w in windows:
            for start in STARTS:
                if accumulate == "charge":
                    planes = bayer_planes(charge_rates(sc.stream, w, start=start, count=1)[0])
                else:
                    planes = bayer_planes(eq4(sc.stream, w, start=start, count=1)[0])
                truth = ground_truth(sc.scene, w, planes=start + w, start=start)[0]
                case = (sc.key, w, planes, truth, sc.stream.cfa)
                if short is not None:
                    first = (charge_rates(sc.stream, short, start=start, count=1) if accumulate == "charge"
                             else eq4(sc.stream, short, start=start, count=1))[0]
                    case += (bayer_planes(first),)
                yield case
        sc.stream = None


def real_cases(windows, short: int | None = None, accumulate: str = "count"):
    """As :func:`scene_cases` for the real recording (no Ψ: ``cfa`` is None)."""
    from spikeref.bayer import bayer_planes
    from spikeref.charge import charge_rates

    with np.load(REAL) as data:
        spikes = np.ascontiguousarray(data["arr_0"].transpose(2, 0, 1))  # (T, H, W)
    truth = spikes[300:500].mean(axis=0, dtype=np.float64)
    for w in windows:
        for start in REAL_STARTS:
            if start + w <= 200:
                if accumulate == "charge":
                    rate = charge_rates(spikes, w, start=start, count=1)[0]
                else:
                    rate = spikes[start : start + w].mean(axis=0, dtype=np.float64).astype(np.float32)
                case = ("real_outdoor", w, bayer_planes(rate), truth, None)
                if short is not None:
                    first = (charge_rates(spikes, short, start=start, count=1)[0]
                             if accumulate == "charge"
                             else spikes[start : start + short].mean(axis=0, dtype=np.float64).astype(np.float32))
                    case += (bayer_planes(first),)
                yield case


def main() -> None:
    from spikeref.bayer import bayer_mosaic, demosaic_bilinear
    from spikeref.denoise.denoiser import DEFAULT_WEIGHTS, Denoiser
    from spikeref.denoise.guard import DEFAULT_RADIUS, NOISE_WINDOW, sure_blend
    from spikeref.denoise.peers import PeerDenoiser, peer_available

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=("bench", "heldout", "real"), default="bench")
    ap.add_argument("--windows", default="10,20,50,100,200")
    ap.add_argument("--weights", type=Path, nargs="+", default=[DEFAULT_WEIGHTS])
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--no-plain", action="store_true", help="leave out the networks without the guard")
    ap.add_argument("--accumulate", choices=("count", "charge"), default="count",
                    help="the window's Eq. 4 rates (default) or its timing-aware charge rates (spikeref.charge), "
                         "for every method (the guard's short window too)")
    ap.add_argument("--plane-noise", action="store_true",
                    help="also the guard with σ from the plane alone at every W (before 2026-11-24's default, and "
                         "a bare call's until 2026-11-27)")
    ap.add_argument("--bare", action="store_true",
                    help="also the guard as a bare call Denoiser()(planes, window=W) runs it: no short window, so "
                         "for W > 10 only the quantisation floor (spikeref.denoise.guard.trusted_excess)")
    ap.add_argument("--guard-radius", type=int, nargs="+", default=[DEFAULT_RADIUS],
                    help="the guard's box radius(es), plane pixels (spikeref.denoise.guard.DEFAULT_RADIUS)")
    ap.add_argument("--speed", action="store_true", help="seconds per 250×400 frame, network against BM3D")
    args = ap.parse_args()
    windows = [int(w) for w in args.windows.split(",")]
    methods = {"identity": lambda p, w, s: p}
    several = len(args.weights) > 1
    for path in args.weights:
        tag = f" {path.stem}" if several else ""
        plain = Denoiser.load(path, guard="off")
        if not args.no_plain:
            methods["network" + tag] = lambda p, w, s, d=plain: d(p, window=w)
        network = Denoiser(plain.unet, shrink=False, guard="off")  # f alone, for --plane-noise's sure_blend
        for radius in args.guard_radius:
            guarded = Denoiser(plain.unet, guard_radius=radius)  # the weights read once
            rtag = tag + ("" if args.guard_radius == [DEFAULT_RADIUS] else f", radius {radius}")
            if args.plane_noise:  # sure_blend without carried=: the plane's own σ at every W
                methods["network + guard, σ of the plane" + rtag] = lambda p, w, s, d=network, r=radius: sure_blend(
                    p, lambda z: d(z, window=w), r, window=w, accumulate=args.accumulate)[0]
            if args.bare:
                methods["network + guard, no short window" + rtag] = lambda p, w, s, d=guarded: d(
                    p, window=w, accumulate=args.accumulate)
            methods["network + guard" + rtag] = lambda p, w, s, d=guarded: (
                d(p, window=w, short=s, short_window=NOISE_WINDOW, accumulate=args.accumulate)
                if w > NOISE_WINDOW and s is not None else d(p, window=w, accumulate=args.accumulate))
    if not args.no_peers:
        for name in ("bm3d", "nlm"):
            if peer_available(name):
                peer = PeerDenoiser(name)
                methods[peer.name] = lambda p, w, s, peer=peer: peer(p, window=w)
    short = NOISE_WINDOW
    cases = (real_cases(windows, short, args.accumulate) if args.set == "real"
             else scene_cases(args.set, windows, short=short, accumulate=args.accumulate))
    table, secs, keys = {}, {m: [] for m in methods}, []
    for key, w, planes, truth, cfa, *rest in cases:
        short = rest[0] if rest else None
        if key not in keys:
            keys.append(key)
            print(f"{key} …", flush=True)
        for name, fn in methods.items():
            t0 = time.perf_counter()
            out = np.asarray(fn(planes, w, short), np.float32)
            secs[name].append(time.perf_counter() - t0)
            img = bayer_mosaic(out) if cfa is None else demosaic_bilinear(bayer_mosaic(out), cfa)
            table.setdefault((key, w, name), []).append(score(truth, img))
    names = list(methods)
    print(f"\n{args.set}: PSNR dB, mean of the windows")
    print("\n| scene | W | " + " | ".join(names) + " |")
    print("|---|---:|" + "---:|" * len(names))
    for key in keys:
        for w in windows:
            print(f"| {key} | {w} | " + " | ".join(f"{np.mean(table[(key, w, n)]):.2f}" for n in names) + " |")
    for w in windows:
        print(f"| **mean** | {w} | " + " | ".join(
            f"**{np.mean([np.mean(table[(k, w, n)]) for k in keys]):.2f}**" for n in names) + " |")
    for name in names[1:]:
        worst = min((np.mean(table[(k, w, name)]) - np.mean(table[(k, w, "identity")]), k, w)
                    for k in keys for w in windows)
        print(f"worst {name} − identity over scenes × W: {worst[0]:+.2f} dB ({worst[1]}, W = {worst[2]})")
    print("seconds per frame of this set (median): " + ", ".join(f"{n} {np.median(v):.3f}" for n, v in secs.items()))
    if args.speed:
        speed(methods)


def speed(methods) -> None:
    """Median seconds per 250×400 frame (four 125×200 Bayer planes of a W = 10 window), same run."""
    rng = np.random.default_rng(0)
    planes = (rng.binomial(10, 0.3, size=(4, 125, 200)) / 10).astype(np.float32)
    timed = {}
    for name, fn in methods.items():
        if name == "identity" or name.startswith("nlm"):
            continue
        fn(planes, 10, None)  # compile / warm up
        reps = 2 if name.startswith("bm3d") else 10
        runs = []
        for _ in range(reps):
            t0 = time.perf_counter()
            fn(planes, 10, None)
            runs.append(time.perf_counter() - t0)
        timed[name] = float(np.median(runs))
    print("seconds per 250×400 frame (median): " + ", ".join(f"{n} {v:.3f}" for n, v in timed.items()))
    bm3d = [v for n, v in timed.items() if n.startswith("bm3d")]
    if bm3d:
        print("BM3D / network: " + ", ".join(f"{n} {bm3d[0] / v:.0f}×" for n, v in timed.items()
                                              if not n.startswith("bm3d")))


if __name__ == "__main__":
    main()
