"""The U-Net (NumPy/Numba): the direct Numba convolution against im2col + BLAS and plain NumPy, and denoised frames/s.

Frames are colour mosaics: four Bayer planes of (H/2, W/2) per frame, one shared network.
``visible`` is one pass per plane, ``blind`` 16 (Eq. 10–11), ``mixed`` 17.
"""

import numpy as np
import pytest

from benchmarks.conftest import best_time
from spikeref.denoise.blindspot import blindspot_denoise
from spikeref.denoise.unet import UNet, UNetSpec, conv3x3, conv3x3_im2col, conv3x3_plain


@pytest.mark.parametrize("cin, cout", [(32, 32), (64, 32), (16, 16), (32, 16)])
def test_conv_layer(benchmark, report, cin, cout):
    """One 3×3 layer on a 128×224 plane (a 250×400 frame's Bayer plane after padding).

    The network's kernel (direct, Numba) against im2col + BLAS (its convolution until
    2026-11-23) and one ``einsum`` per tap (plain NumPy), on the same input.
    """
    rng = np.random.default_rng(0)
    xc = rng.standard_normal((1, cin, 128, 224)).astype(np.float32)
    w = (rng.standard_normal((cout, cin, 3, 3)) * 0.1).astype(np.float32)
    b = np.zeros(cout, np.float32)
    benchmark.pedantic(lambda: conv3x3(xc, w, b, 0.1), rounds=5, iterations=1, warmup_rounds=1)
    t_fast = benchmark.stats.stats.min  # best of 5, as best_time for the others
    x = np.ascontiguousarray(xc.transpose(0, 2, 3, 1))
    wmat = np.ascontiguousarray(w.transpose(2, 3, 1, 0).reshape(9 * cin, cout))
    t_blas = best_time(lambda: conv3x3_im2col(x, wmat, b, 0.1), repeat=5)
    t_plain = best_time(lambda: conv3x3_plain(xc, w, b, 0.1), repeat=2)
    gmac = 9 * cin * cout * 128 * 224 / 1e9
    report(f"conv3x3 {cin}->{cout} on 128x224",
           f"direct {t_fast * 1e3:6.1f} ms ({gmac / t_fast:5.1f} GMAC/s); im2col+BLAS {t_blas * 1e3:6.1f} ms "
           f"({gmac / t_blas:5.1f} GMAC/s); plain NumPy {t_plain * 1e3:7.1f} ms; "
           f"direct vs BLAS {t_blas / t_fast:4.1f}x, vs plain {t_plain / t_fast:5.1f}x")


@pytest.mark.parametrize("width", [16, 32, 48])
@pytest.mark.parametrize("size", [(250, 400), (1000, 1000)])
def test_denoise_visible(benchmark, report, width, size):
    net = UNet.random(UNetSpec(width=width))
    planes = np.random.default_rng(1).random((4, size[0] // 2, size[1] // 2)).astype(np.float32) * 0.3
    rounds = 3 if size[0] < 500 else 1
    benchmark.pedantic(lambda: blindspot_denoise(planes, net, "visible"), rounds=rounds, iterations=1)
    t = benchmark.stats.stats.median
    report(f"denoise visible, width {width}, {size[0]}x{size[1]}", f"{1 / t:7.2f} frames/s ({t:6.2f} s/frame)")


@pytest.mark.parametrize("width", [16, 32])
@pytest.mark.parametrize("mode", ["blind", "mixed"])
def test_denoise_blind_250x400(benchmark, report, width, mode):
    net = UNet.random(UNetSpec(width=width))
    planes = np.random.default_rng(1).random((4, 125, 200)).astype(np.float32) * 0.3
    benchmark.pedantic(lambda: blindspot_denoise(planes, net, mode), rounds=1, iterations=1)
    t = benchmark.stats.stats.median
    report(f"denoise {mode}, width {width}, 250x400", f"{1 / t:7.2f} frames/s ({t:6.2f} s/frame)")


@pytest.mark.parametrize("width", [16, 32])
@pytest.mark.parametrize("mode", ["blind", "mixed"])
def test_denoise_blind_1000x1000(benchmark, report, width, mode):
    """One blind pass over a 1000×1000 frame is 16 visible passes (20–25 s at width 16 here, ~4× at 32)."""
    net = UNet.random(UNetSpec(width=width))
    planes = np.random.default_rng(1).random((4, 500, 500)).astype(np.float32) * 0.3
    benchmark.pedantic(lambda: blindspot_denoise(planes, net, mode), rounds=1, iterations=1)
    t = benchmark.stats.stats.median
    report(f"denoise {mode}, width {width}, 1000x1000", f"{1 / t:7.3f} frames/s ({t:6.1f} s/frame)")
