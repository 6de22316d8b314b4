"""Study: sub-pixel refinement, tile-field regularisation and the per-pixel zero test of :mod:`spikeref.align`.

For each variant (``ReconstructParams`` fields that replace the defaults; ``before`` is the alignment of
the defaults before issue 32's changes, ``AlignParams(prefer_centre=3)``) the ladder's ``ours`` rung
(``spikeref bench --ladder``, W/K/L = 10/3/3, seed 0, 4 scored frames) on the chosen benchmark scenes,
with the flow end-point error per step, and the real near-static recording scored as
``tests/test_pipeline.py::test_real_near_static_recording_defaults_against_plain_accumulation``
(frames 3–8 from planes 0–120, the mean of planes 300–500 as pseudo truth, least-squares gain, 8-pixel
border) without the denoiser.  The ``no_align`` rung is printed once (it does not depend on the
alignment).

    python scripts/study_align_lk.py [--scenes coffee_spin fan …] [--variants default lk …] [--no-real]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REAL = ROOT.parent / "shared" / "data" / "real" / "spikingsim_real_spike.npz"
SIX = ("static", "translation", "hdr", "astronaut_pan", "coffee_spin", "occlusion")


def variants() -> dict:
    """Name → ReconstructParams keyword arguments (``default``: today's; ``before``: the quadratic fit)."""
    from spikeref.align import AlignParams

    def ap(**kw):
        return {"align_params": AlignParams(prefer_centre=3.0, **kw)}

    out = {"default": {}, "before": ap(), "lk": ap(refine="lk")}
    for lam in (30, 100, 300, 1000):
        out[f"lk s{lam}"] = ap(refine="lk", smoothness=float(lam))
    for z in (0.0, 1.0, 2.0, 3.0):
        out[f"lk s300 zt{z:g}"] = ap(refine="lk", smoothness=300.0, zero_test=z)
    out["lk s1000 zt2"] = ap(refine="lk", smoothness=1000.0, zero_test=2.0)
    return out


def identity(planes):
    return planes


def real_no_denoiser(kw: dict) -> float:
    from spikeref.metrics import psnr_after_gain
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.stream import SpikeStream

    with np.load(REAL) as data:
        spikes = np.ascontiguousarray(data["arr_0"].transpose(2, 0, 1))
    truth = spikes[300:500].mean(axis=0, dtype=np.float64)[8:-8, 8:-8]
    stream = SpikeStream.from_array(spikes[:120])
    out = []
    for f in Reconstructor(stream, ReconstructParams(**{"accumulate": "count", **kw}), identity).frames(3, 9):
        out.append(psnr_after_gain(truth, np.asarray(f.rgb, np.float64)[8:-8, 8:-8], float(truth.max())))
    return float(np.mean(out))


def main() -> None:
    from spikeref.bench.ladder import run_ladder
    from spikeref.bench.runner import bench_scenes
    from spikeref.denoise.denoiser import Denoiser

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="*", default=None, help="bench scenes (default: all eight)")
    ap.add_argument("--variants", nargs="*", default=None, help=f"variants (default all): {', '.join(variants())}")
    ap.add_argument("--no-align", action="store_true", help="also run the no-alignment rung")
    ap.add_argument("--no-real", action="store_true", help="leave out the real recording")
    args = ap.parse_args()
    names = args.variants or list(variants())
    den = Denoiser.load()
    scenes = bench_scenes(tuple(args.scenes or ()))
    for name in names:
        kw = variants()[name]
        t0 = time.perf_counter()
        rungs = ("ours", "no_align") if args.no_align else ("ours",)
        res = run_ladder(scenes, denoiser=den, rungs=rungs, peers=(), progress=False,
                         params={"accumulate": "count", **kw})
        psnr = {(r["scene"], r["rung"]): r["psnr"] for r in res["rows"]}
        epe = {}
        for e in res["epe"]:
            epe.setdefault(e["scene"], {})[e["step"]] = e["epe"]
        real = float("nan") if args.no_real or not REAL.is_file() else real_no_denoiser(kw)
        six = [psnr[(s, "ours")] for s in SIX if (s, "ours") in psnr]
        mean = f"{np.mean(six):.2f}" if len(six) == len(SIX) else "—"
        print(f"== {name}: mean of six {mean}, real no-D {real:.2f} ({time.perf_counter() - t0:.0f} s)")
        for sc in res["scenes"]:
            e = "/".join(f"{epe.get(sc, {}).get(st, np.nan):.3f}" for st in range(3)) if sc in epe else "—"
            na = f"  no-align {psnr[(sc, 'no_align')]:.2f}" if (sc, "no_align") in psnr else ""
            print(f"   {sc:14s} {psnr[(sc, 'ours')]:6.2f}{na}   EPE {e}", flush=True)


if __name__ == "__main__":
    main()
