"""Plots and summary tables of a parameter sweep (:mod:`phd_swarm.tools.sweep`).

- ``boxplot.png``: the metric per cell as paper-style box plots (median, quartiles,
  whiskers at 1.5 IQR), the methods side by side. The x axis is the team size (Dames 2020
  Fig. 2 and 5, Chen et al. 2021 Fig. 3a), or the grid resolution when the sweep has one
  team size and several resolutions; one panel per value of the other axes (target count,
  resolution, team size).
- ``ospa_vs_time.png``: the OSPA at each step averaged over all trials of a method (every
  team size and seed, as in Chen et al. Fig. 3b), one panel per target count and
  resolution.
- ``cardinality_vs_time.png``: the true and estimated number of targets averaged the same
  way (Dames Sec. IV-B: the true number settles near 35 with births and deaths).
- ``summary.csv`` and ``summary.md``: per cell the number of trials, median, quartiles and
  IQR, mean, min and max of the metric; paired wins between methods (same seeds); the
  sweep's wall and CPU time.

Matplotlib is used through :class:`matplotlib.figure.Figure` and its Agg canvas only, so no
display and no pyplot state are involved.
"""

from __future__ import annotations

import csv
import itertools
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.patches import Patch

from phd_swarm.config.sweep_spec import SweepSpec
from phd_swarm.tools.tables import figure_grid

#: Box colours, one per method in the spec's order (colour-blind safe).
COLOURS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9")

#: Cell of a sweep: one box.
CELL = ("method", "robots", "targets", "resolution")

SUMMARY_COLUMNS = ("method", "controller", "robots", "targets", "resolution", "n", "median",
                   "q1", "q3", "iqr", "mean", "min", "max", "ospa_final_median",
                   "cardinality_true_final_mean", "cardinality_est_final_mean",
                   "wall_s_mean")


def _quantiles(values: Sequence[float]) -> dict[str, float]:
    v = np.asarray(values, dtype=float)
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return {"median": float(med), "q1": float(q1), "q3": float(q3), "iqr": float(q3 - q1),
            "mean": float(v.mean()), "min": float(v.min()), "max": float(v.max())}


