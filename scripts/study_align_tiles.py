"""Study of the alignment's tile sizes: flow error and PSNR per ``AlignParams.tile_by_step``.

Part 1 — the held-out translating texture (``scripts/denoiser_scenes/heldout_texture.toml``,
``.heldout_data/heldout_texture.dat`` from ``scripts/eval_pipeline.py``): PSNR of ``R_3`` and the
end-point error of ``F_0 … F_2`` against the known motion, frames 20, 60, 100, 140.
Part 2 — the five benchmark scenes (``spikeref bench``'s, seed 0, 4 scored frames): mean PSNR
of four settings of the method.  The figures are in ``docs/results_history.md`` ("Alignment tile sizes").

    python scripts/study_align_tiles.py [--part 1|2]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
TILES = [(16, 16, 8), (32, 16, 8), (32, 32, 16), (64, 32, 16), (64, 64, 32)]


def part1(den) -> None:
    from spikeref.align import AlignParams
    from spikeref.stream import open_spike_file
    from spikeref.metrics import psnr
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.simulate.scenes import load_scene
    from spikeref.simulate.simulator import ground_truth

    scene = load_scene(ROOT / "scripts/denoiser_scenes/heldout_texture.toml")
    stream = open_spike_file(ROOT / ".heldout_data/heldout_texture.dat")
    vx, vy = scene.content.velocity
    w = 10
    per = np.array([vy, vx]) * w / stream.rate_hz / 2  # plane pixels per window
    configs = {str(t): AlignParams(tile_by_step=t) for t in TILES}
    configs["(16, 16, 8), no sub-pixel"] = AlignParams(tile_by_step=(16, 16, 8), subpixel=False)
    configs["(16, 16, 8), radius 0 finest"] = AlignParams(tile_by_step=(16, 16, 8), search_radius=(0, 4, 4, 4))
    for name, ap in configs.items():
        rec = Reconstructor(stream, ReconstructParams(align_params=ap, accumulate="count"), den)
        epe, scores = {}, []
        for k in (20, 60, 100, 140):
            (f,) = list(rec.frames(k, k + 1, keep_steps=True))
            gt = ground_truth(scene, w, planes=(k + 1) * w, start=k * w)[0].astype(np.float64)
            scores.append(psnr(gt, f.rgb, float(gt.max())))
            for (level, i), fl in f.flows.items():
                err = np.hypot(fl[0] - i * per[0], fl[1] - i * per[1])[16:-16, 16:-16]
                epe.setdefault(level, []).append(float(err.mean()))
        print(f"{name:30s} PSNR {np.mean(scores):.2f}  EPE "
              + " ".join(f"F{lv} {np.mean(v):.3f}" for lv, v in sorted(epe.items())), flush=True)
    print(f"zero flow EPE {np.hypot(*per):.3f}")


def part2(den) -> None:
    from spikeref.align import AlignParams
    from spikeref.bench.runner import _score, bench_scenes, run_setting, score_centres
    from spikeref.bench.settings import Setting

    settings = [Setting("ours", 10, 3, 3), Setting("ours", 20, 3, 3), Setting("ours", 10, 5, 3),
                Setting("ours", 10, 3, 1)]
    res = {}
    for sc in bench_scenes():
        sc.simulate(0)
        centres = score_centres(len(sc.stream), 4)
        refs = [sc.reference(t) for t in centres]
        for s in settings:
            for t in TILES[:4]:
                frames, _ = run_setting(s, sc.stream, centres, den, align_params=AlignParams(tile_by_step=t),
                                           accumulate="count")
                res.setdefault((s.name, t), {})[sc.key] = np.mean(
                    [_score(r, f)["psnr"] for r, f in zip(refs, frames, strict=True)])
        sc.stream = None
    for s in settings:
        for t in TILES[:4]:
            d = res[(s.name, t)]
            print(f"{s.name:28s} {str(t):14s} mean {np.mean(list(d.values())):.2f}  "
                  + " ".join(f"{k} {v:.2f}" for k, v in d.items()))


def main() -> None:
    from spikeref.denoise.denoiser import Denoiser

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--part", choices=["1", "2"], default=None, help="run one part only")
    args = ap.parse_args()
    den = Denoiser.load()
    if args.part in (None, "1"):
        part1(den)
    if args.part in (None, "2"):
        part2(den)


if __name__ == "__main__":
    main()
