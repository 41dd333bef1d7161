"""Every system's declared step outputs over ROS equal the in-memory engine's, field by field.

One table of systems (Dames', Chen's O, Sung & Tokekar's, Shirsat & Berman's, Papaioannou
et al.'s): each runs as ROS nodes in one process, lockstep, while a probe records every
step output every robot declares (:mod:`phd_swarm.core.outputs`). The distributed engine
then runs the same scenario, and after each step the same faces build the same outputs
from the engine's agents: the recorded messages must be equal in every field (float64
exact; not the serialised bytes, whose CDR padding is not defined). The
monitor's OSPA of each step must equal the engine's team scored the way the estimator's
observation declares (the image or the union of estimates). Nothing here names a system's
outputs: a new system's row in :data:`SYSTEMS` is the whole test for it.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config import load_run_config
from phd_swarm.core.controllers.base import Decision
from phd_swarm.core.scoring import score_estimates, score_step
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim.presets import sung_tokekar
from phd_swarm.testing import small_static_scenario

ROOT = Path(__file__).resolve().parents[2]


def _config(name: str, steps: int, **overrides):
    scenario = load_run_config(ROOT / "config" / name).scenario
    return scenario.with_overrides(duration=steps * scenario.dt, **overrides)


#: System -> a small scenario of it (a few robots, a few dozen steps).
SYSTEMS = {
    "dames": lambda: small_static_scenario(robots=4, steps=24),
    "chen_o": lambda: small_static_scenario(robots=4, steps=24).with_system(
        controller="chen_o"),
    "sung": lambda: sung_tokekar().with_system(
        controller="lawnmower", options={"false_positive_prob": 0.2}).with_overrides(
        seed=3, duration=30.0),
    "shirsat": lambda: _config("shirsat_small.yaml", 40, seed=4),
    "papaioannou": lambda: _config("papaioannou_small.yaml", 20),
}


def _step_of(msg, dt: float) -> int:
    if hasattr(msg, "step"):
        return int(msg.step)
    stamp = msg.header.stamp
    return int(round((stamp.sec + stamp.nanosec * 1e-9) / dt))


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.parametrize("system", sorted(SYSTEMS))
def test_every_declared_step_output_equals_the_engine_s(tmp_path, system):
    from phd_swarm.nodes import topics as T
    from phd_swarm.nodes.face import Step, load_face
    from phd_swarm.nodes.qos import subscription_qos
    from phd_swarm.testing import InProcessRos, start_swarm

    scenario = SYSTEMS[system]()
    outputs = [o for o in T.declared_outputs(scenario.system) if o.per_step]
    assert outputs, f"{system} declares no step output"
    faces = {o.topic: load_face(o) for o in outputs}
    robots = range(scenario.robots)
    got: dict[tuple[int, str], dict[int, object]] = defaultdict(dict)
    with InProcessRos(executor="events") as ros:
        probe = ros.node("probe")
        for r in robots:
            for o in outputs:
                probe.create_subscription(
                    faces[o.topic].msg_type, T.robot_topic(r, o.topic),
                    lambda m, key=(r, o.topic): got[key].setdefault(
                        _step_of(m, scenario.dt), m), subscription_qos(o.qos))
        world, monitor, nodes = start_swarm(ros, tmp_path, scenario)
        assert ros.spin_until(lambda: monitor.done, timeout=240.0), (
            f"monitor stopped at step {monitor.next_step} of {scenario.steps}")
        assert ros.spin_until(lambda: all(len(got[(r, o.topic)]) == scenario.steps
                                          for r in robots for o in outputs), timeout=30.0)
        assert world.dead == set() and world.rejected == 0 and monitor.rejected == 0
        series = monitor.series
        frame = nodes[0].params["world_frame_id"]

    engine = DistributedEngine(scenario)
    image = bool(scenario.system.parts()["estimator"].observation.image)
    compared = 0
    for k in range(scenario.steps):
        _, truth = engine.world.truth()
        engine.step()
        for r in robots:
            agent = engine.agents[r]
            decision = Decision(goal=np.asarray(agent.position, float),
                                power_weight=float(agent.power_weight))
            step = Step(agent, k, decision, np.empty((0, 2)), scenario.dt, frame)
            for o in outputs:
                built = faces[o.topic].build(step, {})
                recv = got[(r, o.topic)][k]
                if recv != built:
                    diff = [f for f in built.get_fields_and_field_types()
                            if getattr(built, f) != getattr(recv, f)]
                    pytest.fail(f"step {k}, robot {r}, {o.topic}: fields {diff} differ")
                compared += 1
        if image:
            score = score_step(scenario.grid, engine.team_weights(), truth,
                               scenario.extraction, scenario.ospa_c, scenario.ospa_p)
        else:
            score = score_estimates(*engine.team_estimates(), truth, scenario.ospa_c,
                                    scenario.ospa_p)
        assert series[k]["ospa"] == score.ospa, k
    assert compared == scenario.steps * len(robots) * len(outputs)
