"""What the live view costs the demo: its stepping rate without and with ``--view``.

And with a browser watching. Run with ``scripts/bench.sh view [--repeats 3] [--quick]``.
Each repeat runs the demo (``config/dames_static.yaml``, 20 robots, 30 targets, 120 s of
sim time, seed 1, lockstep, recorded; ``--quick``: 8 robots, 20 s) three ways, alternated
so that the machine's drift falls on all of them alike:

- ``off``: ``scripts/run_swarm.sh`` as the demo runs it;
- ``view``: with ``--view`` (the view server and the viewer node; nobody watching);
- ``browser``: with ``--view`` and headless Chromium showing the view from the first step
  to the last (SwiftShader: the browser's rendering takes CPU from the run on this
  machine, as a browser on the same computer would).

It reports, per way, the stepping rate (steps per wall second while the world steps, from
``summary.json``), the run's CPU seconds (``cpu_s``, every process of the run, the viewer
node and the Rerun server included, not the browser) and the view's (viewer and server),
the median over repeats, and the drop of the median rate against ``off``. Writes
``bench/results/view-<date>.json``. Processes are stopped by PID whatever happens.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from results_io import machine_meta, write_results

from phd_swarm.testing import fresh_domain_id, loopback_env
from phd_swarm.tools.browser_shot import Browser
from phd_swarm.tools.processes import stop_process_group
from phd_swarm.tools.view_shots import _URL

ROOT = Path(__file__).resolve().parents[1]
WAYS = ("off", "view", "browser")


def one_run(way: str, out: Path, name: str, options: list[str]) -> dict[str, float]:
    """One run of the demo in ``way``; its stepping rate and CPU seconds."""
    cmd = [str(ROOT / "scripts" / "run_swarm.sh"), str(ROOT / "config" / "dames_static.yaml"),
           *options, "--out", str(out), "--name", name, "--quiet"]
    if way != "off":
        cmd += ["--view", "--view-hold"] if way == "browser" else ["--view"]
    log = out / f"{name}.log"
    with open(log, "w") as sink:
        proc = subprocess.Popen(cmd, env=loopback_env(fresh_domain_id()), stdout=sink,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                start_new_session=True)
    try:
        if way == "browser":
            _watch(proc, log)
        proc.wait(timeout=1800)
    finally:
        stop_process_group(proc, 30.0)
    if proc.returncode != 0:
        raise RuntimeError(f"{name}: exit {proc.returncode}; see {log}")
    summary = json.loads((out / name / "summary.json").read_text())
    return {"steps_per_s": summary["steps"] / summary["stepping_wall_s"],
            "cpu_s": sum(summary["cpu_s"].values()),
            "viewer_cpu_s": summary["cpu_s"].get("viewer", 0.0)
            + summary["cpu_s"].get("view_server", 0.0)}


def _watch(proc: subprocess.Popen, log: Path) -> None:
    """Open the view in Chromium as soon as its URL is printed, until the run is over.

    Then (the command holds its view) stop the command.
    """
    while not (match := _URL.search(log.read_text())):
        if proc.poll() is not None:
            raise RuntimeError(f"the run ended before printing its view's URL; see {log}")
        time.sleep(0.2)
    with Browser() as browser:
        browser.open(match.group(1))
        while "the view stays at" not in log.read_text():
            if proc.poll() is not None:
                raise RuntimeError(f"the run ended without holding its view; see {log}")
            time.sleep(0.5)
    os.killpg(proc.pid, signal.SIGINT)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print and write its figures."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--quick", action="store_true", help="8 robots, 20 s, one repeat")
    p.add_argument("--out", type=Path, default=ROOT / "bench" / "results")
    args = p.parse_args(argv)
    options = ["--robots", "20", "--targets", "30", "--duration", "120", "--seed", "1"]
    repeats = args.repeats
    if args.quick:
        options, repeats = ["--robots", "8", "--targets", "30", "--duration", "20",
                            "--seed", "1"], 1
    rows: dict[str, list[dict[str, float]]] = {w: [] for w in WAYS}
    with tempfile.TemporaryDirectory(prefix="phd_swarm_bench_view_") as tmp:
        for rep in range(repeats):
            for way in WAYS:
                row = one_run(way, Path(tmp), f"{way}-{rep}", options)
                rows[way].append(row)
                print(f"view: repeat {rep + 1}/{repeats} {way:8s} {row['steps_per_s']:6.2f} "
                      f"steps/s, {row['cpu_s']:6.1f} CPU s", flush=True)
    base = statistics.median(r["steps_per_s"] for r in rows["off"])
    results = []
    print(f"{'way':8s} {'steps/s (median)':>17s} {'drop':>7s} {'CPU s (median)':>15s} "
          f"{'view CPU s':>13s}")
    for way in WAYS:
        rate = statistics.median(r["steps_per_s"] for r in rows[way])
        cpu = statistics.median(r["cpu_s"] for r in rows[way])
        viewer = statistics.median(r["viewer_cpu_s"] for r in rows[way])
        drop = 1.0 - rate / base
        results.append({"way": way, "steps_per_s": rate, "drop": drop, "cpu_s": cpu,
                        "viewer_cpu_s": viewer, "runs": rows[way]})
        print(f"{way:8s} {rate:17.2f} {100 * drop:6.1f}% {cpu:15.1f} {viewer:13.1f}")
    meta = machine_meta(options=options, repeats=repeats)
    write_results(args.out, "view", meta, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
