"""Soak benchmark: a long lockstep run, every process sampled, the slope of each figure.

Run with ``scripts/bench.sh soak [--sim-minutes 60] [--robots 20] [--sample-s 2]
[--quick]``. Runs ``scripts/run_swarm.sh config/dames_static.yaml`` (a process per robot,
lockstep, the recorder on) for ``--sim-minutes`` of sim time, and every ``--sample-s``
wall seconds samples, for every process of the run (world, monitor, recorder, each
robot): its resident memory (VmRSS), its open files (``/proc/PID/fd``), its CPU time and
the ``/dev/shm`` files it maps (Fast DDS's shared-memory segments), with the step the
monitor last reported, whether the world was still stepping (its log has no "world:
done" yet; the monitor may lag behind the world, and after the world is done the team
exits) and all entries in ``/dev/shm`` (other runs' too: soak alone). Then, from the
samples taken while stepping, after the warm-up (the first ``--warmup`` of the steps),
per process:

- ``rss_mb_per_sim_hour``: the least-squares slope of RSS over sim time (target: < 1 MB
  per process per sim-hour);
- ``fds_per_sim_hour``, ``shm_mapped_per_sim_hour``: the same for open files and mapped
  shared-memory files;
- ``cpu_ms_per_step``: CPU per step between samples, its mean in the second and the last
  quarter of the run, and their ratio (flat: within noise of 1);

and the slope of the ``/dev/shm`` entries. Prints a table (robots as their median and
worst), writes ``bench/results/soak-<date>.json`` with every sample, and two plots beside
it: RSS and CPU per step over sim time, per process. ``--quick``: 4 robots, 2 sim-minutes.
DDS's own queue depths are not visible from outside a process and are not sampled.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from results_io import machine_meta, write_results

from phd_swarm.nodes.world import DONE_LINE
from phd_swarm.testing import run_pids

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "dames_static.yaml"
_STEP = re.compile(rb"step (\d+)/")
OBSERVERS = {"world": "phd_swarm.nodes.world", "monitor": "phd_swarm.nodes.monitor",
             "recorder": "phd_swarm.nodes.recorder"}


def parse_args(argv: list[str]) -> argparse.Namespace:
    """The command line (see the module docstring)."""
    p = argparse.ArgumentParser(prog="scripts/bench.sh soak")
    p.add_argument("--sim-minutes", type=float, default=60.0)
    p.add_argument("--robots", type=int, default=20)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--sample-s", type=float, default=2.0, help="wall seconds between samples")
    p.add_argument("--warmup", type=float, default=0.1,
                   help="fraction of the steps left out of the slopes (default 0.1)")
    p.add_argument("--quick", action="store_true", help="4 robots, 2 sim-minutes")
    p.add_argument("--out", type=Path, default=Path(__file__).with_name("results"))
    opts = p.parse_args(argv)
    if opts.quick:
        opts.robots, opts.sim_minutes = 4, 2.0
    return opts


def _proc_figures(pid: int) -> tuple[float, int, float, int] | None:
    """(RSS [MB], open files, CPU [s], /dev/shm files mapped) of ``pid``; None if gone."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
        fds = len(os.listdir(f"/proc/{pid}/fd"))
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        maps = Path(f"/proc/{pid}/maps").read_text()
    except (OSError, IndexError):
        return None
    found = re.search(r"VmRSS:\s+(\d+) kB", status)
    if found is None:  # a zombie: exited, not yet reaped
        return None
    rss = int(found.group(1)) / 1024
    cpu = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    shm = len(set(re.findall(r"(/dev/shm/\S+)", maps)))
    return rss, fds, cpu, shm


def _pids(run: Path, robots: int) -> dict[str, int]:
    found = {}
    for name, module in OBSERVERS.items():
        pids = run_pids(run, module)
        if pids:
            found[name] = pids[0]
    for r in range(robots):
        pids = run_pids(run, f"robot_id:={r}")
        if pids:
            found[f"robot_{r}"] = pids[0]
    return found


def _last_step(monitor_log: Path) -> int:
    try:
        found = _STEP.findall(monitor_log.read_bytes()[-4096:])
    except OSError:
        return -1
    return int(found[-1]) if found else -1


