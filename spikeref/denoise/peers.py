"""Classical peer denoisers, run the way a user of this field would run them off the shelf.

Not in the paper.  The benchmark's stage ladder (:mod:`spikeref.bench.ladder`) has the classical peer
on the same single window (BM3D, non-local means) as a rung: the spike denoiser has to beat what a
practitioner gets by handing one window's firing-rate planes (Eq. 4, ``count / W``) to a
textbook image denoiser.  This module is that practitioner.  "Off the shelf" means the
libraries' documented calls with the parameters below and nothing tuned on our data:

* ``bm3d``: :func:`bm3d.bm3d` ``(plane, sigma_psd=σ)`` with its default profile (``"np"``).
* ``nlm``: :func:`skimage.restoration.denoise_nl_means` ``(plane, h=0.8·σ, sigma=σ,
  patch_size=5, patch_distance=6, fast_mode=True)`` (the parameters of scikit-image's
  own NLM example).
* ``gaussian``: :func:`scipy.ndimage.gaussian_filter` ``(plane, gaussian_sigma, mode="reflect")``;
  it uses no noise level.

Each Bayer plane (R, G1, G2, B) is denoised on its own, as a grey image.  The noise level σ
(rate units, i.e. spikes per readout) is, per plane:

* ``"blind"`` (default): :func:`skimage.restoration.estimate_sigma` of the plane (wavelet MAD),
  what a user without a noise model does;
* ``"spike"``: the spike-noise-aware σ we can give the peer.  A rate read from ``W`` independent
  Bernoulli readouts with probability ``p`` has variance ``p(1 − p)/W``; one σ per plane is

  .. math:: \\sigma = \\sqrt{\\operatorname{mean}_{x}\\; \\hat p(x)\\,(1 - \\hat p(x)) / W},
            \\qquad \\hat p = \\operatorname{clip}(\\text{plane}, 0, 1)

  (the plane's mean binomial variance; both peers take a single, stationary σ).  Plugging the
  noisy ``p̂`` in for ``p`` errs low by a factor ``sqrt(1 − 1/W)`` for binomial counts
  (``E[p̂(1 − p̂)] = p(1 − p)(1 − 1/W)``, 5 % at ``W = 10``); no correction is applied, so the
  figure is exactly what the formula gives and a reader can recompute it;
* a positive float: that σ for every plane.

A flat plane, or a σ of 0, returns the plane unchanged (for ``"bm3d"`` and ``"nlm"``; the blind
estimate of a flat plane is ~1e-33 or NaN, and is taken as 0 when NaN).

BM3D and scale.  BM3D's thresholds are multiples of ``sigma_psd`` and its transforms are linear,
so scaling the plane and σ by the same factor scales the output by that factor, up to its
internal rounding: rescaling a plane to ``[0, 1]`` by its maximum (and undoing it) changes next
to nothing.  Measured on 125 × 200 planes of binomial rates (``W = 10``, smooth truth in
[0.1, 0.6], [0.02, 0.3], [0.01, 0.1]; plane maxima 1.0, 0.8, 0.6), the MSE against the truth with
and without that rescaling agreed to four significant digits (4.245e-4, 2.299e-4, 9.777e-5), the
largest pixel difference 2e-3 against a noise σ of 0.08.  Rates already lie in ``[0, 1]``, so
the plane is passed as it is (what a user would do): no rescaling.

BM3D needs planes of at least 9 × 9 pixels (bm3d 4.0.3 refuses smaller ones and crashes the
interpreter on exactly 8 × 8, so the call refuses those first).

Licences.  ``bm3d`` (Tampere University) is free for non-commercial use only; scikit-image is BSD.  It is an optional
extra for comparison (``pip install "spikeref[peers]"``), never a runtime dependency of
spikeref: it and scikit-image are imported inside the call, not at import time.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter

__all__ = ["PEERS", "PeerDenoiser", "peer_available"]

PEERS = ("bm3d", "nlm", "gaussian")
_SIGMA_MODES = ("blind", "spike")
_INSTALL = 'pip install "spikeref[peers]"'
# bm3d 4.0.3 raises for planes under 8 × 8 and crashes the interpreter (segfault) on exactly 8 × 8.
_BM3D_MIN_SIDE = 9


def _import_bm3d():
    try:
        import bm3d
    except ImportError as exc:
        raise ImportError(f"the 'bm3d' peer needs the bm3d package: {_INSTALL} (bm3d's licence is "
                          f"non-commercial: for comparison only)") from exc
    return bm3d


def _import_skimage_restoration(blind_sigma: bool):
    try:
        from skimage import restoration
    except ImportError as exc:
        raise ImportError(f"the 'nlm' peer and sigma='blind' need scikit-image: {_INSTALL}") from exc
    if blind_sigma:  # estimate_sigma imports PyWavelets only when called: ask for it before any work
        try:
            import pywt  # noqa: F401
        except ImportError as exc:
            raise ImportError(f"sigma='blind' needs PyWavelets (for scikit-image's estimate_sigma): {_INSTALL}") \
                from exc
    return restoration


def _check_method(method) -> str:
    if not isinstance(method, str) or method not in PEERS:
        raise ValueError(f"method must be one of {PEERS}; got {method!r}")
    return method


def _is_positive_number(value) -> bool:
    return (not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating))
            and math.isfinite(value) and value > 0)


def peer_available(method) -> bool:
    """Whether the packages ``method`` needs with its default (blind) σ can be imported.

    Parameters
    ----------
    method : {"bm3d", "nlm", "gaussian"}
        ``"bm3d"`` needs ``bm3d`` and scikit-image with PyWavelets (for the blind σ), ``"nlm"``
        scikit-image with PyWavelets,
        ``"gaussian"`` only SciPy (always available).

    Returns
    -------
    bool
    """
    _check_method(method)
    try:
        if method == "bm3d":
            _import_bm3d()
        if method in ("bm3d", "nlm"):
            _import_skimage_restoration(blind_sigma=True)
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class PeerDenoiser:
    """A classical single-window denoiser applied to each Bayer plane of firing rates.

    See the module docstring for the exact library calls ("off the shelf"), the two ways of
    setting σ and the licence of ``bm3d``.

    Parameters
    ----------
    method : {"bm3d", "nlm", "gaussian"}
        The peer.  ``"bm3d"`` needs the ``bm3d`` package (non-commercial licence, comparison
        only), ``"nlm"`` scikit-image; both are in the extra ``peers``.
    sigma : {"blind", "spike"} or float, default "blind"
        Noise standard deviation handed to the peer, in rate units (spikes per readout):
        ``"blind"`` estimates it per plane with :func:`skimage.restoration.estimate_sigma`,
        ``"spike"`` uses ``sqrt(mean(p̂(1 − p̂)) / W)`` per plane, a positive float is used as is.
        Ignored by ``"gaussian"``.
    gaussian_sigma : float, default 1.0
        Standard deviation of the Gaussian kernel in pixels (of the plane), for ``"gaussian"``.

    Examples
    --------
    >>> peer = PeerDenoiser("nlm", sigma="spike")                  # doctest: +SKIP
    >>> clean = peer(sr.bayer_planes(rates[0]), window=10)        # doctest: +SKIP
    """

    method: str
    sigma: object = "blind"
    gaussian_sigma: float = 1.0

    def __post_init__(self):
        _check_method(self.method)
        if isinstance(self.sigma, str):
            if self.sigma not in _SIGMA_MODES:
                raise ValueError(f"sigma must be 'blind', 'spike' or a positive float; got {self.sigma!r}")
        elif _is_positive_number(self.sigma):
            object.__setattr__(self, "sigma", float(self.sigma))
        elif isinstance(self.sigma, bool) or not isinstance(self.sigma, (int, float, np.integer, np.floating)):
            raise TypeError(f"sigma must be 'blind', 'spike' or a positive float; got {self.sigma!r}")
        else:
            raise ValueError(f"sigma must be 'blind', 'spike' or a positive float; got {self.sigma!r}")
        if isinstance(self.gaussian_sigma, bool) or not isinstance(
                self.gaussian_sigma, (int, float, np.integer, np.floating)):
            raise TypeError(f"gaussian_sigma must be a positive float (pixels); got {self.gaussian_sigma!r}")
        if not _is_positive_number(self.gaussian_sigma):
            raise ValueError(f"gaussian_sigma must be a positive float (pixels); got {self.gaussian_sigma!r}")
        object.__setattr__(self, "gaussian_sigma", float(self.gaussian_sigma))

    @property
    def name(self) -> str:
        """Label for tables: ``"BM3D (blind σ)"``, ``"NLM (spike σ)"``, ``"NLM (σ=0.05)"``, ``"Gaussian σ=1.0"``."""
        if self.method == "gaussian":
            return f"Gaussian σ={self.gaussian_sigma}"
        label = {"bm3d": "BM3D", "nlm": "NLM"}[self.method]
        how = f"{self.sigma} σ" if isinstance(self.sigma, str) else f"σ={self.sigma:g}"
        return f"{label} ({how})"

    def plane_sigma(self, plane, window=None) -> float:
        """The σ (rate units) this peer hands its library for one ``(h, w)`` plane."""
        if isinstance(self.sigma, float):
            return self.sigma
        if self.sigma == "spike":
            if window is None:
                raise ValueError("sigma='spike' needs window= (the exposure W in planes, of Eq. 4)")
            p = np.clip(np.asarray(plane, dtype=np.float64), 0.0, 1.0)
            return float(np.sqrt(np.mean(p * (1.0 - p)) / float(window)))
        restoration = _import_skimage_restoration(blind_sigma=True)
        with warnings.catch_warnings():
            # One grey plane; skimage warns that a narrow last axis might be colour channels.  A
            # plane whose finest diagonal wavelet band is all zero (constant, or varying along one
            # axis only) gives the median of no coefficients: NaN with a RuntimeWarning.
            warnings.filterwarnings("ignore", message=".*channel_axis.*", category=UserWarning)
            warnings.filterwarnings("ignore", category=RuntimeWarning)
            sigma = float(restoration.estimate_sigma(np.asarray(plane, dtype=np.float64), channel_axis=None))
        return 0.0 if math.isnan(sigma) else sigma   # no noise found in that band

    def __call__(self, planes, window=None) -> np.ndarray:
        """Denoise each plane independently.

        Parameters
        ----------
        planes : array_like, shape (4, h, w) or (h, w)
            Floating-point Bayer planes of firing rates in ``[0, 1]`` (Eq. 4, ``count / W``);
            any number of leading planes is accepted, each denoised on its own.
        window : float, optional
            The exposure ``W`` behind the rates, in planes.  Needed only for ``sigma="spike"``.

        Returns
        -------
        numpy.ndarray
            Same shape as ``planes``, float32, finite.

        Raises
        ------
        TypeError
            ``planes`` not floating point.
        ValueError
            Bad shape, non-finite rates, a bad or missing ``window``, a plane under 9 × 9 for BM3D.
        ImportError
            ``bm3d`` or scikit-image missing (``pip install "spikeref[peers]"``).
        """
        arr = np.asarray(planes)
        if arr.ndim < 2 or arr.shape[-1] < 1 or arr.shape[-2] < 1:
            raise ValueError(f"planes must have shape (4, h, w) or (h, w); got {arr.shape}")
        if not np.issubdtype(arr.dtype, np.floating):
            raise TypeError(f"planes must be floating point firing rates; got {arr.dtype}")
        if window is not None and not _is_positive_number(window):
            raise ValueError(f"window must be a positive number of planes; got {window!r}")
        if self.sigma == "spike" and window is None:
            raise ValueError("sigma='spike' needs window= (the exposure W in planes, of Eq. 4)")
        if not np.all(np.isfinite(arr)):
            raise ValueError("planes must be finite firing rates")
        h, w = arr.shape[-2:]
        if self.method == "bm3d":
            if min(h, w) < _BM3D_MIN_SIDE:
                raise ValueError(f"planes must be at least {_BM3D_MIN_SIDE} × {_BM3D_MIN_SIDE} pixels for "
                                 f"method='bm3d' (its 8 × 8 blocks); got {h} × {w}")
            bm3d = _import_bm3d()
        if self.method == "nlm" or (self.method == "bm3d" and self.sigma == "blind"):
            restoration = _import_skimage_restoration(blind_sigma=self.sigma == "blind")

        flat = arr.reshape(-1, h, w).astype(np.float32, copy=False)
        out = np.empty(flat.shape, dtype=np.float32)
        for i, plane in enumerate(flat):
            if self.method == "gaussian":
                out[i] = gaussian_filter(plane, self.gaussian_sigma, mode="reflect")
                continue
            if plane.size == 0 or plane.min() == plane.max():   # flat: nothing to denoise, σ = 0
                out[i] = plane
                continue
            sigma = self.plane_sigma(plane, window)
            if not math.isfinite(sigma) or sigma < 0:
                raise ValueError(f"noise level of plane {i} is not a finite σ ≥ 0: {sigma!r}")
            if sigma == 0.0:
                out[i] = plane
            elif self.method == "bm3d":
                out[i] = bm3d.bm3d(plane.astype(np.float64), sigma_psd=sigma)
            else:
                out[i] = restoration.denoise_nl_means(plane, h=0.8 * sigma, sigma=sigma, patch_size=5,
                                                      patch_distance=6, fast_mode=True)
        if not np.all(np.isfinite(out)):
            raise ValueError(f"{self.name} returned non-finite values")
        return out.reshape(arr.shape)
