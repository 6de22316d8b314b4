"""Chromatic spike simulator: Eq. 1–3 behind a Bayer CFA, the noise effects of Eq. 5–9, scenes."""

from spikeref.simulate.camera import Camera, fire, mosaic_radiance
from spikeref.simulate.effects import EFFECTS, parse_effects
from spikeref.simulate.recording import simulate_to_dat
from spikeref.simulate.scenes import CONTENT_TYPES, Scene, load_scene, scene_from_dict
from spikeref.simulate.simulator import SimulationResult, ground_truth, iter_simulation, simulate

__all__ = [
    "Camera",
    "fire",
    "mosaic_radiance",
    "EFFECTS",
    "parse_effects",
    "Scene",
    "CONTENT_TYPES",
    "load_scene",
    "scene_from_dict",
    "simulate",
    "iter_simulation",
    "ground_truth",
    "SimulationResult",
    "simulate_to_dat",
]

from spikeref._callable import make_module_callable  # noqa: E402

make_module_callable(__name__, "simulate")  # `sr.simulate(...)` works after any import of this subpackage
