"""Run every setting on every benchmark scene: accuracy and seconds per output frame, in one process.

For each scene (:func:`bench_scenes`, simulated with a fixed seed) the frames are scored at
the same instants for every method: ``n`` centres ``t_j`` (plane indices, ``t_j ≡ 5 mod 10``,
20 planes apart, in the middle of the recording).  The reference is the ground truth of the
2000-FPS frame at ``t_j``: the mean radiance over the 10 planes ``[t_j − 5, t_j + 5)``.

* TFP with window ``W``: the window of ``W`` planes centred on ``t_j``;
* TFI and TFSTP: at plane ``t_j`` (TFSTP's synapses run from plane 0);
* the method with window ``W``: the output frame whose window is centred on ``t_j`` — the
  stream is sliced so that its window grid has a window there (for ``W = 20`` the grid is
  shifted by 5 planes).

Seconds per output frame, all measured in this process after a warm-up that compiles every
Numba kernel:

* the method: the median time between consecutive frames of a streamed run over the scored
  range (steady state: each frame costs its share of every step); the first frame, which
  also fills the rings of the support, is reported apart as ``warmup_s``;
* TFP and TFI: the median over the scored frames, each computed alone 5 times;
* TFSTP: the median time of one 2000-FPS output step (10 planes of synapse updates + Ψ).

Every frame is demosaicked by Ψ (bilinear) and scored with :mod:`spikeref.metrics`: PSNR and
SSIM with ``data_range`` = the reference frame's maximum, PU21-PSNR and PU21-SSIM with the
reference's peak luminance at 4000 cd/m².
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from spikeref.bench.settings import BenchGrid, Setting, grid_settings

__all__ = ["BENCH_VERSION", "SCORE_WINDOW", "FRAME_SPACING", "BenchScene", "bench_scenes", "load_bench_scene",
           "needs_scikit_image", "score_centres",
           "run_setting", "run_bench", "METRICS"]

#: Version of the benchmark scene set (``spikeref/bench/scenes/*.toml``); in every results file.
BENCH_VERSION = 2
#: Planes of the reference frame (the 2000-FPS ground truth).
SCORE_WINDOW = 10
#: Planes between scored frames: a common multiple of every W, so all grids have a window there.
FRAME_SPACING = 20
METRICS = ("psnr", "ssim", "pu21_psnr", "pu21_ssim")
#: Timed repeats of each TFP / TFI frame (the median over frames × repeats is reported).
BASELINE_REPEATS = 5


@dataclass
class BenchScene:
    """A benchmark scene: its file, the simulated stream and its scene description."""

    key: str
    path: Path
    scene: object
    stream: object = None

    def simulate(self, seed: int) -> None:
        from spikeref.simulate.simulator import simulate

        if self.stream is None:
            self.stream = simulate(self.scene, seed=seed).stream

    def dark_calibration(self, seed: int, planes: int) -> dict:
        """The calibration a user would make of this scene's sensor (:func:`spikeref.dark_level.calibrate_dark`): a
        dark recording of ``planes`` readouts, the scene with the lens covered
        (:func:`spikeref.simulate.simulator.dark_scene`), simulated with the scene's ``seed`` — the same sensor:
        thresholds, hot pixels, which pixels have inherent noise — and ``take=1``, other noise draws."""
        from spikeref.dark_level import calibrate_dark
        from spikeref.simulate.simulator import dark_scene, simulate

        dark = simulate(dark_scene(self.scene), seed=seed, planes=planes, take=1).stream
        return calibrate_dark(dark, planes=planes)

    def reference(self, centre: int) -> np.ndarray:
        """Ground truth ``(H, W, 3) float64`` of the 10-plane window centred on ``centre``."""
        from spikeref.simulate.simulator import ground_truth

        h = SCORE_WINDOW // 2
        return ground_truth(self.scene, SCORE_WINDOW, planes=centre + h, start=centre - h)[0].astype(np.float64)


def _scene_dir() -> Path:
    return Path(str(resources.files("spikeref.bench") / "scenes"))


def needs_scikit_image(path: Path) -> bool:
    """True when a scene file shows a photograph bundled with scikit-image (``skimage:NAME``)."""
    from spikeref.simulate.scenes import SKIMAGE_PREFIX

    return f'"{SKIMAGE_PREFIX}' in Path(path).read_text()


def load_bench_scene(path) -> BenchScene:
    """A scene file as a :class:`BenchScene` (its key: the ``name`` field with spaces as ``_``)."""
    from spikeref.simulate.scenes import load_scene

    scene = load_scene(path)
    return BenchScene(scene.name.replace(" ", "_"), Path(path), scene)


def bench_scenes(names=()) -> list[BenchScene]:
    """The benchmark scenes (version :data:`BENCH_VERSION`), optionally only those named.

    A scene's key is its ``name`` field with spaces as ``_`` (``static``, ``translation``,
    ``fan``, ``hdr``, ``low_light``, and the natural-content scenes ``astronaut_pan``,
    ``coffee_spin``, ``occlusion``).  The natural-content scenes show photographs bundled with
    scikit-image (the ``test`` extra): without it they are left out (and naming one is an error
    that says what to install).
    """
    import importlib.util

    have_skimage = importlib.util.find_spec("skimage") is not None
    found, missing = [], []
    for path in sorted(_scene_dir().glob("*.toml")):
        if not have_skimage and needs_scikit_image(path):
            missing.append(path.stem.split("_", 1)[1])
            continue
        found.append(load_bench_scene(path))
    bad = [n for n in names if n in missing]
    if bad:
        raise ValueError(f"scene {', '.join(bad)} shows a scikit-image photograph: pip install \"spikeref[test]\"")
    keys = [s.key for s in found]
    unknown = [n for n in names if n not in keys]
    if unknown:
        raise ValueError(f"unknown scene {', '.join(unknown)}; allowed: {', '.join(keys)}")
    return [s for s in found if not names or s.key in names]


def score_centres(planes: int, frames: int) -> list[int]:
    """``frames`` centre planes ``≡ 5 (mod 10)``, :data:`FRAME_SPACING` apart, around the middle."""
    first = (planes // 2 - FRAME_SPACING * (frames - 1) // 2) // 10 * 10 + 5
    return [first + FRAME_SPACING * j for j in range(frames)]


def _score(reference: np.ndarray, image: np.ndarray) -> dict:
    from spikeref.metrics import psnr, pu21_psnr, pu21_ssim, ssim

    img = np.asarray(image, dtype=np.float64)
    top = float(reference.max())
    return {"psnr": psnr(reference, img, top), "ssim": ssim(reference, img, top),
            "pu21_psnr": pu21_psnr(reference, img), "pu21_ssim": pu21_ssim(reference, img)}


def run_setting(setting: Setting, stream, centres: list[int], denoiser=None,
                align_params=None, accumulate: str | None = None) -> tuple[list[np.ndarray], dict]:
    """Frames of ``setting`` at the ``centres`` and its timings.

    ``align_params`` (an :class:`~spikeref.align.AlignParams`) replaces the method's default
    alignment parameters and ``accumulate`` (``"count"`` or ``"charge"``) what its windows give
    (for studies; the bench itself uses the defaults).

    Returns
    -------
    frames : list of ``(H, W, 3) float32`` linear RGB (Ψ applied), one per centre
    timing : dict
        ``seconds_per_frame`` (see the module docstring), ``warmup_s`` (the method's first
        frame, 0 for baselines) and, for the method, ``<stage>_s`` for each stage of
        :data:`~spikeref.pipeline.STAGES` but ``write`` plus ``other_s``: seconds per frame of
        the frames after the first (:meth:`~spikeref.pipeline.Reconstructor.profile`; NaN for
        baselines and for a single scored frame).
    """
    from spikeref.accumulate import accumulate as eq4
    from spikeref.baselines import TFSTPState, tfi, tfstp
    from spikeref.bayer import demosaic_bilinear

    cfa = stream.cfa  # the benchmark scenes are Bayer streams

    def psi(x):
        return demosaic_bilinear(x, cfa)

    from spikeref.pipeline import STAGES

    frames, times, warmup = [], [], 0.0
    stage_keys = [k for k in (*STAGES, "other") if k != "write"]
    stages = dict.fromkeys(stage_keys, float("nan"))
    if setting.method in ("tfp", "tfi"):
        w = setting.window
        for t in centres:
            for _ in range(BASELINE_REPEATS):  # milliseconds each: repeat, so that one slow call does not decide
                t0 = time.perf_counter()
                if setting.method == "tfp":
                    img = psi(eq4(stream, w, start=t - w // 2, count=1)[0])
                else:
                    img = psi(tfi(stream, times=[t])[0])
                times.append(time.perf_counter() - t0)
            frames.append(img)
    elif setting.method == "tfstp":
        state = TFSTPState(stream.height, stream.width)
        wanted = set(centres)
        for t in range(centres[0] % SCORE_WINDOW, centres[-1] + 1, SCORE_WINDOW):  # the 2000-FPS video
            t0 = time.perf_counter()
            img = psi(tfstp(stream, times=[t], state=state)[0])
            times.append(time.perf_counter() - t0)
            if t in wanted:
                frames.append(img)
    elif setting.method == "ours":
        from spikeref.pipeline import ReconstructParams, Reconstructor

        w = setting.window
        offset = (centres[0] - w // 2) % w
        view = stream.slice(offset)
        ks = [(t - w // 2 - offset) // w for t in centres]
        extra = {} if align_params is None else {"align_params": align_params}
        if accumulate is not None:
            extra["accumulate"] = accumulate
        params = ReconstructParams(window=w, K=setting.K, L=setting.L, mode=setting.mode, align=setting.align,
                                   flow_frames=setting.flow_frames, warp=setting.warp, denoise=setting.denoise,
                                   **extra)
        rec = Reconstructor(view, params, denoiser)
        wanted = set(ks)
        t0 = time.perf_counter()
        first = None
        for k, frame in zip(range(ks[0], ks[-1] + 1), rec.frames(ks[0], ks[-1] + 1), strict=True):
            now = time.perf_counter()
            if k == ks[0]:
                warmup = now - t0
                first = rec.profile()
            else:
                times.append(now - t0)
            t0 = now
            if k in wanted:
                frames.append(frame.rgb)
        if not times:  # a single scored frame: its time is all we have
            times.append(warmup)
        else:  # the steady-state frames' breakdown: all of them less the first
            last, n = rec.profile(), rec.frames_made - first.frames
            stages = {k: (last.seconds[k] - first.seconds[k]) / n for k in stage_keys}
    else:
        raise ValueError(f"unknown method {setting.method!r}")
    return frames, {"seconds_per_frame": float(np.median(times)), "warmup_s": float(warmup),
                    **{f"{k}_s": float(v) for k, v in stages.items()}}


def _warm_up(stream, denoiser, modes) -> None:
    """Compile every kernel once (JIT time must not enter the first setting's timing)."""
    short = stream.slice(0, 120)
    centres = [55]
    for s in (Setting("tfp", 10), Setting("tfi", 0), Setting("tfstp", 0)):
        run_setting(s, short, centres)
    # L = 2 with alignment reaches every step's kernels (accumulate, align, Eq. 14 and 15, Ψ);
    # the other modes only add the masked volume and Φ, which L = 0 reaches
    run_setting(Setting("ours", 10, K=3, L=2), short, centres, denoiser)
    for mode in modes:
        if mode != "visible":
            run_setting(Setting("ours", 10, K=3, L=0, mode=mode), short, centres, denoiser)


def run_bench(grid: BenchGrid, seed: int = 0, denoiser=None, progress: bool = True, sheet_scene: str = "fan",
              log=None) -> dict:
    """Run ``grid`` on the benchmark scenes.

    Parameters
    ----------
    grid : BenchGrid
    seed : int
        Simulation seed (the same for every scene: the frames are deterministic).
    denoiser : Denoiser, optional
        Default: the bundled weights for what the method's windows give by default (the charge's,
        :func:`~spikeref.denoise.denoiser.bundled_weights`).
    progress : bool
        A progress bar over scene × setting.
    sheet_scene : str
        Scene whose middle scored frame goes on the contact sheet.

    Returns
    -------
    dict
        ``rows`` (one dict per scene × setting: scores averaged over the scored frames and the
        timings), ``settings``, ``scenes``, ``sheet`` (``{"reference": img, name: img}``),
        ``centres``.
    """
    from tqdm import tqdm

    from spikeref.denoise.denoiser import Denoiser, bundled_weights

    scenes = bench_scenes(grid.scenes)
    settings = grid_settings(grid)
    if not settings:
        raise ValueError("the grid has no method to run")
    uses_ours = any(s.method == "ours" for s in settings)
    if uses_ours and denoiser is None:  # the bundled network for what the default windows give
        from spikeref.pipeline import DEFAULT_ACCUMULATE

        denoiser = Denoiser.load(bundled_weights(DEFAULT_ACCUMULATE))
    rows, sheet, all_centres = [], {}, {}
    bar = tqdm(total=len(scenes) * len(settings), desc="bench", unit="run", disable=not progress)
    try:
        for i, sc in enumerate(scenes):
            bar.set_postfix_str(f"{sc.key}: simulating")
            sc.simulate(seed)
            if i == 0:
                bar.set_postfix_str("compiling kernels")
                _warm_up(sc.stream, denoiser, sorted({s.mode for s in settings if s.method == "ours"}))
            centres = score_centres(len(sc.stream), grid.frames)
            all_centres[sc.key] = centres
            refs = [sc.reference(t) for t in centres]
            mid = len(centres) // 2
            if sc.key == sheet_scene:
                sheet["reference"] = refs[mid].astype(np.float32)
            for s in settings:
                bar.set_postfix_str(f"{sc.key}: {s.name}")
                frames, timing = run_setting(s, sc.stream, centres, denoiser)
                scores = [_score(r, f) for r, f in zip(refs, frames, strict=True)]
                row = {"bench_version": BENCH_VERSION, "scene": sc.key, "setting": s.name, "method": s.method,
                       "W": s.window, "K": s.K if s.method == "ours" else "", "L": s.L if s.method == "ours" else "",
                       "mode": s.mode if s.method == "ours" else "",
                       "align": ("on" if s.align else "off") if s.method == "ours" else "",
                       "flow_frames": s.flow_frames if s.method == "ours" and s.align and s.L else "",
                       "warp": s.warp if s.method == "ours" and s.align and s.L else "",
                       "denoise": ("on" if s.denoise else "off") if s.method == "ours" else "",
                       **{m: float(np.mean([sc_[m] for sc_ in scores])) for m in METRICS},
                       **timing, "frames": len(frames), "height": sc.stream.height, "width": sc.stream.width}
                rows.append(row)
                if sc.key == sheet_scene:
                    sheet[s.name] = np.asarray(frames[mid], dtype=np.float32)
                if log is not None:
                    log(row)
                bar.update(1)
            sc.stream = None  # free the recording
    finally:
        bar.close()
    return {"rows": rows, "settings": settings, "scenes": [s.key for s in scenes], "sheet": sheet,
            "centres": all_centres, "seed": seed}
