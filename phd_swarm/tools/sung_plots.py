"""The figures of :mod:`.sung_tables`: per-method curves over time and box plots over seeds.

Sung & Tokekar (2022) Figs. 8-10 from a Sung sweep read by
:func:`~phd_swarm.tools.sung_tables.load_sweep`: per method the mean over seeds (line) and
the 10-90 % band over seeds (shaded) of series over time (:func:`plot_time`), and box plots
over seeds of per-run values (:func:`plot_boxes`). Figures on the Agg canvas
(:func:`phd_swarm.tools.tables.figure_grid`, :func:`~phd_swarm.tools.tables.save_png`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from phd_swarm.tools.sung_sweep import MethodRuns, Sweep
from phd_swarm.tools.sweep_plots import COLOURS, legend_columns
from phd_swarm.tools.tables import figure_grid, save_png

#: Band of the time plots: these percentiles over the seeds at each step.
BAND = (10.0, 90.0)

#: The box plots: per-run quantity and axis label.
BOXES = (("tracks_mean", "mean number of tracks"),
         ("components_mean", "mean number of components"),
         ("weights_components_mean", "mean sum of weights"),
         ("mahal_closest_mean", "mean Mahalanobis to closest"),
         ("ospa_mean", "mean OSPA [m]"))


def _colours(n: int) -> list[str]:
    if n <= len(COLOURS):
        return list(COLOURS[:n])
    from matplotlib import colormaps

    cmap = colormaps["tab10"]
    return [cmap(i % 10) for i in range(n)]


def _stack(runs: MethodRuns, key: str) -> tuple[np.ndarray, np.ndarray]:
    """Time and the (runs, steps) array of one series, cut to the shortest run."""
    n = min(len(s["t"]) for s in runs.series)
    t = runs.series[0]["t"][:n]
    return t, np.vstack([s[key][:n] for s in runs.series])


def _band(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean and the :data:`BAND` percentiles over runs at each step (NaN-aware)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN steps stay NaN
        mean = np.nanmean(values, axis=0)
        lo, hi = np.nanpercentile(values, BAND, axis=0)
    return mean, lo, hi


def _title(sweep: Sweep, what: str) -> str:
    n = sorted({len(r.trials) for r in sweep.methods.values()})
    runs = f"{n[0]}" if len(n) == 1 else f"{n[0]}-{n[-1]}"
    head = sweep.figure or "Sung & Tokekar (2022)"
    return f"{head}\n{sweep.name}: {what}, {runs} seed{'s' if n[-1] > 1 else ''} per method"


def _legend(fig: Figure, handles: list) -> None:
    labels = [h.get_label() for h in handles]
    fig.legend(handles=handles, loc="outside lower center",
               ncols=legend_columns(labels, fig.get_figwidth()), fontsize="small")


def plot_time(sweep: Sweep, panels: Sequence[tuple[str, str]], path: Path, what: str,
              truth: bool = False) -> Path:
    """Per method the mean over seeds and the 10-90 % band of series over time.

    Parameters
    ----------
    sweep : Sweep
        The sweep (:func:`load_sweep`).
    panels : sequence of (str, str)
        Series and y-axis label, one panel each.
    path : Path
        The PNG file to write.
    what : str
        Subject of the figure's title.
    truth : bool
        Draw the true number of targets (mean over all runs) as a dashed line.

    Returns
    -------
    Path
        ``path``.
    """
    fig, axes = figure_grid(len(panels), 8.0 if len(panels) == 1 else 5.2, 3.5)
    colours = _colours(len(sweep.methods))
    handles: list = []
    for i, (ax, (key, label)) in enumerate(zip(axes, panels, strict=True)):
        for colour, (m, runs) in zip(colours, sweep.methods.items(), strict=True):
            t, values = _stack(runs, key)
            mean, lo, hi = _band(values)
            line, = ax.plot(t, mean, color=colour, lw=1.0, label=f"{m} (n={len(runs.trials)})")
            ax.fill_between(t, lo, hi, color=colour, alpha=0.18, lw=0)
            if i == 0:
                handles.append(line)
        if truth:
            longest = max(sweep.methods.values(), key=lambda r: len(r.series[0]["t"]))
            t, true = _stack(longest, "cardinality_true")
            ax.plot(t, np.nanmean(true, axis=0), color="black", lw=1.0, ls="--")
        ax.set_xlabel("time step [s]")
        ax.set_ylabel(label)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    if truth:
        handles.append(Line2D([], [], color="black", lw=1.0, ls="--", label="true number"))
    handles.append(Line2D([], [], color="grey", lw=6, alpha=0.3,
                          label=f"{BAND[0]:g}-{BAND[1]:g} % of seeds"))
    _legend(fig, handles)
    fig.suptitle(_title(sweep, what + " (mean over seeds)"), fontsize="medium")
    save_png(fig, path)
    return path


def plot_boxes(sweep: Sweep, summ: dict[str, Any], path: Path) -> Path:
    """Box plots over seeds per method of the per-run values of :data:`BOXES`.

    Parameters
    ----------
    sweep : Sweep
        The sweep (:func:`load_sweep`).
    summ : dict
        Its :func:`summary`.
    path : Path
        The PNG file to write.

    Returns
    -------
    Path
        ``path``.
    """
    names = list(summ["methods"])
    width = max(3.2, 0.55 * len(names) + 1.4)
    fig, axes = figure_grid(len(BOXES), width, 3.4)
    colours = _colours(len(names))
    for ax, (q, label) in zip(axes, BOXES, strict=True):
        for j, m in enumerate(names):
            v = np.asarray(summ["methods"][m]["runs"][q], dtype=float)
            v = v[np.isfinite(v)]
            if not len(v):
                ax.text(j, 0, "n/a", ha="center", va="bottom", fontsize="small")
                continue
            c = colours[j]
            ax.boxplot([v], positions=[j], widths=0.6, patch_artist=True, manage_ticks=False,
                       boxprops={"facecolor": c, "alpha": 0.45, "edgecolor": c},
                       medianprops={"color": "black"}, whiskerprops={"color": c},
                       capprops={"color": c},
                       flierprops={"marker": "+", "markeredgecolor": c})
            ax.plot(np.full(len(v), j), v, ".", color=c, markersize=3, alpha=0.8)
            paper = summ["methods"][m]["paper"].get(q)
            if paper is not None:
                ax.plot([j], [paper], marker="*", color="black", markersize=8, ls="none")
        ax.set_xticks(range(len(names)))
        tilt = 0.075 * sum(len(m) + 1 for m in names) > 0.8 * width
        ax.set_xticklabels(names, rotation=35 if tilt else 0, ha="right" if tilt else "center")
        ax.set_xlim(-0.6, len(names) - 0.4)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    _legend(fig, [Line2D([], [], marker="*", color="black", ls="none", markersize=8,
                         label="paper (one run)")])
    fig.suptitle(_title(sweep, "per-run values over seeds"), fontsize="medium")
    save_png(fig, path)
    return path


