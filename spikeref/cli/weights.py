"""``--weights``: the bundled network by default, and the denoiser loaded with a missing or damaged file refused
in one line.  The commands call :func:`load_denoiser` through this module (``weights.load_denoiser``)."""

from __future__ import annotations

import warnings

from spikeref.cli.errors import CliError

__all__ = ["bundled_weights_by_default", "load_denoiser"]


def bundled_weights_by_default(args, accumulate: str) -> None:
    """Without ``--weights``: the bundled network trained on what the windows give (count or charge)."""
    from spikeref.denoise.denoiser import bundled_weights

    if args.weights is None:
        args.weights = bundled_weights(accumulate).stem  # the bundled name, as a user would give it


def load_denoiser(weights, *, accumulate: str | None = None, **kw):
    """``Denoiser.load`` with a damaged weights file reported as one line (before any output is opened).

    With ``accumulate`` (what the windows will give), a note when the weights were trained on the other
    (their metadata's ``accumulate``; weights without it were trained on counts).
    """
    from spikeref.denoise.denoiser import WEIGHTS_DIR, Denoiser

    try:  # a damaged file: the reader's one-line ValueError, which main reports
        den = Denoiser.load(weights, **kw)
    except FileNotFoundError:
        names = ", ".join(sorted(p.stem for p in WEIGHTS_DIR.glob("*.npz")))
        raise CliError(f"--weights {weights}: no such weights file, nor a bundled name ({names})") from None
    trained = den.unet.meta.get("accumulate", "count")
    if accumulate is not None and trained != accumulate:
        what = {"count": "Eq. 4 windows (counts)", "charge": "window charges"}
        warnings.warn(f"--weights {weights} was trained on {what[trained]}; the windows here give {what[accumulate]} "
                      f"(--accumulate {accumulate}): expect a worse denoiser", UserWarning, stacklevel=2)
    return den
