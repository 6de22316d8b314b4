import numpy as np
import pytest

from spikeref.io.dat import pack_planes
from spikeref.stream import SpikeStream, as_stream


def test_array_stream_basics(rng):
    spikes = (rng.random((25, 4, 6)) < 0.5).astype(np.uint8)
    s = SpikeStream.from_array(spikes, cfa="bggr", rate_hz=10000)
    assert (len(s), s.height, s.width, s.cfa, s.rate_hz) == (25, 4, 6, "BGGR", 10000.0)
    assert s.duration_s == pytest.approx(25 / 10000)
    assert not s.is_packed and "25 planes of 4×6" in repr(s)
    windows = list(s.windows(10))
    assert len(windows) == 2
    np.testing.assert_array_equal(windows[1], spikes[10:20])
    assert as_stream(s) is s


def test_packed_stream_windows_equal_array_windows(rng):
    spikes = (rng.random((12, 4, 6)) < 0.5).astype(np.uint8)
    s = SpikeStream.from_packed(pack_planes(spikes), 4, 6)
    for w in s.windows(4):
        assert w.shape == (4, 4, 6)
    np.testing.assert_array_equal(np.concatenate(list(s.windows(4))), spikes)


@pytest.mark.parametrize(
    "start, length, match",
    [(-1, 2, "outside the stream"), (0, 0, "at least 1"), (10, 5, "outside the stream of 12"), (0.5, 2, "integers")],
)
def test_window_range_errors(start, length, match):
    s = SpikeStream.from_array(np.zeros((12, 2, 2), np.uint8))
    with pytest.raises((ValueError, TypeError), match=match):
        s.window(start, length)


def test_constructor_errors():
    with pytest.raises(ValueError, match="rate_hz"):
        SpikeStream.from_array(np.zeros((1, 2, 2), np.uint8), rate_hz=0)
    with pytest.raises(ValueError, match="packed must be uint8 of shape"):
        SpikeStream.from_packed(np.zeros((3, 5), np.uint8), 4, 8)
    with pytest.raises(TypeError, match="windows"):
        iter(SpikeStream.from_array(np.zeros((1, 2, 2), np.uint8)))


def _rss_file_kib() -> int:
    with open("/proc/self/status") as f:
        status = dict(line.split(":", 1) for line in f)
    return int(status["RssFile"].split()[0])


@pytest.mark.skipif(not __import__("os").path.exists("/proc/self/status"), reason="needs Linux /proc")
def test_release_drops_mapped_pages_and_keeps_data(tmp_path, rng):
    from spikeref.io.dat import write_dat
    from spikeref.stream import read_dat

    spikes = (rng.random((2048, 64, 128)) < 0.3).astype(np.uint8)  # 2048 planes × 1 KiB = 2 MiB
    write_dat(tmp_path / "x.dat", spikes)
    stream = read_dat(tmp_path / "x.dat", height=64, width=128)
    assert int(stream.window(0, 2048).sum()) == int(spikes.sum())  # every page now mapped
    before = _rss_file_kib()
    stream.release(0, 2048)
    assert before - _rss_file_kib() >= 1024  # at least half of the 2 MiB left the resident set
    stream.release(3, 5)  # unaligned ranges are fine
    np.testing.assert_array_equal(stream.window(1000, 48), spikes[1000:1048])
    with pytest.raises(ValueError, match="outside the stream"):
        stream.release(2040, 9)
    SpikeStream.from_array(spikes[:4]).release(0, 4)  # in memory: nothing to drop


def test_slice_is_a_view_with_a_shifted_window_grid(rng):
    spikes = (rng.random((40, 4, 6)) < 0.4).astype(np.uint8)
    packed = SpikeStream.from_packed(pack_planes(spikes), height=4, width=6, cfa="RGGB")
    for stream in (SpikeStream.from_array(spikes, cfa="RGGB"), packed):
        part = stream.slice(5, 35)
        assert len(part) == 30 and part.cfa == "RGGB" and part.is_packed == stream.is_packed
        np.testing.assert_array_equal(part.window(10, 10), spikes[15:25])
        assert len(stream.slice(7)) == 33
        with pytest.raises(ValueError, match="outside the stream"):
            stream.slice(30, 41)
        with pytest.raises(ValueError, match="at least 1 plane"):
            stream.slice(20, 20)


