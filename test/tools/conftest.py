"""A short recorded run shared by the log tools' tests (replay, evaluation, plots)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: The recorded run: 4 robots, 10 static targets drawn, 24 steps of 0.5 s, seed 5.
RECORDED = {"robots": 4, "targets": 10, "steps": 24, "seed": 5}


@pytest.fixture(scope="session")
def recorded_run(tmp_path_factory) -> Path:
    """Directory of a finished ``run_swarm.sh`` run (run.mcap, summary.json, config.yaml)."""
    from phd_swarm.testing import ChildProcesses

    out = tmp_path_factory.mktemp("recorded")
    argv = [str(ROOT / "scripts" / "run_swarm.sh"), str(ROOT / "config" / "dames_static.yaml"),
            "--robots", str(RECORDED["robots"]), "--targets", str(RECORDED["targets"]),
            "--duration", str(RECORDED["steps"] * 0.5), "--seed", str(RECORDED["seed"]),
            "--out", str(out), "--name", "run", "--quiet"]
    with ChildProcesses() as children:
        proc = children.start(argv)
        try:
            stdout, stderr = proc.communicate(timeout=240)
        except subprocess.TimeoutExpired:
            children.stop(proc)
            raise
    assert proc.returncode == 0, f"run_swarm failed:\n{stdout}\n{stderr}"
    return out / "run"
