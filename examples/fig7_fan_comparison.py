"""The paper's Fig. 7 and Fig. 5 on a simulated fan: baselines, ours and the ground truth, then the steps.

Simulates the fan-over-toys scene (``examples/scenes/fan.toml``, 256×256, RGGB, realistic
noise), reconstructs one frame with the progressive warping (W = 10, K = 3, L = 3, bundled
denoiser) and writes, into ``--out`` (default ``out/examples``):

* ``fig7_fan.png`` — TFP(W=10), TFP(W=100), TFI, TFSTP, ours and the ground truth, side by
  side, all through one exposure, with PSNR/SSIM against the ground truth printed
  (:mod:`spikeref.metrics`, the truth's peak as the data range, as ``spikeref bench``);
* ``fig5_steps.png`` — the progressive steps ``R_0 … R_L`` of the same frame (Fig. 5).

Every image is taken at the same instant: the centre of window ``k`` (planes ``[kW, (k+1)W)``).
TFP(W=100) is the mean over the 100 planes centred there; TFI and TFSTP are read at the
window's centre plane.  Run from the repository root::

    python examples/fig7_fan_comparison.py
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    import imageio.v3 as iio

    from spikeref.baselines import tfi, tfstp
    from spikeref.metrics import psnr, ssim
    from spikeref.bayer import demosaic_bilinear
    from spikeref.accumulate import accumulate
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.simulate.scenes import load_scene
    from spikeref.simulate.simulator import simulate
    from spikeref.tonemap import choose_exposure, tonemap

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "examples")
    ap.add_argument("--frame", type=int, default=12, help="frame number k (window k is its centre)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    W, K, L = 10, 3, 3
    k = args.frame
    scene = load_scene(ROOT / "examples" / "scenes" / "fan.toml")
    planes = (k + 8) * W  # the support of frame k (k ± 3 windows) and TFP(W=100) around it
    result = simulate(scene, seed=args.seed, planes=planes, progress=True)
    stream = result.stream
    cfa = stream.cfa
    centre = k * W + W // 2

    rec = Reconstructor(stream, ReconstructParams(window=W, K=K, L=L))
    (ours,) = list(rec.frames(k, k + 1, keep_steps=True))
    images = {
        "TFP (W=10)": demosaic_bilinear(accumulate(stream, W, start=k * W, count=1)[0], cfa),
        "TFP (W=100)": demosaic_bilinear(accumulate(stream, 100, start=centre - 50, count=1)[0], cfa),
        "TFI": demosaic_bilinear(tfi(stream, times=[centre])[0], cfa),
        "TFSTP": demosaic_bilinear(tfstp(stream, times=[centre])[0], cfa),
        "ours": ours.rgb,
        "ground truth": result.ground_truth(W)[k],
    }
    gt = images["ground truth"]
    exposure = choose_exposure(gt[None])
    peak = float(gt.max())  # scored as spikeref bench does: linear RGB, the truth's peak as the data range
    for name, img in images.items():
        if name != "ground truth":
            print(f"{name:>14}: PSNR {psnr(gt, img, peak):6.2f} dB  SSIM {ssim(gt, img, peak):.3f}")

    def strip(imgs, titles, path):
        tiles = [tonemap(np.clip(im, 0, None), exposure) for im in imgs]
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            fig, axes = plt.subplots(1, len(tiles), figsize=(2.6 * len(tiles), 2.9))
            for ax, tile, title in zip(axes, tiles, titles, strict=True):
                ax.imshow(tile)
                ax.set_title(title, fontsize=9)
                ax.axis("off")
            fig.tight_layout()
            fig.savefig(path, dpi=110)
            plt.close(fig)
        except ImportError:  # without the 'plot' extra: the tiles side by side, in the order printed
            iio.imwrite(path, np.concatenate(tiles, axis=1))
        print("wrote", path, "—", ", ".join(titles))

    strip(list(images.values()), list(images), args.out / "fig7_fan.png")
    strip(ours.steps + [gt], [f"R_{level} ({(K - 1) * level + 1}·W planes)" for level in range(L + 1)]
          + ["ground truth"], args.out / "fig5_steps.png")


if __name__ == "__main__":
    main()
