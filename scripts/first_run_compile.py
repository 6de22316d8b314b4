"""What a spikeref command compiles on its first run, and how long the first and second runs take.

Runs the command twice in fresh processes that share one Numba cache: by default the per-user
folder spikeref chooses (``spikeref._jit``) under a new temporary ``XDG_CACHE_HOME``, as for a
new user; ``--cache-dir`` sets ``NUMBA_CACHE_DIR`` instead.  The first run compiles, the second
loads from the cache.  Each run records every Numba compilation (``numba.core.event``'s
``numba:compile`` events: the kernel, its signature and its seconds; a kernel compiled inside
another one is indented and listed before it) and three moments counted from the launch of its
process: when the pipeline is first asked for frames, when the first frame is done, and the exit.
At the end it lists the files of the imported ``spikeref`` package (an installed one in
``site-packages``, or the checkout) written during the runs: there should be none.

    python scripts/first_run_compile.py                                   # reconstruct --frames 3:4 on the sample
    python scripts/first_run_compile.py --cache-dir DIR -- reconstruct rec.dat -o out.mp4

Figures: ``docs/results.md`` ("First run: what Numba compiles").
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time


def _child(argv: list[str], out_path: str) -> None:
    """Run ``spikeref <argv>`` in this process and write what compiled and when to ``out_path``."""
    from numba.core import event

    compiles: list[tuple[str, str, float, int]] = []

    class Recorder(event.Listener):
        def __init__(self):
            self.started: list[float] = []

        def on_start(self, ev):
            self.started.append(time.perf_counter())

        def on_end(self, ev):
            seconds = time.perf_counter() - self.started.pop()
            fn = ev.data["dispatcher"].py_func
            compiles.append((f"{fn.__module__}.{fn.__qualname__}", str(ev.data["args"]), seconds, len(self.started)))

    event.register("numba:compile", Recorder())
    import spikeref.pipeline as pipeline
    from spikeref import cli

    marks: dict[str, float] = {}
    frames = pipeline.Reconstructor.frames

    def timed_frames(self, *args, **kwargs):
        marks.setdefault("frames asked", time.time())
        for i, frame in enumerate(frames(self, *args, **kwargs)):
            if i == 0:
                marks.setdefault("first frame done", time.time())
            yield frame

    pipeline.Reconstructor.frames = timed_frames
    try:
        code = cli.main(argv)
    finally:
        marks["exit"] = time.time()
        with open(out_path, "w") as fh:
            json.dump({"compiles": compiles, "marks": marks}, fh)
    sys.exit(code or 0)


def main(args=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cache-dir", default=None,
                   help="Numba cache folder (NUMBA_CACHE_DIR); default: the per-user folder under a new temporary "
                        "XDG_CACHE_HOME")
    p.add_argument("--runs", type=int, default=2, help="runs one after the other (default 2)")
    p.add_argument("--child", nargs=1, help=argparse.SUPPRESS)
    p.add_argument("command", nargs="*", help="the spikeref command (default: reconstruct --frames 3:4 …)")
    ns = p.parse_args(args)
    if ns.child:
        _child(ns.command, ns.child[0])
        return 0
    if ns.runs < 1:
        p.error(f"--runs must be at least 1; got {ns.runs}")
    work = tempfile.mkdtemp(prefix="spikeref-first-run-")
    command = ns.command or ["reconstruct", "--frames", "3:4", "-o", os.path.join(work, "x.mp4"),
                             "--exr-dir", os.path.join(work, "exr")]
    env = dict(os.environ)
    if ns.cache_dir:
        env["NUMBA_CACHE_DIR"] = cache = ns.cache_dir
    else:
        env.pop("NUMBA_CACHE_DIR", None)
        env["XDG_CACHE_HOME"] = os.path.join(work, "cache")
        cache = os.path.join(env["XDG_CACHE_HOME"], "spikeref", "numba")
    spec = importlib.util.find_spec("spikeref")
    if spec is None or spec.origin is None:
        p.error("spikeref is not importable by this Python (install it, or set PYTHONPATH to the checkout)")
    package = os.path.dirname(spec.origin)
    print(f"spikeref {' '.join(command)}\npackage: {package}\nNumba cache: {cache}; "
          f"load average before: {os.getloadavg()[0]:.2f}")
    began = time.time()
    for run in range(1, ns.runs + 1):
        out = os.path.join(work, f"run{run}.json")
        launched = time.time()
        proc = subprocess.run([sys.executable, __file__, "--child", out, "--", *command], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if proc.returncode != 0:
            print(proc.stderr[-2000:], file=sys.stderr)
            return proc.returncode
        with open(out) as fh:
            result = json.load(fh)
        top = [c for c in result["compiles"] if c[3] == 0]
        times = ", ".join(f"{k} {v - launched:.2f} s" for k, v in result["marks"].items())
        print(f"\nrun {run}: {times}; {len(top)} kernels compiled, {sum(c[2] for c in top):.2f} s")
        for name, signature, seconds, depth in result["compiles"]:
            if name.startswith("spikeref"):
                print(f"  {'  ' * depth}{seconds:6.2f} s  {name}{signature}")
    written = [os.path.join(d, f) for d, _, files in os.walk(package) for f in files
               if os.path.getmtime(os.path.join(d, f)) >= began]
    print(f"\nload average after: {os.getloadavg()[0]:.2f}; files written inside {package}: {len(written)}")
    for path in written:
        print(f"  {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
