"""Make the three small frames that ``video.toml`` simulates as shipped (``video_frames/``).

A 32×48 sRGB scene: a horizontal colour gradient (red → green → blue, darker at the bottom)
with a white disc of radius 6 that moves 8 pixels to the right from frame to frame.  Run from
anywhere; the frames are written beside this script::

    python examples/scenes/make_video_frames.py

The PNGs are small (a few kB) and deterministic; replace them, or point ``path`` in
``video.toml`` at your own video or image sequence.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HEIGHT, WIDTH, FRAMES = 32, 48, 3
RADIUS, START_X, STEP_X = 6.0, 12.0, 8.0
OUT = Path(__file__).resolve().parent / "video_frames"


def frame(i: int) -> np.ndarray:
    """Frame ``i`` as ``(HEIGHT, WIDTH, 3) uint8`` sRGB."""
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    u = x / (WIDTH - 1)  # 0 at the left, 1 at the right
    rgb = np.stack([np.clip(1 - 2 * u, 0, 1), 1 - np.abs(2 * u - 1), np.clip(2 * u - 1, 0, 1)], axis=-1)
    rgb *= (0.8 - 0.5 * y / (HEIGHT - 1))[..., None]  # darker towards the bottom
    inside = (y - HEIGHT / 2 + 0.5) ** 2 + (x - START_X - STEP_X * i) ** 2 <= RADIUS**2
    rgb[inside] = 1.0
    return np.round(255 * rgb).astype(np.uint8)


def main() -> None:
    import imageio.v3 as iio

    OUT.mkdir(exist_ok=True)
    for i in range(FRAMES):
        iio.imwrite(OUT / f"frame_{i:03d}.png", frame(i))
    print(f"wrote {FRAMES} frames of {HEIGHT}×{WIDTH} to {OUT}")


if __name__ == "__main__":
    main()
