"""The golden registry: every oracle module's cases, each paired with the fast function it checks.

A case is declared beside its oracle (``GOLDEN_CASES`` at the end of each module of
:mod:`spikeref.oracles`: inputs from fixed seeds, how the oracle makes the outputs, the tolerance, the
manifest's text).  This module, which sits in the application layer because it imports fast code, adds
the fast side (:data:`FAST`): the fast functions, plugged into the case's own ``outputs`` recipe where it
declares one.  ``scripts/make_golden.py`` runs every
oracle and freezes inputs and outputs in ``golden/<name>.npz`` with ``golden/manifest.json``
(:func:`build_manifest`); ``tests/test_golden.py`` holds both the oracle and the fast function to those
files.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Callable

import numpy as np

from spikeref import baselines as _bl
from spikeref import bayer as _bayer
from spikeref import charge as _charge
from spikeref import metrics as _met
from spikeref.accumulate import accumulate as _accumulate
from spikeref.denoise import blindspot as _bs
from spikeref.denoise import revisible as _rev
from spikeref.denoise import shrinkage as _shr
from spikeref.io import dat as _dat
from spikeref.oracles import accumulate as o_acc
from spikeref.oracles import align as o_align
from spikeref.oracles import baselines as o_bl
from spikeref.oracles import bayer as o_bayer
from spikeref.oracles import blindspot as o_bs
from spikeref.oracles import camera as o_cam
from spikeref.oracles import charge as o_charge
from spikeref.oracles import compose as o_compose
from spikeref.oracles import dat as o_dat
from spikeref.oracles import demosaic as o_dem
from spikeref.oracles import directional_demosaic as o_ddf
from spikeref.oracles import effects as o_fx
from spikeref.oracles import guard as o_guard
from spikeref.oracles import merge as o_merge
from spikeref.oracles import metrics as o_met
from spikeref.oracles import multiframe_demosaic as o_mf
from spikeref.oracles import pipeline as o_pipe
from spikeref.oracles import revisible as o_rev
from spikeref.oracles import shrinkage as o_shr
from spikeref.oracles import unet as o_unet
from spikeref.oracles import warp as o_warp
from spikeref.oracles.case import OracleCase
from spikeref.oracles.unet import unet_params_from_inputs
from spikeref.simulate import camera as _cam
from spikeref.simulate import effects as _fx

__all__ = ["GoldenCase", "CASES", "FAST", "MANIFEST_FORMAT", "manifest_entry", "build_manifest"]

#: The oracle modules whose ``GOLDEN_CASES`` make the registry, in the manifest's order.
ORACLE_MODULES = (o_dat, o_cam, o_fx, o_bs, o_unet, o_acc, o_charge, o_bayer, o_dem, o_ddf, o_bl, o_warp, o_align,
                  o_rev, o_shr, o_pipe, o_met, o_compose, o_guard, o_merge, o_mf)


@dataclass(frozen=True)
class GoldenCase(OracleCase):
    """An :class:`~spikeref.oracles.case.OracleCase` with ``run_function``: ``(inputs) -> outputs`` of the fast
    function, the same names as ``run_oracle``'s."""

    run_function: Callable[[dict], dict] | None = None


def _fire(case, i):
    return {"spikes": _cam.fire(i["charge"], float(i["threshold"]), np.array(i["phase"], dtype=np.float64, copy=True))}


def _unet(case, i):
    from spikeref.denoise.unet import UNet

    return {"output": UNet.from_params(unet_params_from_inputs(i))(i["images"])}


def _align_params(settings):
    from spikeref.align import AlignParams

    return AlignParams(**settings)


def _align(case, i):
    from spikeref.align import align, align_tiles

    return case.outputs(i, align_tiles, align, _align_params)


def _align_noise_aware(case, i):
    from spikeref.align import align_tiles
    from spikeref.align_noise import estimate_noise_correlation, local_noise

    return case.outputs(i, align_tiles, lambda r, a: 0.5 * (local_noise(r) + local_noise(a)),
                        estimate_noise_correlation, _align_params)


