"""Fault injection: bad arguments, full disks, unwritable folders and signals leave no trace.

Four promises of the command line (docs/faults.md), each driven here the way it fails in use:

* A refused command (bad argument or input) exits 2 with one line on stderr, no traceback,
  nothing on stdout, and leaves the disk as it found it: no output file, no temporary file and
  no empty folder. Every case runs in an empty working folder (the default outputs land there)
  and compares the folder's whole tree before and after.
* Zero is a value, never "not given": ``--width 0`` is refused, it does not fall back to 400.
* An OS error while writing (a full disk, an unwritable or read-only folder, a vanished file)
  ends in one line naming the path, the frames written and ``--resume``, exit 1; ``--resume``
  then completes the run bit for bit. Faults are injected by monkeypatching the EXR writer.
* SIGINT and SIGTERM sent to a real ``spikeref reconstruct`` process: exit 130, one line with
  the frames written and the exact command that resumes, frames on disk whole.
"""

from __future__ import annotations

import errno
import os
import json
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import spikeref.render as render
from spikeref.cli import SAMPLE, CliError, main
from spikeref.io.atomic import atomic_write
from spikeref.io.exr import read_exr
from spikeref.render import exr_name
from spikeref.sample import SAMPLE_SCENE

#: fast reconstruction settings for the runs that write frames (about 0.5 s per frame on 2 cores)
FAST = ["-L", "1", "--guard", "off"]
#: the frames of the reference run (the embedded sample has frames 1:25 at L = 1)
REF_FRAMES = range(3, 9)


# ----------------------------------------------------------------------------- inputs the cases make
def _dat(d: Path, name: str = "in.dat") -> Path:
    """A 40-plane 8×8 ``.dat`` without a sidecar (so --height/--width are needed)."""
    from spikeref.io.dat import write_dat

    path = d / name
    write_dat(path, (np.random.default_rng(0).random((40, 8, 8)) < 0.3).astype(np.uint8))
    return path


def _file(d: Path, name: str = "a_file", text: str = "not a folder") -> Path:
    path = d / name
    path.write_text(text)
    return path


def _junk_weights(d: Path) -> Path:
    path = d / "junk.npz"
    path.write_bytes(b"PK\x03\x04 this is not a weights file")
    return path


S = str
SCENE = S(SAMPLE_SCENE)

