"""Frames/s of the default reconstruction here against an earlier revision's, alternated in one run.

``python benchmarks/pipeline_against_revision.py REV [--frames 24] [--rounds 3] [--size 250x400] [--preset paper]``

Checks out ``REV`` into a temporary git worktree, writes one colour test stream (Bernoulli spikes of a
smooth texture moving 1 px per window, RGGB) as a ``.dat`` both revisions can read, and then runs, in
turn and ``--rounds`` times, a fresh process of each revision that opens the file with
``spikeref.read_dat`` and reconstructs ``--frames`` frames with that revision's own defaults
(``spikeref.reconstruct``'s ``ReconstructParams()`` and its bundled network) at W/K/L = 10/3/3; with
``--preset paper``, the paper's procedure as ``benchmarks/test_speed_pipeline.py`` times it
(``ReconstructParams.paper()`` and the bundled network alone as the paper's ``D``: ``guard="off"``,
``shrink=False``, since 2026-11-25; before, the residual shrinkage ran too), and ``--preset fast`` the fast
preset.  The first frame of each process is left out of the timing (it compiles or loads the kernels).  Prints
frames/s per round and the ratio of the medians, and the time a frame spends outside the U-Net's passes
(``Reconstructor.profile()``), which does not move with the network's speed from one process to the next.
Needs git and the revision in this clone; the revision must have ``Reconstructor.profile()`` (8faa5d0 and later).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, sys, time
import numpy as np
import spikeref as sr
from spikeref.pipeline import ReconstructParams, Reconstructor
stream = sr.read_dat(sys.argv[1], height=int(sys.argv[2]), width=int(sys.argv[3]), cfa="RGGB")
preset = sys.argv[5]
if preset == "default":
    rec = Reconstructor(stream, ReconstructParams(window=10, K=3, L=3))
else:
    from spikeref.denoise.denoiser import Denoiser, bundled_weights
    params = getattr(ReconstructParams, preset)(window=10, K=3, L=3)
    paper = preset == "paper"  # the paper's D: the network alone, no guard and no residual shrinkage
    den = Denoiser.load(bundled_weights(params.accumulate), guard="off" if paper else "sure", shrink=not paper)
    rec = Reconstructor(stream, params, den)
a = rec.frames_available.start
n = int(sys.argv[4])
it = iter(rec.frames(a, a + n + 1))
next(it)  # compile / load
net_before = rec.profile().seconds["network"]
t0 = time.perf_counter()
for _ in it:
    pass
total = time.perf_counter() - t0
net = rec.profile().seconds["network"] - net_before  # the U-Net's passes in the timed frames only
print(json.dumps({"fps": n / total, "ms": 1e3 * total / n, "net_ms": 1e3 * net / n, "module": sr.__file__}))
"""


def _run(src: Path, dat: Path, h: int, w: int, frames: int, preset: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src))
    done = subprocess.run([sys.executable, "-c", CHILD, str(dat), str(h), str(w), str(frames), preset], env=env,
                          cwd=tempfile.gettempdir(), capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rev", help="the earlier revision (a commit, tag or branch of this clone)")
    ap.add_argument("--frames", type=int, default=24, help="frames timed per process (default 24)")
    ap.add_argument("--rounds", type=int, default=3, help="processes of each revision, alternated (default 3)")
    ap.add_argument("--size", default="250x400", help="HxW pixels (default 250x400)")
    ap.add_argument("--preset", choices=("default", "paper", "fast"), default="default",
                    help="the defaults (default), the paper's procedure, or the fast preset")
    args = ap.parse_args(argv)
    h, w = (int(v) for v in args.size.lower().split("x"))
    from spikeref.io.dat import write_dat

    sys.path.insert(0, str(REPO / "benchmarks"))
    from test_speed_pipeline import moving_texture_spikes  # the stream of the pipeline's speed benchmark

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        old = tmp / "old"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "-q", str(old), args.rev], check=True)
        try:
            dat = tmp / "stream.dat"
            write_dat(dat, moving_texture_spikes(h, w, 10 * (args.frames + 8)))
            fps = {"before": [], "now": []}
            for r in range(args.rounds):
                for name, src in (("before", old), ("now", REPO)):
                    out = _run(src, dat, h, w, args.frames, args.preset)
                    assert Path(out["module"]).resolve().is_relative_to(src.resolve()), out["module"]
                    outside = out["ms"] - out["net_ms"]
                    out["outside_ms"], out["share"] = outside, outside / out["ms"]
                    fps[name].append(out)
                    print(f"round {r + 1}: {name:6s} {out['fps']:6.2f} frames/s; outside the network "
                          f"{outside:5.1f} ms a frame ({out['share']:.1%})", flush=True)
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(old)], check=False)
    med = {name: {key: statistics.median(o[key] for o in runs) for key in ("fps", "outside_ms", "share")}
           for name, runs in fps.items()}
    before, now = med["before"]["fps"], med["now"]["fps"]
    print(f"median frames/s at {h}x{w}, 10/3/3, {args.preset}: {args.rev} {before:.2f}, now {now:.2f} "
          f"({now / before:.2f}x)")
    print(f"median outside the network (ms a frame, share): {args.rev} {med['before']['outside_ms']:.1f} "
          f"({med['before']['share']:.1%}), now {med['now']['outside_ms']:.1f} ({med['now']['share']:.1%})")


if __name__ == "__main__":
    main()
