"""The methods and settings `spikeref bench` compares, and the grids it runs.

A :class:`Setting` names one way of making a frame: a baseline (TFP with its window, TFI,
TFSTP) or the progressive warping with ``W, K, L``, the denoiser mode, alignment on or
off, and what the flow is estimated on (``flow_frames``: the denoised frames, as the paper, or
the smoothed frames of the speed option).  A :class:`BenchGrid` lists which values each
axis takes; :func:`grid_settings` expands it:

* baselines as listed;
* the method in ``visible`` mode on the whole product ``W × K × L × align × flow_frames``
  (``L = 0`` has no neighbours, so ``K``, alignment and flow frames do not apply and it
  appears once per ``W``; without alignment there is no flow, so it appears once per
  ``W, K, L``) — or, with ``visible_product=False`` (the quick grid), along the ``L`` axis at
  the first ``W, K, align, flow_frames`` plus each other axis varied alone at the largest ``L``;
* the costly modes (``mixed`` runs 17 network passes per frame, ``blind`` 16) along
  ``expensive_L`` at the first ``W, K, align, flow_frames``;
* the fast preset (:meth:`~spikeref.pipeline.ReconstructParams.fast`: smoothed flow frames and
  the chained warp) and the fastest (:meth:`~spikeref.pipeline.ReconstructParams.fastest`: the
  same without a denoiser) at the first ``W, K`` and the largest ``L`` (≥ 2; at ``L = 1`` it is
  the composed warp), when the grid runs ``visible`` with alignment on (``fast_preset=True``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

__all__ = ["BASELINES", "MODES", "AXES", "Setting", "BenchGrid", "FULL_GRID", "QUICK_GRID", "grid_settings",
           "parse_grid"]

#: Baseline names accepted by ``--methods`` and what they are.
BASELINES = {"tfp10": ("tfp", 10), "tfp100": ("tfp", 100), "tfi": ("tfi", 0), "tfstp": ("tfstp", 0)}
MODES = ("visible", "mixed", "blind")
#: The values each axis of the method may take in the benchmark.
AXES = {"W": (10, 20), "K": (3, 5), "L": (0, 1, 2, 3), "align": (True, False),
        "flow_frames": ("denoised", "smoothed")}


@dataclass(frozen=True)
class Setting:
    """One method with its parameters.

    Attributes
    ----------
    method : {"tfp", "tfi", "tfstp", "ours"}
    window : int
        Planes per window: TFP's window, or the method's ``W`` (0 for TFI/TFSTP).
    K, L : int
        The method's frames per step and steps (ignored by baselines).
    mode : str
        Denoiser inference mode of the method.
    align : bool
        Whether the method estimates flow (False: zero flow, plain accumulation).
    flow_frames : {"denoised", "smoothed"}
        What the flow is estimated on (:class:`~spikeref.pipeline.ReconstructParams`).
    warp : {"composed", "chained"}
        How the output is warped (:class:`~spikeref.pipeline.ReconstructParams`); ``"chained"``
        with smoothed flow frames is the fast preset.
    denoise : bool
        Whether the method denoises (:class:`~spikeref.pipeline.ReconstructParams`); the fast
        preset without it is the fastest preset.
    """

    method: str
    window: int = 10
    K: int = 3
    L: int = 3
    mode: str = "visible"
    align: bool = True
    flow_frames: str = "denoised"
    warp: str = "composed"
    denoise: bool = True

    @property
    def name(self) -> str:
        if self.method == "tfp":
            return f"TFP W={self.window}"
        if self.method in ("tfi", "tfstp"):
            return self.method.upper()
        if self.L == 0:
            return f"ours {self.mode} W={self.window} L=0"
        suffix = "" if self.align else " no-align"
        if self.align and self.flow_frames != "denoised":
            suffix = f" {self.flow_frames}-flow"
        preset = self.warp == "chained" and self.flow_frames == "smoothed"
        if self.warp != "composed":
            suffix += (" (fast preset)" if self.denoise else " (fastest preset)") if preset else f" {self.warp}-warp"
        if not self.denoise and not preset:
            suffix += " no-denoiser"
        return f"ours {self.mode} W={self.window} K={self.K} L={self.L}" + suffix


@dataclass(frozen=True)
class BenchGrid:
    """The axes of a benchmark run (see the module docstring for how they expand)."""

    baselines: tuple = tuple(BASELINES)
    modes: tuple = MODES
    W: tuple = AXES["W"]
    K: tuple = AXES["K"]
    L: tuple = AXES["L"]
    align: tuple = AXES["align"]
    flow_frames: tuple = AXES["flow_frames"]
    expensive_L: tuple = AXES["L"]
    visible_product: bool = True
    #: scored frames per scene (spaced 20 planes apart, centred in the recording)
    frames: int = 4
    scenes: tuple = field(default=())  # empty: every benchmark scene
    #: also run the fast preset (see the module docstring)
    fast_preset: bool = True

    def __post_init__(self):
        _check_values("methods", self.baselines, tuple(BASELINES))
        _check_values("modes", self.modes, MODES)
        for axis in ("W", "K", "L", "align", "flow_frames"):
            _check_values(axis, getattr(self, axis), AXES[axis])
            if not getattr(self, axis):
                raise ValueError(f"{axis} needs at least one value (allowed: {_fmt(AXES[axis])})")
        _check_values("expensive_L", self.expensive_L, AXES["L"])
        if isinstance(self.frames, bool) or not isinstance(self.frames, int) or not 1 <= self.frames <= 8:
            raise ValueError(f"frames must be an integer in 1…8 (scored frames per scene); got {self.frames!r}")


def _fmt(values) -> str:
    return ", ".join("on" if v is True else "off" if v is False else str(v) for v in values)


def _check_values(name: str, values, allowed) -> None:
    if not isinstance(values, tuple):
        raise TypeError(f"{name} must be a tuple; got {type(values).__name__}")
    bad = [v for v in values if v not in allowed or isinstance(v, bool) != isinstance(allowed[0], bool)]
    if bad:
        raise ValueError(f"unknown {name} {_fmt(bad)}; allowed: {_fmt(allowed)}")
    if len(set(values)) != len(values):
        raise ValueError(f"{name} lists a value twice: {_fmt(values)}")


#: Every axis in full (`spikeref bench`): 4 baselines + 38 visible + the two fast presets + 8 mixed/blind settings.
FULL_GRID = BenchGrid()
#: `spikeref bench --quick`: the L axis, then K = 5, W = 20, no alignment and smoothed flow frames one
#: at a time at L = 3;
#: the two fast presets; mixed and blind at L = 0 only; two scored frames per scene.
QUICK_GRID = BenchGrid(expensive_L=(0,), visible_product=False, frames=2)


def grid_settings(grid: BenchGrid) -> list[Setting]:
    """Expand ``grid`` into the list of settings to run, baselines first, without repeats."""
    out: list[Setting] = []
    for b in grid.baselines:
        method, window = BASELINES[b]
        out.append(Setting(method, window=window))
    w0, k0, a0, f0 = grid.W[0], grid.K[0], grid.align[0], grid.flow_frames[0]

    def ours(mode, w, k, level, a, f):
        if not level:
            return Setting("ours", window=w, K=3, L=0, mode=mode, align=True)
        return Setting("ours", window=w, K=k, L=level, mode=mode, align=a, flow_frames=f if a else "denoised")

    for mode in grid.modes:
        if mode == "visible":
            if grid.visible_product:
                cand = [ours(mode, w, k, level, a, f) for w in grid.W for level in grid.L for k in grid.K
                        for a in grid.align for f in grid.flow_frames]
            else:
                cand = [ours(mode, w0, k0, level, a0, f0) for level in grid.L]
                top = max(grid.L)
                cand += [ours(mode, w0, k, top, a0, f0) for k in grid.K[1:]]
                cand += [ours(mode, w, k0, top, a0, f0) for w in grid.W[1:]]
                cand += [ours(mode, w0, k0, top, a, f0) for a in grid.align[1:]]
                cand += [ours(mode, w0, k0, top, True, f) for f in grid.flow_frames[1:]]
            if grid.fast_preset and max(grid.L) >= 2 and True in grid.align:
                cand += [Setting("ours", window=w0, K=k0, L=max(grid.L), mode=mode, align=True,
                                 flow_frames="smoothed", warp="chained", denoise=d) for d in (True, False)]
        else:
            cand = [ours(mode, w0, k0, level, a0, f0) for level in grid.expensive_L]
        for s in cand:
            if s not in out:
                out.append(s)
    return out


def parse_grid(quick: bool = False, methods=None, modes=None, W=None, K=None, L=None, align=None,
               frames=None, scenes=None, flow_frames=None) -> BenchGrid:
    """Build a grid from the command line: the full or quick grid with any axis replaced.

    ``methods`` holds baseline names (``tfp10, tfp100, tfi, tfstp``) and/or ``ours``;
    without ``ours`` the method is not run.  ``align`` holds ``"on"``/``"off"``, ``flow_frames``
    ``"denoised"``/``"smoothed"``.
    Unknown names raise ``ValueError`` naming the option and the allowed values.
    """
    base = QUICK_GRID if quick else FULL_GRID
    kw = {}
    if methods is not None:
        methods = tuple(methods)
        _check_values("methods", methods, (*BASELINES, "ours"))
        kw["baselines"] = tuple(m for m in methods if m != "ours")
        if "ours" not in methods:
            kw["modes"] = ()
    if modes is not None:
        if methods is not None and "ours" not in methods:
            raise ValueError("--modes given but --methods leaves out 'ours'")
        kw["modes"] = tuple(modes)
    for name, values in (("W", W), ("K", K), ("L", L)):
        if values is not None:
            kw[name] = tuple(int(v) for v in values)
    if L is not None:
        kw["expensive_L"] = tuple(v for v in kw["L"] if v in base.expensive_L) or (min(kw["L"]),)
    if align is not None:
        bad = [a for a in align if a not in ("on", "off")]
        if bad:
            raise ValueError(f"unknown align {', '.join(bad)}; allowed: on, off")
        kw["align"] = tuple(a == "on" for a in align)
    if flow_frames is not None:
        kw["flow_frames"] = tuple(flow_frames)
    if frames is not None:
        kw["frames"] = frames
    if scenes is not None:
        kw["scenes"] = tuple(scenes)
    return replace(base, **kw)
