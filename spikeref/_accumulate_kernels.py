"""The kernels of Eq. 4 (:mod:`spikeref.accumulate` reads like the equation; the speed is here).

Two kernels count spikes: one over unpacked ``(T, H, W) uint8`` planes and one
directly over the packed ``.dat`` bytes of a memory-mapped stream.  The packed
kernel never unpacks a plane: it keeps *bit-sliced* counters (bit ``k`` of the
count of 64 pixels in one machine word per level ``k``), adds each packed word
with a ripple of XOR/AND over the ``⌈log2(W+1)⌉`` levels — 64 pixels per
operation; the fast path takes planes in pairs through a carry-save adder — and
expands the counters to per-pixel counts once per window with two bit-matrix
transposes (8 pixels' counts per 64-bit store).

Nothing here checks its arguments: :func:`spikeref.accumulate.window_counts` does.
"""

from __future__ import annotations

import numpy as np

from spikeref._jit import njit, prange

__all__ = ["count_windows", "count_unpacked", "count_packed", "count_packed_bytes8", "counts_to_rates",
           "packed_words"]

_WORD_CHUNK = 256  # words per parallel task in the packed kernel (fits L1 with its counters)


@njit(parallel=True)
def count_unpacked(spikes, t0, window, nwin, out):
    # spikes (T, H, W) uint8; out (nwin, H, W) uint16/uint32: out[k] = sum of planes [t0+kW, t0+(k+1)W)
    h = spikes.shape[1]
    w = spikes.shape[2]
    for task in prange(nwin * h):
        k = task // h
        y = task % h
        acc = np.zeros(w, dtype=np.uint32)
        base = t0 + k * window
        for t in range(base, base + window):
            for x in range(w):
                acc[x] += spikes[t, y, x]
        for x in range(w):
            out[k, y, x] = acc[x]


@njit(inline="always")
def _ripple(levels, carry, first, nlev, n):
    # add the carry words into the bit-sliced counters from level `first` up (XOR = sum bit,
    # AND = carry to the next level), 64 pixels per operation
    for lev in range(first, nlev):
        for j in range(n):
            c = levels[lev, j]
            levels[lev, j] = c ^ carry[j]
            carry[j] = c & carry[j]


@njit(parallel=True)
def count_packed(words, t0, window, nwin, nlev, bits_per_word, height, file_width, width, col_offset, out):
    # words (T, nw) uint8/16/32/64: packed planes viewed as little-endian words, so pixel p of the
    # stored plane is bit (p % bits_per_word) of word p // bits_per_word.
    nw = words.shape[1]
    nchunk = (nw + _WORD_CHUNK - 1) // _WORD_CHUNK
    for task in prange(nwin * nchunk):
        k = task // nchunk
        j0 = (task % nchunk) * _WORD_CHUNK
        j1 = min(nw, j0 + _WORD_CHUNK)
        n = j1 - j0
        levels = np.zeros((nlev, n), dtype=words.dtype)
        carry = np.empty(n, dtype=words.dtype)
        base = t0 + k * window
        for t in range(base, base + window):
            for j in range(n):
                carry[j] = words[t, j0 + j]
            _ripple(levels, carry, 0, nlev, n)
        # expand the bit-sliced counters into per-pixel counts, upright and cropped
        for j in range(n):
            for b in range(bits_per_word):
                p = (j0 + j) * bits_per_word + b
                col = p % file_width - col_offset
                if col < 0 or col >= width:
                    continue
                row = height - 1 - p // file_width
                v = 0
                for lev in range(nlev):
                    v |= int((levels[lev, j] >> np.uint64(b)) & np.uint64(1)) << lev
                out[k, row, col] = v


@njit(inline="always")
def _transpose8(x):
    # Transpose the 8×8 bit matrix held in a uint64 (element (r, c) at bit 8r + c) with three
    # rounds of masked swaps (2×2, 4×4 then 8×8 blocks; Warren, Hacker's Delight §7-3).
    t = (x ^ (x >> np.uint64(7))) & np.uint64(0x00AA00AA00AA00AA)
    x = x ^ t ^ (t << np.uint64(7))
    t = (x ^ (x >> np.uint64(14))) & np.uint64(0x0000CCCC0000CCCC)
    x = x ^ t ^ (t << np.uint64(14))
    t = (x ^ (x >> np.uint64(28))) & np.uint64(0x00000000F0F0F0F0)
    x = x ^ t ^ (t << np.uint64(28))
    return x