# (id, argv builder: folder → argv, text the one line must hold). Every case is refused (exit 2).
BAD = [
    # ---- the top level
    ("unknown command", lambda d: ["transmogrify"], "invalid choice: 'transmogrify'"),
    # ---- info
    ("info: missing file", lambda d: ["info", S(d / "nope.dat")], "no such file"),
    ("info: --height 0", lambda d: ["info", "--height", "0"], "--height must be a positive"),
    ("info: --width -8", lambda d: ["info", S(_dat(d)), "--height", "8", "--width", "-8"],
     "--width must be a positive"),
    ("info: --file-width 0", lambda d: ["info", S(_dat(d)), "--height", "8", "--width", "8", "--file-width", "0"],
     "--file-width must be a positive"),
    ("info: --rate-hz 0", lambda d: ["info", "--rate-hz", "0"], "--rate-hz must be a finite number > 0"),
    ("info: --rate-hz nan", lambda d: ["info", "--rate-hz", "nan"], "--rate-hz must be a finite number > 0"),
    ("info: --height not a number", lambda d: ["info", "--height", "tall"], "invalid int value: 'tall'"),
    # ---- baseline
    ("baseline: -o out.xyz with --exr-dir", lambda d: ["baseline", "tfp", "-o", "out.xyz", "--exr-dir", "e"],
     "must end in .mp4 or .gif"),
    ("baseline: --fps 0", lambda d: ["baseline", "tfp", "-o", "v.mp4", "--exr-dir", "e", "--fps", "0"],
     "--fps must be a finite number > 0"),
    ("baseline: --fps inf", lambda d: ["baseline", "tfp", "-o", "v.mp4", "--fps", "inf"],
     "--fps must be a finite number > 0"),
    ("baseline: -W 0", lambda d: ["baseline", "tfp", "-o", "v.mp4", "--exr-dir", "e", "-W", "0"],
     "window must be a positive"),
    ("baseline: --every 0", lambda d: ["baseline", "tfi", "-o", "v.mp4", "--exr-dir", "e", "--every", "0"],
     "--every must be a positive"),
    ("baseline: video under a file", lambda d: ["baseline", "tfp", "-o", S(_file(d) / "v.mp4"), "--exr-dir", "e"],
     "is not a folder"),
    ("baseline: --exr-dir is a file", lambda d: ["baseline", "tfp", "-o", "v.mp4", "--exr-dir", S(_file(d))],
     "is not a folder"),
    ("baseline: -o is a folder", lambda d: ["baseline", "tfp", "-o", S(d), "--exr-dir", "e"],
     "must end in .mp4 or .gif"),
    ("baseline: unknown method", lambda d: ["baseline", "magic", "-o", "v.mp4"], "invalid choice: 'magic'"),
    ("baseline: the default EXR folder is a file", lambda d: [S(_file(d, "tfp_exr")) and "baseline", "tfp"],
     "--exr-dir tfp_exr: cannot write there (tfp_exr is not a folder)"),
    # ---- denoise
    ("denoise: -W 0", lambda d: ["denoise", "-W", "0", "--exr-dir", "e"], "window must be a positive"),
    ("denoise: --start -1", lambda d: ["denoise", "--start", "-1", "--exr-dir", "e"], "--start must be"),
    ("denoise: --start past the end", lambda d: ["denoise", "--start", "300", "--exr-dir", "e"],
     "--start 300: the stream has 264 planes"),
    ("denoise: window past the end", lambda d: ["denoise", "--start", "260", "--exr-dir", "e"],
     "no whole window"),
    ("denoise: --frames 0", lambda d: ["denoise", "--frames", "0", "--exr-dir", "e"], "--frames must be a positive"),
    ("denoise: --fps 0", lambda d: ["denoise", "-o", "v.mp4", "--exr-dir", "e", "--fps", "0"],
     "--fps must be a finite number > 0"),
    ("denoise: -o v.xyz", lambda d: ["denoise", "-o", "v.xyz", "--exr-dir", "e"], "must end in .mp4 or .gif"),
    ("denoise: the default EXR folder is a file", lambda d: [S(_file(d, "denoised_exr")) and "denoise"],
     "--exr-dir denoised_exr: cannot write there (denoised_exr is not a folder)"),
    ("denoise: missing weights", lambda d: ["denoise", "--weights", "w.npz", "--exr-dir", "e"], "w.npz"),
    ("denoise: --width 0", lambda d: ["denoise", "--width", "0", "--frames", "1", "--exr-dir", "e"],
     "--width must be a positive"),
    # ---- reconstruct (without -o/--exr-dir it would write reconstruction.mp4 and reconstruction_exr/)
    ("reconstruct: --preset turbo", lambda d: ["reconstruct", "--preset", "turbo", "--frames", "3:4"],
     "invalid choice: 'turbo' (choose from 'default', 'fast', 'fastest', 'paper')"),
    ("reconstruct: --paper with --preset fast", lambda d: ["reconstruct", "--paper", "--preset", "fast"],
     "--paper is --preset paper"),
    ("reconstruct: --profile with --workers", lambda d: ["reconstruct", "--profile", "--workers", "2"],
     "--profile times one process"),
    ("reconstruct: --fps 0", lambda d: ["reconstruct", "--fps", "0", "--frames", "3:4"],
     "--fps must be a finite number > 0"),
    ("reconstruct: -o out.xyz", lambda d: ["reconstruct", "-o", "out.xyz", "--exr-dir", "e", "--frames", "3:4"],
     "must end in .mp4 or .gif"),
    ("reconstruct: --width 0", lambda d: ["reconstruct", S(_dat(d)), "--height", "8", "--width", "0", "-L", "0"],
     "--width must be a positive"),
    ("reconstruct: --height 0", lambda d: ["reconstruct", "--height", "0", "--frames", "3:4"],
     "--height must be a positive"),
    ("reconstruct: --rate-hz -5", lambda d: ["reconstruct", "--rate-hz", "-5", "--frames", "3:4"],
     "--rate-hz must be a finite number > 0"),
    ("reconstruct: -W 0", lambda d: ["reconstruct", "-W", "0"], "-W/--window must be a whole number ≥ 1"),
    ("reconstruct: -K 2", lambda d: ["reconstruct", "-K", "2"], "K must be odd"),
    ("reconstruct: -L -1", lambda d: ["reconstruct", "-L", "-1"], "-L must be a whole number ≥ 0"),
    ("reconstruct: --frames 5:3", lambda d: ["reconstruct", "--frames", "5:3"], "--frames 5:3"),
    ("reconstruct: --frames 0:100", lambda d: ["reconstruct", "--frames", "0:100"], "this stream has frames 3:23"),
    ("reconstruct: --frames a:b", lambda d: ["reconstruct", "--frames", "a:b"], "integer frame numbers"),
    ("reconstruct: --resume without EXR folder", lambda d: ["reconstruct", "--resume", "-o", "v.mp4"],
     "--resume needs --exr-dir"),
    ("reconstruct: --exr-dir is a file", lambda d: ["reconstruct", "--exr-dir", S(_file(d)), "--frames", "3:4"],
     "is not a folder"),
    ("reconstruct: video folder under a file", lambda d: ["reconstruct", "-o", S(_file(d) / "x" / "v.mp4"),
                                                          "--exr-dir", "e", "--frames", "3:4"], "is not a folder"),
    ("reconstruct: corrupt weights", lambda d: ["reconstruct", "--weights", S(_junk_weights(d)), "--frames", "3:4"],
     "junk.npz"),
    ("reconstruct: --workers 0", lambda d: ["reconstruct", "--workers", "0", "--exr-dir", "e"],
     "--workers must be at least 1"),
    ("reconstruct: --chunk-frames 0", lambda d: ["reconstruct", "--workers", "1", "--chunk-frames", "0",
                                                 "--exr-dir", "e", "--frames", "3:4"],
     "--chunk-frames: chunk_frames must be a positive"),
    ("reconstruct: Dask and -o out.xyz", lambda d: ["reconstruct", "--workers", "1", "-o", "out.xyz",
                                                    "--frames", "3:4"], "must end in .mp4 or .gif"),
    ("reconstruct: Dask and --fps 0", lambda d: ["reconstruct", "--workers", "1", "-o", "v.mp4", "--fps", "0",
                                                 "--frames", "3:4"], "--fps must be a finite number > 0"),
    ("reconstruct: Dask and bad --frames", lambda d: ["reconstruct", "--workers", "1", "--exr-dir", "e",
                                                      "--frames", "0:100"],
     "--frames 0:100: this stream has frames 3:23"),
    ("reconstruct: --workers and --scheduler", lambda d: ["reconstruct", "--workers", "1", "--scheduler",
                                                          "tcp://127.0.0.1:1", "--exr-dir", "e"], "not both"),
    ("reconstruct: --profile on Dask", lambda d: ["reconstruct", "--profile", "--workers", "2", "--exr-dir", "e"],
     "--profile times one process"),
    ("reconstruct: unknown --flow-frames", lambda d: ["reconstruct", "--flow-frames", "raw"],
     "invalid choice: 'raw'"),
    ("reconstruct: -K not a number", lambda d: ["reconstruct", "-K", "three"], "invalid int value: 'three'"),
    # ---- bench (it would write spikeref-bench/)
    ("bench: --frames 0", lambda d: ["bench", "--frames", "0"], "frames must be"),
    ("bench: unknown method", lambda d: ["bench", "--methods", "magic"], "unknown methods magic"),
    ("bench: unknown scene", lambda d: ["bench", "--methods", "tfi", "--scenes", "moon"], "moon"),
    ("bench: --sheet-scene not run", lambda d: ["bench", "--methods", "tfi", "--scenes", "static",
                                                "--sheet-scene", "fan"], "--sheet-scene 'fan'"),
    ("bench: missing weights", lambda d: ["bench", "--methods", "ours", "--weights", "w.npz"], "w.npz"),
    ("bench: --seed -1", lambda d: ["bench", "--methods", "tfi", "--scenes", "static", "--frames", "1",
                                    "--seed", "-1"], "--seed must be"),
    ("bench: --out under a file", lambda d: ["bench", "--methods", "tfi", "--out", S(_file(d) / "b")],
     "is not a folder"),
    ("bench --ladder: --frames 0", lambda d: ["bench", "--ladder", "--frames", "0"], "--frames must be 1…8"),
    ("bench --ladder: -K 2", lambda d: ["bench", "--ladder", "-K", "2"], "odd K"),
    ("bench --ladder: missing weights", lambda d: ["bench", "--ladder", "--weights", "w.npz"], "w.npz"),
    ("bench --ladder: --quick", lambda d: ["bench", "--ladder", "--quick"], "does not apply to --ladder"),
    # ---- train (it would write w.npz and w.npz.ckpt)
    ("train: missing file", lambda d: ["train", "nope.dat", "-o", "w.npz"], "no such file"),
    ("train: --steps 0", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "8", "-o", "w.npz",
                                    "--steps", "0"], "--steps must be a positive"),
    ("train: --patch 100", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "8", "-o", "w.npz",
                                      "--patch", "100"], "--patch must be a multiple of 32"),
    ("train: window range", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "8", "-o", "w.npz",
                                       "--window-min", "10", "--window-max", "5"], "--window-max"),
    ("train: --lr -1", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "8", "-o", "w.npz",
                                  "--lr", "-1"], "--lr must be a finite number ≥ 0"),
    ("train: --batch 0", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "8", "-o", "w.npz",
                                    "--batch", "0"], "--batch must be a positive"),
    ("train: --stop-after 0", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "8", "-o", "w.npz",
                                         "--stop-after", "0"], "--stop-after must be a positive"),
    ("train: --checkpoint-every 0", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "8", "-o",
                                               "w.npz", "--checkpoint-every", "0"], "--checkpoint-every must be"),
    ("train: -o not .npz", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "8", "-o", "w.txt"],
     "must end in .npz"),
    ("train: --width 0", lambda d: ["train", S(_dat(d)), "--height", "8", "--width", "0", "-o", "w.npz"],
     "--width must be a positive"),
    # ---- simulate (it would write x.dat, x.json and the ground truth)
    ("simulate: missing scene", lambda d: ["simulate", "nope.toml", "-o", "x.dat"], "no such scene file"),
    ("simulate: -o x.npy", lambda d: ["simulate", SCENE, "-o", "new/x.npy"], "must be a .dat"),
    ("simulate: --gt not .npz", lambda d: ["simulate", SCENE, "-o", "x.dat", "--gt", "gt/g.txt"],
     "ground truth goes to a .npz file"),
    ("simulate: --planes 0", lambda d: ["simulate", SCENE, "-o", "x.dat", "--planes", "0"],
     "--planes must be a positive"),
    ("simulate: --gt-window 0", lambda d: ["simulate", SCENE, "-o", "x.dat", "--gt-exr", "g",
                                           "--gt-window", "0"], "--gt-window must be a positive"),
    ("simulate: --chunk-planes 0", lambda d: ["simulate", SCENE, "-o", "x.dat", "--chunk-planes", "0"],
     "--chunk-planes must be a positive"),
    ("simulate: --seed -1", lambda d: ["simulate", SCENE, "-o", "x.dat", "--seed", "-1"], "--seed must be"),
    ("simulate: bad effect value", lambda d: ["simulate", SCENE, "-o", "x.dat", "--effects",
                                              "dark_current:gamma=-1"], "dark_current.gamma"),
    ("simulate: -o under a file", lambda d: ["simulate", SCENE, "-o", S(_file(d) / "x.dat")], "is not a folder"),
    ("simulate: -o missing", lambda d: ["simulate", SCENE], "the following arguments are required: -o"),
    # ---- noise-check
    ("calibrate: -o not .npz", lambda d: ["calibrate", str(SAMPLE), "-o", "map.txt"], "must end in .npz"),
    ("calibrate: --planes 3", lambda d: ["calibrate", str(SAMPLE), "-o", "map.npz", "--planes", "3"],
     "--planes must be a number of readouts ≥ 8"),
    ("calibrate: -o in a missing folder", lambda d: ["calibrate", str(SAMPLE), "-o", "no/map.npz"], "does not exist"),
    ("reconstruct: --hot-pixels not a map", lambda d: ["reconstruct", "--hot-pixels", "on", "--exr-dir", "e"],
     "--hot-pixels must be auto, off or a map .npz"),
    ("noise-check: --windows 0", lambda d: ["noise-check", "--windows", "0,10"], "windows must be a positive"),
    ("noise-check: --windows abc", lambda d: ["noise-check", "--windows", "abc"], "comma-separated whole numbers"),
    ("noise-check: --start -1", lambda d: ["noise-check", "--start", "-1"], "--start must be"),
    ("noise-check: --planes 0", lambda d: ["noise-check", "--planes", "0"], "--planes must be a positive"),
    ("noise-check: --min-rate -1", lambda d: ["noise-check", "--min-rate", "-1"],
     "--min-rate must be a finite number ≥ 0"),
    ("noise-check: --plot not .png", lambda d: ["noise-check", "--plot", "fig.jpg"], "--plot must end in .png"),
    ("noise-check: --plot under a file", lambda d: ["noise-check", "--plot", S(_file(d) / "fig.png")],
     "is not a folder"),
    # ---- golden
    ("golden: unknown action", lambda d: ["golden", "verify", "x"], "invalid choice: 'verify'"),
    ("golden: check a missing folder", lambda d: ["golden", "check", S(d / "nope")], "no such folder"),
    ("golden: check an unknown case", lambda d: ["golden", "check", S(d), "--cases", "tfi,nope"],
     "unknown case nope"),
    ("golden: --golden without a manifest", lambda d: ["golden", "list", "--golden", S(d)], "no manifest.json there"),
    ("golden: export --format csv", lambda d: ["golden", "export", "x", "--format", "csv"], "invalid choice: 'csv'"),
    ("golden: export into a file", lambda d: ["golden", "export", S(_file(d))], "is not a folder"),
    ("golden: export under a file", lambda d: ["golden", "export", S(_file(d) / "x")], "is not a folder"),
]


