import json
from pathlib import Path

import numpy as np
import pytest

from spikeref.cli import main
from spikeref.io.dat import write_dat
from spikeref.io.exr import read_exr

SCENES = Path(__file__).resolve().parents[1] / "examples" / "scenes"


def test_info_on_the_embedded_sample(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "planes      264" in out and "224 × 256" in out and "RGGB" in out
    assert "plane 3 at (1,1) B: " in out and "per Bayer plane" in out
    assert "frames      3:23 for reconstruct at W=10, K=3, L=3" in out  # 264 planes: 26 windows, 3 on each side


def test_info_on_a_mono_file_names_phases_not_colours(tmp_path, capsys):
    spikes = np.zeros((20, 4, 8), np.uint8)
    spikes[:, 0::2, 0::2] = 1
    np.save(tmp_path / "m.npy", spikes)
    assert main(["info", str(tmp_path / "m.npy")]) == 0
    out = capsys.readouterr().out
    assert "per 2×2 phase (spikes/readout):" in out and "plane 0 at (0,0): 1.00000" in out
    assert "plane 3 at (1,1): 0.00000" in out
    assert "frames      none for reconstruct at W=10, K=3, L=3: it needs 70 planes" in out


def test_info_reads_a_sidecar_and_reports_rates(tmp_path, capsys):
    spikes = np.zeros((20, 4, 8), np.uint8)
    spikes[:, 0::2, 0::2] = 1  # every R pixel fires at every readout
    write_dat(tmp_path / "r.dat", spikes)
    (tmp_path / "r.json").write_text(json.dumps({"height": 4, "width": 8, "cfa": "RGGB"}))
    assert main(["info", str(tmp_path / "r.dat")]) == 0
    out = capsys.readouterr().out
    assert "R: 1.00000" in out and "B: 0.00000" in out and "mean rate   0.25000" in out


def _spy_on_plane_reads(monkeypatch, limit):
    """Count the planes ``spikeref info`` reads through ``window_counts``; fail as soon as more than ``limit``."""
    import spikeref.accumulate as accumulate

    real, reads = accumulate.window_counts, []

    def spy(stream, window, start=0, count=None, out=None):
        n = window * (count if count is not None else (len(stream) - start) // window)
        assert sum(r[1] for r in reads) + n <= limit, f"info read more than {limit} planes"
        reads.append((start, n))
        return real(stream, window, start=start, count=count, out=out)

    monkeypatch.setattr(accumulate, "window_counts", spy)
    return reads


def test_info_on_a_25_gb_file_reads_only_a_bounded_sample(tmp_path, monkeypatch, capsys):
    path = tmp_path / "huge.dat"
    with open(path, "wb") as f:
        f.truncate(25_000_000_000)  # sparse: 200 000 planes of 1000×1000 (125 000 bytes each), no disk used
    (tmp_path / "huge.json").write_text(json.dumps({"height": 1000, "width": 1000, "cfa": "RGGB"}))
    reads = _spy_on_plane_reads(monkeypatch, limit=1000)
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "planes      200000" in out and "1000 × 1000" in out and "plane size  125000 bytes" in out
    assert "duration    10000.000 ms" in out and "RGGB" in out and "mean rate   0.00000" in out
    assert "statistics  over 1000 of 200000 planes" in out and "--stats" in out
    assert 0 < sum(n for _, n in reads) <= 1000
    starts = [s for s, _ in reads]
    assert min(starts) == 0 and max(s + n for s, n in reads) == 200000  # spread from the first plane to the last


def test_info_sample_and_stats_agree_on_a_uniform_file(tmp_path, monkeypatch, capsys):
    spikes = np.zeros((5000, 4, 8), np.uint8)
    spikes[:, 0::2, 0::2] = 1  # every R pixel fires at every readout
    spikes[::2, 1::2, 1::2] = 1  # every B pixel at every other readout (the sample blocks are 50 planes)
    write_dat(tmp_path / "u.dat", spikes)
    (tmp_path / "u.json").write_text(json.dumps({"height": 4, "width": 8, "cfa": "RGGB"}))
    reads = _spy_on_plane_reads(monkeypatch, limit=1000)
    assert main(["info", str(tmp_path / "u.dat")]) == 0
    sampled = capsys.readouterr().out
    assert "statistics  over 1000 of 5000 planes" in sampled and "R: 1.00000" in sampled and "B: 0.50000" in sampled
    reads.clear()
    monkeypatch.undo()
    assert main(["info", str(tmp_path / "u.dat"), "--stats"]) == 0
    full = capsys.readouterr().out
    assert "statistics  over all 5000 planes" in full and "R: 1.00000" in full and "B: 0.50000" in full


def test_baseline_tfp_writes_video_and_exr(tmp_path, capsys):
    assert main(["baseline", "tfp", "-o", str(tmp_path / "v.mp4"), "--exr-dir", str(tmp_path / "exr"), "-W", "20"]) == 0
    assert capsys.readouterr().err.splitlines()[-2:] == [f"wrote {tmp_path / 'v.mp4'}", f"wrote {tmp_path / 'exr'}"]
    assert (tmp_path / "v.mp4").stat().st_size > 1000
    names = sorted(p.name for p in (tmp_path / "exr").iterdir())
    assert len(names) == 264 // 20 and names[0] == "frame_000000.exr"
    frame = read_exr(tmp_path / "exr" / names[0])
    assert frame.shape == (224, 256, 3) and np.isfinite(frame).all() and 0 <= frame.min() <= frame.max() <= 1
    # --frames: exactly those, each the same as in the whole run
    assert main(["baseline", "tfp", "--exr-dir", str(tmp_path / "part"), "-W", "20", "--frames", "3:5"]) == 0
    assert sorted(p.name for p in (tmp_path / "part").iterdir()) == ["frame_000003.exr", "frame_000004.exr"]
    np.testing.assert_array_equal(read_exr(tmp_path / "part" / "frame_000004.exr"),
                                  read_exr(tmp_path / "exr" / "frame_000004.exr"))
    capsys.readouterr()
    assert main(["baseline", "tfp", "--exr-dir", str(tmp_path / "none"), "-W", "20", "--frames", "12:20"]) == 2
    assert "--frames 12:20: there are frames 0:13" in capsys.readouterr().err
    assert not (tmp_path / "none").exists()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["info", "nope.dat"], "no such file"),
        (["baseline", "tfp", "-o", "out.avi"], "must end in .mp4 or .gif"),
        (["baseline", "tfp", "-o", "v.mp4", "-W", "0"], "window must be a positive"),
        (["baseline", "tfp", "-o", "v.mp4", "-W", "100000"], "longer than the stream"),
        (["info", "--cfa", "RGB"], "--cfa RGB: not a colour pattern; give one of RGGB, BGGR, GRBG, GBRG or mono"),
        (["simulate", "missing.toml", "-o", "x.dat"], "no such scene file"),
        (["simulate", str(SCENES / "fan.toml"), "-o", "x.dat", "--effects", "glare"], "unknown effect 'glare'"),
        (["simulate", str(SCENES / "fan.toml"), "-o", "x.dat", "--effects", "dark_current:gamma"],
         "expected param=value"),
        (["simulate", str(SCENES / "fan.toml"), "-o", "x.dat", "--effects", "dark_current:gamma=-1"],
         "dark_current.gamma"),
        (["simulate", str(SCENES / "fan.toml"), "-o", "x.npy"], "must be a .dat"),
        (["noise-check", "--windows", "0"], "windows must be a positive"),
    ],
)
def test_bad_input_is_one_clear_line_and_no_output(tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_truncated_dat_names_the_plane_size(tmp_path, capsys):
    (tmp_path / "t.dat").write_bytes(b"\0" * 12501)
    assert main(["info", str(tmp_path / "t.dat")]) == 2
    assert "12500 bytes each" in capsys.readouterr().err


def test_simulate_writes_dat_sidecar_and_ground_truth(tmp_path, capsys):
    out = tmp_path / "sub" / "fan.dat"
    out.parent.mkdir()  # an output file's folder must exist (spikeref makes no missing parents)
    argv = ["simulate", str(SCENES / "fan.toml"), "-o", str(out), "--planes", "40", "--seed", "3",
            "--gt", str(tmp_path / "gt.npz"), "--gt-window", "20", "--effects", "random_phase,dark_current:gamma=0.01"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "40 planes" in text and "random_phase, dark_current" in text
    side = json.loads(out.with_suffix(".json").read_text())
    assert side["effects"] == {"random_phase": {}, "dark_current": {"gamma": 0.01}} and side["seed"] == 3
    with np.load(tmp_path / "gt.npz") as gt:
        assert gt["gt"].shape == (2, 256, 256, 3)
    # the file opens without --height/--width thanks to the sidecar
    assert main(["info", str(out)]) == 0
    assert "256 × 256" in capsys.readouterr().out
    # the same command gives the same bytes; --effects none is noise-free
    assert main(argv[:1] + [argv[1], "-o", str(tmp_path / "again.dat")] + argv[4:]) == 0
    assert (tmp_path / "again.dat").read_bytes() == out.read_bytes()


def test_noise_check_on_a_static_simulation(tmp_path, capsys):
    out = tmp_path / "chart.dat"
    assert main(["simulate", str(SCENES / "color_chart.toml"), "-o", str(out), "--planes", "400"]) == 0
    capsys.readouterr()
    assert main(["noise-check", str(out), "--windows", "5,10,50,100"]) == 0
    text = capsys.readouterr().out
    assert "| 5 | 0.25 |" in text and "R mean abs" in text and "E[I_c]" in text


@pytest.fixture(scope="module")
def random_weights(tmp_path_factory):
    from spikeref.denoise.unet import UNet, UNetSpec

    path = tmp_path_factory.mktemp("w") / "w16.npz"
    UNet.random(UNetSpec(width=16), seed=0).save(path)
    return path


def test_reconstruct_chunks_and_resume_equal_one_run(tmp_path, random_weights, capsys):
    w = ["--weights", str(random_weights), "-L", "2"]
    a_out = ["-o", str(tmp_path / "a.mp4"), "--exr-dir", str(tmp_path / "a")]
    assert main(["reconstruct", *a_out, "--frames", "2:7", *w]) == 0
    assert "frames 2:7 at 2000 FPS" in capsys.readouterr().err
    # an interrupted run: frames 2:4 written, then --resume completes 2:7 without recomputing them
    assert main(["reconstruct", "--exr-dir", str(tmp_path / "b"), "--frames", "2:4", *w]) == 0
    first = (tmp_path / "b" / "frame_000002.exr").stat().st_mtime_ns
    assert main(["reconstruct", "-o", str(tmp_path / "b.mp4"), "--exr-dir", str(tmp_path / "b"), "--frames", "2:7",
                 "--resume", *w]) == 0
    assert "2 already written" in capsys.readouterr().err
    assert (tmp_path / "b" / "frame_000002.exr").stat().st_mtime_ns == first
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert names == [f"frame_{k:06d}.exr" for k in range(2, 7)] + ["spikeref_run.json"]
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == names
    for n in names[:-1]:
        np.testing.assert_array_equal(read_exr(tmp_path / "a" / n), read_exr(tmp_path / "b" / n))
    assert (tmp_path / "b.mp4").stat().st_size > 1000
    # the folder's record says how its frames were made: --resume with other settings is refused, nothing written
    before = sorted((p.name, p.stat().st_mtime_ns) for p in (tmp_path / "b").iterdir())
    assert main(["reconstruct", "--exr-dir", str(tmp_path / "b"), "--frames", "2:8", "--resume", "--no-denoiser",
                 "-L", "2"]) == 2
    err = capsys.readouterr().err
    assert "--resume: the frames in" in err and "were made with other settings (denoiser, params.denoise;" in err
    assert sorted((p.name, p.stat().st_mtime_ns) for p in (tmp_path / "b").iterdir()) == before
    # without --resume too: it would overwrite some frames and keep the others (a folder of two settings)
    assert main(["reconstruct", "--exr-dir", str(tmp_path / "b"), "--frames", "2:3", "--no-denoiser", "-L", "2"]) == 2
    err = capsys.readouterr().err
    assert f"--exr-dir {tmp_path / 'b'} holds frames made with other settings (denoiser, params.denoise;" in err
    assert "would mix" in err
    assert sorted((p.name, p.stat().st_mtime_ns) for p in (tmp_path / "b").iterdir()) == before
    # the same settings without --resume overwrite as they always did
    assert main(["reconstruct", "--exr-dir", str(tmp_path / "b"), "--frames", "2:3", *w]) == 0
    (tmp_path / "b" / "spikeref_run.json").unlink()  # a folder from before the record: resumed as it is
    assert main(["reconstruct", "--exr-dir", str(tmp_path / "b"), "--frames", "2:7", "--resume", *w]) == 0
    assert "5 already written" in capsys.readouterr().err


def test_reconstruct_fast_preset_and_profile(tmp_path, random_weights, capsys):
    argv = ["reconstruct", "--exr-dir", str(tmp_path / "f"), "--frames", "3:5", "--weights", str(random_weights)]
    assert main([*argv, "--preset", "fast", "--profile"]) == 0
    err = capsys.readouterr().err
    assert "the fast preset" in err and "chained warp" in err
    table = err[err.index("where the time went"):]
    for stage in ("accumulate", "network", "guard", "align", "warp", "demosaic", "write", "other", "total"):
        assert f"\n{stage} " in table, table
    assert "2 frames" in table and "outside the network:" in table and "% of time" in table
    assert sorted(p.name for p in (tmp_path / "f").glob("*.exr")) == ["frame_000003.exr", "frame_000004.exr"]
    assert main([*argv[:2], str(tmp_path / "g"), *argv[3:], "--preset", "paper"]) == 0
    err = capsys.readouterr().err
    assert "the paper's procedure" in err and "where the time went" not in err


def test_reconstruct_without_a_denoiser(tmp_path, capsys):
    """--preset fastest and --no-denoiser run no network; the two agree with the API's ReconstructParams."""
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.sample import load_sample

    assert main(["reconstruct", "--exr-dir", str(tmp_path / "f"), "--frames", "3:5", "--preset", "fastest",
                 "--profile"]) == 0
    err = capsys.readouterr().err
    assert "the fastest preset, no denoiser)" in err and "weights" not in err.splitlines()[0]
    assert "\nnetwork         0.000" in err
    assert main(["reconstruct", "--exr-dir", str(tmp_path / "n"), "--frames", "3:4", "--no-denoiser"]) == 0
    assert "composed warp, multi-frame demosaic, no denoiser)" in capsys.readouterr().err
    want = next(iter(Reconstructor(load_sample(), ReconstructParams.fastest()).frames(3, 4))).rgb
    np.testing.assert_allclose(read_exr(tmp_path / "f" / "frame_000003.exr"), want, rtol=1e-6)
    assert main(["reconstruct", "-o", str(tmp_path / "x.mp4"), "--no-denoiser", "--weights", "b2u_w16"]) == 2
    assert "--no-denoiser runs no network: --weights does not apply" in capsys.readouterr().err
    assert main(["reconstruct", "-o", str(tmp_path / "x.mp4"), "--preset", "fastest", "--guard", "off",
                 "--no-shrink"]) == 2
    assert "--preset fastest runs no network: --guard and --no-shrink do not apply" in capsys.readouterr().err


def test_reconstruct_with_flow_on_smoothed_frames(tmp_path, random_weights, capsys):
    argv = ["reconstruct", "--exr-dir", str(tmp_path / "s"), "--frames", "3:5", "--weights", str(random_weights)]
    assert main([*argv, "--flow-frames", "smoothed"]) == 0
    assert "flow on smoothed frames" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "s").glob("*.exr")) == ["frame_000003.exr", "frame_000004.exr"]
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--flow-frames", "raw"])
    assert exc.value.code == 2
    assert "invalid choice: 'raw'" in capsys.readouterr().err


