"""The whole progressive warping (W = 10, K = 3, L = 3): output frames/s and where the time goes.

Input: Bernoulli spikes of a smooth texture moving 1 px per window, colour (RGGB), in memory.
The baseline measured in the same run is the denoised TFP (``L = 0``: one denoiser pass and Ψ
per frame), so the ratio says what the progressive warping costs on top of it.  Both ways of
making the flow frames are timed: the paper's denoised frames, and the smoothed frames of
``flow_frames="smoothed"`` (one denoiser pass per output frame), and the fast preset
(:meth:`ReconstructParams.fast`: the defaults with the chained warp), and the fastest preset (the fast one
without a denoiser).  Each line ends with the
stage breakdown of :meth:`Reconstructor.profile` and the share of the time outside the U-Net's
passes.  The denoiser is a width-16 U-Net (the bundled weights' shape; random weights cost the
same).
"""

import time

import numpy as np
import pytest

from spikeref.denoise.denoiser import Denoiser
from spikeref.denoise.unet import UNet, UNetSpec
from spikeref.pipeline import ReconstructParams, Reconstructor
from spikeref.stream import SpikeStream


def moving_texture_spikes(h, w, planes, seed=0) -> np.ndarray:
    """Bernoulli spikes ``(planes, h, w) uint8`` of a smooth texture moving 1 px per 10-plane window."""
    rng = np.random.default_rng(seed)
    from scipy.ndimage import gaussian_filter

    tex = gaussian_filter(rng.random((h + 64, w + 64)), 3.0)
    tex = 0.05 + 0.9 * (tex - tex.min()) / np.ptp(tex)
    out = np.empty((planes, h, w), np.uint8)
    for t in range(0, planes, 10):
        s = t // 10
        img = tex[32:32 + h, 32 + s % 32:32 + s % 32 + w]
        n = min(10, planes - t)
        out[t:t + n] = rng.random((n, h, w)) < img
    return out


def _stream(h, w, planes, seed=0):
    return SpikeStream.from_array(moving_texture_spikes(h, w, planes, seed), cfa="RGGB", check=False)


def _run(stream, params, den, n_frames):
    rec = Reconstructor(stream, params, den)
    a = rec.frames_available.start
    t0 = time.perf_counter()
    for _ in rec.frames(a, a + n_frames):
        pass
    return (time.perf_counter() - t0) / n_frames, rec.profile()


def _config(name):
    """``(params, denoiser)`` of a named configuration (the same width-16 network in both)."""
    net = UNet.random(UNetSpec(width=16), seed=0)
    if name == "paper":  # Fig. 3(b) as the paper: progressive warps, flows on D(I_l), D the network alone
        return ReconstructParams.paper(), Denoiser(net, guard="off", shrink=False)
    if name == "paper-smoothed":
        return ReconstructParams.paper(flow_frames="smoothed"), Denoiser(net, guard="off", shrink=False)
    if name == "fast":  # the fast preset: the defaults with only the step-0 flows, composed
        return ReconstructParams.fast(), Denoiser(net)
    if name == "fastest":  # the fast preset without a denoiser: no network pass
        return ReconstructParams.fastest(), None
    return ReconstructParams(), Denoiser(net)  # the defaults: composed warp, smoothed flow frames, z = 3, guard


@pytest.mark.parametrize("config", ["paper", "paper-smoothed", "defaults", "fast", "fastest"])
@pytest.mark.parametrize("size, n_frames", [((250, 400), 12), ((1000, 1000), 3)])
def test_pipeline_fps(benchmark, report, size, n_frames, config):
    params, den = _config(config)
    stream = _stream(*size, planes=(n_frames + 6) * 10 + 10)
    _run(stream, params, den, 1)  # compile
    per_frame, prof = benchmark.pedantic(lambda: _run(stream, params, den, n_frames), rounds=1, iterations=1)
    net = den.unet if den is not None else UNet.random(UNetSpec(width=16), seed=0)  # the baseline keeps its network
    base, _ = _run(stream, ReconstructParams(L=0), Denoiser(net, guard="off"), n_frames)
    parts = ", ".join(f"{k} {v / prof.total:4.0%}" for k, v in prof.seconds.items() if k != "write")
    report(f"pipeline W=10 K=3 L=3, {config}, {size[0]}x{size[1]}",
           f"{1 / per_frame:6.2f} frames/s ({per_frame:6.3f} s/frame); denoised TFP (L=0) {1 / base:6.2f} frames/s; "
           f"ratio {per_frame / base:4.1f}x; outside the network {prof.outside_network:4.0%}; time: {parts}")


def _steady_frame_time(stream, params, den, n_frames, skip) -> float:
    """Mean seconds per frame of frames ``skip … skip + n_frames − 1`` of one run that starts 20 windows in (the
    windows and flows every frame needs once are then made at the same pace as in a long recording)."""
    rec = Reconstructor(stream, params, den)
    a = rec.frames_available.start + 20
    times, t0 = [], time.perf_counter()
    for _ in rec.frames(a, a + skip + n_frames):
        t1 = time.perf_counter()
        times.append(t1 - t0)
        t0 = t1
    return float(np.mean(times[skip:]))


@pytest.mark.parametrize("size, n_frames, skip", [((250, 400), 30, 10), ((1000, 1000), 5, 2)])
def test_adaptive_merge_cost(benchmark, report, size, n_frames, skip):
    """The defaults (the adaptive merge and the multi-frame demosaic) and the adaptive merge through Ψ
    (``demosaic="bilinear"``, the defaults of 2026-11-28 before the multi-frame demosaic) against Eq. 14–15's binomial
    merge (``--merge binomial``, Ψ), alternated in one process."""
    net = UNet.random(UNetSpec(width=16), seed=0)
    stream = _stream(*size, planes=(skip + n_frames + 45) * 10)
    configs = {"adaptive": ReconstructParams(), "adaptive_psi": ReconstructParams(demosaic="bilinear"),
               "binomial": ReconstructParams(merge="binomial")}
    for params in configs.values():  # compile, and page the stream in
        _steady_frame_time(stream, params, Denoiser(net), 1, 1)
    got = {name: [] for name in configs}

    def run():
        for _ in range(2):
            for name, params in configs.items():
                got[name].append(_steady_frame_time(stream, params, Denoiser(net), n_frames, skip))

    benchmark.pedantic(run, rounds=1, iterations=1)
    ada, psi, binom = min(got["adaptive"]), min(got["adaptive_psi"]), min(got["binomial"])
    report(f"adaptive merge {size[0]}x{size[1]}", f"defaults {1 / ada:6.2f} frames/s; adaptive through Ψ "
           f"{1 / psi:6.2f}; binomial merge {1 / binom:6.2f}; ratios {binom / ada:4.2f}x and {binom / psi:4.2f}x "
           f"of the binomial's frames/s (best of two alternated runs)")
