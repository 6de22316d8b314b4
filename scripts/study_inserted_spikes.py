"""Does a sensor insert whole spikes into a pixel's regular train?  Real recordings against the simulator.

The simulator's dark current (``spikeref.simulate.effects.DarkCurrent``, Eq. 5–6 with ``α = E_th``) adds a whole
threshold of charge per dark photon: the pixel fires one extra spike and its integrate-and-fire phase goes on
unchanged, so one interval of its near-periodic train splits into two that add up to the period.  A filter that
removed such spikes would take the dark floor out of the frames, if real sensors made them.  This counts them.

For every pixel (every ``--step``-th row and column) whose median inter-spike interval ``P`` is at least 6 readouts
(long enough for a split to be told from jitter), an interval pair ``(a, b)`` is a split when ``|a + b − P| ≤ 1``,
both are at most ``P − 2`` and the intervals on either side are within 1 of ``P``.

    python scripts/study_inserted_spikes.py [--step 3]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REAL = ROOT.parent / "shared" / "data" / "real"
MIN_PERIOD = 6


def splits(spikes: np.ndarray, step: int) -> tuple[int, int, int]:
    """``(pixels, intervals, splits)`` of a ``(T, H, W)`` stream, as the module says."""
    pixels = intervals = found = 0
    on = np.asarray(spikes).astype(bool)
    for y in range(0, on.shape[1], step):
        for x in range(0, on.shape[2], step):
            d = np.diff(np.flatnonzero(on[:, y, x]))
            if len(d) < 7 or np.median(d) < MIN_PERIOD:
                continue
            p = np.median(d)
            pixels += 1
            for i in range(1, len(d) - 2):
                intervals += 1
                a, b = d[i], d[i + 1]
                found += bool(abs(a + b - p) <= 1 and max(a, b) <= p - 2
                              and abs(d[i - 1] - p) <= 1 and abs(d[i + 2] - p) <= 1)
    return pixels, intervals, found


def recordings():
    """``(name, (T, H, W) spikes)``: the real recordings present, then the bench's static and translation scenes."""
    from spikeref.bench.runner import bench_scenes

    real = REAL / "spikingsim_real_spike.npz"
    if real.is_file():
        with np.load(real) as data:
            yield "real: SpikingSIM outdoor", data["arr_0"].transpose(2, 0, 1)
    uhsr = REAL / "spikezoo_uhsr.npz"
    if uhsr.is_file():
        with np.load(uhsr) as data:
            yield "real: Spike-Zoo UHSR", data["spk"]
    for scene in bench_scenes(("static", "translation")):
        scene.simulate(0)
        yield f"simulated: {scene.key}", scene.stream.window(0, len(scene.stream))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--step", type=int, default=3)
    args = ap.parse_args()
    print(f"{'recording':28s} {'pixels':>7s} {'intervals':>10s} {'splits':>7s} {'share':>8s}")
    for name, spikes in recordings():
        n, total, found = splits(spikes, args.step)
        print(f"{name:28s} {n:7d} {total:10d} {found:7d} {found / max(total, 1):8.2%}", flush=True)


if __name__ == "__main__":
    main()
