"""The U-Net's Numba kernels (:mod:`spikeref.denoise.unet` reads like the network; the speed is here).

The direct 3×3 convolution (one parallel job per two output rows of two output channels, the
nine taps of each input channel summed as one expression over rows held in the L1 cache; fused
multiply-adds only, no reassociation, so the result does not depend on the thread count), 2×2
max-pooling and the nearest upsampling (the skip half of each concatenation is read in place by the
next convolution, never copied).  LLVM turns the nine-tap expression into
fused multiply-adds over a vector of pixels; every output value is computed by one job in a fixed order.  The
measured alternatives (im2col + BLAS, the network's convolution until 2026-11-23, and one ``einsum`` per tap)
are in :mod:`spikeref.denoise._conv_alternatives`, for ``benchmarks/test_speed_unet.py``.  Activations are
channel-first with a zero border of one pixel; every kernel writes interiors only.  Nothing here checks
its arguments: :func:`spikeref.denoise.conv.conv3x3` and :class:`~spikeref.denoise.unet.UNet` do.
"""

from __future__ import annotations

import threading

import numpy as np

from spikeref._jit import njit, prange

__all__ = [
    "buffers", "padded_empty", "release_buffers", "conv3x3_direct", "maxpool_into", "nine_taps", "one_channel_two_rows",
    "split_job", "store_row", "two_channel_two_rows", "upsample_into",
]


@njit
def split_job(job, channels, rows):
    # job over (n, channels, rows) in C order -> (image, channel, row)
    i = job // (channels * rows)
    rest = job - i * channels * rows
    k = rest // rows
    return i, k, rest - k * rows


@njit(fastmath={"contract"}, inline="always")
def nine_taps(k, u0, u1, u2, v0, v1, v2, s0, s1, s2):
    # one output channel's 3×3 kernel k on the rows above (u), at (v) and below (s) the pixel
    return ((k[0, 0] * u0 + k[0, 1] * u1 + k[0, 2] * u2)
            + (k[1, 0] * v0 + k[1, 1] * v1 + k[1, 2] * v2)
            + (k[2, 0] * s0 + k[2, 1] * s1 + k[2, 2] * s2))


@njit(fastmath={"contract"}, inline="always")
def two_channel_two_rows(r0, r1, r2, r3, wa, wb, a0, b0, a1, b1, cols):
    # a0, b0[x] += the 3×3 kernels wa, wb on input rows r0, r1, r2 at x (output row y), and a1, b1[x] on
    # r1, r2, r3 (output row y + 1): 18 weights stay in registers, each input value is loaded once for
    # 36 multiply-adds (four channels of one row needed 36 weights, 17 of them reloaded from the stack)
    for x in range(cols):
        u0 = r0[x]
        u1 = r0[x + 1]
        u2 = r0[x + 2]
        v0 = r1[x]
        v1 = r1[x + 1]
        v2 = r1[x + 2]
        s0 = r2[x]
        s1 = r2[x + 1]
        s2 = r2[x + 2]
        t0 = r3[x]
        t1 = r3[x + 1]
        t2 = r3[x + 2]
        a0[x] += nine_taps(wa, u0, u1, u2, v0, v1, v2, s0, s1, s2)
        b0[x] += nine_taps(wb, u0, u1, u2, v0, v1, v2, s0, s1, s2)
        a1[x] += nine_taps(wa, v0, v1, v2, s0, s1, s2, t0, t1, t2)
        b1[x] += nine_taps(wb, v0, v1, v2, s0, s1, s2, t0, t1, t2)


@njit(fastmath={"contract"}, inline="always")
def one_channel_two_rows(r0, r1, r2, r3, wa, a0, a1, cols):
    # a0[x] += the 3×3 kernel wa on input rows r0, r1, r2 at x, and a1[x] on r1, r2, r3
    for x in range(cols):
        a0[x] += nine_taps(wa, r0[x], r0[x + 1], r0[x + 2], r1[x], r1[x + 1], r1[x + 2], r2[x], r2[x + 1], r2[x + 2])
        a1[x] += nine_taps(wa, r1[x], r1[x + 1], r1[x + 2], r2[x], r2[x + 1], r2[x + 2], r3[x], r3[x + 1], r3[x + 2])


