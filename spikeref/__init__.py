"""spikeref: 2000 FPS colour HDR video from mosaicked chromatic spikes, on a CPU.

A readable NumPy/Numba reference implementation of Yang et al., "Real-data-driven
2000 FPS Color Video from Mosaicked Chromatic Spikes" (ECCV 2024).  Every
equation of the paper is a function here with a literal oracle
(:mod:`spikeref.oracles`) and golden vectors (``golden/``); see
``docs/equations.md`` for the map.
"""

from spikeref.accumulate import accumulate, accumulate_window, window_counts
from spikeref.baselines import STPParams, tfi, tfp, tfstp
from spikeref.bayer import bayer_mosaic, bayer_planes, cfa_channels, demosaic_bilinear
from spikeref.io.dat import load_spikes, read_dat, save_spikes, write_dat
from spikeref.noise_check import noise_check
from spikeref.simulate.scenes import Scene, load_scene
from spikeref.simulate.simulator import ground_truth, simulate
from spikeref.stream import SpikeStream

__version__ = "0.1.0.dev0"

__all__ = [
    "SpikeStream",
    "read_dat",
    "write_dat",
    "load_spikes",
    "save_spikes",
    "accumulate",
    "accumulate_window",
    "window_counts",
    "bayer_planes",
    "bayer_mosaic",
    "cfa_channels",
    "demosaic_bilinear",
    "tfp",
    "tfi",
    "tfstp",
    "STPParams",
    "Scene",
    "load_scene",
    "simulate",
    "ground_truth",
    "noise_check",
]
