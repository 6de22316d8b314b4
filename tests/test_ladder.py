"""The stage ladder (spikeref.bench.ladder): weights, the true-flow warp, one small run, the CLI."""

import numpy as np
import pytest

from spikeref.bayer import bayer_planes, cfa_channel_map
from spikeref.bench.ladder import (PEER_RUNGS, RUNGS, band_psnr, binomial_weights, ladder_markdown,
                                   motion_edge_band, plot_ladder, run_ladder, true_flow_frame)
from spikeref.bench.runner import BenchScene
from spikeref.cli import main
from spikeref.simulate.scenes import Scene, TranslatingTexture
from spikeref.simulate.simulator import ground_truth


def test_binomial_weights_are_eq14_then_eq15():
    np.testing.assert_allclose(binomial_weights(3, 3) * 27, [1, 3, 6, 7, 6, 3, 1])
    np.testing.assert_allclose(binomial_weights(5, 1), np.full(5, 0.2))
    np.testing.assert_allclose(binomial_weights(3, 2) * 9, [1, 2, 3, 2, 1])
    assert binomial_weights(1, 3).tolist() == [1.0]


def test_true_flow_frame_undoes_a_whole_pixel_motion():
    """Windows of a texture moving one plane pixel per window, warped by the exact flow, give the reference."""
    content = TranslatingTexture(height=32, width=40, velocity=(4000.0, -4000.0), texture_size=16, brightness=0.6)
    scene = Scene(name="t", content=content, planes=70)
    # noise-free "counts": W × the exact mean radiance of each window, through the CFA
    gt = ground_truth(scene, 10)  # (7, H, W, 3)
    chan = cfa_channel_map(32, 40, "RGGB").astype(np.int64)
    mosaic = np.take_along_axis(gt, chan[None, ..., None], axis=-1)[..., 0]
    counts = bayer_planes(mosaic * 10.0)  # (7, 4, 16, 20)
    w = binomial_weights(3, 3)
    out = true_flow_frame(counts, content, 10, 0, 3, w)
    ref = counts[3] / 10.0
    # inside (3 plane px from the border, the farthest window's reach) every window lands exactly on the reference
    np.testing.assert_allclose(out[:, 3:-3, 3:-3], ref[:, 3:-3, 3:-3], atol=2e-5)
    # the border renormalises over the windows whose samples lie inside: still the reference, never a dark edge
    np.testing.assert_allclose(out, ref, atol=2e-5)
    # a wrong flow sign would not: warping with the plain sum of windows differs
    assert np.abs(counts.mean(0) / 10.0 - ref).max() > 0.05


def test_the_motion_edge_band_is_where_motion_changes():
    """A texture sliding as a whole has no motion edge inside the view (only where it enters and leaves it); the
    fan's band follows its blades' edges, and none of the still toys far from them."""
    from pathlib import Path

    from spikeref.simulate.scenes import load_scene

    still = TranslatingTexture(height=32, width=40, velocity=(0.0, 0.0), texture_size=16, brightness=0.6)
    assert not motion_edge_band(still, 55.0, 10).any()
    moving = TranslatingTexture(height=32, width=40, velocity=(0.0, 4000.0), texture_size=16, brightness=0.6)
    band = motion_edge_band(moving, 55.0, 10, radius=0)
    assert band.shape == (32, 40) and band.any() and not band[8:-8, 8:-8].any()  # the rows that leave and enter
    fan = load_scene(Path(__file__).resolve().parents[1] / "spikeref" / "bench" / "scenes" / "3_fan.toml").content
    band = motion_edge_band(fan, 105.0, 10)
    h, w = band.shape
    yy, xx = np.mgrid[0:h, 0:w]
    far = np.hypot(yy - h / 2, xx - w / 2) > 0.75 * min(h, w)  # beyond the blades' reach (tip radius 0.4·min)
    assert 0.02 < band.mean() < 0.6 and not band[far].any()


def test_band_psnr_counts_only_the_band():
    ref = np.full((4, 6, 3), 0.5)
    img = ref.copy()
    img[:2] += 0.05  # error only in the first two rows
    band = np.zeros((4, 6), bool)
    band[:2] = True
    assert band_psnr(ref, img, band) == pytest.approx(10 * np.log10(0.25 / 0.0025))
    assert band_psnr(ref, img, ~band) == np.inf and np.isnan(band_psnr(ref, img, np.zeros((4, 6), bool)))


@pytest.fixture(scope="module")
def small_ladder():
    from spikeref.simulate.scenes import load_scene
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "spikeref" / "bench" / "scenes" / "2_translation.toml"
    scene = load_scene(path, overrides={"planes": 120})
    sc = BenchScene("translation", path, scene)
    return run_ladder([sc], frames=1, progress=False)


def test_small_ladder_has_every_rung_and_the_limit_on_top(small_ladder):
    res = small_ladder
    rows = {r["rung"]: r for r in res["rows"]}
    for r in res["rungs"]:
        assert np.isfinite(rows[r]["psnr"]), r
    assert set(res["rungs"]) >= set(RUNGS) - set(PEER_RUNGS["bm3d"]) - set(PEER_RUNGS["nlm"])
    assert rows["limit"]["psnr"] == max(r["psnr"] for r in rows.values())
    # the noise-free windows through the same warp: above the noisy true flow, under the limit by the resampling
    assert rows["true_flow"]["psnr"] + 1.0 < rows["true_flow_clean"]["psnr"] < rows["limit"]["psnr"]
    assert rows["tfp"]["psnr"] == min(r["psnr"] for r in rows.values())
    assert rows["true_flow"]["psnr"] > rows["tfp_support"]["psnr"]  # the texture moves 0.5 plane px per window
    steps = sorted(e["step"] for e in res["epe"])
    assert steps == [0, 1, 2] and all(0 <= e["epe"] < 1.0 for e in res["epe"])


