"""Which CFA phase a recording has: the Bayer pattern read from the spikes themselves.

Real recordings come with a CFA phase that depends on an unstated convention (toolkits flip rows
differently, and flipping an even-height ``RGGB`` mosaic reads as ``GBRG``).  A wrong pattern gives
wrong colours silently; the data say which phase is green.  :func:`detect_cfa` counts the spikes of a
bounded stretch of the recording (:func:`spikeref.accumulate.window_counts`, straight from packed
``.dat`` bytes; at most :attr:`CfaDetectParams.planes` planes and :attr:`CfaDetectParams.max_bytes`
bytes), and :func:`cfa_from_counts` decides from the summed count image ``C`` (``H × W``) split into its
four 2×2 phases ``C_p = C[p // 2 :: 2, p % 2 :: 2]`` (positions (0,0), (0,1), (1,0), (1,1)):

**Texture** (which diagonal is green).  Each phase is band-passed on its own grid,
``B_p = G_σ1 ∗ C_p − G_σ2 ∗ C_p`` (Gaussians of σ = ``band`` = (1, 4) Bayer-plane pixels, SciPy's
``gaussian_filter``, mode ``reflect``), which keeps the scene's texture and drops the phase's mean and
most per-pixel noise.  ``corr_main`` is Pearson's correlation over every pair of *diagonally adjacent*
pixels of phases (0,0) and (1,1) — each (1,1) pixel of the interior (Bayer-plane rows ``1 … h−2``,
columns ``1 … w−2``) paired with each of its four diagonal neighbours — and ``corr_anti`` the same for
phases (0,1) and (1,0).  Both diagonals are one diagonal step apart and every pair is taken in both
diagonal directions, so on a monochrome sensor the two are equal in expectation whatever the
orientation of the scene's texture.  On colour content the two green sites correlate strongly, red with blue
much less: 0.91–0.96 against 0.01–0.81 on the development photographs, colour chart and texture (where the
texture is grey, as in the HDR lamp scene, both are 0.96, and in low light both are 0.14–0.33: the means
decide there).  The gap is measured in Fisher's
``z = atanh(ρ)``: ``Δz = z_main − z_anti``; its standard error ``se_t`` is the spread of ``Δz`` over
4×4 tiles of the image divided by 4 (at least the independent-pairs value ``√(2 / (N − 3))``), so it
grows when few spikes make the textures noisy.  The texture's evidence is
``Z_t = sign(Δz) · max(|Δz| − 0.05, 0) / se_t`` (0.05: a gap a monochrome sensor may show).

**Means** (the two green sites have the same colour).  With ``n_p`` the spikes of phase ``p``, the
contrasts ``c_main = (n_00 − n_11) / (n_00 + n_11)``, ``c_anti = (n_01 − n_10) / (n_01 + n_10)`` and
``c_diag = ((n_00 + n_11) − (n_01 + n_10)) / Σ n`` have the counting (Poisson) standard error
``√((1 − c²) / s)`` over their ``s`` spikes.  The green diagonal is the one whose two phases agree:
``Z_m = sign(|c_anti| − |c_main|) · max(||c_anti| − |c_main|| − 0.01, 0) / se`` (0.01: a gain
difference a sensor's phases may show).  This cue decides where the texture cannot (a grey texture under
coloured light, the HDR lamp scene) and in low light.

**Decision.**  The phases differ (colour) when ``z_colour = max(|Z_t|, z_means) > 3``, with
``z_means`` the largest of ``max(|c| − 0.01, 0) / se`` over the three contrasts; otherwise the four phases
behave alike (both diagonals correlate about equally and the four means agree) and the answer is
``mono``.  For colour, the green diagonal is the sign of ``Z = (Z_t + Z_m) / √2`` (Stouffer's sum of
the two cues; positive: (0,0)/(1,1)), and of the two other phases **red is the brighter** — the
warm-world prior: under daylight or tungsten light a silicon sensor sees more red than blue in natural
scenes.  The prior is fixed; it is wrong for scenes lit otherwise (night, sky, space: scikit-image's
``rocket`` and ``hubble_deep_field``), and no amount of data repairs that.

**Confidence** (``Φ`` the standard normal distribution function):

* colour: ``green_confidence = Φ(|Z|) · Φ(z_colour − 3)`` (the green sites are where the pattern says and
  the phases do differ), times the red/blue part ``0.5 + (p − 0.5)(2Φ(z_rb) − 1)`` with ``z_rb`` the
  red/blue contrast over its standard error and ``p = 0.8`` the prior's reliability (it held for 8 of the
  10 colour photographs of scikit-image): a colour pattern is never more than 0.8 sure of red and blue;
* mono: ``Φ(3 − z_colour)`` (how far inside the "alike" region the phases are) times the *power*: the
  probability that a colour recording seen with this much noise would have been told apart — by its
  texture (a red/blue correlation 0.8 of the green one, the closest on the development set, at the
  correlation measured here) or by its means (a 5 % contrast).  A very dark recording, whose textures
  are mostly noise, reads ``mono`` with a low confidence; a recording with no spikes, with confidence 0.

:class:`CfaGuess` keeps the measured features (both correlations, the four phase means, the planes read,
the three z-values) so that a user can audit the answer; :func:`green_sites_contradict` says when a given
pattern puts its green sites where the data do not.  The measured figures (development and held-out
recordings, the real monochrome ones, the cost) are in ``docs/results.md``, "CFA phase detection"
(``scripts/study_cfa_detect.py``).  The oracle :func:`spikeref.oracles.cfa_detect.cfa_from_counts_oracle`
writes the same decision out pair by pair.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from scipy import ndimage

from spikeref._checks import is_real, whole_number
from spikeref.accumulate import window_counts
from spikeref.bayer import bayer_planes, validate_cfa
from spikeref.stream import as_stream

__all__ = ["CfaDetectParams", "CfaGuess", "detect_cfa", "cfa_from_counts", "green_sites_contradict",
           "green_diagonal", "DETECTED_PATTERNS"]

#: What :func:`detect_cfa` may answer.
DETECTED_PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG", "mono")
_FISHER_CLIP = 0.9999  # correlations are clipped to ±this before atanh
_FLAT = 1e-6  # a band-passed phase whose standard deviation is under this many spikes has no texture


@dataclass(frozen=True)
class CfaDetectParams:
    """How :func:`detect_cfa` reads and decides (defaults chosen on the development recordings of
    ``scripts/study_cfa_detect.py``).

    Parameters
    ----------
    planes : int
        Planes read at most (from ``start``), ≥ 1: 1000 planes are 50 ms at 20 kHz.
    max_bytes : int
        …and at most this many bytes of packed planes (``H·W/8`` a plane), ≥ 1: 128 MiB, 1073 planes
        of 1000×1000, so a very large frame reads fewer planes.
    band : (float, float)
        ``(σ1, σ2)`` of the band-pass ``G_σ1 − G_σ2``, Bayer-plane pixels, ``0 ≤ σ1 < σ2``.
    tiles : int
        Tiles per side (≥ 2) over which the spread of the correlation gap gives its standard error.
    decide_z : float
        z-value above which the phases differ (colour), > 0.
    corr_tolerance : float
        Gap in Fisher z between the diagonals' correlations that a monochrome sensor may show, ≥ 0.
    mean_tolerance : float
        Contrast between phases' spike counts that a monochrome sensor's gains may show, in [0, 1).
    power_corr_ratio : float
        For the ``mono`` confidence: the red/blue correlation of the least distinct colour content, as
        a fraction of the green one, in (0, 1).
    power_contrast : float
        For the ``mono`` confidence: the smallest mean contrast of colour content, in (0, 1).
    red_prior : float
        How often red is the brighter of the two non-green phases on natural content, in [0.5, 1].
    warn_confidence : float
        ``green_confidence`` at or above which a given pattern that puts green elsewhere is contradicted,
        in (0, 1]: 0.99, which every colour recording of the development set reached at its default
        length and none of the monochrome ones came near (they read ``mono``).
    """

    planes: int = 1000
    max_bytes: int = 128 << 20
    band: tuple = (1.0, 4.0)
    tiles: int = 4
    decide_z: float = 3.0
    corr_tolerance: float = 0.05
    mean_tolerance: float = 0.01
    power_corr_ratio: float = 0.8
    power_contrast: float = 0.05
    red_prior: float = 0.8
    warn_confidence: float = 0.99

    def __post_init__(self):
        for name in ("planes", "max_bytes", "tiles"):
            least = 2 if name == "tiles" else 1
            object.__setattr__(self, name, whole_number(getattr(self, name), name, least, f"a whole number ≥ {least}"))
        band = tuple(self.band) if isinstance(self.band, (tuple, list)) else None
        if (band is None or len(band) != 2 or not all(is_real(s) for s in band)
                or not 0 <= band[0] < band[1] or not math.isfinite(band[1])):
            raise ValueError(f"band must be (σ1, σ2) with 0 ≤ σ1 < σ2, finite, in Bayer-plane pixels; "
                             f"got {self.band!r}")
        object.__setattr__(self, "band", (float(band[0]), float(band[1])))
        for name, lo, hi, lo_in, hi_in in _RANGES:
            value = getattr(self, name)
            ok = is_real(value) and math.isfinite(value) and (value >= lo if lo_in else value > lo)
            if not ok or (hi is not None and not (value <= hi if hi_in else value < hi)):
                where = f"{'[' if lo_in else '('}{lo}, {'∞' if hi is None else hi}{']' if hi_in else ')'}"
                raise ValueError(f"{name} must be a number in {where}; got {value!r}")
            object.__setattr__(self, name, float(value))


#: ``(name, low, high, low included, high included)`` of the float parameters (``None``: unbounded).
_RANGES = (("decide_z", 0, None, False, False), ("corr_tolerance", 0, None, True, False),
           ("mean_tolerance", 0, 1, True, False), ("power_corr_ratio", 0, 1, False, False),
           ("power_contrast", 0, 1, False, False), ("red_prior", 0.5, 1, True, True),
           ("warn_confidence", 0, 1, False, True))


@dataclass(frozen=True)
class CfaGuess:
    """The CFA phase read from a recording, with the features it was read from.

    Attributes
    ----------
    pattern : str
        ``RGGB``, ``BGGR``, ``GRBG``, ``GBRG`` (of the upright image, as the package's ``cfa``) or ``mono``.
    confidence : float
        In [0, 1]: for a colour pattern, ``green_confidence`` times the red/blue part (at most
        ``red_prior``); for ``mono``, how alike the phases are times how well colour would have shown.
    green_confidence : float
        In [0, 1]: that the green sites are on the diagonal ``pattern`` names (0 for ``mono``).
    corr_main, corr_anti : float
        Correlation of the band-passed textures of phases (0,0)&(1,1) and of (0,1)&(1,0), in [−1, 1].
    phase_means : tuple of 4 float
        Spikes per readout of the phases at (0,0), (0,1), (1,0), (1,1).
    planes : int
        Planes counted.
    texture_z, means_z : float
        Evidence that the (0,0)/(1,1) diagonal is green (negative: the other) from the textures and from
        which diagonal's phases agree in mean (``Z_t``, ``Z_m`` of the module's text).
    colour_z : float
        Evidence that the phases differ at all (``z_colour``); above ``decide_z`` the pattern is a colour one.
    """

    pattern: str
    confidence: float
    green_confidence: float
    corr_main: float
    corr_anti: float
    phase_means: tuple
    planes: int
    texture_z: float
    means_z: float
    colour_z: float

    @property
    def green_diagonal(self) -> str | None:
        """``"main"`` (green at (0,0) and (1,1)), ``"anti"`` (at (0,1) and (1,0)), ``None`` for mono."""
        return green_diagonal(self.pattern)

    def as_dict(self) -> dict:
        """The fields as plain Python values (for JSON)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["phase_means"] = list(self.phase_means)
        return out

    def describe(self) -> str:
        """One line on what decided, e.g. ``"green at (0,1)/(1,0) (textures correlate 0.92 there, 0.25 on the
        other diagonal; green sites confidence 1.00), red the brighter of the other two (warm-world prior)"``."""
        if self.pattern == "mono":
            spread = max(self.phase_means) / min(self.phase_means) - 1 if min(self.phase_means) > 0 else math.inf
            alike = (f"textures correlate {self.corr_main:.2f} and {self.corr_anti:.2f} on the two diagonals, "
                     f"phase means within {100 * spread:.1f} %")
            return (f"the four 2×2 phases behave alike ({alike})" if self.confidence >= 0.5
                    else f"too few spikes to tell colour from mono ({alike})")
        main = self.green_diagonal == "main"
        green, other = (self.corr_main, self.corr_anti) if main else (self.corr_anti, self.corr_main)
        return (f"green at {'(0,0)/(1,1)' if main else '(0,1)/(1,0)'} (textures correlate {green:.2f} there, "
                f"{other:.2f} on the other diagonal; green sites confidence {self.green_confidence:.2f}), red the "
                f"brighter of the other two (warm-world prior)")


