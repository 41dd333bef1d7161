"""Papaioannou et al. Figs. 1-5 from the Papaioannou sweeps: curves and tables per cell.

Usage::

    python -m phd_swarm.tools.papaioannou_tables DIR [DIR ...] [--out OUT]

``DIR`` is a sweep directory of :mod:`phd_swarm.tools.sweep` made from a
``config/sweeps/papaioannou_*.yaml`` spec. For each (method, agents, targets) cell of each
sweep, over its runs (the per-step figures of
:mod:`phd_swarm.core.estimators.papaioannou.figures`):

- **searched area** [%]: the mean over runs of the team's searched area (Figs. 1, 2, 4) at
  the last step, and its curve over time;
- **OSPA** [m]: the mean over runs and steps (Fig. 3), and its curve over time;
- **tracking ratio**: per run, the steps of the true targets with an agent's estimate
  within the gate over the steps they were alive, ``sum(targets_tracked) /
  sum(targets_alive)`` (Fig. 5, the pooled reading; NaN for a run without targets); mean ±
  sd over runs.

From the per-target series (``target_ids``, ``target_trackers``, ``target_in_view``; runs
made before 2026-12 have none, and show n/a):

- **per target**: the other reading of Fig. 5a's "time tracked normalised with the actual
  lifetime", the mean over targets of each one's tracked steps over its steps alive, over
  all targets (``per_target_all``), over those ever in an agent's square, i.e. that could
  be detected (``per_target_detected``), and over those ever tracked (``per_target_tracked``);
- **in-area lifetime** [s]: the mean over targets of the time each was in the truth during
  the run (the normaliser; :mod:`phd_swarm.sim.lifetimes`);
- **bound**: the perfect sweep's (approximate) upper bound on the pooled ratio for the
  run's agents and its own targets' lifetimes (:func:`phd_swarm.core.analysis.
  tracking_bound.tracking_ratio_bound`, the paper's geometry);
- **looks** [%]: agent-steps spent tracking tentative detections only (the look rule);
- **overlap tests / fired**: per run, the tracking-overlap windows compared with Q_th and
  those that fired (eq. 19, Sec. V-C b), summed over the agents: both agents of a pair
  test the same window, so a pair's window counts twice.

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

from phd_swarm.core.analysis.tracking_bound import tracking_ratio_bound
from phd_swarm.sim.lifetimes import alive_steps
from phd_swarm.tools.sweep_results import load_series
from phd_swarm.tools.tables import figure_grid, over_seeds, read_results, run, save_png

#: The paper's readings where it states numbers (Fig. 5a at C_R = 40 m), by sweep name.
PAPER = {"papaioannou_fig5a": "tracking ratio ~0.25 for 2 agents, 0.83 for 10 at C_R 40 m"}


def run_values(series: dict[str, np.ndarray], agents: int | None = None) -> dict[str, float]:
    """One trial's values (see the module docstring); ``agents`` for the bound and looks."""
    alive = float(np.sum(series["targets_alive"]))
    nan = math.nan
    out = {"searched_final_pct": 100.0 * float(series["searched_area"][-1]),
           "ospa_mean": float(np.mean(series["ospa"])),
           "tracking_ratio": (float(np.sum(series["targets_tracked"])) / alive
                              if alive else nan),
           "agents_tracking_mean": float(np.mean(series["agents_tracking"])),
           **target_values(series, agents)}
    steps = len(series["t"])
    looks = series.get("agents_looking")
    out["looks_pct"] = (100.0 * float(np.sum(looks)) / (agents * steps)
                        if looks is not None and agents else nan)
    for name in ("overlap_tests", "overlaps_fired"):
        out[name] = float(np.sum(series[name])) if name in series else nan
    return out