@njit(inline="always")
def _transpose_lanes8(r0, r1, r2, r3, r4, r5, r6, r7):
    # Eight words seen as eight byte lanes, each lane an 8×8 bit matrix (row = word, column =
    # bit of the lane's byte): transpose every lane at once, so bit c of byte i of word r moves to
    # bit r of byte i of word c.  Blocks of 4, 2, then 1 rows are swapped with masked XORs.
    m4 = np.uint64(0x0F0F0F0F0F0F0F0F)
    m2 = np.uint64(0x3333333333333333)
    m1 = np.uint64(0x5555555555555555)
    s4, s2, s1 = np.uint64(4), np.uint64(2), np.uint64(1)
    x = ((r0 >> s4) ^ r4) & m4
    r4 ^= x
    r0 ^= x << s4
    x = ((r1 >> s4) ^ r5) & m4
    r5 ^= x
    r1 ^= x << s4
    x = ((r2 >> s4) ^ r6) & m4
    r6 ^= x
    r2 ^= x << s4
    x = ((r3 >> s4) ^ r7) & m4
    r7 ^= x
    r3 ^= x << s4
    x = ((r0 >> s2) ^ r2) & m2
    r2 ^= x
    r0 ^= x << s2
    x = ((r1 >> s2) ^ r3) & m2
    r3 ^= x
    r1 ^= x << s2
    x = ((r4 >> s2) ^ r6) & m2
    r6 ^= x
    r4 ^= x << s2
    x = ((r5 >> s2) ^ r7) & m2
    r7 ^= x
    r5 ^= x << s2
    x = ((r0 >> s1) ^ r1) & m1
    r1 ^= x
    r0 ^= x << s1
    x = ((r2 >> s1) ^ r3) & m1
    r3 ^= x
    r2 ^= x << s1
    x = ((r4 >> s1) ^ r5) & m1
    r5 ^= x
    r4 ^= x << s1
    x = ((r6 >> s1) ^ r7) & m1
    r7 ^= x
    r6 ^= x << s1
    return r0, r1, r2, r3, r4, r5, r6, r7


@njit(inline="always")
def _csa_level0(levels, carry, planes, t, j0, n):
    # level 0 + planes[t] + planes[t + 1] (columns j0 …): sum bit into level 0, carry out
    for j in range(n):
        a = np.uint64(planes[t, j0 + j])
        b = np.uint64(planes[t + 1, j0 + j])
        o = levels[0, j]
        u = o ^ a
        levels[0, j] = u ^ b
        carry[j] = (o & a) | (u & b)


@njit(parallel=True)
def count_packed_bytes8(words, t0, window, nwin, nlev, height, file_width, col_offset, out8):
    # Fast path: rows a multiple of 8 pixels, window <= 255 (nlev <= 8).  `words` are the packed
    # planes viewed as little-endian uint64 (T, nw) or, when a plane's bytes are not a multiple of
    # 8, as uint32 (T, nw32) joined in pairs into 64-bit words (the last one half empty when nw32
    # is odd).  out8 is the uint8 output (nwin, H, W) viewed as uint64 (nwin, H, W/8): one store
    # writes the counts of 8 pixels.
    pairs = words.itemsize == 4
    nw32 = words.shape[1]
    nw = (nw32 + 1) // 2 if pairs else nw32
    nbytes = words.itemsize * nw32
    wout8 = out8.shape[2]
    fw8 = file_width // 8
    off8 = col_offset // 8
    nchunk = (nw + _WORD_CHUNK - 1) // _WORD_CHUNK
    s32 = np.uint64(32)
    for task in prange(nwin * nchunk):
        k = task // nchunk
        j0 = (task % nchunk) * _WORD_CHUNK
        j1 = min(nw, j0 + _WORD_CHUNK)
        n = j1 - j0
        whole = n - 1 if (pairs and j1 == nw and nw32 % 2 == 1) else n  # words with both halves
        levels = np.zeros((8, n), dtype=np.uint64)  # levels >= nlev stay zero
        carry = np.empty(n, dtype=np.uint64)
        joined = np.empty((2, n), dtype=np.uint64)  # the uint32 pairs of two planes, joined
        t = t0 + k * window
        end = t + window
        while t < end:
            two = t + 1 < end
            if pairs:
                for i in range(2 if two else 1):
                    for j in range(whole):
                        jj = 2 * (j0 + j)
                        joined[i, j] = np.uint64(words[t + i, jj]) | (np.uint64(words[t + i, jj + 1]) << s32)
                    if whole < n:
                        joined[i, whole] = np.uint64(words[t + i, nw32 - 1])
            if two:
                # two planes at once: a carry-save (full) adder of level 0 with both planes
                # leaves their sum's bit 0 in level 0 and its carry for level 1
                if pairs:
                    _csa_level0(levels, carry, joined, 0, 0, n)
                else:
                    _csa_level0(levels, carry, words, t, j0, n)
                first = 1
                t += 2
            else:
                for j in range(n):
                    carry[j] = joined[0, j] if pairs else np.uint64(words[t, j0 + j])
                first = 0
                t += 1
            _ripple(levels, carry, first, nlev, n)
        # Expand to byte counts.  After _transpose8, bit q of byte i of level word `lev` is bit
        # `lev` of the count of pixel 8q + i; the lane transpose of the eight level words then
        # puts that bit at bit `lev` of byte i of word q: word q holds the counts of 8q..8q+7.
        for lev in range(nlev):
            for j in range(n):
                levels[lev, j] = _transpose8(levels[lev, j])
        # stored byte b holds pixels 8b..8b+7: stored row b // fw8, column group b % fw8
        col8 = (j0 * 8) % fw8
        row = height - 1 - (j0 * 8) // fw8
        for j in range(n):
            q0, q1, q2, q3, q4, q5, q6, q7 = _transpose_lanes8(
                levels[0, j], levels[1, j], levels[2, j], levels[3, j],
                levels[4, j], levels[5, j], levels[6, j], levels[7, j],
            )
            # q0 … q7: the counts of pixels 8q..8q+7 of word j
            c8 = col8 - off8
            if c8 >= 0 and c8 + 8 <= wout8 and col8 + 8 <= fw8 and (j0 + j) * 8 + 8 <= nbytes:
                # all 8 groups in one output row: stored from registers
                out8[k, row, c8] = q0
                out8[k, row, c8 + 1] = q1
                out8[k, row, c8 + 2] = q2
                out8[k, row, c8 + 3] = q3
                out8[k, row, c8 + 4] = q4
                out8[k, row, c8 + 5] = q5
                out8[k, row, c8 + 6] = q6
                out8[k, row, c8 + 7] = q7
                col8 += 8
                if col8 == fw8:
                    col8 = 0
                    row -= 1
                continue
            # a word across a row end, the cropped columns or the plane's end: group by group,
            # through the (no longer needed) level rows
            (levels[0, j], levels[1, j], levels[2, j], levels[3, j],
             levels[4, j], levels[5, j], levels[6, j], levels[7, j]) = q0, q1, q2, q3, q4, q5, q6, q7
            for q in range(8):
                if (j0 + j) * 8 + q >= nbytes:
                    break
                c8 = col8 - off8
                if c8 >= 0 and c8 < wout8:
                    out8[k, row, c8] = levels[q, j]
                col8 += 1
                if col8 == fw8:
                    col8 = 0
                    row -= 1


