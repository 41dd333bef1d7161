"""Offline evaluation of a recorded run: OSPA and cardinality over time, from the log alone.

``scripts/evaluate.sh LOG [options]`` (``python -m phd_swarm.tools.evaluate``) reads a run's
MCAP log (:mod:`phd_swarm.tools.run_log`), rebuilds the team PHD of every step from the
robots' density windows, and scores it against the recorded truth with the live monitor's
own function (:func:`phd_swarm.core.scoring.score_step`: the team estimate, Dames Sec. IV;
the expected number of targets, Dames eq. 2; OSPA, Dames eq. 12). Where the monitor's
metrics are in the log too, it reports how far the two series are apart (0 for a run the
monitor saw completely: same windows, same arithmetic).

Writes into ``--out`` (default: ``evaluation/`` next to the log):

- ``evaluation.json``: the summary (the ``summary.json`` fields of the figures, plus the
  agreement with the monitor, whether the log was truncated, and its completeness: per
  step topic the expected, recorded and missing steps, :mod:`phd_swarm.tools.log_check`);
- ``series.csv``: one row per step (t, OSPA and its parts, cardinalities, windows, and the
  monitor's OSPA);
- ``ospa.png``: OSPA and cardinality over time;
- ``snapshot_<t>s.png`` for each ``--snapshot T`` (default: the last step), with Chen's
  cumulative density beside the PHD for ``chen_o`` runs (or with ``--cumulative``);
- ``--animate FILE.gif`` (or ``.mp4`` with ffmpeg): snapshots every ``--every`` steps.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from phd_swarm.core.scoring import score_step, series_summary
from phd_swarm.logs.mcap_log import LogError
from phd_swarm.tools.log_check import WARNING, check_log
from phd_swarm.tools.plots import Frame, save_animation, save_series, save_snapshot
from phd_swarm.tools.run_log import RunLog, load_run

#: Columns of series.csv.
COLUMNS = ("step", "t", "ospa", "ospa_localisation", "ospa_cardinality", "cardinality_true",
           "cardinality_est", "expected_cardinality", "robots_alive", "windows",
           "monitor_ospa")


def evaluate(run: RunLog, keep: set[int] | None = None
             ) -> tuple[list[dict[str, Any]], dict[int, tuple[np.ndarray, np.ndarray]]]:
    """Score every step of ``run``.

    Returns
    -------
    rows : list of dict
        Per step: :data:`COLUMNS`.
    kept : dict of int to (image, estimates)
        The team PHD image and estimates of the steps in ``keep`` (for pictures).
    """
    s = run.scenario
    keep = keep or set()
    rows: list[dict[str, Any]] = []
    kept: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for k, image, windows in run.team_images():
        rec = run.steps[k]
        if run.truncated and windows < len(run.expected_windows(k)):
            continue  # the log ends inside this step
        score = score_step(s.grid, image, rec.truth, s.extraction, s.ospa_c, s.ospa_p)
        mon = rec.monitor["ospa"] if rec.monitor else math.nan
        rows.append({"step": k, "t": k * s.dt, **score.row(), "robots_alive": len(rec.alive),
                     "windows": windows, "monitor_ospa": mon})
        if k in keep:
            kept[k] = (image, score.estimates)
    rows.sort(key=lambda r: r["step"])
    return rows, kept


def agreement(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """How far the evaluation's OSPA is from the monitor's, over the steps both have."""
    both = [r for r in rows if not math.isnan(r["monitor_ospa"])]
    diff = [abs(r["ospa"] - r["monitor_ospa"]) for r in both]
    return {"steps_compared": len(both),
            "max_abs_ospa_difference": max(diff) if diff else None,
            "steps_only_in_evaluation": len(rows) - len(both)}


def frame(run: RunLog, k: int, image: np.ndarray, estimates: np.ndarray,
          cumulative: np.ndarray | None) -> Frame:
    """The snapshot of step ``k``."""
    s = run.scenario
    rec = run.steps[k]
    env = s.env
    title = (f"{s.name}: {s.robots} robots, controller {run.controller}, seed {s.seed} - "
             f"t = {k * s.dt:.1f} s, {len(rec.truth)} targets, {len(estimates)} estimates")
    return Frame(t=k * s.dt, step=k, extent=(env.xmin, env.ymin, env.xmax, env.ymax),
                 phd=image, robots=rec.robots, alive=set(rec.alive),
                 fov_radius=s.models.detection.radius, cells=rec.cells, goals=rec.goals,
                 truth=rec.truth, estimates=estimates, cumulative=cumulative, title=title)


def _step_at(run: RunLog, t: float, where: str) -> int:
    steps = sorted(run.steps)
    k = int(round(t / run.scenario.dt))
    if t < 0 or k > steps[-1]:
        raise ValueError(f"{where}: time {t} s is outside the log (0 .. "
                         f"{steps[-1] * run.scenario.dt} s)")
    return min(steps, key=lambda s: abs(s - k))


def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    """Write the per-step rows as CSV."""
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows({c: r[c] for c in COLUMNS} for r in rows)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="evaluate.sh", description="Recompute OSPA and cardinality of a recorded run "
        "from its MCAP log, and draw it.")
    p.add_argument("log", help="the run's MCAP file (runs/<name>/run.mcap)")
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
                   help="show Chen's cumulative density beside the PHD (default: for chen_o)")
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
        print(f"{prog}: {args.log}: no step with density windows in the log", file=sys.stderr)
        return 1
    out = Path(args.out) if args.out else Path(args.log).resolve().parent / "evaluation"
    out.mkdir(parents=True, exist_ok=True)
    summary = {"log": str(Path(args.log).resolve()), "truncated": run.truncated,
               "scenario": s.name, "seed": s.seed, "robots": s.robots,
               "controller": run.controller, "steps": len(rows),
               "sim_duration_s": len(rows) * s.dt, **series_summary(rows),
               "ospa_c": s.ospa_c, "ospa_p": s.ospa_p,
               "monitor_agreement": agreement(rows),
               "log_completeness": report.to_dict()}
    if not report.complete:
        print(f"{prog}: {WARNING}: {report.describe()}", file=sys.stderr)
    write_csv(rows, out / "series.csv")
    written = [out / "evaluation.json", out / "series.csv"]
    if not args.no_plots:
        monitor = [{"t": r["t"], "ospa": r["monitor_ospa"]} for r in rows
                   if not math.isnan(r["monitor_ospa"])]
        written.append(save_series(rows, out / "ospa.png", title=(
            f"{s.name}: {s.robots} robots, controller {run.controller}, seed {s.seed}"),
            reference=monitor))
        show_cum = args.cumulative or run.controller == "chen_o"
        cum = run.cumulative_images(set(snaps) | set(anim)) if show_cum else {}
        for k in snaps:
            if k in kept:
                image, est = kept[k]
                written.append(save_snapshot(frame(run, k, image, est, cum.get(k)),
                                             out / f"snapshot_{k * s.dt:g}s.png"))
        if anim:
            try:
                frames = [frame(run, k, *kept[k], cum.get(k)) for k in anim if k in kept]
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
        if agree["steps_compared"]:
            print(f"live monitor: {agree['steps_compared']} steps compared, largest OSPA "
                  f"difference {agree['max_abs_ospa_difference']:.3g} m")
        for path in written:
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
