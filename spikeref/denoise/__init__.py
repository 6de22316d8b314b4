"""Self-supervised chromatic spike denoising (§4.1): blind-spot volume and averaging (Eq. 10–11), Eq. 12 loss."""

from spikeref.denoise.blindspot import blindspot_denoise, cell_masks, mask_aware_average, masked_volume
from spikeref.denoise.revisible import lambda_schedule, revisible_loss

__all__ = [
    "blindspot_denoise",
    "cell_masks",
    "masked_volume",
    "mask_aware_average",
    "revisible_loss",
    "lambda_schedule",
]