def _eq14(case, i):
    from spikeref.warp import warp_spike_windows

    k = i["flows"].shape[0]
    counts = i["spikes"].reshape((k, -1) + i["spikes"].shape[1:]).sum(1)
    return {"rates": warp_spike_windows(counts, i["flows"], i["spikes"].shape[0] // k)}


def _eq15(case, i):
    from spikeref.warp import warp_average

    return {"frame": warp_average(i["frames"], i["flows"])}


def _mhc(case, i):
    from spikeref.demosaic import demosaic_mhc

    return case.outputs(i, demosaic_mhc)


def _ddfapd(case, i):
    from spikeref.directional_demosaic import demosaic_ddfapd

    return case.outputs(i, demosaic_ddfapd)


def _flow_luma(case, i):
    from spikeref.pipeline import flow_luma

    return case.outputs(i, flow_luma)


def _pipeline(case, i):
    """The case's outputs from :class:`~spikeref.pipeline.Reconstructor` with its variant of the settings."""
    from spikeref.denoise.denoiser import Denoiser
    from spikeref.denoise.unet import UNet
    from spikeref.pipeline import ReconstructParams, Reconstructor
    from spikeref.stream import SpikeStream

    c = case.settings
    variant = dict(c["variant"])
    outputs = variant.pop("outputs", ("rgb", "flows", "steps"))
    guard = variant.pop("guard", "off")
    shrink = variant.pop("shrink", True)
    params = ReconstructParams(window=c["window"], K=c["K"], L=c["L"], align_params=_align_params(c["align"]),
                               **{"flow_frames": "denoised", "warp": "progressive", "accumulate": "count",
                                  "resample": "path", "merge": "binomial", **variant})
    net = UNet.from_params(unet_params_from_inputs(i), meta={"input_domain": "count"})
    rec = Reconstructor(SpikeStream.from_array(i["spikes"], cfa=c["cfa"]), params,
                        Denoiser(net, guard=guard, shrink=shrink))
    frames = list(rec.frames(c["frames"][0], c["frames"][-1] + 1, keep_steps=True))
    offsets = range(-(c["K"] // 2), c["K"] // 2 + 1)
    flows = [[[f.flows[(level, o)] if o else np.zeros_like(f.flows[(level, 1)]) for o in offsets]
              for level in range(c["L"])] for f in frames]
    out = {"rgb": np.stack([f.rgb for f in frames]), "steps": np.stack([np.stack(f.steps[:-1]) for f in frames]),
           "flows": np.array(flows)}
    return {k: out[k] for k in outputs}


def _composed(case, i):
    from spikeref.compose import composed_warp

    return case.outputs(i, composed_warp)


def _multiframe(case, i):
    from spikeref.multiframe_demosaic import multiframe_demosaic

    return case.outputs(i, multiframe_demosaic)


def _phase_diversity(case, i):
    from spikeref.multiframe_demosaic import phase_diversity

    return case.outputs(i, phase_diversity)


def _merge(case, i):
    from spikeref.merge import MergeParams, robust_merge

    return case.outputs(i, robust_merge, MergeParams)


def _guard(case, i):
    from spikeref.denoise import guard

    return case.outputs(i, guard.noise_sigma, guard.quantisation_variance, guard.carried_excess_variance,
                        guard.sure_alpha)


def _psi(cfa):
    return lambda c, i: {"rgb": _bayer.demosaic_bilinear(i["mosaic"], cfa)}


#: How the fast function makes each case's outputs: ``(case, inputs) -> outputs``; ``case`` gives what its oracle
#: module declared for both sides (:attr:`OracleCase.outputs`, :attr:`OracleCase.settings`).
FAST: dict[str, Callable] = {
    "dat_layout": lambda c, i: {"bytes": _dat.pack_planes(i["spikes"]).ravel(),
                             "cropped": _dat.unpack_planes(_dat.pack_planes(i["wide_spikes"]), 2, 12, 16)},
    "eq1_3_fire": _fire,
    "eq1_3_fire_fpn": lambda c, i: {"spikes": _cam.fire(i["charge"], i["thresholds"],
                                                     np.array(i["phase"], dtype=np.float64))},
    "eq3_cfa": lambda c, i: {"mosaic": _cam.mosaic_radiance(i["rgb"], "RGGB")},
    "eq6_9_noise": lambda c, i: c.outputs(i, _fx.dark_expected_count, _fx.inherent_rate_paper,
                                          _fx.inherent_rate_exact, _fx.noise_fraction),
    "eq10_11_blindspot": lambda c, i: {"volume": _bs.masked_volume(i["plane"]),
                                    "phi": _bs.mask_aware_average(i["outputs"], _bs.cell_masks(7, 10))},
    "unet_forward": _unet,
    "eq4_accumulate": lambda c, i: {"frames": _accumulate(i["spikes"], int(i["window"]), start=int(i["start"]))},
    "window_charge": lambda c, i: {"charge": _charge.window_charge(i["spikes"], int(i["window"]), int(i["start"]),
                                                                int(i["count"]), int(i["margin"]))},
    "bayer_planes": lambda c, i: {"planes": _bayer.bayer_planes(i["mosaic"])},
    **{f"psi_{cfa.lower()}": _psi(cfa) for cfa in o_bayer.CFA_PATTERNS},
    "demosaic_mhc": _mhc,
    "demosaic_ddfapd": _ddfapd,
    "tfp": lambda c, i: {"frames": np.stack([_bl.tfp(i["spikes"], 7, start=s, count=1)[0]
                                          for s in range(0, i["spikes"].shape[0] - 6)])},
    "tfi": lambda c, i: {"rates": _bl.tfi(i["spikes"])},
    "tfstp": lambda c, i: {"rates": _bl.tfstp(i["spikes"])},
    "eq14_warp_spikes": _eq14,
    "eq15_warp_frames": _eq15,
    "align_hdrplus": _align,
    "align_noise_aware": _align_noise_aware,
    "align_lk_regularised": _align,
    "eq12_revisible_loss": lambda c, i: c.outputs(i, _rev.revisible_loss),
    "shrinkage_residual": lambda c, i: c.outputs(i, _shr.shrink_residual),
    "pipeline_frames": _pipeline,
    "pipeline_frames_paper": _pipeline,
    "flow_luma": _flow_luma,
    "pipeline_frames_smoothed_flow": _pipeline,
    "pipeline_frames_composed_guard": _pipeline,
    "pipeline_frames_chained": _pipeline,
    "pipeline_frames_charge": _pipeline,
    "pipeline_frames_window": _pipeline,
    "metrics_psnr_ssim_pu21": lambda c, i: c.outputs(i, _met.psnr, _met.ssim, _met.pu21_encode),
    "composed_warp": _composed,
    "sure_guard": _guard,
    "robust_merge": _merge,
    "multiframe_demosaic": _multiframe,
    "phase_diversity": _phase_diversity,
}


def _register(case: OracleCase) -> GoldenCase:
    if case.name not in FAST:
        raise KeyError(f"golden case {case.name!r} has no fast function in spikeref.oracles.golden_cases.FAST")
    fast = FAST[case.name]
    return GoldenCase(**{f.name: getattr(case, f.name) for f in fields(OracleCase)},
                      run_function=lambda i: fast(case, i))


CASES: list[GoldenCase] = [_register(c) for module in ORACLE_MODULES for c in module.GOLDEN_CASES]
if len(CASES) != len(FAST):
    raise KeyError(f"fast functions without a case: {sorted(set(FAST) - {c.name for c in CASES})}")


#: ``format`` of ``golden/manifest.json``: 2 added each case's ``spec`` (format 1 had every other field).
MANIFEST_FORMAT = 2


def _array_spec(a: np.ndarray) -> dict:
    return {"dtype": str(a.dtype), "shape": list(a.shape)}


def manifest_entry(case: OracleCase, arrays: dict) -> dict:
    """The manifest entry of ``case`` whose file holds ``arrays`` (``{"in_…"/"out_…": array}``, file order)."""
    return {
        "name": case.name,
        "file": f"{case.name}.npz",
        "equation": case.equation,
        "function": case.function,
        "oracle": case.oracle,
        "description": case.description,
        "spec": case.spec,
        "params": case.params,
        "inputs": {k: _array_spec(np.asarray(a)) for k, a in arrays.items() if k.startswith("in_")},
        "outputs": {k: _array_spec(np.asarray(a)) for k, a in arrays.items() if k.startswith("out_")},
        "tolerance": {"rtol": case.rtol, "atol": case.atol},
    }


def build_manifest(golden, arrays: dict | None = None) -> dict:
    """``golden/manifest.json`` as the registry says it: every case of :data:`CASES`, in order.

    ``arrays`` maps a case name to its arrays (those just made); any other case's arrays are read
    from ``golden/<name>.npz`` (only their dtypes and shapes enter the manifest).
    """
    from pathlib import Path

    golden = Path(golden)
    arrays = arrays or {}
    cases = []
    for case in CASES:
        if case.name in arrays:
            found = arrays[case.name]
        else:
            path = golden / f"{case.name}.npz"
            if not path.is_file():
                raise FileNotFoundError(f"{path} is missing: make it with scripts/make_golden.py --only {case.name}")
            with np.load(path, allow_pickle=False) as data:
                found = {k: data[k] for k in data.files}
        cases.append(manifest_entry(case, found))
    return {"format": MANIFEST_FORMAT, "cases": cases}
