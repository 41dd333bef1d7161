"""Loss study: the distributed filter over lossy links, against the loss-free run.

``python -m phd_swarm.tools.loss_study [--steps N] [--robots R] [--seeds S] [--out DIR]
[--scenarios NAME ...] [--drops P ...] [--delay P] [--max-delay-rounds D]
[--timeout-ticks T]``

Runs :class:`phd_swarm.engines.distributed.DistributedEngine` (the robots' protocol, message
by message) on ``dames_static`` (and ``dames_moving`` if asked) with every envelope going through a
:class:`~phd_swarm.core.exchange.faults.FaultyLink`: drop rates 0, 1, 2, 5 and 10 % by
default, and a delay-only condition (5 % of the messages late by 1 or 2 rounds). Each
condition runs the same seeds (scenario seed s, link seed s); the loss-free run of a seed is
its reference. Per condition it reports:

- ``ospa_mean_last_half``: the mean OSPA over the second half of the steps, scored as the
  sweeps score a trial (:func:`phd_swarm.core.scoring.score_step`: the truth before the
  step against the team PHD after it);
- ``l1_mean`` and ``l1_max``: the relative L1 distance of the team PHD to the loss-free
  run's at the same step, ``sum |w - w0| / sum w0``, mean and max over the steps;
- ``false_deaths``: live robots declared dead by a peer (on timeouts or disagreeing contact
  sets; every robot is alive in this study), and ``timeouts``;
- ``resent``: messages re-sent in answer to keep-alives, ``dropped`` and ``delayed``:
  envelopes the links dropped and delayed, ``messages``: envelopes delivered.

Outputs in ``--out`` (default ``runs/loss_study``): ``trials.csv`` (one row per scenario,
condition and seed), ``summary.csv`` and ``summary.md`` (the mean over the seeds; the max
of ``l1_max``) and ``loss.png``. The markdown table is also printed.
"""

from __future__ import annotations

import argparse
import csv
import logging
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from phd_swarm.core.exchange.faults import LinkFaults
from phd_swarm.core.exchange.voronoi_phd.context import TIMEOUT_TICKS
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim import presets as sc
from phd_swarm.sim.scenario import Scenario

#: Scenario presets the study can run.
SCENARIOS: dict[str, Callable[..., Scenario]] = {"dames_static": sc.dames_static,
                                                   "dames_moving": sc.dames_moving}
#: Default drop rates.
DROPS = (0.0, 0.01, 0.02, 0.05, 0.10)
#: Per-trial columns of trials.csv.
TRIAL_COLUMNS = ("scenario", "condition", "drop", "delay", "max_delay_rounds", "seed",
                 "robots", "steps", "ospa_mean_last_half", "l1_mean", "l1_max",
                 "false_deaths", "timeouts", "revived_peers", "resent", "dropped", "delayed",
                 "messages", "orphan_bins", "wall_s")
#: Columns of summary.csv: the trial columns averaged over the seeds.
SUMMARY_COLUMNS = ("scenario", "condition", "drop", "delay", "max_delay_rounds", "trials",
                   "robots", "steps", "ospa_mean_last_half", "l1_mean", "l1_max",
                   "false_deaths", "timeouts", "revived_peers", "resent", "dropped",
                   "delayed", "messages", "orphan_bins", "wall_s")


@dataclass(frozen=True)
class Condition:
    """One link condition of the study.

    Attributes
    ----------
    drop, delay : float
        Drop probability, and probability that a message not dropped is late.
    max_delay_rounds : int
        Late messages are 1 to this many rounds late.
    """

    drop: float = 0.0
    delay: float = 0.0
    max_delay_rounds: int = 1

    @property
    def label(self) -> str:
        """A short name: ``loss-free``, ``drop 5%``, ``delay 5% (<=2)``."""
        if self.drop == 0.0 and self.delay == 0.0:
            return "loss-free"
        parts = []
        if self.drop:
            parts.append(f"drop {100 * self.drop:g}%")
        if self.delay:
            parts.append(f"delay {100 * self.delay:g}% (<={self.max_delay_rounds})")
        return ", ".join(parts)

    def faults(self, seed: int) -> LinkFaults | None:
        """The engine's faults for link seed ``seed`` (None when loss-free)."""
        if self.drop == 0.0 and self.delay == 0.0:
            return None
        return LinkFaults(self.drop, self.delay, self.max_delay_rounds, seed)


def conditions(drops: Sequence[float] = DROPS, delay: float = 0.05,
               max_delay_rounds: int = 2) -> list[Condition]:
    """The loss-free condition, one per non-zero drop rate, and a delay-only one."""
    out = [Condition()]
    out += [Condition(drop=float(d)) for d in drops if d > 0]
    if delay > 0:
        out.append(Condition(delay=float(delay), max_delay_rounds=max_delay_rounds))
    return out