def _tree(folder: Path) -> dict:
    """Every path under ``folder`` (folders included) with its size and modification time."""
    return {str(p.relative_to(folder)): (p.is_dir(), p.stat().st_size if p.is_file() else 0, p.stat().st_mtime_ns)
            for p in folder.rglob("*")}


def _run(argv, capsys) -> tuple[int, str, str]:
    """``main(argv)`` in this process: exit status, stdout, stderr (argparse exits through SystemExit)."""
    try:
        status = main(argv)
    except SystemExit as exc:
        status = exc.code
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.parametrize("case", BAD, ids=[c[0] for c in BAD])
def test_refused_command_leaves_no_trace(tmp_path, monkeypatch, capsys, case):
    _, build, message = case
    monkeypatch.chdir(tmp_path)
    argv = build(tmp_path)
    before = _tree(tmp_path)
    status, out, err = _run(argv, capsys)
    lines = err.splitlines()  # splits on "\r" too: a progress bar would show up as lines
    assert status == 2, err
    assert "Traceback" not in err
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}: {err!r}"
    assert lines[0].startswith("spikeref")
    assert message in lines[0], lines[0]
    assert out == ""
    assert _tree(tmp_path) == before, "a refused command changed the disk"


def test_the_suite_covers_every_command_with_forty_cases():
    from spikeref.cli import build_parser

    parser = build_parser()
    commands = set(next(a for a in parser._actions if a.dest == "command").choices)
    covered = {c[0].split(":")[0].split(" --")[0] for c in BAD}
    assert commands <= covered, f"commands without a bad-argument case: {sorted(commands - covered)}"
    assert len({c[0] for c in BAD}) == len(BAD) >= 40


