"""What every benchmark shares: the machine description and the JSON result file."""

from __future__ import annotations

import datetime as dt
import json
import os
import platform
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np


def machine_meta(**extra: object) -> dict[str, object]:
    """Date, CPU count, architecture and library versions of this run."""
    return {"date": dt.date.today().isoformat(), "machine": platform.machine(),
            "cpus": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, **extra}


def write_results(out: Path, suite: str, meta: dict[str, object], results: list) -> Path:
    """Write ``{"meta", "results"}`` to ``out/<suite>-<date>.json``; returns the path."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{suite}-{meta['date']}.json"
    path.write_text(json.dumps({"meta": meta, "results": results}, indent=2) + "\n")
    print(f"wrote {path}")
    return path


def time_trial(sc, score: bool = True) -> tuple[float, float]:
    """CPU seconds of a distributed-engine trial's steps, and of its per-step scoring.

    The scoring is what the sweeps do each step (OSPA of the team's estimates and the
    system's figures); 0 unless ``score``.
    """
    from phd_swarm.core.scoring import score_estimates
    from phd_swarm.engines import make_engine

    engine = make_engine("distributed", sc)
    engine_s = score_s = 0.0
    for _ in range(sc.steps):
        _, truth = engine.world.truth()
        t0 = time.process_time()
        engine.step()
        t1 = time.process_time()
        engine_s += t1 - t0
        if score:
            score_estimates(*engine.team_estimates(), truth, sc.ospa_c, sc.ospa_p)
            engine.figures(truth)
            score_s += time.process_time() - t1
    return engine_s, score_s


def run_swarm_figures(config: Path, *options: str) -> dict[str, object]:
    """``scripts/run_swarm.sh CONFIG OPTIONS`` (recorded, on loopback); its summary's figures.

    Steps, completeness, stepping and total wall time, real-time factor, CPU seconds per
    process, messages per robot per step, and the system's own figure means.
    """
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, ROS_DOMAIN_ID=os.environ.get("ROS_DOMAIN_ID", "42"),
               ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [str(root / "scripts" / "run_swarm.sh"), str(config), *options, "--out", tmp,
               "--name", "run", "--quiet"]
        subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL)
        s = json.loads((Path(tmp) / "run" / "summary.json").read_text())
    return {"case": f"ROS nodes, lockstep, recorded ({config.relative_to(root)})",
            "steps": s["steps"], "complete": s["complete"],
            "stepping_wall_s": round(s["stepping_wall_s"], 2),
            "total_wall_s": round(s["wall_duration_s"], 2),
            "real_time_factor": round(s["real_time_factor"], 2),
            "messages_per_robot_per_step": s["messages_per_robot_per_step"],
            "figures": s.get("figures", {}), "cpu_s": s["cpu_s"]}

