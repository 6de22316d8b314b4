"""Frames/s of the Dask reconstruction with 1 and 2 local workers, scheduler overhead, memory per worker.

Writes a moving random texture (128×128 RGGB, ``--planes`` planes) as ``.dat`` into a temporary
folder and reconstructs every frame (W = 10, K = 3, L = 3, bundled denoiser) into EXR files:

* in this process, without Dask (``spikeref.pipeline`` streaming: the reference);
* on a ``LocalCluster`` of 1 and then 2 single-threaded worker processes, ``--chunk-frames`` per task.

It reports frames/s of each and their ratio (same run), the cluster's start-up time, the round
trip of an empty task (the scheduler's overhead per chunk) and each worker's peak resident memory.

    python benchmarks/distributed_scaling.py [--planes 600] [--chunk-frames 8]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def _noop():
    return 0


def main() -> None:
    from dask.distributed import Client, LocalCluster

    from spikeref.distributed import reconstruct_chunk, plan_chunks, reconstruct_distributed
    from spikeref.io.dat import write_dat
    from spikeref.pipeline import ReconstructParams, frame_range

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--planes", type=int, default=600)
    ap.add_argument("--chunk-frames", type=int, default=8)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    base = rng.random((128, 160)) * 0.5 + 0.05
    rates = np.stack([np.roll(base, t // 10, axis=1)[:, :128] for t in range(args.planes)])
    spikes = (rng.random(rates.shape) < rates).astype(np.uint8)
    params = ReconstructParams()
    frames = frame_range(args.planes)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        path = tmp / "moving.dat"
        write_dat(path, spikes)
        (tmp / "moving.json").write_text('{"height": 128, "width": 128, "cfa": "RGGB"}')
        t0 = time.perf_counter()
        (chunk,) = plan_chunks(frames, params, len(frames))
        reconstruct_chunk(str(path), {}, params, chunk, str(tmp / "single"))
        single = len(frames) / (time.perf_counter() - t0)
        print(f"{len(frames)} frames of 128×128 (W=10, K=3, L=3), chunks of {args.chunk_frames} frames")
        print(f"  one process, no Dask:   {single:6.2f} frames/s")
        fps = {}
        for n in (1, 2):
            t0 = time.perf_counter()
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0")
            client = Client(cluster)
            client.submit(_noop, pure=False).result()
            start = time.perf_counter() - t0
            t0 = time.perf_counter()
            client.gather([client.submit(_noop, pure=False) for _ in range(200)])
            noop_ms = (time.perf_counter() - t0) / 200 * 1e3
            t0 = time.perf_counter()
            s = reconstruct_distributed(path, tmp / f"w{n}", params, client=client, chunk_frames=args.chunk_frames,
                                        progress=False)
            wall = time.perf_counter() - t0
            fps[n] = len(frames) / wall
            busy = sum(x["seconds"] for x in s)
            peaks = {x["pid"]: x["peak_rss_mib"] for x in s}
            print(f"  {n} worker(s): {fps[n]:6.2f} frames/s ({wall:.1f} s; {len(s)} chunks, {busy:.1f} s inside "
                  f"tasks; cluster start {start:.1f} s; empty-task round trip {noop_ms:.1f} ms; "
                  f"overhead per chunk {(wall * n - busy) / len(s) * 1e3:.0f} ms); peak memory per worker "
                  + ", ".join(f"{v:.0f} MiB" for v in peaks.values()))
            client.close()
            cluster.close()
        print(f"  2 workers / 1 worker: {fps[2] / fps[1]:.2f}×; 2 workers / one process: {fps[2] / single:.2f}×")


if __name__ == "__main__":
    main()
