"""Oracle for the ``.dat`` bit layout (docs/spec/io.md): LSB-first bits, rows bottom-up (or top-down when told)."""

import numpy as np

from spikeref.oracles.case import OracleCase

__all__ = ["pack_dat_oracle", "unpack_dat_oracle", "GOLDEN_CASES"]


def pack_dat_oracle(spikes, rows="bottom-up"):
    """Bytes of a ``.dat`` file for upright ``(T, H, W)`` 0/1 planes, bit by bit (rows stored ``rows``)."""
    if rows not in ("bottom-up", "top-down"):
        raise ValueError(f"rows must be 'bottom-up' or 'top-down'; got {rows!r}")
    t_total, h, w = spikes.shape
    out = bytearray(t_total * h * w // 8)
    for t in range(t_total):
        for stored_row in range(h):
            # rows are stored bottom-up (the spike camera's), or top-down when told
            image_row = h - 1 - stored_row if rows == "bottom-up" else stored_row
            for x in range(w):
                p = t * h * w + stored_row * w + x  # pixel index in the file
                if spikes[t, image_row, x]:
                    out[p // 8] |= 1 << (p % 8)  # pixel p is bit p % 8 of byte p // 8
    return np.frombuffer(bytes(out), dtype=np.uint8)


def unpack_dat_oracle(data, height, width, file_width=None, col_offset=0, rows="bottom-up"):
    """Upright ``(T, H, W)`` planes from ``.dat`` bytes, bit by bit (crop to ``width``; rows stored ``rows``)."""
    if rows not in ("bottom-up", "top-down"):
        raise ValueError(f"rows must be 'bottom-up' or 'top-down'; got {rows!r}")
    file_width = width if file_width is None else file_width
    data = np.asarray(data, dtype=np.uint8).ravel()
    n_planes = data.size * 8 // (height * file_width)
    spikes = np.zeros((n_planes, height, width), dtype=np.uint8)
    for t in range(n_planes):
        for stored_row in range(height):
            image_row = height - 1 - stored_row if rows == "bottom-up" else stored_row
            for x in range(width):
                p = t * height * file_width + stored_row * file_width + col_offset + x
                spikes[t, image_row, x] = (data[p // 8] >> (p % 8)) & 1
    return spikes


# ----------------------------------------------------------------------------- the golden cases
def _inputs_dat():
    rng1, rng2 = np.random.default_rng(1), np.random.default_rng(2)
    return {"spikes": (rng1.random((3, 4, 8)) < 0.5).astype(np.uint8),
            "wide_spikes": (rng2.random((2, 2, 16)) < 0.5).astype(np.uint8)}


GOLDEN_CASES = (
    OracleCase(
        "dat_layout", "— (storage: the spike-camera .dat layout, not in the paper)",
        "spikeref.io.dat.pack_planes / unpack_planes", "spikeref.oracles.dat.pack_dat_oracle",
        "Bytes of a .dat file: LSB-first bits, rows bottom-up; and a 16-wide stored row cropped to its first 12 "
        "columns (column offset 0).",
        _inputs_dat,
        lambda i: {"bytes": pack_dat_oracle(i["spikes"]),
                   "cropped": unpack_dat_oracle(pack_dat_oracle(i["wide_spikes"]), 2, 12, 16)},
        spec="docs/spec/io.md#dat_layout",
    ),
)
