"""Study: does a timing-aware firing rate of one W-plane window beat Eq. 4's ``count / W``?

Eq. 4 (TFP) estimates a pixel's rate in the window ``[s, s + W)`` as ``n / W``.  An
integrate-and-fire pixel of constant rate ``p`` fires nearly periodically, so the count's error is
mostly the ±1 quantisation of the residual charge at the two window edges (variance
``≈ 1 / (6 W²)``).  The spike *times* (on the readout grid) locate those residual charges to a
fraction ``≈ p`` of an interval, so in the quantisation-limited regime a timing-aware estimate
should have ``≈ p²`` times the count's quantisation variance.  This script measures how much of
that survives the simulator's other noise (shot noise, threshold fixed-pattern noise, spurious
spikes, motion) and a real recording.

Estimators (per pixel, per window; spike ``k`` at readout ``t_k``; readout ``r`` integrates the
time ``[r, r + 1)``, so a threshold crossing seen at readout ``t_k`` is placed at ``t_k + ½``):

``tfp``
    ``n / W`` (Eq. 4, :func:`spikeref.accumulate.accumulate`).
``span``
    Planes inside the window only: ``(n − 1) / (t_n − t_1)`` when ``n ≥ 2`` spikes, else
    ``n / W``.  The same as the residual-charge form below with both edge phases extrapolated
    from the window's own first and last spike at the rate ``(n − 1)/(t_n − t_1)``.
``lsq``
    Planes inside the window only: ``1 / slope`` of the least-squares line ``t_k ≈ a + k / p``
    when ``n ≥ 3``; ``span`` otherwise (uses every spike time, not only the two extreme ones).
``resid``
    Residual charge with a margin of ``M = W`` planes each side: the cumulative charge ``Q(t)``
    is interpolated linearly between the crossings ``(t_k + ½, k)``, and
    ``p̂ = (Q(s + W) − Q(s)) / W = (n + φ(s + W) − φ(s)) / W`` with
    ``φ(b) = (b − t_prev − ½) / (t_next − t_prev)`` the elapsed fraction of the interval that
    straddles the edge ``b`` (``t_prev < b ≤ t_next``).  Where that interval is not bracketed
    inside the margin, ``φ = ½`` (the mean of a uniform phase: the count's own assumption).
    The estimate is still the mean rate over ``[s, s + W)``; the margin only locates the edges.
``bracket``
    Margin ``M = W``: ``(n + 1) / (t_next(s + W) − t_prev(s))`` — whole intervals over the span
    from the last spike before the window to the first one after it (a window stretched by up to
    one interval each side); ``n / W`` where either spike is missing from the margin.
``tfi``
    ``1 / ISI`` at the window's centre plane ``s + W // 2`` (:func:`spikeref.baselines.tfi`).

Scores (the conventions of ``scripts/eval_guard.py``, whose ``score``, ``scene_cases``' windows
and ``real_cases``' truth are reused):

(a) RMSE (×1000, spikes per readout) of the rate mosaic against the exact ground truth mosaic
    (each pixel's channel of ``spikeref.simulate.simulator.ground_truth``), 8-pixel border left
    out, no gain fitted;
(b) PSNR (``eval_guard.score``) of ``Ψ`` of the mosaic (``demosaic_bilinear(bayer_mosaic(planes))``)
    against the RGB ground truth, a least-squares gain per channel;
(c) the same PSNR after the bundled denoiser (``Denoiser.load()``, SURE guard on, and
    ``guard="off"``), called as ``den(planes, window=W)`` on each estimator's Bayer planes, and
    BM3D (``--bm3d``; bench scenes at ``W = 10`` only, if installed; σ estimated blind per plane).
    ``--weff`` adds the guarded network told a noise-equivalent window
    ``W_eff = W · σ_TFP / σ_input`` (both σ estimated blind, ``spikeref.denoise.guard.noise_sigma``,
    clipped to ``[W, 10 W]``): the count-domain network and the guard's quantisation floor
    otherwise assume the noise of a ``W``-plane count, several times the timing input's.

Sets: ``bench`` (the benchmark scenes, seed 0, windows starting at planes 300 and 420, as
``eval_guard.scene_cases``) and ``real`` (SpikingSIM's real monochrome recording, pseudo truth the
mean of planes 300–500 as ``eval_guard.real_cases``, scored without Ψ; windows start at planes 50
and 150 — not 0 and 100 — so that a margin of up to 50 planes fits before the window and stays
clear of the truth's planes).

    python scripts/study_window_timing.py [--set bench|real] [--windows 10,20,50] [--no-denoise] [--bm3d]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

from eval_guard import BORDER, REAL, STARTS, score  # noqa: E402

REAL_STARTS_MARGIN = (50, 150)
ESTIMATORS = ("tfp", "span", "lsq", "resid", "bracket", "tfi")
DENOISED = ("tfp", "span", "resid", "bracket")  # inputs fed to the denoisers


# --------------------------------------------------------------------------- estimators
def _first(mask: np.ndarray, base: int):
    """Plane index of the first True along axis 0 (``base`` + offset) and whether there is one."""
    has = mask.any(axis=0)
    return base + np.argmax(mask, axis=0), has


def _last(mask: np.ndarray, base: int):
    has = mask.any(axis=0)
    return base + mask.shape[0] - 1 - np.argmax(mask[::-1], axis=0), has


def window_rates(spikes: np.ndarray, s: int, w: int, margin: int, tfi_frame: np.ndarray) -> tuple[dict, dict]:
    """All estimators' rates ``(H, W) float64`` for the window ``[s, s + w)`` of ``spikes (T, H, W)``.

    Returns the rates by name and the fraction of pixels where each timing estimator fell back.
    """
    T = spikes.shape[0]
    lo, hi = max(0, s - margin), min(T, s + w + margin)
    inside = spikes[s : s + w].astype(bool)
    n = inside.sum(axis=0).astype(np.float64)
    out = {"tfp": n / w}
    fallback = {}

    # span: (n − 1) / (t_n − t_1)
    t1, _ = _first(inside, s)
    tn, _ = _last(inside, s)
    two = n >= 2
    span = np.where(two, (n - 1) / np.maximum(tn - t1, 1), n / w)
    out["span"] = span
    fallback["span"] = float(np.mean(~two))

    # lsq: 1 / slope of t_k on k (k = 0 … n − 1), n ≥ 3
    t = np.arange(s, s + w, dtype=np.float64)[:, None, None]
    k = np.cumsum(inside, axis=0) - 1.0  # index of the spike at a spike plane
    ks = np.where(inside, k, 0.0)
    ts = np.where(inside, t, 0.0)
    sk, st, skk, skt = ks.sum(0), ts.sum(0), (ks * ks).sum(0), (ks * ts).sum(0)
    three = n >= 3
    nn = np.maximum(n, 1)
    cov = skt - sk * st / nn
    var = skk - sk * sk / nn
    slope = np.where(three & (var > 0), cov / np.where(var > 0, var, 1), 1.0)
    out["lsq"] = np.where(three & (slope > 0), 1.0 / np.where(slope > 0, slope, 1), span)
    fallback["lsq"] = float(np.mean(~three))

    # residual charge with the margin
    def edge(b):
        before = spikes[lo:b].astype(bool)
        after = spikes[b:hi].astype(bool)
        tp, hp = _last(before, lo) if before.shape[0] else (np.zeros(n.shape, int), np.zeros(n.shape, bool))
        tq, hq = _first(after, b) if after.shape[0] else (np.zeros(n.shape, int), np.zeros(n.shape, bool))
        ok = hp & hq
        phi = np.where(ok, (b - tp - 0.5) / np.maximum(tq - tp, 1), 0.5)
        return phi, ok, tp, tq, hp, hq

    phi0, ok0, tp0, _, hp0, _ = edge(s)
    phi1, ok1, _, tq1, _, hq1 = edge(s + w)
    out["resid"] = (n + phi1 - phi0) / w
    fallback["resid"] = float(np.mean(~(ok0 & ok1)))

    both = hp0 & hq1
    out["bracket"] = np.where(both, (n + 1) / np.maximum(tq1 - tp0, 1), n / w)
    fallback["bracket"] = float(np.mean(~both))

    out["tfi"] = tfi_frame.astype(np.float64)
    return out, fallback


def self_check() -> None:
    """Noise-free constant-rate pixels with random phases: the estimators' bias and RMSE."""
    rng = np.random.default_rng(0)
    print("noise-free constant rate (random phase): RMSE ×1000 (bias ×1000), margin M = W")
    print("| p | W | " + " | ".join(ESTIMATORS[:-1]) + " | √(1/6W²) | p·√(1/6W²) |")
    print("|---:|---:|" + "---:|" * (len(ESTIMATORS) + 1))
    for p in (0.0537, 0.1913, 0.3771, 0.6133, 0.8291):  # pW not whole (a whole pW counts exactly)
        for w in (10, 20, 50):
            npx = 4000
            T = 3 * w
            acc = rng.uniform(0, 1, npx) + p * np.arange(1, T + 1)[:, None]  # charge after readout r
            spikes = np.diff(np.floor(acc), axis=0, prepend=np.floor(acc[:1] - p)).astype(np.uint8)
            spikes = spikes.reshape(T, 1, npx)
            est, _ = window_rates(spikes, w, w, w, np.zeros((1, npx)))
            cells = [f"{1e3 * np.sqrt(np.mean((est[m] - p) ** 2)):.2f} ({1e3 * np.mean(est[m] - p):+.2f})"
                     for m in ESTIMATORS[:-1]]
            q = np.sqrt(1 / (6 * w * w))
            print(f"| {p} | {w} | " + " | ".join(cells) + f" | {1e3 * q:.2f} | {1e3 * p * q:.2f} |")


