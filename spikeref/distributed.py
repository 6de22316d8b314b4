"""Chunked reconstruction on Dask (``dask.distributed``): long recordings on many processes or machines.

The output frame range is cut into chunks of consecutive frames. Chunk ``[a, b)`` needs the windows ``a − reach …
b−1 + reach`` (``reach = L (K − 1)/2``), i.e. the planes ``[(a − reach) W, (b + reach) W)``: neighbouring chunks
overlap by ``2·reach·W = ((K − 1) L + 1) W − W`` planes; with the adaptive merge ``reach`` is ``max(L (K − 1)/2,
support)``, as far as its support reads (:attr:`~spikeref.pipeline.ReconstructParams.windows_read`). With window
charges (``accumulate="charge"``, the default) a window also reads the spike times up to
:data:`spikeref.charge.DEFAULT_MARGIN` readouts beyond it, so each chunk reads that margin (rounded up to whole
windows) more on either side. Each task opens the memory-mapped file itself, slices it to those planes (nothing else
is read), reconstructs its frames and writes them as EXR files straight into the output folder (atomic writes: a
killed worker leaves no partial frame).
Only a small summary travels back through the scheduler — never a frame.

Frames do not depend on the chunking (the pipeline's chunk independence, tested), so the
EXR files are bit-identical to a single-process run.  With ``resume=True`` frames already
on disk are skipped (whole chunks are not even submitted), so a killed job or a lost worker
loses nothing: run the same command again.

Input and output paths must be visible to every worker under the same name (shared storage
on a cluster).  Needs the extra ``dask`` (``pip install 'spikeref[dask]'``).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, replace
from pathlib import Path

from spikeref.pipeline import ReconstructParams

__all__ = ["Chunk", "ChunkError", "plan_chunks", "reconstruct_chunk", "reconstruct_distributed", "assemble_video"]


@dataclass(frozen=True)
class Chunk:
    """Output frames ``[start, stop)`` and the planes ``[first_plane, stop_plane)`` they need."""

    index: int
    start: int
    stop: int
    first_plane: int
    stop_plane: int

    def __str__(self) -> str:
        return (f"chunk {self.index} (frames {self.start}:{self.stop}, "
                f"planes {self.first_plane}:{self.stop_plane})")


class ChunkError(RuntimeError):
    """A chunk failed on a worker; the message names the chunk and the worker's error."""