def target_values(series: dict[str, np.ndarray], agents: int | None = None
                  ) -> dict[str, float]:
    """Per-target readings of one trial from its id series (all NaN without them).

    ``per_target_all`` / ``_detected`` / ``_tracked``: the mean over targets (all, ever in
    a square, ever tracked) of tracked steps over steps alive; ``lifetime_mean`` [s];
    ``targets_seen``: targets ever in the truth; ``bound_pooled``: the perfect sweep's bound
    for ``agents`` and these lifetimes.
    """
    keys = ("per_target_all", "per_target_detected", "per_target_tracked", "lifetime_mean",
            "targets_seen", "bound_pooled")
    out = dict.fromkeys(keys, math.nan)
    if "target_ids" not in series:
        return out
    ids = np.asarray(series["target_ids"])
    valid = ids >= 0
    uid, lives = alive_steps(ids)
    out["targets_seen"] = float(len(uid))
    if not len(uid):
        return out
    inv = np.searchsorted(uid, ids[valid])
    tracked = np.bincount(inv, weights=np.asarray(series["target_trackers"])[valid] > 0,
                          minlength=len(uid))
    seen = np.bincount(inv, weights=np.asarray(series["target_in_view"])[valid] > 0,
                       minlength=len(uid)) > 0
    ratio = tracked / lives
    t = np.asarray(series["t"], dtype=float)
    dt = float(t[1] - t[0]) if len(t) > 1 else 1.0
    out.update({"per_target_all": float(ratio.mean()),
                "per_target_detected": float(ratio[seen].mean()) if seen.any() else math.nan,
                "per_target_tracked": (float(ratio[tracked > 0].mean()) if (tracked > 0).any()
                                       else math.nan),
                "lifetime_mean": float(lives.mean()) * dt,
                "bound_pooled": (tracking_ratio_bound(int(agents), lives) if agents
                                 else math.nan)})
    return out


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
        runs = [run_values(s, robots) for s in series]
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
    lines = ["## Papaioannou et al.: searched area, OSPA and tracking time", "",
             f"Bound (pooled): a perfect sweep with 10 m squares tracks at most this share of "
             f"the target time, for the run's agents and its targets' lifetimes (approximate: "
             f"it takes a target's birth point independent of its lifetime) "
             f"(docs/decisions.md); for a geometric 30-step life it is "
             f"{tracking_ratio_bound(10, 30.0):.2f} with 10 agents and "
             f"{tracking_ratio_bound(2, 30.0):.2f} with 2.", ""]
    for t in tables:
        lines += [f"### {t['name']}", ""]
        if t["paper"]:
            lines += [f"Paper: {t['paper']}.", ""]
        lines += ["| method | agents | targets | runs | searched area at the end [%] | "
                  "mean OSPA [m] | tracking ratio (pooled) | per target: all / detected | "
                  "bound (pooled) | in-area lifetime [s] | agents tracking (mean) | "
                  "looks [%] | overlap tests / fired (per agent) |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for c in t["cells"]:
            s = c["stats"]
            lines.append(f"| {c['method']} | {c['agents']} | {c['targets']} | {c['runs']} | "
                         f"{_cell(s['searched_final_pct'])} | {_cell(s['ospa_mean'])} | "
                         f"{_cell(s['tracking_ratio'])} | "
                         f"{_cell(s['per_target_all'])} / {_cell(s['per_target_detected'])} | "
                         f"{_cell(s['bound_pooled'])} | {_cell(s['lifetime_mean'])} | "
                         f"{_cell(s['agents_tracking_mean'])} | {_cell(s['looks_pct'])} | "
                         f"{_cell(s['overlap_tests'])} / {_cell(s['overlaps_fired'])} |")
        lines.append("")
    return "\n".join(lines)


def plot_curves(table: dict[str, Any], path: Path) -> Path:
    """Searched area and OSPA against time, one line per cell (mean over its runs)."""
    fig, axes = figure_grid(2, 5.0, 3.8)
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
    return save_png(fig, path, dpi=120)


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
    return run(argv, "papaioannou_tables", __doc__.split("\n\n")[0],
                          sweep_table, write)


if __name__ == "__main__":
    sys.exit(main())
