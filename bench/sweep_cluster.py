"""Sweep throughput: the local process pool against a Dask cluster on the same cores.

Run with ``scripts/bench.sh sweep-cluster``. Runs one spec's trials from scratch twice per
repeat: on the local pool of ``--workers`` processes (``sweep.sh --workers N``), and on a
Dask scheduler with as many workers of one thread each, every process on 127.0.0.1
(``sweep.sh --scheduler``, :class:`phd_swarm.tools.sweep_cluster.DaskProcesses`). Prints
the trials per second of each run: the trials over the session's wall time in its
``sweep.json`` (loading the spec, connecting to the cluster and checking its workers,
running and writing every trial; the plots drawn after it are not counted), and its CPU
time (the pool's with its processes', Dask's of the client alone). The cluster's start-up
(a fresh cluster for each run, so that its workers run the current code) is timed apart:
a cluster's workers outlive a sweep. The two runs must write the same rows (timings
aside), or the benchmark fails.

Writes ``bench/results/sweep-cluster-<date>.json``.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from results_io import machine_meta, write_results

from phd_swarm.tools.sweep_cluster import DaskProcesses
from phd_swarm.tools.sweep_results import TIMING_COLUMNS


def _sweep(spec: str, quick: bool, out: Path, *how: str) -> dict[str, float]:
    """One sweep from scratch in a process of its own; its trials and session wall [s]."""
    argv = [sys.executable, "-m", "phd_swarm.tools.sweep", spec, "--out", str(out), *how]
    done = subprocess.run([*argv, *(["--quick"] if quick else [])], capture_output=True,
                          text=True, timeout=3600, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed:\n{done.stderr[-3000:]}")
    session = json.loads((out / "sweep.json").read_text())["sessions"][-1]
    return {"trials": session["trials_run"], "wall_s": session["wall_s"],
            "session_cpu_s": session["cpu_s"],
            "trials_per_s": session["trials_run"] / session["wall_s"]}


def _rows(out: Path) -> dict[str, dict[str, str]]:
    with open(out / "results.csv", newline="") as f:
        return {r["trial"]: {c: v for c, v in r.items() if c not in TIMING_COLUMNS}
                for r in csv.DictReader(f)}


def main(argv: list[str] | None = None) -> int:
    """Run both, print trials/s, write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", default="dames_static",
                        help="sweep spec (default dames_static, its quick form: 18 trials "
                             "on the central engine, about 40 s on 2 cores)")
    parser.add_argument("--full-form", action="store_true",
                        help="the spec's full form instead of its quick form")
    parser.add_argument("--workers", type=int, default=2,
                        help="local processes, and Dask workers of one thread (default 2)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each (default 1)")
    parser.add_argument("--quick", action="store_true",
                        help="examples/stationary_sweep.yaml's quick form (2 short trials)")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)
    spec, quick = args.spec, not args.full_form
    if args.quick:
        spec = str(Path(__file__).resolve().parents[1] / "examples" / "stationary_sweep.yaml")
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-sweep-cluster-") as tmp:
        work = Path(tmp)
        for rep in range(args.repeat):
            runs = {"pool": _sweep(spec, quick, work / f"pool{rep}", "--workers",
                                   str(args.workers))}
            # A fresh cluster per run: its workers run the code of now (the sweep checks).
            with DaskProcesses(work / f"cluster{rep}") as dask:
                t0 = time.monotonic()
                address = dask.scheduler("127.0.0.1")
                for i in range(args.workers):
                    dask.worker(address, "127.0.0.1", f"w{i + 1}")
                startup = time.monotonic() - t0
                runs["dask"] = _sweep(spec, quick, work / f"dask{rep}", "--scheduler",
                                      address)
            for name, r in runs.items():
                print(f"{name:<5} {r['trials']} trials in {r['wall_s']:6.1f} s: "
                      f"{r['trials_per_s']:.3f} trials/s", flush=True)
            if _rows(work / f"pool{rep}") != _rows(work / f"dask{rep}"):
                raise RuntimeError("the pool and Dask wrote different rows")
            rows.append({"spec": Path(spec).stem, "quick": quick, "workers": args.workers,
                         "repeat": rep, "same_rows": True, "dask_startup_s": startup,
                         **{f"{n}_{k}": v for n, r in runs.items() for k, v in r.items()},
                         "dask_over_pool": runs["dask"]["trials_per_s"]
                         / runs["pool"]["trials_per_s"]})
            print(f"Dask cluster start-up {startup:.1f} s (not counted); Dask / pool "
                  f"throughput {rows[-1]['dask_over_pool']:.3f}; same rows", flush=True)
    write_results(args.out, "sweep-cluster", machine_meta(), rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