def test_resume_recomputes_empty_truncated_and_foreign_frames(tmp_path, random_weights, capsys):
    # What a power loss or a run with other settings can leave: a zero-byte file, half a file, a frame of
    # another size. --resume must not count them as done (nor crash reading them back); it recomputes them.
    from spikeref.io.exr import write_exr

    w = ["--weights", str(random_weights), "-L", "1"]
    ref, out = tmp_path / "ref", tmp_path / "out"
    assert main(["reconstruct", "--exr-dir", str(ref), "--frames", "2:6", *w]) == 0
    assert main(["reconstruct", "--exr-dir", str(out), "--frames", "2:6", *w]) == 0
    good = (out / "frame_000005.exr").stat().st_mtime_ns
    (out / "frame_000002.exr").write_bytes(b"")
    data = (ref / "frame_000003.exr").read_bytes()
    (out / "frame_000003.exr").write_bytes(data[: len(data) // 2])
    write_exr(out / "frame_000004.exr", np.zeros((8, 8, 3), np.float32))
    capsys.readouterr()
    assert main(["reconstruct", "-o", str(tmp_path / "v.mp4"), "--exr-dir", str(out), "--frames", "2:6", "--resume",
                 *w]) == 0
    err = capsys.readouterr().err
    assert "3 frame files" in err and "computed again" in err and "1 already written" in err
    assert (out / "frame_000005.exr").stat().st_mtime_ns == good
    for k in range(2, 6):
        name = f"frame_{k:06d}.exr"
        np.testing.assert_array_equal(read_exr(out / name), read_exr(ref / name))
    # reading a damaged frame back (assembling a video from it) is a one-line error, not a traceback
    for damaged in (b"", data[: len(data) // 2]):
        (out / "frame_000003.exr").write_bytes(damaged)
        with pytest.raises(ValueError, match="not a readable EXR"):
            read_exr(out / "frame_000003.exr")


@pytest.mark.parametrize("extra, message", [
    (["--frames", "0:5"], "this stream has frames 3:23"),
    (["--frames", "5:3"], "--frames 5:3: an empty range"),
    (["--accumulate", "count", "--support", "20"], "--support applies to the adaptive merge; this run merges with "
                                                    "the binomial merge (--accumulate count makes it so"),
    (["--frames", "x"], "--frames must be a:b (frame numbers, b excluded) or a number of frames; got 'x'"),
    (["--frames", "1:2:3"], "--frames must look like a:b"),
    (["-K", "2"], "-K must be odd (the reference is the middle window); got 2"),
    (["-W", "0"], "-W/--window must be a whole number ≥ 1; got 0"),
    (["-L", "-1"], "-L must be a whole number ≥ 0; got -1"),
    (["--weights", "nosuch"], "--weights nosuch: no such weights file, nor a bundled name (b2u_w16, "),
    (["-W", "40"], "needs ((K−1)L+1)·W = 280 planes"),
    (["--resume"], "--resume needs --exr-dir"),
])
def test_reconstruct_bad_input(tmp_path, random_weights, capsys, extra, message):
    out = tmp_path / "v.mp4"
    argv = ["reconstruct", "-o", str(out), "--weights", str(random_weights), *extra]
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_no_shrink_gives_the_papers_denoiser(tmp_path, capsys):
    """`denoise --no-shrink` writes Ψ[D(I)] without the residual shrinkage; the default differs from it."""
    outs = {}
    for flag in ([], ["--no-shrink"]):
        d = tmp_path / ("plain" if flag else "shrunk")
        assert main(["denoise", "-W", "50", "--guard", "off", "--exr-dir", str(d), *flag]) == 0
        assert capsys.readouterr().err.splitlines()[-1] == f"wrote {d}"
        outs[bool(flag)] = read_exr(sorted(d.glob("*.exr"))[0])
    assert outs[True].shape == outs[False].shape and not np.array_equal(outs[True], outs[False])


def test_array_files_by_key_and_axis_order(tmp_path, capsys):
    """`--key` picks an .npz array (Spike-Zoo's ``spk`` without it); `--axes HWT` reads planes-last arrays."""
    spikes = (np.random.default_rng(0).random((40, 16, 24)) < 0.2).astype(np.uint8)
    np.savez(tmp_path / "zoo.npz", spk=spikes, label=np.zeros(3))
    np.savez(tmp_path / "sim.npz", arr_0=np.ascontiguousarray(np.moveaxis(spikes, 0, -1)))
    assert main(["info", str(tmp_path / "zoo.npz")]) == 0
    out = capsys.readouterr().out
    assert "planes      40" in out and "size        16 × 24 pixels" in out
    assert main(["info", str(tmp_path / "sim.npz"), "--axes", "HWT"]) == 0
    out = capsys.readouterr().out
    assert "planes      40" in out and "size        16 × 24 pixels" in out and "axes        HWT (planes last)" in out
    assert main(["info", str(tmp_path / "sim.npz")]) == 0  # planes first: 16 planes of 24×40, as stored
    out = capsys.readouterr().out
    assert "planes      16" in out
    assert "axes        THW (planes first; --axes HWT reads a planes-last array)" in out  # how it was read
    assert main(["reconstruct", str(tmp_path / "sim.npz"), "--axes", "HWT", "--no-denoiser", "-L", "1",
                 "--exr-dir", str(tmp_path / "exr"), "--frames", "1:2"]) == 0
    assert "sim.npz: 40 planes of 16×24 (stored planes-last, --axes HWT) mono" in capsys.readouterr().err
    assert main(["info", str(tmp_path / "zoo.npz"), "--key", "nope"]) == 2
    assert "no key 'nope'; found keys ['spk', 'label']" in capsys.readouterr().err


def test_help_never_shows_a_none_default(capsys):
    """The defaults formatter adds "(default: X)" only where the help has not said it, and never "None"."""
    import contextlib

    for cmd in ("reconstruct", "denoise", "baseline", "simulate", "noise-check", "bench", "train"):
        with contextlib.suppress(SystemExit):
            main([cmd, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "(default: None)" not in text, cmd
        assert "(default: False)" not in text, cmd
    with contextlib.suppress(SystemExit):
        main(["noise-check", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: 5,10,20,50,100" in text
    assert "first plane of the analysed span (default: 0)" in text  # 0 is a default shown, not "not given"


def test_help_quotes_no_measured_figure(capsys):
    """A measured speed or accuracy lives in one place (README.md, docs/results.md) and --help points there: the help
    once said 15.6 against 12.1 frames/s for the fast preset while the README said 23.6 against 18.4."""
    import contextlib
    import re

    figure = re.compile(r"\d+(\.\d+)?\s*(frames/s|dB\b|[x×] (faster|slower|the))", re.IGNORECASE)
    for cmd in ("reconstruct", "denoise", "baseline", "simulate", "noise-check", "bench", "train", "info", "golden"):
        with contextlib.suppress(SystemExit):
            main([cmd, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        found = [m.group(0) for m in figure.finditer(text)]
        assert found == [], (cmd, found)
    assert figure.search("measured 15.6 against 12.1 frames/s") and figure.search("+6.8 dB over TFP")


def test_a_cold_first_run_says_it_compiles_once(tmp_path, capsys, monkeypatch):
    """Before the first run sits silent while Numba compiles, one line says so and for how long; once a run of that
    command has ended well the kernels are cached and later runs say nothing (the marker follows the package's
    files: spikeref._jit.is_warm)."""
    from spikeref import _jit

    if not _jit.numba_available:
        pytest.skip("no Numba: nothing compiles")
    monkeypatch.setattr(_jit, "cache_dir", tmp_path / "cache")
    monkeypatch.setattr(_jit, "caching_enabled", True)
    argv = ["baseline", "tfp", "-W", "50", "--exr-dir", str(tmp_path / "a")]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert f"compiling kernels once, about 8 s on two cores (cached in {tmp_path / 'cache'} for later runs)" in err
    assert _jit.is_warm("baseline-tfp") and not _jit.is_warm("baseline-tfi")
    assert main(argv[:-1] + [str(tmp_path / "b")]) == 0
    assert "compiling" not in capsys.readouterr().err
    assert main(["baseline", "tfp", "-W", "0", "--exr-dir", str(tmp_path / "c")]) == 2  # refused: no note
    assert "compiling" not in capsys.readouterr().err
    monkeypatch.setattr(_jit, "cache_dir", None)
    monkeypatch.setattr(_jit, "caching_enabled", False)
    assert main(argv[:-1] + [str(tmp_path / "d")]) == 0
    assert "the kernel cache is off, so every run compiles" in capsys.readouterr().err


def test_a_closed_pipe_ends_quietly():
    """`spikeref info | head -1`: the reader leaves early; no "Broken pipe" error, exit status 0."""
    import subprocess
    import sys

    code = "import sys; from spikeref.cli import main; sys.exit(main(['info']))"
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before info writes its first line (its imports take longer)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, err
    assert "Broken pipe" not in err and "Traceback" not in err


def test_weights_trained_on_the_other_window_quantity_get_a_note(tmp_path, capsys):
    """Count-trained weights on window charges (or the reverse) run, with a one-line note saying so."""
    argv = ["denoise", "-W", "50", "--frames", "1", "--guard", "off", "--exr-dir"]
    assert main([*argv, str(tmp_path / "a"), "--accumulate", "charge", "--weights", "b2u_w16"]) == 0
    assert ("spikeref denoise: note: --weights b2u_w16 was trained on Eq. 4 windows (counts); the windows here give "
            "window charges" in capsys.readouterr().err)
    assert main([*argv, str(tmp_path / "b"), "--accumulate", "charge"]) == 0  # the bundled charge network
    assert "note" not in capsys.readouterr().err


def test_denoise_frames_takes_a_range_like_reconstruct(tmp_path, capsys):
    """`denoise --frames a:b` writes frames a … b−1 (the same frames a longer run writes); N means 0:N."""
    argv = ["denoise", "-W", "20", "--guard", "off", "--exr-dir"]
    assert main([*argv, str(tmp_path / "all"), "--frames", "4"]) == 0
    assert main([*argv, str(tmp_path / "part"), "--frames", "2:4"]) == 0
    names = sorted(p.name for p in (tmp_path / "part").iterdir())
    assert names == ["frame_000002.exr", "frame_000003.exr"]
    for name in names:
        np.testing.assert_array_equal(read_exr(tmp_path / "part" / name), read_exr(tmp_path / "all" / name))
    capsys.readouterr()
    assert main([*argv, str(tmp_path / "x"), "--frames", "3:2"]) == 2
    assert "--frames 3:2: an empty range" in capsys.readouterr().err
    assert main([*argv, str(tmp_path / "x"), "--frames", "10:99"]) == 2
    assert "--frames 10:99: there are frames 0:13" in capsys.readouterr().err
    assert main([*argv, str(tmp_path / "x"), "--frames", "two"]) == 2
    assert "--frames must be a:b" in capsys.readouterr().err


@pytest.mark.parametrize("argv, written", [
    (["denoise", "-W", "50", "--frames", "2", "--guard", "off"], ["denoised.mp4", "denoised_exr"]),
    (["baseline", "tfp", "-W", "50"], ["tfp.mp4", "tfp_exr"]),
    (["baseline", "tfi", "--every", "50", "--exr-dir", "only"], ["only"]),
])
def test_commands_without_outputs_write_named_defaults(tmp_path, monkeypatch, capsys, argv, written):
    """As `reconstruct`: without -o/--exr-dir a video and its EXR frames under names of the command's own."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == written
    assert capsys.readouterr().err.splitlines()[-len(written):] == [f"wrote {name}" for name in written]
    exrs = sorted((tmp_path / written[-1]).glob("*.exr"))
    assert exrs and np.isfinite(read_exr(exrs[0])).all()


def test_reconstruct_frames_n_is_the_first_n(tmp_path, capsys):
    """``--frames N``: the first N frames the stream has (as ``denoise --frames N``), cut at the end."""
    argv = ["reconstruct", "--no-denoiser", "-L", "1", "--exr-dir"]
    assert main([*argv, str(tmp_path / "a"), "--frames", "2"]) == 0
    assert "→ frames 1:3 at" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "a").glob("*.exr")) == ["frame_000001.exr", "frame_000002.exr"]
    assert main([*argv, str(tmp_path / "b"), "--frames", "9999", "-W", "40"]) == 0
    assert "→ frames 1:5 at" in capsys.readouterr().err  # cut to the stream: 264 planes are 6 windows of 40
    assert main([*argv, str(tmp_path / "c"), "--frames", "0"]) == 2
    assert "--frames must be a positive number of frames; got 0" in capsys.readouterr().err


def test_workers_without_dask_are_refused_before_any_output(tmp_path, capsys, monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "distributed" else real(name, *a))
    out = tmp_path / "exr"
    assert main(["reconstruct", "--exr-dir", str(out), "--workers", "2"]) == 2
    assert "--workers needs Dask: pip install 'spikeref[dask]'" in capsys.readouterr().err
    assert not out.exists()


def test_a_dat_without_sidecar_says_what_size_it_assumed(tmp_path, capsys):
    write_dat(tmp_path / "r.dat", np.zeros((4, 250, 400), np.uint8))
    assert main(["info", str(tmp_path / "r.dat")]) == 0
    assert "note: r.dat has no r.json beside it: read as 250×400 mono (give --height/--width/--cfa" \
           in capsys.readouterr().err
    assert main(["info", str(tmp_path / "r.dat"), "--height", "250", "--width", "400"]) == 0
    assert "note:" not in capsys.readouterr().err  # the sizes were given
    (tmp_path / "r.json").write_text(json.dumps({"height": 250, "width": 400}))
    assert main(["info", str(tmp_path / "r.dat")]) == 0
    assert "note:" not in capsys.readouterr().err


def _if_spikes(rates, planes, seed=0):
    """Integrate-and-fire spikes (T, H, W) of a static rate map: each pixel's train anticorrelated in time."""
    phase = np.random.default_rng(seed).random(rates.shape)
    level = np.floor(rates[None] * np.arange(planes + 1)[:, None, None] + phase[None])
    return np.diff(level, axis=0).astype(np.uint8)


def _warnings(err: str) -> list[str]:
    """The input warnings of stderr: planes-last arrays and .dat options for array files (not the CFA's)."""
    return [line for line in err.splitlines() if line.startswith("warning:")
            and ("looks stored planes-last" in line or " for .dat files and ignored " in line)]


def test_rows_option_reads_a_top_down_dat_as_the_bottom_up_one(tmp_path, capsys):
    """--rows top-down (or "rows" in NAME.json): the same frames as the bottom-up file of the same spikes;
    `info` prints the order; --rows sideways is refused by the parser; a run record names a top-down input."""
    spikes = _if_spikes(np.tile([[0.4, 0.2], [0.2, 0.1]], (8, 12)), 80)
    write_dat(tmp_path / "bu.dat", spikes)
    write_dat(tmp_path / "td.dat", spikes, rows="top-down")
    size = ["--height", "16", "--width", "24", "--cfa", "RGGB"]
    assert main(["info", str(tmp_path / "td.dat"), *size, "--rows", "top-down"]) == 0
    out = capsys.readouterr().out
    assert "rows        stored top-down\n" in out and "plane 0 at (0,0) R: 0.4" in out
    assert main(["info", str(tmp_path / "td.dat"), *size]) == 0  # the wrong order: a G plane where R should be
    out = capsys.readouterr().out
    assert "rows        stored bottom-up (the spike camera's; --rows top-down if the image is upside down)" in out
    assert "plane 0 at (0,0) R: 0.2" in out
    run = ["reconstruct", "--no-denoiser", "-L", "1", "--frames", "1:2"]
    assert main([*run, str(tmp_path / "bu.dat"), *size, "--exr-dir", str(tmp_path / "a")]) == 0
    assert main([*run, str(tmp_path / "td.dat"), *size, "--rows", "top-down", "--exr-dir", str(tmp_path / "b")]) == 0
    np.testing.assert_array_equal(read_exr(tmp_path / "b" / "frame_000001.exr"),
                                  read_exr(tmp_path / "a" / "frame_000001.exr"))
    record = json.loads(next((tmp_path / "b").glob("*.json")).read_text())
    assert record["input"]["rows"] == "top-down"
    assert "rows" not in json.loads(next((tmp_path / "a").glob("*.json")).read_text())["input"]
    (tmp_path / "td.json").write_text(json.dumps({"height": 16, "width": 24, "cfa": "RGGB", "rows": "top-down"}))
    assert main([*run, str(tmp_path / "td.dat"), "--exr-dir", str(tmp_path / "c")]) == 0
    np.testing.assert_array_equal(read_exr(tmp_path / "c" / "frame_000001.exr"),
                                  read_exr(tmp_path / "a" / "frame_000001.exr"))
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(["info", str(tmp_path / "td.dat"), "--rows", "sideways"])
    assert exc.value.code == 2
    assert "argument --rows: invalid choice: 'sideways' (choose from 'bottom-up', 'top-down')" \
        in capsys.readouterr().err


def test_dat_options_given_for_an_array_file_warn_and_the_run_goes_on(tmp_path, capsys):
    spikes = (np.random.default_rng(1).random((12, 4, 8)) < 0.3).astype(np.uint8)
    np.savez(tmp_path / "a.npz", spikes=spikes)
    write_dat(tmp_path / "a.dat", spikes)
    assert main(["info", str(tmp_path / "a.npz"), "--height", "4", "--rows", "top-down", "--file-width", "16"]) == 0
    out, err = capsys.readouterr()
    assert _warnings(err) == ["warning: --height, --file-width, --rows are for .dat files and ignored for a.npz: an "
                              "array file holds its own size, row 0 at the top"]
    assert "planes      12" in out and "rows" not in out  # it ran, and an array has no stored row order
    assert main(["info", str(tmp_path / "a.npz"), "--width", "8"]) == 0
    assert _warnings(capsys.readouterr().err) == ["warning: --width is for .dat files and ignored for a.npz: an "
                                                  "array file holds its own size, row 0 at the top"]
    for argv in (["info", str(tmp_path / "a.npz")], ["info", str(tmp_path / "a.npz"), "--axes", "THW"],
                 ["info", str(tmp_path / "a.dat"), "--height", "4", "--width", "8", "--rows", "bottom-up",
                  "--file-width", "8"]):
        assert main(argv) == 0
        assert _warnings(capsys.readouterr().err) == [], argv
    # what does not apply to a .dat stays refused
    assert main(["info", str(tmp_path / "a.dat"), "--height", "4", "--width", "8", "--key", "spk"]) == 2
    assert "key and axes are for .npy/.npz files" in capsys.readouterr().err
    assert main(["info", str(tmp_path / "a.dat"), "--height", "4", "--width", "8", "--axes", "HWT"]) == 2
    assert "key and axes are for .npy/.npz files" in capsys.readouterr().err


def test_an_array_that_looks_planes_last_warns_unless_read_so(tmp_path, capsys):
    rates = 0.05 + 0.4 * np.random.default_rng(2).random((40, 56))
    spikes = _if_spikes(rates, 120)
    np.savez(tmp_path / "hwt.npz", np.ascontiguousarray(np.moveaxis(spikes, 0, -1)))
    np.save(tmp_path / "thw.npy", spikes)
    assert main(["info", str(tmp_path / "hwt.npz")]) == 0
    out, err = capsys.readouterr()
    assert _warnings(err) == ["warning: hwt.npz looks stored planes-last: its last axis (120 long) behaves like time "
                              "(a pixel's spikes, anticorrelated from one readout to the next) and its first (40) "
                              "does not; read as 40 planes of 56×120 it gives streaks: give --axes HWT"]
    assert "planes      40" in out  # the run went on, as asked
    assert main(["info", str(tmp_path / "hwt.npz"), "--axes", "HWT"]) == 0
    assert _warnings(capsys.readouterr().err) == []
    assert main(["info", str(tmp_path / "thw.npy")]) == 0
    assert _warnings(capsys.readouterr().err) == []


@pytest.mark.realdata
def test_the_planes_last_warning_on_the_real_recordings(real_data, capsys):
    """SpikingSIM's (H, W, T) sample warns without --axes HWT and not with it; Spike-Zoo's (T, H, W) UHSR file and
    the .dat recording do not warn."""
    sim = str(real_data / "spikingsim_real_spike.npz")
    assert main(["info", sim]) == 0
    warned = _warnings(capsys.readouterr().err)
    assert len(warned) == 1 and "looks stored planes-last" in warned[0] and "give --axes HWT" in warned[0]
    for argv in (["info", sim, "--axes", "HWT"], ["info", str(real_data / "spikezoo_uhsr.npz")],
                 ["info", str(real_data / "spikezoo_data_reds_sim_250x400.dat"), "--height", "250", "--width", "400"]):
        assert main(argv) == 0
        assert _warnings(capsys.readouterr().err) == [], argv


# ----------------------------------------------------------------------------- the CFA phase read from the data
@pytest.fixture(scope="module")
def chart_gbrg(tmp_path_factory):
    """A colour chart behind a GBRG mosaic (48×64, 200 planes, noisy): ``chart.dat`` with a sidecar that says
    GBRG, ``bare.dat`` with one that gives the size only."""
    from spikeref.simulate import load_scene, simulate

    folder = tmp_path_factory.mktemp("cfa")
    scene = load_scene(SCENES / "color_chart.toml",
                       overrides={"planes": 200, "camera": {"cfa": "GBRG"}, "content": {"height": 48, "width": 64}})
    spikes = simulate(scene, seed=1).spikes
    for name, meta in (("chart", {"cfa": "GBRG"}), ("bare", {})):
        write_dat(folder / f"{name}.dat", spikes)
        (folder / f"{name}.json").write_text(json.dumps({"height": 48, "width": 64, **meta}))
    return folder


def _cfa_warnings(err: str) -> list[str]:
    """The CFA's warning lines of stderr: a pattern whose green sites the data contradict, or a mosaic read as mono."""
    return [line for line in err.splitlines() if (line.startswith("warning:") and "puts green at" in line)
            or line.startswith("warning: the spikes look like a Bayer mosaic")]


def test_info_json_is_one_object_with_the_detected_phase(chart_gbrg, capsys):
    assert main(["info", str(chart_gbrg / "chart.dat"), "--json"]) == 0
    captured = capsys.readouterr()
    facts = json.loads(captured.out)  # the whole of stdout is one JSON object
    assert facts["height"] == 48 and facts["width"] == 64 and facts["planes"] == 200
    assert facts["cfa"] == "GBRG" and facts["cfa_source"] == "from chart.json"
    assert facts["cfa_detected"] == "GBRG" and 0.5 < facts["cfa_confidence"] <= 1
    assert facts["rate_hz"] == 20000 and facts["duration_ms"] == pytest.approx(10.0)
    assert facts["file"].endswith("chart.dat") and len(facts["phase_rates"]) == 4 and facts["frames"] == [3, 17]
    assert facts["cfa_features"]["planes"] == 200 and len(facts["cfa_features"]["phase_means"]) == 4
    assert _cfa_warnings(captured.err) == []
    # no pattern given: "mono", and the mosaic the data show gets one warning line
    assert main(["info", str(chart_gbrg / "bare.dat"), "--json"]) == 0
    captured = capsys.readouterr()
    facts = json.loads(captured.out)
    assert facts["cfa"] == "mono" and facts["cfa_detected"] == "GBRG"
    assert len(_cfa_warnings(captured.err)) == 1 and "--cfa auto or --cfa GBRG" in captured.err


def test_info_prints_the_given_and_the_detected_phase(chart_gbrg, capsys):
    assert main(["info", str(chart_gbrg / "chart.dat")]) == 0
    out = capsys.readouterr().out
    assert "cfa         GBRG (from chart.json)" in out and "cfa detected GBRG, confidence 0." in out
    assert main(["info", str(chart_gbrg / "bare.dat"), "--cfa", "GRBG"]) == 0
    captured = capsys.readouterr()
    assert "cfa         GRBG (as given)" in captured.out and _cfa_warnings(captured.err) == []  # same green sites
    assert main(["info", str(chart_gbrg / "bare.dat"), "--cfa", "auto"]) == 0
    out = capsys.readouterr().out
    assert "cfa         auto (read from the data below)" in out and "plane 1 at (0,1) B:" in out


def test_cfa_auto_picks_the_pattern(chart_gbrg, tmp_path, capsys):
    from spikeref.cli import build_parser, open_input

    args = build_parser().parse_args(["denoise", str(chart_gbrg / "chart.dat"), "--cfa", "auto"])
    stream = open_input(args)
    assert stream.cfa == "GBRG" and args.cfa == "GBRG"  # a later reader (Dask's workers) opens it alike
    assert capsys.readouterr().err.startswith("cfa auto: detected GBRG, confidence 0.")
    assert main(["baseline", "tfp", str(chart_gbrg / "bare.dat"), "--cfa", "AUTO", "--exr-dir", str(tmp_path / "e"),
                 "-W", "50"]) == 0
    err = capsys.readouterr().err
    assert sum(line.startswith("cfa auto: detected GBRG") for line in err.splitlines()) == 1
    assert _cfa_warnings(err) == []
    # a monochrome recording: auto reads mono, and the run goes on without colour
    mono = np.zeros((60, 8, 10), np.uint8)
    mono[::3] = 1
    np.save(tmp_path / "m.npy", mono)
    args = build_parser().parse_args(["denoise", str(tmp_path / "m.npy"), "--cfa", "auto"])
    assert open_input(args).cfa is None and args.cfa == "mono"
    assert "cfa auto: detected mono" in capsys.readouterr().err


def test_a_contradicting_cfa_warns_once_and_a_right_one_does_not(chart_gbrg, tmp_path, capsys):
    run = ["baseline", "tfp", str(chart_gbrg / "chart.dat"), "--exr-dir", str(tmp_path / "a"), "-W", "50"]
    assert main([*run, "--cfa", "RGGB"]) == 0  # the run goes on: the user may know better
    warned = _cfa_warnings(capsys.readouterr().err)
    assert len(warned) == 1 and warned[0].startswith("warning: --cfa RGGB puts green at (0,1)/(1,0), the spikes at "
                                                     "(0,0)/(1,1) (detected GBRG, green sites confidence 1.00)")
    assert len(list((tmp_path / "a").iterdir())) == 4
    for given in ([], ["--cfa", "GBRG"], ["--cfa", "GRBG"]):  # the sidecar's, the same, the same green sites
        assert main([*run[:4], str(tmp_path / f"ok{len(given)}{''.join(given)}"), *run[5:], *given]) == 0
        assert _cfa_warnings(capsys.readouterr().err) == [], given
    # the sidecar's pattern contradicted: named as the sidecar's
    (tmp_path / "s.json").write_text(json.dumps({"height": 48, "width": 64, "cfa": "BGGR"}))
    (tmp_path / "s.dat").write_bytes((chart_gbrg / "chart.dat").read_bytes())
    assert main(["info", str(tmp_path / "s.dat")]) == 0
    warned = _cfa_warnings(capsys.readouterr().err)
    assert len(warned) == 1 and "the cfa BGGR from s.json puts green at (0,1)/(1,0)" in warned[0]
    # the embedded sample (RGGB, as its sidecar says) and a monochrome file: no warning
    assert main(["info"]) == 0 and _cfa_warnings(capsys.readouterr().err) == []
    mono = (np.random.default_rng(0).random((100, 16, 20)) < 0.2).astype(np.uint8)
    np.save(tmp_path / "m.npy", mono)
    assert main(["info", str(tmp_path / "m.npy"), "--cfa", "RGGB"]) == 0
    assert _cfa_warnings(capsys.readouterr().err) == []  # the phases are alike: nothing contradicts RGGB


def _hot_dat(tmp_path, dark: bool, name: str, planes: int = 120):
    """A 32×32 RGGB .dat (with its sidecar) of Bernoulli spikes: a dim smooth scene or the dark, and three hot
    pixels at 0.6 spikes per readout."""
    from spikeref.io.dat import sidecar_path

    mask = np.zeros((32, 32), bool)
    mask[5, 6] = mask[17, 22] = mask[26, 9] = True
    base = np.zeros((32, 32)) if dark else 0.2 + 0.1 * np.sin(np.arange(32) / 5.0)[None, :] * np.ones((32, 1))
    p = np.clip(base + 0.6 * mask, 0, 1)
    spikes = (np.random.default_rng(7).random((planes, 32, 32)) < p).astype(np.uint8)
    path = tmp_path / name
    write_dat(path, spikes)
    sidecar_path(path).write_text(json.dumps({"height": 32, "width": 32, "cfa": "RGGB"}))
    return path, mask


@pytest.mark.filterwarnings("ignore:.*too small for the alignment pyramid")
def test_calibrate_then_reconstruct_and_denoise_with_the_map(tmp_path, capsys):
    dark, mask = _hot_dat(tmp_path, True, "dark.dat")
    scene, _ = _hot_dat(tmp_path, False, "scene.dat")
    assert main(["calibrate", str(dark), "-o", str(tmp_path / "map.npz")]) == 0
    out = capsys.readouterr().out
    assert "dark.dat: 3 hot pixels" in out
    assert main(["info", str(scene), "--json"]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["hot_pixels"] == 3 and facts["hot_pixel_planes"] == 120
    np.testing.assert_array_equal(np.load(tmp_path / "map.npz")["hot"], mask)
    exr = tmp_path / "exr"
    assert main(["reconstruct", str(scene), "--hot-pixels", str(tmp_path / "map.npz"), "-L", "1", "--no-denoiser",
                 "--frames", "1:2", "--exr-dir", str(exr)]) == 0
    assert "hot pixels: 3 replaced by their same-colour neighbours in every window, from" in capsys.readouterr().err
    record = json.loads((exr / "spikeref_run.json").read_text())
    assert record["hot_pixels"]["replaced"] == 3 and "hot_pixels" not in record["params"]
    # found in the recording itself by default; none said with off
    assert main(["denoise", str(scene), "-W", "10", "--frames", "2", "--exr-dir", str(tmp_path / "d")]) == 0
    assert "hot pixels: 3 replaced" in capsys.readouterr().err
    assert main(["reconstruct", str(scene), "--hot-pixels", "off", "-L", "1", "--no-denoiser", "--frames", "1:2",
                 "--exr-dir", str(tmp_path / "e")]) == 0
    assert "hot pixels" not in capsys.readouterr().err


@pytest.mark.filterwarnings("ignore:.*too small for the alignment pyramid")
def test_calibrate_measures_the_dark_level_and_reconstruct_subtracts_it(tmp_path, capsys):
    """A dark recording firing 0.02 spikes per readout everywhere (and a hot pixel, left out): the map holds that
    level per phase, and ``--dark-level`` takes it off every frame (recorded for ``--resume``)."""
    from spikeref.io.dat import sidecar_path

    rng = np.random.default_rng(11)
    dark_spikes = (rng.random((1000, 32, 32)) < 0.02).astype(np.uint8)
    dark_spikes[:, 5, 6] = 1  # hot: fires every readout
    dark = tmp_path / "dark.dat"
    write_dat(dark, dark_spikes)
    sidecar_path(dark).write_text(json.dumps({"height": 32, "width": 32, "cfa": "RGGB"}))
    scene, _ = _hot_dat(tmp_path, False, "scene.dat")
    cal = tmp_path / "cal.npz"
    assert main(["calibrate", str(dark), "-o", str(cal), "--planes", "1000"]) == 0
    captured = capsys.readouterr()
    assert "1 hot pixels" in captured.out and "dark level (Eq. 9's E[N]/W" in captured.out
    assert "warning: a dark level" not in captured.err
    level = np.load(cal)["dark_level"]
    # 256 pixels a phase × 1000 readouts at 0.02: a binomial standard error of 0.0003
    np.testing.assert_allclose(level, 0.02, atol=0.0015)
    common = [str(scene), "-L", "1", "--no-denoiser", "--frames", "1:2", "--hot-pixels", "off"]
    assert main(["reconstruct", *common, "--exr-dir", str(tmp_path / "a")]) == 0
    assert main(["reconstruct", *common, "--dark-level", str(cal), "--exr-dir", str(tmp_path / "b")]) == 0
    from spikeref.io.exr import read_exr
    from spikeref.dark_level import subtract_dark_level

    plain, dark_taken = read_exr(tmp_path / "a" / "frame_000001.exr"), read_exr(tmp_path / "b" / "frame_000001.exr")
    np.testing.assert_allclose(dark_taken, subtract_dark_level(plain, level, "RGGB"), atol=1e-6)
    record = json.loads((tmp_path / "b" / "spikeref_run.json").read_text())
    np.testing.assert_allclose(record["dark_level"], level)
    assert "dark_level" not in json.loads((tmp_path / "a" / "spikeref_run.json").read_text())


def test_calibrate_warns_when_the_recording_is_not_dark(tmp_path, capsys):
    lit, _ = _hot_dat(tmp_path, False, "lit.dat")  # a dim smooth scene at 0.1–0.3 spikes per readout
    assert main(["calibrate", str(lit), "-o", str(tmp_path / "m.npz")]) == 0
    assert "warning: a dark level of" in capsys.readouterr().err


@pytest.mark.parametrize("value, message", [
    ("map.txt", "--dark-level must be a calibration map .npz"),
    ("nope.npz", "--dark-level nope.npz: no such file (make one with spikeref calibrate"),
    ("old.npz", "no dark level in this map"),
    ("small.npz", "a map of 4×4 pixels for a recording of 32×32"),
    ("lit.npz", "is not a dark recording's (above 0.05)"),
])
def test_bad_dark_level_maps_are_refused_in_one_line(tmp_path, capsys, monkeypatch, value, message):
    from spikeref.hot_pixels import save_hot_pixel_map

    monkeypatch.chdir(tmp_path)
    save_hot_pixel_map(tmp_path / "old.npz", np.zeros((32, 32), bool))
    save_hot_pixel_map(tmp_path / "small.npz", np.zeros((4, 4), bool), height=4, width=4, dark_level=np.zeros(4))
    save_hot_pixel_map(tmp_path / "lit.npz", np.zeros((32, 32), bool), dark_level=np.full(4, 0.2))
    scene, _ = _hot_dat(tmp_path, False, "scene.dat")
    assert main(["reconstruct", str(scene), "--dark-level", value, "-L", "1", "--exr-dir", "x"]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("value, message", [
    ("map.txt", "--hot-pixels must be auto, off or a map .npz"),
    ("nope.npz", "no such file (make one with spikeref calibrate"),
    ("small.npz", "a map of 4×4 pixels for a recording of 32×32"),
])
def test_bad_hot_pixel_maps_are_refused_in_one_line(tmp_path, capsys, monkeypatch, value, message):
    from spikeref.hot_pixels import save_hot_pixel_map

    monkeypatch.chdir(tmp_path)
    save_hot_pixel_map(tmp_path / "small.npz", np.zeros((4, 4), bool))
    scene, _ = _hot_dat(tmp_path, False, "scene.dat")
    assert main(["reconstruct", str(scene), "--hot-pixels", value, "-L", "1", "--exr-dir", "x"]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "x").exists()


def test_every_option_of_reconstruct_denoise_and_bench_is_in_docs_options():
    """``docs/options.md`` lists every option of the three commands that make or measure frames (issue: each option
    with what it buys); a new option without its line there fails here."""
    from pathlib import Path

    from spikeref.cli import build_parser

    text = (Path(__file__).resolve().parents[1] / "docs" / "options.md").read_text(encoding="utf-8")
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    missing = []
    for name in ("reconstruct", "denoise", "bench"):
        for action in commands[name]._actions:
            flags = [f for f in action.option_strings if f.startswith("--") or len(f) == 2]
            if not flags or "--help" in flags:
                continue
            if not any(f"`{f}" in text for f in flags):
                missing.append(f"{name} {flags[0]}")
    assert not missing, missing


def test_help_loads_no_numba_kernel():
    """``spikeref --help`` and every command's parser answer without importing Numba or a kernel module
    (docs/architecture.md: application modules import what a command runs inside the function that runs it)."""
    import subprocess
    import sys

    from spikeref.cli.noise_check import NOISE_CHECK_WINDOWS
    from spikeref.noise_check import DEFAULT_WINDOWS

    assert NOISE_CHECK_WINDOWS == DEFAULT_WINDOWS  # restated for the parser
    code = ("import sys\nfrom spikeref.cli.parser import build_parser\nbuild_parser()\n"
            "print(sorted(m for m in sys.modules if m == 'numba' or m.startswith('numba.') or 'kernels' in m))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out
