"""Shirsat & Berman (2021) Sec. VI and Table 1 from the Shirsat sweeps, beside the exact analysis.

Usage::

    python -m phd_swarm.tools.shirsat_tables DIR [DIR ...] [--out OUT]

``DIR`` is a sweep directory of :mod:`phd_swarm.tools.sweep` made from a
``config/sweeps/shirsat_*.yaml`` spec (``results.csv``, ``series/<trial>.npz``,
``spec.json``). Writes ``shirsat_tables.md`` (and ``shirsat_tables.json``) into ``OUT`` (default:
the first ``DIR``), with one row per sweep and ``shirsat_reward_vs_time.png`` (Fig. 5b: the
reward-set cardinality over time, mean and 10-90 % band over the runs, per sweep).

Per run (the per-step figures of :mod:`phd_swarm.core.estimators.shirsat.figures`):

- **mean inter-arrival time** E[tau]: N T dt / sum_k robots_meeting(k), the run's time
  robot-steps over its renewals (a robot at a renewal epoch at step k, eq. 5-6, counts
  once per step, as a renewal process counts epochs; consecutive steps on one node are
  consecutive epochs) -- the empirical form of Kac's mean return time that
  :func:`phd_swarm.core.analysis.renewal_exact.mean_interarrival` computes exactly (event
  ``robot``), printed beside it;
- **t_reward**: the first time every robot's reward cardinality equals the true number of
  targets (``all_found``; the paper's criterion); NaN if never;
- **reward %** (Table 1, "the ratio of the mean number of targets detected by the robots
  until the mean inter-arrival time to the actual number of targets"): the robots' mean
  number of reward members that match a true target (``reward_true_mean`` of
  :mod:`phd_swarm.core.estimators.shirsat.figures`: by label for a labelled member, else
  within the 1.5 m gate of a target, each target matched once), over the true number of
  targets, at two times: the sweep's pooled E[tau] (all its runs' robot time over all
  their renewals) and the paper's own E[tau] (20 / 190 / 430 s for Table 1, 68 s for the
  small scenario); a clutter point in a reward set is not a target detected. Beside it the
  former reading, every member counted (``reward_mean``), at the pooled E[tau]. Series
  saved before ``reward_true_mean`` existed give n/a for the matched figures;
- the final reward cardinality, its members that match a true target, and the final OSPA
  of the reward sets (means over robots).

Each row names its reading: the reward-set union (by position, or by label with a sensor
that identifies targets, ``reward_union``) and the merge metric.

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
from phd_swarm.core.analysis.renewal_exact import mean_interarrival
from phd_swarm.core.controllers.dtds_walk.grid_graph import GridGraph
from phd_swarm.tools.sweep_results import load_series
from phd_swarm.tools.tables import figure_grid, over_seeds, read_results, run, save_png

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
            "reward_true_final": float(true_curve(series)[-1]),
            "reward_ospa_final": float(series["reward_ospa_mean"][-1]),
            "targets": float(targets)}


def true_curve(series: dict[str, np.ndarray]) -> np.ndarray:
    """``reward_true_mean`` of a trial's series, or NaNs if it was saved without it."""
    if "reward_true_mean" in series:
        return np.asarray(series["reward_true_mean"], dtype=float)
    return np.full(len(series["t"]), math.nan)


def pooled_interarrival(runs: Sequence[dict[str, float]]) -> float:
    """E[tau] pooled over runs: all their robot time over all their renewals [s].

    The ratio of totals, not the mean of the per-run ratios, which runs with few renewals
    bias up (NaN if there is no renewal at all).
    """
    renewals = sum(v["renewals"] for v in runs)
    return sum(v["robot_time_s"] for v in runs) / renewals if renewals else math.nan


def percent_at(curves: Sequence[tuple[np.ndarray, np.ndarray]], time: float,
               targets: int) -> list[float]:
    """Per run, 100 x the curve at ``time`` [s] (linear interpolation) over ``targets``.

    NaN for every run if ``time`` is not finite or lies after a run's last step.
    """
    if not math.isfinite(time):
        return [math.nan] * len(curves)
    return [100.0 * float(np.interp(time, t, c)) / targets if time <= t[-1] else math.nan
            for t, c in curves]


def reading(system: Any) -> str:
    """The sweep's reading of the paper: the reward-set union and the merge metric."""
    names = {o for o, _ in system.options}
    union = system.option("reward_union") if "reward_union" in names else "position"
    text = (f"union by label ({system.sensor})" if union == "label"
            else "union by position")
    if "merge_metric" in names:
        text += f", {system.option('merge_metric')} merge"
    return text