def test_load_spikes_key_and_axes(tmp_path):
    """``.npz`` keys in the order of NPZ_SPIKE_KEYS, a named key, and planes-last arrays (SpikingSIM's)."""
    from spikeref.stream import NPZ_SPIKE_KEYS, load_spikes

    assert NPZ_SPIKE_KEYS == ("spikes", "spk")
    spikes = (np.random.default_rng(1).random((12, 4, 6)) < 0.3).astype(np.uint8)
    hwt = np.ascontiguousarray(np.moveaxis(spikes, 0, -1))
    np.savez(tmp_path / "two.npz", spk=spikes, other=spikes[:2])
    np.savez(tmp_path / "hwt.npz", arr_0=hwt)
    np.save(tmp_path / "hwt.npy", hwt)
    np.testing.assert_array_equal(load_spikes(tmp_path / "two.npz").window(0, 12), spikes)
    np.testing.assert_array_equal(load_spikes(tmp_path / "two.npz", key="other").window(0, 2), spikes[:2])
    for name in ("hwt.npz", "hwt.npy"):
        stream = load_spikes(tmp_path / name, axes="HWT")
        assert stream.shape == (12, 4, 6)
        np.testing.assert_array_equal(stream.window(0, 12), spikes)
        assert load_spikes(tmp_path / name).shape == (4, 6, 12)  # as stored: planes first
    np.savez(tmp_path / "many.npz", a=spikes, b=spikes)
    with pytest.raises(ValueError, match=r"no key 'spikes' or 'spk' and more than one array; found keys \['a', 'b'\]"):
        load_spikes(tmp_path / "many.npz")
    with pytest.raises(ValueError, match=r"no key 'c'; found keys \['a', 'b'\]"):
        load_spikes(tmp_path / "many.npz", key="c")
    with pytest.raises(ValueError, match="axes must be one of THW, HWT; got 'TWH'"):
        load_spikes(tmp_path / "hwt.npz", axes="TWH")
    with pytest.raises(ValueError, match="a .npy file holds one array"):
        load_spikes(tmp_path / "hwt.npy", key="spikes")
    np.save(tmp_path / "flat.npy", spikes[0])
    with pytest.raises(ValueError, match=r"must have shape \(H, W, T\) with axes='HWT'; got shape \(4, 6\)"):
        load_spikes(tmp_path / "flat.npy", axes="HWT")


def test_damaged_array_files_are_one_error_naming_the_file(tmp_path):
    """A truncated .npz, a text file named .npz/.npy, a .npy named .npz: one ValueError naming the file."""
    from spikeref.stream import load_spikes

    spikes = (np.random.default_rng(1).random((12, 4, 6)) < 0.3).astype(np.uint8)
    np.savez(tmp_path / "whole.npz", spikes=spikes)
    (tmp_path / "cut.npz").write_bytes((tmp_path / "whole.npz").read_bytes()[:60])
    (tmp_path / "text.npz").write_text("hello")
    (tmp_path / "text.npy").write_text("hello")
    np.save(tmp_path / "one.npy", spikes)
    (tmp_path / "one.npz").write_bytes((tmp_path / "one.npy").read_bytes())
    for name, why in (("cut.npz", "not a readable .npz spike file"), ("text.npz", r"\(not NumPy array data\)"),
                      ("text.npy", r"\.npy spike file \(not NumPy array data\)"),
                      ("one.npz", "holds one array, as a .npy file does: name it .npy")):
        with pytest.raises(ValueError, match=why) as info:
            load_spikes(tmp_path / name)
        assert str(info.value).startswith(f"{tmp_path / name}: ")
    np.testing.assert_array_equal(load_spikes(tmp_path / "one.npy").window(0, 12), spikes)
    with pytest.raises(ValueError, match=r"is a folder; give a spike file in it \(.dat, .npy or .npz\)"):
        load_spikes(tmp_path)


def test_packed_streams_know_their_row_order(rng):
    """A top-down packed stream gives the upright planes, keeps its order when sliced; arrays have none."""
    spikes = (rng.random((20, 4, 8)) < 0.5).astype(np.uint8)
    top_down = SpikeStream.from_packed(pack_planes(spikes, rows="top-down"), 4, 8, rows="top-down")
    assert top_down.rows == "top-down" and "rows top-down" in repr(top_down)
    np.testing.assert_array_equal(top_down.window(3, 9), spikes[3:12])
    part = top_down.slice(5, 15)
    assert part.rows == "top-down"
    np.testing.assert_array_equal(part.window(0, 10), spikes[5:15])
    assert SpikeStream.from_packed(pack_planes(spikes), 4, 8).rows == "bottom-up"
    assert SpikeStream.from_array(spikes).rows is None and SpikeStream.from_array(spikes).slice(2).rows is None
    # the same bytes read in the other order: the image upside down
    other = SpikeStream.from_packed(pack_planes(spikes, rows="top-down"), 4, 8)
    np.testing.assert_array_equal(other.window(0, 20), spikes[:, ::-1])


