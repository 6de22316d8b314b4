"""Oracle for the ``.dat`` bit layout (docs/spec/io.md): LSB-first bits, rows bottom-up."""

import numpy as np

__all__ = ["pack_dat_oracle", "unpack_dat_oracle"]


def pack_dat_oracle(spikes):
    """Bytes of a ``.dat`` file for upright ``(T, H, W)`` 0/1 planes, bit by bit."""
    t_total, h, w = spikes.shape
    out = bytearray(t_total * h * w // 8)
    for t in range(t_total):
        for stored_row in range(h):
            image_row = h - 1 - stored_row  # rows are stored bottom-up
            for x in range(w):
                p = t * h * w + stored_row * w + x  # pixel index in the file
                if spikes[t, image_row, x]:
                    out[p // 8] |= 1 << (p % 8)  # pixel p is bit p % 8 of byte p // 8
    return np.frombuffer(bytes(out), dtype=np.uint8)


def unpack_dat_oracle(data, height, width, file_width=None, col_offset=0):
    """Upright ``(T, H, W)`` planes from ``.dat`` bytes, bit by bit (crop to ``width``)."""
    file_width = width if file_width is None else file_width
    data = np.asarray(data, dtype=np.uint8).ravel()
    n_planes = data.size * 8 // (height * file_width)
    spikes = np.zeros((n_planes, height, width), dtype=np.uint8)
    for t in range(n_planes):
        for stored_row in range(height):
            for x in range(width):
                p = t * height * file_width + stored_row * file_width + col_offset + x
                spikes[t, height - 1 - stored_row, x] = (data[p // 8] >> (p % 8)) & 1
    return spikes