def cells(rows: Sequence[dict[str, Any]]) -> dict[tuple, list[dict[str, Any]]]:
    """Rows grouped by (method, robots, targets, resolution), each sorted by seed."""
    out: dict[tuple, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        out[tuple(r[c] for c in CELL)].append(r)
    for v in out.values():
        v.sort(key=lambda r: r["seed"])
    return dict(out)


def summary_rows(spec: SweepSpec, rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """One summary row per cell (:data:`SUMMARY_COLUMNS`), in the spec's order."""
    grouped = cells(rows)
    out = []
    for robots, targets, res, method in itertools.product(
            spec.robots, spec.targets, spec.resolutions, spec.methods):
        rs = grouped.get((method, robots, targets, res))
        if not rs:
            continue
        out.append({"method": method, "controller": spec.methods[method], "robots": robots,
                    "targets": targets, "resolution": res, "n": len(rs),
                    **_quantiles([r["value"] for r in rs]),
                    "ospa_final_median": float(np.median([r["ospa_final"] for r in rs])),
                    "cardinality_true_final_mean":
                        float(np.mean([r["cardinality_true_final"] for r in rs])),
                    "cardinality_est_final_mean":
                        float(np.mean([r["cardinality_est_final"] for r in rs])),
                    "wall_s_mean": float(np.mean([r["wall_s"] for r in rs]))})
    return out


def paired_wins(spec: SweepSpec, rows: Sequence[dict[str, Any]]) -> list[str]:
    """Lines 'A < B in w of n paired trials' for the first method against each other one.

    Trials are paired by seed, team size, target count and resolution (common random
    numbers: the same targets for both methods).
    """
    methods = list(spec.methods)
    if len(methods) < 2:
        return []
    by = {(r["method"], r["robots"], r["targets"], r["resolution"], r["seed"]): r["value"]
          for r in rows}
    first = methods[0]
    lines = []
    for other in methods[1:]:
        wins = n = 0
        for (m, *rest), v in by.items():
            if m != first:
                continue
            w = by.get((other, *rest))
            if w is None:
                continue
            n += 1
            wins += v < w
        if n:
            lines.append(f"{first} below {other} in {wins} of {n} paired trials "
                         f"({100 * wins / n:.0f} %)")
    return lines


def _fmt(x: float) -> str:
    return f"{x:.2f}"


def _hms(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}h{s % 3600 // 60:02d}m{s % 60:02d}s"


def write_summary(spec: SweepSpec, rows: Sequence[dict[str, Any]], out: Path,
                  timing: dict[str, Any]) -> list[Path]:
    """Write ``summary.csv`` and ``summary.md``; returns their paths."""
    table = summary_rows(spec, rows)
    csv_path = out / "summary.csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=SUMMARY_COLUMNS)
        w.writeheader()
        w.writerows(table)
    total = len(spec.methods) * len(spec.robots) * len(spec.targets) * len(
        spec.resolutions) * spec.trials
    lines = [f"# {spec.figure}: {spec.label}", ""]
    if spec.description:
        full = "Full form: " if spec.quick else ""
        lines += [full + spec.description.strip(), ""]
    lines += [f"- metric: {spec.metric_label}; {len(rows)} of {total} trials done; seeds "
              f"{spec.base_seed}..{spec.base_seed + spec.trials - 1} (the same for every "
              f"method and team size)",
              "- methods: " + ", ".join(f"{k} = `{v}`" for k, v in spec.methods.items()),
              f"- run length {spec.duration:g} s; preset `{spec.preset}`"]
    if timing:
        sessions = timing.get("sessions", [])
        lines.append(f"- sweep wall time {_hms(timing.get('wall_s', 0.0))}, CPU time "
                     f"{_hms(timing.get('cpu_s', 0.0))} over {len(sessions)} session(s) "
                     f"(workers: {', '.join(str(s.get('workers')) for s in sessions)})")
    lines.append(f"- sum over trials: wall {_hms(sum(r['wall_s'] for r in rows))}, CPU "
                 f"{_hms(sum(r['cpu_s'] for r in rows))}")
    for line in paired_wins(spec, rows):
        lines.append(f"- {line}")
    warned = [r["trial"] for r in rows if (out / "logs" / f"{r['trial']}.log").exists()]
    if warned:
        lines.append(f"- {len(warned)} of the {len(rows)} finished trials logged protocol "
                     f"warnings (logs/<trial>.log)")
    sessions = timing.get("sessions", []) if timing else []
    failed = sessions[-1].get("failed", {}) if sessions else {}
    if failed:
        lines.append(f"- {len(failed)} trial(s) failed in the last session (not in the "
                     f"table):")
        lines += [f"  - `{k}`: {v}" for k, v in sorted(failed.items())]
    lines.append("")
    lines.append("Cells: median [q1, q3] (IQR) of the metric over the trials, n trials.")
    methods = list(spec.methods)
    for targets, res in itertools.product(spec.targets, spec.resolutions):
        lines += ["", f"## {targets} targets, resolution {res:g} m", "",
                  "| robots | " + " | ".join(methods) + " |",
                  "|---:|" + "---|" * len(methods)]
        for robots in spec.robots:
            cellstr = []
            for m in methods:
                c = next((t for t in table if (t["method"], t["robots"], t["targets"],
                                              t["resolution"]) == (m, robots, targets, res)),
                         None)
                cellstr.append("–" if c is None else
                               f"{_fmt(c['median'])} [{_fmt(c['q1'])}, {_fmt(c['q3'])}] "
                               f"({_fmt(c['iqr'])}), n={c['n']}")
            lines.append(f"| {robots} | " + " | ".join(cellstr) + " |")
    md_path = out / "summary.md"
    md_path.write_text("\n".join(lines) + "\n")
    return [csv_path, md_path]


# ------------------------------------------------------------------------------ plots
def _panels(spec: SweepSpec) -> tuple[str, list[Any], list[dict[str, Any]]]:
    """The x axis, its values, and the panels (fixed values of the other axes)."""
    x_axis = "resolution" if len(spec.robots) == 1 and len(spec.resolutions) > 1 else "robots"
    values = {"robots": list(spec.robots), "targets": list(spec.targets),
              "resolution": list(spec.resolutions)}
    others = [a for a in ("targets", "resolution", "robots") if a != x_axis]
    combos = [dict(zip(others, c, strict=True))
              for c in itertools.product(*(values[a] for a in others))]
    return x_axis, values[x_axis], combos


def _panel_title(panel: dict[str, Any], spec: SweepSpec) -> str:
    parts = []
    if "targets" in panel and (len(spec.targets) > 1 or spec.preset != "chen_clustered"):
        births = spec.base_scenario().targets.birth  # then the count is the initial one
        parts.append(f"{panel['targets']} {'initial ' if births else ''}targets")
    if "resolution" in panel and len(spec.resolutions) > 1:
        parts.append(f"{panel['resolution']:g} m grid")
    if "robots" in panel:
        parts.append(f"{panel['robots']} robots")
    return ", ".join(parts)


def legend_columns(labels: Sequence[str], fig_width_in: float) -> int:
    """Columns of a legend under the figure: one row if it fits the figure's width, else more.

    An entry takes about 0.075 in per character of its label at the default font size, plus
    0.6 in for its patch and padding.
    """
    widths = [0.075 * len(label) + 0.6 for label in labels]
    for ncols in range(len(labels), 1, -1):
        nrows = -(-len(labels) // ncols)  # matplotlib fills the columns first
        if (ncols - 1) * nrows >= len(labels):
            continue  # would leave a column empty: the same layout as fewer columns
        columns = [widths[i * nrows:(i + 1) * nrows] for i in range(ncols)]
        if sum(max(c) for c in columns if c) <= fig_width_in:
            return ncols
    return 1


def trials_per_box(grouped: dict[tuple, list], trials: int) -> str:
    """``10 trials per box``, or ``3-4 trials per box (of 10)`` for a sweep not finished."""
    sizes = sorted({len(rs) for rs in grouped.values()}) or [0]
    n = f"{sizes[0]}" if len(sizes) == 1 else f"{sizes[0]}-{sizes[-1]}"
    return f"{n} trials per box" + ("" if sizes == [trials] else f" (of {trials})")


def plot_boxes(spec: SweepSpec, rows: Sequence[dict[str, Any]], path: Path) -> Path:
    """The metric per cell as grouped box plots (Dames Fig. 2/5, Chen Fig. 3a)."""
    grouped = cells(rows)
    x_axis, xs, panels = _panels(spec)
    methods = list(spec.methods)
    fig, axes = figure_grid(len(panels), 5.5 if len(xs) > 4 or len(panels) == 1 else 4.2, 3.6)
    width = 0.8 / len(methods)
    for ax, panel in zip(axes, panels, strict=True):
        for j, m in enumerate(methods):
            data, pos = [], []
            for i, x in enumerate(xs):
                key = {**panel, x_axis: x}
                rs = grouped.get((m, key["robots"], key["targets"], key["resolution"]))
                if rs:
                    data.append([r["value"] for r in rs])
                    pos.append(i + (j - (len(methods) - 1) / 2) * width)
            if not data:
                continue
            colour = COLOURS[j % len(COLOURS)]
            ax.boxplot(data, positions=pos, widths=width * 0.85, patch_artist=True,
                       manage_ticks=False, showfliers=True,
                       boxprops={"facecolor": colour, "alpha": 0.45, "edgecolor": colour},
                       medianprops={"color": "black"},
                       whiskerprops={"color": colour}, capprops={"color": colour},
                       flierprops={"marker": "+", "markeredgecolor": colour})
            for p, d in zip(pos, data, strict=True):
                ax.plot(np.full(len(d), p), d, ".", color=colour, markersize=3, alpha=0.8)
        ax.set_xticks(range(len(xs)))
        ax.set_xticklabels([f"{x:g}" if x_axis == "resolution" else str(x) for x in xs])
        ax.set_xlim(-0.6, len(xs) - 0.4)
        ax.set_xlabel("grid resolution [m]" if x_axis == "resolution" else "team size |R|")
        ax.set_ylabel(spec.metric_label)
        ax.set_ylim(bottom=0)
        ax.grid(axis="y", alpha=0.3)
        title = _panel_title(panel, spec)
        if title:
            ax.set_title(title)
    handles = [Patch(facecolor=COLOURS[j % len(COLOURS)], alpha=0.45,
                     label=f"{m} ({spec.methods[m]})") for j, m in enumerate(methods)]
    fig.legend(handles=handles, loc="outside lower center",
               ncols=legend_columns([h.get_label() for h in handles], fig.get_figwidth()))
    fig.suptitle(f"{spec.figure}\n{spec.label}, {trials_per_box(grouped, spec.trials)}",
                 fontsize="medium")
    fig.savefig(path, dpi=110)
    return path


def _series_means(spec: SweepSpec, rows: Sequence[dict[str, Any]], series_dir: Path,
                  names: Sequence[str]) -> dict[tuple, dict[str, Any]]:
    """Per (method, targets, resolution): t and the mean over trials of each series."""
    sums: dict[tuple, dict[str, Any]] = {}
    for r in rows:
        f = series_dir / f"{r['trial']}.npz"
        if not f.exists():
            continue
        with np.load(f) as z:
            key = (r["method"], r["targets"], r["resolution"])
            acc = sums.setdefault(key, {"t": z["t"], "n": 0,
                                        **{n: np.zeros_like(z["t"]) for n in names}})
            if len(z["t"]) != len(acc["t"]):
                continue
            for n in names:
                acc[n] = acc[n] + z[n]
            acc["n"] += 1
    for acc in sums.values():
        for n in names:
            acc[n] = acc[n] / max(acc["n"], 1)
    return sums


def plot_time(spec: SweepSpec, rows: Sequence[dict[str, Any]], series_dir: Path,
              out: Path) -> list[Path]:
    """Mean OSPA and mean cardinalities over time per method (Chen Fig. 3b)."""
    names = ("ospa", "cardinality_true", "cardinality_est")
    means = _series_means(spec, rows, series_dir, names)
    if not means:
        return []
    panels = list(itertools.product(spec.targets, spec.resolutions))
    written = []
    for what in ("ospa", "cardinality"):
        fig, axes = figure_grid(len(panels), 5.0, 3.4)
        for ax, (targets, res) in zip(axes, panels, strict=True):
            for j, m in enumerate(spec.methods):
                acc = means.get((m, targets, res))
                if acc is None:
                    continue
                colour = COLOURS[j % len(COLOURS)]
                if what == "ospa":
                    ax.plot(acc["t"], acc["ospa"], color=colour, lw=1.2,
                            label=f"{m} (n={acc['n']})")
                else:
                    ax.plot(acc["t"], acc["cardinality_est"], color=colour, lw=1.2,
                            label=f"{m} estimated (n={acc['n']})")
                    if j == 0:
                        ax.plot(acc["t"], acc["cardinality_true"], color="black", lw=1.0,
                                ls="--", label="true")
            if what == "ospa" and spec.metric != "final":
                ax.axvspan(*spec.window, color="grey", alpha=0.1, lw=0)
            ax.set_xlabel("time [s]")
            ax.set_ylabel("mean OSPA [m]" if what == "ospa" else "mean number of targets")
            if what == "ospa":
                ax.set_ylim(bottom=0)
            ax.grid(alpha=0.3)
            ax.set_title(_panel_title({"targets": targets, "resolution": res}, spec) or None)
            ax.legend(fontsize="small")
        teams = ", ".join(str(r) for r in spec.robots)
        fig.suptitle(f"{spec.figure}\n{spec.label}: mean over all trials and team sizes "
                     f"({teams})", fontsize="medium")
        path = out / f"{what}_vs_time.png"
        fig.savefig(path, dpi=110)
        written.append(path)
    return written


def write_report(spec: SweepSpec, rows: Sequence[dict[str, Any]], out: Path,
                 timing: dict[str, Any]) -> list[Path]:
    """Every plot and the summary tables of a sweep into ``out``; returns the paths."""
    written = [plot_boxes(spec, rows, out / "boxplot.png")]
    written += plot_time(spec, rows, out / "series", out)
    written += write_summary(spec, rows, out, timing)
    return written


__all__ = ["SUMMARY_COLUMNS", "cells", "paired_wins", "plot_boxes", "plot_time",
           "summary_rows", "write_report", "write_summary"]