# --------------------------------------------------------------------------- cases
def bench_cases(windows):
    """``(key, W, start, spikes (T, H, W), truth RGB (H, W, 3), truth mosaic, cfa)``, as eval_guard.scene_cases."""
    from spikeref.bayer import cfa_channel_map
    from spikeref.bench.runner import bench_scenes
    from spikeref.simulate.simulator import ground_truth

    for sc in bench_scenes(()):
        sc.simulate(0)
        spikes = np.ascontiguousarray(sc.stream.window(0, len(sc.stream)))
        cfa = sc.stream.cfa
        h, wd = spikes.shape[1:]
        chan = cfa_channel_map(h, wd, cfa)
        yy, xx = np.mgrid[:h, :wd]
        for w in windows:
            for start in STARTS:
                truth = ground_truth(sc.scene, w, planes=start + w, start=start)[0]
                yield sc.key, w, start, spikes, truth, truth[yy, xx, chan], cfa
        sc.stream = None


def real_cases_margin(windows, truth_kind="mean"):
    """The real recording: pseudo truth = mean of planes 300–500 (eval_guard.real_cases), windows at 50 and 150."""
    with np.load(REAL) as data:
        spikes = np.ascontiguousarray(data["arr_0"].transpose(2, 0, 1))  # (T, H, W)
    if truth_kind == "mean":
        truth = spikes[300:500].mean(axis=0, dtype=np.float64)
    else:  # planes 280–500 only (the windows and their margins end by plane 250)
        truth = window_rates(spikes, 300, 180, 20, np.zeros(spikes.shape[1:]))[0]["resid"]
    for w in windows:
        for start in REAL_STARTS_MARGIN:
            if start + w + min(w, 50) <= 300 and start - min(w, 50) >= 0:
                yield "real_outdoor", w, start, spikes, truth, truth, None


