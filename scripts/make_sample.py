"""Rebuild the embedded sample ``spikeref/data/sample.dat`` (+ ``sample.json``) from ``sample.toml``.

The sample is the fan-over-toys scene (the paper's Fig. 7a setting) seen by an RGGB spike
camera with realistic noise, simulated by :mod:`spikeref.simulate` with a fixed seed, so
running this again rebuilds the same bytes.  Its ground truth is not stored: it is computed
exactly from the same scene file by :func:`spikeref.sample.sample_ground_truth`.  Usage::

    python scripts/make_sample.py [--out spikeref/data]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from spikeref.stream import read_dat
from spikeref.simulate.recording import simulate_to_dat
from spikeref.simulate.scenes import load_scene

SEED = 2024
DATA = Path(__file__).resolve().parents[1] / "spikeref" / "data"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=DATA)
    args = parser.parse_args(argv)
    scene = load_scene(DATA / "sample.toml")
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out / "sample.dat"
    meta = simulate_to_dat(scene, out, seed=SEED, progress=True)
    meta["scene_file"] = "sample.toml"
    meta["made_by"] = "scripts/make_sample.py"
    (args.out / "sample.json").write_text(json.dumps(meta, indent=2) + "\n")
    spikes = read_dat(out, meta["height"], meta["width"]).window(0, meta["planes"])
    size = out.stat().st_size
    print(f"wrote {out}: {meta['planes']} planes of {meta['height']}×{meta['width']}, {size / 1e6:.2f} MB, "
          f"mean rate {np.mean(spikes):.3f} spikes/readout")


if __name__ == "__main__":
    main()
