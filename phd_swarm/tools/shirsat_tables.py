"""Shirsat & Berman (2021) Sec. VI and Table 1 from the Shirsat sweeps, beside the exact analysis.

Usage::

    python -m phd_swarm.tools.shirsat_tables DIR [DIR ...] [--out OUT]

``DIR`` is a sweep directory of :mod:`phd_swarm.tools.sweep` made from a
``config/sweeps/shirsat_*.yaml`` spec (``results.csv``, ``series/<trial>.npz``,
``spec.json``). Writes ``shirsat_tables.md`` (and ``shirsat_tables.json``) into ``OUT`` (default:
the first ``DIR``), with one row per sweep and ``shirsat_reward_vs_time.png`` (Fig. 5b: the
reward-set cardinality over time, mean and 10-90 % band over the runs, per sweep).

Per run (the per-step figures of :mod:`phd_swarm.core.estimators.shirsat_figures`):

- **mean inter-arrival time** E[tau]: N T dt / sum_k robots_meeting(k), the run's time
  robot-steps over its renewals (a robot at a renewal epoch at step k, eq. 5-6, counts
  once per step, as a renewal process counts epochs; consecutive steps on one node are
  consecutive epochs) -- the empirical form of Kac's mean return time that
  :func:`phd_swarm.core.analysis.renewal.mean_interarrival` computes exactly (event
  ``robot``), printed beside it;
- **t_reward**: the first time every robot's reward cardinality equals the true number of
  targets (``all_found``; the paper's criterion); NaN if never;
- **reward %** (Table 1): the robots' mean reward cardinality at the mean inter-arrival time
  of the sweep (pooled over its runs, as the paper's "until the mean inter-arrival time"),
  over the true number of targets;
- the final reward cardinality and the final OSPA of the reward sets (mean over robots).

Over the runs: mean ± sample sd (NaN runs left out and counted), and the median.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from phd_swarm.config.sweep_spec import find_spec, load_spec
from phd_swarm.core.analysis.renewal import mean_interarrival
from phd_swarm.core.grid_graph import GridGraph
from phd_swarm.tools import tables_cli
from phd_swarm.tools.sung_tables import over_seeds, read_results
from phd_swarm.tools.sweep import load_series

#: The paper's numbers per sweep name: E[tau] [s], t_reward [s], reward [%].
PAPER = {"shirsat_small": {"interarrival_s": 68.0, "t_reward_s": 150.0},
         "shirsat_table1_s1": {"interarrival_s": 20.0, "reward_pct": 10.0},
         "shirsat_table1_s2": {"interarrival_s": 190.0, "reward_pct": 33.0},
         "shirsat_table1_s3": {"interarrival_s": 430.0, "reward_pct": 65.0}}

#: Points drawn per curve at most.
MAX_POINTS = 600


def run_values(series: dict[str, np.ndarray], robots: int, targets: int) -> dict[str, float]:
    """The per-run values of one trial's series (see the module docstring)."""
    t = np.asarray(series["t"], dtype=float)
    dt = float(t[1] - t[0]) if len(t) > 1 else 1.0
    meetings = float(np.sum(series["robots_meeting"]))
    found = np.flatnonzero(np.asarray(series["all_found"]) >= 0.5)
    return {"interarrival_s": robots * len(t) * dt / meetings if meetings else math.nan,
            "robot_time_s": robots * len(t) * dt, "renewals": meetings,
            "t_reward_s": float(t[found[0]]) if found.size else math.nan,
            "reward_final": float(series["reward_mean"][-1]),
            "reward_ospa_final": float(series["reward_ospa_mean"][-1]),
            "targets": float(targets)}


def sweep_table(path: Path) -> dict[str, Any]:
    """The numbers of one sweep directory, with the exact E[tau] of its scenario."""
    rows = read_results(path)
    spec_json = json.loads((path / "spec.json").read_text())
    name = spec_json["name"]
    spec = load_spec(find_spec(name))
    scenario = spec.trials_list()[0].scenario
    robots, targets = int(rows[0]["robots"]), int(rows[0]["targets"])
    runs, curves = [], []
    for r in sorted(rows, key=lambda r: int(r["seed"])):
        s = load_series(path / "series" / f"{r['trial']}.npz")
        runs.append(run_values(s, robots, targets))
        curves.append((np.asarray(s["t"], dtype=float),
                       np.asarray(s["reward_mean"], dtype=float)))
    pooled_tau = over_seeds([v["interarrival_s"] for v in runs])["mean"]
    at = [float(np.interp(pooled_tau, t, c)) if math.isfinite(pooled_tau) else math.nan
          for t, c in curves]
    env, opt = scenario.env, scenario.system.option
    graph = GridGraph(env.xmin, env.ymin, env.xmax, env.ymax, float(opt("grid_spacing")),
                      int(opt("grid_neighbours")))
    exact = mean_interarrival(graph, robots, "robot") * scenario.dt
    # The ratio of totals: per-run ratios are biased up by runs with few renewals.
    pooled = (sum(v["robot_time_s"] for v in runs) / sum(v["renewals"] for v in runs)
              if sum(v["renewals"] for v in runs) else math.nan)
    stats = {q: over_seeds([v[q] for v in runs]) for q in runs[0]}
    stats["reward_pct"] = over_seeds([100.0 * a / targets for a in at])
    for q, s in stats.items():
        vals = [v[q] for v in runs] if q != "reward_pct" else [100.0 * a / targets
                                                                for a in at]
        ok = np.asarray(vals, dtype=float)
        ok = ok[np.isfinite(ok)]
        s["median"] = float(np.median(ok)) if ok.size else math.nan
    return {"name": name, "figure": spec_json.get("figure", ""), "robots": robots,
            "targets": targets, "side_m": env.xmax - env.xmin, "steps": len(curves[0][0]),
            "dt": scenario.dt, "grid": f"{graph.spacing:g} m / {graph.neighbours}",
            "runs": len(runs), "exact_interarrival_s": exact,
            "pooled_interarrival_s": pooled, "stats": stats,
            "paper": PAPER.get(name, {}), "curves": curves}