@pytest.mark.parametrize("kwargs, error", [
    ({"video": "v.xyz", "exr_dir": "e"}, "must end in .mp4 or .gif"),
    ({"video": "sub/v.mp4", "exr_dir": "e", "fps": 0}, "fps must be positive"),
    ({"video": "v.mp4", "exr_dir": "e", "fps": float("nan")}, "fps must be positive"),
])
def test_frame_sink_checks_everything_before_making_folders(tmp_path, monkeypatch, kwargs, error):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match=error):
        render.FrameSink(**kwargs)
    assert list(tmp_path.iterdir()) == []


def test_render_baseline_every_zero_is_refused_not_the_window(tmp_path):
    from spikeref.sample import load_sample

    with pytest.raises(ValueError, match="every must be a positive"):
        render.render_baseline(load_sample(), "tfi", tmp_path / "v.mp4", exr_dir=tmp_path / "e", every=0)
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- writing faults
@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """An uninterrupted run of frames 3:9 (the frames every fault test compares with)."""
    ref = tmp_path_factory.mktemp("ref") / "exr"
    assert main(["reconstruct", "--exr-dir", str(ref), "--frames", f"{REF_FRAMES.start}:{REF_FRAMES.stop}",
                 *FAST]) == 0
    return ref


def _assert_frames_equal_reference(folder: Path, reference: Path, frames) -> None:
    for k in frames:
        a, b = read_exr(folder / exr_name(k)), read_exr(reference / exr_name(k))
        assert a.dtype == b.dtype == np.float32
        np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))  # bit for bit


