"""Study: alignment on a real, near-static recording, and the noise-aware options against moving scenes.

Part ``real`` — the SpikingSIM outdoor recording (``../shared/data/real/spikingsim_real_spike.npz``,
key ``arr_0``, uint8 (250, 400, 500) as (H, W, T); monochrome, handled as four 2×2 phases).  The
scene is near-static, so the mean of planes 300–500 is a pseudo ground truth for frames made from
planes 0–200 (disjoint noise).  At W/K/L = 10/3/3 the frames ``k = 3 … 16`` (support in planes
0–200) are scored by :func:`score_real`: PSNR with the pseudo truth's maximum as data range, after
a least-squares gain (one scalar), an 8-pixel border left out, averaged over the frames.  Rows:

* plain accumulation — ``align=False`` with the identity for ``D`` (the same 70-plane support and
  binomial weights as Eq. 14–15);
* ours without the denoiser (``denoiser = identity``) and with the bundled denoiser, for the
  current defaults and for each variant;
* TFP(W=100) — the 100 planes centred on each frame's window (shifted to stay inside 0–200).

and the flow statistics per step (median, 90th and 99th percentile of ``|F_l|`` in plane pixels,
over every pixel of every neighbour of the scored frames, without the denoiser).

Part ``bench`` — the benchmark scenes (``spikeref bench``'s, seed 0): PSNR of the same variants
(with the denoiser and with the identity) at the bench's scored instants, and, where the scene
has a motion model, the flow's end-point error per step against the exact flow
(:func:`spikeref.simulate.motion.plane_flow`; an 8-pixel border and occluded pixels left out, as
``spikeref bench --ladder``).

    python scripts/study_align_real.py [--part real|bench] [--frames 4] [--scenes translation fan …]
                                       [--variants default z3 …]

"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REAL = ROOT.parent / "shared" / "data" / "real" / "spikingsim_real_spike.npz"
BORDER = 8
FRAMES = range(3, 17)  # W/K/L = 10/3/3: the support of frame k is windows k−3 … k+3, inside planes 0–200


def variants() -> dict:
    """Name → ReconstructParams keyword arguments (the first is today's default)."""
    from spikeref.align import AlignParams

    return {
        "default": {},
        "plain (align=False)": {"align": False},
        "debias only": {"align_params": AlignParams(prefer_centre=1e-9)},
        "z2": {"align_params": AlignParams(prefer_centre=2.0)},
        "z3": {"align_params": AlignParams(prefer_centre=3.0)},
        "z4": {"align_params": AlignParams(prefer_centre=4.0)},
        "composed": {"warp": "composed"},
        "composed z3": {"warp": "composed", "align_params": AlignParams(prefer_centre=3.0)},
        "composed plain": {"warp": "composed", "align": False},
        "composed z3 smoothed": {"warp": "composed", "align_params": AlignParams(prefer_centre=3.0),
                                 "flow_frames": "smoothed"},
        "composed z4": {"warp": "composed", "align_params": AlignParams(prefer_centre=4.0)},
        "composed z4 smoothed": {"warp": "composed", "align_params": AlignParams(prefer_centre=4.0),
                                 "flow_frames": "smoothed"},
        "composed z5 smoothed": {"warp": "composed", "align_params": AlignParams(prefer_centre=5.0),
                                 "flow_frames": "smoothed"},
    }


def identity(planes):
    return planes


# ----------------------------------------------------------------------------- real recording
def load_real():
    from spikeref.stream import SpikeStream

    with np.load(REAL) as data:
        spikes = np.ascontiguousarray(data["arr_0"].transpose(2, 0, 1))  # (T, H, W)
    truth = spikes[300:500].mean(axis=0, dtype=np.float64)
    return SpikeStream.from_array(spikes[:200]), truth


def score_real(truth: np.ndarray, image: np.ndarray) -> float:
    """PSNR against the pseudo truth after a least-squares gain, border left out."""
    from spikeref.metrics import psnr_after_gain

    crop = (slice(BORDER, -BORDER), slice(BORDER, -BORDER))
    return psnr_after_gain(truth[crop], np.asarray(image)[crop], float(truth.max()))


def run_real(stream, truth, kw: dict, denoiser, keep_flows: bool = False):
    from spikeref.pipeline import ReconstructParams, Reconstructor

    rec = Reconstructor(stream, ReconstructParams(**{"accumulate": "count", **kw}), denoiser)
    scores, mags = [], {}
    for frame in rec.frames(FRAMES.start, FRAMES.stop, keep_steps=keep_flows):
        scores.append(score_real(truth, frame.rgb))
        for (level, _), f in frame.flows.items():
            mags.setdefault(level, []).append(np.hypot(f[0], f[1]).ravel())
    stats = {lv: tuple(float(np.percentile(np.concatenate(v), q)) for q in (50, 90, 99)) for lv, v in mags.items()}
    return float(np.mean(scores)), stats


def part_real(names, den) -> None:
    stream, truth = load_real()
    tfp = []
    for k in FRAMES:
        start = int(np.clip((k + 0.5) * 10 - 50, 0, len(stream) - 100))
        tfp.append(score_real(truth, stream.window(start, 100).mean(axis=0, dtype=np.float64)))
    print(f"\nReal recording (SpikingSIM outdoor, frames {FRAMES.start}–{FRAMES.stop - 1}, W/K/L = 10/3/3)")
    print(f"{'variant':22s} {'no denoiser':>12s} {'denoiser':>9s}   flow |F_l| (no denoiser): median / p90 / p99 "
          "plane px per step")
    print(f"{'TFP(W=100)':22s} {np.mean(tfp):12.2f}")
    for name in names:
        kw = variants()[name]
        t0 = time.perf_counter()
        s_id, stats = run_real(stream, truth, kw, identity, keep_flows=kw.get("align", True))
        s_den, _ = run_real(stream, truth, kw, den)
        flows = "  ".join(f"F{lv} {a:.2f}/{b:.2f}/{c:.2f}" for lv, (a, b, c) in sorted(stats.items()))
        print(f"{name:22s} {s_id:12.2f} {s_den:9.2f}   {flows}   ({time.perf_counter() - t0:.0f} s)", flush=True)


# ----------------------------------------------------------------------------- bench scenes
def run_scene(sc, centres, kw: dict, denoiser, epe: bool):
    """Frames at the bench's centres (as ``spikeref.bench.runner.run_setting``) and EPE per step."""
    from spikeref.bench.ladder import _epe
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.simulate.motion import plane_flow

    params = ReconstructParams(**{"accumulate": "count", **kw})
    w = params.window
    offset = (centres[0] - w // 2) % w
    view = sc.stream.slice(offset)
    ks = [(t - w // 2 - offset) // w for t in centres]
    rec = Reconstructor(view, params, denoiser)
    frames, errors = [], {}
    for k in ks:
        (frame,) = rec.frames(k, k + 1, keep_steps=epe)
        frames.append(frame.rgb)
        for (level, i), f in frame.flows.items():
            t_ref = offset + (k + 0.5) * w
            true, vis = plane_flow(sc.scene.content, t_ref, t_ref + i * w)
            if true is not None:
                errors.setdefault(level, []).append(_epe(f, true, vis))
    return frames, {lv: float(np.mean(v)) for lv, v in sorted(errors.items())}


def part_bench(names, den, scene_names, n_frames: int) -> None:
    from spikeref.bench.runner import _score, bench_scenes, score_centres

    print(f"\nBenchmark scenes (seed 0, {n_frames} scored frames, W/K/L = 10/3/3): PSNR (dB) with the denoiser | "
          "without; flow EPE per step (plane px, without the denoiser | with)")
    for sc in bench_scenes(scene_names):
        sc.simulate(0)
        centres = score_centres(len(sc.stream), n_frames)
        refs = [sc.reference(t) for t in centres]
        print(f"-- {sc.key}")
        for name in names:
            kw = variants()[name]
            row = {}
            for label, d in (("den", den), ("id", identity)):
                frames, epe = run_scene(sc, centres, kw, d, epe=kw.get("align", True))
                row[label] = (float(np.mean([_score(r, f)["psnr"] for r, f in zip(refs, frames, strict=True)])), epe)
            epe_txt = "  ".join(f"F{lv} {row['id'][1][lv]:.3f} | {row['den'][1][lv]:.3f}" for lv in row["id"][1])
            print(f"   {name:22s} {row['den'][0]:6.2f} | {row['id'][0]:6.2f}   {epe_txt}", flush=True)
        sc.stream = None


def main() -> None:
    from spikeref.denoise.denoiser import Denoiser

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--part", choices=["real", "bench"], default=None, help="run one part only")
    ap.add_argument("--frames", type=int, default=4, help="scored frames per bench scene (default 4)")
    ap.add_argument("--scenes", nargs="*", default=["static", "translation", "fan", "hdr", "low_light"],
                    help="bench scenes (default: static translation fan hdr low_light)")
    ap.add_argument("--variants", nargs="*", default=None, help=f"variants (default all): {', '.join(variants())}")
    args = ap.parse_args()
    names = args.variants or list(variants())
    unknown = [n for n in names if n not in variants()]
    if unknown:
        ap.error(f"unknown variant(s) {unknown}; choose from {list(variants())}")
    den = Denoiser.load()
    if args.part in (None, "real"):
        part_real(names, den)
    if args.part in (None, "bench"):
        part_bench(names, den, args.scenes, args.frames)


if __name__ == "__main__":
    main()