def green_diagonal(cfa: str | None) -> str | None:
    """Where a pattern puts green: ``"main"`` ((0,0) and (1,1): ``GRBG``, ``GBRG``), ``"anti"`` ((0,1) and
    (1,0): ``RGGB``, ``BGGR``), ``None`` for ``None`` or ``"mono"``."""
    if cfa is None or (isinstance(cfa, str) and cfa.lower() == "mono"):
        return None
    return "main" if validate_cfa(cfa)[0] == "G" else "anti"


def green_sites_contradict(cfa: str | None, guess: CfaGuess, *, threshold: float | None = None) -> bool:
    """Whether the data contradict the green sites of ``cfa`` (a pattern, or ``None``/``"mono"``).

    True when ``guess`` is a colour pattern whose green diagonal differs from ``cfa``'s (for a mono
    ``cfa``: any colour pattern) and ``guess.green_confidence ≥ threshold`` (default
    :attr:`CfaDetectParams.warn_confidence`).  A ``mono`` guess contradicts nothing.
    """
    if not isinstance(guess, CfaGuess):
        raise TypeError(f"guess must be a CfaGuess; got {type(guess).__name__}")
    threshold = CfaDetectParams().warn_confidence if threshold is None else threshold
    if not is_real(threshold) or not 0 <= threshold <= 1:
        raise ValueError(f"threshold must be a number in [0, 1]; got {threshold!r}")
    if guess.pattern == "mono" or guess.green_confidence < threshold:
        return False
    return green_diagonal(cfa) != guess.green_diagonal


