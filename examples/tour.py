"""A guided tour of the method: from the embedded sample's spikes to the 2000 FPS colour video, one idea per figure.

Every figure is made here from real computation with the package's own functions, on the
embedded sample (``spikeref/data/sample.dat``: a fan over toys, RGGB, 224×256, 264 planes at
20 000 planes/s, simulated with realistic sensor noise from ``spikeref/data/sample.toml``, whose
exact ground truth is recomputed from the scene) and, for the noise check, on a real recording
when ``../shared/data/real/`` is there.  One section per idea of the paper (Yang et al., ECCV
2024), each citing its equation:

1. the sample and its spikes (Eq. 3);
2. a pixel's charge, threshold and spikes over time, without and with each noise effect the
   sample lists (Eq. 1–3, Eq. 5–7);
3. the same frame accumulated over W = 1, 10 and 100 planes: noise against blur (Eq. 4);
4. the zero-mean noise check of Fig. 4a (Eq. 9);
5. the 16 masks and the blind-spot volume of one plane (Eq. 10–11);
6. what the network's visible and blind outputs look like, and the re-visible loss (Eq. 12);
7. every step R_0 … R_L of the progressive warping with its flow field (Fig. 3(b), Fig. 5, Eq. 13);
8. a window before and after warping (Eq. 14–15);
9. the stage ladder: what each stage gains (a small run, ``spikeref.bench.ladder``);
10. the video: consecutive output frames against the truth.

Writes ``NN_name.png`` into ``--out`` and the page that shows them with the equations and the
measured numbers, ``<out>.md`` beside that folder.  By default ``--out`` is the scratch folder
``out/tour`` of the current directory (the page: ``out/tour.md``; ``out/`` is git-ignored), so
a plain run never touches the committed page::

    python examples/tour.py [--out out/tour] [--small]

To regenerate the committed page, ``docs/tour/`` and ``docs/tour.md``, say so explicitly, from
anywhere (about a minute on two cores once the Numba kernels are compiled)::

    python examples/tour.py --update-docs

``--update-docs`` refuses ``--out`` and ``--small``, and refuses to run without the real
recording (``../shared/data/real/spikingsim_real_spike.npz`` beside the repository), whose section
the committed page shows.  ``--small`` makes every figure at a reduced size (fewer pixels traced,
fewer frames scored, the ladder on the sample alone): what ``tests/test_tour.py`` runs.  Needs
matplotlib (the ``plot`` or ``test`` extra).
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REAL = ROOT.parent / "shared" / "data" / "real" / "spikingsim_real_spike.npz"
#: The committed page's figures (``--update-docs``); the page is ``docs/tour.md``.
DOCS = ROOT / "docs" / "tour"
#: The default ``--out``: a scratch folder of the current directory (``out/`` is git-ignored).
SCRATCH = Path("out") / "tour"

try:  # a checkout that was not installed: use the package beside this folder
    import spikeref  # noqa: F401
except ImportError:  # pragma: no cover - depends on the installation
    sys.path.insert(0, str(ROOT))

#: The frame the tour follows: window k = 13 (planes 130 … 139, centred on plane 135 = 6.75 ms).
FRAME = 13
W, K, L = 10, 3, 3


# ----------------------------------------------------------------------------- figures
class Tour:
    """The shared inputs of every section and the figure writer."""

    def __init__(self, out: Path, small: bool):
        from spikeref.sample import load_sample, sample_scene
        from spikeref.simulate.simulator import ground_truth
        from spikeref.tonemap import choose_exposure

        self.out, self.small = out, small
        self.stream = load_sample()
        self.scene = sample_scene()
        self.cfa = self.stream.cfa
        start = FRAME * W
        self.truth = ground_truth(self.scene, W, planes=start + W, start=start)[0].astype(np.float64)
        self.exposure = choose_exposure(self.truth)
        self.peak = float(self.truth.max())
        self.files: list[Path] = []
        self._default = None

    def figure(self, width: float, height: float):
        from matplotlib.figure import Figure

        return Figure(figsize=(width, height), dpi=80)

    def save(self, fig, name: str) -> str:
        """Write ``fig`` as a 256-colour PNG (small enough to commit) and return its name."""
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=80)
        return self.keep(buf, name)

    def keep(self, png, name: str) -> str:
        """Re-encode a PNG (a file or a buffer) with 256 colours as ``out/name``; returns ``name``."""
        from PIL import Image

        with Image.open(png) as image:
            small = image.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=0)
        path = self.out / name
        small.save(path, format="PNG", optimize=True)
        self.files.append(path)
        return name

    def default_frames(self) -> list:
        """The package's default reconstruction (``ReconstructParams()``) of the frames around ``FRAME``, with
        their steps and flows; made once, for sections 7 and 10."""
        from spikeref.pipeline import ReconstructParams, Reconstructor

        if self._default is None:
            count = 2 if self.small else 4
            first = FRAME - count // 2
            rec = Reconstructor(self.stream, ReconstructParams(window=W, K=K, L=L))
            self._default = list(rec.frames(first, first + count, keep_steps=True))
        return self._default

    def fan_disk(self) -> np.ndarray:
        """``(H, W)`` bool: the pixels the fan's blades can cover (within its tip radius of the centre)."""
        h, w = self.stream.height, self.stream.width
        yy, xx = np.mgrid[0:h, 0:w]
        return np.hypot(yy - h / 2, xx - w / 2) <= self.scene.content.tip_radius + 1

    def show(self, ax, rgb, title: str) -> None:
        """A linear frame through the tour's one exposure (the truth's 99.5th percentile at 0.9, sRGB)."""
        from spikeref.tonemap import tonemap

        ax.imshow(tonemap(np.clip(rgb, 0, None), self.exposure), interpolation="nearest")
        ax.set_title(title, fontsize=8)
        ax.axis("off")

    def psi(self, planes) -> np.ndarray:
        """Ψ of four Bayer planes (Eq. 13's bilinear demosaic)."""
        from spikeref.bayer import bayer_mosaic, demosaic_bilinear

        return demosaic_bilinear(bayer_mosaic(np.asarray(planes, dtype=np.float32), self.cfa), self.cfa)

    def planes(self, k: int, window: int = W) -> np.ndarray:
        """``I_0(k)``: the four Bayer planes of firing rates of window ``k`` (Eq. 4)."""
        from spikeref.accumulate import accumulate
        from spikeref.bayer import bayer_planes

        return bayer_planes(accumulate(self.stream, window, start=k * window, count=1)[0], self.cfa)

    def psnr(self, rgb, where=None) -> float:
        """PSNR against the truth of window ``FRAME`` (the truth's peak as the data range, as ``spikeref bench``),
        over the pixels ``where`` is True (default all)."""
        from spikeref.metrics import psnr

        if where is None:
            return psnr(self.truth, rgb, self.peak)
        return psnr(self.truth[where][:, None], np.asarray(rgb)[where][:, None], self.peak)


