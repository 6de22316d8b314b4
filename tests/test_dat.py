import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.accumulate import accumulate
from spikeref.io.dat import pack_planes, save_spikes, unpack_planes, write_dat
from spikeref.stream import load_spikes, read_dat
from spikeref.oracles import pack_dat_oracle, unpack_dat_oracle


def test_layout_is_lsb_first_and_bottom_up():
    # one spike at the top-left pixel of a 2×8 image: it is stored in the LAST row, bit 0
    spikes = np.zeros((1, 2, 8), np.uint8)
    spikes[0, 0, 0] = 1
    assert pack_planes(spikes).tolist() == [[0, 1]]
    spikes[0, 0, 0] = 0
    spikes[0, 1, 3] = 1  # bottom row, 4th pixel -> first stored byte, bit 3
    assert pack_planes(spikes).tolist() == [[8, 0]]


@given(t=st.integers(1, 4), h=st.integers(1, 4), w=st.integers(1, 3), seed=st.integers(0, 2**31))
@settings(max_examples=30, deadline=None)
def test_pack_matches_oracle(t, h, w, seed):
    spikes = (np.random.default_rng(seed).random((t, 2 * h, 4 * w)) < 0.5).astype(np.uint8)
    np.testing.assert_array_equal(pack_planes(spikes).ravel(), pack_dat_oracle(spikes))
    np.testing.assert_array_equal(unpack_planes(pack_planes(spikes), 2 * h, 4 * w), spikes)


def test_roundtrip_file_and_memmap(tmp_path, rng):
    spikes = (rng.random((23, 6, 8)) < 0.4).astype(np.uint8)
    path = write_dat(tmp_path / "s.dat", spikes)
    assert path.stat().st_size == 23 * 6
    stream = read_dat(path, 6, 8, cfa="RGGB")
    assert len(stream) == 23 and stream.shape == (23, 6, 8) and stream.is_packed
    assert isinstance(stream.packed, np.memmap)
    np.testing.assert_array_equal(stream.window(0, 23), spikes)
    np.testing.assert_array_equal(stream.window(5, 3), spikes[5:8])
    assert stream.duration_s == pytest.approx(23 / 20000)
    # writing a stream copies it window by window
    write_dat(tmp_path / "copy.dat", stream)
    assert (tmp_path / "copy.dat").read_bytes() == path.read_bytes()


def test_padded_rows_are_cropped(tmp_path, rng):
    spikes = (rng.random((5, 4, 16)) < 0.5).astype(np.uint8)
    write_dat(tmp_path / "wide.dat", spikes)
    stream = read_dat(tmp_path / "wide.dat", 4, 12, file_width=16)
    np.testing.assert_array_equal(stream.window(0, 5), spikes[:, :, :12])
    raw = np.fromfile(tmp_path / "wide.dat", np.uint8)
    np.testing.assert_array_equal(unpack_dat_oracle(raw, 4, 12, 16), spikes[:, :, :12])
    offset = read_dat(tmp_path / "wide.dat", 4, 8, file_width=16, col_offset=8)
    np.testing.assert_array_equal(offset.window(0, 5), spikes[:, :, 8:])


def test_bad_files_give_clear_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such .dat file"):
        read_dat(tmp_path / "missing.dat", 4, 8)
    (tmp_path / "empty.dat").write_bytes(b"")
    with pytest.raises(ValueError, match="empty"):
        read_dat(tmp_path / "empty.dat", 4, 8)
    (tmp_path / "trunc.dat").write_bytes(b"\0" * 13)
    msg = r"not a whole number of 4×8 planes \(4 bytes each; 3 whole planes and 1 bytes"
    with pytest.raises(ValueError, match=msg):
        read_dat(tmp_path / "trunc.dat", 4, 8)
    with pytest.raises(ValueError, match="not a whole number of bytes"):
        read_dat(tmp_path / "trunc.dat", 3, 5)
    with pytest.raises(ValueError, match="cfa must be one of"):
        write_dat(tmp_path / "ok.dat", np.zeros((1, 2, 4), np.uint8))
        read_dat(tmp_path / "ok.dat", 2, 4, cfa="RGB")


def test_atomic_write_leaves_nothing_on_error(tmp_path):
    with pytest.raises(ValueError, match="only 0 and 1"):
        write_dat(tmp_path / "bad.dat", np.full((2, 2, 4), 3, np.uint8))
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("suffix", [".npy", ".npz", ".dat"])
def test_save_and_load_by_suffix(tmp_path, rng, suffix):
    spikes = (rng.random((7, 4, 6)) < 0.5).astype(np.uint8)
    save_spikes(tmp_path / f"s{suffix}", spikes)
    stream = load_spikes(tmp_path / f"s{suffix}", height=4, width=6)
    np.testing.assert_array_equal(stream.window(0, 7), spikes)
    with pytest.raises(ValueError, match="unknown spike file type"):
        save_spikes(tmp_path / "s.txt", spikes)


@pytest.mark.realdata
def test_real_dat_sample_reads_upright(real_data):
    # the Spike-Zoo REDS sample: 301 planes of 250×400; planes 130–170 centre on the ground truth
    import imageio.v3 as iio

    stream = read_dat(real_data / "spikezoo_data_reds_sim_250x400.dat", 250, 400)
    assert len(stream) == 301
    tfp = accumulate(stream, 41, start=130, count=1)[0]
    gt = iio.imread(real_data / "spikezoo_data_reds_sim_gt.png").astype(np.float64)
    if gt.ndim == 3:
        gt = gt[..., 0]
    assert gt.shape == (250, 400)
    corr = np.corrcoef(tfp.ravel(), gt.ravel())[0, 1]
    assert corr > 0.95
    flipped = np.corrcoef(tfp[::-1].ravel(), gt.ravel())[0, 1]
    assert flipped < 0.5  # reading the rows top-down would not match the picture


