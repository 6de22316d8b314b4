"""`spikeref bench`: grids, scored instants, timing protocol, Pareto front, outputs and bad input."""

import csv

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.bench import (BENCH_VERSION, FULL_GRID, QUICK_GRID, Setting, bench_scenes, grid_settings, parse_grid,
                            pareto_front, run_setting, score_centres)
from spikeref.bench.report import contact_sheet, summarize
from spikeref.cli import main
from spikeref.stream import SpikeStream


def test_full_and_quick_grids():
    full = grid_settings(FULL_GRID)
    names = [s.name for s in full]
    # baselines; visible W×K×L×(align on × 2 flow frames + off), L=0 once per W: 2 + 2·2·3·3 = 38; mixed+blind
    assert len(names) == len(set(names)) == 4 + 38 + 2 + 8
    assert "ours visible W=10 K=3 L=3 smoothed-flow (fast preset)" in names
    assert "ours visible W=10 K=3 L=3 smoothed-flow (fastest preset)" in names
    assert Setting("ours", flow_frames="smoothed", denoise=False).name == "ours visible W=10 K=3 L=3 smoothed-flow " \
        "no-denoiser"
    assert "ours visible W=20 K=5 L=3 no-align" in names and "ours blind W=10 K=3 L=3" in names
    assert "ours visible W=20 K=5 L=3 smoothed-flow" in names and "ours visible W=10 L=0" in names
    assert not any("no-align" in n and "smoothed" in n for n in names)  # no flow, nothing to smooth
    assert not any(s.mode != "visible" and s.flow_frames != "denoised" for s in full)
    assert "ours blind W=20 K=3 L=3" not in names  # costly modes only along L at the first W, K, align
    quick = [s.name for s in grid_settings(QUICK_GRID)]
    assert quick == ["TFP W=10", "TFP W=100", "TFI", "TFSTP", "ours visible W=10 L=0", "ours visible W=10 K=3 L=1",
                     "ours visible W=10 K=3 L=2", "ours visible W=10 K=3 L=3", "ours visible W=10 K=5 L=3",
                     "ours visible W=20 K=3 L=3", "ours visible W=10 K=3 L=3 no-align",
                     "ours visible W=10 K=3 L=3 smoothed-flow", "ours visible W=10 K=3 L=3 smoothed-flow (fast preset)",
                     "ours visible W=10 K=3 L=3 smoothed-flow (fastest preset)", "ours mixed W=10 L=0",
                     "ours blind W=10 L=0"]
    only = grid_settings(parse_grid(methods=["tfi", "ours"], modes=["blind"], L=[0, 2]))
    assert [s.name for s in only] == ["TFI", "ours blind W=10 L=0", "ours blind W=10 K=3 L=2"]


@pytest.mark.parametrize("kw, match", [
    ({"methods": ["tfp10", "tfp50"]}, "unknown methods tfp50; allowed: tfp10, tfp100, tfi, tfstp, ours"),
    ({"modes": ["fast"]}, "unknown modes fast"),
    ({"W": [15]}, "unknown W 15; allowed: 10, 20"),
    ({"K": [4]}, "unknown K 4"),
    ({"L": [4]}, "unknown L 4"),
    ({"align": ["maybe"]}, "unknown align maybe"),
    ({"flow_frames": ["raw"]}, "unknown flow_frames raw; allowed: denoised, smoothed"),
    ({"frames": 0}, "frames must be an integer in 1…8"),
    ({"methods": ["tfi"], "modes": ["visible"]}, "leaves out 'ours'"),
    ({"W": [10, 10]}, "lists a value twice"),
])
def test_bad_grid_options(kw, match):
    with pytest.raises(ValueError, match=match):
        parse_grid(**kw)


def test_scenes_are_versioned_and_named():
    keys = [s.key for s in bench_scenes()]
    assert keys == ["static", "translation", "fan", "hdr", "low_light", "astronaut_pan", "coffee_spin", "occlusion"]
    for s in bench_scenes():
        assert f"set version {BENCH_VERSION}" in s.path.read_text() and s.scene.effects  # realistic noise everywhere
    with pytest.raises(ValueError, match="unknown scene moon; allowed: static, translation"):
        bench_scenes(["moon"])


def test_score_centres_sit_on_both_window_grids():
    c = score_centres(800, 4)
    assert c == [375, 395, 415, 435]  # ≡ 5 (mod 10), 20 apart, around plane 400
    assert score_centres(800, 1) == [405]