def _world_done(world_log: Path) -> bool:
    try:
        return DONE_LINE.encode() in world_log.read_bytes()[-4096:]
    except OSError:
        return False


def soak(opts: argparse.Namespace, where: Path) -> tuple[list[dict], dict]:
    """Run and sample; (samples, summary.json)."""
    duration = opts.sim_minutes * 60.0
    cmd = [str(ROOT / "scripts" / "run_swarm.sh"), str(CONFIG), "--robots", str(opts.robots),
           "--targets", str(opts.robots), "--duration", f"{duration:g}", "--seed",
           str(opts.seed), "--out", str(where), "--name", "soak", "--quiet"]
    run = where / "soak"
    monitor_log = run / "logs" / "monitor.log"
    world_log = run / "logs" / "world.log"
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, start_new_session=True, env=env)
    samples: list[dict] = []
    pids: dict[str, int] = {}
    started = time.monotonic()
    try:
        while proc.poll() is None:
            time.sleep(opts.sample_s)
            if len(pids) < opts.robots + len(OBSERVERS):
                pids = _pids(run, opts.robots)
            stepping = not _world_done(world_log)
            step = _last_step(monitor_log)
            if step < 1:
                continue
            row = {"t_wall": round(time.monotonic() - started, 2), "step": step,
                   "stepping": stepping,
                   "shm_entries": len(os.listdir("/dev/shm")), "processes": {}}
            for name, pid in pids.items():
                fig = _proc_figures(pid)
                if fig is not None:
                    row["processes"][name] = {"rss_mb": round(fig[0], 2), "fds": fig[1],
                                              "cpu_s": fig[2], "shm_mapped": fig[3]}
            samples.append(row)
    finally:  # stopped by PID (its process group), whatever happened
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(timeout=120)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    if proc.returncode != 0:
        raise SystemExit(f"soak: run_swarm exited with code {proc.returncode}; see {run}/logs")
    return samples, json.loads((run / "summary.json").read_text())


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.polyfit(x, y, 1)[0]) if len(x) >= 3 and np.ptp(x) > 0 else float("nan")


def figures(samples: list[dict], steps: int, dt: float, warmup: float) -> dict[str, dict]:
    """Per process: the slopes of RSS and open files, CPU per step by quarter."""
    kept = [s for s in samples if s["step"] >= warmup * steps and s.get("stepping", True)]
    names = sorted({n for s in kept for n in s["processes"]})
    out: dict[str, dict] = {}
    for name in names:
        rows = [(s["step"], s["processes"][name]) for s in kept if name in s["processes"]]
        step = np.array([k for k, _ in rows], dtype=float)
        sim_h = step * dt / 3600.0
        rss = np.array([p["rss_mb"] for _, p in rows])
        fds = np.array([p["fds"] for _, p in rows], dtype=float)
        shm = np.array([p.get("shm_mapped", 0) for _, p in rows], dtype=float)
        cpu = np.array([p["cpu_s"] for _, p in rows])
        dk = np.diff(step)
        ok = dk > 0
        per_step = np.diff(cpu)[ok] / dk[ok] * 1e3
        at = step[1:][ok]
        span = at.max() - at.min() if at.size else 0.0

        def quarter(q: int, at=at, per_step=per_step, span=span) -> float:
            lo = at.min() + span * q / 4 if at.size else 0.0
            sel = per_step[(at >= lo) & (at <= lo + span / 4)] if at.size else per_step
            return round(float(sel.mean()), 3) if sel.size else float("nan")

        second, last = quarter(1), quarter(3)
        out[name] = {"rss_mb_start": round(float(rss[0]), 1) if rss.size else None,
                     "rss_mb_end": round(float(rss[-1]), 1) if rss.size else None,
                     "rss_mb_per_sim_hour": round(_slope(sim_h, rss), 3),
                     "fds_per_sim_hour": round(_slope(sim_h, fds), 3),
                     "shm_mapped_per_sim_hour": round(_slope(sim_h, shm), 3),
                     "cpu_ms_per_step_q2": second, "cpu_ms_per_step_q4": last,
                     "cpu_ratio_q4_q2": round(last / second, 3) if second else None}
    sim_h = np.array([s["step"] * dt / 3600.0 for s in kept])
    shm = np.array([s["shm_entries"] for s in kept], dtype=float)
    out["/dev/shm"] = {"entries_start": int(shm[0]) if shm.size else None,
                       "entries_end": int(shm[-1]) if shm.size else None,
                       "entries_per_sim_hour": round(_slope(sim_h, shm), 3)}
    return out


