"""What a benchmark run writes: ``results.csv``, ``results.md``, ``pareto.png`` and ``contact_sheet.png``.

No computation of scores here: :mod:`spikeref.bench.runner` makes the rows; this module
averages them over scenes, finds the Pareto front (a setting is on it when no other is both
at least as fast and at least as accurate, and strictly better in one) and draws.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from spikeref.bench.runner import METRICS
from spikeref.bench.settings import Setting

__all__ = ["pareto_front", "summarize", "stage_table", "markdown_report", "write_csv", "plot_pareto", "contact_sheet",
           "write_report"]


def pareto_front(cost, score) -> np.ndarray:
    """Boolean mask of the points on the Pareto front (lower ``cost`` and higher ``score`` better).

    A point is dominated when another has ``cost ≤`` and ``score ≥`` with one of them strict.
    Ties (equal cost and score) are all on the front.
    """
    c = np.asarray(cost, dtype=np.float64)
    s = np.asarray(score, dtype=np.float64)
    if c.shape != s.shape or c.ndim != 1:
        raise ValueError(f"cost and score must be 1-D of equal length; got {c.shape} and {s.shape}")
    if not (np.all(np.isfinite(c)) and np.all(~np.isnan(s))):
        raise ValueError("cost must be finite and score must not be NaN")
    dominated = ((c[None, :] <= c[:, None]) & (s[None, :] >= s[:, None])
                 & ((c[None, :] < c[:, None]) | (s[None, :] > s[:, None])))
    return ~dominated.any(axis=1)


def summarize(rows: list[dict]) -> list[dict]:
    """One row per setting: the mean of each metric and of seconds per frame over the scenes."""
    order = list(dict.fromkeys(r["setting"] for r in rows))
    out = []
    for name in order:
        rs = [r for r in rows if r["setting"] == name]
        first = rs[0]
        row = {k: first.get(k, "") for k in ("setting", "method", "W", "K", "L", "mode", "align", "flow_frames",
                                              "warp", "denoise")}
        for m in (*METRICS, "seconds_per_frame", "warmup_s"):
            row[m] = float(np.mean([r[m] for r in rs]))
        for k in _stage_keys(first):
            vals = [float(r[k]) for r in rs]
            row[k] = float(np.mean(vals)) if all(np.isfinite(vals)) else float("nan")
        row["per_scene_psnr"] = {r["scene"]: r["psnr"] for r in rs}
        out.append(row)
    front = pareto_front([r["seconds_per_frame"] for r in out], [r["psnr"] for r in out])
    for r, f in zip(out, front, strict=True):
        r["pareto_psnr"] = bool(f)
    return out


def _stage_keys(row: dict) -> list[str]:
    """The per-stage seconds-per-frame columns of a row (``accumulate_s`` … ``other_s``)."""
    from spikeref.pipeline import STAGES

    return [f"{k}_s" for k in (*STAGES, "other") if f"{k}_s" in row]


def stage_table(summary: list[dict]) -> list[str]:
    """Markdown lines: where the method's time goes per setting (ms per frame per stage, % outside the network)."""
    rows = [r for r in summary if r["method"] == "ours" and _stage_keys(r)
            and all(np.isfinite(r[k]) for k in _stage_keys(r))]
    if not rows:
        return []
    keys = _stage_keys(rows[0])
    lines = ["Where the method's time goes (steady-state frames, ms per frame, mean over the scenes; network = "
             "the U-Net's passes, guard = the rest of the denoiser):", "",
             "| setting | " + " | ".join(k[:-2] for k in keys) + " | total | outside the network |",
             "|---|" + "---:|" * (len(keys) + 2)]
    for r in rows:
        total = sum(r[k] for k in keys)
        out = 1 - r["network_s"] / total if total > 0 else float("nan")
        lines.append(f"| {r['setting']} | " + " | ".join(f"{1e3 * r[k]:.1f}" for k in keys)
                     + f" | {1e3 * total:.1f} | {100 * out:.0f} % |")
    return lines