def _only_whole_frames(folder: Path) -> list[str]:
    """The frames' names in ``folder``; asserts there is no temporary or hidden file beside the frames and
    the run record (``render.RUN_RECORD``), which is whole JSON."""
    names = sorted(p.name for p in folder.iterdir() if p.name != render.RUN_RECORD)
    assert all(re.fullmatch(r"frame_\d{6}\.exr", n) for n in names), f"partial or temporary files left: {names}"
    if (folder / render.RUN_RECORD).exists():
        assert isinstance(json.loads((folder / render.RUN_RECORD).read_text()), dict)
    return names


def _fail_at(monkeypatch, k: int, fail) -> None:
    """Make the ``k``-th EXR write of this process (0-based) call ``fail(path)`` instead of writing."""
    real = render.write_exr
    calls = []

    def write(path, frame, half=False):
        calls.append(path)
        if len(calls) == k + 1:
            return fail(path)
        return real(path, frame, half=half)

    monkeypatch.setattr(render, "write_exr", write)


def _full_disk(path):
    """What OpenEXR does on a full disk: some bytes reach the temporary file, then a RuntimeError."""
    def partial(tmp):
        Path(tmp).write_bytes(b"\x76\x2f\x31\x01" + bytes(4096))
        raise RuntimeError(f'Failed to write pixel data to image file "{tmp}". {os.strerror(errno.ENOSPC)}.')

    return atomic_write(path, partial)


