"""The robust merge and the adaptive support (spikeref.merge) against Eq. 14–15's binomial average, on the ladder.

Runs the stage ladder's rungs ``net`` (the denoiser on one window), ``ours`` (the defaults), ``ours_robust``
(``ReconstructParams(merge="robust")``), ``ours_adaptive`` (``merge="adaptive"``, ``support`` 20 windows) and
``limit`` on the benchmark scenes (``--set bench``, seed 0: where the merge's parameters were chosen) or on the
held-out scenes (``--set heldout``: ``scripts/heldout_scenes``, seed 11, never used to choose them), and prints
each scene's PSNR and the differences the issue's targets name.

    python scripts/study_merge.py [--set bench|heldout] [--frames 4] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SETS = {"bench": (ROOT / "spikeref" / "bench" / "scenes", 0), "heldout": (ROOT / "scripts" / "heldout_scenes", 11)}
RUNGS = ("net", "ours", "ours_robust", "ours_adaptive", "limit")


def main(argv=None) -> int:
    from spikeref.bench.ladder import run_ladder
    from spikeref.bench.runner import load_bench_scene, needs_scikit_image

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=sorted(SETS), default="bench")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--scenes", default=None, help="comma-separated scene file stems (default all)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    folder, seed = SETS[args.set]
    import importlib.util

    have_skimage = importlib.util.find_spec("skimage") is not None
    paths = [p for p in sorted(folder.glob("*.toml")) if have_skimage or not needs_scikit_image(p)]
    if args.scenes:
        keep = set(args.scenes.split(","))
        paths = [p for p in paths if p.stem in keep]
    rows = {}
    for path in paths:
        sc = load_bench_scene(path)
        res = run_ladder([sc], seed=seed, frames=args.frames, rungs=RUNGS, progress=False)
        rows[sc.key] = {r["rung"]: r["psnr"] for r in res["rows"]}
        got = rows[sc.key]
        print(f"{sc.key:32s} " + " ".join(f"{r} {got[r]:.2f}" for r in RUNGS), file=sys.stderr, flush=True)
    head = "| scene | D on W | ours | robust | adaptive | limit | robust − ours | adaptive − ours | adaptive − limit |"
    lines = [head,
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for key, g in rows.items():
        lines.append(f"| {key} | {g['net']:.2f} | {g['ours']:.2f} | {g['ours_robust']:.2f} | {g['ours_adaptive']:.2f} "
                     f"| {g['limit']:.2f} | {g['ours_robust'] - g['ours']:+.2f} "
                     f"| {g['ours_adaptive'] - g['ours']:+.2f} "
                     f"| {g['ours_adaptive'] - g['limit']:+.2f} |")
    mean = {r: float(np.mean([g[r] for g in rows.values()])) for r in RUNGS}
    lines.append(f"| **mean** | {mean['net']:.2f} | {mean['ours']:.2f} | {mean['ours_robust']:.2f} | "
                 f"{mean['ours_adaptive']:.2f} | {mean['limit']:.2f} | {mean['ours_robust'] - mean['ours']:+.2f} | "
                 f"{mean['ours_adaptive'] - mean['ours']:+.2f} | {mean['ours_adaptive'] - mean['limit']:+.2f} |")
    text = "\n".join(lines)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