def plot(samples: list[dict], dt: float, path: Path) -> list[Path]:
    """RSS and CPU per step over sim time, per process: two PNGs beside ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = sorted({n for s in samples for n in s["processes"]})
    written = []
    for what, label in (("rss", "resident memory [MB]"), ("cpu", "CPU per step [ms]")):
        fig, ax = plt.subplots(figsize=(9, 5))
        for name in names:
            rows = [(s["step"], s["processes"][name]) for s in samples
                    if name in s["processes"]]
            step = np.array([k for k, _ in rows], dtype=float)
            if what == "rss":
                x, y = step, np.array([p["rss_mb"] for _, p in rows])
            else:
                cpu = np.array([p["cpu_s"] for _, p in rows])
                dk = np.diff(step)
                ok = dk > 0
                x, y = step[1:][ok], np.diff(cpu)[ok] / dk[ok] * 1e3
            robot = name.startswith("robot")
            ax.plot(x * dt / 60.0, y, lw=0.8 if robot else 1.6,
                    color="0.6" if robot else None, label=None if robot else name)
        ax.plot([], [], color="0.6", lw=0.8, label="robots (one line each)")
        ax.set_xlabel("sim time [min]")
        ax.set_ylabel(label)
        ax.legend()
        ax.grid(alpha=0.3)
        out = path.with_name(f"{path.stem}-{what}.png")
        fig.savefig(out, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(out)
    return written


def main(argv: list[str] | None = None) -> int:
    """Run the soak, print the slopes, write samples, figures and plots."""
    opts = parse_args(sys.argv[1:] if argv is None else argv)
    dt = 0.5
    with tempfile.TemporaryDirectory(prefix="phd_swarm_soak_") as tmp:
        samples, summary = soak(opts, Path(tmp))
    steps = summary["steps"]
    figs = figures(samples, steps, dt, opts.warmup)
    robots = {k: v for k, v in figs.items() if k.startswith("robot")}
    complete = bool((summary.get("log_completeness") or {}).get("complete"))
    print(f"soak: {opts.robots} robot processes, {steps} steps ({steps * dt / 60:g} sim-min) "
          f"in {summary['wall_duration_s']:.0f} s wall, {len(samples)} samples; log "
          f"{'complete' if complete else 'INCOMPLETE'}")
    print(f"{'process':<22}{'RSS MB start/end':>18}{'MB/sim-h':>10}{'fds/sim-h':>10}"
          f"{'CPU ms/step q2':>15}{'q4':>8}{'q4/q2':>7}")
    rows = [(k, figs[k]) for k in ("world", "monitor", "recorder") if k in figs]
    if robots:
        worst = max(robots.items(), key=lambda kv: kv[1]["rss_mb_per_sim_hour"])
        median = sorted(robots.items(), key=lambda kv: kv[1]["rss_mb_per_sim_hour"])[
            len(robots) // 2]
        rows += [(f"{median[0]} (median)", median[1]), (f"{worst[0]} (worst)", worst[1])]
    for name, f in rows:
        rss = f"{f['rss_mb_start']}/{f['rss_mb_end']}"
        print(f"{name:<22}{rss:>18}"
              f"{f['rss_mb_per_sim_hour']:>10}{f['fds_per_sim_hour']:>10}"
              f"{f['cpu_ms_per_step_q2']:>15}{f['cpu_ms_per_step_q4']:>8}"
              f"{f['cpu_ratio_q4_q2']:>7}")
    shm = figs["/dev/shm"]
    print(f"/dev/shm entries: {shm['entries_start']} -> {shm['entries_end']} "
          f"({shm['entries_per_sim_hour']} per sim-hour)")
    meta = machine_meta(robots=opts.robots, sim_minutes=opts.sim_minutes,
                        sample_s=opts.sample_s, warmup=opts.warmup, steps=steps,
                        wall_s=summary["wall_duration_s"], log_complete=complete)
    path = write_results(opts.out, "soak", meta, [{"figures": figs, "samples": samples}])
    for png in plot(samples, dt, path):
        print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
