"""The regularised re-visible loss of Eq. 12 (§4.1, after Blind2Unblind).

.. math::

    L_r = \\lVert D(I) + \\lambda\\, sg(f_\\theta(I)) - (\\lambda + 1) I \\rVert_2^2
          + \\eta \\lVert D(I) - I \\rVert_2^2

``D(I)`` is the blind output (Eq. 10–11), ``f_θ(I)`` the visible output (the network on the
unmasked frame), ``I`` the noisy frame.  Interpretations (``docs/equations.md``): ``sg`` is a
stop-gradient on the visible term (as in Blind2Unblind's code; the paper's Eq. 12 does not
mark it); each squared norm is a **mean** over pixels (mean squared error), so the loss does
not scale with the crop size; ``η = 1``; ``λ`` rises from 2 to 20 over training
(:func:`lambda_schedule`).  The image-quality term ``λ_i L_i`` needs a pretrained IQA model
that cannot be shipped and is omitted.

:func:`revisible_loss` is the NumPy transcription (forward value only); the PyTorch version
used for training is :func:`revisible_loss_torch` (extra ``train``); tests hold them equal.
"""

from __future__ import annotations

import numpy as np

__all__ = ["revisible_loss", "revisible_loss_torch", "lambda_schedule"]


def _check(name, a):
    a = np.asarray(a, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return a


def revisible_loss(blind, visible, noisy, lam: float, eta: float = 1.0) -> float:
    """Eq. 12 in NumPy: ``mean((D + λ f − (λ+1) I)²) + η mean((D − I)²)``.

    Parameters
    ----------
    blind, visible, noisy : ndarray, same shape
        ``D(I)``, ``f_θ(I)`` and ``I`` (firing rates).
    lam, eta : float
        ``λ ≥ 0`` and ``η ≥ 0``.
    """
    d, f, i = _check("blind", blind), _check("visible", visible), _check("noisy", noisy)
    if not (d.shape == f.shape == i.shape):
        raise ValueError(f"blind, visible and noisy must have one shape; got {d.shape}, {f.shape}, {i.shape}")
    if not (np.isfinite(lam) and lam >= 0 and np.isfinite(eta) and eta >= 0):
        raise ValueError(f"lam and eta must be non-negative; got {lam!r}, {eta!r}")
    rev = np.mean((d + lam * f - (lam + 1.0) * i) ** 2)
    reg = np.mean((d - i) ** 2)
    return float(rev + eta * reg)


def revisible_loss_torch(blind, visible, noisy, lam: float, eta: float = 1.0, weight=None):
    """Eq. 12 in PyTorch, with the stop-gradient on the visible term (``visible.detach()``).

    ``weight`` (optional, broadcastable to ``blind``, 0 or 1): take both means over the pixels
    where it is 1 only — the pixels whose blind value ``D(I)`` was computed, when a training step
    runs only some of the masks (:attr:`spikeref.denoise.train.TrainConfig.masks_per_step`).
    ``weight=None`` and an all-ones weight give the same value.
    """
    import torch

    if weight is None:
        rev = torch.mean((blind + lam * visible.detach() - (lam + 1.0) * noisy) ** 2)
        reg = torch.mean((blind - noisy) ** 2)
        return rev + eta * reg
    weight = torch.broadcast_to(weight, blind.shape).to(blind.dtype)
    total = weight.sum().clamp(min=1.0)
    rev = (weight * (blind + lam * visible.detach() - (lam + 1.0) * noisy) ** 2).sum() / total
    reg = (weight * (blind - noisy) ** 2).sum() / total
    return rev + eta * reg


def lambda_schedule(progress: float, start: float = 2.0, end: float = 20.0) -> float:
    """``λ`` at ``progress`` ∈ [0, 1] of training: linear from ``start`` to ``end`` (the paper's 2 → 20)."""
    if not (np.isfinite(progress) and 0.0 <= progress <= 1.0):
        raise ValueError(f"progress must lie in [0, 1]; got {progress!r}")
    return start + (end - start) * progress