@njit(parallel=True)
def counts_to_rates(counts, gain, out):
    # out[k] = counts[k] * gain; gain (H, W) float32 = M_c / W per pixel, or (1, 1) for one gain
    nwin, h, w = counts.shape
    uniform = gain.shape[0] == 1 and gain.shape[1] == 1
    g0 = gain[0, 0]
    for task in prange(nwin * h):
        k = task // h
        y = task % h
        if uniform:
            for x in range(w):
                out[k, y, x] = counts[k, y, x] * g0
        else:
            for x in range(w):
                out[k, y, x] = counts[k, y, x] * gain[y, x]


def packed_words(packed: np.ndarray) -> tuple[np.ndarray, int]:
    """View packed planes as the widest little-endian word that divides a plane."""
    nbytes = packed.shape[1]
    for size, dtype in ((8, "<u8"), (4, "<u4"), (2, "<u2")):
        if nbytes % size == 0 and packed.strides[1] == 1 and packed.strides[0] % size == 0:
            try:
                return packed.view(dtype), 8 * size
            except ValueError:
                break
    return packed, 8


def count_windows(stream, window: int, start: int, count: int, out: np.ndarray) -> np.ndarray:
    """Eq. 4's sums into ``out`` ``(count, H, W)`` with the kernel that fits the stream (arguments checked).

    An unpacked stream: :func:`count_unpacked`.  A packed one: :func:`count_packed_bytes8` when the
    counts fit uint8 and the columns are whole bytes (the common case), else :func:`count_packed`.
    Both packed kernels place stored row ``r`` at image row ``H - 1 - r`` (rows stored bottom-up); for
    a stream whose bytes store the rows top-down (``stream.rows == "top-down"``) the counted rows are
    flipped afterwards, so ``out`` is upright either way.
    """
    if not stream.is_packed:
        count_unpacked(stream.array, start, window, count, out)
        return out
    words, bits = packed_words(stream.packed)
    nlev = int(window).bit_length()
    if (bits >= 32 and out.dtype == np.uint8 and stream.width % 8 == 0
            and stream.file_width % 8 == 0 and stream.col_offset % 8 == 0):
        count_packed_bytes8(words if bits == 64 else words.view("<u4"), start, window, count, nlev,
                            stream.height, stream.file_width, stream.col_offset, out.view("<u8"))
    else:
        count_packed(words, start, window, count, nlev, bits, stream.height, stream.file_width,
                     stream.width, stream.col_offset, out)
    if stream.rows == "top-down":  # the kernels read stored row r as image row H - 1 - r: turn them upright
        out[...] = out[:, ::-1].copy()
    return out
