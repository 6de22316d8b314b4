"""The audit map: each equation → the function that runs it → its literal oracle → its tests → its golden files.

One registry for ``docs/equations.md``'s table: ``scripts/make_golden.py`` writes the table between the
markers from :data:`AUDIT_MAP`, and ``tests/test_golden_spec.py`` fails when the committed file differs.
The golden column names cases of :data:`spikeref.oracles.golden_cases.CASES` as ``{name}`` (the file and
the link to its specification, both from the registry that also writes ``golden/manifest.json``) or
``{name:file}`` (the file alone); the other columns are the text of the table.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from spikeref.oracles.golden_cases import CASES

__all__ = ["AuditRow", "AUDIT_MAP", "BEGIN", "END", "audit_table", "render_golden", "with_audit_table"]

#: The markers around the generated table in ``docs/equations.md``.
BEGIN = "<!-- audit map: written by scripts/make_golden.py from spikeref/oracles/audit_map.py; edit there -->"
END = "<!-- end of the audit map -->"


@dataclass(frozen=True)
class AuditRow:
    """One row of the audit map (Markdown text; ``golden`` with ``{case}`` / ``{case:file}`` placeholders)."""

    equation: str
    what: str
    function: str
    oracle: str
    tests: str
    golden: str


def render_golden(template: str) -> str:
    """``{name}`` → the file ``name.npz`` in backquotes and its ``[spec](spec/…)`` link; ``{name:file}`` → the file.

    The link is the case's ``spec`` in the registry, relative to ``docs/``; a name the registry does not
    have raises ``KeyError``.
    """
    specs = {c.name: c.spec for c in CASES}

    def case(name: str) -> str:
        if name not in specs:
            raise KeyError(f"the audit map names golden case {name!r}, which the registry does not have")
        return name

    def linked(m) -> str:
        name = case(m.group(1))
        return f"`{name}.npz` ([spec]({specs[name].removeprefix('docs/')}))"

    text = re.sub(r"\{(\w+):file\}", lambda m: f"`{case(m.group(1))}.npz`", template)
    return re.sub(r"\{(\w+)\}", linked, text)


def audit_table() -> str:
    """The Markdown table of :data:`AUDIT_MAP`."""
    lines = ["| eq. | what | function | oracle | tests | golden |", "| --- | --- | --- | --- | --- | --- |"]
    for r in AUDIT_MAP:
        lines.append(f"| {r.equation} | {r.what} | {r.function} | {r.oracle} | {r.tests} | {render_golden(r.golden)} |")
    return "\n".join(lines)


def with_audit_table(text: str) -> str:
    """``text`` (``docs/equations.md``) with the part between :data:`BEGIN` and :data:`END` written anew."""
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise ValueError("docs/equations.md must hold the audit map's BEGIN and END markers once each, in order")
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    return f"{head}{BEGIN}\n{audit_table()}\n{END}{tail}"


AUDIT_MAP: tuple[AuditRow, ...] = (
    AuditRow(
        equation='1–3',
        what='integrate-and-fire behind a CFA, subtract reset',
        function='`spikeref.simulate.camera.fire`, `mosaic_radiance`; run by `spikeref.simulate.simulator.simulate`',
        oracle='`oracles.camera.fire_oracle`, `mosaic_radiance_oracle`',
        tests='`tests/test_camera.py` (exact to the spike for dyadic radiance), `tests/test_golden.py`',
        golden='{eq1_3_fire}, {eq1_3_fire_fpn} (per-pixel thresholds), {eq3_cfa}',
    ),
    AuditRow(
        equation='5',
        what='diffuse (dark-current) photons, Poisson',
        function='`spikeref.simulate.effects.add_dark_current` (effect `dark_current`)',
        oracle='Poisson law itself',
        tests='`tests/test_effects.py::test_eq5_dark_photons_are_poisson` (mean and variance)',
        golden='— (random)',
    ),
    AuditRow(
        equation='6',
        what='`E[N_d] = αγW/E_th`',
        function='`effects.dark_expected_count`',
        oracle='`oracles.effects.dark_expected_count_oracle`',
        tests='`tests/test_effects.py::test_eq6_dark_current_expected_count` (simulated counts, 5 standard errors)',
        golden='{eq6_9_noise}',
    ),
    AuditRow(
        equation='7',
        what='inherent noise, Gaussian intervals',
        function=('`effects.InherentNoiseProcess`, `draw_inherent_intervals`, `draw_first_inherent` (effect '
                  '`inherent_noise`)'),
        oracle='—',
        tests='`tests/test_effects.py` (fraction of pixels, stationary start)',
        golden='— (random)',
    ),
    AuditRow(
        equation='8',
        what='`E[N_i] = C_i W`',
        function=("`effects.inherent_rate_paper` (the paper's integral), `inherent_rate_exact` (what the simulator "
                  'does)'),
        oracle='`oracles.effects.inherent_rate_paper_oracle` (adaptive quadrature), `inherent_rate_exact_oracle`',
        tests='`tests/test_effects.py::test_eq8_*`',
        golden='{eq6_9_noise}',
    ),
    AuditRow(
        equation='9',
        what='`E[N]/W = αγ/E_th + C_i`',
        function='`effects.noise_fraction`',
        oracle='`oracles.effects.noise_fraction_oracle`',
        tests='`tests/test_effects.py::test_eq9_diffuse_plus_inherent`',
        golden='{eq6_9_noise}',
    ),
    AuditRow(
        equation='Fig. 4a',
        what='noise ratio `I_c/E[I_c] − 1` against `W`, `E` the whole-span mean',
        function='`spikeref.noise_check.noise_check` (`spikeref noise-check`)',
        oracle='the Bernoulli variance `(1 − p)/(pW)·(1 − 1/n)`',
        tests=('`tests/test_noise_check.py` (theory, periodic stream exact zero, channel pooling, packed = '
               'in-memory, real recording)'),
        golden='—',
    ),
    AuditRow(
        equation='—',
        what='other effects: threshold FPN, random phase, shot noise, hot pixels',
        function='`effects.fpn_thresholds`, `initial_phase`, `add_shot_noise`, `hot_pixel_charge`',
        oracle='—',
        tests='`tests/test_effects.py` (fixed pattern, uniform first spikes by χ², variance/mean, defect count)',
        golden='— (random)',
    ),
    AuditRow(
        equation='4',
        what='window accumulation `I_c = M_c/W · Σ S_c`',
        function=('`spikeref.accumulate.accumulate`, `window_counts` (packed and unpacked kernels in '
                  '`spikeref._accumulate_kernels`)'),
        oracle='`oracles.accumulate.accumulate_oracle`',
        tests='`tests/test_accumulate.py`, `tests/test_golden.py`',
        golden='{eq4_accumulate}',
    ),
    AuditRow(
        equation="— (not in the paper; the pipeline's default, `paper()` keeps Eq. 4)",
        what=("timing-aware Eq. 4: a window's charge `c = n + φ(s + W) − φ(s)`, `φ(b) = (b − t_prev − ½)/(t_next − "
              't_prev)` the elapsed fraction of the inter-spike interval straddling the boundary `b` (spikes looked '
              'for within `M` = 200 readouts; `φ = ½` without both), clipped at 0; rates `c / W` '
              '([spec](spec/accumulate.md#window_charge))'),
        function=('`spikeref.charge.window_charge`, `charge_rates`; `spikeref.pipeline.Reconstructor` with '
                  '`ReconstructParams(accumulate="charge")`, `Denoiser.frames(accumulate="charge")`, `--accumulate '
                  'charge`; `TrainConfig(accumulate="charge")`'),
        oracle='`oracles.charge.window_charge_oracle` (spike lists per pixel)',
        tests=('`tests/test_charge.py` (oracle by hypothesis, `M = 0` = Eq. 4, adjacent windows add up, ideal '
               "pixels: error ≈ p × the count's, dark pixels fall back), `tests/test_pipeline.py` (zero flow = "
               "weighted charge, chunks, the output guard's reference window, the real recording), "
               '`tests/test_distributed.py` (chunks read the margin), `tests/test_golden.py`'),
        golden=('{window_charge}, {pipeline_frames_charge:file} (the pipeline on charges: oracle '
                '`oracles.pipeline.reconstruct_oracle(accumulate="charge")`, '
                '[spec](spec/pipeline.md#pipeline_frames_charge))'),
    ),
    AuditRow(
        equation="— (not in the paper; §4.2's pseudo-long exposure, merged robustly; the default on window charges)",
        what=("the robust merge: each aligned window weighed by `r = clip(2 − z/z₀, 0, 1)` of a clipped χ² of its "
              "difference to the merge over a 5×5 box, beyond the noise; the adaptive support: shells of windows "
              "beyond Eq. 14–15's, reached by chaining step-0 flows, taken where `λ b² share² <` the variance they "
              "remove, the bias judged against the core's scatter floored at `φ v / max(1, e W)` "
              "([spec](spec/merge.md#robust_merge))"),
        function=('`spikeref.merge.robust_merge`; `spikeref.compose.composed_samples`, `chained_samples`; '
                  '`ReconstructParams(merge="auto" | "robust" | "adaptive", support=10)` (the pipeline passes '
                  '`MergeParams(window=W)`)'),
        oracle='`oracles.merge.robust_merge_oracle` (pixel by pixel)',
        tests=('`tests/test_merge.py` (oracle by hypothesis, an occluder dropped, a static scene grown, shells refused '
               'where a far window differs, the floor in full up to one spike a window), `tests/test_compose.py` '
               '(the samples against `composed_warp`), '
               '`tests/test_pipeline.py` (the pipeline\'s merges)'),
        golden="{robust_merge}",
    ),
    AuditRow(
        equation="— (not in the paper; replaces Eq. 13's Ψ where the merge is robust or adaptive: the default)",
        what=("the multi-frame demosaic: each full-resolution pixel and colour gathers every merged window's raw "
              "Bayer samples around where its content is in that window, weighted by the window's final merge weight "
              "and a Gaussian of the distance (`σ = 0.6` px for red and blue, `σ/√2` for green); the denoiser's change "
              "of the merged planes is added through Ψ, and a sharper demosaic's correction (the directional "
              "demosaic where the colours share their detail, `colour_detail_ratio`, Malvar–He–Cutler's elsewhere) "
              "where the windows sampled only the reference's CFA phases (`1 − δ`, "
              "[spec](spec/multiframe_demosaic.md#phase_diversity)), halved where the colour is saturated "
              "(`colour_saturation`); where the merge took about one window "
              "the gathered increment ramps out and its Wiener gain takes that pixel's noise "
              "([spec](spec/multiframe_demosaic.md#multiframe_demosaic))"),
        function=('`spikeref.multiframe_demosaic.multiframe_demosaic`, `phase_diversity`, `colour_saturation`; '
                  '`spikeref.merge.robust_merge(final_weights=True)`; `ReconstructParams(demosaic="auto" | '
                  '"multiframe")`'),
        oracle=('`oracles.multiframe_demosaic.multiframe_demosaic_oracle` (pixel by pixel), '
                '`phase_diversity_oracle` (cell by cell)'),
        tests=('`tests/test_multiframe_demosaic.py` (oracle by hypothesis, one window keeps each site\'s value, four '
               'phases recover what one mosaic misses, the fallback, δ against its oracle and at the lattice, the '
               'gain and the ramp where the merge took one window), `tests/test_compose.py` (the reference at its '
               'own pixels), '
               '`tests/test_pipeline.py` (the default, a static and a moving scene, the MHC correction pays where '
               'nothing moves), `tests/test_merge.py` (the final '
               'weights are the estimate\'s)'),
        golden="{multiframe_demosaic}, {phase_diversity}, {robust_merge} (`final_adaptive_floor`)",
    ),
    AuditRow(
        equation="— (not in the paper; the pipeline's default, `paper()` keeps them)",
        what=("hot pixels: found in the recording (above the second largest of the 8 same-colour neighbours by "
              "`max(0.1, 6σ)` over the stretch and in half its blocks, and alone among the 8 mosaic neighbours), "
              "replaced in every window by the mean of their non-hot same-colour neighbours"),
        function=('`spikeref.hot_pixels.find_hot_pixels`, `HotPixelRepair`; `spikeref.pipeline.Reconstructor` '
                  '(`ReconstructParams(hot_pixels="auto")`, `hot_pixels=` map), `Denoiser.frames(hot_pixels=)`, '
                  '`--hot-pixels`, `spikeref calibrate`'),
        oracle='`hot_pixels.repair_oracle` (the repair, pixel by pixel)',
        tests=('`tests/test_hot_pixels.py` (repair against its oracle by hypothesis, moving points, spots of light, '
               'pairs and blobs), `tests/test_pipeline.py` (replaced before the windows are read; the paper keeps '
               'them), `tests/test_effects.py` (the simulator\'s `hot_pixels` with a range of rates), '
               '`tests/test_cli.py` (`calibrate`, `--hot-pixels`)'),
        golden="— (not frozen: a port may leave it out; `scripts/study_hot_pixels.py` measures it)",
    ),
    AuditRow(
        equation="Eq. 9 (`E[N]/W = αγ/E_th + C_i`, which the paper's frames keep; subtracting it is not in the paper)",
        what=("the dark level: each 2×2 phase's mean rate over a dark recording (hot pixels left out), subtracted "
              "from every output frame per colour (mean of the colour's phases; a monochrome frame per phase), "
              "clipped at 0"),
        function=('`spikeref.dark_level.measure_dark_level`, `calibrate_dark`, `subtract_dark_level`; '
                  '`spikeref.pipeline.Reconstructor(dark_level=)`, `spikeref calibrate`, `--dark-level`, '
                  '`spikeref bench --ladder --dark-calibration`'),
        oracle='`dark_level.dark_level_oracle` (phase by phase, pixel by pixel)',
        tests=('`tests/test_dark_level.py` (oracle by hypothesis, per phase with hot pixels left out, a simulated '
               'dark recording gives Eq. 6 + Eq. 8, the subtraction per colour and per phase, the Reconstructor\'s '
               'frames and steps), `tests/test_cli.py` (`calibrate` stores it, `--dark-level`), '
               '`tests/test_ladder.py` (the calibrated ladder)'),
        golden="— (a mean and a subtraction; the spec is the module's docstring)",
    ),
    AuditRow(
        equation='§4.1',
        what='mosaic → 4 Bayer planes and back',
        function='`spikeref.bayer.bayer_planes`, `bayer_mosaic`',
        oracle='`oracles.bayer.bayer_planes_oracle`',
        tests='`tests/test_bayer.py`',
        golden='{bayer_planes}',
    ),
    AuditRow(
        equation='10–11',
        what=('masked volume Ω (4×4 cells, 16 masks) and mask-aware averaging Φ; `visible` / `blind` / `mixed` '
              'inference'),
        function='`spikeref.denoise.blindspot.masked_volume`, `mask_aware_average`, `blindspot_denoise`',
        oracle='`oracles.blindspot.masked_volume_oracle`, `mask_aware_average_oracle`',
        tests='`tests/test_blindspot.py`, `tests/test_golden.py`',
        golden='{eq10_11_blindspot}',
    ),
    AuditRow(
        equation='— (not in the paper)',
        what=('residual shrinkage after `D`: `D(I) + g·(I − D(I))`, `g = max(0, 1 − σ²/mean₃ₓ₃ r²)`, `σ² = p(1 − '
              'p)/W` (binomial, `p = D(I)` clipped to `[1/2W, 1 − 1/2W]`); on by default, `shrink=False` / '
              "`--no-shrink` gives the paper's `D(I)`"),
        function='`spikeref.denoise.shrinkage.shrink_residual` (applied by `Denoiser`)',
        oracle='`oracles.shrinkage.shrink_residual_oracle`',
        tests=('`tests/test_shrinkage.py` (oracle by hypothesis, pinned 0.725, limits), `tests/test_denoiser.py`, '
               '`tests/test_golden.py`'),
        golden='{shrinkage_residual}',
    ),
    AuditRow(
        equation='12',
        what='re-visible loss `mean((D + λ sg(f) − (λ+1)I)²) + η mean((D − I)²)`, λ 2 → 20',
        function='`spikeref.denoise.revisible.revisible_loss` (NumPy), `revisible_loss_torch` (training)',
        oracle='`oracles.revisible.revisible_loss_oracle` (pixel by pixel)',
        tests=('`tests/test_revisible.py` (hand-computed 0.0074, torch loss = golden values, no gradient through the '
               'visible term, gradient of the blind term), `tests/test_golden.py`'),
        golden='{eq12_revisible_loss}',
    ),
    AuditRow(
        equation='13 (Ψ)',
        what='bilinear demosaic',
        function='`spikeref.bayer.demosaic_bilinear`',
        oracle='`oracles.bayer.demosaic_bilinear_oracle`',
        tests='`tests/test_bayer.py`',
        golden='{psi_rggb:file}, {psi_bggr:file}, {psi_grbg:file}, {psi_gbrg}',
    ),
    AuditRow(
        equation='§5.2',
        what='TFP baseline',
        function='`spikeref.baselines.tfp`',
        oracle='`oracles.baselines.tfp_spikecv_oracle`',
        tests='`tests/test_baselines.py` (incl. real data)',
        golden='{tfp}',
    ),
    AuditRow(
        equation='§5.2',
        what='TFI baseline',
        function='`spikeref.baselines.tfi`',
        oracle='`oracles.baselines.tfi_oracle`',
        tests='`tests/test_baselines.py` (incl. real data)',
        golden='{tfi}',
    ),
    AuditRow(
        equation='§5.2',
        what='TFSTP baseline',
        function='`spikeref.baselines.tfstp`',
        oracle='`oracles.baselines.tfstp_oracle`',
        tests='`tests/test_baselines.py`',
        golden='{tfstp}',
    ),
    AuditRow(
        equation='§4.1, suppl. §8',
        what=('U-Net `f_θ`: head, 5 encoder + 5 decoder blocks of two 3×3 convs, LeakyReLU 0.1, skips, tail (25 '
              'convs), constant width `C`'),
        function=('`spikeref.denoise.unet.UNet` (direct Numba 3×3 kernel `denoise.conv.conv3x3`, channel-first, '
                  'zero-bordered activations; `denoise._conv_alternatives.conv3x3_im2col` = im2col + BLAS kept as '
                  'the measured alternative); PyTorch twin `denoise.torch_unet.TorchUNet` for training'),
        oracle='`oracles.unet.unet_forward_oracle` (loops over taps, channels-first)',
        tests=('`tests/test_unet.py` (direct, im2col and plain convolutions against `oracles.unet.conv3x3_oracle` by '
               'hypothesis, oracle, torch parity float32, padding/cropping, same output with one thread and the '
               'whole Numba pool, weights file errors), `tests/test_golden.py`'),
        golden='{unet_forward} (width 8, fixed random weights)',
    ),
    AuditRow(
        equation='12 (training)',
        what='Blind2Unblind training: crops, `W` log-uniform 5…200, flips/turns, masked volume in torch',
        function='`spikeref.denoise.train.train`, `masked_volume_torch`, `CropSampler` (`spikeref train`)',
        oracle='`denoise.blindspot.masked_volume` (NumPy Eq. 10–11)',
        tests=('`tests/test_train.py` (torch volume = NumPy volume, resume = uninterrupted run, no ground truth '
               'read, export loads in NumPy)'),
        golden='—',
    ),
    AuditRow(
        equation='— (training; not in the paper)',
        what=('Noise2Noise pairs on static streams (`TrainConfig(objective="pairs")`, the bundled charge network): '
              'one window against the spike count of every plane its input did not read, scaled to `W`'),
        function='`spikeref.denoise.train.CropSampler.sample_pairs`, `train_step` (`spikeref train --objective pairs`)',
        oracle='the literal sums in the test (planes outside `[t − 200, t + W + 200)`, times `W` over their number)',
        tests=('`tests/test_train.py` (target = those sums, in-memory and packed; input and target turned together; '
               'too-short streams refused; resume = uninterrupted run)'),
        golden='—',
    ),
    AuditRow(
        equation='13',
        what='`R_0 = Ψ[D(I_0)]`, for flow only; output `R_L = Ψ[D(I_L)]`; the whole of Fig. 3(b)',
        function='`spikeref.pipeline.Reconstructor`, `reconstruct` (`spikeref reconstruct`)',
        oracle=('`oracles.pipeline.reconstruct_oracle` (the recursion over steps, built from the oracles of the '
                'other rows, no streaming)'),
        tests=('`tests/test_pipeline.py` (K = 1 / L = 0 = denoised TFP, zero flow = weighted accumulation, chunks = '
               'full run, reads only the support, bounded rings), `tests/test_golden.py`'),
        golden=("{pipeline_frames} (W = 5, K = 3, L = 3, 64×64, the U-Net's weights inside; frames, earlier steps, "
                "flows; with the residual shrinkage), {pipeline_frames_paper} (the paper's D alone: `--paper`)"),
    ),
    AuditRow(
        equation='§4.2, suppl. §8',
        what=('HDR+ tile alignment on the 2×2 luma of `D(I_l)`: pyramid 1…⅛, L2 coarse / L1 fine, 3-candidate '
              'upsampling, quadratic sub-pixel fit (`AlignParams()`; the default pipeline runs Lucas–Kanade steps '
              'instead, `refine="lk"`, with `smoothness=300` and `zero_test=2`: the row after the noise-aware '
              "search's), bilinear per-pixel flow"),
        function='`spikeref.align.align`, `align_tiles`, `flow_from_tiles`, `gaussian_pyramid`, `luma`',
        oracle=('`oracles.align.align_tiles_oracle`, `flow_from_tiles_oracle` (their pieces in `oracles.align_search`: '
                '`gaussian_pyramid_oracle`, `search_oracle`; `oracles.align_refine.quadratic_offset_oracle`)'),
        tests=('`tests/test_align.py` (oracle, known integer / long / sub-pixel shifts, flat → 0), '
               '`tests/test_pipeline.py::test_flow_follows_known_motion`'),
        golden='{align_hdrplus} (known shifts in `in_shifts`)',
    ),
    AuditRow(
        equation="— (not in the paper; the pipeline's default, `paper()` keeps Fig. 3(b)'s `D(I_l)`)",
        what=("flow frames: each step's flow aligns the 2×2 luma of the raw `I_l` smoothed by a Gaussian of σ = 1 "
              'plane pixel (taps cut at ⌊4σ + ½⌋, half-sample symmetric border) instead of the luma of `D(I_l)`; the '
              'denoiser runs once per output frame instead of `L + 1` times'),
        function=('`spikeref.pipeline.flow_luma`; `spikeref.pipeline.Reconstructor` with '
                  '`ReconstructParams(flow_frames="smoothed")`'),
        oracle='`oracles.pipeline.flow_luma_oracle`, `oracles.pipeline.reconstruct_oracle(flow_frames="smoothed")`',
        tests=('`tests/test_pipeline.py` (flows = `align` of `flow_luma`, one denoiser call per frame, chunks = full '
               'run), `tests/test_golden.py`'),
        golden='{flow_luma}, {pipeline_frames_smoothed_flow}',
    ),
    AuditRow(
        equation='14',
        what="`I_1 = M_c/(KW) Σ_{t'} S_c(x + F_0, t')`: spike planes of K windows warped onto the reference",
        function='`spikeref.warp.warp_spike_windows` (warps window counts)',
        oracle='`oracles.warp.eq14_oracle` (plane by plane)',
        tests='`tests/test_warp.py` (counts = planes, zero flow = Eq. 4 over K·W)',
        golden='{eq14_warp_spikes}',
    ),
    AuditRow(
        equation='15',
        what='`I_l = 1/K Σ_i I_{l−1}(x + F_{l−1}, t_i)`',
        function='`spikeref.warp.warp_average`',
        oracle='`oracles.warp.eq15_oracle`',
        tests='`tests/test_warp.py` (convex combination, integer shift undone, renormalised border)',
        golden='{eq15_warp_frames}',
    ),
    AuditRow(
        equation='— (not in the paper; the default output)',
        what=('composed warp: `I_L(x, k) = Σ_π v_π S_{k+Σπ}(x_π) / (W Σ_π v_π)` over the `K^L` paths `π = (i_L … '
              'i_1)`; the position moves hop by hop by the step flows `F_m(j, j+i)` of the frame reached (bilinear '
              'flow lookup, clamped), and the window reached is sampled once with Catmull–Rom (Keys `a = −½`, '
              'clamped taps); a position outside the plane drops its path. `resample="window"` (the pipeline\'s '
              'default): each window sampled once at the mean position of its kept paths, weighted by their number'),
        function=('`spikeref.compose.composed_warp`, `path_table`; in the pipeline `spikeref.pipeline.Reconstructor` '
                  'with `ReconstructParams(warp="composed")` (default; `"progressive"` = Eq. 14–15; `"chained"` = '
                  'every hop by the step-0 flow, a speed option)'),
        oracle=("`oracles.compose.composed_warp_oracle` (path by path, Keys' kernel written out; `resample=`); in "
                'the pipeline `oracles.pipeline.reconstruct_oracle(warp="composed")`, `(warp="chained")` and '
                '`(resample="window")`'),
        tests=('`tests/test_compose.py` (oracle by hypothesis, whole-pixel flows = shifted windows, one resample '
               'keeps a fine pattern the chained bilinear warps blur), `tests/test_pipeline.py` (same flows as '
               'progressive, +1 dB on a panning photograph, chunks, rings), `tests/test_golden.py`'),
        golden=('{composed_warp} (alone, both resamplings), {pipeline_frames_composed_guard}, '
                '{pipeline_frames_chained}, {pipeline_frames_window}'),
    ),
    AuditRow(
        equation='— (not in the paper; on by default)',
        what=('SURE guard after `D`: `I + α (f(I) − I)`, `α = clip(Σ_N σ²(1 − ∂f/∂I) / Σ_N (f − I)², 0, 1)` over a '
              "17×17 box `N`; `σ²` per pixel = `max(σ_c², q(p))`, two terms: `σ_c` the plane's noise σ by Immerkær's "
              '3×3 filter (the mean of the smallest 75 % of its absolute responses over the interior, divided by '
              "`6U`, `U = 0.5149…` the mean of a standard half-normal over its smallest 75 %), and the count's "
              "quantisation floor `q(p) = min(min(p, 1−p)/W, 1/(6W²))` of the network's output `p = f(I)` (clipped "
              'to [0, 1]; `W` the exposure); `∂f/∂I` by one Monte-Carlo probe (±1 from `default_rng(0)`) with step '
              '`ε_c = 0.05·√(mean over the plane of σ²)`; applied to the output only '
              '([spec](spec/denoise.md#sure-guard)); at an exposure `W` > 10 planes `σ_c²` is capped at `κ·e·W₀/W + '
              "mean q(f(I))`, `e` the noise above the floor on a short window of `W₀ ≤ 10` planes (denoise mode: the "
              'window\'s first 10; the pipeline\'s output with `accumulate="charge"`: the reference window, `W₀ = W`, '
              '`q` then the charge\'s floor `min(q, p²/(6W²))`), `κ = 0.75`, and `e = 0` where no such window is '
              'given (a bare call, the pipeline\'s count path): the floor alone '
              '([spec](spec/denoise.md#noise-measured-on-a-short-window-denoise-mode))'),
        function=('`spikeref.denoise.guard.sure_blend`, `noise_sigma`, `quantisation_variance`, '
                  '`carried_excess_variance`, `trusted_excess`, `sure_alpha`; `Denoiser(guard="sure")` '
                  '(`--guard off` and `--paper` '
                  "for the paper's `D`)"),
        oracle=('`oracles.guard.noise_sigma_oracle`, `quantisation_variance_oracle`, '
                '`carried_excess_variance_oracle`, `sure_alpha_oracle`; the pipeline oracle\'s `guard="sure"`'),
        tests=('`tests/test_guard.py` (unbiased σ on white noise, quantised rates, oracle by hypothesis, keeps an '
               "ideal denoiser, undoes a detail-killing one, low light, the short window's noise: nothing above the "
               'floor for pure quantisation, shot noise carried as 1/W, texture given back at W = 200, a long '
               'window alone never made much worse), `tests/test_denoiser.py` (frames pass the first 10 planes, a '
               "bare long window takes the floor, the README's call never worse on real spikes), "
               '`tests/test_golden.py`'),
        golden='{sure_guard} (its pieces alone), {pipeline_frames_composed_guard}',
    ),
    AuditRow(
        equation='— (not in the paper; on by default)',
        what=('noise-aware search: zero motion (else the search centre) kept unless the best match beats it by more '
              "than `prefer_centre` = 3 standard deviations of what noise explains; the zero offset's distance "
              "corrected for adjacent windows' anti-correlated count noise (`ρ` clipped at −½)"),
        function=('`spikeref.align.align_tiles` and `align(..., noise=, correlation=)` with '
                  "`AlignParams(prefer_centre=3)` (the pipeline's default, `AlignParams()` keeps 0); "
                  '`spikeref.align_noise.estimate_noise`, `local_noise`, `estimate_noise_correlation`'),
        oracle=('`oracles.align.align_tiles_oracle` with `prefer_centre > 0` '
                '(`oracles.align_search.noise_aware_search_oracle`: the zero and centre rules written out; biases and '
                'thresholds as plain sums over each tile, `oracles.align_noise.bias_and_threshold_oracle`), '
                '`oracles.align_noise.local_noise_oracle`, `estimate_noise_oracle`, '
                '`estimate_noise_correlation_oracle`, `level_noise_factors_oracle`'),
        tests=('`tests/test_align.py` (kernels = oracle on twelve pairs, each at two pyramids and two steps: still '
               'and moving pairs with anti-correlated noise, noise estimated or given as a number or a map, ρ > 0, ρ '
               'clipped, unrelated images, whole-number counts with exact ties, no noise; estimators = oracles; '
               'defaults bit-identical, zero kept on the noise of a static scene, the zero-offset bias for '
               'anti-correlated noise, motion still found, the real near-static recording, argument errors), '
               '`tests/test_golden.py`'),
        golden='{align_noise_aware}',
    ),
    AuditRow(
        equation="— (not in the paper or HDR+; the pipeline's default)",
        what=('Lucas–Kanade sub-pixel steps, a regularised tile field and a per-pixel zero-motion test. '
              '`refine="lk"`: 2 Gauss–Newton steps of a translation per tile from the integer vector, `Δ = G⁻¹ Σ g '
              "(ref(p) − alt(p + u))`, `G = Σ g gᵀ`, `g` the alternate's central-difference gradient (one-sided at "
              'the border), both sampled bilinearly; each step clipped to ±1 per component, a singular `G` (`det ≤ '
              '10⁻⁹ tr²`) stops them, samples moved outside the image left out; replaces the quadratic fit. '
              '`smoothness=λ` (300): the field after exactly 30 Jacobi sweeps `u_i ← (J_i + λ n_i I)⁻¹ (J_i û_i + λ '
              'Σ_{j~i} u_j)` towards the minimiser of `Σ_i (u_i − û_i)ᵀ J_i (u_i − û_i) + λ Σ_{i~j} |u_i − u_j|²` '
              "(4-neighbours), `J_i` the tile's `G` over its mean noise variance (floored at 10⁻²⁰); where `J ≪ λ` "
              'thirty sweeps are not the minimiser, and the sweeps are the definition. `zero_test=z₀` (2): per pixel '
              'the flow set to zero where `Σ_{9×9} d < −z₀ √(Σ_{9×9} q)`, `d = (r − a)² − (r − a(p + F))²` less its '
              'noise-only mean, `q` its variance under Gaussian noise (the bilinear weights and the same-pixel '
              'correlation `ρ` ≥ −½ in both; sample position clamped, box edge-replicated), on the raw frames '
              '(`align(..., raw=)`; the pipeline: the 2×2 luma before smoothing or denoising) '
              '([spec](spec/align.md#lucas-kanade-refinement))'),
        function=('`spikeref.align.align_tiles`, `align` (`noise=`, `correlation=`, `raw=`), '
                  '`spikeref.align_noise.zero_motion_test`; '
                  '`AlignParams(refine="lk", smoothness=300, zero_test=2)` with `prefer_centre=3` = '
                  '`pipeline.default_align_params()` (`AlignParams()` keeps HDR+)'),
        oracle=('`oracles.align.align_tiles_oracle` with `refine="lk"`, `smoothness > 0` '
                '(`oracles.align_refine.lucas_kanade_oracle`, `gradient_oracle`, `bilinear_oracle`, '
                '`tile_noise_oracle`, `regularise_oracle`; `sweeps=None` gives the exact minimiser), `align_oracle` '
                'with `zero_test` (`oracles.align_zero_test.zero_motion_test_oracle`, `zero_motion_sums_oracle`)'),
        tests=('`tests/test_align.py` (kernels = oracles on seven pairs at two steps — still, moving, an object on a '
               'still background with the zero test on the raw frames, half flat without noise; noise estimated, '
               "given, a map, `ρ` clipped —, the float64 kernels to 10⁻¹⁰, the Jacobi sweeps reach the energy's "
               "minimiser, Gauss–Newton converges on a bilinear image, the zero test's noise moments by Monte Carlo; "
               'sub-pixel shifts recovered, flat and identical input stay at 0, noise quieted on a static scene, '
               'motion dropped where zero explains better), '
               '`tests/test_pipeline.py::test_default_alignment_refines_by_lucas_kanade_and_the_paper_does_not`, '
               '`tests/test_golden.py`'),
        golden='{align_lk_regularised}',
    ),
    AuditRow(
        equation='— (not in the paper; an option)',
        what=('Malvar–He–Cutler demosaic of the output frame: the sampled colour kept, G at R/B and R/B at G or B/R '
              'from five 5×5 linear filters (eighths), whole-sample mirrored border, negatives clipped to 0'),
        function=('`spikeref.demosaic.demosaic_mhc`; `ReconstructParams(demosaic="mhc")`, `spikeref reconstruct '
                  "--demosaic mhc` (Ψ stays the default and the flow's)"),
        oracle='`oracles.demosaic.demosaic_mhc_oracle`',
        tests=('`tests/test_demosaic.py` (oracle by hypothesis for the four patterns, exact on linear grey ramps, '
               'sharper than Ψ on fine grey detail, clipping)'),
        golden='{demosaic_mhc}',
    ),
    AuditRow(
        equation='— (not in the paper; the multi-frame demosaic\'s correction, and an option)',
        what=('Menon–Andriani–Calvagno (2007) directional demosaic without its refining step: green along the rows '
              'and the columns by [−¼, ½, ½, ½, −¼], the direction whose colour differences vary less over the 5×5 '
              'window, R and B through their differences with G, whole-sample mirrored border, negatives clipped'),
        function=('`spikeref.directional_demosaic.demosaic_ddfapd`; `multiframe_frame`\'s correction where the '
                  'colours share their detail (`colour_detail_ratio`, `DETAIL_GATE`); '
                  '`ReconstructParams(demosaic="ddfapd")`, `spikeref reconstruct '
                  '--demosaic ddfapd`'),
        oracle='`oracles.directional_demosaic.demosaic_ddfapd_oracle`',
        tests=('`tests/test_directional_demosaic.py` (oracle by hypothesis for the four patterns, exact on grey '
               'stripes either way, the decision follows an edge, sharper than MHC on grey edges, shapes and errors)'),
        golden='{demosaic_ddfapd}',
    ),
    AuditRow(
        equation='—',
        what=("true motion of the simulator's image scenes: `x(t) = c + exp(G t)(p − c) + v t`, backward flow `x(t') "
              '− x` on the Bayer-plane grid, occlusion mask'),
        function='`spikeref.simulate.motion.Motion`, `plane_flow`; `ImageMotion.true_flow`',
        oracle='closed forms (`scipy.linalg.expm`)',
        tests=('`tests/test_motion.py` (exponential, clockwise rotation, composition, the later frame warped by the '
               'flow reproduces the earlier one, occlusion)'),
        golden='—',
    ),
    AuditRow(
        equation='—',
        what='`.dat` storage layout',
        function='`spikeref.io.dat.pack_planes`, `unpack_planes`, `map_dat` (`spikeref.stream.read_dat`)',
        oracle='`oracles.dat.pack_dat_oracle`, `unpack_dat_oracle`',
        tests='`tests/test_dat.py` (incl. the real `.dat` sample)',
        golden='{dat_layout}',
    ),
    AuditRow(
        equation='Table 1 metrics',
        what=('PSNR; SSIM (Wang et al. 2004: Gaussian σ = 1.5, 11 taps, K1 = 0.01, K2 = 0.03, population moments, '
              'valid region, mean over channels); PU21 `banding_glare` encoding (luminance clamped to [0.005, 10 '
              '000] cd/m²) and PU21-PSNR (peak 256) / PU21-SSIM with the reference peak at 4000 cd/m²'),
        function='`spikeref.metrics.psnr`, `ssim`, `pu21_encode`, `pu21_psnr`, `pu21_ssim`, `luminance` (Rec. 709)',
        oracle='`oracles.metrics.psnr_oracle`, `ssim_oracle` (window by window), `pu21_oracle`',
        tests=('`tests/test_metrics.py` (= scikit-image `structural_similarity(gaussian_weights=True, sigma=1.5, '
               'use_sample_covariance=False)` and `peak_signal_noise_ratio`; PU(100) ≈ 256.38, PU(10 000) ≈ 595.39; '
               'scale invariance)'),
        golden='{metrics_psnr_ssim_pu21}',
    ),
)
