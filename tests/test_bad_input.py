"""Bad input at every public entry point: a clear error naming what is wrong, and no partial output file.

Each case runs in an empty folder; after the error the folder must hold nothing but the
inputs the case made (no output, no temporary file).  CLI cases check the exit status 2 and
the message on stderr; API cases the exception type and message.
"""

from pathlib import Path

import numpy as np
import pytest

from spikeref.cli import SAMPLE, main

GOOD = (np.random.default_rng(0).random((40, 8, 8)) < 0.3).astype(np.uint8)


def _dat(folder: Path, nbytes=None, name="in.dat") -> Path:
    from spikeref.io.dat import write_dat

    path = folder / name
    write_dat(path, GOOD)
    if nbytes is not None:
        path.write_bytes(path.read_bytes()[:nbytes])
    return path


def _toml(folder: Path, text: str) -> Path:
    path = folder / "scene.toml"
    path.write_text(text)
    return path


SCENE = ('name = "u"\nplanes = 20\n[camera]\ncfa = "RGGB"\n[content]\ntype = "uniform"\nheight = 8\nwidth = 8\n'
         'brightness = {b}\n')

# (id, argv builder (folder → argv), message on stderr)
CLI_CASES = [
    ("info missing file", lambda d: ["info", str(d / "nope.dat")], "no such file"),
    ("truncated .dat", lambda d: ["info", str(_dat(d, 8 * 8 // 8 * 40 - 3)), "--height", "8", "--width", "8"],
     "not a whole number of 8×8 planes"),
    ("empty .dat", lambda d: ["info", str(_dat(d, 0)), "--height", "8", "--width", "8"], "the file is empty"),
    ("odd height for a Bayer file", lambda d: ["reconstruct", str(_dat(d)), "--height", "1", "--width", "64",
                                               "--cfa", "RGGB", "-L", "0", "--exr-dir", str(d / "o")], "even"),
    ("unknown CFA", lambda d: ["info", str(_dat(d)), "--height", "8", "--width", "8", "--cfa", "RGBX"],
     "--cfa RGBX: not a colour pattern; give one of RGGB, BGGR, GRBG, GBRG or mono"),
    ("K even", lambda d: ["reconstruct", "-K", "2", "-o", str(d / "o.mp4")], "K must be odd"),
    ("L negative", lambda d: ["reconstruct", "-L", "-1", "-o", str(d / "o.mp4")], "-L must be a whole number ≥ 0"),
    ("W zero", lambda d: ["reconstruct", "-W", "0", "-o", str(d / "o.mp4")], "-W/--window must be a whole number ≥ 1"),
    ("stream shorter than the support", lambda d: ["reconstruct", "-W", "40", "-o", str(d / "o.mp4")],
     "needs ((K−1)L+1)·W = 280 planes"),
    ("--frames not a:b", lambda d: ["reconstruct", "--frames", "5:", "--frames", "five", "-o", str(d / "o.mp4")],
     "--frames must be a:b (frame numbers, b excluded) or a number of frames"),
    ("--frames outside", lambda d: ["reconstruct", "--frames", "0:100", "-o", str(d / "o.mp4")],
     "--frames 0:100: this stream has frames 3:23"),
    ("video suffix", lambda d: ["reconstruct", "-o", str(d / "o.avi")], "video output must end in .mp4 or .gif"),
    ("--resume without EXR folder", lambda d: ["reconstruct", "--resume", "-o", str(d / "o.mp4")],
     "--resume needs --exr-dir"),
    ("missing weights", lambda d: ["reconstruct", "--weights", str(d / "w.npz"), "-o", str(d / "o.mp4")],
     "w.npz"),
    ("weights not an npz", lambda d: ["denoise", "--weights", str(_toml(d, "x")), "-o", str(d / "o.mp4")],
     "not a weights .npz"),
    ("denoise W zero", lambda d: ["denoise", "-W", "0", "-o", str(d / "o.mp4")], "window"),
    ("baseline unknown file type", lambda d: ["baseline", "tfp", str(_toml(d, "x")), "-o", str(d / "o.mp4")],
     "unknown spike file type '.toml'"),
    ("scene without planes", lambda d: ["simulate", str(_toml(d, SCENE.format(b=0.5).replace("planes = 20\n", ""))),
                                        "-o", str(d / "o.dat")],
     "planes is required"),
    ("scene negative brightness", lambda d: ["simulate", str(_toml(d, SCENE.format(b=-1))), "-o", str(d / "o.dat")],
     "brightness"),
    ("scene unknown effect", lambda d: ["simulate", str(_toml(d, SCENE.format(b=0.5) + "[effects.glitter]\n")),
                                        "-o", str(d / "o.dat")], "glitter"),
    ("noise-check window zero", lambda d: ["noise-check", "--windows", "0,10"], "window"),
    ("workers zero", lambda d: ["reconstruct", "--workers", "0", "--exr-dir", str(d / "x")],
     "--workers must be at least 1"),
    ("bench unknown method", lambda d: ["bench", "--methods", "magic", "--out", str(d / "b")], "unknown methods magic"),
    ("bench output under a file", lambda d: ["bench", "--methods", "tfi", "--out", str(_toml(d, "x") / "b")],
     "cannot write there"),
    ("video in a missing folder", lambda d: ["reconstruct", "-o", str(d / "no" / "dir" / "o.mp4")],
     "the folder {d}/no/dir does not exist"),
    ("EXR folder two levels down", lambda d: ["reconstruct", "--exr-dir", str(d / "no" / "exr")],
     "the folder {d}/no does not exist"),
    ("denoise video in a missing folder", lambda d: ["denoise", "-o", str(d / "no" / "o.mp4")], "does not exist"),
    ("baseline EXR two levels down", lambda d: ["baseline", "tfp", "--exr-dir", str(d / "no" / "exr")],
     "does not exist"),
    ("noise-check plot in a missing folder", lambda d: ["noise-check", "--plot", str(d / "no" / "p.png")],
     "does not exist"),
    ("simulate into a missing folder", lambda d: ["simulate", str(_toml(d, SCENE.format(b=0.5))),
                                                  "-o", str(d / "no" / "o.dat")], "does not exist"),
]


@pytest.mark.parametrize("case", CLI_CASES, ids=[c[0] for c in CLI_CASES])
def test_cli_bad_input_fails_cleanly(tmp_path, capsys, case):
    _, argv, message = case
    args = argv(tmp_path)
    before = {p for p in tmp_path.rglob("*")}
    assert main(args) == 2
    err = capsys.readouterr().err
    message = message.replace("{d}", str(tmp_path))
    assert "error:" in err and message in err, err
    assert len(err.strip().splitlines()) == 1 or "compiling kernels" in err, err
    after = {p for p in tmp_path.rglob("*")}
    left = sorted(str(p.relative_to(tmp_path)) for p in after - before)
    assert left == [], f"partial output left behind: {left}"


def test_an_output_folder_is_made_one_level_deep_and_never_its_missing_parents(tmp_path, capsys, monkeypatch):
    """The rule of the CLI's outputs: the folder an option names (``--exr-dir``) is made inside a folder that exists;
    a missing parent — of a video, or of that folder — is refused in one line, with nothing made (the defect:
    ``-o /nonexistent/dir/out.mp4`` made ``/nonexistent/dir`` and exited 0)."""
    monkeypatch.chdir(tmp_path)
    assert main(["reconstruct", "--frames", "3:4", "-o", "no/dir/out.mp4"]) == 2
    assert "the folder" in capsys.readouterr().err and not (tmp_path / "no").exists()
    assert main(["reconstruct", "--frames", "3:4", "--exr-dir", "exr"]) == 0
    assert sorted(p.name for p in (tmp_path / "exr").iterdir())[-1] == "spikeref_run.json"


def _api_cases():
    import spikeref as sr
    from spikeref.align import align
    from spikeref.denoise.unet import UNet, UNetSpec
    from spikeref.io.exr import write_exr
    from spikeref.io.video import write_png
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.warp import warp_average

    den = sr.Denoiser(UNet.random(UNetSpec(width=8), seed=0))
    nan_planes = np.zeros((4, 32, 32), np.float32)
    nan_planes[0, 3, 3] = np.nan
    return [
        ("spikes complex", lambda d: sr.accumulate(GOOD.astype(np.complex64), 10), TypeError, "uint8 0/1"),
        ("spikes float 0.5", lambda d: sr.accumulate(GOOD * 0.5, 10), ValueError, "only 0 and 1"),
        ("spikes value 2", lambda d: sr.accumulate(GOOD * 2, 10), ValueError, "only 0 and 1"),
        ("spikes 2-D", lambda d: sr.accumulate(GOOD[0], 1), ValueError, "shape (T, H, W)"),
        ("window 0", lambda d: sr.accumulate(GOOD, 0), ValueError, "window must be at least 1 plane"),
        ("window longer than the stream", lambda d: sr.accumulate(GOOD, 41), ValueError, "41"),
        ("odd width for Bayer planes", lambda d: sr.bayer_planes(np.zeros((4, 5)), "RGGB"), ValueError, "even"),
        ("unknown CFA", lambda d: sr.demosaic_bilinear(np.zeros((4, 4)), "RGBG"), ValueError, "cfa must be one of"),
        ("TFI times unsorted", lambda d: sr.tfi(GOOD, times=[5, 3]), ValueError, "sorted"),
        ("TFI time outside", lambda d: sr.tfi(GOOD, times=[40]), ValueError, "must lie in [0, 40)"),
        ("write_dat 2-D", lambda d: sr.write_dat(d / "o.dat", GOOD[0]), ValueError, "shape (T, H, W)"),
        ("write_dat values", lambda d: sr.write_dat(d / "o.dat", GOOD * 3), ValueError, "only 0 and 1"),
        ("read truncated .dat", lambda d: sr.read_dat(_dat(d, 77), height=8, width=8), ValueError,
         "in.dat: size 77 bytes"),
        ("write_exr 4 channels", lambda d: write_exr(d / "o.exr", np.zeros((4, 4, 4))), ValueError,
         "(H, W, 3) or (H, W)"),
        ("write_png float NaN", lambda d: write_png(d / "o.png", np.full((4, 4, 3), np.nan)), (ValueError, TypeError),
         "uint8"),
        ("denoise NaN", lambda d: den(nan_planes, "visible"), ValueError, "finite"),
        ("denoise integer planes", lambda d: den(np.zeros((4, 32, 32), np.int32), "visible"), TypeError,
         "floating point"),
        ("denoise unknown mode", lambda d: den(np.zeros((4, 32, 32), np.float32), "sharp"), ValueError,
         "mode must be one of"),
        ("weights wrong format", lambda d: sr.Denoiser.load(_toml(d, "x")), ValueError, "not a weights .npz"),
        ("align shape mismatch", lambda d: align(np.zeros((64, 64)), np.zeros((64, 72))), ValueError, "same shape"),
        ("align smaller than a tile", lambda d: align(np.zeros((16, 16)), np.zeros((16, 16))), ValueError, "at least"),
        ("warp flows shape", lambda d: warp_average(np.zeros((3, 4, 8, 8)), np.zeros((3, 2, 8, 9))), ValueError,
         "flows"),
        ("K = 0", lambda d: ReconstructParams(K=0), ValueError, "K must be an integer ≥ 1"),
        ("unknown mode", lambda d: ReconstructParams(mode="sharp"), ValueError, "mode must be one of"),
        ("reconstruct a list", lambda d: Reconstructor([GOOD]), TypeError, "stream must be a SpikeStream"),
        ("psnr shapes", lambda d: sr.psnr(np.zeros((4, 4)), np.zeros((4, 5)), 1.0), ValueError, "same shape"),
        ("ssim too small", lambda d: sr.ssim(np.zeros((8, 8)), np.zeros((8, 8)), 1.0), ValueError, "11×11"),
        ("stream slice outside", lambda d: sr.SpikeStream.from_array(GOOD).slice(10, 50), ValueError,
         "outside the stream"),
        ("scene negative size", lambda d: sr.load_scene(_toml(d, SCENE.format(b=0.5).replace("height = 8",
                                                                                             "height = -8"))),
         ValueError, "height"),
    ]


API_CASES = _api_cases()


@pytest.mark.parametrize("case", API_CASES, ids=[c[0] for c in API_CASES])
def test_api_bad_input_fails_cleanly(tmp_path, case):
    _, call, exc, message = case
    with pytest.raises(exc) as info:
        call(tmp_path)
    assert message in str(info.value), str(info.value)
    outputs = [p.name for p in tmp_path.rglob("*") if p.is_file() and p.suffix not in (".toml",) and p.name != "in.dat"]
    assert outputs == [], f"partial output left behind: {outputs}"


def test_at_least_thirty_distinct_bad_inputs():
    assert len({c[0] for c in CLI_CASES}) + len({c[0] for c in API_CASES}) >= 30
    assert SAMPLE.is_file()  # the CLI cases without a file use the embedded sample
