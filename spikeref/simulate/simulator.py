"""Simulate a scene: radiance → CFA → the listed effect stages → integrate-and-fire (§3, §4.1, §5.1).

The simulator renders the scene's linear RGB radiance for every readout (the mean of
``camera.substeps`` samples inside the readout), applies the Bayer CFA (Eq. 3), runs
**only** the effect stages the scene lists (:mod:`spikeref.simulate.effects`, in the order
given there), and integrates and fires (Eq. 1–2, :func:`spikeref.simulate.camera.fire`).
A scene with no effects is noise-free and deterministic.

Randomness and chunks
---------------------
Time is cut into blocks of :data:`BLOCK` readouts.  Every effect has its own random
stream, and within it every block has its own generator, derived from ``(seed, effect,
block)`` with :class:`numpy.random.SeedSequence`.  Hence

* the spikes do not depend on how a run is cut into chunks (chunks are whole blocks),
* the first ``n`` planes of a longer run equal a run of ``n`` planes,
* adding or removing one effect does not change the draws of the others.

Ground truth
------------
For window ``W`` and frame ``k`` (planes ``[start + kW, start + (k+1)W)``) the ground truth
is the mean over those readouts of the full-colour radiance the camera integrated (the same
sub-step samples), in **rate units** ``α L / E_th`` — the firing rate, in spikes per
readout, of a noise-free pixel with the nominal threshold behind a filter of that colour.
It is not clipped at 1, although the rate of a real pixel saturates there.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Iterator

import numpy as np
from tqdm import tqdm

from spikeref.simulate import effects as fx
from spikeref.simulate.camera import fire, mosaic_radiance
from spikeref.simulate.patterns import Uniform
from spikeref.stream import SpikeStream

__all__ = [
    "BLOCK",
    "SimulationChunk",
    "SimulationResult",
    "Simulation",
    "iter_simulation",
    "simulate",
    "ground_truth",
    "dark_scene",
    "resolve_seed",
]

#: Readouts per random block (chunks are whole blocks).
BLOCK = 16

#: Elements ``planes × H × W`` per chunk by default (about 128 MB of float64 charge).
CHUNK_ELEMENTS = 1 << 24

_STREAM_ID = {name: i + 1 for i, name in enumerate(fx.EFFECTS)}


def resolve_seed(seed) -> int:
    """An integer seed from ``seed``: an int ≥ 0, a Generator (one draw), or ``None`` (fresh entropy)."""
    if seed is None:
        return int(np.random.SeedSequence().entropy)
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, 2**63))
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed must be an int, a numpy Generator or None; got {type(seed).__name__}")
    if seed < 0:
        raise ValueError(f"seed must be non-negative; got {seed}")
    return int(seed)


def _rng(seed: int, effect: str, block: int | None = None, take: int = 0) -> np.random.Generator:
    """The draws of ``effect``: those made once (``block=None``: thresholds, initial phases, which pixels are hot or
    have inherent noise and their first spurious spike) from ``seed`` alone, those of one block of readouts also
    from ``take`` (0: the keys of every earlier version, so a recording of ``take=0`` is unchanged)."""
    key = (_STREAM_ID[effect],) if block is None else (_STREAM_ID[effect], block + 1)
    if block is not None and take:
        key = key + (take,)
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def _check_scene(scene):
    for attr in ("content", "camera", "effects", "planes"):
        if not hasattr(scene, attr):
            raise TypeError(f"scene must be a spikeref.simulate.scenes.Scene; got {type(scene).__name__}")


def readout_radiance(content, readout: int, substeps: int) -> np.ndarray:
    """Mean linear RGB radiance over readout ``[readout, readout + 1)``: ``(H, W, 3) float64``.

    The mean of ``substeps`` samples at ``readout + (s + ½)/substeps``.
    """
    times = readout + (np.arange(substeps, dtype=np.float64) + 0.5) / substeps
    rgb = np.asarray(content.radiance(times), dtype=np.float64)
    expected = (substeps, content.height, content.width, 3)
    if rgb.shape != expected:
        raise ValueError(f"scene content returned radiance of shape {rgb.shape}; expected {expected}")
    rgb = rgb.mean(axis=0)
    if not np.all(np.isfinite(rgb)) or rgb.min() < 0:
        raise ValueError(f"scene radiance must be finite and non-negative (readout {readout})")
    return rgb


@dataclass
class SimulationChunk:
    """One chunk of a simulation.

    Attributes
    ----------
    start : int
        Readout of ``spikes[0]``.
    spikes : ndarray ``(n, H, W) uint8``
    ground_truth : ndarray ``(k, H, W, 3) float32`` or None
        Ground-truth frames completed in this chunk (rate units), when asked for.
    gt_start : int
        Index of the first of those frames.
    """

    start: int
    spikes: np.ndarray
    ground_truth: np.ndarray | None = None
    gt_start: int = 0


class Simulation:
    """The state of one simulation run, advanced block by block.

    Parameters
    ----------
    scene : Scene
        What to simulate (content, camera, effects); see :mod:`spikeref.simulate.scenes`.
    seed : int, numpy.random.Generator or None
        Random seed (only used by effects); the integer actually used is ``self.seed``.
    effects : dict, optional
        ``{name: effect}`` replacing the scene's effects (``{}`` for none).
    gt_window : int, optional
        Also accumulate ground-truth frames of this many readouts.
    take : int
        Which recording of the same sensor (≥ 0): the draws made once (thresholds, initial phases, hot pixels,
        which pixels have inherent noise and their first spurious spike) come from ``seed`` alone, those of
        every block of readouts (shot noise, dark photons, the later spurious spikes) also from ``take`` — a dark
        recording of the sensor that recorded a scene is ``take=1`` with the scene's seed.
    """

    def __init__(self, scene, seed=0, effects=None, gt_window: int | None = None, take: int = 0):
        _check_scene(scene)
        if isinstance(take, (bool, np.bool_)) or not isinstance(take, (int, np.integer)) or take < 0:
            raise ValueError(f"take must be an integer ≥ 0; got {take!r}")
        self.take = int(take)
        if effects is not None:
            scene = replace(scene, effects=fx.parse_effects(effects))
        self.scene = scene
        self.seed = resolve_seed(seed)
        self.effects = dict(scene.effects)
        cam = scene.camera
        self.camera = cam
        shape = (scene.content.height, scene.content.width)
        self.shape = shape
        if cam.cfa is not None and (shape[0] % 2 or shape[1] % 2):
            raise ValueError(f"a Bayer sensor needs even height and width; got {shape[0]}×{shape[1]}")
        e = self.effects
        if "threshold_fpn" in e:
            self.thresholds = fx.fpn_thresholds(e["threshold_fpn"], cam.threshold, shape,
                                                _rng(self.seed, "threshold_fpn"))
        else:
            self.thresholds = np.full(shape, float(cam.threshold))
        self.thresholds = np.ascontiguousarray(self.thresholds, dtype=np.float64)
        if "random_phase" in e:
            self.state = fx.initial_phase(self.thresholds, _rng(self.seed, "random_phase"))
        else:
            self.state = np.zeros(shape, dtype=np.float64)
        self.hot = None
        if "hot_pixels" in e:
            self.hot = fx.hot_pixel_charge(e["hot_pixels"], cam.threshold, shape, _rng(self.seed, "hot_pixels"))
        self.inherent = None
        if "inherent_noise" in e:
            self.inherent = fx.InherentNoiseProcess(e["inherent_noise"], shape, _rng(self.seed, "inherent_noise"))
        self.readout = 0
        if gt_window is not None and (not isinstance(gt_window, (int, np.integer)) or gt_window < 1):
            raise ValueError(f"gt_window must be a positive integer; got {gt_window!r}")
        self.gt_window = gt_window
        self._gt_sum = np.zeros(shape + (3,), dtype=np.float64) if gt_window else None
        self._gt_count = 0
        self._gt_done = 0
        self._static_rgb = None
        self._static_charge = None
        self._charge_buf = None

    # ------------------------------------------------------------------ rendering
    def _rgb(self, readout: int) -> np.ndarray:
        content = self.scene.content
        if getattr(content, "static", False):
            if self._static_rgb is None:
                self._static_rgb = readout_radiance(content, 0, 1)
            return self._static_rgb
        return readout_radiance(content, readout, self.camera.substeps)

    def _charge(self, rgb: np.ndarray, out: np.ndarray) -> None:
        """``α L`` behind the CFA (Eq. 3) into ``out`` ``(H, W)``; a mono sensor sees the mean of R, G, B."""
        cam = self.camera
        if cam.cfa is not None:
            out[...] = mosaic_radiance(rgb, cam.cfa)
        else:
            out[...] = rgb.mean(axis=-1)
        out *= cam.alpha

    def _block(self, n: int, spikes: np.ndarray) -> list:
        """Simulate the next ``n ≤ BLOCK`` readouts (the current block, possibly cut short) into ``spikes``."""
        cam, e = self.camera, self.effects
        start = self.readout
        if start % BLOCK:
            raise RuntimeError("a simulation can only be cut at block boundaries")
        block = start // BLOCK
        h, w = self.shape
        gt_frames = []
        static = getattr(self.scene.content, "static", False)
        if static and self._static_charge is None:
            self._static_charge = np.empty((h, w), dtype=np.float64)
            self._charge(self._rgb(0), self._static_charge)
        changes_charge = self.hot is not None or "shot_noise" in e or "dark_current" in e
        if static and not changes_charge:  # the same charge every readout: a read-only broadcast view
            charge = np.broadcast_to(self._static_charge, (n, h, w))
        else:
            if self._charge_buf is None:  # reused: fresh large arrays would cost a page fault per 4 kB
                self._charge_buf = np.empty((BLOCK, h, w), dtype=np.float64)
            charge = self._charge_buf[:n]
        for k in range(n):
            if static:
                if changes_charge:
                    charge[k] = self._static_charge
                rgb = self._static_rgb
            else:
                rgb = self._rgb(start + k)
                self._charge(rgb, charge[k])
            if self._gt_sum is not None:
                self._gt_sum += rgb
                self._gt_count += 1
                if self._gt_count == self.gt_window:
                    gt_frames.append((self._gt_sum * (cam.alpha / (cam.threshold * self.gt_window))).astype(np.float32))
                    self._gt_sum[...] = 0.0
                    self._gt_count = 0
        if self.hot is not None:
            charge += self.hot
        if "shot_noise" in e:
            fx.add_shot_noise(charge, e["shot_noise"], cam.threshold,
                              _rng(self.seed, "shot_noise", block, self.take))
        if "dark_current" in e:
            fx.add_dark_current(charge, e["dark_current"], cam.alpha, BLOCK,
                                _rng(self.seed, "dark_current", block, self.take))
        # radiance was checked finite and ≥ 0 per readout, and every effect adds charge ≥ 0
        fire(charge, self.thresholds, self.state, out=spikes, check=False)
        if self.inherent is not None:
            self.inherent.apply_block(spikes, start, BLOCK, _rng(self.seed, "inherent_noise", block, self.take))
        self.readout += n
        return gt_frames

    def run(self, n: int) -> SimulationChunk:
        """Simulate the next ``n`` readouts; ``n`` must be a multiple of :data:`BLOCK` unless it is the last chunk."""
        if not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n must be a non-negative integer; got {n!r}")
        start = self.readout
        h, w = self.shape
        spikes = np.empty((n, h, w), dtype=np.uint8)
        gt = []
        gt_start = self._gt_done
        done = 0
        while done < n:
            m = min(BLOCK, n - done)
            frames = self._block(m, spikes[done:done + m])
            gt.extend(frames)
            done += m
        self._gt_done += len(gt)
        gt_arr = None
        if self._gt_sum is not None:
            gt_arr = np.stack(gt) if gt else np.zeros((0, h, w, 3), dtype=np.float32)
        return SimulationChunk(start=start, spikes=spikes, ground_truth=gt_arr, gt_start=gt_start)


def _default_chunk(height: int, width: int) -> int:
    return max(BLOCK, (CHUNK_ELEMENTS // max(1, height * width)) // BLOCK * BLOCK)


def iter_simulation(scene, seed=0, *, planes: int | None = None, effects=None, gt_window: int | None = None,
                    chunk_planes: int | None = None, progress: bool = False,
                    take: int = 0) -> Iterator[SimulationChunk]:
    """Simulate ``scene`` chunk by chunk (bounded memory), yielding :class:`SimulationChunk`.

    Parameters
    ----------
    scene : Scene
    seed : int, numpy.random.Generator or None
    planes : int, optional
        Readouts to simulate (default ``scene.planes``).
    effects : dict, optional
        Replaces the scene's effects: ``{name: {param: value}}`` or parsed effects; ``{}`` for none.
    gt_window : int, optional
        Also return ground-truth frames of this many readouts with each chunk.
    chunk_planes : int, optional
        Readouts per chunk, rounded up to a multiple of :data:`BLOCK`; the default keeps
        a chunk near 16 M pixel-readouts.  The result does not depend on it.
    progress : bool
        Show a progress bar (planes).
    take : int
        Which recording of the same sensor (:class:`Simulation`).
    """
    _check_scene(scene)
    total = scene.planes if planes is None else planes
    if not isinstance(total, (int, np.integer)) or total < 1:
        raise ValueError(f"planes must be a positive integer; got {total!r}")
    h, w = scene.content.height, scene.content.width
    if chunk_planes is None:
        chunk = _default_chunk(h, w)
    else:
        if not isinstance(chunk_planes, (int, np.integer)) or chunk_planes < 1:
            raise ValueError(f"chunk_planes must be a positive integer; got {chunk_planes!r}")
        chunk = -(-int(chunk_planes) // BLOCK) * BLOCK
    sim = Simulation(scene, seed=seed, effects=effects, gt_window=gt_window, take=take)

    with tqdm(total=int(total), desc=f"simulating {getattr(scene, 'name', '')}".strip(), unit="plane",
              disable=not progress, leave=False) as bar:
        while sim.readout < total:
            n = min(chunk, total - sim.readout)
            out = sim.run(n)
            bar.update(n)
            yield out


@dataclass
class SimulationResult:
    """Spikes of a simulated scene, with its ground truth on demand.

    Attributes
    ----------
    spikes : ndarray ``(T, H, W) uint8``
    scene : Scene
        The scene as simulated (its ``effects`` are the ones that ran).
    seed : int
        The integer seed used; with it the run is reproduced exactly.
    """

    spikes: np.ndarray
    scene: object
    seed: int
    _gt_cache: dict = field(default_factory=dict, repr=False)

    @property
    def stream(self):
        """The spikes as a :class:`spikeref.SpikeStream` (with the camera's CFA and rate)."""
        cam = self.scene.camera
        return SpikeStream.from_array(self.spikes, cfa=cam.cfa, rate_hz=cam.rate_hz, check=False)

    def ground_truth(self, window: int, start: int = 0) -> np.ndarray:
        """Ground-truth frames ``(n, H, W, 3) float32`` (rate units) for windows of ``window`` planes.

        Frame ``k`` is the mean over planes ``[start + kW, start + (k+1)W)``; only whole
        windows inside the simulated planes are returned.
        """
        key = (int(window), int(start))
        if key not in self._gt_cache:
            planes = self.spikes.shape[0]
            self._gt_cache[key] = ground_truth(self.scene, window, planes=planes, start=start)
        return self._gt_cache[key]


def simulate(scene, seed=0, *, planes: int | None = None, effects=None, progress: bool = False,
             take: int = 0) -> SimulationResult:
    """Simulate ``scene`` in memory.

    Parameters
    ----------
    scene : Scene
        Content (radiance over time), camera (Eq. 1–3 parameters) and effects; see
        :func:`spikeref.simulate.scenes.load_scene`.
    seed : int, numpy.random.Generator or None
        Seed of the effects' random draws (a scene without effects ignores it).
    planes : int, optional
        Readouts to simulate (default ``scene.planes``).
    effects : dict, optional
        Replaces the scene's effects (``{}``: noise-free).
    progress : bool
        Show a progress bar.
    take : int
        Which recording of the same sensor (:class:`Simulation`): ``take=1`` and :func:`dark_scene` give the
        dark recording a user would calibrate the sensor of ``take=0`` with.

    Returns
    -------
    SimulationResult
        ``.spikes`` ``(T, H, W) uint8`` and ``.ground_truth(window)``.
    """
    _check_scene(scene)
    total = scene.planes if planes is None else planes
    if not isinstance(total, (int, np.integer)) or total < 1:
        raise ValueError(f"planes must be a positive integer; got {total!r}")
    spikes = np.empty((int(total), scene.content.height, scene.content.width), dtype=np.uint8)
    sim_seed = resolve_seed(seed)
    ran = scene
    if effects is not None:
        ran = replace(scene, effects=fx.parse_effects(effects))
    for chunk in iter_simulation(ran, sim_seed, planes=int(total), progress=progress, take=take):
        spikes[chunk.start:chunk.start + chunk.spikes.shape[0]] = chunk.spikes
    return SimulationResult(spikes=spikes, scene=ran, seed=sim_seed)


def dark_scene(scene):
    """``scene`` with the lens covered: the same camera, size, effects and length, no light (a uniform radiance 0).

    Simulated with the scene's seed and ``take=1`` (:func:`simulate`) it is the dark recording of the sensor that
    recorded the scene — its fixed pattern and hot pixels, other noise draws — from which a user calibrates the
    dark level and the hot pixels (``spikeref calibrate``).
    """
    _check_scene(scene)
    c = scene.content
    dark = Uniform(height=c.height, width=c.width, rate_hz=c.rate_hz, brightness=0.0)
    return replace(scene, name=f"{scene.name} (dark)".strip(), content=dark)


def ground_truth(scene, window: int, planes: int | None = None, start: int = 0,
                 progress: bool = False) -> np.ndarray:
    """Ground-truth frames of ``scene``: ``(n, H, W, 3) float32`` in rate units ``α L / E_th``.

    Frame ``k`` is the mean radiance over readouts ``[start + kW, start + (k+1)W)``
    (each readout the mean of ``camera.substeps`` samples, as the camera integrates it);
    ``n = (planes - start) // window``.  Needs only the scene, not the spikes.
    """
    _check_scene(scene)
    total = scene.planes if planes is None else planes
    if not isinstance(window, (int, np.integer)) or window < 1:
        raise ValueError(f"window must be a positive integer; got {window!r}")
    if not isinstance(start, (int, np.integer)) or not 0 <= start <= total:
        raise ValueError(f"start must lie in [0, {total}]; got {start!r}")
    n = (total - start) // window
    content, cam = scene.content, scene.camera
    out = np.empty((n, content.height, content.width, 3), dtype=np.float32)
    scale = cam.alpha / (cam.threshold * window)
    if getattr(content, "static", False):
        out[...] = (readout_radiance(content, 0, 1) * (cam.alpha / cam.threshold)).astype(np.float32)
        return out

    for k in tqdm(range(n), desc="ground truth", unit="frame", disable=not progress, leave=False):
        acc = np.zeros((content.height, content.width, 3), dtype=np.float64)
        for r in range(start + k * window, start + (k + 1) * window):
            acc += readout_radiance(content, r, cam.substeps)
        out[k] = acc * scale
    return out