def _lines(err: str) -> list[str]:
    """The lines of stderr, less spikeref's notes (``spikeref CMD: note: …``, say about alignment), which may come."""
    return [line for line in err.splitlines() if ": note: " not in line]


def _resume_command(line: str) -> list[str]:
    m = re.search(r"continue with: (spikeref .*)$", line)
    assert m, line
    argv = shlex.split(m.group(1))
    assert argv[:2] == ["spikeref", "reconstruct"] and "--resume" in argv
    return argv[1:]


def test_full_disk_at_frame_k_then_resume_is_bit_identical(tmp_path, monkeypatch, capsys, reference):
    out, video = tmp_path / "out", tmp_path / "v.mp4"
    _fail_at(monkeypatch, 2, _full_disk)  # frames 3, 4 are written, frame 5 finds the disk full
    argv = ["reconstruct", "-o", str(video), "--exr-dir", str(out), "--frames", "3:7", *FAST]
    status, _, err = _run(argv, capsys)
    assert status == 1, err
    assert "Traceback" not in err
    lines = _lines(err)
    assert len(lines) == 2 and lines[0].startswith("sample.dat: 264 planes"), err  # the header, then one line
    line = lines[1]
    assert line.startswith("spikeref reconstruct: error: ") and str(out / exr_name(5)) in line, line
    assert os.strerror(errno.ENOSPC) in line and "2 of 4 frames" in line and "once there is space" in line, line
    assert _only_whole_frames(out) == [exr_name(3), exr_name(4)]  # no temporary file, no partial frame 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no video, no partial video
    monkeypatch.undo()
    resume = _resume_command(line)
    assert resume == [*argv, "--resume"]
    status, _, err = _run(resume, capsys)
    assert status == 0, err
    assert "2 already written" in err
    assert _only_whole_frames(out) == [exr_name(k) for k in range(3, 7)]
    _assert_frames_equal_reference(out, reference, range(3, 7))
    assert video.stat().st_size > 1000


@pytest.mark.parametrize("code, hint", [
    (errno.EACCES, "once the folder is writable"),
    (errno.EROFS, "once the folder is writable"),
    (errno.ENOENT, "then continue"),
    (errno.EIO, "then continue"),
])
def test_os_error_while_writing_is_one_line(tmp_path, monkeypatch, capsys, code, hint):
    out = tmp_path / "out"

    def fail(path):
        raise OSError(code, os.strerror(code), str(path))

    _fail_at(monkeypatch, 1, fail)
    status, _, err = _run(["reconstruct", "--exr-dir", str(out), "--frames", "3:5", *FAST], capsys)
    assert status == 1 and "Traceback" not in err, err
    line = _lines(err)[-1]
    assert len(_lines(err)) == 2, err
    assert f"{out / exr_name(4)}: {os.strerror(code)}" in line and "1 of 2 frames" in line and hint in line, line
    assert _resume_command(line)[-1] == "--resume"
    assert _only_whole_frames(out) == [exr_name(3)]


