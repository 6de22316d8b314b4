"""The real outdoor recording as a user runs it: ``spikeref reconstruct`` on the whole file, scored from its EXRs.

The SpikingSIM outdoor recording (``../shared/data/real/spikingsim_real_spike.npz``, 500 planes of 250×400 stored
planes-last, monochrome, near-static) goes through the command line exactly as a user would give it::

    spikeref reconstruct spikingsim_real_spike.npz --axes HWT --frames 3:23 --exr-dir DIR [options]

and every EXR frame is scored against the pseudo ground truth, the mean of planes 300–500 with the recording's four
hot pixels repaired by their neighbours (``HotPixelRepair(find_hot_pixels(all 500 planes))``), by
``spikeref.metrics.psnr_after_gain`` (one least-squares gain, data range the truth's peak).  Rows: frames 3–22
(the first 20 frames, the whole image: the scoring that gives the figure filed with the adaptive merge's issue,
48.58 dB at the defaults of 2026-11-27, 48.69 without the denoiser, reproduced here to 0.01 dB by those defaults
with this script) and frames 3–19 (those whose adaptive support, ±10 windows, ends by plane 300: no planes shared
with the truth), each with no border and an 8-pixel border left out.

The stream reader sees the whole recording, as the user's command does: a window charge near a frame's last window
reads spike times past it (``spikeref.charge``, up to 200 readouts), so a stream cut at plane 120 or 300 (the
test's and ``scripts/study_never_worse.py``'s scorings) gives other figures for the same frames.

    python scripts/eval_real_cli.py [--variants default,no-denoiser,binomial,paper]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REAL = ROOT.parent / "shared" / "data" / "real" / "spikingsim_real_spike.npz"
FRAMES = range(3, 23)
DISJOINT = range(3, 20)  # frame k's adaptive support (±10 windows of 10 planes) ends at plane 10(k + 11) ≤ 300
VARIANTS = {"default": [], "no-denoiser": ["--no-denoiser"], "binomial": ["--merge", "binomial"],
            "paper": ["--paper"]}


def pseudo_truth() -> np.ndarray:
    """The mean of planes 300–500, the four hot pixels repaired (``(250, 400) float64``)."""
    from spikeref.hot_pixels import HotPixelRepair, find_hot_pixels

    with np.load(REAL) as data:
        spikes = np.ascontiguousarray(data["arr_0"].transpose(2, 0, 1))
    return HotPixelRepair(find_hot_pixels(spikes)).mosaic(spikes[300:500].mean(axis=0, dtype=np.float64))


def score(truth: np.ndarray, image: np.ndarray, border: int) -> float:
    from spikeref.metrics import psnr_after_gain

    crop = (slice(border, truth.shape[0] - border), slice(border, truth.shape[1] - border))
    t = truth[crop]
    return psnr_after_gain(t, np.asarray(image, np.float64)[crop], float(t.max()))


def run_variant(options: list[str], out: Path) -> dict[int, np.ndarray]:
    """``{frame: (H, W) image}`` written by ``spikeref reconstruct`` (its grey frames' first channel)."""
    from spikeref.io.exr import read_exr

    cli = "import sys; from spikeref.cli import main; sys.exit(main())"  # the `spikeref` entry point
    cmd = [sys.executable, "-c", cli, "reconstruct", str(REAL), "--axes", "HWT", "--frames",
           f"{FRAMES.start}:{FRAMES.stop}", "--exr-dir", str(out), "--output", str(out / "video.mp4"), *options]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    frames = {}
    for k in FRAMES:
        rgb = read_exr(out / f"frame_{k:06d}.exr")
        frames[k] = rgb[..., 0] if rgb.ndim == 3 else rgb
    return frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", default="default,no-denoiser,binomial,paper")
    args = ap.parse_args()
    if not REAL.is_file():
        raise SystemExit(f"{REAL} is not here")
    truth = pseudo_truth()
    print(f"{'variant':14s} {'3–22':>7s} {'3–22 b8':>8s} {'3–19':>7s} {'3–19 b8':>8s}   (dB)")
    for name in args.variants.split(","):
        with tempfile.TemporaryDirectory() as tmp:
            frames = run_variant(VARIANTS[name], Path(tmp))
        cells = [np.mean([score(truth, frames[k], b) for k in rows]) for rows in (FRAMES, DISJOINT) for b in (0, 8)]
        print(f"{name:14s} " + " ".join(f"{c:7.2f}" for c in cells), flush=True)


if __name__ == "__main__":
    main()
