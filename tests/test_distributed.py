"""Chunked reconstruction on Dask: chunk plan, bit-identical frames, resume after a kill, errors naming the chunk."""

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from spikeref.cli import main
from spikeref.distributed import Chunk, ChunkError, plan_chunks, reconstruct_chunk, reconstruct_distributed
from spikeref.io.dat import write_dat
from spikeref.io.exr import read_exr
from spikeref.pipeline import ReconstructParams, frame_range
from spikeref.render import exr_name

H, W_PX, PLANES = 128, 128, 170  # W=10, K=3, L=3: frames 3 … 13 (11 frames)
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    rng = np.random.default_rng(5)
    base = rng.random((H, W_PX)) * 0.5 + 0.05
    shifts = [np.roll(base, t // 20, axis=1) for t in range(PLANES)]
    spikes = (rng.random((PLANES, H, W_PX)) < np.stack(shifts)).astype(np.uint8)
    folder = tmp_path_factory.mktemp("rec")
    path = folder / "moving.dat"
    write_dat(path, spikes)
    (folder / "moving.json").write_text('{"height": 128, "width": 128, "cfa": "RGGB"}')
    # The single-process reference runs with one thread (BLAS and Numba), as a Dask worker with
    # threads_per_worker=1 does; the frames must not depend on it (docs/distributed.md).
    single = folder / "single_exr"
    env = {**os.environ, **ONE_THREAD}
    subprocess.run([sys.executable, "-m", "spikeref.cli", "reconstruct", str(path), "--exr-dir", str(single)],
                   check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return path, single


def _numba_pool_size():
    from spikeref._jit import numba, numba_available

    return numba.config.NUMBA_NUM_THREADS if numba_available else 1


def _frames(folder):
    return {p.name: read_exr(p) for p in sorted(Path(folder).glob("frame_*.exr"))}


def _assert_identical(folder, reference):
    got, want = _frames(folder), _frames(reference)
    assert sorted(got) == sorted(want) and len(want) == len(frame_range(PLANES))
    for name in want:
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)


def test_plan_covers_the_frames_with_the_support_overlap():
    p = ReconstructParams(window=10, K=3, L=3, accumulate="count", merge="binomial")
    chunks = plan_chunks(range(3, 14), p, 4)
    assert [(c.start, c.stop) for c in chunks] == [(3, 7), (7, 11), (11, 14)]
    assert chunks[0] == Chunk(0, 3, 7, 0, 100)  # windows 3−3 … 6+3
    overlap = chunks[0].stop_plane - chunks[1].first_plane
    assert overlap == ((p.K - 1) * p.L + 1) * p.window - p.window
    # window charges (the default) read DEFAULT_MARGIN = 200 readouts more on either side, in whole windows
    charge = plan_chunks(range(3, 40), ReconstructParams(window=30, K=3, L=3, merge="binomial"), 4)
    assert charge[0] == Chunk(0, 3, 7, 0, (7 + 3) * 30 + 210)  # 200 readouts → 7 windows of 30; clipped at 0
    assert charge[5] == Chunk(5, 23, 27, (23 - 3) * 30 - 210, (27 + 3) * 30 + 210)
    # the adaptive merge (the default on charges) reads `support` windows each side where the recording has them
    adaptive = plan_chunks(range(3, 40), ReconstructParams(window=10, K=3, L=3, accumulate="count", merge="adaptive",
                                                           support=12), 4)
    assert adaptive[1] == Chunk(1, 7, 11, 0, (11 + 12) * 10)  # windows 7 − 12 … 10 + 12, clipped at 0
    assert adaptive[5] == Chunk(5, 23, 27, (23 - 12) * 10, (27 + 12) * 10)
    with pytest.raises(ValueError, match="chunk_frames must be a positive integer"):
        plan_chunks(range(3, 14), p, 0)


def test_chunks_run_anywhere_equal_one_run(recording, tmp_path, monkeypatch):
    path, single = recording
    # Outside a Dask worker the thread cap does not apply, even with OMP_NUM_THREADS set: these
    # chunks run with the process's whole Numba pool (two threads on a 2-core machine).
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    p = ReconstructParams()
    whole = plan_chunks(frame_range(PLANES), p, 100)
    assert len(whole) == 1
    reconstruct_chunk(str(path), {}, p, whole[0], str(tmp_path / "one"))
    for c in plan_chunks(frame_range(PLANES), p, 4):  # in this process, no scheduler
        s = reconstruct_chunk(str(path), {}, p, c, str(tmp_path / "chunks"))
        assert s["written"] == c.stop - c.start
        assert s["planes_read"] == min(c.stop_plane, PLANES) - c.first_plane  # a charge's margin stops at the end
        assert s["threads"] == _numba_pool_size()
    _assert_identical(tmp_path / "chunks", tmp_path / "one")  # same process: bit for bit
    # another process with one thread instead of the whole pool: also bit for bit (every kernel
    # sums each output in a fixed order; the U-Net no longer calls BLAS)
    _assert_identical(tmp_path / "chunks", single)


def test_chunks_run_the_papers_procedure_too(recording, tmp_path):
    # guard="off", shrink=False and ReconstructParams.paper() reach the chunk's denoiser: the chunks
    # equal one run of the paper's procedure in this process, and differ from the defaults' frames.
    from spikeref.denoise.denoiser import Denoiser
    from spikeref.pipeline import Reconstructor
    from spikeref.stream import open_spike_file

    path, single = recording
    p = ReconstructParams.paper()
    for c in plan_chunks(frame_range(PLANES), p, 5):
        reconstruct_chunk(str(path), {}, p, c, str(tmp_path), guard="off", shrink=False)
    rec = Reconstructor(open_spike_file(path), p, Denoiser.load(mode=p.mode, guard="off", shrink=False))
    got = _frames(tmp_path)
    assert len(got) == len(frame_range(PLANES))
    for frame in rec.frames():
        np.testing.assert_array_equal(got[exr_name(frame.index)], frame.rgb)
    assert not np.array_equal(got[exr_name(5)], _frames(single)[exr_name(5)])


def test_cli_passes_the_denoiser_options_to_the_workers(recording, tmp_path, monkeypatch):
    import spikeref.distributed as dist

    seen = {}

    def fake(path, exr_dir, params, **kw):
        seen.update(kw, params=params)
        return []

    monkeypatch.setattr(dist, "reconstruct_distributed", fake)
    monkeypatch.setattr(dist, "assemble_video", lambda *a, **k: None)
    path, _ = recording
    assert main(["reconstruct", str(path), "--paper", "--workers", "1", "--exr-dir", str(tmp_path / "e")]) == 0
    assert seen["params"] == ReconstructParams.paper() and (seen["guard"], seen["shrink"]) == ("off", False)
    assert main(["reconstruct", str(path), "--guard", "off", "--no-shrink", "--workers", "1",
                 "--exr-dir", str(tmp_path / "f")]) == 0
    assert seen["params"] == ReconstructParams() and (seen["guard"], seen["shrink"]) == ("off", False)
    assert main(["reconstruct", str(path), "--workers", "1", "--exr-dir", str(tmp_path / "g")]) == 0
    assert (seen["guard"], seen["shrink"]) == ("sure", True)
    # an array file's key and axis order reach the workers, which open the file again
    spikes = (np.random.default_rng(0).random((16, 16, 80)) < 0.3).astype(np.uint8)
    np.savez(tmp_path / "hwt.npz", s=spikes, other=spikes[:1])
    assert main(["reconstruct", str(tmp_path / "hwt.npz"), "--key", "s", "--axes", "HWT", "--workers", "1",
                 "--exr-dir", str(tmp_path / "h")]) == 0
    assert (seen["open_kwargs"]["key"], seen["open_kwargs"]["axes"]) == ("s", "HWT")


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("dask.distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_two_worker_processes_write_bit_identical_frames(recording, client, tmp_path):
    path, single = recording
    summaries = reconstruct_distributed(path, tmp_path, client=client, chunk_frames=3, progress=False)
    assert [s["chunk"] for s in summaries] == [0, 1, 2, 3]
    assert len({s["pid"] for s in summaries}) == 2  # both workers took chunks
    assert all(s["pid"] != os.getpid() and s["peak_rss_mib"] > 0 for s in summaries)
    # Dask starts its workers with OMP_NUM_THREADS=1; each task caps Numba's pool to it
    assert all(s["threads"] == 1 for s in summaries)
    _assert_identical(tmp_path, single)
    # resume: every frame on disk → no chunk runs; one frame removed → only its chunk runs
    assert reconstruct_distributed(path, tmp_path, client=client, chunk_frames=3, resume=True, progress=False) == []
    (tmp_path / exr_name(8)).unlink()
    again = reconstruct_distributed(path, tmp_path, client=client, chunk_frames=3, resume=True, progress=False)
    assert [(s["chunk"], s["written"], s["skipped"]) for s in again] == [(1, 1, 2)]
    _assert_identical(tmp_path, single)


def test_without_a_denoiser_no_weights_are_read(recording, client, tmp_path):
    """``params.denoise=False``: the weights are neither checked nor loaded; the frames are the single process's."""
    from spikeref.pipeline import Reconstructor
    from spikeref.stream import open_spike_file

    path, _ = recording
    params = ReconstructParams.fastest()
    summaries = reconstruct_distributed(path, tmp_path, params, weights=tmp_path / "missing.npz", client=client,
                                        frames=range(3, 5), chunk_frames=2, progress=False)
    assert sum(s["written"] for s in summaries) == 2
    want = [f.rgb for f in Reconstructor(open_spike_file(path), params).frames(3, 5)]
    for k, w in zip((3, 4), want, strict=True):
        np.testing.assert_allclose(read_exr(tmp_path / exr_name(k)), w, rtol=1e-6, atol=1e-7)


def test_worker_error_names_the_chunk(recording, client, tmp_path):
    path, _ = recording
    (tmp_path / exr_name(7)).mkdir()  # frame 7 cannot be written: a folder sits at its name
    # planes (6 − 10)·10 − 200 … (9 + 10)·10 + 200: the adaptive merge's support of 10 windows and the window
    # charge's margin, clipped at 0
    with pytest.raises(ChunkError, match=r"chunk 1 \(frames 6:9, planes 0:390\) failed on a worker"):
        reconstruct_distributed(path, tmp_path, client=client, chunk_frames=3, progress=False)


def test_killed_job_resumes_to_the_same_complete_set(recording, tmp_path):
    pytest.importorskip("dask.distributed")
    path, single = recording
    out = tmp_path / "exr"
    cmd = [sys.executable, "-m", "spikeref.cli", "reconstruct", str(path), "--exr-dir", str(out), "--workers", "2",
           "--chunk-frames", "1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
                            env={**os.environ, **ONE_THREAD})
    deadline = time.time() + 120
    while time.time() < deadline and not (out.is_dir() and any(out.glob("frame_*.exr"))):
        time.sleep(0.2)
    os.killpg(proc.pid, 9)  # the whole job: client, scheduler and workers
    proc.wait()
    first = sorted(p.name for p in out.glob("frame_*.exr"))
    assert 0 < len(first) < len(frame_range(PLANES))  # killed midway
    # a worker killed mid-write may leave its hidden temporary (".frame_….part.exr"), never a partial
    # file under a frame's name: every frame file there is a whole EXR
    from spikeref.io.exr import read_exr

    assert all(p.name.endswith(".part.exr") for p in out.glob(".*"))
    assert all(read_exr(out / name).shape[-1] == 3 for name in first)
    subprocess.run(cmd + ["--resume"], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env={**os.environ, **ONE_THREAD})
    _assert_identical(out, single)


def test_cli_workers_writes_video_and_frames(recording, tmp_path):
    pytest.importorskip("dask.distributed")
    path, single = recording
    video = tmp_path / "out.mp4"
    assert main(["reconstruct", str(path), "-o", str(video), "--workers", "1", "--chunk-frames", "6"]) == 0
    _assert_identical(tmp_path / "out_exr", single)
    assert video.stat().st_size > 0


@pytest.mark.parametrize("argv, match", [
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "not both"),
    (["--workers", "0"], "--workers must be at least 1"),
    (["--workers", "1", "--chunk-frames", "0"], "chunk_frames must be a positive integer"),
    (["--workers", "1", "--frames", "0:5"], "--frames 0:5: this stream has frames 3:14"),
])
def test_cli_bad_distributed_options(recording, tmp_path, capsys, argv, match):
    path, _ = recording
    assert main(["reconstruct", str(path), "--exr-dir", str(tmp_path / "x"), *argv]) == 2
    assert match in capsys.readouterr().err
    assert not any((tmp_path / "x").glob("*.exr")) if (tmp_path / "x").exists() else True


def test_cli_passes_the_row_order_to_the_workers(tmp_path, monkeypatch):
    """--rows reaches the workers' open options, so every chunk reads a top-down .dat upright."""
    import spikeref.distributed as dist
    from spikeref.stream import open_spike_file

    seen = {}
    monkeypatch.setattr(dist, "reconstruct_distributed", lambda path, exr_dir, params, **kw: seen.update(kw) or [])
    monkeypatch.setattr(dist, "assemble_video", lambda *a, **k: None)
    spikes = (np.random.default_rng(0).random((80, 16, 16)) < 0.3).astype(np.uint8)
    write_dat(tmp_path / "td.dat", spikes, rows="top-down")
    assert main(["reconstruct", str(tmp_path / "td.dat"), "--height", "16", "--width", "16", "--rows", "top-down",
                 "--no-denoiser", "--workers", "1", "--exr-dir", str(tmp_path / "e")]) == 0
    assert seen["open_kwargs"]["rows"] == "top-down"
    np.testing.assert_array_equal(open_spike_file(tmp_path / "td.dat", **seen["open_kwargs"]).window(0, 80), spikes)


@pytest.mark.filterwarnings("ignore:.*too small for the alignment pyramid")
def test_chunks_replace_the_hot_pixels_of_the_whole_recording(tmp_path):
    """Each chunk finds the hot pixels in the recording's first planes, not in its own: the chunks' frames are
    those of one run, hot pixels replaced (a defect that sets in after the first planes is in no map)."""
    from spikeref.hot_pixels import find_hot_pixels
    from spikeref.pipeline import Reconstructor
    from spikeref.stream import read_dat

    rng = np.random.default_rng(9)
    h = w = 32
    base = 0.2 + 0.1 * np.sin(np.arange(w) / 4.0)[None, :] * np.ones((h, 1))
    hot = np.zeros((h, w), bool)
    hot[6, 9] = hot[21, 14] = True
    planes = 400
    rates = np.broadcast_to(np.clip(base + 0.6 * hot, 0, 1), (planes, h, w)).copy()
    rates[280:, 26, 27] = 0.9  # under half the recording's blocks, over half of the last chunk's
    spikes = (rng.random(rates.shape) < rates).astype(np.uint8)
    path = tmp_path / "hot.dat"
    write_dat(path, spikes)
    open_kwargs = {"height": h, "width": w, "cfa": "RGGB"}
    p = ReconstructParams(window=10, K=3, L=1, denoise=False, merge="binomial")  # chunks 3 windows apart
    whole = Reconstructor(read_dat(path, h, w, "RGGB"), p)
    np.testing.assert_array_equal(whole.hot_pixel_mask, hot)
    frames = frame_range(planes, 10, 3, 1)
    chunks = plan_chunks(frames, p, 8)
    last = read_dat(path, h, w, "RGGB").slice(chunks[-1].first_plane)
    assert find_hot_pixels(last)[26, 27]  # what a chunk would find in its own planes: this test can fail
    for c in chunks:
        reconstruct_chunk(str(path), open_kwargs, p, c, str(tmp_path / "chunks"))
    got = _frames(tmp_path / "chunks")
    assert len(got) == len(frames)
    for frame in whole.frames(frames.start, frames.stop):
        np.testing.assert_array_equal(got[f"frame_{frame.index:06d}.exr"], frame.rgb)
