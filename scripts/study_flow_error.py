"""Where the flow's end-point error is: binned by the distance to the nearest motion edge.

``python scripts/study_flow_error.py [--scene occlusion] [--seed 0]`` runs the default reconstruction
(W/K/L = 10/3/3, the bundled network) on one benchmark scene at the ladder's four scored frames, keeps
every step's flows and compares each with the scene's exact flow (:func:`spikeref.simulate.motion.plane_flow`;
occluded pixels and a 4-pixel border left out, as the ladder does).  A pixel's distance to a motion edge
is its distance to the nearest pixel where the true flow changes by more than 0.05 plane px to a
neighbour, or that is occluded.  Prints, per step, the mean error, its median and 90th percentile, and
per band of distance the mean error and the shares of pixels and of error.  Needs the test extra (the
scene's photograph comes from scikit-image).
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.ndimage import distance_transform_edt

from spikeref.bench.runner import bench_scenes, score_centres
from spikeref.denoise.denoiser import Denoiser, bundled_weights
from spikeref.pipeline import ReconstructParams, Reconstructor
from spikeref.simulate.motion import plane_flow

BANDS = ((0, 4), (4, 8), (8, 16), (16, 32), (32, np.inf))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="occlusion", help="a benchmark scene with a motion model (default occlusion)")
    ap.add_argument("--seed", type=int, default=0, help="simulation seed (default 0, the ladder's)")
    args = ap.parse_args(argv)
    sc = bench_scenes([args.scene])[0]
    sc.simulate(args.seed)
    params = ReconstructParams()
    w = params.window
    centres = score_centres(len(sc.stream), 4)
    offset = (centres[0] - w // 2) % w
    view = sc.stream.slice(offset)
    ks = {(t - w // 2 - offset) // w for t in centres}
    rec = Reconstructor(view, params, Denoiser.load(bundled_weights(params.accumulate)))
    errors: dict[int, list] = {}
    for frame in rec.frames(min(ks), max(ks) + 1, keep_steps=True):
        if frame.index not in ks:
            continue
        t_ref = offset + (frame.index + 0.5) * w
        for (step, i), flow in frame.flows.items():
            true, visible = plane_flow(sc.scene.content, t_ref, t_ref + i * w)
            if true is None:
                raise SystemExit(f"{args.scene} has no motion model: no exact flow to compare with")
            err = np.hypot(flow[0] - true[0], flow[1] - true[1])
            change = sum(np.hypot(*(np.diff(true[c], axis=a, append=np.take(true[c], [-1], axis=a))
                                    for c in (0, 1))) for a in (0, 1))
            dist = distance_transform_edt(~((change > 0.05) | ~visible))
            b = slice(4, -4)
            keep = visible[b, b]
            errors.setdefault(step, []).append((err[b, b][keep], dist[b, b][keep]))
    for step in sorted(errors):
        e = np.concatenate([x[0] for x in errors[step]])
        d = np.concatenate([x[1] for x in errors[step]])
        p50, p90 = np.percentile(e, [50, 90])
        print(f"step {step}: mean {e.mean():.3f}, median {p50:.3f}, 90th percentile {p90:.3f} plane px")
        for lo, hi in BANDS:
            m = (d >= lo) & (d < hi)
            if m.any():
                print(f"    {lo:>3}–{hi:<4} px from a motion edge: {e[m].mean():.3f} "
                      f"({100 * m.mean():.0f} % of pixels, {100 * e[m].sum() / e.sum():.0f} % of the error)")


if __name__ == "__main__":
    main()
