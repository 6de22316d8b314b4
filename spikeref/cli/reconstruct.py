"""``spikeref reconstruct``: colour HDR video by progressive warping, in this process or in chunks on Dask;
the run record of its EXR folder and ``--resume``, and the line that says how a stopped run continues."""

from __future__ import annotations

import argparse
import errno
import importlib.util
import sys
from dataclasses import replace
from pathlib import Path

from spikeref.cli import weights
from spikeref.cli.arguments import DefaultsHelpFormatter, check_float, check_int, frames_within
from spikeref.cli.compile_note import compiling_note
from spikeref.cli.errors import (
    CliError, Interrupted, RunFailed, os_error_text, output_phase, resume_command, signal_name,
)
from spikeref.cli.inputs import (
    add_hot_pixel_option, add_input_options, axes_said, calibration_map, calibration_map_path, hot_pixel_map,
    hot_pixel_option, open_input, say_hot_pixels,
)
from spikeref.cli.outputs import check_output_dir, check_video, say_written

__all__ = ["cmd_reconstruct", "add_parser"]


def _frames_in(args, avail: range, params) -> range:
    """The ``--frames`` of ``args`` (``a:b`` or ``N``) inside the frames ``avail`` the stream has, or a refusal."""
    return frames_within(args.frames, avail, "this stream has frames {start}:{stop}" +
                         f" (W={args.window}, K={args.K}, L={args.L}: frame k needs windows k−{params.reach} … "
                         f"k+{params.reach})")


def _frames_written(exr_dir: Path | None, frames: range) -> int:
    """How many of ``frames`` have their EXR file in ``exr_dir`` (written by Dask workers, say)."""
    from spikeref.render import exr_name

    if exr_dir is None or not exr_dir.is_dir():
        return 0
    return sum((exr_dir / exr_name(k)).is_file() for k in frames)


def _continue_hint(exc: BaseException) -> str:
    """How the one line of a failed run leads to the resume command."""
    code = getattr(exc, "errno", None)
    if code in (errno.ENOSPC, errno.EDQUOT):
        return "once there is space, continue with"
    if code in (errno.EACCES, errno.EPERM, errno.EROFS):
        return "once the folder is writable, continue with"
    return "then continue with"


def _stopped(args, exc: BaseException, exr_dir: Path | None, frames: range, written: int) -> CliError:
    """The one line for a reconstruction stopped by a signal or an OS error: what is on disk, how to continue.

    ``written`` frames of ``frames`` are whole in ``exr_dir`` (atomic writes); ``--resume`` skips them.
    """
    if isinstance(exc, KeyboardInterrupt):
        cls, what, hint = Interrupted, f"interrupted ({signal_name(exc)})", "continue with"
    else:
        cls, what = RunFailed, (os_error_text(exc) if isinstance(exc, OSError) else str(exc))
        hint = _continue_hint(exc)
    if exr_dir is None:
        return cls(f"{what}; no frame was kept (the video is written at the end, and there is no --exr-dir): "
                   "run the command again, with --exr-dir DIR to make it resumable")
    on_disk = f"{written} of {len(frames)} frames written to {exr_dir}"
    if cls is Interrupted:
        return cls(f"{what} with {on_disk}; {hint}: {resume_command(args, exr_dir)}")
    return cls(f"{what}; {on_disk}; {hint}: {resume_command(args, exr_dir)}")


