"""Write a simulation to disk in chunks: ``.dat`` spikes, a JSON sidecar, ground truth as NPZ/EXR.

Memory is bounded by one chunk (see :func:`spikeref.simulate.simulator.iter_simulation`),
whatever the number of planes; every file is written atomically.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from spikeref.io.atomic import atomic_write
from spikeref.io.dat import DatWriter, sidecar_path
from spikeref.io.exr import write_exr
from spikeref.io.npz import NpzWriter
from spikeref.simulate import effects as fx
from spikeref.simulate.simulator import iter_simulation, resolve_seed

__all__ = ["simulate_to_dat", "gt_exr_name", "sidecar_path"]


def gt_exr_name(index: int) -> str:
    """File name of ground-truth frame ``index`` in an EXR folder."""
    return f"gt_{index:06d}.exr"


def _effects_table(effects: dict) -> dict:
    out = {}
    for name, effect in effects.items():
        out[name] = {k: v for k, v in vars(effect).items()} if vars(effect) else {}
    return out


def simulate_to_dat(scene, path, seed=0, *, planes: int | None = None, effects=None, gt_path=None,
                    gt_window: int = 10, gt_exr_dir=None, chunk_planes: int | None = None,
                    progress: bool = False) -> dict:
    """Simulate ``scene`` into the ``.dat`` file ``path`` (and its ground truth), chunk by chunk.

    Parameters
    ----------
    scene : Scene
    path : str or Path
        Output ``.dat`` (the layout of ``docs/spec/io.md``).  A sidecar ``NAME.json`` records height, width,
        CFA, readout rate, planes, scene name, seed and effects, so ``spikeref`` commands
        open the file without ``--height/--width/--cfa``.
    seed : int, numpy.random.Generator or None
    planes : int, optional
        Readouts (default ``scene.planes``).
    effects : dict, optional
        Replaces the scene's effects (``{}``: none).
    gt_path : str or Path, optional
        ``.npz`` with ``gt`` ``(n, H, W, 3) float32`` (rate units ``α L / E_th``), ``window``,
        ``start`` (0), ``rate_hz`` and ``fps`` (= ``rate_hz / window``).
    gt_window : int
        ``W`` of the ground-truth frames, in readouts.
    gt_exr_dir : str or Path, optional
        Also write each ground-truth frame as ``gt_NNNNNN.exr`` (float32 linear RGB) here.
    chunk_planes : int, optional
        Readouts per chunk (memory); the output does not depend on it.
    progress : bool
        Show a progress bar.

    Returns
    -------
    dict
        The sidecar's content.
    """
    path = Path(path)
    if path.suffix.lower() != ".dat":
        raise ValueError(f"output must be a .dat file; got {path.name!r}")
    total = scene.planes if planes is None else planes
    seed = resolve_seed(seed)
    if effects is not None:
        scene = replace(scene, effects=fx.parse_effects(effects))
    want_gt = gt_path is not None or gt_exr_dir is not None
    if want_gt and (not isinstance(gt_window, (int, np.integer)) or gt_window < 1):
        raise ValueError(f"gt_window must be a positive integer; got {gt_window!r}")
    if gt_path is not None and Path(gt_path).suffix.lower() != ".npz":
        raise ValueError(f"ground truth goes to a .npz file; got {Path(gt_path).name!r}")
    if gt_exr_dir is not None:
        Path(gt_exr_dir).mkdir(parents=True, exist_ok=True)
    h, w = scene.content.height, scene.content.width
    cam = scene.camera
    n_gt = int(total) // gt_window if want_gt else 0

    npz = NpzWriter(gt_path) if gt_path is not None else None
    member = npz.stream("gt", (n_gt, h, w, 3), np.float32) if npz is not None else None
    try:
        with DatWriter(path, h, w) as writer:
            for chunk in iter_simulation(scene, seed, planes=total, gt_window=gt_window if want_gt else None,
                                         chunk_planes=chunk_planes, progress=progress):
                writer.append(chunk.spikes)
                if want_gt and chunk.ground_truth.shape[0]:
                    if member is not None:
                        member.append(chunk.ground_truth)
                    if gt_exr_dir is not None:
                        for i, frame in enumerate(chunk.ground_truth):
                            write_exr(Path(gt_exr_dir) / gt_exr_name(chunk.gt_start + i), frame)
        if npz is not None:
            npz.add("window", np.int64(gt_window))
            npz.add("start", np.int64(0))
            npz.add("rate_hz", np.float64(cam.rate_hz))
            npz.add("fps", np.float64(cam.rate_hz / gt_window))
            npz.add("units", np.array("rate: alpha*L/E_th, spikes per readout"))
            npz.close()
    except BaseException:
        if npz is not None:
            npz.abort()
        raise
    meta = {
        "height": h,
        "width": w,
        "cfa": cam.cfa or "mono",
        "rate_hz": cam.rate_hz,
        "planes": int(total),
        "scene": getattr(scene, "name", ""),
        "seed": seed,
        "effects": _effects_table(scene.effects),
        "camera": {"threshold": cam.threshold, "alpha": cam.alpha, "substeps": cam.substeps},
        "written_by": "spikeref simulate",
    }
    text = json.dumps(meta, indent=2) + "\n"
    atomic_write(sidecar_path(path), lambda tmp: Path(tmp).write_text(text))
    return meta
