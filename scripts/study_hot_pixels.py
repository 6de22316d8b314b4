"""What hot pixels cost the defaults, and what finding and replacing them (spikeref.hot_pixels) gives back.

For each scene, the same simulation (same seed, so the same photons, noise and spikes everywhere else) is
made without hot pixels and with the simulator's ``hot_pixels`` effect at several densities and rates;
each is reconstructed with the defaults (``ReconstructParams()``, ``hot_pixels="auto"``) and with the
handling off (``hot_pixels="off"``), and scored as ``spikeref bench --ladder`` scores its ``ours`` rung
(PSNR of the frame centred on each scored instant against the exact truth of its 10 planes).  The
detection is compared with the simulator's own map (``Simulation(scene, seed).hot``): precision, recall.

Scene sets:

* ``--set heldout`` (default): ``scripts/heldout_scenes/*.toml``, seed 11 — fixed before any tuning of
  the detector and never used to choose its parameters;
* ``--set bench``: ``spikeref/bench/scenes/*.toml``, seed 0 — where the detector's parameters were
  chosen.

    python scripts/study_hot_pixels.py [--set heldout|bench] [--frames 4] [--json out/hot_pixels.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SETS = {"heldout": (ROOT / "scripts" / "heldout_scenes", 11), "bench": (ROOT / "spikeref" / "bench" / "scenes", 0)}
#: (label, hot_pixels effect or None): the issue's case first (0.3 % of pixels at 0.3–0.9 spikes per readout)
CASES = [
    ("clean", None),
    ("0.3% at 0.3-0.9", {"fraction": 0.003, "rate": 0.3, "rate_max": 0.9}),
    ("0.1% at 0.3-0.9", {"fraction": 0.001, "rate": 0.3, "rate_max": 0.9}),
    ("1% at 0.3-0.9", {"fraction": 0.01, "rate": 0.3, "rate_max": 0.9}),
    ("0.3% at 0.1-0.3", {"fraction": 0.003, "rate": 0.1, "rate_max": 0.3}),
]


def _scene(path: Path, hot: dict | None):
    """The scene of ``path`` with its own effects and, if given, the ``hot_pixels`` effect set to ``hot``."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    from spikeref.simulate.scenes import scene_from_dict

    data = tomllib.loads(path.read_text())
    effects = {k: v for k, v in data.get("effects", {}).items() if k != "hot_pixels"}
    if hot is not None:
        effects["hot_pixels"] = hot
    data["effects"] = effects
    return scene_from_dict(data, source=str(path), base_dir=path.parent)


def main(argv=None) -> int:
    from spikeref.bench.ladder import run_ladder
    from spikeref.bench.runner import BenchScene, needs_scikit_image
    from spikeref.hot_pixels import find_hot_pixels
    from spikeref.simulate.simulator import Simulation, simulate

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=sorted(SETS), default="heldout")
    ap.add_argument("--frames", type=int, default=4, help="scored frames per scene")
    ap.add_argument("--cases", default=None, help="comma-separated case numbers (0 = clean), default all")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    folder, seed = SETS[args.set]
    paths = [p for p in sorted(folder.glob("*.toml")) if not needs_scikit_image(p) or _has_skimage()]
    cases = CASES if args.cases is None else [CASES[int(i)] for i in args.cases.split(",")]
    rows = []
    for path in paths:
        for label, hot in cases:
            scene = _scene(path, hot)
            sim = Simulation(scene, seed=seed)
            truth = sim.hot > 0 if sim.hot is not None else np.zeros(sim.shape, bool)
            stream = simulate(scene, seed=seed).stream
            t0 = time.perf_counter()
            found = find_hot_pixels(stream)
            find_s = time.perf_counter() - t0
            row = {"scene": path.stem, "case": label, "hot": int(truth.sum()), "found": int(found.sum()),
                   "true_positives": int((found & truth).sum()), "find_ms": 1000 * find_s}
            for mode in ("auto", "off"):
                sc = BenchScene(path.stem, path, scene, stream)
                res = run_ladder([sc], seed=seed, frames=args.frames, rungs=("ours",), progress=False,
                                 params={"hot_pixels": mode})
                row[f"psnr_{mode}"] = res["rows"][0]["psnr"]
            rows.append(row)
            tp, hot_n, found_n = row["true_positives"], row["hot"], row["found"]
            print(f"{path.stem:32s} {label:16s} hot {hot_n:4d} found {found_n:4d} (tp {tp}) "
                  f"auto {row['psnr_auto']:.2f} off {row['psnr_off']:.2f} dB  find {row['find_ms']:.0f} ms",
                  file=sys.stderr, flush=True)
    print(_table(rows, [c[0] for c in cases]))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


def _has_skimage() -> bool:
    import importlib.util

    return importlib.util.find_spec("skimage") is not None


def _table(rows: list[dict], cases: list[str]) -> str:
    """Per case: the loss against the clean scene with the handling on (auto) and off, and the detection."""
    clean = {r["scene"]: r for r in rows if r["case"] == "clean"}
    lines = ["| scene | case | hot pixels | found | precision | recall | auto − clean (dB) | off − clean (dB) |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        base = clean.get(r["scene"])
        ref = base["psnr_auto"] if base else float("nan")
        prec = r["true_positives"] / r["found"] if r["found"] else float("nan")
        rec = r["true_positives"] / r["hot"] if r["hot"] else float("nan")
        lines.append(f"| {r['scene']} | {r['case']} | {r['hot']} | {r['found']} | {prec:.3f} | {rec:.3f} | "
                     f"{r['psnr_auto'] - ref:+.2f} | {r['psnr_off'] - ref:+.2f} |")
    lines += ["", "| case | mean auto − clean (dB) | worst auto − clean | mean off − clean | worst off − clean |",
              "|---|---:|---:|---:|---:|"]
    for case in cases:
        d_auto = [r["psnr_auto"] - clean[r["scene"]]["psnr_auto"] for r in rows if r["case"] == case
                  and r["scene"] in clean]
        d_off = [r["psnr_off"] - clean[r["scene"]]["psnr_auto"] for r in rows if r["case"] == case
                 and r["scene"] in clean]
        if d_auto:
            lines.append(f"| {case} | {np.mean(d_auto):+.3f} | {min(d_auto):+.3f} | {np.mean(d_off):+.3f} | "
                         f"{min(d_off):+.3f} |")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