def cmd_reconstruct(args) -> int:
    import time

    from tqdm import tqdm

    from spikeref.io.exr import read_exr
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.render import FrameSink, exr_name, frame_runs, frames_on_disk

    video, exr_dir = args.output, args.exr_dir
    if video is None and exr_dir is None:
        video, exr_dir = Path("reconstruction.mp4"), Path("reconstruction_exr")
    if args.resume and exr_dir is None:
        raise CliError("--resume needs --exr-dir (the frames already written are found there)")
    if args.paper and args.preset not in (None, "paper"):
        raise CliError(f"--paper is --preset paper; give one of --paper and --preset {args.preset}")
    preset = "paper" if args.paper else (args.preset or "default")
    args.paper = preset == "paper"
    chosen = {k: v for k, v in (("flow_frames", args.flow_frames), ("warp", args.warp), ("demosaic", args.demosaic),
                                ("accumulate", args.accumulate)) if v is not None}
    if args.no_denoiser:
        chosen["denoise"] = False
    if args.merge is not None:
        chosen["merge"] = args.merge
    if args.support is not None:
        check_int(args.support, "--support", 1, "a positive number of windows")
    dark_map = _dark_level_option(args.dark_level)
    hot_map = hot_pixel_option(args.hot_pixels)
    if args.hot_pixels is not None:  # a map replaces the search; auto/off as given (the paper's preset: off)
        chosen["hot_pixels"] = "off" if hot_map is not None else args.hot_pixels
    for value, flag, low in ((args.window, "-W/--window", 1), (args.K, "-K", 1), (args.L, "-L", 0)):
        check_int(value, flag, low, f"a whole number ≥ {low}")
    if args.K % 2 == 0:
        raise CliError(f"-K must be odd (the reference is the middle window); got {args.K}")
    params = ReconstructParams.preset(preset, window=args.window, K=args.K, L=args.L, align=not args.no_align,
                                      **chosen)
    if args.support is not None:  # one check, whatever chose the merge
        if params.merge_used != "adaptive":
            why = (f"--merge {args.merge}" if args.merge else f"--preset {preset}" if preset != "default"
                   else "--accumulate count" if params.accumulate == "count" else f"--warp {params.warp}")
            raise CliError(f"--support applies to the adaptive merge; this run merges with the {params.merge_used} "
                           f"merge ({why} makes it so: add --merge adaptive, or leave out --support)")
        params = replace(params, support=args.support)
    if not params.denoise:
        given = [flag for flag, on in (("--weights", args.weights is not None), ("--guard", args.guard is not None),
                                       ("--no-shrink", args.no_shrink)) if on]
        if given:
            raise CliError(f"{'--no-denoiser' if args.no_denoiser else '--preset ' + preset} runs no network: "
                           f"{' and '.join(given)} {'does' if len(given) == 1 else 'do'} not apply")
    weights.bundled_weights_by_default(args, params.accumulate)
    check_float(args.fps, "--fps")
    check_video(video)
    check_output_dir(exr_dir, "--exr-dir")
    guard = args.guard or ("off" if args.paper else "sure")
    shrink = not (args.no_shrink or args.paper)
    if args.workers is not None or args.scheduler is not None:
        if args.profile:
            raise CliError("--profile times one process; run without --workers/--scheduler")
        return _reconstruct_on_dask(args, params, video, exr_dir, guard, shrink, hot_map, dark_map)
    stream = open_input(args)
    den = weights.load_denoiser(args.weights, accumulate=params.accumulate, shrink=shrink,
                                guard=guard) if params.denoise else None
    dark = _dark_level(dark_map, stream)  # the same sensor's size
    rec = Reconstructor(stream, params, den, hot_pixels=hot_pixel_map(hot_map, stream), dark_level=dark)
    frames = _frames_in(args, rec.frames_available, params)
    a, b = frames.start, frames.stop
    done = set()
    if exr_dir is not None:
        with output_phase():
            _check_resume_record(exr_dir, _run_record(stream, params, args, guard, shrink, rec.hot_pixel_mask,
                                                      hot_map, dark), args.resume)
    if args.resume:
        done, bad = frames_on_disk(exr_dir, frames, stream.height, stream.width)
        if bad:
            print(f"{len(bad)} frame files in {exr_dir} are empty, unreadable or of another size "
                  f"(first: {exr_name(bad[0])}); they are computed again", file=sys.stderr)
    fps_out = stream.rate_hz / args.window
    parts = [f"W={args.window}, K={args.K}, L={args.L}",
             "window charges" if params.accumulate == "charge" else "Eq. 4 counts"]
    warp = params.warp + " warp"
    parts += ["no alignment"] if args.no_align else [f"flow on {params.flow_frames} frames", warp]
    parts += ["the paper's procedure"] if args.paper else []
    parts += [f"the {preset} preset"] if preset in ("fast", "fastest") else []
    parts += {"mhc": ["Malvar–He–Cutler demosaic"], "ddfapd": ["directional demosaic"],
              "multiframe": ["multi-frame demosaic"]}.get(
        params.demosaic_used if stream.cfa else "", [])
    parts += [f"guard {guard}", f"weights {Path(str(args.weights)).stem}"] if params.denoise else ["no denoiser"]
    print(f"{stream.path.name if stream.path else 'stream'}: {len(stream)} planes of {stream.height}×{stream.width}"
          f"{axes_said(stream, args)} {stream.cfa or 'mono'} → frames {a}:{b} at {fps_out:g} FPS ({', '.join(parts)})"
          + (f"; {len(done)} already written" if done else ""), file=sys.stderr)
    say_hot_pixels(rec.hot_pixel_mask, hot_map)
    compiling_note(args, f"reconstruct-{preset}")
    written = len(done)  # whole EXR frames of a:b in exr_dir, for the line of an interrupted or failed run
    t_loop = time.perf_counter()
    try:
        with FrameSink(video, exr_dir, fps=args.fps, half=args.half) as sink, \
                tqdm(total=b - a, desc="reconstruct", unit="frame", disable=None) as bar:
            for lo, hi, on_disk in frame_runs(a, b, done):
                if on_disk:  # --resume: read back what an earlier run wrote (the video needs every frame)
                    for k in range(lo, hi):
                        if video is not None:
                            sink.add(k, read_exr(exr_dir / exr_name(k)), on_disk=True)
                        bar.update(1)
                    continue
                for frame in rec.frames(lo, hi):
                    with rec.timed("write"):
                        sink.add(frame.index, frame.rgb)
                    written += exr_dir is not None
                    bar.update(1)
    except (KeyboardInterrupt, OSError) as exc:  # the frames on disk are whole (atomic writes): say how to go on
        if exr_dir is not None and not exr_dir.is_dir():
            written = 0  # the folder itself is gone
        raise _stopped(args, exc, exr_dir, frames, written) from exc
    loop_s = time.perf_counter() - t_loop  # includes closing the video (its last frames are encoded there)
    say_written(video, exr_dir)
    if args.profile:
        print(f"where the time went (frames made here: {rec.frames_made}; 'write' = EXR and video; "
              f"'other' = the rest of the loop, closing the video included):", file=sys.stderr)
        print(rec.profile(total=loop_s).table(), file=sys.stderr)
    return 0


