"""Offline evaluation of a recorded run: OSPA and cardinality over time, from the log alone.

``scripts/evaluate.sh LOG [options]`` (``python -m phd_swarm.tools.evaluate``) reads a run's
MCAP log (:mod:`phd_swarm.tools.run_log`) and scores every step against the recorded truth
with the live monitor's own functions, on the monitor's inputs:

- a grid-PHD system (Dames, Chen): the team PHD rebuilt from the robots' density windows,
  scored by :func:`phd_swarm.core.scoring.score_step` (the team estimate, Dames Sec. IV;
  the expected number of targets, Dames eq. 2; OSPA, Dames eq. 12);
- any other system (Sung & Tokekar's GM-PHD): the union of the robots' own estimates with
  the sum of their expected counts, scored by
  :func:`phd_swarm.core.scoring.score_estimates`, and the estimator part's own per-step
  figures (its ``figures`` hook, e.g. :mod:`phd_swarm.core.estimators.sung.figures`) from
  the robots' components and tracks.

Where the monitor's metrics are in the log too, it reports how far the two OSPA series are
apart (0 for a run the monitor saw completely: same inputs, same arithmetic).

Writes into ``--out`` (default: ``evaluation/`` next to the log):

- ``evaluation.json``: the summary (the ``summary.json`` fields of the figures, plus the
  agreement with the monitor, whether the log was truncated, and its completeness: per
  step topic the expected, recorded and missing steps, :mod:`phd_swarm.tools.log_check`;
  ``absences``: the spans of steps in which a robot was out of the team, and when it
  rejoined, also printed);
  for a non-grid system also ``figures``, the mean over steps of each of the estimator's
  figures (NaN steps left out, None if none has a value: the monitor's
  :func:`~phd_swarm.nodes.monitor.figure_means`);
- ``series.csv``: one row per step (:data:`COLUMNS`: t, OSPA and its parts, cardinalities,
  ``windows`` (the robots that reported: density windows, or estimates with their
  components and tracks) and the monitor's OSPA; then the estimator's figures, in the
  order its hook gives them);
- ``ospa.png``: OSPA and cardinality over time;
- ``figures.png`` (non-grid systems with figures): the estimator's figures over time
  (components and tracks, their weights, Mahalanobis distances, the largest variance);
- ``snapshot_<t>s.png`` for each ``--snapshot T`` (default: the last step): for a grid PHD
  the team PHD, with Chen's cumulative density beside it when the controller steers by it
  (``chen_o``, which requires ``cumulative``; or with
  ``--cumulative``); otherwise the robots' paths so far and their components' 2-sigma
  ellipses;
- ``--animate FILE.gif`` (or ``.mp4`` with ffmpeg): snapshots every ``--every`` steps.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from phd_swarm.core.scoring import StepScore, score_estimates, score_step, series_summary
from phd_swarm.logs.mcap_log import LogError
from phd_swarm.nodes.monitor import figure_means
from phd_swarm.tools.log_check import WARNING, check_log
from phd_swarm.tools.plots import (
    Frame,
    figure_panels,
    save_animation,
    save_figures,
    save_series,
    save_snapshot,
)
from phd_swarm.tools.run_log import RunLog, load_run

#: Columns of series.csv.
COLUMNS = ("step", "t", "ospa", "ospa_localisation", "ospa_cardinality", "cardinality_true",
           "cardinality_est", "expected_cardinality", "robots_alive", "windows",
           "monitor_ospa")


@dataclass
class Kept:
    """What the picture of a kept step needs beyond the log's :class:`StepRecord`.

    Attributes
    ----------
    estimates : np.ndarray, shape (K, 2)
        The team estimate.
    image : np.ndarray (ny, nx) or None
        The team PHD (grid systems).
    views : list
        The robots' components and tracks (non-grid systems).
    """

    estimates: np.ndarray
    image: np.ndarray | None = None
    views: list[Any] = field(default_factory=list)


def evaluate(run: RunLog, keep: set[int] | None = None
             ) -> tuple[list[dict[str, Any]], dict[int, Kept]]:
    """Score every step of ``run``, as the live monitor scores it.

    Returns
    -------
    rows : list of dict
        Per step: :data:`COLUMNS`, then the estimator's figures (non-grid systems, on the
        steps its hook was given every reporting robot's components and tracks).
    kept : dict of int to Kept
        The team estimate (and PHD image or components and tracks) of the steps in
        ``keep`` (for pictures).
    """
    score = _score_grid if run.grid_phd else _score_estimates
    rows, kept = score(run, keep or set())
    rows.sort(key=lambda r: r["step"])
    return rows, kept


def _row(run: RunLog, k: int, score: StepScore, windows: int) -> dict[str, Any]:
    rec = run.steps[k]
    mon = rec.monitor["ospa"] if rec.monitor else math.nan
    return {"step": k, "t": k * run.scenario.dt, **score.row(), "robots_alive": len(rec.alive),
            "windows": windows, "monitor_ospa": mon}


def _cut_short(run: RunLog, k: int, windows: int) -> bool:
    """Whether the log ends inside step k (a truncated log with too few windows)."""
    return run.truncated and windows < len(run.expected_windows(k))


def _score_grid(run: RunLog, keep: set[int]) -> tuple[list[dict[str, Any]], dict[int, Kept]]:
    """The team PHD of every step, scored by :func:`score_step`."""
    s = run.scenario
    rows: list[dict[str, Any]] = []
    kept: dict[int, Kept] = {}
    for k, image, windows in run.team_images():
        if _cut_short(run, k, windows):
            continue
        score = score_step(s.grid, image, run.steps[k].truth, s.extraction, s.ospa_c,
                           s.ospa_p)
        rows.append(_row(run, k, score, windows))
        if k in keep:
            kept[k] = Kept(score.estimates, image=image)
    return rows, kept


def _score_estimates(run: RunLog, keep: set[int]
                     ) -> tuple[list[dict[str, Any]], dict[int, Kept]]:
    """The robots' own estimates of every step, scored by :func:`score_estimates`.

    As the monitor's ``_score_estimates``: the union of the estimates in robot-id order
    with the sum of the expected counts; the figures hook given every robot's view.
    """
    s = run.scenario
    hook = run.reader.figures
    rows: list[dict[str, Any]] = []
    kept: dict[int, Kept] = {}
    for k, estimates, expected, views, reporters in run.team_estimates():
        if _cut_short(run, k, len(reporters)):
            continue
        truth = run.steps[k].truth
        score = score_estimates(estimates, expected, truth, s.ospa_c, s.ospa_p)
        figures = hook(views, truth, s.ospa_c, s.ospa_p) if hook is not None and views else {}
        rows.append({**_row(run, k, score, len(reporters)), **figures})
        if k in keep:
            kept[k] = Kept(score.estimates, views=views)
    return rows, kept


def figure_names(rows: list[dict[str, Any]]) -> list[str]:
    """The estimator's figures in the rows, in its hook's order (none for a grid system)."""
    for r in rows:
        names = [c for c in r if c not in COLUMNS]
        if names:
            return names
    return []


def agreement(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """How far the evaluation's OSPA is from the monitor's, over the steps both have."""
    both = [r for r in rows if not math.isnan(r["monitor_ospa"])]
    diff = [abs(r["ospa"] - r["monitor_ospa"]) for r in both]
    return {"steps_compared": len(both),
            "max_abs_ospa_difference": max(diff) if diff else None,
            "steps_only_in_evaluation": len(rows) - len(both)}


def frame(run: RunLog, k: int, kept: Kept, cumulative: np.ndarray | None,
          paths: dict[int, tuple[np.ndarray, np.ndarray]] | None = None) -> Frame:
    """The snapshot of step ``k``.

    A grid system's shows the team PHD; any other's the robots' ``paths`` up to k
    (:meth:`RunLog.paths`) and the components of their mixtures.
    """
    s = run.scenario
    rec = run.steps[k]
    env = s.env
    title = (f"{s.name}: {s.robots} robots, controller {run.controller}, seed {s.seed} - "
             f"t = {k * s.dt:.1f} s, {len(rec.truth)} targets, {len(kept.estimates)} "
             "estimates")
    f = Frame(t=k * s.dt, step=k, extent=(env.xmin, env.ymin, env.xmax, env.ymax),
              phd=kept.image, robots=rec.robots, alive=set(rec.alive),
              fov_radius=s.models.detection.radius, cells=rec.cells, goals=rec.goals,
              truth=rec.truth, estimates=kept.estimates, cumulative=cumulative, title=title)
    if kept.views:
        f.component_means = np.concatenate([v.mixture.means[:, :2] for v in kept.views])
        f.component_covs = np.concatenate([v.mixture.covs[:, :2, :2] for v in kept.views])
        f.component_weights = np.concatenate([v.mixture.weights for v in kept.views])
    if paths:
        f.paths = {rid: pos[: np.searchsorted(steps, k, side="right")]
                   for rid, (steps, pos) in paths.items()}
    return f


def _step_at(run: RunLog, t: float, where: str) -> int:
    steps = sorted(run.steps)
    k = int(round(t / run.scenario.dt))
    if t < 0 or k > steps[-1]:
        raise ValueError(f"{where}: time {t} s is outside the log (0 .. "
                         f"{steps[-1] * run.scenario.dt} s)")
    return min(steps, key=lambda s: abs(s - k))


def write_csv(rows: list[dict[str, Any]], path: Path, figures: list[str] | None = None
              ) -> None:
    """Write the per-step rows as CSV: :data:`COLUMNS`, then ``figures`` (NaN if absent)."""
    columns = [*COLUMNS, *(figures or ())]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        w.writerows({c: r.get(c, math.nan) for c in columns} for r in rows)


def missing_inputs(run: RunLog) -> str:
    """What a step of ``run`` is scored from, for the message of a log with none of it."""
    if run.grid_phd:
        return "density windows"
    kinds = run.step_inputs
    names = kinds[0] if len(kinds) == 1 else f"{', '.join(kinds[:-1])} and {kinds[-1]}"
    return (f"the robots' {names} (a robot's step needs every one of "
            + ", ".join(f"/robot_<i>/{k}" for k in kinds) + ")")


def describe_absences(absences: list[dict[str, int | None]]) -> str:
    """``robot 2 steps 63-222 (rejoined at 223); robot 3 steps 64-299 (never rejoined)``.

    ``absences``: :meth:`~phd_swarm.tools.run_log.RunLog.absences`.
    """
    return "; ".join(f"robot {a['robot']} steps {a['first']}-{a['last']} "
                     + (f"(rejoined at {a['rejoined']})" if a["rejoined"] is not None
                        else "(never rejoined)") for a in absences)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="evaluate.sh", description="Recompute OSPA and cardinality of a recorded run "
        "from its MCAP log, and draw it.")
    p.add_argument("log", help="the run's MCAP file (runs/<name>/run.mcap), or its directory")
    p.add_argument("--config", help="the run's config file, for logs recorded without one")
    p.add_argument("--out", help="output directory (default: evaluation/ next to the log)")
    p.add_argument("--snapshot", type=float, action="append", metavar="T",
                   help="draw the step at time T [s] (repeatable; default: the last step)")
    p.add_argument("--animate", metavar="FILE", help="write an animation (.gif, or .mp4 "
                   "with ffmpeg)")
    p.add_argument("--every", type=int, default=10, metavar="N",
                   help="animation: one frame every N steps (default 10)")
    p.add_argument("--fps", type=float, default=5.0, help="animation frame rate (default 5)")
    p.add_argument("--cumulative", action="store_true",
                   help="show Chen's cumulative density beside the PHD (default: when the "
                   "controller steers by it, Chen's O)")
    p.add_argument("--no-plots", action="store_true", help="only evaluation.json and CSV")
    p.add_argument("--quiet", action="store_true", help="no summary on stdout")
    return p


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point (see the module docstring); returns the exit code."""
    args = _parser().parse_args(argv)
    prog = "evaluate.sh"
    if args.every < 1 or args.fps <= 0:
        print(f"{prog}: --every must be >= 1 and --fps > 0", file=sys.stderr)
        return 2
    start = time.monotonic()
    if Path(args.log).is_dir():
        args.log = str(Path(args.log) / "run.mcap")
    try:
        run = load_run(args.log, args.config)
        s = run.scenario
        last = max(run.steps)
        snaps = [] if args.no_plots else sorted(
            {_step_at(run, t, "--snapshot") for t in (args.snapshot or [last * s.dt])})
        anim = ([k for k in sorted(run.steps) if k % args.every == 0 or k == last]
                if args.animate and not args.no_plots else [])
        rows, kept = evaluate(run, set(snaps) | set(anim))
        report = check_log(args.log, run.config)
    except (LogError, ValueError) as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 1
    if not rows:
        print(f"{prog}: {args.log}: no step with {missing_inputs(run)} in the log",
              file=sys.stderr)
        return 1
    out = Path(args.out) if args.out else Path(args.log).resolve().parent / "evaluation"
    out.mkdir(parents=True, exist_ok=True)
    summary = {"log": str(Path(args.log).resolve()), "truncated": run.truncated,
               "scenario": s.name, "seed": s.seed, "robots": s.robots,
               "controller": run.controller, "steps": len(rows),
               "sim_duration_s": len(rows) * s.dt, **series_summary(rows),
               "ospa_c": s.ospa_c, "ospa_p": s.ospa_p,
               "monitor_agreement": agreement(rows),
               "log_completeness": report.to_dict(),
               "absences": run.absences()}
    names = figure_names(rows)
    if run.reader.figures is not None:
        summary["figures"] = figure_means(rows, names)
    if not report.complete:
        print(f"{prog}: {WARNING}: {report.describe()}", file=sys.stderr)
    write_csv(rows, out / "series.csv", names)
    written = [out / "evaluation.json", out / "series.csv"]
    if not args.no_plots:
        monitor = [{"t": r["t"], "ospa": r["monitor_ospa"]} for r in rows
                   if not math.isnan(r["monitor_ospa"])]
        title = f"{s.name}: {s.robots} robots, controller {run.controller}, seed {s.seed}"
        written.append(save_series(rows, out / "ospa.png", title=title, reference=monitor))
        if figure_panels(names):
            written.append(save_figures(rows, out / "figures.png", title=title))
        # A controller that steers by the cumulative density (Chen's O) shows it by default.
        show_cum = args.cumulative or "cumulative" in s.system.parts()["controller"].requires
        cum = run.map_layer_images(set(snaps) | set(anim)) if show_cum else {}
        paths = None if run.grid_phd else run.paths()
        for k in snaps:
            if k in kept:
                written.append(save_snapshot(frame(run, k, kept[k], cum.get(k), paths),
                                             out / f"snapshot_{k * s.dt:g}s.png"))
        if anim:
            try:
                frames = [frame(run, k, kept[k], cum.get(k), paths) for k in anim
                          if k in kept]
                written.append(save_animation(frames, args.animate, fps=args.fps))
            except ValueError as exc:
                print(f"{prog}: {exc}", file=sys.stderr)
                return 1
    summary["wall_s"] = time.monotonic() - start
    (out / "evaluation.json").write_text(json.dumps(summary, indent=2) + "\n")
    if not args.quiet:
        agree = summary["monitor_agreement"]
        print(f"{s.name}: {len(rows)} steps, final OSPA {summary['ospa_final']:.3f} m, mean "
              f"over the second half {summary['ospa_mean_last_half']:.3f} m, targets "
              f"{summary['cardinality_est_final']} estimated / "
              f"{summary['cardinality_true_final']} true")
        print(f"log: {report.describe()}")
        if summary["absences"]:
            print("out of the team: " + describe_absences(summary["absences"]))
        if agree["steps_compared"]:
            print(f"live monitor: {agree['steps_compared']} steps compared, largest OSPA "
                  f"difference {agree['max_abs_ospa_difference']:.3g} m")
        for path in written:
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
