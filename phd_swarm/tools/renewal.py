"""Shirsat & Berman's inter-arrival times, exactly, under each reading of the paper.

Usage::

    python -m phd_swarm.tools.renewal [--out DIR] [--quick] [--seed N]

The paper gives E[tau] ~ 68 s for 3 robots on 5 x 5 m (Sec. VI, Fig. 5a) and, for 20
robots, 20 s on 15 x 15 m, 190 s on 20 x 20 m and 430 s on 30 x 30 m (Table 1), but not
the grid spacing, the seconds per step, the neighbourhood or which meetings it counts.
This tool computes the exact expectations (:mod:`phd_swarm.core.analysis.renewal_exact`) for
every combination of

- grid spacing 0.25, 0.5, 1 m and 4 or 8 neighbours (:data:`GEOMETRIES`);
- reading (:data:`READINGS`): whose meetings (a given pair, a given robot with any other,
  any two robots of the team), and which time: the mean gap between successive meetings
  (Kac: the renewal inter-arrival the paper averages), the mean gap between *new*
  meetings (robots staying together count once), or the mean first meeting time from
  the paper's start (robots on uniformly random nodes; exact where the composite chain
  fits :data:`MAX_STATES`, else "-"),

all in steps, and the seconds per step each would need to give the paper's seconds.

Outputs (in ``--out``, default ``results/renewal/``):

- ``renewal.md`` (also printed): the tables, and the spread of the estimate one 300 s run
  gives (the paper's 68 s is one run's average of a handful of intervals);
- ``renewal.json``: the same numbers;
- ``renewal.png``: the mean inter-arrival time of a robot with any other (Kac, steps)
  against the side of a square map, 5 to 40 m at 1 m spacing with 4 neighbours, for 3, 10
  and 20 robots (lines, exact), with seeded simulations (markers with 95 % confidence
  intervals), and the pair reading (dashed).

``--quick`` computes the first-meeting columns only for small chains and simulates fewer,
shorter runs (a few seconds). Exit code 0.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from phd_swarm.core.analysis import renewal_exact as renewal
from phd_swarm.core.analysis.renewal_simulation import simulate_meetings, window_averages
from phd_swarm.core.controllers.dtds_walk.grid_graph import GridGraph
from phd_swarm.tools import plots

#: (grid spacing [m], neighbours) of the tables.
GEOMETRIES = tuple((s, n) for s in (0.25, 0.5, 1.0) for n in (4, 8))

#: Seconds per step thought plausible (the issue's 0.1 ... 1 s).
DT_RANGE = (0.1, 1.0)

#: Sec. VI / Fig. 5a: robots, side [m], E[tau] [s].
FIG5 = (3, 5.0, 68.0)

#: Table 1: robots, and (side [m], mean inter-arrival time [s]) of scenarios 1-3.
TABLE1 = (20, ((15.0, 20.0), (20.0, 190.0), (30.0, 430.0)))

#: Largest composite chain of a first-meeting column (default run, ``--quick``).
MAX_STATES = 2_000_000
QUICK_MAX_STATES = 100_000

#: Relative residual of the first-meeting solves (4+ significant digits).
RTOL = 1e-8


@dataclass(frozen=True)
class Reading:
    """One reading of the paper's mean inter-arrival time.

    Attributes
    ----------
    key : str
    label : str
        For the tables.
    compute : callable
        ``compute(graph, robots, max_states)`` -> E[tau] in steps, or None when the exact
        computation is too large.
    """

    key: str
    label: str
    compute: Callable[[GridGraph, int, int], float | None]


def _gap(event: str) -> Callable[[GridGraph, int, int], float | None]:
    return lambda g, n, limit: renewal.mean_interarrival(g, n, event)


def _new(event: str) -> Callable[[GridGraph, int, int], float | None]:
    return lambda g, n, limit: renewal.mean_time_between_entries(g, n, event)


def _first(event: str) -> Callable[[GridGraph, int, int], float | None]:
    def compute(g: GridGraph, n: int, limit: int) -> float | None:
        if float(g.size) ** renewal.chain_robots(n, event) > limit:
            return None
        return renewal.mean_first_meeting(g, n, event, "uniform", rtol=RTOL,
                                          max_states=limit)
    return compute


READINGS = (
    Reading("pair_gap", "pair: gap between meetings (Kac)", _gap("pair")),
    Reading("robot_gap", "robot-any: gap between meetings (Kac)", _gap("robot")),
    Reading("team_gap", "any two: gap between meetings (Kac)", _gap("team")),
    Reading("pair_new", "pair: gap between new meetings", _new("pair")),
    Reading("robot_new", "robot-any: gap between new meetings", _new("robot")),
    Reading("pair_first", "pair: first meeting, uniform start", _first("pair")),
    Reading("robot_first", "robot-any: first meeting, uniform start", _first("robot")),
    Reading("team_first", "any two: first meeting, uniform start", _first("team")),
)


def square(side: float, spacing: float, neighbours: int) -> GridGraph:
    """The grid graph of a side x side m map."""
    return GridGraph(0.0, 0.0, side, side, spacing, neighbours)


def _fmt(x: float | None, digits: int = 4) -> str:
    if x is None:
        return "-"
    return f"{x:.{digits}g}"


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def fig5_numbers(limit: int) -> dict[str, dict[str, float | None]]:
    """E[tau] [steps] per geometry label and reading key, 3 robots on 5 x 5 m."""
    robots, side, _ = FIG5
    out: dict[str, dict[str, float | None]] = {}
    for spacing, nb in GEOMETRIES:
        g = square(side, spacing, nb)
        out[f"{spacing:g} m/{nb}"] = {r.key: r.compute(g, robots, limit) for r in READINGS}
    return out


def table1_numbers(limit: int) -> dict[str, dict[str, list[float | None]]]:
    """E[tau] [steps] of scenarios 1-3 per geometry label and reading key, 20 robots."""
    robots, scenarios = TABLE1
    out: dict[str, dict[str, list[float | None]]] = {}
    for spacing, nb in GEOMETRIES:
        graphs = [square(side, spacing, nb) for side, _ in scenarios]
        out[f"{spacing:g} m/{nb}"] = {
            r.key: [r.compute(g, robots, limit) for g in graphs]
            for r in READINGS if r.key != "robot_first" and r.key != "team_first"}
    return out


def render_fig5(numbers: dict[str, dict[str, float | None]]) -> str:
    """Markdown: rows readings, columns geometries; cells "E[tau] steps (s/step for 68 s)"."""
    robots, side, seconds = FIG5
    geoms = list(numbers)
    rows = []
    for r in READINGS:
        cells = []
        for geo in geoms:
            e = numbers[geo][r.key]
            if e is None:
                cells.append("-")
            else:
                dt = seconds / e
                mark = " **" if DT_RANGE[0] <= dt <= DT_RANGE[1] else ""
                cells.append(f"{e:.4g} ({dt:.3g} s){mark}")
        rows.append([r.label, *cells])
    head = (f"### Sec. VI, Fig. 5a: {robots} robots on {side:g} x {side:g} m, "
            f"E[tau] = {seconds:g} s\n\nEach cell: E[tau] in steps (seconds per step that "
            f"would give {seconds:g} s); ** marks {DT_RANGE[0]:g}-{DT_RANGE[1]:g} s per step. "
            "Columns: grid spacing / neighbours.\n\n")
    return head + _table(["reading", *geoms], rows)


def render_table1(numbers: dict[str, dict[str, list[float | None]]]) -> str:
    """Markdown: one row per geometry and reading; steps, ratios, implied s/step."""
    robots, scenarios = TABLE1
    paper = [s for _, s in scenarios]
    rows = []
    for geo, per in numbers.items():
        for r in READINGS:
            if r.key not in per:
                continue
            e = per[r.key]
            steps = " : ".join(_fmt(x) for x in e)
            if any(x is None for x in e):
                ratios, dts = "-", " / ".join(
                    "-" if x is None else f"{p / x:.3g}" for x, p in zip(e, paper, strict=True))
            else:
                ratios = f"{e[1] / e[0]:.2f}, {e[2] / e[0]:.2f}, {e[2] / e[1]:.2f}"
                dts = " / ".join(f"{p / x:.3g}" for x, p in zip(e, paper, strict=True))
            rows.append([geo, r.label, steps, ratios, dts])
    sides = " : ".join(f"{s:g}" for s, _ in scenarios)
    head = (f"### Table 1: {robots} robots on {sides} m squares, "
            f"{' : '.join(f'{p:g}' for p in paper)} s\n\n"
            f"The paper's ratios (2/1, 3/1, 3/2) are {paper[1] / paper[0]:.2f}, "
            f"{paper[2] / paper[0]:.2f}, {paper[2] / paper[1]:.2f}. With one spacing and "
            "one time step the ratios are fixed by the reading; the seconds per step each "
            "scenario implies would have to agree.\n\n")
    return head + _table(["spacing / nbrs", "reading", "E[tau] steps (1 : 2 : 3)",
                          "ratios 2/1, 3/1, 3/2", "implied s/step (1 / 2 / 3)"], rows)


#: One run as in Fig. 5a: run length [s], and the (spacing [m], seconds per step) tried
#: (4 neighbours).
RUN_SECONDS = 300.0
RUN_CASES = tuple((s, dt) for s in (0.25, 0.5, 1.0) for dt in (0.25, 0.5, 1.0))


def single_runs(runs: int, seed: int) -> list[dict[str, float | str]]:
    """The spread of one 300 s run's average inter-arrival time, as the paper measured it.

    For each of :data:`RUN_CASES` and each event, ``runs`` runs of 3 robots on 5 x 5 m
    from uniformly random nodes
    (:func:`~phd_swarm.core.analysis.renewal_simulation.window_averages`, generator
    ``default_rng([seed, case, event])``); the rows give Kac's mean and the run averages'
    median and 5-95 % range, in seconds.
    """
    robots, side, _ = FIG5
    rows: list[dict[str, float | str]] = []
    for c, (spacing, dt) in enumerate(RUN_CASES):
        g = square(side, spacing, 4)
        steps = int(round(RUN_SECONDS / dt))
        for e, event in enumerate(renewal.EVENTS):
            rng = np.random.default_rng([seed, c, e])
            avg = window_averages(g, rng, robots, steps, runs, event) * dt
            avg = avg[np.isfinite(avg)]
            lo, med, hi = np.percentile(avg, [5, 50, 95])
            rows.append({"spacing": spacing, "dt": dt, "event": event,
                         "kac": renewal.mean_interarrival(g, robots, event) * dt,
                         "median": float(med), "p05": float(lo), "p95": float(hi),
                         "runs_with_interval": float(avg.size / runs)})
    return rows


def render_single_runs(rows: Sequence[dict[str, float | str]]) -> str:
    """Markdown table of :func:`single_runs`."""
    robots, side, seconds = FIG5
    body = [[f"{r['spacing']:g} m / {r['dt']:g} s", str(r["event"]), f"{r['kac']:.3g}",
             f"{r['median']:.3g}", f"{r['p05']:.3g} - {r['p95']:.3g}"] for r in rows]
    head = (f"### One {RUN_SECONDS:g} s run, as in Fig. 5a ({robots} robots, {side:g} x "
            f"{side:g} m, 4 neighbours, uniform start)\n\nThe run's average of its "
            "inter-arrival times (the first from time 0, the one open at the end dropped, "
            "pooled over the run's pairs / robots / team), in seconds, against Kac's mean; "
            f"the paper's one run gave {seconds:g} s.\n\n")
    return head + _table(["spacing / s per step", "event", "Kac mean [s]",
                          "run average: median [s]", "5 - 95 % [s]"], body)


@dataclass(frozen=True)
class SimPoint:
    """One simulated point of the plot: robots, side [m], mean and CI half-width [steps]."""

    robots: int
    side: float
    mean: float
    half_width: float
    exact: float


def simulate_points(robot_counts: Sequence[int], sides: Sequence[float], runs: int,
                    gaps: float, seed: int) -> list[SimPoint]:
    """Seeded simulations of the robot-any Kac mean at 1 m spacing, 4 neighbours.

    Each point walks ``runs`` teams from stationarity for about ``gaps`` expected gaps per
    robot (at least 1,000 and at most 60,000 steps), with its own generator
    ``default_rng([seed, robots, side])``.
    """
    out = []
    for n in robot_counts:
        for side in sides:
            g = square(side, 1.0, 4)
            exact = renewal.mean_interarrival(g, n, "robot")
            steps = int(min(60_000, max(1_000, gaps * exact)))
            rng = np.random.default_rng([seed, n, int(side)])
            sim = simulate_meetings(g, rng, n, steps, runs, "robot", "stationary")
            mean, half = sim.interarrival()
            out.append(SimPoint(n, float(side), mean, half, exact))
    return out


def save_plot(path: Path, robot_counts: Sequence[int], points: Sequence[SimPoint]) -> Path:
    """Mean inter-arrival time [steps] against the map's side (module docstring)."""
    sides = np.arange(5, 41)
    fig = plots.new_figure((7.5, 4.8))
    ax = fig.subplots()
    colours = (plots.ROBOT_COLOUR, plots.ESTIMATE_COLOUR, plots.TRUTH_COLOUR,
               plots.COMPONENT_COLOUR)
    for n, colour in zip(robot_counts, colours, strict=False):
        exact = [renewal.mean_interarrival(square(s, 1.0, 4), n, "robot") for s in sides]
        ax.plot(sides, exact, color=colour, lw=1.4, label=f"{n} robots, robot with any other")
        pts = [p for p in points if p.robots == n]
        if pts:
            ax.errorbar([p.side for p in pts], [p.mean for p in pts],
                        yerr=[p.half_width for p in pts], fmt="o", ms=4, color=colour,
                        capsize=3, lw=1.0)
    pair = [renewal.mean_interarrival(square(s, 1.0, 4), 2, "pair") for s in sides]
    ax.plot(sides, pair, "--", color="0.4", lw=1.0, label="a given pair (any N)")
    ax.plot([], [], "o", color="0.3", ms=4, label="simulation, 95 % CI")
    ax.set_yscale("log")
    ax.set_xlabel("side of the square map [m] (1 m grid spacing, 4 neighbours)")
    ax.set_ylabel("mean inter-arrival time [steps]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper left")
    fig.suptitle("Shirsat & Berman: mean time between meetings (Kac, exact) vs map size",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return path


def render_points(points: Sequence[SimPoint]) -> str:
    """Markdown table of the simulated points against the exact values."""
    rows = [[str(p.robots), f"{p.side:g}", f"{p.exact:.4g}", f"{p.mean:.4g}",
             f"± {p.half_width:.3g}",
             "yes" if abs(p.mean - p.exact) <= p.half_width else "no"] for p in points]
    return ("### Simulation check (robot with any other, 1 m, 4 neighbours, from "
            "stationarity)\n\n" + _table(["robots", "side [m]", "exact [steps]",
                                           "simulated", "95 % CI", "exact inside"], rows))


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """The command line (module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("results/renewal"),
                   help="output directory (default results/renewal/)")
    p.add_argument("--quick", action="store_true",
                   help="small first-meeting chains only, short simulations")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulations")
    return p.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Compute, print and write the tables and the plot."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    t0 = time.perf_counter()
    limit = QUICK_MAX_STATES if args.quick else MAX_STATES
    fig5 = fig5_numbers(limit)
    table1 = table1_numbers(limit)
    robot_counts = (3, 10, 20)
    if args.quick:
        points = simulate_points(robot_counts, (5.0, 10.0), runs=32, gaps=40, seed=args.seed)
        runs = single_runs(100, args.seed)
    else:
        points = simulate_points(robot_counts, (5.0, 10.0, 20.0, 40.0), runs=48, gaps=40,
                                 seed=args.seed)
        runs = single_runs(1000, args.seed)
    args.out.mkdir(parents=True, exist_ok=True)
    text = "\n\n".join([
        "## Shirsat & Berman: exact mean inter-arrival times "
        "(python -m phd_swarm.tools.renewal" + (" --quick" if args.quick else "") + ")",
        render_fig5(fig5), render_single_runs(runs), render_table1(table1),
        render_points(points)]) + "\n"
    (args.out / "renewal.md").write_text(text)
    (args.out / "renewal.json").write_text(json.dumps(
        {"fig5": fig5, "table1": table1, "single_runs": runs,
         "simulation": [p.__dict__ for p in points], "quick": args.quick,
         "seed": args.seed}, indent=1, default=lambda x: None if x is None else float(x)))
    save_plot(args.out / "renewal.png", robot_counts, points)
    print(text)
    print(f"wrote {args.out / 'renewal.md'}, renewal.json and renewal.png "
          f"in {time.perf_counter() - t0:.1f} s")
    return 0


__all__ = ["FIG5", "GEOMETRIES", "READINGS", "TABLE1", "Reading", "main", "render_fig5",
           "render_table1", "save_plot", "simulate_points", "square"]

if __name__ == "__main__":
    sys.exit(main())