def _dark_level_option(value):
    """``--dark-level MAP.npz``: the map's path (its suffix and existence checked before any work), or None."""
    if value is None:
        return None
    return calibration_map_path(value, "--dark-level", "a calibration map .npz (spikeref calibrate DARK -o MAP.npz)")


def _dark_level(path, stream):
    """The dark level ``(4,)`` of the map at ``path`` (:func:`_dark_level_option`), its size checked against
    ``stream``'s; None without a map."""
    from spikeref.dark_level import load_dark_level

    return calibration_map(load_dark_level, path, stream, "--dark-level")


def _run_record(stream, params, args, guard, shrink, hot_mask=None, hot_map=None, dark=None) -> dict:
    """How this run makes its frames, for the EXR folder's record (``--resume`` refuses other settings).

    The hot pixels are recorded by what was replaced (named only when some were), not by the option, so a
    folder of frames made before the option existed, of a recording without hot pixels, resumes as before.
    """
    from dataclasses import asdict

    path = Path(stream.path) if stream.path is not None else None
    record = {"input": {"name": path.name if path else None,
                        "bytes": path.stat().st_size if path and path.is_file() else None,
                        "planes": len(stream), "height": stream.height, "width": stream.width, "cfa": stream.cfa},
              "params": {k: v for k, v in asdict(params).items()
                         if k != "hot_pixels" and not (params.merge_used == "binomial" and k in ("merge", "support"))}}
    if params.merge_used != "binomial":  # the merge that ran, not "auto"
        record["params"]["merge"] = params.merge_used
    if hot_mask is not None and hot_mask.any():
        record["hot_pixels"] = {"replaced": int(hot_mask.sum()),
                                "from": str(hot_map) if hot_map is not None else "the recording"}
    if dark is not None:  # named only when given, so records of earlier runs resume as before
        record["dark_level"] = [float(v) for v in dark]
    if stream.rows == "top-down":  # named only when not the default, so records of bottom-up runs stay as they were
        record["input"]["rows"] = stream.rows
    if params.denoise:
        record["denoiser"] = {"weights": str(args.weights), "guard": guard, "shrink": shrink}
    return record


