"""Fig. 4a noise check (§4.1, Eq. 4, Eq. 9): statistics against theory and a direct oracle, channel
pooling, packed streams, bounded memory, errors, plot and a real recording."""

import importlib
import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.bayer import cfa_channel_map
from spikeref.io.dat import write_dat
from spikeref.stream import read_dat
from spikeref.noise_check import DEFAULT_MIN_SPIKES, NoiseCheck, noise_check, plot_noise_check

nc = importlib.import_module("spikeref.noise_check")  # the module (the package re-exports the function by its name)

Z = 5.0  # tolerances are Z standard errors of the statistic, computed from the sample size


def bernoulli(rate_map, planes, seed):
    """A static stream: each pixel fires independently with probability ``rate_map`` per readout."""
    rng = np.random.default_rng(seed)
    rate_map = np.asarray(rate_map, dtype=np.float64)
    return (rng.random((planes,) + rate_map.shape) < rate_map).astype(np.uint8)


def oracle(spikes, windows, cfa=None, start=0, planes=None, min_rate=None):
    """Literal Fig. 4a: every frame I = count/W, E = span mean, ρ = I/E − 1, numpy statistics."""
    seg = spikes[start : None if planes is None else start + planes].astype(np.float64)
    span, h, w = seg.shape
    total = seg.sum(axis=0)
    expected = total / span
    min_rate = DEFAULT_MIN_SPIKES / span if min_rate is None else min_rate
    used = (total > 0) & (expected >= min_rate)
    chan = cfa_channel_map(h, w, cfa) if cfa else np.zeros((h, w), dtype=np.int8)
    nch = 3 if cfa else 1
    rows = []
    for win in windows:
        if win > span:
            continue
        n = span // win
        frames = seg[: n * win].reshape(n, win, h, w).sum(axis=1) / win
        ratio = frames / np.where(used, expected, 1.0) - 1.0
        row = []
        for c in range(nch):
            vals = ratio[:, used & (chan == c)]
            row.append((vals.mean(), np.abs(vals).mean(), vals.std()) if vals.size else (np.nan,) * 3)
        rows.append(row)
    return np.array(rows)  # (n_windows, n_channels, 3)