def test_real_openexr_full_disk_error_becomes_enospc(tmp_path):
    """OpenEXR reports a full disk as RuntimeError text; the atomic writer turns it into OSError(ENOSPC)."""
    with pytest.raises(OSError) as info:
        _full_disk(tmp_path / "f.exr")
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(tmp_path / "f.exr")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(RuntimeError, match="something else"):  # other errors pass unchanged
        atomic_write(tmp_path / "g.exr", lambda tmp: (_ for _ in ()).throw(RuntimeError("something else")))
    assert list(tmp_path.iterdir()) == []


def test_output_folder_vanishing_mid_run(tmp_path, monkeypatch, capsys):
    """The EXR folder is deleted while the run goes on (a cleanup job, an unmounted share)."""
    import shutil

    out = tmp_path / "out"
    real = render.write_exr

    def vanish(path):
        shutil.rmtree(out)
        return real(path, np.zeros((4, 4, 3), np.float32))

    _fail_at(monkeypatch, 1, vanish)
    status, _, err = _run(["reconstruct", "--exr-dir", str(out), "--frames", "3:5", *FAST], capsys)
    assert status == 1 and "Traceback" not in err, err
    line = _lines(err)[-1]
    assert str(out) in line and "0 of 2 frames" in line and "--resume" in line, line
    assert not out.exists()


def test_a_vanished_input_frame_when_resuming(tmp_path, monkeypatch, capsys, reference):
    """--resume reads the frames on disk back for the video; one disappears between the check and the read."""
    out = tmp_path / "out"
    out.mkdir()
    for k in (3, 4):
        (out / exr_name(k)).write_bytes((reference / exr_name(k)).read_bytes())
    real = render.frames_on_disk

    def then_vanish(*a, **kw):
        found = real(*a, **kw)
        (out / exr_name(4)).unlink()
        return found

    monkeypatch.setattr(render, "frames_on_disk", then_vanish)
    argv = ["reconstruct", "-o", str(tmp_path / "v.mp4"), "--exr-dir", str(out), "--frames", "3:6", "--resume", *FAST]
    status, _, err = _run(argv, capsys)
    assert status == 1 and "Traceback" not in err, err
    line = _lines(err)[-1]
    assert str(out / exr_name(4)) in line and "--resume" in line, line
    assert not (tmp_path / "v.mp4").exists()
    monkeypatch.undo()
    assert main(_resume_command(line)) == 0
    _assert_frames_equal_reference(out, reference, range(3, 6))


def test_a_failed_dask_chunk_is_one_line_with_the_resume_command(tmp_path, monkeypatch, capsys):
    """A chunk fails on a worker (its input vanished): exit 1, one line, a resume command that names the folder."""
    import spikeref.distributed as distributed
    from spikeref.cli import build_parser

    def fail(*a, **kw):
        raise distributed.ChunkError("chunk 0 (frames 3:4, planes 20:50) failed on a worker: FileNotFoundError: "
                                     "[Errno 2] No such file or directory: 'rec.dat'")

    monkeypatch.setattr(distributed, "reconstruct_distributed", fail)
    video = tmp_path / "v.mp4"
    status, _, err = _run(["reconstruct", "--workers", "1", "-o", str(video), "--frames", "3:4"], capsys)
    assert status == 1 and "Traceback" not in err, err
    assert len(_lines(err)) == 2, err  # the header, then one line
    line = _lines(err)[-1]
    assert "chunk 0" in line and "0 of 1 frames" in line, line
    resume = build_parser().parse_args(_resume_command(line))
    assert resume.resume and resume.exr_dir == tmp_path / "v_exr" and resume.output == video  # -o alone: named


def test_interrupt_in_process_keeps_whole_frames(tmp_path, monkeypatch, capsys, reference):
    """A KeyboardInterrupt inside the EXR write (the worst moment): no temporary file, exit 130."""
    out = tmp_path / "out"

    def interrupted(path):
        def partial(tmp):
            Path(tmp).write_bytes(b"half a frame")
            raise KeyboardInterrupt

        return atomic_write(path, partial)

    _fail_at(monkeypatch, 1, interrupted)
    status, _, err = _run(["reconstruct", "--exr-dir", str(out), "--frames", "3:6", *FAST], capsys)
    assert status == 130 and "Traceback" not in err, err
    line = _lines(err)[-1]
    assert line.startswith("spikeref reconstruct: interrupted (SIGINT)") and "1 of 3 frames" in line, line
    assert _only_whole_frames(out) == [exr_name(3)]
    monkeypatch.undo()
    assert main(_resume_command(line)) == 0
    _assert_frames_equal_reference(out, reference, range(3, 6))


