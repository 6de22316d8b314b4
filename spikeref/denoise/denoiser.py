"""The denoiser as users call it: bundled weights, the three inference modes, frames of a stream.

``Denoiser.load()`` reads the bundled weights (:data:`DEFAULT_WEIGHTS`, for Eq. 4's counts, trained here
on a CPU from unlabeled spikes: simulated procedural scenes and photographs under motion, and real
monochrome recordings — see ``docs/results.md`` and ``scripts/train_denoiser.py``;
:func:`bundled_weights` names the network for window charges, which the pipeline loads by default);
``den(planes, mode, window=W)``
denoises Bayer planes of firing rates (exposure ``W`` planes) with the shared one-channel U-Net
(:mod:`spikeref.denoise.unet`) in the mode asked for (:mod:`spikeref.denoise.blindspot`);
:meth:`Denoiser.frames` gives ``Ψ[D(I)]`` for the windows of a spike stream (Eq. 4, then D, then the
bilinear demosaic Ψ).
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from spikeref.accumulate import accumulate as eq4
from spikeref.bayer import bayer_mosaic, bayer_planes, demosaic_bilinear
from spikeref.charge import ACCUMULATE, WINDOWS_PER_CALL, charge_rates
from spikeref.denoise.blindspot import MODES, blindspot_denoise, check_cell
from spikeref.denoise.guard import DEFAULT_RADIUS, GUARDS, NOISE_WINDOW, sure_blend, trusted_excess
from spikeref.denoise.shrinkage import shrink_residual
from spikeref.denoise.unet import UNet, exposure_level
from spikeref.hot_pixels import HotPixelRepair, hot_pixels_to_replace

__all__ = ["Denoiser", "DEFAULT_WEIGHTS", "WEIGHTS_DIR", "BUNDLED_FOR", "bundled_weights"]

WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
#: The bundled network for what a window gives (``accumulate=`` of the pipeline, ``Denoiser.frames``
#: and the CLI): each was trained on that input's noise (``docs/results.md``).
BUNDLED_FOR = {"count": "b2u_w16", "charge": "pairs_w16_charge"}
#: The bundled weights used when none are named (trained on Eq. 4's counts).
DEFAULT_WEIGHTS = WEIGHTS_DIR / f"{BUNDLED_FOR['count']}.npz"


def bundled_weights(accumulate: str) -> Path:
    """The bundled weights file for ``accumulate`` (``"count"`` or ``"charge"``; :data:`BUNDLED_FOR`)."""
    if accumulate not in BUNDLED_FOR:
        raise ValueError(f"accumulate must be one of {', '.join(BUNDLED_FOR)}; got {accumulate!r}")
    return WEIGHTS_DIR / f"{BUNDLED_FOR[accumulate]}.npz"


def _check_guard(guard) -> str:
    if guard not in GUARDS:
        raise ValueError(f"guard must be one of {', '.join(GUARDS)}; got {guard!r}")
    return guard


def _check_exposure(value, name: str) -> None:
    """``value`` (an exposure in planes) is None or a finite number > 0; else ``ValueError`` naming ``name``."""
    if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))
                              or not np.isfinite(value) or value <= 0):
        raise ValueError(f"{name} must be a positive number of planes; got {value!r}")


class Denoiser:
    """``D``: a U-Net plus an inference mode.

    Parameters
    ----------
    unet : UNet
        The network ``f_θ`` (one channel, shared by the four Bayer planes).
    mode : {"visible", "blind", "mixed"}
        Default inference mode: ``visible`` = ``f(I)`` (one pass, default); ``blind`` = Eq. 10–11
        (16 passes); ``mixed`` = ``(D(I) + λ f(I)) / (1 + λ)`` (17 passes).
    lam : float
        ``λ`` of the mixed mode.
    cell : int
        Blind-spot cell (4 → 16 masks).
    shrink : bool
        After the network, give back the part of the residual ``I − D(I)`` that exceeds the
        binomial noise of the exposure (:mod:`spikeref.denoise.shrinkage`; not in the paper,
        on by default because it measured better at every window — ``docs/results_history.md``).
        ``False`` gives the paper's ``D(I)`` exactly.  Needs the exposure: a call without
        ``window`` (possible for a rate-domain network) skips it.  Not applied under a guard.
    guard : {"sure", "off"}
        ``"sure"`` (default; not in the paper): blend the network's output with its input,
        ``I + α (f(I) − I)``, with ``α`` per pixel chosen by Stein's unbiased risk estimate from
        the data's own noise level (:mod:`spikeref.denoise.guard`) — one more network pass, and
        the output is never much worse than the input where the network removes detail (at windows
        longer than :data:`~spikeref.denoise.guard.NOISE_WINDOW` planes the noise is taken from a
        short window when one is given, else only the quantisation floor: :meth:`__call__`).
        ``"off"``: the network's output (then ``shrink``).  Both ``guard="off", shrink=False``
        give the paper's ``D(I)``.
    guard_radius : int
        Half side of the guard's neighbourhood in plane pixels.

    Attributes
    ----------
    input_domain : {"count", "rate"}
        What the network was trained on (the weights' metadata; ``"rate"`` when it says
        nothing).  A ``"count"`` network denoises ``I·W`` — the spike counts, whose noise level
        hardly depends on the exposure — and the result is divided by ``W`` again, so callers
        always pass and get firing rates but must say the exposure ``window``.  Interpretation:
        Eq. 10–12 are written on ``I``; a network on ``I`` alone cannot tell a clean long window
        from a noisy short one (``spikeref.denoise.train.TrainConfig.input_domain``).
    """

    def __init__(self, unet: UNet, mode: str = "visible", lam: float = 2.0, cell: int = 4, shrink: bool = True,
                 guard: str = "sure", guard_radius: int = DEFAULT_RADIUS):
        if not isinstance(unet, UNet):
            raise TypeError(f"unet must be a spikeref.denoise.unet.UNet; got {type(unet).__name__}")
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}; got {mode!r}")
        if not isinstance(shrink, (bool, np.bool_)):
            raise TypeError(f"shrink must be True or False; got {shrink!r}")
        if (isinstance(lam, bool) or not isinstance(lam, (int, float, np.integer, np.floating))
                or not np.isfinite(lam) or lam < 0):
            raise ValueError(f"lam (λ of the mixed mode) must be a finite number ≥ 0; got {lam!r}")
        cell_hw = check_cell(cell)
        trained = unet.meta.get("config", {}).get("cell")
        if trained is not None and check_cell(trained) != cell_hw:
            raise ValueError(f"cell={cell!r} differs from the cell the weights were trained with ({trained!r}); "
                             "the blind and mixed modes must hide pixels as in training")
        self.unet, self.mode, self.lam, self.cell, self.shrink = unet, mode, float(lam), cell, bool(shrink)
        self.guard = _check_guard(guard)
        if isinstance(guard_radius, bool) or not isinstance(guard_radius, (int, np.integer)) or guard_radius < 0:
            raise ValueError(f"guard_radius must be an integer ≥ 0 (plane pixels); got {guard_radius!r}")
        self.guard_radius = int(guard_radius)
        domain = unet.meta.get("input_domain", unet.meta.get("config", {}).get("input_domain", "rate"))
        if domain not in ("count", "rate"):
            raise ValueError(f"the weights' metadata names an unknown input_domain {domain!r} (count or rate)")
        self.input_domain = domain

    @classmethod
    def load(cls, path=None, **kw) -> "Denoiser":
        """From a weights ``.npz`` or the name of a bundled file (default: :data:`DEFAULT_WEIGHTS`).

        Bundled (``spikeref/denoise/weights/``, see ``docs/results.md``), two networks for the two inputs a
        window can give: ``b2u_w16`` (width 16, the paper's Blind2Unblind loss on Eq. 4's counts; the default here,
        for ``accumulate="count"`` and for the paper's procedure) and ``pairs_w16_charge`` (width 16, trained on
        the timing-aware window charge of :mod:`spikeref.charge` by Noise2Noise pairs of static streams, not the
        paper's loss: for ``accumulate="charge"``, the pipeline's default; :func:`bundled_weights`).  Each network
        is trained on what its path feeds it: the charge network on counts, or the count network on charges, is
        out of its training distribution.  ``b2u_w16_charge`` and ``b2u_w32`` shipped until 2026-11-28; the
        commands in their metadata (``docs/results.md``) remake them.
        """
        if path is None:
            path = DEFAULT_WEIGHTS
        else:
            path = Path(path)
            bundled = WEIGHTS_DIR / (path.name if path.suffix == ".npz" else path.name + ".npz")
            if not path.exists() and path.parent == Path(".") and bundled.is_file():
                path = bundled
        return cls(UNet.load(path), **kw)

    def __repr__(self) -> str:
        return f"Denoiser({self.unet!r}, mode={self.mode!r}, shrink={self.shrink}, guard={self.guard!r})"

    def __call__(self, planes, mode: str | None = None, window: float | None = None,
                 guard: str | None = None, short=None, short_window: float | None = None,
                 accumulate: str = "count", floor_window: float | None = None) -> np.ndarray:
        """Denoise firing-rate planes ``(..., h, w)`` float (e.g. ``(4, H/2, W/2)``); same shape, float32.

        ``window`` is the exposure behind the rates, in planes (``W`` of Eq. 4; for a warped
        accumulation its noise-equivalent length).  A count-domain network needs it; a
        rate-domain network uses it only for the residual shrinkage (``shrink``, applied for
        ``window ≥ 1``).  ``guard`` overrides the denoiser's own guard for this call (the
        pipeline turns it off for the frames it only aligns).

        With the guard, ``window`` also says how far the plane's own noise estimate can be trusted
        (:func:`~spikeref.denoise.guard.trusted_excess`): up to
        :data:`~spikeref.denoise.guard.NOISE_WINDOW` planes it is; at longer windows texture and the
        sensor's fixed pattern pass for noise, so the guard takes only the noise every spike count has
        (the quantisation floor) — never much worse than the input ``planes``, at the price of part of
        the gain on noisier sensors — unless it is given ``short`` (rates of the planes' shape) and
        ``short_window`` (planes, at most ``NOISE_WINDOW``): a shorter window of the same stream,
        e.g. the first ``NOISE_WINDOW`` planes of this one (:meth:`frames` passes them), on which it
        measures the noise and carries :data:`~spikeref.denoise.guard.CARRY_FRACTION` of its excess
        over the floor to ``window``
        (:func:`~spikeref.denoise.guard.carried_excess_variance`).  A ``short`` longer than
        ``NOISE_WINDOW`` planes is not read (the floor is taken).  Without ``window`` the guard
        uses the plane's own noise estimate.
        ``accumulate="charge"`` says the planes are :mod:`spikeref.charge` rates: the guard's
        noise floor is then the charge's (:func:`~spikeref.denoise.guard.quantisation_variance`).
        ``floor_window`` (planes; default ``window``) is the exposure the guard takes the floor, the
        carried noise and the ``NOISE_WINDOW`` test at, where it differs from the network's
        ``window``: a merge of consecutive window charges (Eq. 15 of charges) shares its inner
        window edges, so its quantisation is that of one charge over about its whole support, not
        over its noise-equivalent window (``docs/results.md``, "Never worse than plain accumulation").
        """
        use = self.guard if guard is None else _check_guard(guard)
        if use == "sure":
            arr = self._check_planes(planes, window)
            short_arr = None
            if short is not None:
                if window is None:
                    raise ValueError("short= needs window= (the exposure of planes)")
                short_arr = self._check_planes(short, short_window)
                if short_arr.shape != arr.shape:
                    raise ValueError(f"short must have the shape of planes {arr.shape}; got {short_arr.shape}")
                if short_window is None:
                    raise ValueError("short= needs short_window= (its exposure in planes)")
            _check_exposure(floor_window, "floor_window")
            noise_at = window if floor_window is None else floor_window
            carried = trusted_excess(noise_at, short_arr, short_window, accumulate)
            out, _ = sure_blend(arr, lambda z: self._network(z, mode, window), self.guard_radius, window=noise_at,
                                carried=carried, accumulate=accumulate)
            return out
        out = self._network(planes, mode, window)
        if self.shrink and window is not None and window >= 1:
            out = shrink_residual(np.asarray(planes), out, window)
        return out

    @staticmethod
    def _check_planes(planes, window) -> np.ndarray:
        arr = np.asarray(planes)
        if arr.ndim < 2:
            raise ValueError(f"planes must have shape (..., h, w); got {arr.shape}")
        if not np.issubdtype(arr.dtype, np.floating):
            raise TypeError(f"planes must be floating point firing rates; got {arr.dtype}")
        _check_exposure(window, "window")
        return arr

    def _network(self, planes, mode, window) -> np.ndarray:
        """The network in ``mode`` (Eq. 10–11 or ``f(I)``) on rates, without guard or shrinkage."""
        arr = self._check_planes(planes, window)
        net = self.unet
        if self.unet.spec.in_channels == 2:  # told the exposure (UNetSpec.in_channels)
            if window is None:
                raise ValueError("these weights read the exposure: pass window= (the exposure in planes)")
            level = exposure_level(window)

            def net(batch):
                return self.unet(batch, level=level)
        if self.input_domain == "rate":
            out = blindspot_denoise(arr.astype(np.float32, copy=False), net, mode or self.mode,
                                    cell=self.cell, lam=self.lam)
        elif window is None:
            raise ValueError("these weights denoise spike counts: pass window= (the exposure in planes, "
                             "W of Eq. 4)")
        else:
            scale = np.float32(window)
            counts = arr.astype(np.float32) * scale
            out = blindspot_denoise(counts, net, mode or self.mode, cell=self.cell, lam=self.lam)
            out /= scale
        return out

    def frames(self, stream, window: int = 10, start: int = 0, count: int | None = None,
               mode: str | None = None, accumulate: str = "count",
               hot_pixels=None) -> Iterator[tuple[int, np.ndarray]]:
        """Yield ``(k, Ψ[D(I_k)])`` for windows ``k`` of ``stream`` (Eq. 4 with ``W = window``).

        Frames are linear RGB ``(H, W, 3) float32`` in spikes per readout for a colour stream
        (monochrome: ``(H, W)``; the denoiser runs on the four 2×2 phases).  ``start`` is the
        first plane; ``count`` windows (default: every whole window).  With the guard on and
        ``window`` longer than :data:`~spikeref.denoise.guard.NOISE_WINDOW` planes, the guard
        measures the noise on the window's first ``NOISE_WINDOW`` planes (``short=`` of
        :meth:`__call__`).  ``accumulate="charge"`` takes each window's timing-aware charge
        (:func:`spikeref.charge.charge_rates`; not in the paper) instead of Eq. 4's count, and the
        short window's charge for the guard.  ``hot_pixels`` (``(H, W) bool``, e.g.
        :func:`spikeref.hot_pixels.find_hot_pixels` of the stream) are replaced in every window by the mean of
        their same-colour neighbours before the network sees it (:class:`spikeref.hot_pixels.HotPixelRepair`).
        """
        if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 1:
            raise ValueError(f"window must be a positive number of planes; got {window!r}")
        if isinstance(start, bool) or not isinstance(start, (int, np.integer)) or start < 0:
            raise ValueError(f"start must be a plane index ≥ 0; got {start!r}")
        if count is not None and (isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1):
            raise ValueError(f"count must be a positive number of frames (or None for all); got {count!r}")
        if accumulate not in ACCUMULATE:
            raise ValueError(f"accumulate must be count or charge; got {accumulate!r}")
        if stream.height % 2 or stream.width % 2:
            raise ValueError(f"the stream must have even height and width; got {stream.height}×{stream.width}")
        total = (len(stream) - start) // window
        if total < 1:
            raise ValueError(f"window={window} from plane {start} is longer than the stream ({len(stream)} planes)")
        count = total if count is None else min(int(count), total)
        hot = hot_pixels_to_replace(stream, "off", hot_pixels)  # the map given (its size checked), or None
        repair = None if hot is None else HotPixelRepair(hot)
        measure = charge_rates if accumulate == "charge" else eq4

        def rates_of(length: int, first: int, n: int) -> np.ndarray:
            """``n`` windows of ``length`` planes from plane ``first`` (``measure``), the hot pixels replaced."""
            out = measure(stream, length, start=first, count=n)
            return out if repair is None else repair.mosaic(np.ascontiguousarray(out, dtype=np.float32))

        block, block_k = [], 0  # WINDOWS_PER_CALL windows at a time: a charge's margins are read once per call
        for k in range(count):
            first = start + k * window
            if k - block_k >= len(block):
                block_k = k
                block = rates_of(window, first, min(WINDOWS_PER_CALL, count - k))
            rates = block[k - block_k]
            extra = {}
            if self.guard == "sure" and window > NOISE_WINDOW:
                short = rates_of(NOISE_WINDOW, first, 1)[0]
                extra = {"short": bayer_planes(short), "short_window": NOISE_WINDOW}
            clean = bayer_mosaic(self(bayer_planes(rates), mode, window=window, accumulate=accumulate, **extra))
            yield k, (demosaic_bilinear(clean, stream.cfa) if stream.cfa else clean)
