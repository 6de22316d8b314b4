"""What a single-mosaic demosaic can reach: the exact mosaics of the scored frames through Ψ, Malvar–He–Cutler and
the directional demosaic (Menon–Andriani–Calvagno, no refining step), against the truth.

    python scripts/study_demosaic_limits.py

The frames are those the ladder scores (``spikeref bench --ladder``: four per scene, seed 0 for the benchmark
scenes, 11 for the held-out ones) and the embedded sample's frames 3–22 (``sample_ground_truth(10)``); each is
mosaicked by Eq. 3 (``mosaic_radiance``) and scored as the ladder scores (linear RGB, the truth's peak as the range).
Where the scene holds still every window samples the reference's CFA phases and the multi-frame demosaic can do
no better than such a demosaic (docs/results.md, "The directional demosaic where the colours share their detail").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    from spikeref.bayer import demosaic_bilinear
    from spikeref.bench.ladder import psnr_score
    from spikeref.bench.runner import load_bench_scene, score_centres
    from spikeref.demosaic import demosaic_mhc
    from spikeref.directional_demosaic import demosaic_ddfapd
    from spikeref.sample import load_sample, sample_ground_truth
    from spikeref.simulate.camera import mosaic_radiance

    methods = {"Ψ": demosaic_bilinear, "MHC": demosaic_mhc, "DDFAPD": demosaic_ddfapd}
    sets = {}
    for name, folder, seed in (("bench", ROOT / "spikeref/bench/scenes", 0),
                               ("held-out", ROOT / "scripts/heldout_scenes", 11)):
        for path in sorted(folder.glob("*.toml")):
            sc = load_bench_scene(path)
            sc.simulate(seed)
            sets.setdefault(name, {})[sc.key] = [sc.reference(t) for t in score_centres(len(sc.stream), 4)]
            sc.stream = None
    sample = load_sample()
    sets["sample"] = {"sample": list(sample_ground_truth(10)[3:23])}
    cfa = {"bench": "RGGB", "held-out": "RGGB", "sample": sample.cfa}
    for name, scenes in sets.items():
        means = {m: [] for m in methods}
        for key, truths in scenes.items():
            row = {m: float(np.mean([psnr_score(t, f(mosaic_radiance(t, cfa[name]).astype(np.float32), cfa[name]))
                                     for t in truths])) for m, f in methods.items()}
            for m, v in row.items():
                means[m].append(v)
            print(f"{name:9s} {key:24s} " + "  ".join(f"{m} {v:6.2f}" for m, v in row.items()))
        print(f"{name:9s} {'mean':24s} " + "  ".join(f"{m} {np.mean(v):6.2f}" for m, v in means.items()))


if __name__ == "__main__":
    main()
