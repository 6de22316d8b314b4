import json

import numpy as np
import pytest

from spikeref.cli import main
from spikeref.io.dat import write_dat
from spikeref.io.exr import read_exr


def test_info_on_the_embedded_sample(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "planes      400" in out and "128 × 160" in out and "RGGB" in out
    assert "plane 3 at (1,1)     B" in out


def test_info_reads_a_sidecar_and_reports_rates(tmp_path, capsys):
    spikes = np.zeros((20, 4, 8), np.uint8)
    spikes[:, 0::2, 0::2] = 1  # every R pixel fires at every readout
    write_dat(tmp_path / "r.dat", spikes)
    (tmp_path / "r.json").write_text(json.dumps({"height": 4, "width": 8, "cfa": "RGGB"}))
    assert main(["info", str(tmp_path / "r.dat")]) == 0
    out = capsys.readouterr().out
    assert "R: 1.00000" in out and "B: 0.00000" in out and "mean rate   0.25000" in out


def test_baseline_tfp_writes_video_and_exr(tmp_path):
    assert main(["baseline", "tfp", "-o", str(tmp_path / "v.mp4"), "--exr-dir", str(tmp_path / "exr"), "-W", "20"]) == 0
    assert (tmp_path / "v.mp4").stat().st_size > 1000
    names = sorted(p.name for p in (tmp_path / "exr").iterdir())
    assert len(names) == 20 and names[0] == "frame_000000.exr"
    frame = read_exr(tmp_path / "exr" / names[0])
    assert frame.shape == (128, 160, 3) and np.isfinite(frame).all() and 0 <= frame.min() <= frame.max() <= 1


@pytest.mark.parametrize(
    "argv, message",
    [
        (["info", "nope.dat"], "no such file"),
        (["baseline", "tfp", "-o", "out.avi"], "must end in .mp4 or .gif"),
        (["baseline", "tfp", "-o", "v.mp4", "-W", "0"], "window must be a positive"),
        (["baseline", "tfp", "-o", "v.mp4", "-W", "100000"], "longer than the stream"),
        (["info", "--cfa", "RGB"], "cfa must be one of"),
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