def test_a_huge_file_opens_without_being_read(tmp_path):
    # a 4 GB sparse file of 1000×1000 planes: opening and reading its last window touches only that window
    import resource

    path = tmp_path / "huge.dat"
    plane = 1000 * 1000 // 8
    with open(path, "wb") as fh:
        fh.truncate(32000 * plane)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    stream = read_dat(path, 1000, 1000, cfa="RGGB")
    assert len(stream) == 32000 and stream.duration_s == pytest.approx(1.6)
    assert stream.window(31990, 10).sum() == 0
    grown_mib = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    assert grown_mib < 200


@pytest.mark.parametrize("name", ["height", "width", "file_width", "rate_hz"])
@pytest.mark.parametrize("value", [0, -1, True])
def test_open_spike_file_refuses_zero_and_none_means_not_given(tmp_path, rng, name, value):
    # 0 is a value, never "not given": refused with the argument's name, for .dat and .npy alike.
    from spikeref.stream import open_spike_file

    spikes = (rng.random((6, 4, 8)) < 0.3).astype(np.uint8)
    for suffix in (".dat", ".npy"):
        path = save_spikes(tmp_path / f"s{suffix}", spikes)
        with pytest.raises(ValueError, match=name):
            open_spike_file(path, **{name: value})
    if name in ("height", "width"):
        with pytest.raises(ValueError, match=name):
            load_spikes(tmp_path / "s.dat", **{name: value})
    # None: the sidecar's value, else the default.
    (tmp_path / "s.json").write_text('{"height": 4, "width": 8, "rate_hz": 1000.0}')
    stream = open_spike_file(tmp_path / "s.dat", height=None, width=None, file_width=None, rate_hz=None)
    assert stream.shape == (6, 4, 8) and stream.rate_hz == 1000.0
    np.testing.assert_array_equal(stream.window(0, 6), spikes)
    (tmp_path / "s.json").unlink()
    with pytest.raises(ValueError, match="250"):  # no sidecar: the 250×400 default, which this file is not
        open_spike_file(tmp_path / "s.dat")


def test_top_down_layout_matches_the_oracle_and_round_trips(tmp_path, rng):
    """rows="top-down": stored row r is image row r; the bits and the crop are as bottom-up's."""
    from spikeref.io.dat import DatWriter

    one = np.zeros((1, 2, 8), np.uint8)
    one[0, 0, 0] = 1  # the top-left pixel: the first stored byte, bit 0, when rows are stored top-down
    assert pack_planes(one, rows="top-down").tolist() == [[1, 0]]
    assert pack_planes(one).tolist() == [[0, 1]]  # the default stores it in the last row
    spikes = (rng.random((5, 6, 16)) < 0.5).astype(np.uint8)
    packed = pack_planes(spikes, rows="top-down")
    np.testing.assert_array_equal(packed.ravel(), pack_dat_oracle(spikes, rows="top-down"))
    np.testing.assert_array_equal(packed, pack_planes(spikes[:, ::-1]))  # the other order is the flipped image
    np.testing.assert_array_equal(unpack_planes(packed, 6, 16, rows="top-down"), spikes)
    np.testing.assert_array_equal(unpack_planes(packed, 6, 12, 16, 4, rows="top-down"), spikes[:, :, 4:])
    np.testing.assert_array_equal(unpack_dat_oracle(packed, 6, 12, 16, 4, rows="top-down"), spikes[:, :, 4:])
    write_dat(tmp_path / "w.dat", spikes, rows="top-down", chunk_planes=2)
    with DatWriter(tmp_path / "d.dat", 6, 16, rows="top-down") as writer:
        writer.append(spikes[:3])
        writer.append(spikes[3:])
    assert (tmp_path / "w.dat").read_bytes() == (tmp_path / "d.dat").read_bytes() == packed.tobytes()
    stream = read_dat(tmp_path / "w.dat", 6, 16, rows="top-down")
    np.testing.assert_array_equal(stream.window(0, 5), spikes)
    write_dat(tmp_path / "back.dat", stream)  # a stream is written upright: bottom-up by default
    assert (tmp_path / "back.dat").read_bytes() == pack_planes(spikes).tobytes()


@pytest.mark.parametrize("rows, error, match", [
    ("sideways", ValueError, r"rows must be one of 'bottom-up', 'top-down' \(the order the \.dat stores"),
    ("", ValueError, "got ''"), (None, TypeError, "got NoneType"), (1, TypeError, "got int"),
])
def test_a_bad_row_order_is_refused_naming_rows(tmp_path, rows, error, match):
    from spikeref.io.dat import DatWriter

    spikes = np.zeros((1, 2, 8), np.uint8)
    for call in (lambda: pack_planes(spikes, rows=rows), lambda: unpack_planes(pack_planes(spikes), 2, 8, rows=rows),
                 lambda: write_dat(tmp_path / "x.dat", spikes, rows=rows),
                 lambda: DatWriter(tmp_path / "y.dat", 2, 8, rows=rows)):
        with pytest.raises(error, match=match):
            call()
    assert os.listdir(tmp_path) == []  # refused before anything is written
    assert pack_planes(spikes, rows="Top-Down").tolist() == pack_planes(spikes, rows="top-down").tolist()