def assert_matches_oracle(res, ref):
    np.testing.assert_allclose(res.mean_ratio, ref[..., 0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(res.mean_abs_ratio, ref[..., 1], rtol=1e-9, atol=1e-12)
    # the variance comes from E[ρ²] − E[ρ]² (running sums): compare it, with rounding relative to E[ρ²]
    second = ref[..., 0] ** 2 + ref[..., 2] ** 2
    var, ref_var = res.std_ratio**2, ref[..., 2] ** 2
    assert np.array_equal(np.isnan(var), np.isnan(ref_var))
    ok = np.isnan(ref_var) | (np.abs(var - ref_var) <= 1e-9 * ref_var + 1e-13 * (1 + second))
    assert ok.all(), (var, ref_var)


# ----------------------------------------------------------------------------- theory


def test_bernoulli_spread_matches_theory_and_falls_with_w():
    """Var(I/E − 1) at window W is (1 − p)/(pW) for a Bernoulli(p) pixel, times (1 − 1/n) because
    E is the mean of the same n frames (one degree of freedom per pixel)."""
    p, planes, side = 0.2, 4000, 64
    res = noise_check(bernoulli(np.full((side, side), p), planes, seed=1), windows=(5, 20, 100, 400))
    assert res.channels == ("mono",) and res.pixels[0] == side * side and res.planes == planes
    assert res.windows == (5, 20, 100, 400) and list(res.frames) == [800, 200, 40, 10]
    for i, w in enumerate(res.windows):
        n = planes // w
        var = (1 - p) / (p * w) * (1 - 1 / n)
        dof = side * side * (n - 1)
        kurt = (1 - 6 * p * (1 - p)) / (w * p * (1 - p))  # excess kurtosis of Binomial(W, p)
        sampling = math.sqrt((2 + kurt) / dof)  # relative standard error of a sample variance
        estimation = (1 - p) / (p * planes)  # relative (delta-method) error from dividing by the estimated E
        assert res.std_ratio[i, 0] ** 2 == pytest.approx(var, rel=Z * sampling + Z * estimation)
    assert np.all(np.diff(res.mean_abs_ratio[:, 0]) < 0)  # Fig. 4a: the ratio falls with W
    # W divides the span: the frames tile E's window, so the mean is 0 up to rounding
    np.testing.assert_allclose(res.mean_ratio, 0.0, atol=1e-12)


@pytest.mark.parametrize("planes, window", [(1000, 300), (2100, 400), (997, 50)])
def test_mean_ratio_is_zero_within_its_standard_error(planes, window):
    """W does not divide the span: the frames cover m = nW planes of the span's ``planes``, so the
    per-pixel mean ratio is ≈ (r/planes)(a − b)/p with a, b the rates of the covered and the r left
    over planes; its variance is (1 − p)/p · r/(planes · m) per pixel."""
    p, side = 0.3, 48
    spikes = bernoulli(np.full((side, side), p), planes, seed=planes + window)
    res = noise_check(spikes, windows=(window,))
    m = (planes // window) * window
    r = planes - m
    se = math.sqrt((1 - p) / p * r / (planes * m) / (side * side))
    assert res.mean_ratio[0, 0] != 0.0  # not zero by construction here
    assert abs(res.mean_ratio[0, 0]) <= Z * se
    assert_matches_oracle(res, oracle(spikes, (window,)))


def test_a_non_static_stream_is_not_zero_mean():
    """The check can fail: light that changes inside the span leaves a ratio that does not fall."""
    p1, p2, side = 0.1, 0.3, 16
    dim, bright = bernoulli(np.full((side, side), p1), 600, 2), bernoulli(np.full((side, side), p2), 600, 3)
    spikes = np.concatenate([dim, bright])
    res = noise_check(spikes, windows=(5, 50, 300, 800))
    plateau = (p2 - p1) / (p1 + p2)  # |I/E − 1| of a long frame entirely in one half
    assert res.mean_abs_ratio[2, 0] == pytest.approx(plateau, rel=0.1)
    # one frame of 800 planes: rate (600 p1 + 200 p2)/800 = 0.15 against E = 0.2, a ratio of −0.25
    assert res.mean_ratio[3, 0] == pytest.approx(-0.25, abs=0.05)
    assert_matches_oracle(res, oracle(spikes, (5, 50, 300, 800)))


def test_periodic_pixels_have_exactly_zero_ratio():
    """A pixel firing every k readouts, W a multiple of k dividing the span: I equals E exactly."""
    spikes = np.zeros((2100, 6, 4), dtype=np.uint8)
    for y, k in enumerate((3, 7, 5, 3, 7, 5)):
        spikes[y % k :: k, y] = 1  # row y fires every k readouts (its own phase)
    res = noise_check(spikes, windows=(105, 210, 525, 2100), min_rate=0.0)
    assert res.pixels[0] == 24
    assert np.all(res.mean_ratio == 0.0) and np.all(res.mean_abs_ratio == 0.0) and np.all(res.std_ratio == 0.0)
    other = noise_check(spikes, windows=(4,), min_rate=0.0)  # W not a multiple of k: quantisation noise
    assert other.mean_abs_ratio[0, 0] > 0.1


# ------------------------------------------------------------------------ channels, span


@pytest.mark.parametrize("cfa", ["RGGB", "BGGR"])
def test_channels_are_pooled_by_the_cfa(cfa):
    letters = {"R": 0.4, "G": 0.2, "B": 0.1}
    rates = np.empty((8, 10))
    for (dy, dx), c in zip([(0, 0), (0, 1), (1, 0), (1, 1)], cfa, strict=True):
        rates[dy::2, dx::2] = letters[c]
    planes = 3000
    spikes = bernoulli(rates, planes, seed=4)
    res = noise_check(spikes, windows=(10, 100), cfa=cfa)
    assert res.channels == ("R", "G", "B")
    assert list(res.pixels) == [20, 40, 20]
    for k, c in enumerate("RGB"):
        se = math.sqrt(letters[c] * (1 - letters[c]) / (planes * res.pixels[k]))
        assert abs(res.expected_rate[k] - letters[c]) <= Z * se
    # std ∝ √((1 − p)/p): the dim channel is the noisiest
    assert res.std_ratio[0, 0] < res.std_ratio[0, 1] < res.std_ratio[0, 2]
    assert_matches_oracle(res, oracle(spikes, (10, 100), cfa=cfa))
    # the stream's own pattern is used when cfa is not given
    from spikeref.stream import SpikeStream

    same = noise_check(SpikeStream.from_array(spikes, cfa=cfa), windows=(10, 100))
    np.testing.assert_array_equal(same.std_ratio, res.std_ratio)


def test_span_start_planes_and_skipped_windows():
    spikes = bernoulli(np.random.default_rng(5).uniform(0.05, 0.5, (6, 8)), 700, seed=6)
    res = noise_check(spikes, windows=(7, 10, 150, 200, 250, 1000, 10), start=100, planes=500)
    assert res.windows == (7, 10, 150, 200, 250) and res.skipped == (1000,)
    assert res.start == 100 and res.planes == 500 and list(res.frames) == [71, 50, 3, 2, 2]
    assert_matches_oracle(res, oracle(spikes, res.windows, start=100, planes=500))
    whole = noise_check(spikes[100:600], windows=res.windows)
    np.testing.assert_array_equal(whole.mean_abs_ratio, res.mean_abs_ratio)
    table = res.table()
    assert "| 10 | 0.5 | 50 |" in table and "mono mean abs" in table and "E[I_c]" in table
    assert "skipped (longer than the 500-plane span): W = 1000" in table


def test_dark_pixels_are_excluded():
    planes = 400
    rates = np.full((4, 4), 0.3)
    rates[0, 0] = 0.0  # never fires
    rates[0, 1] = 0.02  # ~8 spikes in 400 planes: below the default 20
    spikes = bernoulli(rates, planes, seed=7)
    spikes[:, 0, 1] = 0
    spikes[:10, 0, 1] = 1  # exactly 10 spikes
    res = noise_check(spikes, windows=(10,))
    assert res.min_rate == DEFAULT_MIN_SPIKES / planes and res.pixels[0] == 14
    assert noise_check(spikes, windows=(10,), min_rate=10 / planes).pixels[0] == 15
    assert noise_check(spikes, windows=(10,), min_rate=0.0).pixels[0] == 15  # rate 0 is always left out
    assert_matches_oracle(res, oracle(spikes, (10,)))
    with pytest.raises(ValueError, match="min_rate: no pixel"):
        noise_check(spikes, windows=(10,), min_rate=0.9)


def test_a_channel_without_pixels_is_nan():
    rates = np.full((4, 4), 0.3)
    rates[0::2, 0::2] = 0.0  # every R pixel of RGGB is dark
    res = noise_check(bernoulli(rates, 200, seed=8), windows=(5,), cfa="RGGB")
    assert list(res.pixels) == [0, 8, 4]
    assert np.isnan(res.mean_abs_ratio[0, 0]) and np.isnan(res.expected_rate[0])
    assert np.all(np.isfinite(res.mean_abs_ratio[0, 1:]))


# ---------------------------------------------------------------------- too few pixels


def _mostly_dark(side=32, lit=5, planes=400, seed=30):
    """A static stream where all but ``lit`` pixels fire far below the default min_rate (20/planes)."""
    rates = np.full((side, side), 0.005)  # ~2 spikes in 400 planes: left out
    rates.flat[np.random.default_rng(seed).choice(side * side, lit, replace=False)] = 0.3
    return bernoulli(rates, planes, seed=seed)


def test_a_channel_on_too_few_pixels_is_flagged():
    """The long-window rows average ~one independent value per pixel: with n pixels a channel's
    mean |ρ| and std carry a relative standard error of ~1/√n, so fewer than MIN_PIXELS is flagged."""
    assert nc.MIN_PIXELS == 100
    res = noise_check(_mostly_dark(), windows=(5, 50))
    assert res.pixels[0] == 5 and res.too_few_pixels == ("mono",) and len(res.warnings) == 1
    assert "channel mono rests on 5 pixels (fewer than 100)" in res.warnings[0]
    assert f"{100 / math.sqrt(5):.0f} %" in res.warnings[0]
    table = res.table()
    assert "mono 5 (too few)" in table
    assert table.splitlines()[-1] == "warning: " + res.warnings[0]
    # the statistics are computed all the same
    assert_matches_oracle(res, oracle(_mostly_dark(), (5, 50)))
    # min_pixels is the threshold; 0 flags nothing
    assert noise_check(_mostly_dark(), windows=(5,), min_pixels=5).warnings == ()
    assert noise_check(_mostly_dark(), windows=(5,), min_pixels=6).too_few_pixels == ("mono",)
    assert noise_check(_mostly_dark(), windows=(5,), min_pixels=0).warnings == ()
    with pytest.raises(TypeError, match="min_pixels"):
        noise_check(_mostly_dark(), windows=(5,), min_pixels=2.5)
    with pytest.raises(ValueError, match="min_pixels"):
        noise_check(_mostly_dark(), windows=(5,), min_pixels=-1)


def test_a_normal_stream_is_not_flagged():
    res = noise_check(bernoulli(np.full((16, 16), 0.3), 400, seed=31), windows=(5, 50))
    assert res.pixels[0] == 256 and res.too_few_pixels == () and res.warnings == ()
    assert "warning" not in res.table() and "too few" not in res.table()
    # with a CFA each channel is judged on its own pixels: 64 R, 128 G, 64 B of 16x16, at most 128
    colour = noise_check(bernoulli(np.full((16, 16), 0.3), 400, seed=31), windows=(5,), cfa="RGGB")
    assert colour.too_few_pixels == ("R", "B")
    colour = noise_check(bernoulli(np.full((20, 20), 0.3), 400, seed=31), windows=(5,), cfa="RGGB")
    assert list(colour.pixels) == [100, 200, 100] and colour.warnings == ()


def test_one_warning_per_affected_channel():
    rates = np.full((24, 24), 0.3)
    rates[0::2, 0::2] = 0.0  # every R pixel of RGGB is dark
    rates[1::2, 1::2] = 0.005  # and all B pixels but a few
    rates[1, 1] = rates[3, 3] = 0.3
    res = noise_check(bernoulli(rates, 400, seed=32), windows=(5,), cfa="RGGB")
    assert list(res.pixels) == [0, 288, 2] and res.too_few_pixels == ("R", "B")
    assert len(res.warnings) == 2
    assert res.warnings[0].startswith("channel R has no pixel") and "NaN" in res.warnings[0]
    assert res.warnings[1].startswith("channel B rests on 2 pixels")
    assert "R 0 (too few), G 288, B 2 (too few)" in res.table()


def _cli_noise_check(tmp_path, capsys, spikes, *extra):
    from spikeref.cli import main

    np.save(tmp_path / "s.npy", spikes)
    assert main(["noise-check", str(tmp_path / "s.npy"), "--windows", "5,50", *extra]) == 0
    return capsys.readouterr()


def test_the_cli_warns_on_too_few_pixels(tmp_path, capsys):
    cap = _cli_noise_check(tmp_path, capsys, _mostly_dark())
    lines = [line for line in cap.err.splitlines() if line.startswith("warning:")]
    assert lines == [
        "warning: channel mono rests on 5 pixels (fewer than 100): its mean |ratio| and std are "
        "uncertain by about 45 % (1/√5); analyse a longer span or lower min_rate for more pixels"
    ]
    assert "mono 5 (too few)" in cap.out
    cap = _cli_noise_check(tmp_path, capsys, bernoulli(np.full((16, 16), 0.3), 400, seed=33))
    assert "warning" not in cap.err and "warning" not in cap.out and "mono 256" in cap.out


def _plotted(monkeypatch, res, path):
    """Draw ``res`` and return the figure that was saved."""
    from matplotlib.figure import Figure

    saved, real_savefig = [], Figure.savefig

    def savefig(self, *args, **kwargs):
        saved.append(self)
        return real_savefig(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    plot_noise_check(res, path)
    assert len(saved) == 1
    return saved[0]


def test_the_plot_marks_a_channel_on_too_few_pixels(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    ax = _plotted(monkeypatch, noise_check(_mostly_dark(), windows=(5, 50)), tmp_path / "few.png").axes[0]
    assert "warning: too few pixels (< 100): mono 5" in ax.get_title()
    assert all("only 5 px" in t.get_text() for t in ax.get_legend().get_texts())
    res = noise_check(bernoulli(np.full((16, 16), 0.3), 400, seed=34), windows=(5, 50))
    ax = _plotted(monkeypatch, res, tmp_path / "fine.png").axes[0]
    assert "warning" not in ax.get_title()
    assert not any("px" in t.get_text() for t in ax.get_legend().get_texts())


# --------------------------------------------------------------------- packed, memory


def test_packed_dat_equals_in_memory(tmp_path):
    spikes = bernoulli(np.random.default_rng(9).uniform(0.02, 0.5, (16, 24)), 1000, seed=10)
    write_dat(tmp_path / "s.dat", spikes)
    stream = read_dat(tmp_path / "s.dat", 16, 24, "RGGB")
    assert stream.is_packed
    packed = noise_check(stream, windows=(5, 50, 300, 1000))
    mem = noise_check(spikes, windows=(5, 50, 300, 1000), cfa="RGGB")
    for name in ("mean_ratio", "mean_abs_ratio", "std_ratio", "expected_rate", "pixels", "frames"):
        np.testing.assert_array_equal(getattr(packed, name), getattr(mem, name))
    assert_matches_oracle(mem, oracle(spikes, (5, 50, 300, 1000), cfa="RGGB"))


def test_chunking_bounds_memory_and_does_not_change_the_result(tmp_path, monkeypatch):
    side, planes = 64, 6000
    spikes = bernoulli(np.full((side, side), 0.25), planes, seed=11)
    write_dat(tmp_path / "long.dat", spikes)
    stream = read_dat(tmp_path / "long.dat", side, side)
    whole = noise_check(spikes, windows=(5, 60))
    monkeypatch.setattr(nc, "_CHUNK_ELEMENTS", 7 * side * side)  # 7 frames per chunk
    noise_check(stream, windows=(5,))  # warm up (JIT) outside the measurement
    tracemalloc.start()
    try:
        chunked = noise_check(stream, windows=(5, 60))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    np.testing.assert_allclose(chunked.std_ratio, whole.std_ratio, rtol=1e-12)
    np.testing.assert_allclose(chunked.mean_abs_ratio, whole.mean_abs_ratio, rtol=1e-12)
    all_frames = (planes // 5) * side * side  # bytes of the uint8 counts of every W = 5 frame
    assert peak < all_frames / 4, f"peak {peak} bytes: frames are not processed in chunks"


@settings(max_examples=25, deadline=None, derandomize=True)
@given(
    planes=st.integers(1, 60),
    start=st.integers(0, 10),
    windows=st.lists(st.integers(1, 70), min_size=1, max_size=4),
    cfa=st.sampled_from([None, "RGGB", "GBRG"]),
    seed=st.integers(0, 2**16),
)
def test_matches_the_direct_computation(planes, start, windows, cfa, seed):
    rates = np.random.default_rng(seed).uniform(0.0, 0.9, (4, 6))
    spikes = bernoulli(rates, start + planes, seed=seed)
    if min(windows) > planes:
        with pytest.raises(ValueError, match="windows"):
            noise_check(spikes, windows=windows, cfa=cfa, start=start, min_rate=0.0)
        return
    if not spikes[start:].any():
        with pytest.raises(ValueError, match="min_rate: no pixel"):
            noise_check(spikes, windows=windows, cfa=cfa, start=start, min_rate=0.0)
        return
    res = noise_check(spikes, windows=windows, cfa=cfa, start=start, min_rate=0.0)
    assert res.windows == tuple(sorted({w for w in windows if w <= planes}))
    assert_matches_oracle(res, oracle(spikes, res.windows, cfa=cfa, start=start, min_rate=0.0))


# ---------------------------------------------------------------------------- errors


def test_bad_arguments_raise_naming_the_argument():
    spikes = bernoulli(np.full((4, 4), 0.3), 400, seed=12)
    cases = [
        (dict(windows=(0,)), ValueError, "windows must be a positive"),
        (dict(windows=()), ValueError, "windows must list"),
        (dict(windows=(5, 2.5)), TypeError, "windows"),
        (dict(windows=(True,)), TypeError, "windows"),
        (dict(windows="5"), TypeError, "windows"),
        (dict(windows=(500, 1000)), ValueError, "windows: every window"),
        (dict(start=400), ValueError, "start"),
        (dict(start=-1), ValueError, "start"),
        (dict(start=1.0), TypeError, "start"),
        (dict(planes=0), ValueError, "planes"),
        (dict(start=100, planes=301), ValueError, "planes"),
        (dict(planes=10.0), TypeError, "planes"),
        (dict(min_rate=-1.0), ValueError, "min_rate"),
        (dict(min_rate=float("nan")), ValueError, "min_rate"),
        (dict(min_rate="0.1"), TypeError, "min_rate"),
        (dict(cfa="RGB"), ValueError, "cfa"),
        (dict(cfa=3), TypeError, "cfa"),
        (dict(progress="yes"), TypeError, "progress"),
    ]
    for kwargs, error, message in cases:
        with pytest.raises(error, match=message):
            noise_check(spikes, **kwargs)
    with pytest.raises(ValueError, match="even height and width"):
        noise_check(bernoulli(np.full((3, 4), 0.3), 100, seed=13), windows=(5,), cfa="RGGB")
    with pytest.raises(TypeError, match="spikes"):
        noise_check([[[0, 1]]], windows=(1,))


def test_progress_bar_runs(capsys):
    res = noise_check(bernoulli(np.full((4, 4), 0.3), 200, seed=14), windows=(5, 10), progress=True)
    assert res.windows == (5, 10)
    assert "noise check" in capsys.readouterr().err


# ------------------------------------------------------------------------------ plot


def test_plot_writes_a_png(tmp_path):
    pytest.importorskip("matplotlib")
    res = noise_check(bernoulli(np.full((8, 8), 0.2), 1000, seed=15), windows=(5, 50, 500), cfa="BGGR")
    out = plot_noise_check(res, tmp_path / "fig4a.png")
    assert out == tmp_path / "fig4a.png"
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["fig4a.png"]  # no temporary left behind
    with pytest.raises(TypeError, match="NoiseCheck"):
        plot_noise_check(res.table(), tmp_path / "x.png")


def test_plot_without_matplotlib_names_the_extra(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_matplotlib(name, *args, **kwargs):
        if name.startswith("matplotlib"):
            raise ImportError("no matplotlib")
        return real_import(name, *args, **kwargs)

    res = noise_check(bernoulli(np.full((4, 4), 0.3), 100, seed=16), windows=(5,))
    monkeypatch.setattr(builtins, "__import__", no_matplotlib)
    with pytest.raises(ImportError, match=r"pip install 'spikeref\[plot\]'"):
        plot_noise_check(res, tmp_path / "x.png")
    assert not list(tmp_path.iterdir())


def test_result_is_a_frozen_dataclass():
    res = noise_check(bernoulli(np.full((4, 4), 0.3), 100, seed=17), windows=(5,))
    assert isinstance(res, NoiseCheck)
    with pytest.raises(AttributeError):
        res.planes = 3


# ------------------------------------------------------------------------- real data


@pytest.mark.realdata
def test_real_recording_noise_falls_with_window(real_data):
    """A real monochrome spike-camera recording (SpikingSIM sample, 500 planes of 250×400)."""
    path = real_data / "spikingsim_real_spike.npz"
    if not path.exists():
        pytest.skip(f"{path.name} is not present")
    with np.load(path) as f:
        spikes = np.ascontiguousarray(np.moveaxis(f["arr_0"], -1, 0))  # stored (H, W, T)
    assert spikes.shape == (500, 250, 400)
    res = noise_check(spikes, windows=(5, 10, 20, 50, 100, 250))
    assert res.pixels[0] > 0.9 * 250 * 400
    assert np.all(np.diff(res.mean_abs_ratio[:, 0]) < 0)
    assert np.all(np.diff(res.std_ratio[:, 0]) < 0)
    # the split into four 2×2 phases (a mono sensor read as RGGB) sees the same noise in each phase
    colour = noise_check(spikes, windows=(5, 50), cfa="RGGB")
    g = colour.mean_abs_ratio[:, [1]]
    np.testing.assert_allclose(colour.mean_abs_ratio, np.broadcast_to(g, colour.mean_abs_ratio.shape), rtol=0.05)


@pytest.mark.realdata
def test_real_low_light_recording_is_flagged(real_data, tmp_path, capsys):
    """UHSR (200 planes of 250×250, low light): only 3 pixels reach 20 spikes; the CLI says so."""
    from spikeref.cli import main

    path = real_data / "spikezoo_uhsr.npz"
    if not path.exists():
        pytest.skip(f"{path.name} is not present")
    assert main(["noise-check", str(path), "--windows", "5,50"]) == 0
    cap = capsys.readouterr()
    assert "pixels used (long-window rate >= 0.1 and > 0): mono 3 (too few)" in cap.out
    assert [line for line in cap.err.splitlines() if line.startswith("warning:")] == [
        "warning: channel mono rests on 3 pixels (fewer than 100): its mean |ratio| and std are uncertain by "
        "about 58 % (1/√3); analyse a longer span or lower min_rate for more pixels"
    ]
