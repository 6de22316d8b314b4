"""docs/inputs.md: each toolkit layout of its table, written here with plain NumPy (the bit packing spelled out,
not spikeref's writer), read with the options the table names, upright and in the right CFA phase."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from spikeref.accumulate import window_counts
from spikeref.bayer import bayer_planes
from spikeref.cli import build_parser, open_input
from spikeref.io.dat import write_dat

INPUTS_MD = Path(__file__).resolve().parents[1] / "docs" / "inputs.md"
#: The channel rates (spikes per readout) of the mosaics below: each 2×2 phase tells its colour by its rate.
RATES = {"R": 0.40, "G": 0.22, "B": 0.08}


def _if_spikes(rate_map: np.ndarray, planes: int, seed: int = 0) -> np.ndarray:
    """Integrate-and-fire spikes ``(T, H, W)`` of a static ``rate_map`` (spikes per readout), random phase."""
    phase = np.random.default_rng(seed).random(rate_map.shape)
    level = np.floor(rate_map[None] * np.arange(planes + 1)[:, None, None] + phase[None])
    return np.diff(level, axis=0).astype(np.uint8)


def _upright(height: int, width: int, planes: int, cfa: str | None = None, seed: int = 0) -> np.ndarray:
    """Upright spikes of a scene that tells top from bottom (a vertical ramp of rates) and, with a CFA, each
    2×2 phase's colour by its rate (:data:`RATES`)."""
    ramp = np.linspace(0.05, 0.45, height)[:, None] * np.ones((1, width))
    if cfa is None:
        return _if_spikes(ramp, planes, seed)
    cell = np.array([[RATES[cfa[0]], RATES[cfa[1]]], [RATES[cfa[2]], RATES[cfa[3]]]])
    mosaic = np.tile(cell, (height // 2, width // 2)) * (0.75 + 0.25 * ramp / ramp.max())
    return _if_spikes(mosaic, planes, seed)


def _dat_bytes(upright: np.ndarray, rows: str, file_width: int | None = None, pad: int = 1) -> bytes:
    """A headerless ``.dat``: each plane's rows in the stored order (``"bottom-up"``: the last image row first),
    ``file_width``-wide stored rows (the extra columns right of the image filled with ``pad``), pixel ``p`` of a
    plane at bit ``p % 8`` of byte ``p // 8``."""
    t, h, w = upright.shape
    stored = upright[:, ::-1, :] if rows == "bottom-up" else upright
    if file_width is not None and file_width > w:
        extra = np.full((t, h, file_width - w), pad, np.uint8)
        stored = np.concatenate([stored, extra], axis=2)
    bits = stored.reshape(-1, 8).astype(np.uint16)
    weights = 1 << np.arange(8, dtype=np.uint16)  # bit k of a byte is the k-th pixel of its group of 8
    return (bits * weights).sum(axis=1).astype(np.uint8).tobytes()


def _open(path: Path, *options: str):
    """The stream ``spikeref info PATH OPTIONS`` reads (the command line's own parser and opener)."""
    return open_input(build_parser().parse_args(["info", str(path), *options]))


def _phase_colours(stream) -> str:
    """The colour of each 2×2 phase (0,0), (0,1), (1,0), (1,1) of the stream as read, told by its rate."""
    rates = bayer_planes(window_counts(stream, len(stream))[0] / len(stream)).mean(axis=(-1, -2))
    names = np.array(list(RATES))
    return "".join(names[np.argmin(np.abs(np.array(list(RATES.values()))[None] - rates[:, None]), axis=1)])


def _check_upright(stream, upright: np.ndarray) -> None:
    np.testing.assert_array_equal(stream.window(0, len(stream)), upright)


# ------------------------------------------------------------------------------ one test per table row
#: The options each row of docs/inputs.md's table names (first cell → options), as its test passes them.
OPTIONS = {
    "SpikeCV `.dat`": [],
    "Spike-Zoo `.dat`": ["--height", "64", "--width", "96"],
    "Spike-Zoo `.npz`": [],
    "SSL-CSC `.dat` (simulated colour clips)": ["--rows", "top-down", "--cfa", "RGGB",
                                                "--height", "40", "--width", "64"],
    "SpikeCV 1000×1000 Bayer clips": ["--height", "1000", "--width", "1000", "--cfa", "BGGR"],
    "1024-wide stored rows (1000×1000 image)": ["--height", "1000", "--width", "1000", "--file-width", "1024"],
    "416-wide stored rows with a 16-pixel head (250×400 image)": ["--width", "400", "--file-width", "416"],
    "SpikingSIM `.npz`": ["--axes", "HWT"],
    "spikeref's own files": [],
}


def test_spikecv_dat(tmp_path):
    upright = _upright(250, 400, 24)
    (tmp_path / "rec.dat").write_bytes(_dat_bytes(upright, "bottom-up"))
    stream = _open(tmp_path / "rec.dat", *OPTIONS["SpikeCV `.dat`"])  # the defaults: 250×400, bottom-up
    _check_upright(stream, upright)
    assert stream.rows == "bottom-up" and stream.cfa is None


def test_spikezoo_dat(tmp_path):
    upright = _upright(64, 96, 24, seed=1)  # another size than the defaults
    (tmp_path / "rec.dat").write_bytes(_dat_bytes(upright, "bottom-up"))
    _check_upright(_open(tmp_path / "rec.dat", *OPTIONS["Spike-Zoo `.dat`"]), upright)


def test_spikezoo_npz(tmp_path):
    upright = _upright(32, 48, 40, seed=2)
    np.savez(tmp_path / "uhsr.npz", spk=upright, label=np.int64(3))
    stream = _open(tmp_path / "uhsr.npz", *OPTIONS["Spike-Zoo `.npz`"])
    _check_upright(stream, upright)
    assert stream.shape == (40, 32, 48)


def test_sslcsc_dat(tmp_path):
    upright = _upright(40, 64, 200, cfa="RGGB", seed=3)
    (tmp_path / "clip.dat").write_bytes(_dat_bytes(upright, "top-down"))
    options = OPTIONS["SSL-CSC `.dat` (simulated colour clips)"]
    stream = _open(tmp_path / "clip.dat", *options)
    _check_upright(stream, upright)
    assert stream.rows == "top-down" and _phase_colours(stream) == "RGGB" == stream.cfa
    wrong = _open(tmp_path / "clip.dat", *options[2:])  # without --rows top-down: upside down, the mosaic GBRG
    _check_upright(wrong, upright[:, ::-1])
    assert _phase_colours(wrong) == "GBRG"


def test_spikecv_bayer_1000(tmp_path):
    upright = _upright(1000, 1000, 16, cfa="BGGR", seed=4)
    (tmp_path / "water.dat").write_bytes(_dat_bytes(upright, "bottom-up"))
    stream = _open(tmp_path / "water.dat", *OPTIONS["SpikeCV 1000×1000 Bayer clips"])
    _check_upright(stream, upright)
    assert _phase_colours(stream) == "BGGR" == stream.cfa
    assert _phase_colours(_open(tmp_path / "water.dat", "--height", "1000", "--width", "1000",
                                "--rows", "top-down")) == "GRBG"  # the wrong order swaps the phase


def test_rows_1024_wide(tmp_path):
    upright = _upright(1000, 1000, 16, cfa="RGGB", seed=5)
    (tmp_path / "wide.dat").write_bytes(_dat_bytes(upright, "bottom-up", file_width=1024))
    stream = _open(tmp_path / "wide.dat", *OPTIONS["1024-wide stored rows (1000×1000 image)"], "--cfa", "RGGB")
    _check_upright(stream, upright)  # the 24 extra columns (a spike at every readout) are dropped
    assert stream.file_width == 1024 and _phase_colours(stream) == "RGGB"
    assert int(window_counts(stream, 16)[0].max()) < 16


def test_rows_416_wide_with_head(tmp_path):
    upright = _upright(250, 400, 16, seed=6)
    (tmp_path / "head.dat").write_bytes(_dat_bytes(upright, "bottom-up", file_width=416))
    stream = _open(tmp_path / "head.dat", *OPTIONS["416-wide stored rows with a 16-pixel head (250×400 image)"])
    _check_upright(stream, upright)


def test_spikingsim_npz(tmp_path):
    upright = _upright(50, 80, 120, seed=7)
    np.savez(tmp_path / "real_spike.npz", np.ascontiguousarray(np.moveaxis(upright, 0, -1)))  # arr_0, (H, W, T)
    stream = _open(tmp_path / "real_spike.npz", *OPTIONS["SpikingSIM `.npz`"])
    _check_upright(stream, upright)
    assert stream.shape == (120, 50, 80)


def test_spikeref_files(tmp_path):
    upright = _upright(24, 32, 60, cfa="GRBG", seed=8)
    write_dat(tmp_path / "sim.dat", upright)
    assert (tmp_path / "sim.dat").read_bytes() == _dat_bytes(upright, "bottom-up")
    (tmp_path / "sim.json").write_text(json.dumps({"height": 24, "width": 32, "cfa": "GRBG", "rate_hz": 20000.0}))
    stream = _open(tmp_path / "sim.dat", *OPTIONS["spikeref's own files"])
    _check_upright(stream, upright)
    assert stream.cfa == "GRBG" == _phase_colours(stream)
    write_dat(tmp_path / "td.dat", upright, rows="top-down")
    assert (tmp_path / "td.dat").read_bytes() == _dat_bytes(upright, "top-down")
    (tmp_path / "td.json").write_text(json.dumps({"height": 24, "width": 32, "cfa": "GRBG", "rows": "top-down"}))
    _check_upright(_open(tmp_path / "td.dat"), upright)
    np.savez(tmp_path / "saved.npz", spikes=upright, spk=upright[:1])  # "spikes" comes before Spike-Zoo's "spk"
    _check_upright(_open(tmp_path / "saved.npz"), upright)


def _table_rows() -> list[list[str]]:
    lines = INPUTS_MD.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| layout |"))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in re.split(r"(?<!\\)\|", line.strip())[1:-1]])
    return rows


def test_every_row_of_the_table_has_its_test_and_names_the_options_it_uses():
    """The table's rows are OPTIONS's, in order, and each names every option its test passes (with its value,
    except a size, which the table may write H and W)."""
    rows = _table_rows()
    assert [r[0] for r in rows] == list(OPTIONS)
    for name, _, documented, _ in rows:
        options = OPTIONS[name]
        for flag, value in zip(options[::2], options[1::2], strict=True):
            size = flag in ("--height", "--width") and re.search(rf"{flag} (H|W)\b", documented)
            assert f"{flag} {value}" in documented or size, f"{name}: docs/inputs.md does not name {flag} {value}"
        if not options:
            assert documented.startswith("none"), f"{name}: the test passes no option, the table names some"


def test_the_sample_data_of_the_table_reads_as_documented(real_data):
    """The real files of two rows: Spike-Zoo's UHSR ``.npz`` (key spk, planes first) and SpikingSIM's (planes
    last, --axes HWT)."""
    uhsr = _open(real_data / "spikezoo_uhsr.npz")
    assert uhsr.shape == (200, 250, 250)
    sim = _open(real_data / "spikingsim_real_spike.npz", "--axes", "HWT")
    assert sim.shape == (500, 250, 400)
    with np.load(real_data / "spikingsim_real_spike.npz") as data:
        np.testing.assert_array_equal(sim.window(7, 1)[0], data["arr_0"][:, :, 7])


@pytest.mark.parametrize("cfa, flipped", [("RGGB", "GBRG"), ("BGGR", "GRBG"), ("GRBG", "BGGR"), ("GBRG", "RGGB")])
def test_reading_the_other_row_order_gives_the_flipped_phase(tmp_path, cfa, flipped):
    """docs/inputs.md, "Why it matters for colour": each pattern and the one the other row order reads."""
    upright = _upright(8, 16, 200, cfa=cfa, seed=9)
    (tmp_path / "x.dat").write_bytes(_dat_bytes(upright, "top-down"))
    assert _phase_colours(_open(tmp_path / "x.dat", "--height", "8", "--width", "16", "--rows", "top-down")) == cfa
    assert _phase_colours(_open(tmp_path / "x.dat", "--height", "8", "--width", "16")) == flipped
