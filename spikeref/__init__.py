"""spikeref: 2000 FPS colour HDR video from mosaicked chromatic spikes, on a CPU.

A readable NumPy/Numba reference implementation of Yang et al., "Real-data-driven
2000 FPS Color Video from Mosaicked Chromatic Spikes" (ECCV 2024).  Every
equation of the paper is a function here with a literal oracle
(:mod:`spikeref.oracles`) and golden vectors (``golden/``); see
``docs/equations.md`` for the map.
"""

import importlib

__version__ = "0.1.0.dev0"

# Public names and the module that defines each.  They are imported on first use (PEP 562),
# so ``import spikeref`` is quick and modules that need no Numba (the .dat layout, the
# training code on a machine without Numba) import without it.
_EXPORTS = {
    "SpikeStream": "spikeref.stream",
    "read_dat": "spikeref.stream",
    "write_dat": "spikeref.io.dat",
    "load_spikes": "spikeref.stream",
    "save_spikes": "spikeref.io.dat",
    "accumulate": "spikeref.accumulate",
    "accumulate_window": "spikeref.accumulate",
    "window_counts": "spikeref.accumulate",
    "bayer_planes": "spikeref.bayer",
    "bayer_mosaic": "spikeref.bayer",
    "cfa_channels": "spikeref.bayer",
    "demosaic_bilinear": "spikeref.bayer",
    "tfp": "spikeref.baselines",
    "tfi": "spikeref.baselines",
    "tfstp": "spikeref.baselines",
    "STPParams": "spikeref.baselines",
    "Scene": "spikeref.simulate.scenes",
    "load_scene": "spikeref.simulate.scenes",
    "simulate": "spikeref.simulate.simulator",
    "ground_truth": "spikeref.simulate.simulator",
    "noise_check": "spikeref.noise_check",
    "Denoiser": "spikeref.denoise.denoiser",
    "AlignParams": "spikeref.align",
    "align": "spikeref.align",
    "warp_spike_windows": "spikeref.warp",
    "warp_average": "spikeref.warp",
    "ReconstructParams": "spikeref.pipeline",
    "Reconstructor": "spikeref.pipeline",
    "reconstruct": "spikeref.pipeline",
    "psnr": "spikeref.metrics",
    "ssim": "spikeref.metrics",
    "pu21_encode": "spikeref.metrics",
    "pu21_psnr": "spikeref.metrics",
    "pu21_ssim": "spikeref.metrics",
}

__all__ = list(_EXPORTS)


def __getattr__(name):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'spikeref' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
