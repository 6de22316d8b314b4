"""The merges (spikeref.merge) on the ladder: Eq. 14–15's binomial average, the robust merge, the adaptive support.

Runs the stage ladder's rungs ``net`` (the denoiser on one window), ``ours_binomial`` (``merge="binomial"``: Eq.
14–15's weights, the defaults until 2026-11-28), ``ours_robust`` (``merge="robust"``), ``ours`` (the defaults: the
adaptive support, ``support`` windows each side, 10 unless ``--support``), ``no_align``, ``no_denoiser`` and
``limit`` on the benchmark scenes (``--set bench``, seed 0: where the merge's parameters were chosen) or on the
held-out scenes (``--set heldout``: ``scripts/heldout_scenes``, seed 11, never used to choose them), and prints
each scene's PSNR and the differences the issue's targets name.

    python scripts/study_merge.py [--set bench|heldout] [--frames 4] [--support 10] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SETS = {"bench": (ROOT / "spikeref" / "bench" / "scenes", 0), "heldout": (ROOT / "scripts" / "heldout_scenes", 11)}
RUNGS = ("net", "ours_binomial", "ours_robust", "ours", "no_align", "no_denoiser", "limit")


def main(argv=None) -> int:
    from spikeref.bench.ladder import run_ladder
    from spikeref.bench.runner import load_bench_scene, needs_scikit_image

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=sorted(SETS), default="bench")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--scenes", default=None, help="comma-separated scene file stems (default all)")
    ap.add_argument("--support", type=int, default=None, help="the adaptive support's reach in windows")
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
        res = run_ladder([sc], seed=seed, frames=args.frames, rungs=RUNGS, progress=False,
                         params=None if args.support is None else {"support": args.support})
        rows[sc.key] = {r["rung"]: r["psnr"] for r in res["rows"]}
        got = rows[sc.key]
        print(f"{sc.key:32s} " + " ".join(f"{r} {got[r]:.2f}" for r in RUNGS), file=sys.stderr, flush=True)
    cols = ("net", "ours_binomial", "ours_robust", "ours", "no_align", "no_denoiser", "limit")
    head = ("| scene | D on W | Eq. 14–15 merge | robust | ours (adaptive) | no alignment | no denoiser | limit "
            "| robust − Eq. 14–15 | ours − Eq. 14–15 | ours − limit |")
    lines = [head, "|---|" + "---:|" * 10]

    def row(name, g):
        return (f"| {name} | " + " | ".join(f"{g[c]:.2f}" for c in cols)
                + f" | {g['ours_robust'] - g['ours_binomial']:+.2f} | {g['ours'] - g['ours_binomial']:+.2f} "
                  f"| {g['ours'] - g['limit']:+.2f} |")

    for key, g in rows.items():
        lines.append(row(key, g))
    mean = {r: float(np.mean([g[r] for g in rows.values()])) for r in RUNGS}
    lines.append(row("**mean**", mean))
    text = "\n".join(lines)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
