"""Recorded runs of every system, shared by the run_swarm and log tools' tests."""

from __future__ import annotations

import subprocess
from collections.abc import Callable
from dataclasses import dataclass
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


@dataclass(frozen=True)
class SystemRun:
    """A system's recorded run: ``run_swarm.sh CONFIG OPTIONS``, ``robots`` x ``steps``.

    ``config`` names a file of config/, or makes one in a temporary directory.
    """

    config: str | Callable[[Path], Path]
    options: tuple[str, ...]
    robots: int
    steps: int


def _sung_config(where: Path) -> Path:
    """config/sung_static.yaml with 20 % false positives and GP prediction."""
    config = where / "sung_short.yaml"
    text = (ROOT / "config" / "sung_static.yaml").read_text()
    text = text.replace("false_positive_prob: 0.1 ", "false_positive_prob: 0.2 ").replace(
        "fov_rule: true ", "fov_rule: true\n          gp_prediction: true ")
    assert "gp_prediction: true" in text and "false_positive_prob: 0.2" in text
    config.write_text(text)
    return config


#: The recorded Sung & Tokekar run: one robot, lawn-mower, 20 % false positives, GP
#: prediction, 400 steps of 1 s, seed 2.
SUNG_RECORDED = {"steps": 400, "seed": 2}

#: Every system's recorded run, made once per session by :func:`system_run` (and shared by
#: the log tools' tests): the table of ``test_run_swarm_systems.py``.
SYSTEM_RUNS = {
    "dames": SystemRun("dames_static.yaml", (
        "--robots", str(RECORDED["robots"]), "--targets", str(RECORDED["targets"]),
        "--duration", str(RECORDED["steps"] * 0.5), "--seed", str(RECORDED["seed"])),
        RECORDED["robots"], RECORDED["steps"]),
    "chen_o": SystemRun("chen_clustered.yaml", ("--robots", "4", "--duration", "6",
                                                "--seed", "2", "--controller", "chen_o"),
                        4, 12),
    "sung": SystemRun(_sung_config, ("--robots", "1", "--duration",
                                     str(float(SUNG_RECORDED["steps"])), "--seed",
                                     str(SUNG_RECORDED["seed"])), 1, SUNG_RECORDED["steps"]),
    # Seed 4: meetings at steps 2, 30, 32 and 33.
    "shirsat": SystemRun("shirsat_small.yaml", ("--seed", "4", "--duration", "60"), 3, 60),
    # On the repository's Fast DDS profile (UDP bound to 127.0.0.1; the others: LOCALHOST).
    "papaioannou": SystemRun("papaioannou_small.yaml", ("--duration", "25", "--dds",
                                                        "profile"), 4, 25),
}


@pytest.fixture(scope="session")
def system_run(tmp_path_factory) -> Callable[[str], Path]:
    """``system_run(NAME)``: the directory of :data:`SYSTEM_RUNS`'s run NAME, recorded once."""
    runs: dict[str, Path] = {}

    def run(name: str) -> Path:
        if name not in runs:
            spec = SYSTEM_RUNS[name]
            where = tmp_path_factory.mktemp(name)
            config = (spec.config(where) if callable(spec.config)
                      else ROOT / "config" / spec.config)
            runs[name] = record_swarm_run(where, str(config), *spec.options)
        return runs[name]

    return run


@pytest.fixture(scope="session")
def recorded_run(system_run) -> Path:
    """Directory of a finished ``run_swarm.sh`` run (run.mcap, summary.json, config.yaml)."""
    return system_run("dames")


@pytest.fixture(scope="session")
def sung_run(system_run) -> Path:
    """Directory of a finished ``run_swarm.sh config/sung_static.yaml --robots 1`` run."""
    return system_run("sung")