# ----------------------------------------------------------------------------- 1. the sample
def section_sample(t: Tour) -> str:
    from spikeref.bayer import cfa_channel_map

    plane = t.stream.window(FRAME * W + W // 2, 1)[0]
    channel = cfa_channel_map(*plane.shape, t.cfa)
    colours = np.zeros(plane.shape + (3,), np.uint8)
    colours[plane == 1] = np.eye(3, dtype=np.uint8)[channel[plane == 1]] * 255
    y0, x0 = 40, 150
    fig = t.figure(8.4, 2.9)
    axes = fig.subplots(1, 3)
    axes[0].imshow(colours, interpolation="nearest")
    axes[0].set_title(f"plane {FRAME * W + W // 2}: {int(plane.sum())} spikes,\neach in its filter's colour",
                      fontsize=8)
    axes[1].imshow(colours[y0:y0 + 32, x0:x0 + 32], interpolation="nearest")
    axes[1].set_title(f"rows {y0}–{y0 + 31}, columns {x0}–{x0 + 31}:\nthe RGGB cells", fontsize=8)
    for ax in axes[:2]:
        ax.axis("off")
    t.show(axes[2], t.truth, f"the truth: mean radiance\nover planes {FRAME * W}–{FRAME * W + W - 1}")
    fig.tight_layout()
    name = t.save(fig, "01_sample.png")
    rate = float(np.mean([t.stream.window(s, 1).mean() for s in range(0, len(t.stream), 11)]))
    return f"""## 1. The sample: one bit per pixel per readout (Eq. 3)

![the sample's spikes]({t.out.name}/{name})

The embedded sample is what a colour spike camera records: every readout (1/20 000 s) is a
plane of bits `S_c(x, t)` (Eq. 3), one per pixel behind its colour filter (RGGB).  It is
{t.stream.height}×{t.stream.width} pixels and {len(t.stream)} planes ({len(t.stream) / 20:.1f} ms) of a fan
at {t.scene.content.revolutions_per_second:g} revolutions per second over toys, simulated with the sample's
noise effects; a pixel fires on average on {100 * rate:.0f} % of the readouts.  The truth on the right is
the scene's mean radiance over the 10 planes the tour follows (frame {FRAME}), recomputed exactly from
`spikeref/data/sample.toml`.
"""


# ----------------------------------------------------------------------------- 2. one pixel
#: The effects the sample lists, in the order the simulator applies them (spikeref.simulate.effects).
EFFECT_TITLES = {
    "threshold_fpn": "threshold FPN: E_th,x = E_th (1 + σz)",
    "random_phase": "random phase: E(x, 0) ~ U[0, E_th,x)",
    "dark_current": "dark current (Eq. 5): Poisson(γ) photons of charge α",
    "inherent_noise": "inherent noise (Eq. 7): spikes at N(μ, σ) intervals",
}


def _pixel_run(effects: dict, radiance: float, readouts: int, pixels: int, seed: int):
    """Integrate-and-fire (Eq. 1–2) of ``pixels`` pixels under the same constant radiance, with ``effects``.

    The stages of :class:`spikeref.simulate.simulator.Simulation` in its order (threshold FPN, random
    phase, dark current, fire, inherent noise), each from :mod:`spikeref.simulate.effects`, with
    α = E_th = 1.  Returns the charge per readout ``(T, n)``, the spikes ``(T, n)``, the thresholds
    ``(n,)`` and the initial accumulator ``(n,)``.
    """
    from spikeref.simulate import effects as fx
    from spikeref.simulate.camera import fire

    rng = np.random.default_rng(seed)
    shape = (1, pixels)
    thresholds = np.ones(shape)
    if "threshold_fpn" in effects:
        thresholds = fx.fpn_thresholds(effects["threshold_fpn"], 1.0, shape, rng)
    state = fx.initial_phase(thresholds, rng) if "random_phase" in effects else np.zeros(shape)
    start = state[0].copy()
    charge = np.full((readouts,) + shape, radiance)
    if "dark_current" in effects:
        fx.add_dark_current(charge, effects["dark_current"], 1.0, readouts, rng)
    spikes = fire(charge, thresholds, state)
    if "inherent_noise" in effects:
        fx.InherentNoiseProcess(effects["inherent_noise"], shape, rng).apply_block(spikes, 0, readouts, rng)
    return charge[:, 0], spikes[:, 0], thresholds[0], start


def _charge_trace(charge: np.ndarray, threshold: float, start: float) -> np.ndarray:
    """The accumulator of one pixel after each readout ``(T,)``, from the same kernel in one call.

    Copy ``j`` of the pixel receives the charge of readouts ``0 … j`` and none after (no charge: no
    change, no spike), so its final state is the accumulator after readout ``j``.
    """
    from spikeref.simulate.camera import fire

    n = len(charge)
    upto = np.where(np.arange(n)[:, None] <= np.arange(n)[None, :], charge[:, None], 0.0)  # (T, copies)
    state = np.full((1, n), start)
    fire(upto[:, None, :], threshold, state)
    return state[0]


def section_pixel(t: Tour) -> str:
    effects = dict(t.scene.effects)
    radiance, readouts = 0.13, (60 if t.small else 120)
    pixels = 512 if t.small else 4096
    runs = [("noise-free", {})] + [(EFFECT_TITLES.get(n, n), {n: e}) for n, e in effects.items()]
    runs.append(("all four, as the sample", effects))
    _, clean, _, _ = _pixel_run({}, radiance, readouts, 1, 0)
    clean = clean[:, 0]
    fig = t.figure(8.4, 1.25 * len(runs))
    axes = fig.subplots(len(runs), 1, sharex=True)
    counts = []
    for ax, (title, fx) in zip(axes, runs, strict=True):
        charge, spk, thr, start = _pixel_run(fx, radiance, readouts, pixels, seed=7)
        # the pixel (of the n) whose spikes differ most from the noise-free pixel's, ties to the first
        p = int(np.argmax((spk != clean[:, None]).sum(axis=0)))
        ax.plot(np.arange(readouts), _charge_trace(charge[:, p], thr[p], start[p]), color="0.3", lw=1)
        ax.axhline(thr[p], color="tab:orange", lw=1, ls="--")
        fired = np.flatnonzero(spk[:, p])
        ax.vlines(fired, -0.45, -0.1, color="tab:red", lw=1.5)
        extra = np.flatnonzero(spk[:, p] & (clean == 0))
        ax.vlines(extra, -0.45, -0.1, color="tab:blue", lw=2.5)
        ax.set_ylim(-0.5, 1.15)
        ax.set_yticks([0, 1])
        counts.append(int(spk[:, p].sum()))
        ax.set_title(f"{title} — {counts[-1]} spikes (noise-free: {int(clean.sum())})", fontsize=8, loc="left")
    axes[-1].set_xlabel("readout t (1/20 000 s)")
    axes[len(runs) // 2].set_ylabel("charge E (units of E_th)", fontsize=8)
    fig.tight_layout(h_pad=0.3)
    name = t.save(fig, "02_pixel.png")
    listed = ", ".join(f"`{n}`" for n in effects)
    return f"""## 2. A pixel: charge, threshold, spikes (Eq. 1–3) and the noise effects (Eq. 5–7)

![a pixel's charge and spikes]({t.out.name}/{name})

A pixel integrates its light, `E(x, t) = ∫ αL dt mod E_th` (Eq. 1), and fires a spike when
the charge reaches the threshold (Eq. 2; behind a colour filter, Eq. 3), keeping the charge
above it.  Grey: the charge after each readout, orange: the threshold, red ticks: spikes
(blue: spikes the noise-free pixel does not fire), for a constant radiance of {radiance} spikes
per readout.  The rows add, one at a time, the effects the sample lists ({listed}, with its
parameters; `spikeref.simulate.effects`), each on the pixel among {pixels} whose spikes
change most in these {readouts} readouts: threshold FPN and random phase move the spikes, dark
current (Eq. 5–6: a dark photon brings a whole threshold of charge, so it fires at once) and
inherent noise (Eq. 7) add some.  The tour runs the simulator's own stages
(`spikeref.simulate.camera.fire` and the effects) to make the spikes and the charge.
"""


# ----------------------------------------------------------------------------- 3. windows
def section_windows(t: Tour) -> str:
    from spikeref.accumulate import accumulate
    from spikeref.bayer import demosaic_bilinear

    centre = FRAME * W + W // 2
    images, scores = [], {}
    for window in (1, 10, 100):
        rates = accumulate(t.stream, window, start=centre - window // 2, count=1)[0]
        images.append((window, demosaic_bilinear(rates, t.cfa)))
        scores[window] = t.psnr(images[-1][1])
    fig = t.figure(8.4, 4.9)
    axes = fig.subplots(2, 4)
    y0, x0, side = 8, 100, 72  # a blade's path, top of the fan
    for col, (window, rgb) in enumerate(images + [("truth", t.truth)]):
        title = "the truth (W = 10)" if window == "truth" else f"W = {window}: {scores[window]:.1f} dB"
        t.show(axes[0, col], rgb, title)
        t.show(axes[1, col], rgb[y0:y0 + side, x0:x0 + side], f"rows {y0}–{y0 + side - 1}, cols {x0}–{x0 + side - 1}")
    fig.tight_layout()
    name = t.save(fig, "03_windows.png")
    return f"""## 3. Accumulation: noise against blur (Eq. 4)

![the same frame at W = 1, 10, 100]({t.out.name}/{name})

The simplest reconstruction counts each pixel's spikes over a window of `W` planes,
`I_c = M_c/W · Σ S_c` (Eq. 4; `spikeref.accumulate`, `M_c = 1`), then demosaics with Ψ.  All
three frames are centred on plane {centre}.  One plane (W = 1) is all noise ({scores[1]:.1f} dB
against the truth of the 10 planes), W = 10 is sharp but noisy ({scores[10]:.1f} dB), W = 100
(5 ms) is smooth where the scene is still but smears the blades ({scores[100]:.1f} dB).  The rest
of the method is about getting the noise of W = 100 down without its blur.
"""


# ----------------------------------------------------------------------------- 4. noise check
def _still_corners(t: Tour) -> np.ndarray:
    """The sample's four 48×48 corners, outside the blade tips (the background never changes there): 96×96."""
    spikes = t.stream.window(0, len(t.stream))
    h, w, s = t.stream.height, t.stream.width, 48
    top = np.concatenate([spikes[:, :s, :s], spikes[:, :s, w - s:]], axis=2)
    bottom = np.concatenate([spikes[:, h - s:, :s], spikes[:, h - s:, w - s:]], axis=2)
    return np.ascontiguousarray(np.concatenate([top, bottom], axis=1))


def section_noise_check(t: Tour) -> str:
    from spikeref.noise_check import noise_check, plot_noise_check

    corners = noise_check(_still_corners(t), windows=(2, 5, 10, 20, 50, 100), cfa=t.cfa)
    name = "04_noise_check_sample.png"
    t.keep(plot_noise_check(corners, t.out / name), name)
    g = corners.channels.index("G")
    text = f"""## 4. The noise has zero mean (Fig. 4a, Eq. 9)

![Fig. 4a on the sample's still corners]({t.out.name}/{name})

The denoiser is trained without clean images because a short window scatters around its
expectation with zero mean: `E[I_c] = L + E[N]/W` (Eq. 9).  `spikeref.noise_check` measures
Fig. 4a's noise ratio `I_c / E[I_c] − 1` per channel against `W`, with `E[I_c]` each pixel's
rate over the whole span.  On the sample's four still 48×48 corners (outside the blade tips,
{corners.planes} planes) the mean ratio (dashed) stays on zero while its spread (solid, mean
`|ratio|`) falls from {corners.mean_abs_ratio[0, g]:.2f} at W = {corners.windows[0]} to
{corners.mean_abs_ratio[-1, g]:.3f} at W = {corners.windows[-1]} (G)."""
    if REAL.is_file():
        with np.load(REAL) as data:
            spikes = np.moveaxis(data["arr_0"], -1, 0)  # stored (H, W, T)
        if t.small:
            spikes = spikes[:200, :64, :64]
        real = noise_check(np.ascontiguousarray(spikes), windows=(2, 5, 10, 20, 50, 100, 250))
        rname = "04_noise_check_real.png"
        t.keep(plot_noise_check(real, t.out / rname), rname)
        text += f"""

![Fig. 4a on a real recording]({t.out.name}/{rname})

The same check on a real monochrome recording (SpikingSIM's `real_spike.npz`, {spikes.shape[1]}×{spikes.shape[2]},
{real.planes} planes of a near-static outdoor scene, read from `../shared/data/real/` when it is
there): the ratio falls from {real.mean_abs_ratio[0, 0]:.2f} at W = {real.windows[0]} to
{real.mean_abs_ratio[-1, 0]:.3f} at W = {real.windows[-1]}, its mean stays near zero — real sensor noise
behaves as the paper says."""
    else:
        text += """

(A real recording is checked the same way when `../shared/data/real/` is there; it was not when
this page was made.)"""
    return text + "\n"


# ----------------------------------------------------------------------------- 5. blind spot
def section_blindspot(t: Tour) -> str:
    from spikeref.denoise.blindspot import cell_masks, masked_volume

    plane = t.planes(FRAME)[1]  # the first G plane of I_0, rates
    side = 16
    # the crop: the 16×16 block (on an 8-pixel grid) where the truth's G varies most, so the fill shows
    green = t.truth[0::2, 1::2, 1]
    starts = [(y, x) for y in range(0, green.shape[0] - side + 1, 8) for x in range(0, green.shape[1] - side + 1, 8)]
    y0, x0 = max(starts, key=lambda p: float(green[p[0]:p[0] + side, p[1]:p[1] + side].std()))
    crop = plane[y0:y0 + side, x0:x0 + side].astype(np.float64)
    volume = masked_volume(crop, 4)  # (16, side, side)
    masks = cell_masks(side, side, 4)
    fig = t.figure(8.4, 4.3)
    grid = fig.add_gridspec(4, 8)
    ax = fig.add_subplot(grid[:, :4])
    order = np.arange(16).reshape(4, 4)
    ax.imshow(np.tile(order, (2, 2)), cmap="tab20", interpolation="nearest")
    for y in range(8):
        for x in range(8):
            ax.text(x, y, str(order[y % 4, x % 4]), ha="center", va="center", fontsize=8)
    ax.set_title("mask M_i hides pixel i of every 4×4 cell\n(two cells shown each way)", fontsize=8)
    ax.axis("off")
    top = float(np.percentile(crop, 99))
    for i in range(16):
        a = fig.add_subplot(grid[i // 4, 4 + i % 4])
        a.imshow(volume[i], cmap="gray", vmin=0, vmax=top, interpolation="nearest")
        ys, xs = np.nonzero(masks[i])
        a.scatter(xs, ys, s=6, c="tab:red", marker="s", linewidths=0)
        a.set_title(f"Ω_{i}", fontsize=7, pad=1)
        a.axis("off")
    fig.tight_layout()
    name = t.save(fig, "05_blindspot.png")
    return f"""## 5. The blind-spot volume (Eq. 10–11)

![the 16 masks and the masked volume]({t.out.name}/{name})

Each Bayer plane is cut into 4×4 cells; mask `M_i` hides pixel `i` of every cell, top to bottom,
left to right (left).  The masked volume `Ω_c` holds 16 copies of the plane, each with its hidden
pixels (red) filled from their 8 neighbours (`spikeref.denoise.blindspot.masked_volume`; Eq. 11
writes `(1 − M_i) I_c`, and as Blind2Unblind the package fills the holes instead:
[the specification](spec/denoise.md#eq10_11_blindspot)).  Shown: a {side}×{side} crop (rows
{y0}–{y0 + side - 1}, columns {x0}–{x0 + side - 1} of the plane grid, where the truth varies most) of
the first G plane of frame {FRAME} at W = {W}.  The network `f_θ` denoises every `Ω_i`, and Φ keeps
at each pixel the output of the copy that hid it: `D(I_c) = Σ_i M_i f_θ(Ω_c,i) / Σ_i M_i`
(Eq. 10–11), so no output pixel has seen its own noisy value.
"""


# ----------------------------------------------------------------------------- 6. visible and blind
def section_denoiser(t: Tour) -> str:
    from spikeref.denoise.denoiser import Denoiser
    from spikeref.denoise.revisible import revisible_loss

    den = Denoiser.load(guard="off", shrink=False)  # the paper's D: the network alone
    noisy = t.planes(FRAME)
    visible = den(noisy, "visible", window=W)
    blind = den(noisy, "blind", window=W)
    lam = 2.0
    mixed = (blind + lam * visible) / (1 + lam)
    images = [("I_0 (W = 10)", noisy), ("visible f_θ(I): 1 pass", visible),
              ("blind D(I), Eq. 10–11: 16 passes", blind), (f"(D + λf)/(1 + λ), λ = {lam:g}", mixed)]
    fig = t.figure(8.4, 2.5)
    axes = fig.subplots(1, 5)
    scores = {}
    for ax, (title, planes) in zip(axes[:-1], images, strict=True):
        rgb = t.psi(planes)
        scores[title] = t.psnr(rgb)
        t.show(ax, rgb, f"{title}\n{scores[title]:.1f} dB")
    t.show(axes[-1], t.truth, "the truth\n")
    fig.tight_layout()
    name = t.save(fig, "06_denoiser.png")
    losses = {lv: revisible_loss(blind, visible, noisy, lv, 1.0) for lv in (2.0, 20.0)}
    return f"""## 6. Visible and blind outputs, and the re-visible loss (Eq. 12)

![noisy, visible, blind and mixed outputs]({t.out.name}/{name})

The bundled network (`b2u_w16`, trained self-supervised on spike streams only) run as the paper
has it, without the package's guard or shrinkage.  Its *blind* output `D(I)` (Eq. 10–11, 16
passes) never sees a pixel's own value, so it cannot copy the noise but loses some detail
({scores[images[2][0]]:.1f} dB); the *visible* output `f_θ(I)` (one pass on the unmasked frame)
keeps more ({scores[images[1][0]]:.1f} dB; the noisy frame: {scores[images[0][0]]:.1f} dB).
Training ties the two with the re-visible loss
`‖D(I) + λ f_θ(I) − (λ + 1) I‖² + η ‖D(I) − I‖²` (Eq. 12; `spikeref.denoise.revisible`, λ from
2 to 20): on this frame it is {losses[2.0]:.4g} at λ = 2 and {losses[20.0]:.4g} at λ = 20
(η = 1, means over pixels).  The pipeline uses the visible output (one pass).
"""


# ----------------------------------------------------------------------------- 7. progressive steps
def section_steps(t: Tour) -> tuple[str, object]:
    from spikeref.denoise.denoiser import Denoiser
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.tonemap import tonemap

    params = ReconstructParams.paper(window=W, K=K, L=L)
    rec = Reconstructor(t.stream, params, Denoiser.load(guard="off", shrink=False))
    (frame,) = list(rec.frames(FRAME, FRAME + 1, keep_steps=True))
    (ours,) = [f for f in t.default_frames() if f.index == FRAME]
    disk = t.fan_disk()
    fig = t.figure(8.4, 4.4)
    axes = fig.subplots(2, L + 1)
    scores = []
    for level, rgb in enumerate(frame.steps):
        scores.append(t.psnr(rgb))
        t.show(axes[0, level], rgb, f"R_{level}: {((K - 1) * level + 1) * W} planes, {scores[-1]:.1f} dB")
    ours_scores = [t.psnr(rgb) for rgb in ours.steps]
    blades = [t.psnr(rgb, disk) for rgb in frame.steps]
    gain = 4.0  # arrows drawn 4× their length
    mags = []  # 99th percentile of the flow's length inside the blades' circle, plane pixels
    for level in range(L):
        ax = axes[1, level]
        flow = frame.flows[(level, 1)]  # F_l(k, k+1): where the content of window k is in window k+1
        ax.imshow(tonemap(np.clip(frame.steps[level].mean(axis=-1), 0, None), t.exposure), cmap="gray", vmin=0,
                  vmax=255, interpolation="nearest")
        step = 8
        yy, xx = np.mgrid[step // 2:flow.shape[1]:step, step // 2:flow.shape[2]:step]
        dy, dx = flow[0, yy, xx], flow[1, yy, xx]
        ax.quiver(2 * xx + 0.5, 2 * yy + 0.5, 2 * dx * gain, 2 * dy * gain, color="tab:orange", angles="xy",
                  scale_units="xy", scale=1, width=0.006, headwidth=3)
        mags.append(float(np.percentile(np.hypot(flow[0], flow[1])[disk[::2, ::2]], 99)))
        ax.set_title(f"F_{level}(k, k+1), drawn on R_{level}", fontsize=8)
        ax.axis("off")
    t.show(axes[1, L], t.truth, "the truth")
    fig.tight_layout()
    name = t.save(fig, "07_steps.png")
    paper_db, blades_db, ours_db = (", ".join(f"{v:.1f}" for v in vals) for vals in (scores, blades, ours_scores))
    text = f"""## 7. Progressive warping: every step R_0 … R_L and its flow (Fig. 3(b), Fig. 5, Eq. 13)

![R_0 … R_3 and their flows]({t.out.name}/{name})

Frame {FRAME} by the paper's procedure exactly (`ReconstructParams.paper()`, W = {W}, K = {K},
L = {L}, the network's `D` alone).  Step 0 denoises and demosaics each window,
`R_0 = Ψ[D(I_0)]` (Eq. 13), and aligns it with its neighbours (HDR+ tiles, `spikeref.align`);
each later step averages K frames of the step before, warped by those flows, so `R_l` gathers
`((K − 1)l + 1)·W` planes of light without their motion.  Bottom: the flow from window k to window
k+1 estimated at each step, drawn as arrows {gain:g}× their length on the frame it was estimated on
(`ReconstructedFrame.flows`): the fan turns counter-clockwise, about {2 * mags[0]:.0f} px per window
near the tips (the 99th percentile of step 0's flow inside the blades' circle, in image pixels).
On this fast fan the steps gain little: {paper_db} dB for `R_0 … R_{L}` over the frame, {blades_db} dB
inside the blades' circle, and the plain HDR+ search finds motion on the still background at the
later steps.  The package's defaults (each window's charge instead of its count, the noise-aware
search, flows on smoothed frames, the composed warp with the adaptive merge, the guard and, for the last step, the
multi-frame demosaic instead of Ψ; `ReconstructParams()`) give {ours_db} dB for the same steps.
"""
    return text, frame


# ----------------------------------------------------------------------------- 8. warping
def section_warp(t: Tour, frame) -> str:
    from spikeref.denoise.denoiser import Denoiser
    from spikeref.warp import warp_average, warp_bilinear, warp_spike_windows

    half = (K - 1) // 2
    windows = {i: t.planes(FRAME + i) for i in range(-half, half + 1)}
    flows = np.stack([frame.flows[(0, i)] if i else np.zeros_like(frame.flows[(0, 1)])
                      for i in range(-half, half + 1)])
    moved, _ = warp_bilinear(windows[1], flows[-1])
    counts = np.stack([windows[i] for i in range(-half, half + 1)]) * W
    eq14 = warp_spike_windows(counts, flows, W)
    plain = counts.sum(axis=0) / (K * W)
    den = Denoiser.load(guard="off", shrink=False)
    d_ref, d_next = den(windows[0], "visible", window=W), den(windows[1], "visible", window=W)
    eq15 = warp_average(np.stack([d_ref, d_next]), np.stack([np.zeros_like(flows[-1]), flows[-1]]))
    d_moved, _ = warp_bilinear(d_next, flows[-1])
    before = float(np.mean(np.abs(d_next - d_ref)))
    after = float(np.mean(np.abs(d_moved - d_ref)))
    disk = t.fan_disk()
    on_blades = {name: t.psnr(t.psi(img), disk) for name, img in (("plain", plain), ("eq14", eq14))}
    fig = t.figure(8.4, 4.6)
    axes = fig.subplots(2, 4)
    t.show(axes[0, 0], t.psi(windows[0]), f"window k = {FRAME}")
    t.show(axes[0, 1], t.psi(windows[1]), "window k+1")
    t.show(axes[0, 2], t.psi(moved), "window k+1 warped onto k")
    t.show(axes[0, 3], t.psi(eq14), f"Eq. 14: K = {K} warped, summed\n{t.psnr(t.psi(eq14)):.1f} dB")
    t.show(axes[1, 0], t.psi(plain), f"K = {K} summed, not warped\n{t.psnr(t.psi(plain)):.1f} dB")
    diff_top = float(np.percentile(np.abs(d_next - d_ref), 99.5))
    for ax, img, title in ((axes[1, 1], np.abs(d_next - d_ref), f"|D(k+1) − D(k)|: mean {before:.4f}"),
                           (axes[1, 2], np.abs(d_moved - d_ref), f"after warping: mean {after:.4f}")):
        ax.imshow(t.psi(img).mean(axis=-1), cmap="magma", vmin=0, vmax=diff_top, interpolation="nearest")
        ax.set_title(title, fontsize=8)
        ax.axis("off")
    t.show(axes[1, 3], t.psi(eq15), "Eq. 15 on D(k), D(k+1)")
    fig.tight_layout()
    name = t.save(fig, "08_warp.png")
    return f"""## 8. A window before and after warping (Eq. 14–15)

![a window before and after warping]({t.out.name}/{name})

Top: the spike window after frame {FRAME}'s is moved back onto it by the flow `F_0(k, k+1)` of
section 7 (backward bilinear sampling per Bayer plane, `spikeref.warp`); Eq. 14 does this for
the K = {K} windows around k and sums their spikes, `I_1 = 1/(KW) Σ S(x + F_0(x, t, t'), t')`
(`warp_spike_windows`).  Over the whole frame, mostly still background, the two sums score alike;
inside the blades' circle the warped sum scores {on_blades["eq14"]:.1f} dB and the unwarped one
{on_blades["plain"]:.1f} dB.  Bottom: the same for two denoised frames, as each later step does
(Eq. 15, `warp_average`): where the blades were (the difference before warping), the difference
after warping is mostly gone; the mean absolute difference drops from {before:.4f} to {after:.4f} spikes per
readout, the rest being noise.
"""


# ----------------------------------------------------------------------------- 9. ladder
def section_ladder(t: Tour) -> str:
    from spikeref.bench.ladder import RUNG_LABELS, RUNGS, plot_ladder, run_ladder
    from spikeref.bench.runner import BenchScene, bench_scenes
    from spikeref.sample import SAMPLE_SCENE

    sample = BenchScene("sample", SAMPLE_SCENE, t.scene, t.stream)
    sample.simulate = lambda seed: None  # already recorded
    scenes = [sample]
    if t.small:
        rungs, frames = ("tfp", "net", "ours", "limit"), 1
    else:
        # no classical peers (an extra) and no MHC rungs (an output option, not a stage): a minute at most
        rungs, frames = tuple(r for r in RUNGS if r not in ("bm3d", "nlm", "ours_mhc", "limit_mhc")), 1
        scenes += [s for s in bench_scenes() if s.key in ("static", "translation")]  # with a motion model
    result = run_ladder(scenes, frames=frames, peers=(), rungs=rungs, progress=False)
    name = "09_ladder.png"
    plot_ladder(result, t.out / name)
    t.keep(t.out / name, name)
    by = {(r["scene"], r["rung"]): r["psnr"] for r in result["rows"]}
    keys = [s.key for s in scenes]
    gains = "; ".join(
        f"{k}: TFP(W) {by[(k, 'tfp')]:.1f}, D on W {by[(k, 'net')]:.1f}, ours {by[(k, 'ours')]:.1f}, "
        f"limit {by[(k, 'limit')]:.1f} dB" for k in keys)
    labels = ", ".join(RUNG_LABELS[r] for r in result["rungs"])
    scene_list = ", ".join(f"`{k}`" for k in keys)
    return f"""## 9. What each stage gains: the stage ladder

![the stage ladder of a small run]({t.out.name}/{name})

`spikeref.bench.ladder` makes the same output frames every way, from one noisy window up to the
physical limit (the noise-free mosaic of the truth through Ψ), and scores each against the exact
truth (PSNR, linear RGB): {labels}.  This is a small run made by the tour itself — {frames}
scored frame per scene on {scene_list} — not the benchmark's full ladder (`docs/ladder.png`, made
by `spikeref bench --ladder` on its eight scenes, four frames each, with the classical peers and
the MHC demosaic; its table is in `docs/results_history.md`).  Here: {gains}.  With one frame per
scene, differences under a few tenths of a dB are noise.
"""


# ----------------------------------------------------------------------------- 10. video
def section_video(t: Tour) -> str:
    from spikeref.metrics import psnr
    from spikeref.simulate.simulator import ground_truth

    frames = t.default_frames()
    count, first = len(frames), frames[0].index
    truths = ground_truth(t.scene, W, planes=(first + count) * W, start=first * W)
    fig = t.figure(2.1 * count, 4.6)
    axes = fig.subplots(2, count)
    scores = []
    for j, (f, truth) in enumerate(zip(frames, truths, strict=True)):
        scores.append(psnr(truth, f.rgb, float(truth.max())))
        t.show(axes[0, j], f.rgb, f"frame {f.index}: {(f.index + 0.5) * W / 20:.2f} ms, {scores[-1]:.1f} dB")
        t.show(axes[1, j], truth, f"the truth, planes {f.index * W}–{f.index * W + W - 1}")
    fig.tight_layout()
    name = t.save(fig, "10_video.png")
    return f"""## 10. The video

![consecutive output frames]({t.out.name}/{name})

The package's default reconstruction (`ReconstructParams()`: the paper's W = {W}, K = {K},
L = {L} with the measured additions the README lists) gives one frame per window: {count}
consecutive frames, 0.5 ms apart (2000 FPS), {", ".join(f"{s:.1f}" for s in scores)} dB.
`spikeref reconstruct` writes all of them as `reconstruction.mp4` and linear EXR frames.
"""


# ----------------------------------------------------------------------------- main
SECTIONS = (section_sample, section_pixel, section_windows, section_noise_check, section_blindspot,
            section_denoiser)


def parse_args(argv=None) -> argparse.Namespace:
    """The command line, with ``out`` resolved: ``--out``, ``DOCS`` with ``--update-docs``, else ``SCRATCH``."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=None,
                    help=f"folder of the figures; the page is written beside it as <out>.md (default: {SCRATCH}, "
                         "a scratch folder of the current directory)")
    ap.add_argument("--update-docs", action="store_true",
                    help=f"regenerate the committed page: write {DOCS.relative_to(ROOT)}/ and "
                         f"{DOCS.relative_to(ROOT)}.md (the full tour; not with --out or --small)")
    ap.add_argument("--small", action="store_true",
                    help="every figure at a reduced size (the test's run)")
    args = ap.parse_args(argv)
    if args.update_docs:
        if args.out is not None:
            ap.error("--update-docs writes docs/tour/ and docs/tour.md: leave out --out")
        if args.small:
            ap.error("--update-docs makes the committed page, which is the full tour: leave out --small")
        if not REAL.is_file():
            ap.error(f"--update-docs: the committed page shows the real recording {REAL.name}, which is not in "
                     f"{REAL.parent}; regenerating without it would drop that section")
        args.out = DOCS
    elif args.out is None:
        args.out = SCRATCH
    return args


def main(argv=None) -> list[Path]:
    """Write the figures and the page; returns the files written (figures, then the page)."""
    args = parse_args(argv)
    args.out = args.out.resolve()  # the files returned and printed are absolute
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        sys.exit("tour.py: error: the tour draws with matplotlib: pip install 'spikeref[plot]'")
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    tour = Tour(args.out, args.small)
    parts = []
    for section in SECTIONS:
        parts.append(section(tour))
    steps_text, frame = section_steps(tour)
    parts.append(steps_text)
    parts.append(section_warp(tour, frame))
    parts.append(section_ladder(tour))
    parts.append(section_video(tour))
    page = args.out.parent / f"{args.out.name}.md"
    command = "python examples/tour.py" + (" --update-docs" if args.update_docs else "") + (
        " --small" if args.small else "")
    head = f"""# A guided tour: from spikes to 2000 FPS colour video

One figure per idea of the paper (Yang et al., *Real-data-driven 2000 FPS Color Video from
Mosaicked Chromatic Spikes*, ECCV 2024), each made from real computation on the embedded sample
by `{command}` (this page and the figures in
`{args.out.name}/` are its output).  Every frame is linear RGB in spikes per readout, shown through
one exposure; every PSNR is `spikeref.metrics.psnr` against the exact truth of the same 10
planes, the truth's peak as the data range.  `docs/equations.md` maps each equation to its
function, oracle, test and golden file.
"""
    page.write_text(head + "\n" + "\n".join(parts), encoding="utf-8")
    print(f"wrote {len(tour.files)} figures into {args.out} and {page} in {time.perf_counter() - t0:.1f} s")
    return tour.files + [page]


if __name__ == "__main__":
    main()