# --------------------------------------------------------------------------- main
def main() -> None:
    from spikeref.baselines import tfi
    from spikeref.bayer import bayer_mosaic, bayer_planes, demosaic_bilinear

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=("bench", "real"), default="bench")
    ap.add_argument("--windows", default="10,20,50")
    ap.add_argument("--no-denoise", action="store_true", help="only (a) and (b)")
    ap.add_argument("--bm3d", action="store_true", help="BM3D on TFP and the timing inputs (bench, W = 10)")
    ap.add_argument("--weff", action="store_true",
                    help="also the guarded network told the timing input's noise-equivalent window W_eff")
    ap.add_argument("--real-truth", choices=("mean", "timing"), default="mean",
                    help="real set: pseudo truth = mean of planes 300–500 (eval_guard) or the 'resid' rate of "
                         "planes 300–480 (margin 20), a less noisy pseudo truth from the same planes")
    ap.add_argument("--check", action="store_true", help="only the noise-free constant-rate check")
    args = ap.parse_args()
    if args.check:
        self_check()
        return
    windows = [int(x) for x in args.windows.split(",")]

    denoisers = {}
    if not args.no_denoise:
        from spikeref.denoise.denoiser import Denoiser

        guarded, plain = Denoiser.load(), Denoiser.load(guard="off")
        denoisers["net+guard"] = lambda p, w: guarded(p, window=w)
        denoisers["net"] = lambda p, w: plain(p, window=w)
        if args.weff:
            denoisers["net+guard@Weff"] = lambda p, w: guarded(p, window=w_eff(p, w))
        if args.bm3d:
            from spikeref.denoise.peers import PeerDenoiser, peer_available

            if peer_available("bm3d"):
                peer = PeerDenoiser("bm3d")
                denoisers["bm3d"] = lambda p, w: peer(p, window=w)
            else:
                print("BM3D not installed: left out")

    from spikeref.denoise.guard import noise_sigma

    tfp_sigma2 = [None]  # the TFP planes' noise variance of the current window (Immerkær)

    def w_eff(planes, w):
        """Noise-equivalent window of a timing input: W·σ_TFP/σ_input (both estimated blind), in [W, 10 W]."""
        s2 = float(np.mean(noise_sigma(planes) ** 2))
        return float(np.clip(w * np.sqrt(tfp_sigma2[0] / max(s2, 1e-12)), w, 10 * w))

    cases = real_cases_margin(windows, args.real_truth) if args.set == "real" else bench_cases(windows)
    crop = (slice(BORDER, -BORDER), slice(BORDER, -BORDER))
    rmse, psnr, fb, secs, keys = {}, {}, {}, {}, []
    t_all = time.perf_counter()
    for key, w, start, spikes, truth, truth_mosaic, cfa in cases:
        if key not in keys:
            keys.append(key)
            print(f"{key} …", flush=True)
        t0 = time.perf_counter()
        tfi_frame = tfi(spikes, [start + w // 2])[0]
        est, fallback = window_rates(spikes, start, w, w, tfi_frame)
        secs.setdefault("estimators (all)", []).append(time.perf_counter() - t0)
        for name, f in fallback.items():
            fb.setdefault((key, w, name), []).append(f)

        def psi(mosaic, cfa=cfa):
            return mosaic if cfa is None else demosaic_bilinear(mosaic.astype(np.float32), cfa)

        for name, rate in est.items():
            err = rate[crop] - truth_mosaic[crop]
            rmse.setdefault((key, w, name), []).append(float(np.sqrt(np.mean(err ** 2))))
            psnr.setdefault((key, w, name, "none"), []).append(score(truth, psi(rate)))
            if name not in DENOISED:
                continue
            planes = bayer_planes(rate.astype(np.float32))
            if name == "tfp":
                tfp_sigma2[0] = float(np.mean(noise_sigma(planes) ** 2))
            for dname, fn in denoisers.items():
                if dname == "bm3d" and (w != 10 or args.set != "bench"):
                    continue
                if dname.endswith("@Weff") and name == "tfp":  # W_eff = W for TFP
                    psnr.setdefault((key, w, name, dname), []).append(psnr[(key, w, name, "net+guard")][-1])
                    continue
                t1 = time.perf_counter()
                out = np.asarray(fn(planes, w), np.float32)
                secs.setdefault(dname, []).append(time.perf_counter() - t1)
                psnr.setdefault((key, w, name, dname), []).append(score(truth, psi(bayer_mosaic(out))))
    total = time.perf_counter() - t_all

    def table(title, get, cols, fmt):
        print(f"\n{title}")
        print("| scene | W | " + " | ".join(cols) + " |")
        print("|---|---:|" + "---:|" * len(cols))
        for w in windows:
            ks = [k for k in keys if get(k, w, cols[0]) is not None]
            if not ks:
                continue
            for k in ks:
                print(f"| {k} | {w} | " + " | ".join(fmt(get(k, w, c)) for c in cols) + " |")
            if len(ks) > 1:
                print(f"| **mean** | {w} | " + " | ".join(
                    "**" + fmt(np.mean([get(k, w, c) for k in ks])) + "**" for c in cols) + " |")

    def mean_of(d, *key):
        v = d.get(key)
        return None if v is None else float(np.mean(v))

    print(f"\n=== set {args.set}, margin M = W, windows {windows} ===")
    table("(a) RMSE ×1000 of the rate mosaic vs the ground truth (no gain; lower is better)",
          lambda k, w, c: None if (k, w, c) not in rmse else 1e3 * mean_of(rmse, k, w, c),
          list(ESTIMATORS), lambda v: f"{v:.2f}")
    table("(b) PSNR dB of Ψ(mosaic), eval_guard.score (higher is better)",
          lambda k, w, c: mean_of(psnr, k, w, c, "none"), list(ESTIMATORS), lambda v: f"{v:.2f}")
    for dname in denoisers:
        table(f"(c) PSNR dB after {dname}, input = estimator",
              lambda k, w, c, d=dname: mean_of(psnr, k, w, c, d), list(DENOISED), lambda v: f"{v:.2f}")
    table("fallback fraction of pixels (timing estimators)",
          lambda k, w, c: mean_of(fb, k, w, c), ["span", "lsq", "resid", "bracket"], lambda v: f"{v:.3f}")
    print("\nseconds per window (median): " + ", ".join(f"{n} {np.median(v):.3f}" for n, v in secs.items()))
    print(f"total {total:.0f} s")


if __name__ == "__main__":
    main()