def test_rows_from_arguments_and_sidecar(tmp_path, rng):
    """open_spike_file: rows= wins over the sidecar's "rows", which wins over bottom-up; bad values name their
    source; for an array file rows is not used (row 0 is at the top)."""
    import json

    from spikeref.io.dat import write_dat
    from spikeref.stream import load_spikes, open_spike_file, read_dat

    spikes = (rng.random((10, 4, 8)) < 0.5).astype(np.uint8)
    write_dat(tmp_path / "td.dat", spikes, rows="top-down")
    meta = {"height": 4, "width": 8}
    (tmp_path / "td.json").write_text(json.dumps(meta))
    assert open_spike_file(tmp_path / "td.dat").rows == "bottom-up"
    np.testing.assert_array_equal(open_spike_file(tmp_path / "td.dat", rows="top-down").window(0, 10), spikes)
    (tmp_path / "td.json").write_text(json.dumps(dict(meta, rows="top-down")))
    np.testing.assert_array_equal(open_spike_file(tmp_path / "td.dat").window(0, 10), spikes)
    np.testing.assert_array_equal(open_spike_file(tmp_path / "td.dat", rows="bottom-up").window(0, 10),
                                  spikes[:, ::-1])
    (tmp_path / "td.json").write_text(json.dumps(dict(meta, rows="upside-down")))
    with pytest.raises(ValueError, match=r"td\.json: rows must be one of 'bottom-up', 'top-down'.*'upside-down'"):
        open_spike_file(tmp_path / "td.dat")
    for call in (lambda r: read_dat(tmp_path / "td.dat", 4, 8, rows=r),
                 lambda r: open_spike_file(tmp_path / "td.dat", rows=r),
                 lambda r: load_spikes(tmp_path / "td.dat", 4, 8, rows=r),
                 lambda r: SpikeStream.from_packed(pack_planes(spikes), 4, 8, rows=r)):
        with pytest.raises(ValueError, match="rows must be one of 'bottom-up', 'top-down'.*got 'sideways'"):
            call("sideways")
        with pytest.raises(TypeError, match="rows must be one of .*got list"):
            call(["top-down"])
    np.save(tmp_path / "a.npy", spikes)
    np.testing.assert_array_equal(load_spikes(tmp_path / "a.npy", rows="top-down").window(0, 10), spikes)
    with pytest.raises(ValueError, match="rows must be one of"):
        load_spikes(tmp_path / "a.npy", rows="sideways")  # checked even where it is not used


def _integrate_and_fire(rates: np.ndarray, planes: int, seed: int = 0) -> np.ndarray:
    phase = np.random.default_rng(seed).random(rates.shape)
    level = np.floor(rates[None] * np.arange(planes + 1)[:, None, None] + phase[None])
    return np.diff(level, axis=0).astype(np.uint8)


def test_planes_last_is_suspected_from_the_spikes_not_the_shape():
    from spikeref.stream import planes_last_suspected

    rng = np.random.default_rng(0)
    scene = 0.05 + 0.4 * rng.random((48, 64))
    thw = _integrate_and_fire(scene, 200)
    assert not planes_last_suspected(thw)
    assert planes_last_suspected(np.moveaxis(thw, 0, -1))  # (H, W, T) read planes first
    # a Bayer mosaic (colours alternating along rows and columns) is not taken for time, either way round
    bayer = _integrate_and_fire(np.tile([[0.45, 0.2], [0.2, 0.05]], (24, 32)), 200, seed=1)
    assert not planes_last_suspected(bayer)
    assert planes_last_suspected(np.moveaxis(bayer, 0, -1))
    # independent random spikes, dark or saturated streams, short axes: nothing to judge
    for shape in ((32, 32, 32), (200, 48, 64), (40, 64, 200), (64, 48, 200)):
        assert not planes_last_suspected((rng.random(shape) < 0.3).astype(np.uint8)), shape
    assert not planes_last_suspected(np.zeros((40, 48, 64), np.uint8))
    assert not planes_last_suspected(np.ones((40, 48, 64), np.uint8))
    assert not planes_last_suspected(np.moveaxis(thw, 0, -1)[:20])  # the first axis too short to judge
    assert not planes_last_suspected(np.moveaxis(thw[:20], 0, -1))  # the last axis too short
    with pytest.raises(ValueError, match=r"3 axes; got shape \(4, 6\)"):
        planes_last_suspected(np.zeros((4, 6), np.uint8))
