"""Self-supervised chromatic spike denoising (§4.1): U-Net inference, blind-spot volume and
averaging (Eq. 10–11), the Eq. 12 loss; training lives in :mod:`spikeref.denoise.train` (PyTorch);
classical peers (BM3D, NLM, Gaussian; extra ``peers``) in :mod:`spikeref.denoise.peers`."""

import importlib

_EXPORTS = {
    "blindspot_denoise": "spikeref.denoise.blindspot",
    "cell_masks": "spikeref.denoise.blindspot",
    "masked_volume": "spikeref.denoise.blindspot",
    "mask_aware_average": "spikeref.denoise.blindspot",
    "revisible_loss": "spikeref.denoise.revisible",
    "lambda_schedule": "spikeref.denoise.revisible",
    "UNet": "spikeref.denoise.unet",
    "UNetSpec": "spikeref.denoise.unet",
    "Denoiser": "spikeref.denoise.denoiser",
    "PeerDenoiser": "spikeref.denoise.peers",
    "PEERS": "spikeref.denoise.peers",
}

__all__ = list(_EXPORTS)


def __getattr__(name):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'spikeref.denoise' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