@njit
def store_row(src, dst, slope, act):
    # dst[1 : w + 1] = src, through LeakyReLU when act
    for x in range(src.shape[0]):
        v = src[x]
        if act and v < 0:
            v *= slope
        dst[x + 1] = v


@njit(parallel=True, fastmath={"contract"}, error_model="numpy")
def conv3x3_direct(xp, xq, weight, bias, slope, act, rows, cols, out):
    # xp: (n, cp, h + 2, w + 2) float32, zero border; xq: (n, cq, h + 2, w + 2) float32, zero border,
    # the input channels that follow xp's (cq may be 0: the skip half of a concatenation, read where
    # it lies instead of copied); weight: (cout, cp + cq, 3, 3) float32; bias: (cout,) float32;
    # out: (n, cout, h + 2, w + 2) float32 -- the interior's first `rows` rows and `cols` columns
    # are written, the rest of the interior and the border are left to the caller (an output that
    # only its first rows and columns are wanted of needs only those of each layer before it, one
    # more per layer).  One job = two output rows of two output channels (a last channel alone is
    # computed once; a last row alone computes a throw-away second row that is not stored).  fastmath
    # "contract" allows only the fusion of a product and a sum into one FMA; no reassociation, so every
    # value is summed in the same order whatever rows, cols and the thread count are.
    n, cp, hp, wp = xp.shape
    cq = xq.shape[1]
    cout = weight.shape[0]
    groups = (cout + 1) // 2
    pairs = (rows + 1) // 2
    for job in prange(n * groups * pairs):
        i, g, p = split_job(job, groups, pairs)
        y = 2 * p
        second = y + 1 < rows  # row y + 1 is wanted (else a row of rows y + 1, y + 2, y + 2 is computed, not stored)
        below = y + 3 if second else y + 2
        o0 = 2 * g
        o1 = o0 + 1
        lone = o1 == cout  # a last output channel alone (the tail's single output)
        # Fresh rows, so LLVM knows they alias neither each other nor the input (the four rows of one
        # (4, cols) allocation instead: 8x slower, 165 ms a 250x400 pass against 16-20, 2026-11-25).
        rest = 0 if lone else cols  # a lone channel needs no b0, b1
        a0 = np.empty(cols, dtype=np.float32)
        a1 = np.empty(cols, dtype=np.float32)
        b0 = np.empty(rest, dtype=np.float32)
        b1 = np.empty(rest, dtype=np.float32)
        a0[:] = bias[o0]
        a1[:] = bias[o0]
        if not lone:
            b0[:] = bias[o1]
            b1[:] = bias[o1]
        for ci in range(cp + cq):  # xp's channels, then xq's
            src = xp[i, ci] if ci < cp else xq[i, ci - cp]
            if lone:
                one_channel_two_rows(src[y], src[y + 1], src[y + 2], src[below], weight[o0, ci], a0, a1, cols)
            else:
                two_channel_two_rows(src[y], src[y + 1], src[y + 2], src[below], weight[o0, ci], weight[o1, ci],
                                     a0, b0, a1, b1, cols)
        store_row(a0, out[i, o0, y + 1], slope, act)
        if not lone:
            store_row(b0, out[i, o1, y + 1], slope, act)
        if second:
            store_row(a1, out[i, o0, y + 2], slope, act)
            if not lone:
                store_row(b1, out[i, o1, y + 2], slope, act)


@njit(parallel=True)
def maxpool_into(t, out):
    # t: (n, c, h + 2, w + 2) with a border; out: (n, c, h/2 + 2, w/2 + 2), interior written:
    # 2×2 max-pooling of t's interior.
    n, c, hp, wp = out.shape
    h2 = hp - 2
    w2 = wp - 2
    for job in prange(n * c * h2):
        i, k, y = split_job(job, c, h2)
        top = t[i, k, 2 * y + 1]
        bottom = t[i, k, 2 * y + 2]
        dst = out[i, k, y + 1]
        for x in range(w2):
            dst[x + 1] = max(max(top[2 * x + 1], top[2 * x + 2]), max(bottom[2 * x + 1], bottom[2 * x + 2]))