def test_pareto_front_by_hand():
    cost = [1.0, 2.0, 3.0, 2.0, 0.5]
    score = [10.0, 12.0, 11.0, 12.0, 9.0]
    # (3, 11) is dominated by (2, 12); the tie (2, 12) twice stays; (0.5, 9) is the fastest
    np.testing.assert_array_equal(pareto_front(cost, score), [True, True, False, True, True])
    with pytest.raises(ValueError, match="1-D of equal length"):
        pareto_front([1.0], [1.0, 2.0])


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(0.001, 100), st.floats(-10, 50)), min_size=1, max_size=30))
def test_pareto_front_properties(points):
    cost, score = np.array(points).T
    front = pareto_front(cost, score)
    assert front.any()

    def dominates(i, j):
        return cost[i] <= cost[j] and score[i] >= score[j] and (cost[i] < cost[j] or score[i] > score[j])

    n = len(points)
    for j in range(n):
        if front[j]:
            assert not any(dominates(i, j) for i in range(n))
        else:
            assert any(dominates(i, j) and front[i] for i in range(n))


def _stream(rng, planes=300):
    return SpikeStream.from_array((rng.random((planes, 32, 32)) < 0.3).astype(np.uint8), cfa="RGGB")


def test_every_method_is_scored_at_the_same_instant(rng):
    from spikeref.accumulate import accumulate
    from spikeref.bayer import demosaic_bilinear

    stream = _stream(rng)
    centres = [135, 155]
    for w in (10, 100):
        frames, timing = run_setting(Setting("tfp", w), stream, centres)
        for t, f in zip(centres, frames, strict=True):
            np.testing.assert_array_equal(f, demosaic_bilinear(accumulate(stream, w, start=t - w // 2, count=1)[0],
                                                               "RGGB"))
        assert timing["seconds_per_frame"] > 0
    # the method with W = 20 and L = 0 and an identity denoiser is the TFP of the 20 planes centred on t:
    # its window grid is shifted by 5 planes so that a window is centred there
    for w in (10, 20):
        frames, timing = run_setting(Setting("ours", w, L=0), stream, centres, denoiser=lambda p: p,
                                     accumulate="count")
        for t, f in zip(centres, frames, strict=True):
            np.testing.assert_allclose(f, demosaic_bilinear(accumulate(stream, w, start=t - w // 2, count=1)[0],
                                                            "RGGB"), atol=1e-6)
        assert timing["warmup_s"] > 0 and timing["seconds_per_frame"] > 0
    # TFSTP run as a 2000-FPS video from plane 0 equals one call at the instants
    from spikeref.baselines import tfstp

    frames, _ = run_setting(Setting("tfstp", 0), stream, centres)
    np.testing.assert_allclose(frames[1], demosaic_bilinear(tfstp(stream, times=centres)[1], "RGGB"), rtol=1e-6)


def test_summary_and_contact_sheet():
    rows = [{"setting": n, "method": m, "W": 10, "K": "", "L": "", "mode": "", "align": "", "scene": s,
             "psnr": p, "ssim": 0.5, "pu21_psnr": p, "pu21_ssim": 0.5, "seconds_per_frame": c, "warmup_s": 0.0}
            for n, m, p, c in (("A", "tfp", 20.0, 1.0), ("B", "ours", 25.0, 2.0), ("C", "ours", 24.0, 3.0))
            for s in ("x", "y")]
    summary = summarize(rows)
    assert [r["pareto_psnr"] for r in summary] == [True, True, False]
    img = {"reference": np.full((12, 16, 3), 0.5, np.float32), "A": np.zeros((12, 16, 3), np.float32)}
    sheet = contact_sheet(img, columns=6, gap=4, captions=False)
    assert sheet.shape == (12, 36, 3) and sheet.dtype == np.uint8
    assert sheet[:, :16].min() > 200 and sheet[:, 20:].max() == 0  # one exposure: the reference maps near white


def test_contact_sheet_names_every_tile():
    from spikeref.bench.report import _text_mask
    from spikeref.tonemap import choose_exposure, tonemap

    long = "ours visible W=10 K=3 L=3 smoothed-flow (fastest preset)"
    names = ["reference", "TFP W=10", "TFP W=100", long]
    img = {n: np.full((40, 128, 3), v, np.float32) for n, v in zip(names, (0.5, 0.1, 0.3, 0.4), strict=True)}
    sheet = contact_sheet(img, columns=3, gap=4)
    assert sheet.dtype == np.uint8 and sheet.shape[1] == 3 * 128 + 2 * 4
    cap = (sheet.shape[0] + 4) // 2 - 40 - 4  # two rows of caption + tile + gap
    assert cap == 3 * 9 + 4  # the long name takes three lines of 21 characters; every strip is as tall
    assert sheet.shape[0] == 2 * (cap + 40 + 4) - 4
    exposure = choose_exposure(img["reference"])
    strips = {}
    for i, n in enumerate(names):
        y, x = divmod(i, 3)
        top, left = y * (cap + 44), x * 132
        strip = sheet[top: top + cap, left: left + 128]
        assert (strip == 0).any() and (strip == 255).mean() > 0.5  # black text on white, not blank
        np.testing.assert_array_equal(sheet[top + cap: top + cap + 40, left: left + 128], tonemap(img[n], exposure))
        strips[n] = strip
    # the caption is the name itself in the built-in font, centred, next to its own tile (below it)
    ink = strips["TFP W=10"][..., 0] == 0
    ys, xs = np.nonzero(ink)
    text = _text_mask("TFP W=10")
    ty, tx = np.nonzero(text)
    np.testing.assert_array_equal(ink[ys.min(): ys.max() + 1, xs.min(): xs.max() + 1],
                                  text[ty.min(): ty.max() + 1, tx.min(): tx.max() + 1])
    assert abs((xs.min() + xs.max()) - 127) <= 1 and cap - 1 - ys.max() < ys.min()
    assert not np.array_equal(strips["TFP W=10"], strips["TFP W=100"])
    lines = (strips[long] == 0).any(axis=(1, 2))[3: 3 + 27].reshape(3, 9).any(axis=1)
    assert lines.all()  # all three lines of the long name are written
    assert contact_sheet(img, columns=3, gap=4, captions=False).shape == (2 * 44 - 4, 3 * 132 - 4, 3)


def test_caption_wrap():
    from spikeref.bench.report import _wrap

    name = "ours visible W=10 K=3 L=3 smoothed-flow (fastest preset)"
    lines = _wrap(name, 21, 4)
    assert lines == ["ours visible W=10 K=3", "L=3 smoothed-flow", "(fastest preset)"]
    assert _wrap(name, 21, 2) == ["ours visible W=10 K=3", "L=3 smoothed-flow ..."]
    assert _wrap(name, 10, 2) == ["ours", "visible..."]
    assert all(len(line) <= 8 for line in _wrap("reference smoothed-flow", 8, 9))
    assert "".join(_wrap("reference smoothed-flow", 8, 9)) == "referencesmoothed-flow"
    assert _wrap("x", 0, 3) == []


def test_cli_bench_small_run_writes_every_output(tmp_path, capsys):
    out = tmp_path / "bench"
    rc = main(["bench", "--methods", "tfp10,tfp100,ours", "-L", "0", "-W", "10", "--modes", "visible",
               "--scenes", "static,hdr", "--frames", "2", "--out", str(out), "--no-progress"])
    assert rc == 0
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert [(r["scene"], r["setting"]) for r in rows] == [
        (s, n) for s in ("static", "hdr") for n in ("TFP W=10", "TFP W=100", "ours visible W=10 L=0")]
    for r in rows:
        assert r["bench_version"] == str(BENCH_VERSION) and float(r["seconds_per_frame"]) > 0
        assert np.isfinite(float(r["psnr"])) and 0 < float(r["ssim"]) <= 1 and float(r["pu21_psnr"]) > 0
    by = {(r["scene"], r["setting"]): float(r["psnr"]) for r in rows}
    assert by[("static", "TFP W=100")] > by[("static", "TFP W=10")] + 5  # a static scene rewards long windows
    md = (out / "results.md").read_text()
    assert "| TFP W=100" in md and "vs TFP W=10:" in md
    # the method's stage breakdown: a column per stage in the CSV, a table in results.md
    for r in rows:
        ours = r["method"] == "ours"
        assert (float(r["network_s"]) > 0) if ours else np.isnan(float(r["network_s"]))
        if ours:
            staged = sum(float(r[f"{k}_s"]) for k in ("accumulate", "network", "guard", "align", "warp", "demosaic",
                                                      "other"))
            assert staged <= float(r["seconds_per_frame"]) * 1.5
    assert "Where the method's time goes" in md and "| ours visible W=10 L=0 |" in md and "outside the network" in md
    assert (out / "contact_sheet.png").stat().st_size > 0
    assert "| setting |" in capsys.readouterr().out


@pytest.mark.parametrize("argv, match", [
    (["--methods", "tfp10,wavelets"], "unknown methods wavelets"),
    (["--scenes", "moon"], "unknown scene moon"),
    (["-W", "30"], "unknown W 30"),
    (["--sheet-scene", "hdr", "--scenes", "static"], "--sheet-scene 'hdr' is not among"),
])
def test_cli_bench_bad_input_fails_before_any_work(tmp_path, capsys, argv, match):
    out = tmp_path / "never"
    assert main(["bench", *argv, "--out", str(out), "--no-progress"]) == 2
    assert match in capsys.readouterr().err
    assert not out.exists()


def test_cli_bench_unwritable_output(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["bench", "--methods", "tfi", "--out", str(blocker / "sub"), "--no-progress"]) == 2
    assert "cannot write there" in capsys.readouterr().err


def test_pareto_plot_is_a_png(tmp_path):
    pytest.importorskip("matplotlib")
    from spikeref.bench.report import plot_pareto

    rows = [{"setting": n, "method": m, "W": 10, "K": 3, "L": 1, "mode": mode, "align": a, "scene": "x",
             "psnr": p, "ssim": 0.5, "pu21_psnr": p, "pu21_ssim": 0.5, "seconds_per_frame": c, "warmup_s": 0.0}
            for n, m, mode, a, p, c in (("TFP W=10", "tfp", "", "", 20.0, 0.001),
                                        ("ours", "ours", "visible", "on", 25.0, 0.2),
                                        ("ours b", "ours", "blind", "off", 24.0, 3.0))]
    rows.append({**rows[1], "setting": "ours (fast preset)", "warp": "chained", "flow_frames": "smoothed",
                 "seconds_per_frame": 0.1})
    assert plot_pareto(summarize(rows), tmp_path / "p.png")
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_pareto_labels_never_overlap():
    # Ten settings on top of one another: the labels the plot keeps must not cover each other, and the
    # defaults (the highest priority among the method's settings) keep theirs.
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from spikeref.bench.report import _label_points

    summary = [{"setting": f"ours visible W=10 K=5 L={k}", "method": "ours", "warp": "", "align": "on",
                "flow_frames": "smoothed"} for k in range(9)]
    summary.append({"setting": "ours visible W=10 K=3 L=3 smoothed-flow", "method": "ours", "warp": "",
                    "align": "on", "flow_frames": "smoothed"})
    cost = np.full(10, 0.02) * (1 + 0.001 * np.arange(10))
    score = 27.0 + 0.001 * np.arange(10)
    fig, ax = plt.subplots()
    ax.scatter(cost, score)
    ax.set_xscale("log")
    ax.set_xlim(1e-3, 1.0)  # the ten points within a few pixels of each other
    ax.set_ylim(20.0, 30.0)
    fig.canvas.draw()
    _label_points(ax, summary, cost, score, np.ones(10, bool), np.ones(10, bool))
    labels = [t for t in ax.texts]
    fig.canvas.draw()  # an annotation's text goes where it belongs when drawn
    renderer = fig.canvas.get_renderer()
    boxes = _text_boxes(labels, renderer)
    assert "defaults (10/3/3)" in [t.get_text() for t in labels]
    assert len(labels) == 10  # every one kept: those with no room beside their point go to a free slot
    assert sum(t.arrow_patch is not None for t in labels) >= 5  # … joined to it by a leader line
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    _assert_leaders_clear(ax, labels, boxes)
    plt.close(fig)



def test_pareto_labels_keep_off_the_legend_and_the_front():
    # A point with the legend just right of it and the front's line running into it from the left: its
    # label goes neither over the legend nor across the line.
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from spikeref.bench.report import _place_labels

    fig, ax = plt.subplots()
    ax.scatter([0.5], [0.5], s=28)
    ax.plot([0.0, 0.5], [0.5, 0.5], color="k", lw=1)
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.legend(handles=[plt.Line2D([], [], color="k", label=f"entry {k}") for k in range(6)],
              loc="center left", bbox_to_anchor=(0.52, 0.5))
    fig.canvas.draw()
    (label,) = _place_labels(ax, [(0.5, 0.5, "the defaults")])
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    (box,) = _text_boxes([label], renderer)
    assert not box.overlaps(ax.get_legend().get_window_extent(renderer))
    (x0, y), (x1, _) = ax.transData.transform([(0.0, 0.5), (0.5, 0.5)])
    assert not (box.y0 < y < box.y1 and box.x0 < x1 and box.x1 > x0)
    plt.close(fig)

def _text_boxes(labels, renderer):
    """The display boxes of the labels' text alone (an Annotation's own extent takes in its leader line)."""
    from matplotlib.text import Text

    return [Text.get_window_extent(t, renderer) for t in labels]


def _assert_leaders_clear(ax, labels, boxes):
    """No leader line, as drawn, passes through another label; each one ends on its own point."""
    for i, t in enumerate(labels):
        if t.arrow_patch is None:
            continue
        arrow = t.arrow_patch
        v = arrow.get_transform().transform_path(arrow.get_path()).vertices
        np.testing.assert_allclose(v[-1], ax.transData.transform(t.xy), atol=0.5)
        along = np.concatenate([a + np.linspace(0, 1, 200)[:, None] * (b - a)
                                for a, b in zip(v[:-1], v[1:], strict=True)])
        for j, b in enumerate(boxes):
            assert j == i or not any(b.contains(x, y) for x, y in along), (t.get_text(), labels[j].get_text())


def _crowded_summary():
    """Fifteen settings, all on the Pareto front, within a few hundredths of a dB and a few percent of time."""
    def row(name, method, c, p, **kw):
        return {"setting": name, "method": method, "W": 10, "K": 3, "L": 3, "mode": "visible" if method == "ours"
                else "", "align": "on" if method == "ours" else "", "flow_frames": "", "warp": "", "denoise": "on",
                "scene": "x", "psnr": p, "ssim": 0.7 + 0.01 * p / 28, "pu21_psnr": p - 5, "pu21_ssim": 0.5,
                "seconds_per_frame": c, "warmup_s": 0.0, **kw}

    rows = [row("TFP W=10", "tfp", 0.0002, 20.0), row("TFP W=100", "tfp", 0.00021, 25.0),
            row("ours visible W=10 K=3 L=3 smoothed-flow (fastest preset)", "ours", 0.0030, 27.50,
                warp="chained", flow_frames="smoothed", denoise="off"),
            row("ours visible W=10 K=3 L=3 smoothed-flow (fast preset)", "ours", 0.00305, 27.51, warp="chained",
                flow_frames="smoothed"),
            row("ours visible W=10 K=3 L=3 smoothed-flow", "ours", 0.0100, 27.52, flow_frames="smoothed")]
    rows += [row(f"ours visible W=10 K={k} L={n}", "ours", 0.0101 * (1 + 0.01 * (3 * k + n)),
                 27.53 + 0.004 * (3 * k + n)) for k in (3, 5) for n in range(5)]
    assert len(rows) == 15
    return summarize(rows)


def test_crowded_pareto_labels_are_all_readable():
    # Fifteen settings bunched together: every name the plot gives is drawn, inside its panel, over no
    # other label, no marker's centre and not the legend; the crowd is untangled with leader lines.
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from spikeref.bench.report import _pareto_figure

    summary = _crowded_summary()
    assert all(r["pareto_psnr"] for r in summary)
    fig = _pareto_figure(summary)
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        for k, ax in enumerate(fig.axes):
            texts = list(ax.texts)
            names = [t.get_text() for t in texts]
            expected = 15 if k != 1 else 13  # the zoom on the top 1.5 dB leaves the two TFPs out
            assert len(names) == len(set(names)) == expected, names
            assert {"defaults (10/3/3)", "fast preset", "fastest preset", "visible W=10 K=5 L=4"} <= set(names)
            assert k == 1 or {"TFP W=10", "TFP W=100"} <= set(names)
            boxes = _text_boxes(texts, renderer)
            for i, a in enumerate(boxes):
                for j, b in enumerate(boxes[i + 1:], start=i + 1):
                    assert not a.overlaps(b), (names[i], names[j])
            frame = ax.get_window_extent(renderer)
            assert all(frame.x0 <= b.x0 and b.x1 <= frame.x1 and frame.y0 <= b.y0 and b.y1 <= frame.y1
                       for b in boxes)
            centres = np.concatenate([c.get_offset_transform().transform(c.get_offsets()) for c in ax.collections])
            for name, b in zip(names, boxes, strict=True):
                assert not any(b.contains(x, y) for x, y in centres), name
            if ax.get_legend() is not None:
                legend = ax.get_legend().get_window_extent(renderer)
                assert not any(b.overlaps(legend) for b in boxes)
            assert any(t.arrow_patch is not None for t in texts)
            _assert_leaders_clear(ax, texts, boxes)
    finally:
        plt.close(fig)


def test_pareto_plot_without_matplotlib(tmp_path, monkeypatch):
    import sys

    from spikeref.bench.report import plot_pareto

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib → ImportError
    assert plot_pareto(_crowded_summary(), tmp_path / "p.png") is False
    assert not (tmp_path / "p.png").exists()