# ----------------------------------------------------------------------------- the decision
def _phi(x: float) -> float:
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


def _fisher(r: float) -> float:
    return math.atanh(min(max(r, -_FISHER_CLIP), _FISHER_CLIP))


def _band_pass(phases: np.ndarray, band: tuple) -> np.ndarray:
    """``G_σ1 ∗ C_p − G_σ2 ∗ C_p`` of each phase ``(4, h, w)`` on its own grid (σ 0 along the phases' axis)."""
    s1, s2 = band
    fine = ndimage.gaussian_filter(phases, (0, s1, s1), mode="reflect") if s1 > 0 else phases
    return fine - ndimage.gaussian_filter(phases, (0, s2, s2), mode="reflect")


def _pair_maps(b: np.ndarray, u_phase: int, v_phase: int, col_shift: int):
    """Per interior pixel of phase ``u_phase``: ``u``, the sum and the sum of squares of its four diagonal
    neighbours ``v`` (of phase ``v_phase``), and ``u · Σ v``."""
    h, w = b.shape[1:]
    u = b[u_phase, 1:h - 1, 1:w - 1]
    vs = [b[v_phase, 1 + di:h - 1 + di, 1 + dj + col_shift:w - 1 + dj + col_shift] for di in (0, 1) for dj in (0, 1)]
    v1 = vs[0] + vs[1] + vs[2] + vs[3]
    v2 = vs[0] * vs[0] + vs[1] * vs[1] + vs[2] * vs[2] + vs[3] * vs[3]
    return np.stack([u, u * u, v1, v2, u * v1])