def plan_chunks(frames: range, params: ReconstructParams, chunk_frames: int) -> list[Chunk]:
    """Cut ``frames`` (a range of output frame numbers) into chunks of ``chunk_frames`` frames.

    Parameters
    ----------
    frames : range
        Output frames to make (step 1), e.g. ``Reconstructor.frames_available``.
    params : ReconstructParams
        ``W, K, L`` set the planes each chunk reads.
    chunk_frames : int
        Frames per chunk (≥ 1).  Larger chunks re-read less of the overlap (``2·reach·W``
        planes per chunk, i.e. ``(K − 1) L`` windows re-accumulated and re-denoised at each
        step) but give the scheduler fewer pieces to balance and lose more on a kill.
    """
    if isinstance(chunk_frames, bool) or not isinstance(chunk_frames, int) or chunk_frames < 1:
        raise ValueError(f"chunk_frames must be a positive integer; got {chunk_frames!r}")
    if not isinstance(frames, range) or frames.step != 1:
        raise TypeError(f"frames must be a range with step 1; got {frames!r}")
    w, reach = params.window, params.windows_read
    margin = 0
    if params.accumulate == "charge":  # the spike times around each window's edges, in whole windows
        from spikeref.charge import DEFAULT_MARGIN

        margin = -(-DEFAULT_MARGIN // w) * w
    out = []
    for i, a in enumerate(range(frames.start, frames.stop, chunk_frames)):
        b = min(a + chunk_frames, frames.stop)
        out.append(Chunk(i, a, b, max(0, (a - reach) * w - margin), (b + reach) * w + margin))
    return out


_DENOISERS: dict = {}


def _denoiser(weights, mode, accumulate="count", guard="sure", shrink=True):
    key = (str(weights) if weights is not None else None, mode, accumulate, guard, shrink)
    if key not in _DENOISERS:  # one load per worker process
        from spikeref.denoise.denoiser import Denoiser, bundled_weights

        _DENOISERS[key] = Denoiser.load(weights if weights is not None else bundled_weights(accumulate), mode=mode,
                                        guard=guard, shrink=shrink)
    return _DENOISERS[key]


def _follow_worker_thread_limit() -> None:
    """Give Numba's thread pool the limit Dask gives its worker processes.

    Dask starts each worker process with ``OMP_NUM_THREADS=1`` (and the BLAS variables; its
    ``distributed.nanny.pre-spawn-environ``) so that single-threaded workers share a node's cores
    instead of each running a pool as wide as the node.  Numba's pool does not read those
    variables, and the U-Net and the other kernels run on it, so follow ``OMP_NUM_THREADS`` here
    -- on a Dask worker only (the limit holds for the worker's task thread from then on); a
    direct call elsewhere keeps the caller's setting.
    """
    from spikeref._jit import numba, numba_available

    if not numba_available:
        return
    try:
        from distributed import get_worker

        get_worker()
    except (ImportError, ValueError):  # not inside a Dask worker
        return
    try:
        limit = int(os.environ["OMP_NUM_THREADS"])
    except (KeyError, ValueError):
        return
    numba.set_num_threads(max(1, min(limit, numba.config.NUMBA_NUM_THREADS)))


def _numba_threads() -> int:
    from spikeref._jit import numba, numba_available

    return numba.get_num_threads() if numba_available else 1


def reconstruct_chunk(path: str, open_kwargs: dict, params: ReconstructParams, chunk: Chunk, exr_dir: str,
                      weights=None, half: bool = False, skip=(), guard: str = "sure", shrink: bool = True,
                      hot_pixels=None, dark_level=None) -> dict:
    """Reconstruct one chunk and write its EXR frames; runs on a worker (or anywhere).

    ``weights``, ``guard`` and ``shrink`` make the denoiser as :meth:`Denoiser.load` does (the
    bundled network for ``params.accumulate`` when ``weights`` is None).  ``hot_pixels`` is a map to
    replace (``(H, W) bool``); without one, ``params.hot_pixels="auto"`` finds them in the whole
    recording's first planes, as a single run does, so every chunk replaces the same pixels
    (:func:`spikeref.hot_pixels.hot_pixels_to_replace`).  ``dark_level`` ``(4,)``, if given, is subtracted from
    every frame (:class:`spikeref.pipeline.Reconstructor`).

    ``skip`` lists frames of the chunk already on disk (``--resume``: the caller vetted them
    with :func:`spikeref.render.frames_on_disk`, so the task reads no EXR file).

    Returns
    -------
    dict
        ``chunk``, ``written``, ``skipped`` (frames), ``seconds`` (in this task),
        ``planes_read``, ``peak_rss_mib`` (this worker process's peak so far), ``pid``,
        ``threads`` (Numba's thread count in the task, after :func:`_follow_worker_thread_limit`).
    """
    import resource

    from spikeref.hot_pixels import hot_pixels_to_replace
    from spikeref.stream import open_spike_file
    from spikeref.io.exr import write_exr
    from spikeref.pipeline import Reconstructor
    from spikeref.render import exr_name, frame_runs

    _follow_worker_thread_limit()
    t0 = time.perf_counter()
    out = Path(exr_dir)
    out.mkdir(parents=True, exist_ok=True)
    todo = [(a, b) for a, b, on_disk in frame_runs(chunk.start, chunk.stop, set(skip)) if not on_disk]
    written = 0
    if todo:
        stream = open_spike_file(path, **open_kwargs)
        stop_plane = min(chunk.stop_plane, len(stream))  # a charge's margin may reach past the end
        hot = hot_pixels_to_replace(stream, params.hot_pixels, hot_pixels)  # the recording's, not the chunk's
        view = stream.slice(chunk.first_plane, stop_plane)
        shift = chunk.first_plane // params.window  # frame k of the recording is frame k − shift of the view
        den = _denoiser(weights, params.mode, params.accumulate, guard, shrink) if params.denoise else None
        rec = Reconstructor(view, replace(params, hot_pixels="off"), den, hot_pixels=hot, dark_level=dark_level)
        for a, b in todo:
            for frame in rec.frames(a - shift, b - shift):
                write_exr(out / exr_name(frame.index + shift), frame.rgb, half=half)
                written += 1
    return {"chunk": chunk.index, "frames": [chunk.start, chunk.stop], "written": written,
            "skipped": (chunk.stop - chunk.start) - written, "seconds": time.perf_counter() - t0,
            "planes_read": (stop_plane - chunk.first_plane) if todo else 0,
            "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, "pid": os.getpid(),
            "threads": _numba_threads()}


def _make_client(workers, scheduler):
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:
        raise ImportError(f"distributed reconstruction needs Dask: pip install 'spikeref[dask]' ({exc})") from None
    if scheduler is not None:
        return Client(scheduler), None
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0")
    return Client(cluster), cluster


def reconstruct_distributed(path, exr_dir, params: ReconstructParams | None = None, *, open_kwargs: dict | None = None,
                            weights=None, frames: range | None = None, chunk_frames: int = 64,
                            workers: int | None = None, scheduler: str | None = None, client=None,
                            resume: bool = False, half: bool = False, progress: bool = True,
                            guard: str = "sure", shrink: bool = True, hot_pixels=None,
                            dark_level=None) -> list[dict]:
    """Reconstruct ``frames`` of the spike file ``path`` into ``exr_dir`` on a Dask cluster.

    Parameters
    ----------
    path : path
        Spike file (``.dat`` memory-mapped, ``.npy``, ``.npz``), readable by every worker.
    exr_dir : path
        Output folder, writable by every worker; frame ``k`` is ``frame_{k:06d}.exr``.
    params : ReconstructParams
        ``W, K, L``, mode, alignment and the rest (default ``ReconstructParams()``: the package's
        defaults, which go beyond the paper where ``docs/results.md`` measured a gain;
        ``ReconstructParams.paper()`` for the paper's procedure).
    open_kwargs : dict
        ``height, width, cfa, file_width, rate_hz, key, axes, rows`` for :func:`spikeref.stream.open_spike_file`
        (every worker opens the file with them: a ``.dat`` stored top-down needs ``rows="top-down"`` here or in
        its sidecar).
    weights : path or bundled name, optional
        Denoiser weights (default: the bundled network for ``params.accumulate``; none is loaded with
        ``params.denoise=False``).
    guard : {"sure", "off"}
        The denoiser's guard on the output (:class:`spikeref.denoise.denoiser.Denoiser`; default
        ``"sure"``, as :func:`spikeref.pipeline.reconstruct`; ``"off"`` for the paper's ``D``).
    shrink : bool
        With ``guard="off"``, the residual shrinkage (default True; False with ``guard="off"`` is
        the paper's ``D(I)`` exactly).
    frames : range, optional
        Output frames (default every frame the stream has).
    chunk_frames : int
        Frames per task (see :func:`plan_chunks`).
    workers : int, optional
        Start a ``LocalCluster`` of this many single-threaded worker processes.
    scheduler : str, optional
        Address of an existing scheduler (``tcp://host:8786``) instead.
    client : dask.distributed.Client, optional
        An existing client (neither ``workers`` nor ``scheduler``).
    resume : bool
        Skip frames whose EXR exists.
    hot_pixels : ndarray ``(H, W) bool``, optional
        A map of the hot pixels to replace (``spikeref calibrate``, or one found already; an empty map replaces
        none); without one, ``params.hot_pixels="auto"``
        finds them here, once, in the recording's first planes (as a single run does) and every chunk
        replaces the same ones.
    dark_level : array_like ``(4,)``, optional
        The sensor's dark level, subtracted from every frame (``spikeref calibrate``;
        :class:`spikeref.pipeline.Reconstructor`).

    Returns
    -------
    list of dict
        One summary per chunk that ran (:func:`reconstruct_chunk`), by chunk; each also has
        ``wall_s``, the time from submission to its result on this side.

    Raises
    ------
    ChunkError
        When a chunk fails on a worker (the message names it); other chunks are cancelled,
        frames already written stay (rerun with ``resume=True``).
    """
    from spikeref.hot_pixels import hot_pixels_to_replace
    from spikeref.stream import open_spike_file
    from spikeref.pipeline import Reconstructor
    from spikeref.render import frames_on_disk

    params = params if params is not None else ReconstructParams()
    open_kwargs = dict(open_kwargs or {})
    given = sum(x is not None for x in (workers, scheduler, client))
    if given != 1:
        raise ValueError("give exactly one of workers (a local cluster), scheduler (an address) or client")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a positive integer; got {workers!r}")
    path = Path(path).resolve()
    stream = open_spike_file(path, **open_kwargs)  # errors about the input surface here, before any task
    hot_pixels = hot_pixels_to_replace(stream, params.hot_pixels, hot_pixels)  # found once, for every chunk
    params = replace(params, hot_pixels="off")  # the chunks replace this map and search for none
    avail = Reconstructor(stream, params, denoiser=lambda p: p, hot_pixels=hot_pixels,
                          dark_level=dark_level).frames_available  # checks the dark level here, not on a worker
    frames = avail if frames is None else frames
    if frames.start < avail.start or frames.stop > avail.stop or frames.start >= frames.stop:
        raise ValueError(f"frames {frames.start}:{frames.stop} are outside this stream's frames "
                         f"{avail.start}:{avail.stop} (W={params.window}, K={params.K}, L={params.L})")
    if params.denoise:  # a bad weights file or denoiser option fails here, not on every worker
        _denoiser(weights, params.mode, params.accumulate, guard, shrink)
    exr_dir = Path(exr_dir).resolve()
    exr_dir.mkdir(parents=True, exist_ok=True)
    chunks = plan_chunks(frames, params, chunk_frames)
    done = frames_on_disk(exr_dir, frames, stream.height, stream.width)[0] if resume else set()
    chunks = [c for c in chunks if not all(k in done for k in range(c.start, c.stop))]
    if not chunks:
        return []
    own = None
    if client is None:
        client, own = _make_client(workers, scheduler)
    try:
        return _run(client, chunks, str(path), open_kwargs, params, str(exr_dir), weights, half, done, progress,
                    (guard, shrink), hot_pixels, dark_level)
    finally:
        if own is not None:
            client.close()
            own.close()


def _run(client, chunks, path, open_kwargs, params, exr_dir, weights, half, done, progress, options,
         hot_pixels, dark_level=None) -> list[dict]:
    from dask.distributed import as_completed
    from tqdm import tqdm

    weights = str(weights) if weights is not None else None
    submitted = {}
    t0 = time.perf_counter()
    futures = []
    for c in chunks:
        skip = tuple(k for k in range(c.start, c.stop) if k in done)
        f = client.submit(reconstruct_chunk, path, open_kwargs, params, c, exr_dir, weights, half, skip, *options,
                          hot_pixels=hot_pixels, dark_level=dark_level,
                          key=f"spikeref-chunk-{c.index}-{os.getpid()}-{time.time_ns()}",
                          pure=False)
        submitted[f.key] = c
        futures.append(f)
    out = []
    bar = tqdm(total=sum(c.stop - c.start for c in chunks), desc="reconstruct", unit="frame", disable=not progress)
    try:
        for f in as_completed(futures):
            c = submitted[f.key]
            try:
                summary = f.result()
            except Exception as exc:
                for other in futures:
                    other.cancel()
                raise ChunkError(f"{c} failed on a worker: {type(exc).__name__}: {exc}") from exc
            summary["wall_s"] = time.perf_counter() - t0
            out.append(summary)
            bar.update(c.stop - c.start)
    finally:
        bar.close()
    return sorted(out, key=lambda s: s["chunk"])


def assemble_video(exr_dir, frames: range, video, fps: float = 30.0) -> Path:
    """Write the video of EXR frames ``frames`` in order, one exposure for the whole video.

    The exposure is chosen as in a single-process run (:class:`spikeref.render.FrameSink`:
    the first 16 frames), so the video equals the one ``spikeref reconstruct`` writes from the
    same float32 frames. With ``--half`` the exposure comes from the float16 read-backs, so the
    two videos can differ slightly (as a resumed single-process run can).
    """
    from spikeref.io.exr import read_exr
    from spikeref.render import FrameSink, exr_name

    exr_dir = Path(exr_dir)
    missing = [k for k in frames if not (exr_dir / exr_name(k)).is_file()]
    if missing:
        raise FileNotFoundError(f"{len(missing)} EXR frames are missing in {exr_dir} (first: {exr_name(missing[0])});"
                                " rerun with --resume")
    with FrameSink(video, None, fps=fps) as sink:
        for k in frames:
            sink.add(k, read_exr(exr_dir / exr_name(k)), on_disk=True)
    return Path(video)
