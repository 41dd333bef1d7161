"""A short recorded run shared by the log tools' tests (replay, evaluation, plots)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: The recorded run: 4 robots, 10 static targets drawn, 24 steps of 0.5 s, seed 5.
RECORDED = {"robots": 4, "targets": 10, "steps": 24, "seed": 5}


def record_swarm_run(out: Path, config: str, *options: str) -> Path:
    """Run ``run_swarm.sh CONFIG OPTIONS`` into ``out/run`` on loopback; returns that dir."""
    from phd_swarm.testing import ChildProcesses

    argv = [str(ROOT / "scripts" / "run_swarm.sh"), str(ROOT / "config" / config), *options,
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


@pytest.fixture(scope="session")
def record_swarm():
    """:func:`record_swarm_run`, for modules' own recorded runs."""
    return record_swarm_run


@pytest.fixture(scope="session")
def recorded_run(tmp_path_factory) -> Path:
    """Directory of a finished ``run_swarm.sh`` run (run.mcap, summary.json, config.yaml)."""
    return record_swarm_run(
        tmp_path_factory.mktemp("recorded"), "dames_static.yaml",
        "--robots", str(RECORDED["robots"]), "--targets", str(RECORDED["targets"]),
        "--duration", str(RECORDED["steps"] * 0.5), "--seed", str(RECORDED["seed"]))


#: The recorded Sung & Tokekar run: one robot, lawn-mower, 20 % false positives, GP
#: prediction, 400 steps of 1 s, seed 2.
SUNG_RECORDED = {"steps": 400, "seed": 2}


@pytest.fixture(scope="session")
def sung_run(tmp_path_factory) -> Path:
    """Directory of a finished ``run_swarm.sh config/sung_static.yaml --robots 1`` run."""
    config = tmp_path_factory.mktemp("sung_config") / "sung_short.yaml"
    text = (ROOT / "config" / "sung_static.yaml").read_text()
    text = text.replace("false_positive_prob: 0.1 ", "false_positive_prob: 0.2 ").replace(
        "fov_rule: true ", "fov_rule: true\n          gp_prediction: true ")
    assert "gp_prediction: true" in text and "false_positive_prob: 0.2" in text
    config.write_text(text)
    return record_swarm_run(tmp_path_factory.mktemp("sung"), str(config), "--robots", "1",
                            "--duration", str(float(SUNG_RECORDED["steps"])), "--seed",
                            str(SUNG_RECORDED["seed"]))