def _num(x: float) -> str:
    return "n/a" if not math.isfinite(x) else f"{x:.3g}"


def _cell(s: dict[str, float]) -> str:
    if not s["n_valid"]:
        return "n/a"
    out = f"{_num(s['mean'])} ± {_num(s['sd'])} (median {_num(s['median'])})"
    return out + ("" if s["n_valid"] == s["n"] else f" [{s['n_valid']} of {s['n']} runs]")


def markdown(tables: Sequence[dict[str, Any]]) -> str:
    """One row per sweep: ours (mean ± sd over runs), the exact E[tau], the paper's."""
    lines = ["## Shirsat & Berman (2021): renewal times and reward sets",
             "",
             "Per sweep: mean ± sample sd over the runs (median); E[tau] pooled is all runs' "
             "robot time over all their renewals; E[tau] exact is Kac's mean inter-arrival of "
             "a robot's renewals on the grid (core/analysis/renewal.py); paper in the last "
             "column.",
             "",
             "| sweep | robots / targets / side | runs | E[tau] per run [s] | E[tau] pooled "
             "[s] | E[tau] exact [s] "
             "| t_reward [s] | reward % at E[tau] | final reward cardinality | final reward "
             "OSPA [m] | paper |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for t in tables:
        s, p = t["stats"], t["paper"]
        paper = ", ".join(f"{k.replace('_s', '').replace('_pct', ' %')} {v:g}"
                          for k, v in p.items()) or "-"
        lines.append(
            f"| {t['name']} | {t['robots']} / {t['targets']} / {t['side_m']:g} m | "
            f"{t['runs']} | {_cell(s['interarrival_s'])} | "
            f"{_num(t['pooled_interarrival_s'])} | {t['exact_interarrival_s']:.3g} | "
            f"{_cell(s['t_reward_s'])} | {_cell(s['reward_pct'])} | "
            f"{_cell(s['reward_final'])} (true {t['targets']}) | "
            f"{_cell(s['reward_ospa_final'])} | {paper} |")
    return "\n".join(lines) + "\n"


def plot_rewards(tables: Sequence[dict[str, Any]], path: Path) -> Path:
    """Fig. 5b over runs: mean reward cardinality per robot over time, 10-90 % band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tables), figsize=(4.2 * len(tables), 3.4), squeeze=False)
    for ax, t in zip(axes[0], tables, strict=True):
        n = min(len(c) for _, c in t["curves"])
        stack = np.stack([c[:n] for _, c in t["curves"]])
        time = t["curves"][0][0][:n]
        k = max(1, math.ceil(n / MAX_POINTS))
        lo, hi = np.percentile(stack, [10, 90], axis=0)
        ax.fill_between(time[::k], lo[::k], hi[::k], alpha=0.3, lw=0)
        ax.plot(time[::k], stack.mean(axis=0)[::k], lw=1.2, label="mean over runs")
        ax.axhline(t["targets"], color="k", ls="--", lw=0.8, label="true number")
        ax.set_title(f"{t['name']} ({t['runs']} runs)", fontsize=9)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("reward cardinality per robot")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write(tables: list[dict[str, Any]], out: Path) -> str:
    """``shirsat_tables.md``, ``.json`` and ``shirsat_reward_vs_time.png`` into ``out``."""
    (out / "shirsat_tables.md").write_text(markdown(tables))
    (out / "shirsat_tables.json").write_text(json.dumps(
        [{k: v for k, v in t.items() if k != "curves"} for t in tables], indent=2) + "\n")
    plot_rewards(tables, out / "shirsat_reward_vs_time.png")
    return markdown(tables)


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point (see the module docstring); returns the exit code."""
    return tables_cli.run(argv, "shirsat_tables", __doc__.split("\n\n")[0], sweep_table,
                          write)


if __name__ == "__main__":
    sys.exit(main())
