"""What the gap between ours and the limit is made of: each sensor effect of a scene removed in turn.

``python scripts/study_noise_sources.py [--set bench|heldout] [--scenes translation astronaut_pan …]`` rewrites each
scene file without one of its ``[effects.*]`` tables (the threshold's fixed pattern, shot noise, dark current, the
inherent noise of Eq. 7) and runs the ladder's ``ours`` rung and its ``limit`` (Ψ of the noise-free mosaic; the
same for every variant) at the defaults, same seed, same scored frames (``spikeref.bench.ladder.run_ladder``).  The
dB an effect costs is ``all − without it``.  About 1 min per scene and variant on two cores.
"""

from __future__ import annotations

import argparse
import re
import tempfile
from pathlib import Path

import numpy as np

from spikeref.bench.ladder import run_ladder
from spikeref.bench.runner import load_bench_scene

ROOT = Path(__file__).resolve().parent.parent
SETS = {"bench": (ROOT / "spikeref" / "bench" / "scenes", 0), "heldout": (ROOT / "scripts" / "heldout_scenes", 11)}
EFFECTS = ("threshold_fpn", "shot_noise", "dark_current", "inherent_noise")


def without(text: str, effect: str | None) -> str:
    """The scene file's text without the ``[effects.<effect>]`` table (and its keys)."""
    return text if effect is None else re.sub(rf"\[effects\.{effect}\][^\[]*", "", text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=sorted(SETS), default="bench")
    ap.add_argument("--scenes", nargs="*", default=())
    args = ap.parse_args()
    folder, seed = SETS[args.set]
    variants = (None, *EFFECTS)
    print(f"{'scene':24s} {'limit':>6s} {'ours':>6s} " + " ".join(f"{'no ' + e:>17s}" for e in EFFECTS) + "  (dB)")
    table = []
    for path in sorted(folder.glob("*.toml")):
        scene = load_bench_scene(path)
        if args.scenes and scene.key not in args.scenes:
            continue
        text, row, limit = path.read_text(), [], np.nan
        with tempfile.TemporaryDirectory() as tmp:
            for effect in variants:
                if effect is not None and f"[effects.{effect}]" not in text:
                    row.append(row[0])  # the scene has no such effect: removing it changes nothing
                    continue
                variant = Path(tmp) / path.name
                variant.write_text(without(text, effect))
                rungs = ("ours", "limit") if effect is None else ("ours",)  # the limit is noise-free: one per scene
                res = run_ladder([load_bench_scene(variant)], seed=seed, rungs=rungs, peers=(), progress=False)
                got = {r["rung"]: r["psnr"] for r in res["rows"]}
                limit = got.get("limit", limit)
                row.append(got["ours"])
        table.append(row)
        print(f"{scene.key:24s} {limit:6.2f} {row[0]:6.2f} "
              + " ".join(f"{v:17.2f}" for v in row[1:]), flush=True)
    mean = np.mean(np.array(table), axis=0)
    print(f"{'mean (ours, and each without)':24s} {'':6s} {mean[0]:6.2f} " + " ".join(f"{v:17.2f}" for v in mean[1:]))


if __name__ == "__main__":
    main()