def test_ladder_report_and_plot(small_ladder, tmp_path):
    text = ladder_markdown(small_ladder)
    assert "| translation |" in text and "**mean of 1**" in text and "step 2" in text
    pytest.importorskip("matplotlib")
    assert plot_ladder(small_ladder, tmp_path / "ladder.png")
    assert (tmp_path / "ladder.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_peer_rungs_leave_with_their_peer():
    """Without the peers asked for, the rungs that need them are not run (nor listed)."""
    res = run_ladder([], peers=(), progress=False)
    assert not set(res["rungs"]) & {"bm3d", "nlm", "true_flow_bm3d"}
    assert "true_flow_clean" in res["rungs"]
    res = run_ladder([], peers=("nlm",), rungs=("nlm", "true_flow_bm3d"), progress=False)
    assert res["rungs"] == (("nlm",) if "nlm" in res["rungs"] else ())


def test_a_missing_peer_package_is_named_with_its_extra(monkeypatch):
    """scikit-image without PyWavelets (a fresh install without the peers extra): the NLM rungs are left out with a
    note naming the extra, instead of the run stopping inside scikit-image's estimate_sigma."""
    monkeypatch.setitem(__import__("sys").modules, "pywt", None)
    res = run_ladder([], peers=("nlm",), progress=False)
    assert "nlm" not in res["rungs"]
    assert any(n.startswith("nlm:") and 'pip install "spikeref[peers]"' in n for n in res["notes"]), res["notes"]
    assert 'left out: nlm: not installed (pip install "spikeref[peers]")' in ladder_markdown(res)


def test_unknown_rung():
    with pytest.raises(ValueError, match="unknown rung fastest; allowed: tfp, bm3d"):
        run_ladder([], rungs=("fastest",))


@pytest.mark.parametrize("argv, match", [
    (["--quick"], "--quick does not apply to --ladder"),
    (["-K", "2"], "odd K"),
    (["--frames", "9"], "--frames must be 1…8"),
    (["--scenes", "moon"], "unknown scene moon"),
])
def test_cli_ladder_bad_options(tmp_path, capsys, argv, match):
    out = tmp_path / "out"
    assert main(["bench", "--ladder", *argv, "--out", str(out), "--no-progress"]) == 2
    assert match in capsys.readouterr().err
    assert not out.exists()


def test_support_rung_merges_every_visible_window(small_ladder):
    """The ±support rung (every window the 120-plane recording has, equal weights, where visible) is above Eq.
    14–15's seven binomially weighted windows at the exact flow, and under the limit."""
    rows = {r["rung"]: r for r in small_ladder["rows"]}
    assert rows["true_flow"]["psnr"] + 0.5 < rows["true_flow_support"]["psnr"] < rows["limit"]["psnr"]


def test_support_rung_drops_what_the_exact_motion_hides():
    """``visible_only``: a window whose every sample is hidden adds nothing, whatever its values."""
    from spikeref.bench.ladder import true_flow_frame

    class Hidden:  # zero motion, nothing visible at any other time
        height, width = 12, 16

        def true_flow(self, t_ref, t_other, points):
            return np.zeros_like(points), np.zeros(points.shape[:-1], bool)

    counts = np.zeros((3, 4, 6, 8), np.float32)
    counts[1] = 5.0  # the reference window: rate 0.5
    counts[[0, 2]] = 9.0  # hidden windows
    kept = true_flow_frame(counts, Hidden(), 10, 0, 1, np.ones(3), visible_only=True)
    mixed = true_flow_frame(counts, Hidden(), 10, 0, 1, np.ones(3))
    assert np.allclose(kept, 0.5) and np.allclose(mixed, (0.5 + 0.9 + 0.9) / 3)


def test_the_dark_calibration_takes_the_sensors_floor_off_every_noisy_rung():
    """The translation's sensor fires 0.002 spikes per readout without light (Eq. 6, γ = 0.002): calibrated on its
    own dark recording, ours and TFP gain, the limit (noise-free) is the same."""
    from spikeref.simulate.scenes import load_scene
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "spikeref" / "bench" / "scenes" / "2_translation.toml"
    sc = BenchScene("translation", path, load_scene(path, overrides={"planes": 120}))
    level = sc.dark_calibration(0, 2000)["dark_level"]
    # 4096 pixels a phase × 2000 readouts at 0.002 (+ 5 % of pixels at 1/2000 of inherent noise): ±2 %
    np.testing.assert_allclose(level, 0.002 + 0.05 / 2000, rtol=0.06)
    rungs = ("tfp", "ours", "limit")
    plain = {r["rung"]: r["psnr"] for r in run_ladder([sc], frames=1, rungs=rungs, peers=(), progress=False)["rows"]}
    res = run_ladder([sc], frames=1, rungs=rungs, peers=(), progress=False, dark_calibration=True)
    dark = {r["rung"]: r["psnr"] for r in res["rows"]}
    assert res["dark_calibration"] and dark["limit"] == plain["limit"]
    assert dark["ours"] > plain["ours"] + 0.1 and dark["tfp"] > plain["tfp"], (plain, dark)


def test_the_dark_calibration_is_for_the_ladder_only(tmp_path, capsys):
    assert main(["bench", "--dark-calibration", "--quick", "--out", str(tmp_path / "o")]) == 2
    assert "--dark-calibration applies to --ladder only" in capsys.readouterr().err