def make_scenario(name: str, robots: int, steps: int, seed: int) -> Scenario:
    """Preset ``name`` with ``robots`` robots, ``steps`` steps and seed ``seed``."""
    preset = SCENARIOS[name](robots=robots)
    return preset.with_overrides(seed=seed, duration=steps * preset.dt)


def run_trial(scenario: Scenario, faults: LinkFaults | None, timeout_ticks: int,
              reference: list[np.ndarray] | None) -> tuple[dict[str, Any], list[np.ndarray]]:
    """Run one trial and score it.

    Parameters
    ----------
    scenario : Scenario
        The trial's scenario (seed included).
    faults : LinkFaults or None
        The links' faults.
    timeout_ticks : int
        The robots' timeout [rounds].
    reference : list of np.ndarray, optional
        The loss-free team PHD (ny, nx) after each step; None for the loss-free run itself.

    Returns
    -------
    row : dict
        The figures of :data:`TRIAL_COLUMNS` that depend on the run.
    images : list of np.ndarray
        The team PHD after each step.
    """
    from phd_swarm.core.scoring import score_step

    wall0 = time.perf_counter()
    engine = DistributedEngine(scenario, "phd", timeout_ticks=timeout_ticks, faults=faults)
    ospa = np.zeros(scenario.steps)
    l1 = np.zeros(scenario.steps)
    images = []
    for k in range(scenario.steps):
        _, truth = engine.world.truth()
        engine.step()
        image = engine.team_weights()
        images.append(image)
        ospa[k] = score_step(scenario.grid, image, truth, scenario.extraction,
                             scenario.ospa_c, scenario.ospa_p).ospa
        if reference is not None:
            w0 = reference[k]
            l1[k] = float(np.abs(image - w0).sum() / w0.sum())
    stats = engine.counters()
    row = {"ospa_mean_last_half": float(ospa[scenario.steps // 2:].mean()),
           "l1_mean": float(l1.mean()), "l1_max": float(l1.max()),
           "false_deaths": stats.get("declared_dead", 0) + stats.get("strangers", 0),
           "timeouts": stats.get("timeouts", 0),
           "revived_peers": stats.get("revived_peers", 0), "resent": stats.get("resent", 0),
           "dropped": sum(t.dropped for t in engine.traffic),
           "delayed": sum(t.delayed for t in engine.traffic),
           "messages": sum(sum(c.values()) for t in engine.traffic
                           for c in t.messages.values()),
           "orphan_bins": stats.get("orphan_bins", 0),
           "wall_s": time.perf_counter() - wall0}
    return row, images



def run_study(scenarios: Sequence[str], robots: int, steps: int, seeds: int,
              conds: Sequence[Condition], timeout_ticks: int = TIMEOUT_TICKS,
              progress: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """Every scenario x seed x condition; the loss-free run of each seed first.

    Returns
    -------
    list of dict
        One row per trial (:data:`TRIAL_COLUMNS`).
    """
    rows = []
    ordered = sorted(conds, key=lambda c: c.faults(0) is not None)
    for name in scenarios:
        for seed in range(seeds):
            scenario = make_scenario(name, robots, steps, seed)
            reference = None
            for cond in ordered:
                row, images = run_trial(scenario, cond.faults(seed), timeout_ticks, reference)
                if reference is None:
                    reference = images
                rows.append({"scenario": name, "condition": cond.label, "drop": cond.drop,
                             "delay": cond.delay, "max_delay_rounds": cond.max_delay_rounds,
                             "seed": seed, "robots": robots, "steps": steps, **row})
                if progress is not None:
                    progress(f"{name} seed {seed} {cond.label}: OSPA "
                             f"{row['ospa_mean_last_half']:.3f} m, L1 {row['l1_mean']:.2e}, "
                             f"false deaths {row['false_deaths']}, {row['wall_s']:.1f} s")
    return rows


def summarise(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per scenario and condition, in first-seen order: the mean over the seeds.

    ``l1_max`` is the max over the seeds; ``trials`` counts them.
    """
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["scenario"], row["condition"]), []).append(row)
    out = []
    for (name, label), group in groups.items():
        first = group[0]
        summary = {"scenario": name, "condition": label, "drop": first["drop"],
                   "delay": first["delay"], "max_delay_rounds": first["max_delay_rounds"],
                   "trials": len(group), "robots": first["robots"], "steps": first["steps"]}
        for col in SUMMARY_COLUMNS[8:]:
            values = np.array([r[col] for r in group], dtype=float)
            summary[col] = float(values.max() if col == "l1_max" else values.mean())
        out.append(summary)
    return out


def markdown(summary: Sequence[dict[str, Any]]) -> str:
    """The summary as a markdown table."""
    head = ("| scenario | condition | mean OSPA, last half [m] | L1 to loss-free, mean | "
            "L1 max | false deaths | timeouts | re-sent | dropped | delayed | messages |")
    lines = [head, "|" + "---|" * head.count(" | ") + "---|"]
    for s in summary:
        lines.append(
            f"| {s['scenario']} | {s['condition']} | {s['ospa_mean_last_half']:.3f} | "
            f"{s['l1_mean']:.2e} | {s['l1_max']:.2e} | {s['false_deaths']:.1f} | "
            f"{s['timeouts']:.1f} | {s['resent']:.0f} | {s['dropped']:.0f} | "
            f"{s['delayed']:.0f} | {s['messages']:.0f} |")
    return "\n".join(lines) + "\n"


def write_csv(path: Path, rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> None:
    """Write ``rows`` with ``columns`` to ``path``."""
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def plot(summary: Sequence[dict[str, Any]], path: Path) -> None:
    """OSPA, L1 distance to the loss-free run, false deaths and traffic against the drop rate.

    One line per scenario over the drop-only conditions; the delay-only condition is a
    separate marker at drop 0.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(15, 3.8))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 4)
    panels = (("ospa_mean_last_half", "mean OSPA, last half [m]"),
              ("l1_mean", "relative L1 to loss-free (mean over steps)"),
              ("false_deaths", "live robots declared dead (per run)"),
              ("traffic", "messages delivered / loss-free"))
    colours = ("#0072B2", "#D55E00", "#009E73")
    names = list(dict.fromkeys(s["scenario"] for s in summary))
    free = {s["scenario"]: s["messages"] for s in summary
            if s["drop"] == 0 and s["delay"] == 0}
    rows = [{**s, "traffic": s["messages"] / free.get(s["scenario"], np.nan)}
            for s in summary]
    for ax, (col, title) in zip(axes, panels, strict=True):
        for name, colour in zip(names, colours, strict=False):
            drop = [s for s in rows if s["scenario"] == name and s["delay"] == 0]
            delay = [s for s in rows if s["scenario"] == name and s["delay"] > 0]
            ax.plot([100 * s["drop"] for s in drop], [s[col] for s in drop], "o-",
                    color=colour, label=f"{name}, drop")
            if delay:
                ax.plot([100 * s["drop"] for s in delay], [s[col] for s in delay], "s",
                        color=colour, mfc="none", ms=9, label=f"{name}, {delay[0]['condition']}")
        ax.set_xlabel("messages dropped [%]")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; see the module docstring."""
    parser = argparse.ArgumentParser(prog="python -m phd_swarm.tools.loss_study",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=100, help="steps per trial")
    parser.add_argument("--robots", type=int, default=10, help="team size")
    parser.add_argument("--seeds", type=int, default=3, help="seeds 0..S-1 per condition")
    parser.add_argument("--out", type=Path, default=Path("runs/loss_study"),
                        help="output directory")
    parser.add_argument("--scenarios", nargs="+", default=["dames_static"],
                        choices=sorted(SCENARIOS), help="scenario presets")
    parser.add_argument("--drops", nargs="+", type=float, default=list(DROPS),
                        help="drop rates (0 is always run: the reference)")
    parser.add_argument("--delay", type=float, default=0.05,
                        help="delay-only condition's late fraction (0: none)")
    parser.add_argument("--max-delay-rounds", type=int, default=2,
                        help="late messages are 1..D rounds late")
    parser.add_argument("--timeout-ticks", type=int, default=3,
                        help="rounds without progress before a silent peer is dead")
    args = parser.parse_args(argv)
    if args.steps < 2 or args.robots < 1 or args.seeds < 1:
        parser.error("--steps must be >= 2, --robots and --seeds >= 1")
    try:
        conds = conditions(args.drops, args.delay, args.max_delay_rounds)
        for cond in conds:
            cond.faults(0)
    except ValueError as exc:
        parser.error(str(exc))
    # The protocol's warnings (timeouts, orphans) are counted in the results.
    logging.getLogger("phd_swarm.protocol").setLevel(logging.ERROR)
    rows = run_study(args.scenarios, args.robots, args.steps, args.seeds, conds,
                     args.timeout_ticks, progress=lambda m: print(m, file=sys.stderr))
    summary = summarise(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(args.out / "trials.csv", rows, TRIAL_COLUMNS)
    write_csv(args.out / "summary.csv", summary, SUMMARY_COLUMNS)
    table = markdown(summary)
    (args.out / "summary.md").write_text(table)
    plot(summary, args.out / "loss.png")
    print(table)
    print(f"wrote {args.out}/trials.csv, summary.csv, summary.md, loss.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
