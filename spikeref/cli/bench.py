"""``spikeref bench``: accuracy against seconds per frame of every method and setting, and ``--ladder``, the
stage ladder."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from spikeref.cli import weights
from spikeref.cli.arguments import DefaultsHelpFormatter, check_seed, comma_list, int_list
from spikeref.cli.compile_note import compiling_note
from spikeref.cli.errors import CliError, output_phase
from spikeref.cli.outputs import check_output_dir

__all__ = ["cmd_bench", "add_parser"]


def cmd_bench(args) -> int:
    import datetime
    import platform
    import time

    from spikeref.bench import BENCH_VERSION, bench_scenes, grid_settings, parse_grid, run_bench, write_report

    if args.ladder:
        return _cmd_ladder(args)
    if args.dark_calibration:
        raise CliError("--dark-calibration applies to --ladder only (the grid scores the frames as they are)")
    grid = parse_grid(quick=args.quick, methods=args.methods, modes=args.modes, W=args.W, K=args.K, L=args.L,
                      align=args.align, frames=args.frames, scenes=args.scenes, flow_frames=args.flow_frames)
    scenes = bench_scenes(grid.scenes)  # unknown scene names fail here, before any work
    if args.sheet_scene is None:
        args.sheet_scene = "fan" if "fan" in [s.key for s in scenes] else scenes[0].key
    if args.sheet_scene not in [s.key for s in scenes]:
        raise CliError(f"--sheet-scene {args.sheet_scene!r} is not among the scenes run "
                       f"({', '.join(s.key for s in scenes)})")
    settings = grid_settings(grid)
    if not settings:
        raise CliError("nothing to run: --methods leaves no method")
    check_seed(args.seed)
    out = args.out
    check_output_dir(out, "--out")
    from spikeref.pipeline import DEFAULT_ACCUMULATE

    weights.bundled_weights_by_default(args, DEFAULT_ACCUMULATE)  # the network for what the method's windows give
    den = weights.load_denoiser(args.weights) if any(s.method == "ours" for s in settings) else None
    _writable_dir(out, "--out")  # the last check, and the first thing made: every argument is good
    print(f"bench v{BENCH_VERSION}: {len(settings)} settings × {len(scenes)} scenes, {grid.frames} scored frames "
          f"each → {out}", file=sys.stderr)
    t0 = time.perf_counter()
    compiling_note(args, "bench")
    result = run_bench(grid, seed=args.seed, denoiser=den, progress=not args.no_progress,
                       sheet_scene=args.sheet_scene)
    elapsed = time.perf_counter() - t0
    sizes = " / ".join(dict.fromkeys(f"{s.scene.height}×{s.scene.width}" for s in scenes))
    meta = {"bench_version": BENCH_VERSION, "grid": "quick grid" if args.quick else "full grid",
            "when": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, {elapsed:.0f} s",
            "size": sizes, "frames": grid.frames,
            "denoiser": str(args.weights or "bundled default"), "sheet_scene": args.sheet_scene}
    with output_phase():
        written = write_report(result, out, meta)
    print((out / "results.md").read_text(), file=sys.stdout)
    for path in written.values():
        print(f"wrote {path}", file=sys.stderr)
    return 0


def _writable_dir(out: Path, option: str) -> None:
    try:  # the output folder must be writable before minutes of work start
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".spikeref-bench-probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise CliError(f"{option} {out}: cannot write there ({exc.strerror or exc})") from None


def _cmd_ladder(args) -> int:
    """``spikeref bench --ladder``: the stage ladder (ladder.csv, ladder.md, ladder.png)."""
    import csv
    import datetime
    import platform
    import time

    from spikeref.bench import BENCH_VERSION, bench_scenes
    from spikeref.bench.ladder import LadderSetting, ladder_markdown, plot_ladder, run_ladder
    from spikeref.io.atomic import atomic_write

    for name in ("quick", "methods", "modes", "align", "flow_frames"):
        if getattr(args, name):
            raise CliError(f"--{name.replace('_', '-')} does not apply to --ladder (it runs every rung)")
    frames = 4 if args.frames is None else args.frames
    if isinstance(frames, bool) or not 1 <= frames <= 8:
        raise CliError(f"--frames must be 1…8; got {frames}")
    try:
        settings = [LadderSetting(w, k, lv) for w in (args.W or [10]) for k in (args.K or [3])
                    for lv in (args.L or [3])]
    except TypeError as exc:  # pragma: no cover - argparse gives ints
        raise CliError(str(exc)) from None
    for st in settings:
        if st.window < 1 or st.K < 1 or st.K % 2 == 0 or st.L < 1:
            raise CliError(f"--ladder needs W ≥ 1, odd K ≥ 3 and L ≥ 1; got {st.name}")
    try:
        scenes = bench_scenes(tuple(args.scenes or ()))
    except ValueError as exc:
        raise CliError(f"--scenes: {exc}") from None
    check_seed(args.seed)
    out = args.out
    check_output_dir(out, "--out")
    # without --weights each rung loads the bundled network for what its windows give (count or charge)
    den = weights.load_denoiser(args.weights) if args.weights is not None else None
    _writable_dir(out, "--out")  # the last check, and the first thing made: every argument is good
    print(f"bench v{BENCH_VERSION} ladder: {len(settings)} setting(s) × {len(scenes)} scenes, {frames} scored frames "
          f"each → {out}", file=sys.stderr)
    from spikeref.denoise.peers import peer_available

    missing = [name for name in ("bm3d", "nlm") if not peer_available(name)]
    if missing:
        print(f"note: the {' and '.join(m.upper() for m in missing)} rungs are left out: they need the peers extra "
              f"(bm3d, scikit-image, PyWavelets): pip install \"spikeref[peers]\"", file=sys.stderr)
    compiling_note(args, "bench-ladder")
    t0 = time.perf_counter()
    result = run_ladder(scenes, settings, seed=args.seed, denoiser=den, frames=frames,
                        progress=not args.no_progress, dark_calibration=args.dark_calibration)
    elapsed = time.perf_counter() - t0
    calibrated = ", dark level calibrated" if args.dark_calibration else ""
    head = (f"# spikeref bench --ladder (bench v{BENCH_VERSION}, seed {args.seed}{calibrated}, "
            f"{datetime.datetime.now():%Y-%m-%d %H:%M}, {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} CPUs, {elapsed:.0f} s)\n\n")
    text = head + ladder_markdown(result)
    with output_phase():
        def write_csv(tmp):
            with open(tmp, "w", newline="") as fh:
                writer = csv.DictWriter(fh, fieldnames=list(result["rows"][0]))
                writer.writeheader()
                writer.writerows(result["rows"])

        atomic_write(out / "ladder.csv", write_csv)
        atomic_write(out / "ladder.md", lambda tmp: Path(tmp).write_text(text))
        written = [out / "ladder.csv", out / "ladder.md"]
        if plot_ladder(result, out / "ladder.png"):
            written.append(out / "ladder.png")
    print(text)
    for path in written:
        print(f"wrote {path}", file=sys.stderr)
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref bench`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("bench", help="accuracy against seconds per frame of every method and setting "
                                     "(table, CSV, Pareto plot, contact sheet)",
                       description="Run TFP (W=10, W=100), TFI, TFSTP and the progressive warping over its "
                                   "settings (denoiser mode visible/mixed/blind, L = 0…3, K = 3, 5, W = 10, 20 "
                                   "planes, alignment on/off, flow on denoised or smoothed frames, and the "
                                   "fast preset, reconstruct --preset fast) on the "
                                   "versioned benchmark scenes (static, translation, fan, hdr, low_light, and "
                                   "the photographs astronaut_pan, coffee_spin, occlusion with the test extra; "
                                   "128×128 or 128×160 pixels, 800 planes = 40 ms, "
                                   "simulated with realistic noise). Every method is scored at the same instants "
                                   "against the 2000-FPS ground truth (PSNR, SSIM, PU21-PSNR, PU21-SSIM) and "
                                   "timed in seconds per output frame in this process. Writes results.csv, "
                                   "results.md, contact_sheet.png and (with spikeref[plot]) pareto.png. "
                                   "The full grid (52 settings) takes ~5 min on 2 cores; --quick (16 settings, "
                                   "2 frames per scene) under 3 min.",
                       formatter_class=DefaultsHelpFormatter)
    p.add_argument("--quick", action="store_true",
                   help="the quick grid: L axis at K=3, W=10 plus K=5, W=20, no alignment, smoothed flow frames "
                        "one at a time at L=3; mixed and blind at L=0; 2 scored frames per scene")
    p.add_argument("--out", type=Path, default=Path("spikeref-bench"), help="output folder")
    p.add_argument("--methods", type=comma_list, default=None,
                   help="comma-separated subset of tfp10,tfp100,tfi,tfstp,ours (default: all)")
    p.add_argument("--modes", type=comma_list, default=None, help="denoiser modes of ours: visible,mixed,blind")
    p.add_argument("-W", type=int_list, default=None, help="windows W of ours in planes: 10,20")
    p.add_argument("-K", type=int_list, default=None, help="frames per step K of ours: 3,5")
    p.add_argument("-L", type=int_list, default=None, help="steps L of ours: 0,1,2,3")
    p.add_argument("--align", type=comma_list, default=None, help="alignment of ours: on,off")
    p.add_argument("--flow-frames", type=comma_list, default=None,
                   help="what the flow of ours is estimated on: denoised (the paper), smoothed (the speed option)")
    p.add_argument("--frames", type=int, default=None, help="scored frames per scene, 1…8 (full 4, quick 2)")
    p.add_argument("--scenes", type=comma_list, default=None,
                   help="comma-separated subset of static,translation,fan,hdr,low_light,astronaut_pan,"
                        "coffee_spin,occlusion")
    p.add_argument("--sheet-scene", default=None, help="scene shown on the contact sheet (default: fan)")
    p.add_argument("--seed", type=int, default=0, help="simulation seed of the scenes")
    p.add_argument("--weights", default=None, help="denoiser weights (.npz or a bundled name; default bundled)")
    p.add_argument("--ladder", action="store_true",
                   help="the stage ladder instead of the grid: per scene, TFP(W), BM3D / NLM on one window "
                        "(extra peers), the denoiser on one window, TFP(support), no alignment, no denoiser, "
                        "ours, the true-flow ceiling (alone, with the denoiser, with BM3D, over the adaptive "
                        "merge's whole support where visible, on noise-free windows), and the limit (the "
                        "noise-free mosaic through Ψ), plus the flow's end-point error per step; at W/K/L "
                        "from -W/-K/-L (default 10/3/3). Writes ladder.csv, ladder.md "
                        "and (with spikeref[plot]) ladder.png into --out; about 100 s on 2 cores with the "
                        "peers extra. With --ladder, -W/-K/-L, --scenes, --frames, --seed, --weights, --out and "
                        "--no-progress apply; --quick, --methods, --modes, --align and --flow-frames are refused")
    p.add_argument("--dark-calibration", action="store_true",
                   help="--ladder only: calibrate each scene's sensor as a user would (a dark recording of 4000 "
                        "readouts of the same sensor, spikeref calibrate's measure) and subtract its dark level "
                        "from every rung's frames but the noise-free ones (spikeref.dark_level). Default: not "
                        "subtracted, the frames keep Eq. 9's E[N]/W as the paper's")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_bench)
    return [p]