def _pooled_corr(sums: np.ndarray, n: float) -> float | None:
    """Pearson's correlation over ``4n`` pairs from ``Σu, Σu², Σv, Σv², Σuv`` (each ``u`` in four pairs);
    ``None`` when either side has no texture."""
    su, suu, sv, svv, suv = (float(s) for s in sums)
    mu, mv = su / n, sv / (4 * n)
    var_u, var_v = suu / n - mu * mu, svv / (4 * n) - mv * mv
    if not (var_u > _FLAT ** 2 and var_v > _FLAT ** 2):
        return None
    return float(np.clip((suv / (4 * n) - mu * mv) / math.sqrt(var_u * var_v), -1.0, 1.0))


def _bounds(n: int, parts: int) -> list[int]:
    return [k * n // parts for k in range(parts + 1)]


def _texture(phases: np.ndarray, params: CfaDetectParams):
    """``(corr_main, corr_anti, Δz, se_t)`` of the phases ``(4, h, w)`` float64; ``se_t = inf`` when there is no
    texture to compare."""
    h, w = phases.shape[1:]
    if h < 3 or w < 3:
        return 0.0, 0.0, 0.0, math.inf
    b = _band_pass(phases, params.band)
    maps = (_pair_maps(b, 3, 0, 0), _pair_maps(b, 2, 1, -1))  # main: (1,1) with (0,0); anti: (1,0) with (0,1)
    n = (h - 2) * (w - 2)
    r_main, r_anti = (_pooled_corr(m.reshape(5, -1).sum(axis=1), n) for m in maps)
    if r_main is None or r_anti is None:
        return r_main or 0.0, r_anti or 0.0, 0.0, math.inf
    dz = _fisher(r_main) - _fisher(r_anti)
    rows, cols = _bounds(h - 2, min(params.tiles, h - 2)), _bounds(w - 2, min(params.tiles, w - 2))
    gaps = []
    for y0, y1 in zip(rows[:-1], rows[1:], strict=True):
        for x0, x1 in zip(cols[:-1], cols[1:], strict=True):
            tile = [_pooled_corr(m[:, y0:y1, x0:x1].reshape(5, -1).sum(axis=1), (y1 - y0) * (x1 - x0))
                    for m in maps]
            gaps.append(_fisher(tile[0] or 0.0) - _fisher(tile[1] or 0.0))
    floor = math.sqrt(2.0 / (4 * n - 3)) if 4 * n > 3 else math.inf
    spread = float(np.std(gaps, ddof=1)) / math.sqrt(len(gaps)) if len(gaps) > 1 else 0.0
    return r_main, r_anti, dz, max(spread, floor)


def _contrast(a: float, b: float) -> tuple[float, float]:
    """``(a − b) / (a + b)`` of two spike totals and its counting standard error (``inf`` without spikes)."""
    s = a + b
    if s <= 0:
        return 0.0, math.inf
    c = (a - b) / s
    return c, math.sqrt(max(1.0 - c * c, 1.0 / s) / s)


def _excess(value: float, tolerance: float, se: float) -> float:
    """``max(|value| − tolerance, 0) / se`` (0 when ``se`` is infinite)."""
    return max(abs(value) - tolerance, 0.0) / se if math.isfinite(se) else 0.0


def _decide(counts: np.ndarray, planes: int, params: CfaDetectParams) -> CfaGuess:
    phases = bayer_planes(counts).astype(np.float64, copy=False)  # C_p at (0,0), (0,1), (1,0), (1,1)
    totals = phases.sum(axis=(1, 2))
    means = tuple(float(t / (phases[0].size * planes)) for t in totals)
    r_main, r_anti, dz, se_t = _texture(phases, params)
    k, tol_c, tol_m = params.decide_z, params.corr_tolerance, params.mean_tolerance

    z_t = math.copysign(_excess(dz, tol_c, se_t), dz)
    c_main, se_main = _contrast(totals[0], totals[3])
    c_anti, se_anti = _contrast(totals[1], totals[2])
    c_diag, se_diag = _contrast(totals[0] + totals[3], totals[1] + totals[2])
    agree = abs(c_anti) - abs(c_main)  # > 0: the main diagonal's two phases agree better
    z_m = math.copysign(_excess(agree, tol_m, math.hypot(se_main, se_anti)), agree)
    z_means = max(_excess(c_main, tol_m, se_main), _excess(c_anti, tol_m, se_anti), _excess(c_diag, tol_m, se_diag))
    z_colour = max(abs(z_t), z_means)
    z = (z_t + z_m) / math.sqrt(2.0)
    features = dict(corr_main=r_main, corr_anti=r_anti, phase_means=means, planes=int(planes),
                    texture_z=z_t, means_z=z_m, colour_z=z_colour)

    if z_colour <= k:
        r_hi = min(max(r_main, r_anti, 0.0), _FISHER_CLIP)
        dz_colour = _fisher(r_hi) - _fisher(params.power_corr_ratio * r_hi)
        se_means = max(se_main, se_anti, se_diag)
        power = max(_phi((dz_colour - tol_c) / se_t - k) if math.isfinite(se_t) else 0.0,
                    _phi((params.power_contrast - tol_m) / se_means - k) if math.isfinite(se_means) else 0.0)
        return CfaGuess("mono", _phi(k - z_colour) * power, 0.0, **features)

    main = (z, dz, agree) > (0.0, 0.0, 0.0)
    green_conf = _phi(abs(z)) * _phi(z_colour - k)
    if main:  # green at (0,0), (1,1); red and blue at (0,1), (1,0)
        red_first, c_rb, se_rb = totals[1] >= totals[2], c_anti, se_anti
        pattern = "GRBG" if red_first else "GBRG"
    else:
        red_first, c_rb, se_rb = totals[0] >= totals[3], c_main, se_main
        pattern = "RGGB" if red_first else "BGGR"
    z_rb = abs(c_rb) / se_rb if math.isfinite(se_rb) else 0.0
    rb_conf = 0.5 + (params.red_prior - 0.5) * (2.0 * _phi(z_rb) - 1.0)
    return CfaGuess(pattern, green_conf * rb_conf, green_conf, **features)


# ----------------------------------------------------------------------------- public wrappers
def _check_params(params) -> CfaDetectParams:
    if params is None:
        return CfaDetectParams()
    if not isinstance(params, CfaDetectParams):
        raise TypeError(f"params must be a CfaDetectParams; got {type(params).__name__}")
    return params


def _check_size(height: int, width: int, what: str) -> None:
    if height % 2 or width % 2 or height < 2 or width < 2:
        raise ValueError(f"{what} must have an even height and width of at least 2 (whole 2×2 cells); "
                         f"got {height}×{width}")


def cfa_from_counts(counts, planes: int, *, params: CfaDetectParams | None = None) -> CfaGuess:
    """Decide the CFA phase from a spike-count image (the module's rule).

    Parameters
    ----------
    counts : array_like ``(H, W)``
        Spikes per pixel summed over ``planes`` planes (integers or floats, finite, ≥ 0), upright, ``H``
        and ``W`` even.  :func:`spikeref.accumulate.window_counts` with ``count=1`` makes it.
    planes : int
        How many planes ``counts`` sums (≥ 1): it turns counts into the phase means' spikes per readout.
    params : CfaDetectParams, optional

    Returns
    -------
    CfaGuess
    """
    params = _check_params(params)
    arr = np.asarray(counts)
    if arr.ndim != 2:
        raise ValueError(f"counts must be a 2-D (H, W) image of spike counts; got shape {arr.shape}")
    if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise TypeError(f"counts must hold numbers (spike counts); got {arr.dtype}")
    _check_size(*arr.shape, "counts")
    if np.issubdtype(arr.dtype, np.floating) and not np.all(np.isfinite(arr)):
        raise ValueError("counts must be finite")
    if arr.size and arr.min() < 0:
        raise ValueError("counts must be ≥ 0 (spikes per pixel)")
    return _decide(arr, whole_number(planes, "planes", 1, "a whole number ≥ 1 (the planes counts sums)"), params)


def detect_cfa(spikes, *, planes: int | None = None, start: int = 0,
               params: CfaDetectParams | None = None) -> CfaGuess:
    """Read the CFA phase of a recording from its spikes.

    Parameters
    ----------
    spikes : SpikeStream or ndarray ``(T, H, W)`` uint8 0/1
        The recording (a memory-mapped ``.dat`` is counted from its packed bytes); ``H``, ``W`` even.
        Its own ``cfa`` is not looked at.
    planes : int, optional
        Planes to count from ``start`` (≥ 1); default ``params.planes`` (1000).  Fewer are read when the
        stream ends sooner or when they would exceed ``params.max_bytes`` of packed planes.
    start : int
        First plane counted (≥ 0, inside the stream).
    params : CfaDetectParams, optional

    Returns
    -------
    CfaGuess
        ``.pattern`` (``RGGB``, ``BGGR``, ``GRBG``, ``GBRG`` or ``mono``), ``.confidence`` in [0, 1] and the
        features it was decided from (``.planes``: the planes actually counted).

    Memory is one count image (``H × W`` of 16-bit integers: 2 MB at 1000×1000) whatever ``planes`` is.
    """
    params = _check_params(params)
    stream = as_stream(spikes)
    if planes is None:
        planes = params.planes
    else:
        planes = whole_number(planes, "planes", 1, "a whole number ≥ 1, or None for params.planes")
    start = whole_number(start, "start", 0, "a plane index ≥ 0")
    if start >= len(stream):
        raise ValueError(f"start={start} is at or past the end of the stream ({len(stream)} planes)")
    _check_size(stream.height, stream.width, "the recording")
    plane_bytes = -(-stream.height * stream.width // 8)
    n = min(planes, len(stream) - start, max(1, params.max_bytes // plane_bytes))
    counts = window_counts(stream, n, start=start, count=1)[0]
    return _decide(counts, n, params)
