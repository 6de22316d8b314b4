"""The package's public names: every one resolves, and the functions that share a name with
their module (``accumulate``, ``align``, ``noise_check``) stay callable in any import order
(a defect the stability suite found: importing the submodule replaced the function)."""

import subprocess
import sys

import spikeref as sr

CHILD = """
import numpy as np
import spikeref.accumulate, spikeref.align, spikeref.noise_check   # submodules first
import spikeref as sr
from spikeref.stream import SpikeStream
spikes = np.ones((20, 4, 4), np.uint8)
assert sr.accumulate(spikes, 10).shape == (2, 4, 4)
tex = np.random.default_rng(0).random((64, 64)).astype(np.float32)
assert sr.align(tex, tex).shape == (2, 64, 64)
r = sr.noise_check(SpikeStream.from_array(np.ones((400, 4, 4), np.uint8)), windows=(10, 20))
import spikeref.accumulate as m
assert callable(m.window_counts) and m.accumulate is not None
print("ok")
"""


def test_every_public_name_resolves():
    for name in sr.__all__:
        assert getattr(sr, name) is not None, name


def test_functions_named_like_their_module_are_callable_whatever_was_imported_first():
    out = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "ok", out.stderr
