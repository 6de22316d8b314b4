"""Literal oracles: slow, obviously-correct transcriptions of the paper's equations.

Each function here reads like the equation it names, loops over pixels and
planes in plain Python/NumPy, and is used only to check the fast kernels and
to produce the golden vectors in ``golden/`` (``scripts/make_golden.py``).
Nothing in the package calls them at run time.
"""

from spikeref.oracles.accumulate import accumulate_oracle
from spikeref.oracles.baselines import tfi_oracle, tfp_spikecv_oracle, tfstp_oracle
from spikeref.oracles.bayer import bayer_planes_oracle, demosaic_bilinear_oracle
from spikeref.oracles.dat import pack_dat_oracle, unpack_dat_oracle

__all__ = [
    "accumulate_oracle",
    "bayer_planes_oracle",
    "demosaic_bilinear_oracle",
    "pack_dat_oracle",
    "tfi_oracle",
    "tfp_spikecv_oracle",
    "tfstp_oracle",
    "unpack_dat_oracle",
]
