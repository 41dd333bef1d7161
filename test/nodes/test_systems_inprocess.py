"""Every system as ROS nodes in one process, lockstep, against the in-memory engine.

One table of systems (:data:`SYSTEMS`): each runs as ROS nodes in one process, lockstep,
while a probe records every robot's step outputs: its own (``estimates``, ``goal``) and
every output its system's parts declare (:mod:`phd_swarm.core.outputs`), and the world's
pose of it. The distributed engine then runs the same scenario, and after each step:

- the same faces build the same declared outputs from the engine's agents: the recorded
  messages must be equal in every field (float64 exact; not the serialised bytes, whose
  CDR padding is not defined);
- every robot's estimates and goal equal its agent's;
- the monitor's OSPA equals the engine's team scored the way the estimator's observation
  declares (the image or the union of estimates), and the figures it reports are the
  engine's;
- the messages the robots sent, in all, are those the engine's robots sent.

While the team runs, a robot's namespace holds its own topics and its system's declared
outputs and nothing else: no reader of a topic that nobody writes. Nothing here names a
system's outputs: a new system's row in :data:`SYSTEMS` is the whole test for it.
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config import load_run_config
from phd_swarm.core.scoring import score_estimates, score_step
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim.presets import sung_tokekar
from phd_swarm.testing import small_static_scenario

ROOT = Path(__file__).resolve().parents[2]


def _config(name: str, steps: int, **overrides):
    scenario = load_run_config(ROOT / "config" / name).scenario
    return scenario.with_overrides(duration=steps * scenario.dt, **overrides)


def _sung(controller: str = "lawnmower", gp_input: str = "estimates"):
    """One robot, 20 % false positives, GP prediction fed by ``gp_input`` (issue 34)."""
    return sung_tokekar().with_system(controller=controller, options={
        "false_positive_prob": 0.2, "gp_prediction": True,
        "gp_input": gp_input}).with_overrides(seed=3, duration=80.0)


#: System -> a small scenario of it (a few robots, a few dozen steps).
SYSTEMS = {
    "dames": lambda: small_static_scenario(robots=4, steps=24),
    "chen_o": lambda: small_static_scenario(robots=4, steps=24).with_system(
        controller="chen_o"),
    "sung": _sung,
    "sung_largest_gaussian": lambda: _sung("largest_gaussian"),
    "sung_gp_detections": lambda: _sung(gp_input="detections"),
    # Seed 4: the robots meet at steps 2, 30, 32 and 33.
    "shirsat": lambda: _config("shirsat_small.yaml", 60, seed=4),
    "papaioannou": lambda: _config("papaioannou_small.yaml", 30),
}


def _step_of(msg, dt: float) -> int:
    if hasattr(msg, "step"):
        return int(msg.step)
    stamp = msg.header.stamp
    return int(round((stamp.sec + stamp.nanosec * 1e-9) / dt))


def _robot_graph(graph: dict[str, list[str]], robot: int) -> dict[str, list[str]]:
    from phd_swarm.nodes import topics as T

    prefix = T.robot_namespace(robot) + "/"
    return {name[len(prefix):]: types for name, types in graph.items()
            if name.startswith(prefix)}


def _sent(exchange) -> int:
    return int(getattr(exchange, "stats", {}).get("sent", 0))


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.parametrize("system", sorted(SYSTEMS))
def test_the_ros_team_equals_the_engine_output_by_output(tmp_path, system):
    from geometry_msgs.msg import PoseStamped

    from phd_swarm.nodes import convert
    from phd_swarm.nodes import topics as T
    from phd_swarm.nodes.face import Step, load_face
    from phd_swarm.nodes.qos import subscription_qos
    from phd_swarm.nodes.robot_outputs import robot_estimates
    from phd_swarm.nodes.wire import wire_for
    from phd_swarm.testing import InProcessRos, start_swarm
    from phd_swarm_msgs.msg import TargetSet

    scenario = SYSTEMS[system]()
    outputs = [o for o in T.declared_outputs(scenario.system) if o.per_step]
    assert outputs, f"{system} declares no step output"
    faces = {o.topic: load_face(o) for o in outputs}
    robots = range(scenario.robots)
    got: dict[tuple[int, str], dict[int, object]] = defaultdict(dict)
    with InProcessRos(executor="events") as ros:
        probe = ros.node("probe")
        for r in robots:
            for topic, msg_type, qos in (("estimates", TargetSet, "STEP"),
                                         ("goal", PoseStamped, "STEP"),
                                         ("pose", PoseStamped, "STEP"),
                                         *((o.topic, faces[o.topic].msg_type, o.qos)
                                           for o in outputs)):
                probe.create_subscription(
                    msg_type, T.robot_topic(r, topic),
                    lambda m, key=(r, topic): got[key].setdefault(
                        _step_of(m, scenario.dt), m), subscription_qos(qos))
        world, monitor, nodes = start_swarm(ros, tmp_path, scenario)
        assert ros.spin_until(lambda: monitor.next_step >= 2, timeout=60.0)
        graph = dict(probe.get_topic_names_and_types())
        assert ros.spin_until(lambda: monitor.done, timeout=240.0), (
            f"monitor stopped at step {monitor.next_step} of {scenario.steps}")
        assert ros.spin_until(lambda: all(len(by_step) == scenario.steps
                                          for by_step in got.values()), timeout=30.0)
        assert len(got) == scenario.robots * (len(outputs) + 3)
        assert world.dead == set() and world.rejected == 0 and monitor.rejected == 0
        assert sum(sum(n.rejections.values()) for n in nodes) == 0
        sent = sum(_sent(n.filter) for n in nodes)
        series = monitor.series
        frame = nodes[0].params["world_frame_id"]

    # The graph: the run's team topics, and per robot its own and its declared ones only.
    team = {T.CLOCK, T.WORLD_TRUTH, T.WORLD_ROBOTS, T.WORLD_MARKERS, T.MONITOR_METRICS,
            T.MONITOR_ESTIMATES, T.MONITOR_MARKERS}
    assert {t: [T.TEAM_TOPICS[t][0]] for t in team} == {t: graph.get(t) for t in team}
    expected = {rel: [spec[0]] for rel, spec in T.robot_topics(
        T.declared_outputs(scenario.system)).items()}
    if not wire_for(scenario.system.parts()["exchange"]).types:
        del expected["inbox"]       # an exchange that sends nothing has no inbox
    for r in robots:
        assert _robot_graph(graph, r) == expected, f"robot {r}'s topics"

    engine = DistributedEngine(scenario)
    image = bool(scenario.system.parts()["estimator"].observation.image)
    compared, found = 0, 0
    for k in range(scenario.steps):
        ids, truth = engine.world.truth()
        # The world's pose of each robot, written on its topic while watched (this probe).
        for r in robots:
            pose = got[(r, "pose")][k].pose.position
            assert [pose.x, pose.y] == engine.world.robot_positions[r].tolist(), (k, r)
        engine.step()
        for r in robots:
            agent, decision = engine.agents[r], engine.decisions[r]
            points, expected_count = robot_estimates(agent)
            recv = got[(r, "estimates")][k]
            assert np.array_equal(convert.target_positions(recv), points), (k, r)
            assert recv.expected_cardinality == expected_count, (k, r)
            found += len(points)
            goal = got[(r, "goal")][k].pose.position
            assert [goal.x, goal.y] == np.asarray(decision.goal, float).tolist(), (k, r)
            step = Step(agent, k, decision, points, scenario.dt, frame)
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
        row = series[k]
        assert row["step"] == k and row["ospa"] == score.ospa, k
        assert row["cardinality_est"] == score.cardinality_est, k
        figures = engine.figures(truth, ids)
        for name in figures.keys() & row.keys():      # those the monitor reports
            assert _same(float(figures[name]), float(row[name])), (k, name)
    assert compared == scenario.steps * len(robots) * len(outputs)
    assert found > 0, "the team estimated no target"
    assert sent == sum(_sent(engine.agents[r].exchange) for r in robots)
