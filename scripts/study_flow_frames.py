"""What the flow is estimated on: the denoised frames (the paper) or Gaussian-smoothed raw frames.

For each benchmark scene (``spikeref.bench``, seed 0, 4 scored frames) and four settings of
the method (visible; W/K/L = 10/3/3, 10/5/2, 20/5/2, 20/3/3), the mean PSNR and seconds per
frame with ``flow_frames="denoised"`` and with ``flow_frames="smoothed"`` at each σ of
``--sigmas`` (plane pixels; 0 = the raw luma).  This is how
:data:`spikeref.pipeline_params.FLOW_SMOOTHING_SIGMA` was chosen (docs/results_history.md, 2026-11-23).

    python scripts/study_flow_frames.py [--sigmas 0,0.7,1,1.5]
"""

from __future__ import annotations

import argparse

import numpy as np


def main() -> None:
    import spikeref.pipeline_params as pipeline_params
    from spikeref.bench.runner import _score, bench_scenes, run_setting, score_centres
    from spikeref.bench.settings import Setting
    from spikeref.denoise.denoiser import Denoiser

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sigmas", default="0,0.7,1,1.5", help="σ values of the smoothed flow frames, plane pixels")
    args = ap.parse_args()
    sigmas = [float(v) for v in args.sigmas.split(",")]
    settings = [(10, 3, 3), (10, 5, 2), (20, 5, 2), (20, 3, 3)]
    variants = [("denoised", None)] + [(f"smoothed σ={s:g}", s) for s in sigmas]
    den = Denoiser.load()
    default_sigma = pipeline_params.FLOW_SMOOTHING_SIGMA
    scores = {}
    try:
        for sc in bench_scenes():
            sc.simulate(0)
            centres = score_centres(len(sc.stream), 4)
            refs = [sc.reference(c) for c in centres]
            for w, k, level in settings:
                for name, sigma in variants:
                    if sigma is not None:
                        pipeline_params.FLOW_SMOOTHING_SIGMA = sigma
                    setting = Setting("ours", w, K=k, L=level, flow_frames="denoised" if sigma is None else "smoothed")
                    frames, timing = run_setting(setting, sc.stream, centres, den, accumulate="count")
                    psnr = float(np.mean([_score(r, f)["psnr"] for r, f in zip(refs, frames, strict=True)]))
                    scores[(w, k, level, name, sc.key)] = (psnr, timing["seconds_per_frame"])
                    print(f"{sc.key:12s} W={w} K={k} L={level} {name:16s} {psnr:6.2f} dB "
                          f"{timing['seconds_per_frame']:.4f} s/frame", flush=True)
            sc.stream = None
    finally:
        pipeline_params.FLOW_SMOOTHING_SIGMA = default_sigma
    print("\n| W/K/L | " + " | ".join(name for name, _ in variants) + " |")
    print("|---|" + "---|" * len(variants))
    for w, k, level in settings:
        cells = []
        for name, _ in variants:
            vals = [v for key, v in scores.items() if key[:4] == (w, k, level, name)]
            cells.append(f"{np.mean([v[0] for v in vals]):.2f} dB, {np.mean([v[1] for v in vals]):.3f} s")
        print(f"| {w}/{k}/{level} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
