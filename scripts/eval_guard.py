"""Denoise mode on the benchmark scenes: identity (TFP), the network with and without the SURE guard, BM3D, NLM.

Each denoiser is applied to the four Bayer planes of one W-plane window (Eq. 4 rates), the planes
are put back into the mosaic, demosaicked with Ψ and scored in linear RGB against the exact
ground truth of that window: PSNR with the ground truth's peak as the data range, after a
least-squares gain per channel, an 8-pixel border left out, averaged over the windows (planes
300 and 420 on) and then over the scenes.  BM3D and NLM (the ``peers`` extra) run off the shelf,
σ estimated blind from each plane; they are left out when not installed.

    python scripts/eval_guard.py [--windows 10,20,50,100,200] [--scenes static,...] [--no-peers]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

BORDER = 8
STARTS = (300, 420)


def score(truth: np.ndarray, image: np.ndarray) -> float:
    from spikeref.metrics import psnr_after_gain

    crop = (slice(BORDER, -BORDER), slice(BORDER, -BORDER))
    return psnr_after_gain(truth[crop], np.asarray(image)[crop], float(truth.max()), per_channel=True)


def main() -> None:
    from spikeref.accumulate import accumulate
    from spikeref.bayer import bayer_mosaic, bayer_planes, demosaic_bilinear
    from spikeref.bench.runner import bench_scenes
    from spikeref.denoise.denoiser import Denoiser
    from spikeref.denoise.peers import PeerDenoiser, peer_available
    from spikeref.simulate.simulator import ground_truth

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--windows", default="10,20,50,100,200")
    ap.add_argument("--scenes", default=None)
    ap.add_argument("--no-peers", action="store_true")
    args = ap.parse_args()
    windows = [int(w) for w in args.windows.split(",")]
    guarded, plain = Denoiser.load(), Denoiser.load(guard="off")
    methods = {"identity": lambda p, w: p, "network": lambda p, w: plain(p, window=w),
               "network + guard": lambda p, w: guarded(p, window=w)}
    if not args.no_peers:
        for name in ("bm3d", "nlm"):
            if peer_available(name):
                peer = PeerDenoiser(name)
                methods[peer.name] = lambda p, w, peer=peer: peer(p, window=w)
    scenes = bench_scenes(tuple(args.scenes.split(",")) if args.scenes else ())
    table, secs = {}, {m: [] for m in methods}
    for sc in scenes:
        sc.simulate(0)
        cfa = sc.stream.cfa
        for w in windows:
            for start in STARTS:
                planes = bayer_planes(accumulate(sc.stream, w, start=start, count=1)[0])
                truth = ground_truth(sc.scene, w, planes=start + w, start=start)[0]
                for name, fn in methods.items():
                    t0 = time.perf_counter()
                    out = fn(planes, w)
                    secs[name].append(time.perf_counter() - t0)
                    img = demosaic_bilinear(bayer_mosaic(np.asarray(out, np.float32)), cfa)
                    table.setdefault((sc.key, w, name), []).append(score(truth, img))
        sc.stream = None
        print(f"{sc.key} done", flush=True)
    names = list(methods)
    print("\n| scene | W | " + " | ".join(names) + " |")
    print("|---|---:|" + "---:|" * len(names))
    for sc in scenes:
        for w in windows:
            print(f"| {sc.key} | {w} | " + " | ".join(f"{np.mean(table[(sc.key, w, n)]):.2f}" for n in names) + " |")
    for w in windows:
        print(f"| **mean** | {w} | " + " | ".join(
            f"**{np.mean([np.mean(table[(s.key, w, n)]) for s in scenes]):.2f}**" for n in names) + " |")
    worst = min(np.mean(table[(s.key, w, "network + guard")]) - np.mean(table[(s.key, w, "identity")])
                for s in scenes for w in windows)
    print(f"\nworst (network + guard) − identity over scenes × W: {worst:+.2f} dB")
    print("seconds per frame (median): " + ", ".join(f"{n} {np.median(v):.3f}" for n, v in secs.items()))


if __name__ == "__main__":
    main()
