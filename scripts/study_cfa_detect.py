"""How well the CFA phase is read from the spikes (spikeref.cfa_detect): docs/results.md, "CFA phase detection".

    python scripts/study_cfa_detect.py [--sets dev,heldout,real,cost] [--out DIR]

* ``dev`` — the development set (the thresholds were chosen on it): six scikit-image photographs panning
  (``scripts/cfa_scenes/dev_photo_pan.toml`` with each photograph) and four procedural scenes of
  ``examples/scenes`` (colour chart, translating texture, HDR lamp, low light), 128×160, 400 planes, each
  simulated in the four CFA phases (seed 0), and once more through a monochrome sensor (``cfa = "mono"``).
* ``heldout`` — fixed on 2026-11-27 before any threshold was chosen and never used to choose one: a pan over
  scikit-image's ``chelsea`` and one over ``motorcycle_left`` (``scripts/cfa_scenes/heldout_*.toml``) and the
  fan over toys (``examples/scenes/fan.toml`` at 128×160, 400 planes), each in the four phases (seed 11).
* ``real`` — the real monochrome recordings of ``../shared/data/real`` (SpikingSIM's, planes last; Spike-Zoo's
  UHSR) and the simulated REDS ``.dat`` there (250×400, mono).
* ``cost`` — :func:`spikeref.cfa_detect.detect_cfa` on a 1000×1000 packed ``.dat`` of 1000 random planes and on
  the 250×400 ``.dat``, and ``spikeref info --json`` on both (whole process).

Every recording is read by ``detect_cfa`` at its defaults (the first 1000 planes: all 400 here), and the development
recordings once more from their first 100 and 25 planes only (``--short``).  "prior held"
says whether red is the brighter of the red and blue phases in truth (the warm-world prior).  Writes
``cfa_detect.csv`` to ``--out`` (default ``cfa_detect_study/``) and prints the tables.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from spikeref.cfa_detect import detect_cfa, green_diagonal
from spikeref.simulate import load_scene, simulate
from spikeref.stream import load_spikes, read_dat

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT.parent / "shared" / "data" / "real"
PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")
SIZE = {"height": 128, "width": 160}
PLANES = 400

#: Development photographs and the scale that shows each at about 256 pixels on its short side.
DEV_PHOTOS = {"astronaut": 0.5, "coffee": 0.5, "rocket": 0.5, "hubble_deep_field": 0.25, "ihc": 0.5, "retina": 0.2}
DEV_PROCEDURAL = ("color_chart", "translating_texture", "hdr_lamp", "low_light")
#: The held-out recordings: (name, scene file, overrides), simulated in each phase with seed 11.
HELDOUT = (
    ("chelsea pan", ROOT / "scripts" / "cfa_scenes" / "heldout_chelsea_pan.toml", {}),
    ("motorcycle_left pan", ROOT / "scripts" / "cfa_scenes" / "heldout_motorcycle_pan.toml", {}),
    ("fan", ROOT / "examples" / "scenes" / "fan.toml", {"planes": PLANES, "content": dict(SIZE)}),
)


def _dev_scenes():
    for name, scale in DEV_PHOTOS.items():
        yield f"{name} pan", ROOT / "scripts" / "cfa_scenes" / "dev_photo_pan.toml", \
            {"content": {"path": f"skimage:{name}", "scale": scale}}
    for name in DEV_PROCEDURAL:
        yield name, ROOT / "examples" / "scenes" / f"{name}.toml", {"planes": PLANES, "content": dict(SIZE)}


def _merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _row(group: str, scene: str, truth: str, guess, seconds: float) -> dict:
    m = guess.phase_means
    row = {"set": group, "scene": scene, "truth": truth, "detected": guess.pattern,
           "confidence": round(guess.confidence, 4), "green_confidence": round(guess.green_confidence, 4),
           "corr_main": round(guess.corr_main, 4), "corr_anti": round(guess.corr_anti, 4),
           "phase_means": " ".join(f"{v:.5f}" for v in m), "planes": guess.planes,
           "texture_z": round(guess.texture_z, 2), "means_z": round(guess.means_z, 2),
           "colour_z": round(guess.colour_z, 2), "seconds": round(seconds, 4)}
    if truth == "mono":
        row.update(green_right=guess.pattern == "mono", exact=guess.pattern == "mono", prior_held="")
    else:
        red, blue = m[truth.index("R")], m[truth.index("B")]
        row.update(green_right=guess.pattern != "mono" and green_diagonal(guess.pattern) == green_diagonal(truth),
                   exact=guess.pattern == truth, prior_held=bool(red > blue))
    return row


def _simulated(group: str, scenes, seed: int, phases, short=()) -> list[dict]:
    """Rows of ``group`` (every recording read at the defaults) and of ``group (N planes)`` for each ``N`` of
    ``short`` (the same recordings, only their first ``N`` planes read: fewer spikes, noisier textures)."""
    rows = []
    for name, path, overrides in scenes:
        for cfa in phases:
            scene = load_scene(path, overrides=_merge(overrides, {"camera": {"cfa": cfa}}))
            spikes = simulate(scene, seed=seed).spikes
            t0 = time.perf_counter()
            guess = detect_cfa(spikes)
            rows.append(_row(group, name, cfa, guess, time.perf_counter() - t0))
            for n in short:
                rows.append(_row(f"{group} ({n} planes)", name, cfa, detect_cfa(spikes, planes=n), 0.0))
            print(f"  {group:8s} {name:22s} {cfa:5s} → {guess.pattern:5s} {guess.confidence:.2f} "
                  f"(green {guess.green_confidence:.3f}; corr {guess.corr_main:.2f} / {guess.corr_anti:.2f})",
                  file=sys.stderr, flush=True)
    return rows


def _real() -> list[dict]:
    if not REAL.is_dir():
        print(f"  {REAL} is not here: the real recordings are left out", file=sys.stderr)
        return []
    rows = []
    for name, open_it in (
        ("spikingsim_real_spike.npz (--axes HWT)", lambda: load_spikes(REAL / "spikingsim_real_spike.npz", axes="HWT")),
        ("spikezoo_uhsr.npz", lambda: load_spikes(REAL / "spikezoo_uhsr.npz")),
        ("spikezoo_data_reds_sim_250x400.dat", lambda: read_dat(REAL / "spikezoo_data_reds_sim_250x400.dat", 250, 400)),
    ):
        stream = open_it()
        t0 = time.perf_counter()
        guess = detect_cfa(stream)
        rows.append(_row("real", name, "mono", guess, time.perf_counter() - t0))
    return rows


def _timed(fn, repeats: int = 3) -> tuple[float, float]:
    """(first call, best of the next ``repeats``) in seconds."""
    t0 = time.perf_counter()
    fn()
    first = time.perf_counter() - t0
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return first, best


def _info_seconds(path: Path, *extra: str) -> float:
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "spikeref.cli", "info", str(path), "--json", *extra],
                         capture_output=True, text=True, check=True).stdout
    seconds = time.perf_counter() - t0
    json.loads(out)  # one JSON object, nothing else
    return seconds


def _cost() -> list[str]:
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp) / "random_1000x1000.dat"
        rng = np.random.default_rng(0)
        with open(big, "wb") as fh:  # 1000 planes of random bits, 125 000 bytes each
            for _ in range(10):
                fh.write(rng.integers(0, 256, (100, 125_000), dtype=np.uint8).tobytes())
        (Path(tmp) / "random_1000x1000.json").write_text(json.dumps({"height": 1000, "width": 1000, "cfa": "RGGB"}))
        stream = read_dat(big, 1000, 1000)
        first, best = _timed(lambda: detect_cfa(stream))
        lines.append(f"detect_cfa, 1000×1000, 1000 planes (125 MB packed, page cache warm): first call {first:.3f} s, "
                     f"then {best:.3f} s")
        lines.append(f"spikeref info --json, 1000×1000 (whole process): {_info_seconds(big):.2f} s")
        if REAL.is_dir():
            dat = REAL / "spikezoo_data_reds_sim_250x400.dat"
            small = read_dat(dat, 250, 400)
            first, best = _timed(lambda: detect_cfa(small))
            lines.append(f"detect_cfa, 250×400, 301 planes: first call {first:.3f} s, then {best:.3f} s")
            lines.append(f"spikeref info --json, 250×400 (whole process): {_info_seconds(dat):.2f} s")
    return lines


def _summary(rows: list[dict], group: str) -> str:
    colour = [r for r in rows if r["set"] == group and r["truth"] != "mono"]
    mono = [r for r in rows if r["set"] == group and r["truth"] == "mono"]
    parts = []
    if colour:
        g = sum(r["green_right"] for r in colour)
        e = sum(r["exact"] for r in colour)
        p = sum(r["prior_held"] for r in colour)
        scenes = sorted({r["scene"] for r in colour})
        held = sorted({r["scene"] for r in colour if r["prior_held"]})
        parts.append(f"{group}: green sites right {g}/{len(colour)}, exact pattern {e}/{len(colour)}; "
                     f"red brighter than blue (the prior) in {p}/{len(colour)} recordings, "
                     f"{len(held)}/{len(scenes)} scenes")
        wrong_prior = [s for s in scenes if s not in held]
        if wrong_prior:
            parts.append(f"  the prior fails on: {', '.join(wrong_prior)}")
        said = [r for r in colour if r["detected"] != "mono"]
        if said:
            low = min(r["green_confidence"] for r in said)
            conf = [r["confidence"] for r in said]
            parts.append(f"  read as colour {len(said)}/{len(colour)}; lowest green-sites confidence {low:.3f}; "
                         f"confidence {min(conf):.2f}–{max(conf):.2f}")
        sure_wrong = [r for r in colour if not r["green_right"] and r["green_confidence"] >= 0.99]
        parts.append(f"  green sites wrong with a green-sites confidence ≥ 0.99 (would warn against a right --cfa): "
                     f"{len(sure_wrong)}")
        as_mono = [r for r in colour if r["detected"] == "mono"]
        if as_mono:
            parts.append(f"  read as mono: {len(as_mono)} (confidence {min(r['confidence'] for r in as_mono):.2f}–"
                         f"{max(r['confidence'] for r in as_mono):.2f})")
        gg = [r["corr_main"] if green_diagonal(r["truth"]) == "main" else r["corr_anti"] for r in colour]
        rb = [r["corr_anti"] if green_diagonal(r["truth"]) == "main" else r["corr_main"] for r in colour]
        parts.append(f"  texture correlation of the green sites {min(gg):.2f}–{max(gg):.2f}, of red with blue "
                     f"{min(rb):.2f}–{max(rb):.2f}")
    if mono:
        ok = [r for r in mono if r["detected"] == "mono"]
        parts.append(f"{group}: monochrome recordings read mono {len(ok)}/{len(mono)}"
                     + (f" (confidence {min(r['confidence'] for r in ok):.3f}–{max(r['confidence'] for r in ok):.3f})"
                        if ok else ""))
        colour_said = [r for r in mono if r["detected"] != "mono"]
        if colour_said:
            parts.append(f"  read as colour: {len(colour_said)} (green-sites confidence "
                         f"{max(r['green_confidence'] for r in colour_said):.3f} at most)")
    return "\n".join(parts)


def _table(rows: list[dict]) -> str:
    head = "| set | scene | truth | detected | confidence | green conf. | corr (0,0)/(1,1) | corr (0,1)/(1,0) | " \
           "phase means (0,0) (0,1) (1,0) (1,1) | prior held |"
    out = [head, "|" + " --- |" * (head.count("|") - 1)]
    for r in rows:
        out.append(f"| {r['set']} | {r['scene']} | {r['truth']} | {r['detected']} | {r['confidence']:.2f} | "
                   f"{r['green_confidence']:.3f} | {r['corr_main']:.2f} | {r['corr_anti']:.2f} | {r['phase_means']} | "
                   f"{'' if r['prior_held'] == '' else ('yes' if r['prior_held'] else 'no')} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sets", default="dev,heldout,real,cost", help="comma-separated: dev, heldout, real, cost")
    ap.add_argument("--out", type=Path, default=Path("cfa_detect_study"))
    ap.add_argument("--short", default="100,25",
                    help="comma-separated plane counts at which the development recordings are read again "
                         "(fewer spikes: how the answer and its confidence degrade); '' for none")
    args = ap.parse_args(argv)
    sets = [s.strip() for s in args.sets.split(",") if s.strip()]
    unknown = set(sets) - {"dev", "heldout", "real", "cost"}
    if unknown:
        ap.error(f"unknown set(s): {', '.join(sorted(unknown))}")
    rows: list[dict] = []
    t0 = time.perf_counter()
    short = tuple(int(n) for n in args.short.split(",") if n.strip())
    if "dev" in sets:
        rows += _simulated("dev", list(_dev_scenes()), 0, (*PATTERNS, "mono"), short)
    if "heldout" in sets:
        rows += _simulated("heldout", HELDOUT, 11, PATTERNS)
    if "real" in sets:
        rows += _real()
    cost = _cost() if "cost" in sets else []
    if rows:
        args.out.mkdir(parents=True, exist_ok=True)
        with open(args.out / "cfa_detect.csv", "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        print(_table([r for r in rows if "planes)" not in r["set"]]))  # the short reads: in the CSV and below
        print()
        for group in dict.fromkeys(r["set"] for r in rows):
            print(_summary(rows, group))
    for line in cost:
        print(line)
    print(f"\n{time.perf_counter() - t0:.0f} s in all", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
