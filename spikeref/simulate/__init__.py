"""Chromatic spike simulator: Eq. 1–3 integrate-and-fire behind a Bayer CFA."""

from spikeref.simulate.camera import Camera, fire, mosaic_radiance

__all__ = ["Camera", "fire", "mosaic_radiance"]
