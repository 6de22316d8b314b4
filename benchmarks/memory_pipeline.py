"""Peak memory of a whole streamed reconstruction: 2 000 against 20 000 planes of the same scene.

Writes a memory-mapped ``.dat`` of a moving random texture (128×128, RGGB) of each length into a
temporary folder, then reconstructs **every** frame (W = 10, K = 3, L = 3, width-16 denoiser) in a
fresh process and reports its peak resident memory (``ru_maxrss``).  Streaming keeps rings of
a few windows per step, so the anonymous (heap) memory should agree within noise; the
file-backed part of RSS also holds the pages of the memory-mapped ``.dat`` that were read
(reclaimable page cache, which grows with what has been read), so it is printed apart.

    python benchmarks/memory_pipeline.py [--planes 2000 20000]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = """
import resource, sys, time
from spikeref.denoise.denoiser import Denoiser
from spikeref.denoise.unet import UNet, UNetSpec
from spikeref.stream import read_dat
from spikeref.pipeline import Reconstructor
stream = read_dat(sys.argv[1], height=128, width=128, cfa="RGGB")
rec = Reconstructor(stream, denoiser=Denoiser(UNet.random(UNetSpec(width=16), seed=0)))
t0 = time.perf_counter()
n = sum(1 for _ in rec.frames())
status = dict(line.split(":", 1) for line in open("/proc/self/status"))
kib = lambda key: int(status.get(key, "0 kB").split()[0]) // 1024
print(n, round(time.perf_counter() - t0, 1), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024,
      kib("RssAnon"), kib("RssFile"))
"""


def write_stream(path: Path, planes: int) -> None:
    import numpy as np

    from spikeref.io.dat import DatWriter

    rng = np.random.default_rng(0)
    tex = rng.random((128, 256)) * 0.8 + 0.1
    with DatWriter(path, 128, 128) as out:
        for t in range(0, planes, 100):
            n = min(100, planes - t)
            img = tex[:, (t // 10) % 128:(t // 10) % 128 + 128]
            out.append((rng.random((n, 128, 128)) < img).astype(np.uint8))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--planes", type=int, nargs="+", default=[2000, 20000])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for planes in args.planes:
            path = Path(tmp) / f"s{planes}.dat"
            write_stream(path, planes)
            t0 = time.time()
            out = subprocess.run([sys.executable, "-c", CHILD, str(path)], check=True, capture_output=True,
                                 text=True).stdout.split()
            frames, seconds, peak_mb, anon_mb, file_mb = int(out[0]), float(out[1]), *map(int, out[2:5])
            print(f"{planes:6d} planes ({path.stat().st_size / 2**20:6.1f} MiB .dat): {frames} frames in "
                  f"{seconds:.1f} s, peak RSS {peak_mb} MiB; at the end anonymous {anon_mb} MiB, "
                  f"file-backed {file_mb} MiB (wall {time.time() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
