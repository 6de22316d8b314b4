"""The pseudo-exposure of each pixel under the adaptive merge, beside the frame: where the scene moved, it is short.

Reconstructs frame ``--frame`` of the embedded sample (the fan over toys) with ``ReconstructParams(merge=...)``
and draws, left to right: the frame (one exposure, sRGB), the planes merged per pixel of the plane grid
(``ReconstructedFrame.exposure``) and, for reference, Eq. 14–15's fixed 52 planes.  Needs matplotlib.

    python scripts/plot_merge_exposure.py [--frame 12] [--merge adaptive] [--out docs/merge_exposure.png]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def main(argv=None) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.sample import load_sample
    from spikeref.tonemap import choose_exposure, tonemap

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frame", type=int, default=12)
    ap.add_argument("--merge", choices=("robust", "adaptive"), default="adaptive")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "merge_exposure.png")
    args = ap.parse_args(argv)
    stream = load_sample()
    params = ReconstructParams(merge=args.merge)
    frame = next(Reconstructor(stream, params).frames(args.frame, args.frame + 1))
    fixed = 27 ** 2 / 141 * params.window
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.4))
    axes[0].imshow(tonemap(frame.rgb, choose_exposure(frame.rgb)))
    axes[0].set_title(f"frame {args.frame} of the sample, merge={args.merge}")
    im = axes[1].imshow(frame.exposure, cmap="magma", vmin=0)
    axes[1].set_title(f"planes merged per pixel (Eq. 14–15: {fixed:.0f} everywhere)")
    fig.colorbar(im, ax=axes[1], fraction=0.046, label="planes (W × effective windows)")
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    e = frame.exposure
    print(f"wrote {args.out}: planes per pixel median {np.median(e):.0f}, 10th percentile {np.percentile(e, 10):.0f}, "
          f"90th {np.percentile(e, 90):.0f}, max {e.max():.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