@njit(parallel=True)
def upsample_into(low, rows, cols, out):
    # low: (n, c, h/2 + 2, w/2 + 2) with a border; out: (n, c, h + 2, w + 2): the nearest ×2 of
    # low's interior written into out's first `rows` rows and `cols` columns of the interior.
    n, c = out.shape[0], out.shape[1]
    for job in prange(n * c * rows):
        i, k, y = split_job(job, c, rows)
        dst = out[i, k, y + 1]
        src = low[i, k, y // 2 + 1]
        for x in range(cols):
            dst[x + 1] = src[x // 2 + 1]


def padded_empty(n: int, c: int, h: int, w: int) -> np.ndarray:
    """``(n, c, h + 2, w + 2) float32`` with a zero border and an uninitialised interior."""
    buf = np.empty((n, c, h + 2, w + 2), dtype=np.float32)
    buf[:, :, 0, :] = 0
    buf[:, :, -1, :] = 0
    buf[:, :, :, 0] = 0
    buf[:, :, :, -1] = 0
    return buf


class _Buffers:
    """The activation buffers of one thread's forward passes, kept for its next passes of the same size.

    A fresh buffer of several MB is memory the operating system maps on first touch, page by page
    (it zero-fills each page): at 250×400 that was ~5.5 ms of a 28 ms forward pass.  The buffers a
    pass releases (an activation no later layer reads) are handed to the next request of the same
    shape, in this pass or a later one, so a stream of frames of one size touches new memory only in
    its first pass.  Kept, per input size, is for each buffer shape the most buffers of that shape a
    pass has live at once: for the four 128×224 planes of a 250×400 frame and width 16, 35 MB (45 MB
    while each concatenation was copied, until 2026-11-25).  The buffers of the two most recent input
    sizes are kept (the blind and mixed modes alternate two batch sizes); :func:`release_buffers` frees
    them.  The border of every buffer stays zero: the kernels write interiors only.  Every interior
    pixel is written before it is read, except where the last layers make only what the output keeps:
    there a stale pixel is read only into pixels the output drops.
    """

    KEEP_SIZES = 2

    def __init__(self):
        self.by_size: dict[tuple, dict[tuple, list]] = {}  # input size → buffer shape → free buffers
        self.free: dict[tuple, list] = {}

    def start(self, size) -> None:
        """Begin a pass on input ``size``; ``None`` drops every kept buffer."""
        if size is None:
            self.by_size, self.free = {}, {}
            return
        self.free = self.by_size.pop(size, {})
        self.by_size[size] = self.free  # most recent last
        while len(self.by_size) > self.KEEP_SIZES:
            del self.by_size[next(iter(self.by_size))]

    def take(self, n: int, c: int, h: int, w: int) -> np.ndarray:
        stack = self.free.get((n, c, h, w))
        return stack.pop() if stack else padded_empty(n, c, h, w)

    def give(self, buf: np.ndarray) -> None:
        n, c, hp, wp = buf.shape
        self.free.setdefault((n, c, hp - 2, wp - 2), []).append(buf)

    def nbytes(self) -> int:
        return sum(b.nbytes for free in self.by_size.values() for stack in free.values() for b in stack)


_THREAD = threading.local()  # each thread its own buffers: two threads may run one network at once


def buffers() -> _Buffers:
    """The calling thread's kept activation buffers."""
    pool = getattr(_THREAD, "buffers", None)
    if pool is None:
        pool = _THREAD.buffers = _Buffers()
    return pool


def release_buffers() -> int:
    """Free the activation buffers the U-Net keeps for the calling thread's next passes; returns the bytes freed.

    Forward passes keep their buffers for the next passes of the same size
    (:class:`spikeref.denoise.unet.UNet`): call this when a thread is done with the network and its
    memory is wanted back.
    """
    pool = buffers()
    freed = pool.nbytes()
    pool.start(None)
    return freed