def _check_resume_record(exr_dir, record, resume: bool) -> None:
    """Refuse a folder whose frames were made with other settings; then record this run's.

    With ``--resume`` any other settings are refused; without it too when the folder holds frames (this
    run would overwrite some of them and leave the rest: one folder would mix two settings).
    """
    from spikeref.render import EXR_FRAMES, RUN_RECORD, run_record_differences, write_run_record

    differ = run_record_differences(exr_dir, record)
    if differ:
        shown = ", ".join(differ[:6]) + (f" and {len(differ) - 6} more" if len(differ) > 6 else "")
        if resume:
            raise CliError(f"--resume: the frames in {exr_dir} were made with other settings ({shown}; see "
                           f"{RUN_RECORD} there): resume with the same options, or write to another --exr-dir")
        if any(Path(exr_dir).glob(EXR_FRAMES)):
            raise CliError(f"--exr-dir {exr_dir} holds frames made with other settings ({shown}; see {RUN_RECORD} "
                           f"there): this run would mix its frames with them. Write to another --exr-dir, or "
                           f"delete that folder's frames first")
    write_run_record(exr_dir, record)


def _reconstruct_on_dask(args, params, video, exr_dir, guard, shrink, hot_map, dark_map=None) -> int:
    import time

    from spikeref.distributed import ChunkError, assemble_video, reconstruct_distributed
    from spikeref.pipeline import frame_range

    if args.workers is not None and args.scheduler is not None:
        raise CliError("give --workers (a local cluster) or --scheduler (an existing one), not both")
    if args.workers is not None and args.workers < 1:
        raise CliError(f"--workers must be at least 1; got {args.workers}")
    if importlib.util.find_spec("distributed") is None:  # refused before any output exists
        raise CliError(f"{'--workers' if args.workers is not None else '--scheduler'} needs Dask: "
                       f"pip install 'spikeref[dask]'")
    if args.chunk_frames < 1:
        raise CliError(f"--chunk-frames: chunk_frames must be a positive integer (frames per task); "
                       f"got {args.chunk_frames}")
    if exr_dir is None:  # workers write EXR frames; the video is assembled from them
        exr_dir = video.with_name(video.stem + "_exr")
        check_output_dir(exr_dir, "-o/--output")
    stream = open_input(args)
    frames = _frames_in(args, frame_range(len(stream), params.window, params.K, params.L), params)
    if params.denoise:  # refused here, not on every worker
        weights.load_denoiser(args.weights, accumulate=params.accumulate, mode=params.mode, guard=guard, shrink=shrink)
    from spikeref.hot_pixels import find_hot_pixels

    # found once here, in the recording's first planes, and sent to every chunk (a map, even an empty one, is used
    # as it is: the chunks search for none)
    dark = _dark_level(dark_map, stream)  # the same sensor's size
    hot = hot_pixel_map(hot_map, stream)
    if hot is None and params.hot_pixels == "auto":
        hot = find_hot_pixels(stream)
    say_hot_pixels(hot, hot_map)
    with output_phase():
        _check_resume_record(exr_dir, _run_record(stream, params, args, guard, shrink, hot, hot_map, dark),
                             args.resume)
    open_kwargs = {"height": args.height, "width": args.width, "cfa": args.cfa, "file_width": args.file_width,
                   "rate_hz": args.rate_hz, "key": args.key, "axes": args.axes, "rows": args.rows}
    where = f"{args.workers} local workers" if args.workers is not None else f"scheduler {args.scheduler}"
    print(f"{stream.path.name}: frames {frames.start}:{frames.stop} in chunks of {args.chunk_frames} on {where}"
          f" → {exr_dir}", file=sys.stderr)
    t0 = time.perf_counter()
    try:
        summaries = reconstruct_distributed(stream.path, exr_dir, params, open_kwargs=open_kwargs,
                                            weights=args.weights, frames=frames, chunk_frames=args.chunk_frames,
                                            workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                                            half=args.half, guard=guard, shrink=shrink, hot_pixels=hot,
                                            dark_level=dark)
    except (KeyboardInterrupt, OSError, ChunkError) as exc:  # frames already written stay: --resume goes on
        raise _stopped(args, exc, exr_dir, frames, _frames_written(exr_dir, frames)) from exc
    wall = time.perf_counter() - t0
    made = sum(s["written"] for s in summaries)
    if summaries:
        busy = sum(s["seconds"] for s in summaries)
        peak = max(s["peak_rss_mib"] for s in summaries)
        print(f"{made} frames written by {len(summaries)} chunks in {wall:.1f} s ({made / wall:.2f} frames/s); "
              f"{busy:.1f} s inside the tasks; peak memory of a worker {peak:.0f} MiB", file=sys.stderr)
    else:
        print("every frame was already on disk (--resume)", file=sys.stderr)
    if video is not None:
        try:
            assemble_video(exr_dir, frames, video, fps=args.fps)
        except (KeyboardInterrupt, OSError) as exc:
            raise _stopped(args, exc, exr_dir, frames, _frames_written(exr_dir, frames)) from exc
        print(f"wrote {video}", file=sys.stderr)
    print(f"wrote {exr_dir}", file=sys.stderr)
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref reconstruct`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("reconstruct", help="colour HDR video by progressive warping (Eq. 13-15) to MP4 + EXR",
                       description="Reconstruct linear colour HDR frames R_L = Ψ[D(I_L)] (§4.2, Fig. 3b): windows "
                                   "of W planes are accumulated (by default their charge, read from the spike times "
                                   "around each window; Eq. 4's count with --accumulate count or --paper), denoised "
                                   "(§4.1) and aligned (HDR+ tiles); "
                                   "step 1 warps the spike planes of K windows (Eq. 14), steps 2…L warp K frames of "
                                   "the previous step (Eq. 15). One frame per window: 20000/W FPS; frame k is "
                                   "centred on window k (planes kW … (k+1)W − 1) and needs ((K−1)L+1)·W planes around "
                                   "it. Without FILE the embedded sample is used. Without -o/--exr-dir it writes "
                                   "reconstruction.mp4 and reconstruction_exr/. EXR frames are linear float RGB in "
                                   "spikes per readout, named frame_NNNNNN.exr by frame number.",
                       formatter_class=DefaultsHelpFormatter)
    add_input_options(p, optional_file=True)
    p.add_argument("-o", "--output", type=Path, default=None, help="video file (.mp4 or .gif), one exposure")
    p.add_argument("--exr-dir", type=Path, default=None, help="folder for linear EXR frames")
    p.add_argument("-W", "--window", type=int, default=10,
                   help="window in planes (10 planes = 0.5 ms at 20 kHz → 2000 FPS)")
    p.add_argument("-K", type=int, default=3, help="frames warped together at each step (odd)")
    p.add_argument("-L", type=int, default=3, help="warping steps (0: denoised TFP only)")
    p.add_argument("--paper", action="store_true",
                   help="the paper's procedure exactly: flows on the denoised frames, the plain HDR+ search, "
                        "Eq. 14-15 step by step, the network's D(I) without guard or shrinkage (the defaults go "
                        "beyond the paper where the stage ladder measured a gain: docs/results.md)")
    p.add_argument("--preset", choices=["default", "fast", "fastest", "paper"], default=None,
                   help="named settings (options given with it win): default (the defaults below); fast (the "
                        "defaults with --warp chained: only the step-0 flows estimated and composed; faster, at "
                        "about the defaults' accuracy); fastest (fast with --no-denoiser: faster still, a little "
                        "under the defaults in low light); paper (= --paper). Their measured frames/s and dB: "
                        "README.md, 'Fast preset', and docs/results.md, 'Speed'")
    p.add_argument("--no-denoiser", action="store_true",
                   help="D is the identity: no network pass, no weights (not in the paper; with window charges the "
                        "network gains little on the benchmark for about half the frame time: docs/results.md)")
    p.add_argument("--profile", action="store_true",
                   help="after the run, print to stderr where the time went: seconds, %% of the run's time and "
                        "milliseconds per frame for accumulate (Eq. 4), network (the U-Net's passes), guard (the "
                        "rest of the denoiser), align, warp (Eq. 14-15), demosaic, write (EXR/video) and other")
    p.add_argument("--guard", choices=["sure", "off"], default=None,
                   help="sure (default): blend the network's output with its input by Stein's unbiased risk "
                        "estimate, per pixel, from the data's own noise level (one more network pass; not in the "
                        "paper; spikeref.denoise.guard); off: the network's output, then the shrinkage below")
    p.add_argument("--no-shrink", action="store_true",
                   help="with --guard off, do not give back the residual above the exposure's binomial noise "
                        "(spikeref.denoise.shrinkage); --guard off --no-shrink is the paper's D(I) exactly")
    p.add_argument("--no-align", action="store_true", help="zero flow (plain accumulation over the support)")
    p.add_argument("--merge", choices=["adaptive", "robust", "binomial"], default=None,
                   help="how the aligned windows are merged (composed or chained warp): adaptive (default with "
                        "window charges: each window weighed by how well it agrees with the reference beyond the "
                        "noise, so misaligned and occluded samples drop out, and windows beyond Eq. 14-15's support "
                        "added where they keep agreeing, up to --support windows each side), robust (the same "
                        "weights at Eq. 14-15's support), binomial (Eq. 14-15's weights; the default with "
                        "--accumulate count, --preset fast and --paper). Not in the paper; spikeref.merge; what each "
                        "buys and costs: docs/results.md, 'The adaptive merge as the default'")
    p.add_argument("--support", type=int, default=None,
                   help="with the adaptive merge: the farthest window a pixel may collect, in windows each side of "
                        "the reference (default 10: 100 planes at W = 10)")
    add_hot_pixel_option(p, "reconstruct")
    p.add_argument("--dark-level", default=None, metavar="MAP.npz",
                   help="subtract the sensor's dark level from every frame: what it fires without light, per 2×2 "
                        "phase in spikes per readout (Eq. 9's E[N]/W, which the paper's frames keep), measured by "
                        "spikeref calibrate on a recording made with the lens covered; frames clipped at 0. "
                        "Default: not subtracted. Not in the paper; spikeref.dark_level")
    p.add_argument("--flow-frames", choices=["denoised", "smoothed"], default=None,
                   help="what each step's flow is estimated on: smoothed (default; a Gaussian of σ = 1 "
                        "Bayer-plane pixel on the raw frames, one denoiser pass per frame, not in the paper) or "
                        "denoised (the paper, Fig. 3b: L+1 denoiser passes per frame)")
    p.add_argument("--warp", choices=["composed", "progressive", "chained"], default=None,
                   help="how the output is warped: composed (default; the step flows composed, each spike window "
                        "resampled once with a cubic, not in the paper), progressive (Eq. 14-15 step by step) or "
                        "chained (only the step-0 flows composed: no frame or flow of later steps, faster, same "
                        "accuracy on the benchmark; not in the paper)")
    p.add_argument("--demosaic", choices=["auto", "multiframe", "bilinear", "mhc", "ddfapd"], default=None,
                   help="the output frame's demosaic: multiframe (every merged window's raw Bayer samples gathered "
                        "at full resolution with the merge's weights: the windows' sub-pixel motion fills in what "
                        "one mosaic misses; not in the paper; sharper on moving scenes, noisier in low light), "
                        "bilinear (the paper's Ψ, Eq. 13), mhc (Malvar-He-Cutler 5x5 "
                        "filters, not in the paper) or ddfapd (Menon-Andriani-Calvagno: each pixel's green "
                        "interpolated along the rows or the columns, whichever its colour differences vary less "
                        "along; not in the paper). Default auto: multiframe with the adaptive or robust merge, "
                        "bilinear otherwise (--merge binomial, the fast presets, --paper, --no-align). "
                        "docs/results.md")
    p.add_argument("--accumulate", choices=["charge", "count"], default=None,
                   help="what each window contributes: charge (default; the charge its pixels integrated, read from "
                        "the spike times up to 200 readouts around the window's edges: the count's ±1 quantisation "
                        "at the edges falls by about the firing rate; not in the paper; spikeref.charge, "
                        "docs/results.md) or count (Eq. 4, its spikes; the paper's, and --paper's)")
    p.add_argument("--weights", type=Path, default=None,
                   help="denoiser weights .npz, or a bundled name: pairs_w16_charge (the default with charges: "
                        "trained on window charges by Noise2Noise pairs) or b2u_w16 (the default with counts and "
                        "--paper: Eq. 4's counts, the paper's Blind2Unblind loss); each network is trained on what "
                        "its path gives it")
    p.add_argument("--frames", default=None, help="frame numbers a:b to reconstruct (b excluded; default all), "
                   "or N for the first N; "
                   "chunks give exactly the frames of a full run")
    p.add_argument("--resume", action="store_true",
                   help="skip frames whose EXR file exists in --exr-dir (an interrupted run loses nothing)")
    p.add_argument("--fps", type=float, default=30.0, help="playback rate of the video file")
    p.add_argument("--half", action="store_true", help="write float16 EXR (default float32)")
    p.add_argument("--workers", type=int, default=None,
                   help="reconstruct in chunks on a local Dask cluster of this many worker processes "
                        "(needs spikeref[dask]); EXR frames are written by the workers, the video assembled after")
    p.add_argument("--scheduler", default=None,
                   help="address of an existing Dask scheduler (e.g. tcp://host:8786) instead of --workers; "
                        "input and output paths must be visible to every worker")
    p.add_argument("--chunk-frames", type=int, default=64,
                   help="output frames per Dask task; each task re-reads (K-1)·L windows of overlap")
    p.set_defaults(func=cmd_reconstruct)
    return [p]