def test_debug_shows_the_traceback(tmp_path, monkeypatch, capsys):
    def fail(path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    _fail_at(monkeypatch, 0, fail)
    with pytest.raises(CliError) as info:
        main(["reconstruct", "--debug", "--exr-dir", str(tmp_path / "o"), "--frames", "3:4", *FAST])
    assert isinstance(info.value.__cause__, OSError) and info.value.__cause__.errno == errno.ENOSPC
    monkeypatch.setenv("SPIKEREF_DEBUG", "1")
    (tmp_path / "text.npz").write_text("not spikes")
    with pytest.raises(ValueError, match="not a readable .npz spike file"):
        main(["reconstruct", str(tmp_path / "text.npz")])


# ----------------------------------------------------------------------------- signals to a real process
def _spikeref() -> list[str]:
    return [sys.executable, "-m", "spikeref.cli"]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_during_reconstruct_then_resume(tmp_path, sig, reference):
    out = tmp_path / "out"
    frames = f"{REF_FRAMES.start}:{REF_FRAMES.stop}"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("SPIKEREF_DEBUG", None)
    for _attempt in range(3):
        # On a loaded machine the test can be descheduled between seeing the first frame and sending the
        # signal long enough for the run to finish all six frames: then the signal came too late, try again.
        shutil.rmtree(out, ignore_errors=True)
        # A shell starts a background job with SIGINT ignored and the child would inherit that (Python then
        # installs no KeyboardInterrupt handler): the run gets SIGINT's default disposition, as from a terminal.
        proc = subprocess.Popen([*_spikeref(), "reconstruct", "--exr-dir", str(out), "--frames", frames, *FAST],
                                cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        try:
            deadline = time.monotonic() + 120
            while not list(out.glob("frame_*.exr")):
                assert proc.poll() is None, f"the run ended before a signal could be sent: {proc.communicate()}"
                assert time.monotonic() < deadline, "no frame was written in 120 s"
                time.sleep(0.02)
            proc.send_signal(sig)
            _, err = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
        if not (proc.returncode == 0 and len(_only_whole_frames(out)) == len(REF_FRAMES)):
            break
    name = signal.Signals(sig).name
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    lines = _lines(err)
    assert len(lines) == 2 and lines[0].startswith("sample.dat: 264 planes"), err  # the header, then one line
    line = lines[1]
    m = re.fullmatch(rf"spikeref reconstruct: interrupted \({name}\) with (\d+) of 6 frames written to (.+); "
                     r"continue with: (spikeref .*)", line)
    assert m, line
    written = int(m.group(1))
    names = _only_whole_frames(out)
    assert 1 <= written == len(names) <= 6
    _assert_frames_equal_reference(out, reference, [int(n[6:12]) for n in names])
    assert main(_resume_command(line)) == 0
    assert _only_whole_frames(out) == [exr_name(k) for k in REF_FRAMES]
    _assert_frames_equal_reference(out, reference, REF_FRAMES)


def test_run_record_names_what_differs(tmp_path):
    """The EXR folder's record: nested settings compared by name, a missing key differs, an unreadable record
    differs in everything, no record differs in nothing."""
    record = {"params": {"window": 10, "align_params": {"tile_by_step": (32, 16, 8)}}, "denoiser": {"guard": "sure"}}
    assert render.run_record_differences(tmp_path, record) == [] and render.read_run_record(tmp_path) is None
    render.write_run_record(tmp_path / "exr", record)
    assert render.read_run_record(tmp_path / "exr") == json.loads(json.dumps(record))  # tuples come back as lists
    assert render.run_record_differences(tmp_path / "exr", record) == []
    other = {"params": {"window": 20, "align_params": {"tile_by_step": (16, 16, 8)}}}
    assert render.run_record_differences(tmp_path / "exr", other) == [
        "denoiser", "params.align_params.tile_by_step", "params.window"]
    (tmp_path / "exr" / render.RUN_RECORD).write_text("{not json")
    assert render.run_record_differences(tmp_path / "exr", record) == ["denoiser", "params"]