def write_csv(rows: list[dict]) -> str:
    """The per-scene rows as CSV text (one line per scene × setting)."""
    buf = io.StringIO()
    keys = list(rows[0])
    w = csv.DictWriter(buf, fieldnames=keys, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def _best(summary, method_filter):
    cand = [r for r in summary if method_filter(r)]
    return max(cand, key=lambda r: r["psnr"]) if cand else None


def markdown_report(result: dict, summary: list[dict], meta: dict) -> str:
    """The table (mean over scenes) and the comparisons the issue asks to quote."""
    scenes = result["scenes"]
    lines = [f"# spikeref bench (scene set v{meta['bench_version']}, {meta['grid']})", "",
             f"{meta['when']} · {meta['machine']} · seed {result['seed']} · scenes: {', '.join(scenes)} "
             f"({meta['size']}, {meta['frames']} scored frames each) · denoiser {meta['denoiser']}", "",
             "Scores are means over the scenes; reference = the ground truth of the 2000-FPS frame "
             "(10 planes) at each scored instant. Seconds per output frame: steady state, median, this process.",
             "★ = on the Pareto front of PSNR against seconds per frame.", "",
             "| setting | PSNR (dB) | SSIM | PU21-PSNR | PU21-SSIM | s / frame | "
             + " | ".join(f"{s} PSNR" for s in scenes) + " |",
             "|---|---|---|---|---|---|" + "---|" * len(scenes)]
    for r in summary:
        star = " ★" if r["pareto_psnr"] else ""
        lines.append(f"| {r['setting']}{star} | {r['psnr']:.2f} | {r['ssim']:.3f} | {r['pu21_psnr']:.2f} | "
                     f"{r['pu21_ssim']:.3f} | {r['seconds_per_frame']:.4f} | "
                     + " | ".join(f"{r['per_scene_psnr'].get(s, float('nan')):.2f}" for s in scenes) + " |")
    ours = _best(summary, lambda r: r["method"] == "ours")
    by_name = {r["setting"]: r for r in summary}
    lines.append("")
    if ours is not None:
        lines.append(f"Best setting of the method by PSNR: **{ours['setting']}** — {ours['psnr']:.2f} dB, "
                     f"SSIM {ours['ssim']:.3f}, {ours['seconds_per_frame']:.3f} s/frame.")
        for ref, paper in (("TFP W=100", "+2.0 dB, +0.16 SSIM"), ("TFP W=10", "+7.5 dB")):
            if ref in by_name:
                b = by_name[ref]
                lines.append(f"- vs {ref}: {ours['psnr'] - b['psnr']:+.2f} dB PSNR, {ours['ssim'] - b['ssim']:+.3f} "
                             f"SSIM, {ours['pu21_psnr'] - b['pu21_psnr']:+.2f} dB PU21-PSNR (paper: {paper}).")
        steps = [r for r in summary if r["method"] == "ours" and r["mode"] == "visible" and r["align"] in ("on", "")
                 and r["flow_frames"] in ("denoised", "") and r["W"] == ours["W"] and (r["L"] == 0 or r["K"] == 3)]
        steps.sort(key=lambda r: r["L"])
        if len(steps) > 1:
            gains = [f"L={b['L']}: {b['psnr'] - a['psnr']:+.2f} dB for "
                     f"{b['seconds_per_frame'] - a['seconds_per_frame']:+.3f} s/frame"
                     for a, b in zip(steps[:-1], steps[1:], strict=True)]
            lines.append("- Each step of accuracy and its cost (visible, K=3): " + "; ".join(gains) + ".")
    stages = stage_table(summary)
    if stages:
        lines += ["", *stages]
    if meta.get("sheet"):
        lines += ["", f"Contact sheet (`contact_sheet.png`, scene {meta['sheet_scene']}), left to right, top to "
                  "bottom: " + ", ".join(meta["sheet"]) + "."]
    return "\n".join(lines) + "\n"


def _label_points(ax, summary: list[dict], cost: np.ndarray, score: np.ndarray, front: np.ndarray,
                  shown: np.ndarray) -> None:
    """Name the points a reader looks for, with no label over another.

    In order of priority: the baselines, the package's defaults at 10/3/3, the fast presets, the best score,
    then the rest of the Pareto front (``shown``: the points inside the panel's limits).  Each label tries a
    few places beside its point and is left out when every one overlaps a label already drawn.
    """
    best = int(np.nanargmax(np.where(shown, score, -np.inf)))
    defaults = Setting("ours", flow_frames="smoothed").name  # the package's defaults at 10/3/3

    def role(i):
        """``(priority, label)`` of point ``i``, or None when it goes unlabelled."""
        r = summary[i]
        if not shown[i]:
            return None
        if r["method"] != "ours":
            return 0, r["setting"]
        if r["setting"] == defaults:
            return 1, "defaults (10/3/3)"
        if r.get("warp") == "chained":
            return 2, "fast preset" if r.get("denoise") != "off" else "fastest preset"
        if i == best or front[i]:
            return (3 if i == best else 4), r["setting"].replace("ours ", "").replace(" smoothed-flow", "")
        return None

    renderer = ax.figure.canvas.get_renderer()
    inside = ax.get_window_extent(renderer)
    boxes = []
    roles = {i: r for i in range(len(summary)) if (r := role(i)) is not None}
    for i in sorted(roles, key=lambda i: (roles[i][0], i)):
        label = roles[i][1]
        for dx, dy, ha in ((5, -3, "left"), (5, 5, "left"), (-5, 5, "right"), (-5, -9, "right"), (5, -11, "left")):
            t = ax.annotate(label, (cost[i], score[i]), fontsize=6.5, xytext=(dx, dy),
                            textcoords="offset points", ha=ha)
            box = t.get_window_extent(renderer).expanded(1.05, 1.2)
            within = inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0 and box.y1 <= inside.y1
            if within and not any(box.overlaps(b) for b in boxes):
                boxes.append(box)
                break
            t.remove()


def plot_pareto(summary: list[dict], path: Path) -> bool:
    """Accuracy against seconds per frame (log), one panel per metric, front marked. False without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig, axes = plt.subplots(1, 4, figsize=(22, 5.5))
    colours = {"tfp": "tab:gray", "tfi": "tab:brown", "tfstp": "tab:olive"}
    mode_colours = {"visible": "tab:blue", "mixed": "tab:purple", "blind": "tab:red"}
    cost = np.array([r["seconds_per_frame"] for r in summary])
    panels = (("psnr", "PSNR (dB)", False), ("psnr", "PSNR (dB), the top 1.5 dB", True), ("ssim", "SSIM", False),
              ("pu21_psnr", "PU21-PSNR (dB)", False))
    drawn = []  # (ax, score, front, shown) of each panel, labelled once the layout is drawn
    for ax, (metric, label, zoom) in zip(axes, panels, strict=True):
        score = np.array([r[metric] for r in summary])
        front = pareto_front(cost, score)
        top = float(np.nanmax(score))
        shown = score >= top - 1.5 if zoom else np.ones(len(score), bool)
        drawn.append((ax, score, front, shown))
        for r, c, s in zip(summary, cost, score, strict=True):
            col = colours.get(r["method"]) or mode_colours[r["mode"]]
            fast = r["method"] == "ours" and r.get("warp") == "chained"
            marker = "o" if r["method"] != "ours" else ("*" if r.get("denoise") != "off" else "P") if fast else \
                ("s" if r["align"] == "off" else "D" if r["flow_frames"] == "smoothed" else "^")
            ax.scatter(c, s, color=col, marker=marker, s=110 if fast else 28, alpha=0.8, zorder=3 if fast else 2)
        order = np.argsort(cost[front])
        ax.step(cost[front][order], score[front][order], where="post", color="k", lw=1, label="Pareto front")
        ax.set_xscale("log")
        if zoom:
            ax.set_ylim(top - 1.5, top + 0.15)
            ax.set_xlim(float(np.min(cost[shown])) / 1.5, float(np.max(cost[shown])) * 3.0)
        ax.set_xlabel("seconds per output frame (log)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.suptitle("What accuracy costs in time (mean over the benchmark scenes)")
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.canvas.draw()  # the labels are placed against the drawn layout
    for ax, score, front, shown in drawn:
        _label_points(ax, summary, cost, score, front, shown)
    handles = [plt.Line2D([], [], color=c, marker="o", ls="", label=k.upper()) for k, c in colours.items()]
    handles += [plt.Line2D([], [], color=c, marker="^", ls="", label=f"ours {k}") for k, c in mode_colours.items()]
    handles += [plt.Line2D([], [], color="k", marker="s", ls="", label="ours, no alignment"),
                plt.Line2D([], [], color="k", marker="D", ls="", label="ours, flow on smoothed frames"),
                plt.Line2D([], [], color="k", marker="*", ls="", markersize=10, label="ours, fast preset"),
                plt.Line2D([], [], color="k", marker="P", ls="", markersize=9,
                           label="ours, fastest preset (no denoiser)"),
                plt.Line2D([], [], color="k", lw=1, label="Pareto front")]
    axes[0].legend(handles=handles, fontsize=7, loc="lower right")
    from spikeref.io.atomic import atomic_write

    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
    plt.close(fig)
    return True


def contact_sheet(images: dict, columns: int = 6, gap: int = 4) -> np.ndarray:
    """Tiles of the same frame from every method (``{"name": (H, W, 3) linear}``), one exposure for all.

    The exposure is chosen on the first image (the reference), so methods that are too dark or
    too bright show it.  Returns ``uint8 (rows·(H+gap), columns·(W+gap), 3)``.
    """
    from spikeref.tonemap import choose_exposure, tonemap

    names = list(images)
    first = images[names[0]]
    exposure = choose_exposure(first)
    h, w = first.shape[:2]
    rows = -(-len(names) // columns)
    sheet = np.full((rows * (h + gap) - gap, min(columns, len(names)) * (w + gap) - gap, 3), 255, np.uint8)
    for i, name in enumerate(names):
        y, x = divmod(i, columns)
        sheet[y * (h + gap): y * (h + gap) + h, x * (w + gap): x * (w + gap) + w] = tonemap(images[name], exposure)
    return sheet


def write_report(result: dict, out_dir: Path, meta: dict) -> dict:
    """Write every output into ``out_dir``; returns ``{kind: path}`` of what was written."""
    from spikeref.io.atomic import atomic_write
    from spikeref.io.video import write_png

    out_dir = Path(out_dir)
    written = {}
    summary = summarize(result["rows"])
    csv_text = write_csv(result["rows"])
    written["csv"] = atomic_write(out_dir / "results.csv", lambda tmp: Path(tmp).write_text(csv_text))
    if result["sheet"]:
        meta = {**meta, "sheet": list(result["sheet"])}
        written["contact_sheet"] = write_png(out_dir / "contact_sheet.png", contact_sheet(result["sheet"]))
    md = markdown_report(result, summary, meta)
    if plot_pareto(summary, out_dir / "pareto.png"):
        written["pareto"] = out_dir / "pareto.png"
        md += "\n![accuracy against seconds per frame](pareto.png)\n"
    else:
        md += "\n(pareto.png not drawn: install the plot extra, `pip install spikeref[plot]`.)\n"
    written["markdown"] = atomic_write(out_dir / "results.md", lambda tmp: Path(tmp).write_text(md))
    return written
