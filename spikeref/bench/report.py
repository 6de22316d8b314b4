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
    """Name the points a reader looks for, with no label over another, over a marker or over the legend.

    In order of priority: the baselines, the package's defaults at 10/3/3, the fast presets, the best score,
    then the rest of the Pareto front (``shown``: the points inside the panel's limits).  The placing is
    :func:`_place_labels`: beside the point where there is room, else in the nearest free slot with a leader
    line to it.  Call it once the figure's layout is drawn (``fig.canvas.draw()``) and its legend made.
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

    roles = {i: r for i in range(len(summary)) if (r := role(i)) is not None}
    order = sorted(roles, key=lambda i: (roles[i][0], i))
    _place_labels(ax, [(float(cost[i]), float(score[i]), roles[i][1]) for i in order])


def _segments_hit_boxes(p: np.ndarray, q: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Whether segment ``p[k] → q[k]`` crosses box ``boxes[m]`` (``x0, y0, x1, y1``): ``bool (K, M)``.

    Liang–Barsky clipping of each segment against each box, in display pixels.
    """
    if len(boxes) == 0 or len(p) == 0:
        return np.zeros((len(p), len(boxes)), bool)
    d = (q - p)[:, None, :]  # (K, 1, 2)
    lo = boxes[None, :, :2] - p[:, None, :]  # (K, M, 2): where the box starts, from p
    hi = boxes[None, :, 2:] - p[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = np.where(d != 0, np.minimum(lo / d, hi / d), np.where((lo <= 0) & (hi >= 0), -np.inf, np.inf))
        t1 = np.where(d != 0, np.maximum(lo / d, hi / d), np.where((lo <= 0) & (hi >= 0), np.inf, -np.inf))
    enter = np.maximum(t0.max(axis=2), 0.0)
    leave = np.minimum(t1.min(axis=2), 1.0)
    return enter <= leave


def _segments_cross(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether segment ``p[k] → q[k]`` properly crosses segment ``a[m] → b[m]``: ``bool (K, M)``."""
    if len(a) == 0 or len(p) == 0:
        return np.zeros((len(p), len(a)), bool)

    def side(o, u, v):  # sign of the cross product (u − o) × (v − o)
        return np.sign((u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1])
                       - (u[..., 1] - o[..., 1]) * (v[..., 0] - o[..., 0]))

    P, Q, A, B = p[:, None], q[:, None], a[None], b[None]
    return (side(P, Q, A) * side(P, Q, B) < 0) & (side(A, B, P) * side(A, B, Q) < 0)


def _line_segments(line) -> np.ndarray:
    """The straight pieces of a drawn ``Line2D`` (its steps applied) in display pixels: ``(n, 4)``."""
    from matplotlib.cbook import STEP_LOOKUP_MAP

    xy = np.asarray(line.get_xydata(), dtype=np.float64)
    style = line.get_drawstyle()
    if style in STEP_LOOKUP_MAP and style != "default" and len(xy):
        xy = np.column_stack(STEP_LOOKUP_MAP[style](xy[:, 0], xy[:, 1]))
    xy = line.get_transform().transform(xy) if len(xy) else np.zeros((0, 2))
    seg = np.hstack([xy[:-1], xy[1:]]) if len(xy) > 1 else np.zeros((0, 4))
    return seg[np.all(np.isfinite(seg), axis=1)]


def _place_labels(ax, items: list[tuple[float, float, str]], fontsize: float = 6.5) -> list:
    """Write each ``(x, y, label)`` of ``items`` (data coordinates, highest priority first) beside its point.

    A small deterministic placement in display pixels, against the drawn layout.  The obstacles are the
    markers of every scatter in ``ax`` (their drawn size), its lines (the Pareto front), its legend, the
    labels already placed and their leader lines.  Each label takes, of the places that keep it inside the
    panel and clear of every obstacle, the first of:

    * right of its marker, left of it, just above or below either, where no other labelled point is within
      a line of the text (a label in a crowd would wall in its neighbours' leaders);
    * a slot on a grid one text line apart up and down the panel, in columns 14 to 200 points to either
      side or in line with a column of labels already placed (whose leaders then cannot cross its text),
      nearest first, joined to the point by a thin leader line that crosses no label and no other leader;
    * the same with a leader that crosses another leader.

    Labels left with no free place are tried first in another pass (at most three), and the pass that
    places the most is drawn; a label with no place in it is left out.

    Returns
    -------
    list of matplotlib.text.Annotation
        The labels drawn, in the order of ``items``.
    """
    if not items:
        return []
    renderer = ax.figure.canvas.get_renderer()
    pt = renderer.points_to_pixels(1.0)  # display pixels a point
    frame = ax.get_window_extent(renderer)
    inside = np.array([frame.x0, frame.y0, frame.x1, frame.y1]) + np.array([1, 1, -1, -1])
    markers = []  # (x, y, radius) of every marker drawn in the panel, in pixels
    for coll in ax.collections:
        offsets = np.asarray(coll.get_offsets(), dtype=np.float64)
        if offsets.size == 0:
            continue
        xy = coll.get_offset_transform().transform(offsets)
        sizes = np.asarray(coll.get_sizes(), dtype=np.float64)
        sizes = np.broadcast_to(sizes, (len(xy),)) if sizes.size in (1, len(xy)) else np.full(len(xy), 36.0)
        markers.append(np.column_stack([xy, np.sqrt(sizes) / 2 * pt]))
    markers = np.concatenate(markers) if markers else np.zeros((0, 3))
    markers = markers[np.all(np.isfinite(markers), axis=1)]
    fixed = [np.hstack([markers[:, :2] - markers[:, 2:] - 0.5, markers[:, :2] + markers[:, 2:] + 0.5])]
    legend = ax.get_legend()
    if legend is not None:
        lb = legend.get_window_extent(renderer)
        fixed.append(np.array([[lb.x0, lb.y0, lb.x1, lb.y1]]))
    fixed = np.concatenate(fixed)  # the markers, then the legend: (x0, y0, x1, y1) in pixels
    lines = [_line_segments(line) for line in ax.lines]  # (x0, y0, x1, y1) of every line drawn, in pixels
    lines = np.concatenate(lines) if lines else np.zeros((0, 4))

    points, sizes = [], []  # display position and marker radius of each item; its text's width and height
    for x, y, label in items:
        px, py = ax.transData.transform((x, y))
        own = markers[np.hypot(markers[:, 0] - px, markers[:, 1] - py) < 1.0, 2]
        points.append((px, py, float(own.max()) if own.size else 3 * pt))
        t = ax.annotate(label, (x, y), xytext=(0, 0), textcoords="offset points", ha="left", va="center",
                        fontsize=fontsize)
        bb = t.get_window_extent(renderer)
        t.remove()
        sizes.append((bb.width + 2, bb.height + 1))  # a pixel of air around the text
    centres = np.array([p[:2] for p in points]).reshape(-1, 2)
    visible = {i for i, (px, py) in enumerate(centres)
               if inside[0] <= px <= inside[2] and inside[1] <= py <= inside[3]}  # the points a label can go to

    def attempt(order):
        """``{item: (dx, dy, leader)}`` (offsets in pixels) of the items placed, taken in ``order``."""
        boxes = fixed  # grows with each label placed
        leaders = np.zeros((0, 4))  # (x0, y0, x1, y1) of the leader lines drawn
        columns = []  # (text edge x, side, a row's centre y) of the labels on leaders
        placed = {}
        for i in order:
            if i not in visible:
                continue
            (px, py, r), (w, h) = points[i], sizes[i]
            near = r + 2 * pt
            cand = [(near, 0.0), (-near, 0.0), (near, 0.6 * h), (near, -0.6 * h), (-near, 0.6 * h),
                    (-near, -0.6 * h)]
            steps = int((inside[3] - inside[1]) / h) + 1
            far = [(np.hypot(dx, k * h / pt), side * dx * pt, k * h) for dx in (14, 28, 45, 70, 100, 140, 200)
                   for side in (1, -1) for k in range(-steps, steps + 1)]
            # in line with the columns of the labels already out on leaders, on their rows: a stack whose
            # text edges line up keeps each leader off the other labels; preferred to a place as near
            for edge, side, yc in columns:
                if side * (edge - px) >= 10 * pt:
                    far += [(0.75 * np.hypot((edge - px) / pt, (yc + k * h - py) / pt), edge - px, yc + k * h - py)
                            for k in range(-2 * steps, 2 * steps + 1)]
            far.sort(key=lambda c: (c[0], c[1] < 0, c[2]))
            cand = np.array([(dx, dy, 0.0) for dx, dy in cand] + [(dx, dy, 1.0) for _, dx, dy in far])
            dx, dy, lead = cand[:, 0], cand[:, 1], cand[:, 2].astype(bool)
            x0 = np.where(dx >= 0, px + dx, px + dx - w)
            cb = np.column_stack([x0, py + dy - h / 2, x0 + w, py + dy + h / 2])  # (N, 4) candidate boxes
            ok = ((cb[:, 0] >= inside[0]) & (cb[:, 2] <= inside[2]) & (cb[:, 1] >= inside[1])
                  & (cb[:, 3] <= inside[3]))
            ok &= ~((cb[:, None, 0] < boxes[None, :, 2]) & (cb[:, None, 2] > boxes[None, :, 0])
                    & (cb[:, None, 1] < boxes[None, :, 3]) & (cb[:, None, 3] > boxes[None, :, 1])).any(axis=1)
            drawn = np.vstack([lines, leaders])
            ok &= ~_segments_hit_boxes(drawn[:, :2], drawn[:, 2:], cb).T.any(axis=1)  # text over a line
            start = np.column_stack([np.where(dx >= 0, cb[:, 0], cb[:, 2]), py + dy])  # a leader's text end
            toward = np.array([px, py]) - start
            end = start + toward * (1 - (r + 1) / np.maximum(np.hypot(*toward.T), r + 1))[:, None]  # marker edge
            ok &= ~(lead & _segments_hit_boxes(start, end, boxes[len(markers):]).any(axis=1))  # legend, labels
            # straight beside its point only where no other labelled point is within a line of the text:
            # a label in a crowd would wall in the leaders of its neighbours
            others = np.delete(centres, i, axis=0)
            crowd = ((others[None, :, 0] > cb[:, None, 0] - h) & (others[None, :, 0] < cb[:, None, 2] + h)
                     & (others[None, :, 1] > cb[:, None, 1] - h) & (others[None, :, 1] < cb[:, None, 3] + h))
            ok &= lead | ~crowd.any(axis=1)
            crossing = lead & _segments_cross(start, end, leaders[:, :2], leaders[:, 2:]).any(axis=1)
            pick = np.flatnonzero(ok & ~crossing)
            if pick.size == 0:
                pick = np.flatnonzero(ok)
            if pick.size == 0:
                continue
            k = int(pick[0])
            placed[i] = (float(dx[k]), float(dy[k]), bool(lead[k]))
            boxes = np.vstack([boxes, cb[k]])
            if lead[k]:
                leaders = np.vstack([leaders, [*start[k], *end[k]]])
                if (start[k, 0], np.sign(dx[k])) not in {(e, sd) for e, sd, _ in columns}:
                    columns.append((float(start[k, 0]), float(np.sign(dx[k])), float(py + dy[k])))
        return placed

    order = list(range(len(items)))
    best = attempt(order)
    for _ in range(3):  # the labels left out go first, the others after them in their order
        missing = [i for i in order if i not in best and i in visible]
        if not missing:
            break
        order = missing + [i for i in order if i not in missing]
        trial = attempt(order)
        if len(trial) <= len(best):
            break
        best = trial

    out = []
    for i, (x, y, label) in enumerate(items):
        if i not in best:
            continue
        dx, dy, lead = best[i]
        arrow = dict(arrowstyle="-", lw=0.6, color="0.25", shrinkA=0, shrinkB=0,
                     relpos=(0.0 if dx >= 0 else 1.0, 0.5)) if lead else None
        out.append(ax.annotate(label, (x, y), xytext=(dx / pt, dy / pt), textcoords="offset points",
                               ha="left" if dx >= 0 else "right", va="center", fontsize=fontsize,
                               arrowprops=arrow))
    return out


def _pareto_figure(summary: list[dict]):
    """The Pareto figure of :func:`plot_pareto`, drawn and labelled (needs matplotlib; returns the Figure)."""
    import matplotlib.pyplot as plt

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
    handles = [plt.Line2D([], [], color=c, marker="o", ls="", label=k.upper()) for k, c in colours.items()]
    handles += [plt.Line2D([], [], color=c, marker="^", ls="", label=f"ours {k}") for k, c in mode_colours.items()]
    handles += [plt.Line2D([], [], color="k", marker="s", ls="", label="ours, no alignment"),
                plt.Line2D([], [], color="k", marker="D", ls="", label="ours, flow on smoothed frames"),
                plt.Line2D([], [], color="k", marker="*", ls="", markersize=10, label="ours, fast preset"),
                plt.Line2D([], [], color="k", marker="P", ls="", markersize=9,
                           label="ours, fastest preset (no denoiser)"),
                plt.Line2D([], [], color="k", lw=1, label="Pareto front")]
    axes[0].legend(handles=handles, fontsize=7, loc="lower right")
    fig.suptitle("What accuracy costs in time (mean over the benchmark scenes)")
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.canvas.draw()  # the labels are placed against the drawn layout, legend included
    for ax, score, front, shown in drawn:
        _label_points(ax, summary, cost, score, front, shown)
    return fig


def plot_pareto(summary: list[dict], path: Path) -> bool:
    """Accuracy against seconds per frame (log), one panel per metric, front marked. False without matplotlib.

    The points a reader looks for are named (:func:`_label_points`) with no label over another.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig = _pareto_figure(summary)
    from spikeref.io.atomic import atomic_write

    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
    plt.close(fig)
    return True


# A 5×8 bitmap font (printable ASCII, 0x20 … 0x7E) for the contact sheet's captions, so that they need no
# plotting library: five columns a glyph, two hex digits a column, bit 0 the top row, bit 7 the descenders' row.
_FONT_5X8 = (
    "0000000000", "00005f0000", "0007000700", "147f147f14", "242a7f2a12", "2313086462", "3649562050",
    "0000050300", "001c224100", "0041221c00", "2a1c7f1c2a", "08083e0808", "0080703000", "0808080808",
    "0000606000", "2010080402", "3e5149453e", "00427f4000", "4261514946", "2141454b31", "1814127f10",
    "2745454539", "3c4a494930", "0171090503", "3649494936", "064949291e", "0036360000", "0056360000",
    "0008142241", "1414141414", "0041221408", "0201510906", "324979413e", "7e1111117e", "7f49494936",
    "3e41414122", "7f4141221c", "7f49494941", "7f09090901", "3e4149497a", "7f0808087f", "00417f4100",
    "2040413f01", "7f08142241", "7f40404040", "7f020c027f", "7f0408107f", "3e4141413e", "7f09090906",
    "3e4151215e", "7f09192946", "4649494931", "01017f0101", "3f4040403f", "1f2040201f", "3f4038403f",
    "6314081463", "0708700807", "6151494543", "007f414100", "0204081020", "0041417f00", "0402010204",
    "4040404040", "0001020400", "2054545478", "7f48444438", "3844444420", "384444487f", "3854545418",
    "087e090102", "18a4a4a47c", "7f08040478", "00447d4000", "2040443d00", "7f10284400", "00417f4000",
    "7c04180478", "7c08040478", "3844444438", "fc24242418", "18242418fc", "7c08040408", "4854545420",
    "043f444020", "3c4040207c", "1c2040201c", "3c4030403c", "4428102844", "1ca0a0a07c", "4464544c44",
    "0008364100", "00007f0000", "0041360800", "0804080408",
)
_GLYPHS = ((np.array([[int(g[2 * c: 2 * c + 2], 16) for c in range(5)] for g in _FONT_5X8])[:, None, :]
            >> np.arange(8)[None, :, None]) & 1).astype(bool)  # (95, 8, 5): glyph, row, column


def _text_mask(line: str, scale: int = 1) -> np.ndarray:
    """Pixels of one line of text in the built-in 5×8 font: ``bool (8·scale, (6·len(line) − 1)·scale)``.

    Characters outside printable ASCII are drawn as ``?``; glyphs are one column apart.
    """
    if not line:
        return np.zeros((8 * scale, 0), bool)
    codes = [ord(ch) - 32 if 32 <= ord(ch) < 127 else ord("?") - 32 for ch in line]
    cells = np.concatenate([np.pad(_GLYPHS[c], ((0, 0), (0, 1))) for c in codes], axis=1)[:, :-1]
    return np.repeat(np.repeat(cells, scale, axis=0), scale, axis=1)


def _wrap(text: str, width: int, max_lines: int) -> list[str]:
    """``text`` broken at spaces into lines of at most ``width`` characters, at most ``max_lines`` of them.

    A word longer than a line is cut; when the text needs more lines, the last one ends in ``...``.
    """
    if width < 1:
        return []
    lines, line = [], ""
    for word in text.split():
        while len(word) > width:  # a word that fills lines on its own
            if line:
                lines.append(line)
                line = ""
            lines.append(word[:width])
            word = word[width:]
        if not line:
            line = word
        elif len(line) + 1 + len(word) <= width:
            line += " " + word
        else:
            lines.append(line)
            line = word
    if line:
        lines.append(line)
    if len(lines) > max_lines:
        last = lines[max_lines - 1]
        more = last + " ..." if len(last) + 4 <= width else last[:width - 3] + "..." if width > 3 else last[:width]
        lines = lines[:max_lines - 1] + [more]
    return lines


def _caption(text: str, width: int, lines: int, scale: int) -> np.ndarray:
    """A white ``uint8 (lines·9·scale + 4·scale, width, 3)`` strip with ``text`` in black.

    Each line is centred; the block of lines sits at the bottom of the strip (next to the tile below it),
    three ``scale`` rows of white above it and one below.
    """
    line_h = 9 * scale
    strip = np.full((lines * line_h + 4 * scale, width, 3), 255, np.uint8)
    wrapped = _wrap(text, (width - scale) // (6 * scale), lines)
    for k, line in enumerate(wrapped):
        mask = _text_mask(line, scale)
        x = (width - mask.shape[1]) // 2
        y = 3 * scale + (lines - len(wrapped) + k) * line_h
        strip[y: y + mask.shape[0], x: x + mask.shape[1]][mask] = 0
    return strip


def contact_sheet(images: dict, columns: int = 6, gap: int = 4, *, captions: bool = True,
                  max_lines: int = 4) -> np.ndarray:
    """Tiles of the same frame from every method, one exposure for all, each under its name.

    Parameters
    ----------
    images : dict
        ``{"name": (H, W, 3) linear}``, in the order of the tiles (left to right, top to bottom); the
        first one (the reference) sets the exposure, so methods that are too dark or too bright show it.
    columns : int
        Tiles a row.
    gap : int
        White pixels between tiles, across and down.
    captions : bool
        Write each tile's name just above it (black on white, a built-in 5×8 pixel font scaled by
        ``max(1, W // 256)``, centred, broken at spaces to the tile's width; no plotting library needed).
    max_lines : int
        Most lines of a caption; a longer name ends in ``...``.

    Returns
    -------
    numpy.ndarray
        ``uint8 (rows·(C+H+gap) − gap, min(columns, n)·(W+gap) − gap, 3)``, where ``C`` is the height of the
        caption strip (0 without captions; the same for every tile: that of the longest caption).
    """
    from spikeref.tonemap import choose_exposure, tonemap

    names = list(images)
    first = images[names[0]]
    exposure = choose_exposure(first)
    h, w = first.shape[:2]
    scale = max(1, w // 256)
    chars = (w - scale) // (6 * scale)  # a line's characters: (6·n − 1)·scale ≤ W − 2·scale
    n_lines = max(len(_wrap(str(n), chars, max_lines)) for n in names) if captions else 0
    cap = n_lines * 9 * scale + 4 * scale if n_lines else 0
    cell = cap + h + gap
    rows = -(-len(names) // columns)
    sheet = np.full((rows * cell - gap, min(columns, len(names)) * (w + gap) - gap, 3), 255, np.uint8)
    for i, name in enumerate(names):
        y, x = divmod(i, columns)
        top, left = y * cell, x * (w + gap)
        if cap:
            sheet[top: top + cap, left: left + w] = _caption(str(name), w, n_lines, scale)
        sheet[top + cap: top + cap + h, left: left + w] = tonemap(images[name], exposure)
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
