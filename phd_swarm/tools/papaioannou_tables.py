"""Papaioannou et al. Figs. 1-5 from the Papaioannou sweeps: curves and tables per cell.

Usage::

    python -m phd_swarm.tools.papaioannou_tables DIR [DIR ...] [--out OUT]

``DIR`` is a sweep directory of :mod:`phd_swarm.tools.sweep` made from a
``config/sweeps/papaioannou_*.yaml`` spec. For each (method, agents, targets) cell of each
sweep, over its runs (the per-step figures of
:mod:`phd_swarm.core.estimators.papaioannou_figures`):

- **searched area** [%]: the mean over runs of the team's searched area (Figs. 1, 2, 4) at
  the last step, and its curve over time;
- **OSPA** [m]: the mean over runs and steps (Fig. 3), and its curve over time;
- **tracking ratio**: per run, the steps of the true targets with an agent's estimate
  within the gate over the steps they were alive, ``sum(targets_tracked) /
  sum(targets_alive)`` (Fig. 5; NaN for a run without targets); mean ± sd over runs.

Writes ``papaioannou_tables.md`` and ``.json`` and one ``<sweep>_curves.png`` per sweep
(searched area and OSPA against time, one line per cell) into ``OUT`` (default: the first
``DIR``).
"""

from __future__ import annotations

import json
import math
import sys
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from phd_swarm.tools import tables_cli
from phd_swarm.tools.sung_tables import over_seeds, read_results
from phd_swarm.tools.sweep import load_series

#: The paper's readings where it states numbers (Fig. 5a at C_R = 40 m), by sweep name.
PAPER = {"papaioannou_fig5a": "tracking ratio ~0.25 for 2 agents, 0.83 for 10 at C_R 40 m"}


def run_values(series: dict[str, np.ndarray]) -> dict[str, float]:
    """One trial's values (see the module docstring)."""
    alive = float(np.sum(series["targets_alive"]))
    return {"searched_final_pct": 100.0 * float(series["searched_area"][-1]),
            "ospa_mean": float(np.mean(series["ospa"])),
            "tracking_ratio": (float(np.sum(series["targets_tracked"])) / alive
                               if alive else math.nan),
            "agents_tracking_mean": float(np.mean(series["agents_tracking"]))}


def sweep_table(path: Path) -> dict[str, Any]:
    """The cells of one sweep directory: per-run values over seeds, and mean curves."""
    rows = read_results(path)
    name = json.loads((path / "spec.json").read_text())["name"]
    cells: dict[tuple[str, int, int], list[dict[str, np.ndarray]]] = defaultdict(list)
    for r in sorted(rows, key=lambda r: (r["method"], int(r["robots"]), int(r["targets"]),
                                         int(r["seed"]))):
        cells[(r["method"], int(r["robots"]), int(r["targets"]))].append(
            load_series(path / "series" / f"{r['trial']}.npz"))
    out = []
    for (method, robots, targets), series in sorted(cells.items()):
        runs = [run_values(s) for s in series]
        n = min(len(s["t"]) for s in series)
        out.append({
            "method": method, "agents": robots, "targets": targets, "runs": len(runs),
            "stats": {q: over_seeds([v[q] for v in runs]) for q in runs[0]},
            "t": np.asarray(series[0]["t"][:n], dtype=float),
            "searched_curve": 100.0 * np.mean([s["searched_area"][:n] for s in series], 0),
            "ospa_curve": np.mean([s["ospa"][:n] for s in series], axis=0)})
    return {"name": name, "cells": out, "paper": PAPER.get(name.removesuffix("_distributed"))}


def _cell(s: dict[str, float]) -> str:
    if not s["n_valid"]:
        return "n/a"
    sd = "" if not math.isfinite(s["sd"]) else f" ± {s['sd']:.3g}"
    return f"{s['mean']:.3g}{sd}" + ("" if s["n_valid"] == s["n"] else
                                      f" [{s['n_valid']} of {s['n']}]")


def markdown(tables: Sequence[dict[str, Any]]) -> str:
    """One table per sweep, one row per cell: mean ± sd over runs."""
    lines = ["## Papaioannou et al.: searched area, OSPA and tracking time", ""]
    for t in tables:
        lines += [f"### {t['name']}", ""]
        if t["paper"]:
            lines += [f"Paper: {t['paper']}.", ""]
        lines += ["| method | agents | targets | runs | searched area at the end [%] | "
                  "mean OSPA [m] | tracking ratio | agents tracking (mean) |",
                  "|---|---|---|---|---|---|---|---|"]
        for c in t["cells"]:
            s = c["stats"]
            lines.append(f"| {c['method']} | {c['agents']} | {c['targets']} | {c['runs']} | "
                         f"{_cell(s['searched_final_pct'])} | {_cell(s['ospa_mean'])} | "
                         f"{_cell(s['tracking_ratio'])} | "
                         f"{_cell(s['agents_tracking_mean'])} |")
        lines.append("")
    return "\n".join(lines)


def plot_curves(table: dict[str, Any], path: Path) -> Path:
    """Searched area and OSPA against time, one line per cell (mean over its runs)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for c in table["cells"]:
        label = f"{c['method']}, {c['agents']} agents, {c['targets']} targets"
        axes[0].plot(c["t"], c["searched_curve"], lw=1.1, label=label)
        axes[1].plot(c["t"], c["ospa_curve"], lw=1.1, label=label)
    axes[0].set_ylabel("searched area [%]")
    axes[1].set_ylabel("OSPA [m]")
    for ax in axes:
        ax.set_xlabel("time [s]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=6)
    fig.suptitle(f"{table['name']} (mean over runs)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write(tables: list[dict[str, Any]], out: Path) -> str:
    """``papaioannou_tables.md``, ``.json`` and one ``<sweep>_curves.png`` each into ``out``."""
    (out / "papaioannou_tables.md").write_text(markdown(tables))
    (out / "papaioannou_tables.json").write_text(json.dumps(
        [{"name": t["name"], "paper": t["paper"],
          "cells": [{k: v for k, v in c.items() if not isinstance(v, np.ndarray)}
                    for c in t["cells"]]} for t in tables], indent=2) + "\n")
    for t in tables:
        plot_curves(t, out / f"{t['name']}_curves.png")
    return markdown(tables)


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point (see the module docstring); returns the exit code."""
    return tables_cli.run(argv, "papaioannou_tables", __doc__.split("\n\n")[0],
                          sweep_table, write)


if __name__ == "__main__":
    sys.exit(main())
