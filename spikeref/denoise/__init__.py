"""Self-supervised chromatic spike denoising (§4.1): blind-spot volume and mask-aware averaging (Eq. 10–11)."""

from spikeref.denoise.blindspot import blindspot_denoise, cell_masks, mask_aware_average, masked_volume

__all__ = ["blindspot_denoise", "cell_masks", "masked_volume", "mask_aware_average"]
