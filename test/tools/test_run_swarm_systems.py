"""Every system through ``scripts/run_swarm.sh``, recorded, and scored again from its log.

One table of recorded runs (:data:`conftest.SYSTEM_RUNS`): for each, the run completes with
every robot alive, the log holds every step of the robots' own topics and of every output
their system declares, and no topic of a robot that its system does not declare (nothing is
recorded that nobody writes); ``scripts/evaluate.sh`` then scores the log, step by step, as
the monitor did. A system's own properties (meetings, tracks, search maps) are in its
``test_run_swarm_<system>.py``; a new system's row in the table is the common test for it.
"""

from __future__ import annotations

import json
import subprocess

import pytest

from phd_swarm.config import load_run_config
from phd_swarm.logs.mcap_log import summarize
from phd_swarm.nodes import topics as T

from .conftest import ROOT, SYSTEM_RUNS

pytestmark = [pytest.mark.ros, pytest.mark.slow]


@pytest.mark.parametrize("name", sorted(SYSTEM_RUNS))
def test_a_recorded_run_holds_every_step_of_its_systems_topics_and_scores_again(
        system_run, name, tmp_path):
    spec = SYSTEM_RUNS[name]
    run = system_run(name)
    summary = json.loads((run / "summary.json").read_text())
    assert summary["complete"] and summary["steps"] == spec.steps
    assert summary["dead_robots"] == [] and summary["rejected_messages_monitor"] == 0
    system = load_run_config(run / "config.yaml").scenario.system
    assert summary["system"]["estimator"] == system.estimator
    outputs = T.declared_outputs(system)
    per_step = {"estimates", "goal", "status"} | {o.topic for o in outputs if o.per_step}
    topics = summary["log_completeness"]["topics"]
    for r in range(spec.robots):
        for rel in sorted(per_step):
            assert topics[T.robot_topic(r, rel)]["recorded"] == spec.steps, (r, rel)
    allowed = set(T.robot_topics(outputs))
    info = summarize(run / "run.mcap")
    assert not info.truncated
    robots = [t for t in info.topics if t.startswith("/" + T.ROBOT_PREFIX)]
    assert {t.split("/", 2)[2] for t in robots} <= allowed
    for o in outputs:
        if not o.per_step:          # observation traffic (keep-last): not necessarily all
            assert 0 < info.topics[T.robot_topic(0, o.topic)].message_count <= spec.steps

    out = tmp_path / "eval"
    res = subprocess.run([str(ROOT / "scripts" / "evaluate.sh"), str(run / "run.mcap"),
                          "--out", str(out), "--no-plots", "--quiet"],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    evaluation = json.loads((out / "evaluation.json").read_text())
    assert evaluation["log_completeness"]["complete"] and evaluation["steps"] == spec.steps
    agree = evaluation["monitor_agreement"]
    assert agree["steps_compared"] == spec.steps and agree["max_abs_ospa_difference"] == 0.0