def sweep_table(path: Path) -> dict[str, Any]:
    """The numbers of one sweep directory, with the exact E[tau] of its scenario."""
    rows = read_results(path)
    spec_json = json.loads((path / "spec.json").read_text())
    name = spec_json["name"]
    spec = load_spec(find_spec(name))
    trials = {t.key: t for t in spec.trials_list()}
    scenario = next(iter(trials.values())).scenario
    # The reading of the rows' own settings: those of the spec's trials they match.
    same = [trials[r["trial"]] for r in rows if r["trial"] in trials
            and trials[r["trial"]].config_hash == r.get("config_hash")]
    paper = PAPER.get(name) or PAPER.get(getattr(spec, "base", ""), {})
    robots, targets = int(rows[0]["robots"]), int(rows[0]["targets"])
    runs, curves, true = [], [], []
    for r in sorted(rows, key=lambda r: int(r["seed"])):
        s = load_series(path / "series" / f"{r['trial']}.npz")
        runs.append(run_values(s, robots, targets))
        t = np.asarray(s["t"], dtype=float)
        curves.append((t, np.asarray(s["reward_mean"], dtype=float)))
        true.append((t, true_curve(s)))
    pooled = pooled_interarrival(runs)
    per_run = {q: [v[q] for v in runs] for q in runs[0]}
    per_run["reward_pct"] = percent_at(true, pooled, targets)
    per_run["reward_pct_paper_tau"] = percent_at(true, paper.get("interarrival_s", math.nan),
                                                 targets)
    per_run["reward_all_pct"] = percent_at(curves, pooled, targets)
    env, opt = scenario.env, scenario.system.option
    graph = GridGraph(env.xmin, env.ymin, env.xmax, env.ymax, float(opt("grid_spacing")),
                      int(opt("grid_neighbours")))
    exact = mean_interarrival(graph, robots, "robot") * scenario.dt
    stats = {}
    for q, vals in per_run.items():
        stats[q] = over_seeds(vals)
        ok = np.asarray(vals, dtype=float)
        ok = ok[np.isfinite(ok)]
        stats[q]["median"] = float(np.median(ok)) if ok.size else math.nan
    return {"name": name, "figure": spec_json.get("figure", ""),
            "reading": (reading(same[0].scenario.system) if same
                        else "not the spec's settings today (older rows)"),
            "robots": robots,
            "targets": targets, "side_m": env.xmax - env.xmin, "steps": len(curves[0][0]),
            "dt": scenario.dt, "grid": f"{graph.spacing:g} m / {graph.neighbours}",
            "runs": len(runs), "exact_interarrival_s": exact,
            "pooled_interarrival_s": pooled, "stats": stats,
            "paper": paper, "curves": curves}


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
             "a robot's renewals on the grid (core/analysis/renewal_exact.py). Reward %: the "
             "robots' mean number of reward members that match a true target (by label, or "
             "within 1.5 m, each target once) over the true number, at our pooled E[tau] "
             "and at the paper's; 'all members' counts every member, clutter included. "
             "Paper in the last column.",
             "",
             "| sweep | reading | robots / targets / side | runs | E[tau] per run [s] | "
             "E[tau] pooled [s] | E[tau] exact [s] | t_reward [s] | reward % at E[tau] "
             "pooled | reward % at the paper's E[tau] | reward % at E[tau] pooled, all "
             "members | final reward cardinality | final members matching a target | final "
             "reward OSPA [m] | paper |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for t in tables:
        s, p = t["stats"], t["paper"]
        paper = ", ".join(f"{k.replace('_s', '').replace('_pct', ' %')} {v:g}"
                          for k, v in p.items()) or "-"
        lines.append(
            f"| {t['name']} | {t.get('reading', '-')} | {t['robots']} / {t['targets']} / "
            f"{t['side_m']:g} m | {t['runs']} | {_cell(s['interarrival_s'])} | "
            f"{_num(t['pooled_interarrival_s'])} | {t['exact_interarrival_s']:.3g} | "
            f"{_cell(s['t_reward_s'])} | {_cell(s['reward_pct'])} | "
            f"{_cell(s['reward_pct_paper_tau'])} | {_cell(s['reward_all_pct'])} | "
            f"{_cell(s['reward_final'])} (true {t['targets']}) | "
            f"{_cell(s['reward_true_final'])} | {_cell(s['reward_ospa_final'])} | {paper} |")
    return "\n".join(lines) + "\n"


def plot_rewards(tables: Sequence[dict[str, Any]], path: Path) -> Path:
    """Fig. 5b over runs: mean reward cardinality per robot over time, 10-90 % band."""
    fig, axes = figure_grid(len(tables), 4.2, 3.4, cols=len(tables))
    for ax, t in zip(axes, tables, strict=True):
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
    return save_png(fig, path, dpi=120)


def write(tables: list[dict[str, Any]], out: Path) -> str:
    """``shirsat_tables.md``, ``.json`` and ``shirsat_reward_vs_time.png`` into ``out``."""
    (out / "shirsat_tables.md").write_text(markdown(tables))
    (out / "shirsat_tables.json").write_text(json.dumps(
        [{k: v for k, v in t.items() if k != "curves"} for t in tables], indent=2) + "\n")
    plot_rewards(tables, out / "shirsat_reward_vs_time.png")
    return markdown(tables)


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point (see the module docstring); returns the exit code."""
    return run(argv, "shirsat_tables", __doc__.split("\n\n")[0], sweep_table,
                          write)


if __name__ == "__main__":
    sys.exit(main())
