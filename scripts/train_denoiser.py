"""Reproduce the bundled denoiser weights (``spikeref/denoise/weights/``).

1. Simulate the training scenes ``scripts/denoiser_scenes/train_*.toml`` (seed 7) into
   ``--data-dir`` unless the files are there (the held-out ``heldout_*.toml`` scenes are never
   trained on: ``scripts/eval_denoiser.py`` scores them).
2. Train one network per ``--channels`` width with ``spikeref train`` — all widths at once, on
   one GPU if there is one — and write ``b2u_w<C>.npz`` (+ checkpoint and log) into ``--out``.

``--steps`` fixes the step count (the bundled weights' counts are in ``docs/results.md`` and in
each file's metadata).  Without it, ``--budget-s`` seconds are shared: a 40-step probe of every
width measures the step time and the step counts are chosen to fill the budget; the commands
actually run are printed, so a run can be repeated with fixed steps.  (On a GPU the probe's
first steps include cuDNN's autotuning: it over-estimates the step time about 3×.)

The bundled files (2026-11-23, one H100, ``docs/results.md``):

    # b2u_w16.npz — counts (the default input domain), lr 1e-3, 2800-step schedule stopped
    # after step 2200 (the GPU machine's time limit ended the run), exported from that checkpoint:
    spikeref train .train_data/train_*.dat -o b2u_w16.npz --channels 16 --steps 2800 \
        --lr 1e-3 --checkpoint-every 100 --stop-after 2200
    # b2u_w32.npz — rates, before counts became the default:
    spikeref train .train_data/train_*.dat -o b2u_w32.npz --channels 32 --steps 2300 --input-domain rate

    python scripts/train_denoiser.py --steps 6000 --channels 32 --lr 1e-3 --out out/weights
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scripts" / "denoiser_scenes"
SEED = 7


def simulate_missing(data_dir: Path) -> list[Path]:
    data_dir.mkdir(parents=True, exist_ok=True)
    out = []
    for scene in sorted(SCENES.glob("train_*.toml")):
        dat = data_dir / (scene.stem + ".dat")
        if not dat.is_file():
            subprocess.run([sys.executable, "-m", "spikeref.cli", "simulate", str(scene), "-o", str(dat),
                            "--seed", str(SEED)], check=True)
        out.append(dat)
    return out


def command(data, channels, steps, output, extra=(), lr=None):
    return [sys.executable, "-m", "spikeref.cli", "train", *map(str, data), "-o", str(output),
            "--channels", str(channels), "--steps", str(steps), *(["--lr", str(lr)] if lr else []), *extra]


def run_all(commands, logs):
    procs = []
    for cmd, log in zip(commands, logs, strict=True):
        print(" ".join(cmd[2:]).replace("spikeref.cli", "spikeref"), flush=True)
        procs.append(subprocess.Popen(cmd, stdout=open(log, "w"), stderr=subprocess.STDOUT))
    codes = [p.wait() for p in procs]
    for log, code in zip(logs, codes, strict=True):
        if code:
            print(Path(log).read_text()[-3000:], file=sys.stderr)
            raise SystemExit(f"training failed ({log})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data-dir", type=Path, default=ROOT / ".train_data")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "weights")
    ap.add_argument("--channels", default="32", help="comma-separated U-Net widths")
    ap.add_argument("--steps", type=int, default=None, help="fixed step count (else fill --budget-s)")
    ap.add_argument("--budget-s", type=float, default=480.0, help="seconds for probe + training")
    ap.add_argument("--lr", type=float, default=None, help="learning rate (default: spikeref train's)")
    args = ap.parse_args()
    t0 = time.time()
    widths = [int(c) for c in args.channels.split(",")]
    data = simulate_missing(args.data_dir)
    args.out.mkdir(parents=True, exist_ok=True)
    steps = {c: args.steps for c in widths}
    if args.steps is None:
        probe = 40
        logs = [args.out / f"probe_w{c}.log" for c in widths]
        run_all([command(data, c, probe, args.out / f"probe_w{c}.npz", ["--checkpoint-every", "100000"])
                 for c in widths], logs)
        # "wrote …: 40 steps in 4.2 s" — training time without start-up, all widths running at once
        per_step = {c: float(re.search(r"steps in ([0-9.]+) s", log.read_text()).group(1)) / probe
                    for c, log in zip(widths, logs, strict=True)}
        left = args.budget_s - (time.time() - t0) - 40.0  # start-up and export
        steps = {c: max(100, int(left / per_step[c] * 0.9) // 100 * 100) for c in widths}
        print(f"probe: seconds per step {per_step} with {len(widths)} run(s) at once; steps {steps}", flush=True)
        for c in widths:
            for suffix in (".npz", ".npz.ckpt", ".log"):
                (args.out / f"probe_w{c}{suffix}").unlink(missing_ok=True)
    run_all([command(data, c, steps[c], args.out / f"b2u_w{c}.npz", lr=args.lr) for c in widths],
            [args.out / f"train_w{c}.log" for c in widths])
    print(f"done in {time.time() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main()
