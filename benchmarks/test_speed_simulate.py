"""Simulation speed: planes/s with no effects, with all effects, and the cost of each effect alone.

Baseline measured in the same run: a straightforward NumPy integrate-and-fire loop, one
plane at a time, vectorised over pixels (what one would write first).  The static colour
chart isolates the simulator (its radiance is rendered once); the fan adds per-readout
rendering of a moving scene.
"""

import numpy as np
import pytest

from benchmarks.conftest import best_time
from spikeref.simulate.camera import Camera
from spikeref.simulate.scenes import ColorChart, FanOverToys, Scene
from spikeref.simulate.simulator import simulate

ALL = {
    "threshold_fpn": {"sigma": 0.02},
    "random_phase": {},
    "hot_pixels": {"fraction": 1e-4, "rate": 0.2},
    "shot_noise": {"photons_per_threshold": 50},
    "dark_current": {"gamma": 0.002},
    "inherent_noise": {"mu": 2000, "sigma": 200, "fraction": 0.05},
}
SIZES = {"250x400": (250, 400, 320), "1000x1000": (1000, 1000, 48)}


def numpy_fire_loop(scene, planes):
    """Per-plane NumPy integrate-and-fire of a static scene (the baseline)."""
    from spikeref.simulate.camera import mosaic_radiance

    charge = mosaic_radiance(scene.content.radiance([0.0])[0].astype(np.float64), scene.camera.cfa)
    e = np.zeros(charge.shape)
    out = np.empty((planes,) + charge.shape, dtype=np.uint8)
    for t in range(planes):
        e += charge
        fired = e >= 1.0
        e[fired] -= 1.0
        out[t] = fired
    return out


def _chart(size, effects):
    h, w, planes = SIZES[size]
    return Scene(name="chart", content=ColorChart(height=h, width=w), planes=planes, camera=Camera(), effects=effects)


@pytest.mark.parametrize("size", list(SIZES))
def test_simulate_static(benchmark, report, size):
    scene = _chart(size, {})
    planes = scene.planes
    simulate(scene, planes=16)  # compile
    benchmark.pedantic(lambda: simulate(scene), rounds=3, iterations=1)
    t_fast = min(benchmark.stats.stats.min, best_time(lambda: simulate(scene), repeat=2))
    t_slow = best_time(lambda: numpy_fire_loop(scene, planes), repeat=1)
    report(f"simulate {size} chart, no effects", f"{planes / t_fast:9.0f} planes/s; NumPy loop "
           f"{planes / t_slow:7.0f} planes/s; ratio {t_slow / t_fast:5.1f}x")
    parsed = {}
    costs = []
    for name in list(ALL) + ["all"]:
        effects = ALL if name == "all" else {name: ALL[name]}
        sc = _chart(size, effects)
        t = best_time(lambda sc=sc: simulate(sc, seed=1), repeat=2)
        parsed[name] = t
        costs.append(f"{name} {t / t_fast:.2f}x")
    report(f"simulate {size} chart, all effects", f"{planes / parsed['all']:9.0f} planes/s "
           f"({parsed['all'] / t_fast:.1f}x the time without effects)")
    report(f"simulate {size}, each effect alone", "time vs none: " + ", ".join(costs[:-1]))


@pytest.mark.parametrize("size", list(SIZES))
def test_simulate_fan(benchmark, report, size):
    h, w, planes = SIZES[size]
    planes = max(16, planes // 4)
    for effects, label in (({}, "no effects"), (ALL, "all effects")):
        scene = Scene(name="fan", content=FanOverToys(height=h, width=w), planes=planes, camera=Camera(substeps=1),
                      effects=effects)
        simulate(scene, planes=16)
        t = best_time(lambda scene=scene: simulate(scene, seed=1), repeat=2)
        report(f"simulate {size} fan (1 sub-step), {label}", f"{planes / t:9.0f} planes/s (rendering included)")
    benchmark.pedantic(lambda: None, rounds=1, iterations=1)
