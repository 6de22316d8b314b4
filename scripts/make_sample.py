"""Build the embedded sample ``spikeref/data/sample.dat`` (+ ``sample.json``).

A small chromatic spike stream: colour bars with a bright disc moving across
them, seen by an RGGB spike camera (Eq. 1–3, noise-free, random initial
phase with a fixed seed).  Deterministic: running this script again rebuilds
the same bytes.  Usage::

    python scripts/make_sample.py [--out spikeref/data]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from spikeref.io.dat import write_dat
from spikeref.simulate.camera import Camera, fire, mosaic_radiance

HEIGHT, WIDTH, PLANES, SEED = 128, 160, 400, 7


def radiance(t: int) -> np.ndarray:
    """Linear RGB ``(H, W, 3)`` at readout ``t`` (charge per readout, ≤ 1)."""
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    bars = np.array([[0.9, 0.9, 0.9], [0.9, 0.8, 0.1], [0.1, 0.8, 0.8], [0.1, 0.7, 0.1],
                     [0.8, 0.1, 0.8], [0.8, 0.1, 0.1], [0.1, 0.1, 0.8], [0.05, 0.05, 0.05]])
    img = bars[np.minimum((x * len(bars) / WIDTH).astype(int), len(bars) - 1)] * 0.5
    img *= (0.3 + 0.7 * y / HEIGHT)[..., None]  # vertical shading: low light at the top
    cx, cy = 20 + 0.3 * t, HEIGHT / 2 + 25 * np.sin(t / 60)  # 0.3 px per readout = 6000 px/s
    disc = (x - cx) ** 2 + (y - cy) ** 2 < 14**2
    img[disc] = [0.95, 0.6, 0.3]
    return img


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "spikeref" / "data")
    args = parser.parse_args(argv)
    camera = Camera(cfa="RGGB")
    rng = np.random.default_rng(SEED)
    state = rng.uniform(0, camera.threshold, (HEIGHT, WIDTH))
    charge = np.stack([mosaic_radiance(radiance(t), camera.cfa) for t in range(PLANES)]) * camera.alpha
    spikes = fire(charge, camera.threshold, state)
    args.out.mkdir(parents=True, exist_ok=True)
    write_dat(args.out / "sample.dat", spikes)
    meta = {"height": HEIGHT, "width": WIDTH, "cfa": camera.cfa, "rate_hz": camera.rate_hz,
            "planes": PLANES, "made_by": "scripts/make_sample.py", "seed": SEED}
    (args.out / "sample.json").write_text(json.dumps(meta, indent=2) + "\n")
    print(f"wrote {args.out / 'sample.dat'}: {PLANES} planes of {HEIGHT}×{WIDTH}, mean rate {spikes.mean():.3f}")


if __name__ == "__main__":
    main()
