"""A sixth system from outside the package passes through every entry point (issue 35).

``examples/sixth_system`` is a complete system of its own (estimator ``last_seen``,
exchange ``beacon``, controller ``waypoint`` on the built-in ``disk`` sensor) and a topic no
built-in system publishes (``detections``, a ``geometry_msgs/PoseArray``), its ROS side
named by file. Here it is checked part by part (hand-computed expectations), then run
through the in-memory engine, a sweep, ``run_swarm.sh`` with ``evaluate.sh`` on its log,
and the docs generator, without any of them being told about it; and nothing in the
package names it.
"""

from __future__ import annotations

import ast
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config import load_run_config
from phd_swarm.core import registry
from phd_swarm.core.outputs import system_outputs
from phd_swarm.core.scan import Scan
from phd_swarm.core.scoring import score_estimates
from phd_swarm.core.system import SystemConfig

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "phd_swarm"
EXAMPLE = ROOT / "examples" / "sixth_system"
PARTS, FACES = EXAMPLE / "parts.py", EXAMPLE / "ros_faces.py"
CONFIG, SPEC = EXAMPLE / "sixth.yaml", EXAMPLE / "sixth_sweep.yaml"
FILES = ("README.md", "parts.py", "ros_faces.py", "sixth.yaml", "sixth_sweep.yaml")
#: The example's parts, by role.
NAMES = {"estimator": "last_seen", "exchange": "beacon", "controller": "waypoint"}
SIXTH = dict(NAMES, sensor="disk")


@pytest.fixture(scope="module")
def sixth():
    """The example's parts module, registered for this module and taken out again after.

    So that the tests run later in the same process (e.g. the docs') see the package's
    parts only, as they would without this module.
    """
    module = registry.import_file(PARTS)
    yield module
    for role, name in NAMES.items():
        registry._PARTS[role].pop(name, None)
    for path in (PARTS, FACES):
        sys.modules.pop(registry.plugin_module_name(path), None)


# ---------------------------------------------------------------------------- the parts
def test_the_parts_register_and_fit_and_refuse_an_estimator_they_cannot_share(sixth):
    system = SystemConfig(**SIXTH, plugins=(str(PARTS),))
    assert dict(system.options) == {"beacon_range": 30.0, "memory_steps": 10,
                                    "merge_radius": 1.5}
    parts = system.parts()
    assert [o.topic for o in system_outputs(parts)] == ["detections"]
    assert parts["exchange"].wire == f"{FACES}:WIRE"
    with pytest.raises(ValueError, match=r"beacon needs \['shared_estimates'\]"):
        SystemConfig(exchange="beacon", controller="waypoint")  # Dames' grid PHD
    with pytest.raises(ValueError, match="memory_steps"):
        SystemConfig(**SIXTH, options=(("memory_steps", 0),))


def test_merging_keeps_the_youngest_point_of_each_neighbourhood(sixth):
    points = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 5.0], [0.5, 0.0]])
    ages = np.array([3, 0, 1, 0])
    # Youngest first, ties in the given order: (1, 0) absorbs (0.5, 0) and, at exactly
    # the radius, (0, 0); (5, 5) is alone.
    kept, kept_ages = sixth.merge_points(points, ages, 1.0)
    np.testing.assert_array_equal(kept, [[1.0, 0.0], [5.0, 5.0]])
    np.testing.assert_array_equal(kept_ages, [0, 1])
    kept, _ = sixth.merge_points(points, ages, 0.4)
    assert len(kept) == 4
    empty, empty_ages = sixth.merge_points(np.empty((0, 2)), np.empty(0), 1.0)
    assert empty.shape == (0, 2) and empty_ages.shape == (0,)


def test_the_estimator_keeps_sightings_for_memory_steps_and_a_fresh_one_replaces_them(sixth):
    est = sixth.LastSeen(memory_steps=3, merge_radius=1.0)
    est.predict()
    est.update(Scan(0, 0, [0.0, 0.0], [[10.0, 10.0], [10.5, 10.0], [20.0, 0.0]]))
    np.testing.assert_array_equal(est.estimates(), [[10.0, 10.0], [20.0, 0.0]])
    assert est.expected_count() == 2.0
    est.predict()
    est.update(Scan(0, 1, [0.0, 0.0], [[10.2, 10.0]]))
    np.testing.assert_array_equal(est.estimates(), [[10.2, 10.0], [20.0, 0.0]])
    np.testing.assert_array_equal(est.ages, [0, 1])
    est.predict()                       # ages 1, 2
    assert est.expected_count() == 2.0
    est.predict()                       # ages 2, 3: (20, 0) is forgotten
    np.testing.assert_array_equal(est.estimates(), [[10.2, 10.0]])
    est.predict()                       # age 3
    assert est.estimates().shape == (0, 2) and est.expected_count() == 0.0


def test_merging_other_robots_takes_them_in_robot_id_order_and_drops_stale_points(sixth):
    def robot():
        est = sixth.LastSeen(memory_steps=3, merge_radius=1.0)
        est.points, est.ages = np.array([[0.0, 0.0]]), np.array([2])
        return est

    heard = {5: (np.array([[0.5, 0.0]]), np.array([1])),
             2: (np.array([[20.0, 20.0]]), np.array([0])),
             3: (np.array([[30.0, 30.0], [0.7, 0.0]]), np.array([3, 1]))}
    est = robot()
    est.merge(heard)
    # Robot 3's (30, 30) is 3 steps old: stale. (0.5, 0) from 5 and (0.7, 0) from 3 are
    # as young as each other and younger than the own (0, 0): robot 3's comes first.
    np.testing.assert_array_equal(est.estimates(), [[20.0, 20.0], [0.7, 0.0]])
    np.testing.assert_array_equal(est.ages, [0, 1])
    again = robot()
    again.merge(dict(reversed(list(heard.items()))))
    np.testing.assert_array_equal(again.estimates(), est.estimates())
    points, ages = est.shared()
    points[0] = 99.0
    assert est.estimates()[0, 0] == 20.0, "shared() hands out copies"


def _beacon_team(sixth, radio_range: float = 10.0):
    """Robots 0-3 on a line, 3 out of range; each with a LastSeen seeing one point."""
    from phd_swarm.core.exchange.radio import RangeRadio

    ids = np.arange(4)
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [50.0, 0.0]])
    seen = {0: [40.0, 40.0], 1: [0.3, 5.0], 2: [0.0, 5.0], 3: [60.0, 0.0]}
    out = {}
    for rid in ids.tolist():
        ex = sixth.Beacon(rid, RangeRadio(radio_range), timeout_ticks=2)
        est = sixth.LastSeen(memory_steps=10, merge_radius=1.0)
        est.update(Scan(rid, 0, positions[rid], [seen[rid]]))
        ex.bind_estimator(est)
        ex.observe_team(0, ids, positions, np.ones(4, dtype=bool))
        out[rid] = ex
    return out


@pytest.mark.parametrize("order", [(1, 2), (2, 1)])
def test_the_beacon_sends_to_the_robots_in_range_and_merges_in_robot_id_order(sixth, order):
    team = _beacon_team(sixth)
    sent = {rid: ex.start_step(0, np.zeros(2), 0.0, np.empty((0, 2)))
            for rid, ex in team.items()}
    assert [e.dst for e in sent[0]] == [1, 2] and sent[3] == []
    assert team[3].done, "a robot out of range is done at once"
    msg = sent[0][0].msg
    assert isinstance(msg, sixth.BeaconMsg) and msg.WIRE_TYPE == "TargetSet"
    assert msg.wire_size() == 20 + 4 + 4 + 4 + 4 + 4 + 24 + 8
    me = team[0]
    by_src = {e.src: e.msg for es in sent.values() for e in es if e.dst == 0}
    for src in order:
        assert not me.done
        assert me.receive(by_src[src])
        me.advance()
    assert me.done
    # Robot 1's (0.3, 5) and robot 2's (0, 5) are one target, equally young: robot 1's
    # is kept, whichever came first.
    np.testing.assert_array_equal(me.estimator.estimates(),
                                  [[40.0, 40.0], [0.3, 5.0]])
    assert me.stats == {"meetings": 1, "sent": 2, "timeouts": 0}


def test_a_silent_contact_is_given_up_after_timeout_ticks(sixth):
    team = _beacon_team(sixth)
    me = team[0]
    sent = [e for e in team[1].start_step(0, np.zeros(2), 0.0, np.empty((0, 2)))
            if e.dst == 0]
    me.start_step(0, np.zeros(2), 0.0, np.empty((0, 2)))
    me.receive(sent[0].msg)
    me.advance()
    me.tick()
    assert not me.done
    me.tick()
    assert me.done and me.stats["timeouts"] == 1
    np.testing.assert_array_equal(me.estimator.estimates(), [[40.0, 40.0], [0.3, 5.0]])


def test_the_controller_heads_for_waypoints_drawn_from_its_generator(sixth):
    from phd_swarm.core.controllers.base import Knowledge

    ctl = sixth.Waypoint(np.array([0.0, 0.0]), np.array([100.0, 50.0]))
    assert ctl.planned_path().shape == (0, 2)
    rng, ref = np.random.default_rng(7), np.random.default_rng(7)
    first = ref.uniform([0.0, 0.0], [100.0, 50.0])
    second = ref.uniform([0.0, 0.0], [100.0, 50.0])

    def decide(position):
        return ctl.decide(Knowledge(0, 0, np.asarray(position), np.empty((0, 2))), rng)

    d = decide([0.0, 0.0])
    np.testing.assert_array_equal(d.goal, first)
    assert d.power_weight == 0.0
    np.testing.assert_array_equal(decide([1.0, 1.0]).goal, first)   # not there yet
    near = first + np.array([0.6, 0.8])                               # 1 m away: reached
    np.testing.assert_array_equal(decide(near).goal, second)
    np.testing.assert_array_equal(ctl.planned_path(), [second])


# ----------------------------------------------------------------- the ROS side, by file
def test_the_wire_and_the_face_are_loaded_by_file_and_round_trip(sixth):
    from phd_swarm.nodes.face import Step, load_face, load_named
    from phd_swarm.nodes.wire import wire_for

    wire = wire_for(registry.lookup("exchange", "beacon"))
    faces = sys.modules[registry.plugin_module_name(FACES)]
    assert wire is faces.WIRE and faces.BeaconMsg is sixth.BeaconMsg, "one module each"
    msg = sixth.BeaconMsg(3, 12, np.array([[1.5, -2.25], [30.0, 4.0]]), np.array([0, 7]))
    data = wire.encode(msg, 0.5, "map")
    back = wire.decode("beacon", data, None, 100)
    assert (back.src, back.step, wire.kind(back), wire.sender(back)) == (3, 12, "beacon", 3)
    np.testing.assert_array_equal(back.points, msg.points)
    np.testing.assert_array_equal(back.ages, msg.ages)
    assert wire.addressee(back) is None
    assert abs(len(data) - msg.wire_size()) <= 4, "the estimate is the CDR size (padding)"
    bad = wire.to_ros(msg, 0.5, "map")
    bad.ids = bad.ids[:1]
    from phd_swarm.nodes.convert import InvalidMessage

    with pytest.raises(InvalidMessage, match="ids: 1 ages for 2 positions"):
        wire.from_ros(bad, None, 100)

    (output,) = registry.lookup("estimator", "last_seen").outputs
    face = load_face(output)
    assert face is faces.DETECTIONS
    agent = type("A", (), {"robot_id": 2})()
    pose_array = face.build(Step(agent, 4, None, msg.points, 0.5, "map"), {})
    assert pose_array.header.frame_id == "map" and pose_array.header.stamp.sec == 2
    assert [p.orientation.w for p in pose_array.poses] == [1.0, 1.0]
    np.testing.assert_array_equal(face.read(pose_array), msg.points)
    with pytest.raises(ValueError, match="cannot be loaded: FileNotFoundError"):
        load_named(f"{EXAMPLE / 'no_such.py'}:X", "face")
    with pytest.raises(ValueError, match="cannot be loaded: AttributeError"):
        load_named(f"{FACES}:NO_SUCH", "face")


# ------------------------------------------------------------------- the in-memory engine
def _engine_run(steps: int):
    from phd_swarm.engines.distributed import DistributedEngine

    engine = DistributedEngine(load_run_config(CONFIG).scenario)
    engine.run(steps)
    return engine


def test_the_in_memory_engine_runs_it_the_same_twice_and_robots_exchange_beacons(sixth):
    a, b = _engine_run(12), _engine_run(12)
    assert a.scenario.system.plugins == (str(PARTS),) and a.live_ids() == [0, 1, 2, 3]
    assert a.world.robot_positions.tobytes() == b.world.robot_positions.tobytes()
    assert not np.array_equal(a.world.robot_positions,
                              _engine_run(0).world.robot_positions), "the robots move"
    pa, na = a.team_estimates()
    pb, nb = b.team_estimates()
    assert pa.tobytes() == pb.tobytes() and na == nb and na > 0
    assert [dict(t.messages) for t in a.traffic] == [dict(t.messages) for t in b.traffic]
    beacons = [sum(t.messages[r]["TargetSet"] for r in t.messages) for t in a.traffic]
    assert all(n > 0 for n in beacons), "robots in range exchange beacons every step"
    assert {kind for t in a.traffic for r in t.messages for kind in t.messages[r]} == \
        {"TargetSet"}
    assert a.counters()["sent"] == sum(beacons) and a.counters()["timeouts"] == 0


# ------------------------------------------------------------------------------ a sweep
def test_a_sweep_runs_it_on_the_distributed_engine(sixth, tmp_path):
    from phd_swarm.config.sweep_spec import load_spec
    from phd_swarm.tools import sweep

    # The command a user types, in a process of its own: the runner is told nothing.
    res = subprocess.run([sys.executable, "-m", "phd_swarm.tools.sweep", str(SPEC), "--quick",
                          "--workers", "1", "--out", str(tmp_path)],
                         capture_output=True, text=True, timeout=240, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    rows = {r["method"]: r for r in csv.DictReader(open(tmp_path / "results.csv"))}
    assert sorted(rows) == ["memory_10", "memory_2"]
    for r in rows.values():
        assert r["engine"] == "distributed" and r["steps"] == "10"
        assert r["controller"].startswith("waypoint(estimator=last_seen,exchange=beacon")
    assert int(rows["memory_2"]["cardinality_est_final"]) \
        < int(rows["memory_10"]["cardinality_est_final"]), "a shorter memory keeps fewer"
    trial = next(t for t in load_spec(SPEC, quick=True).trials_list()
                 if t.method == "memory_2")
    row, _ = sweep.run_trial(trial)
    assert float(rows["memory_2"]["ospa_final"]) == row["ospa_final"]


# ------------------------------------------------------------------------------ the docs
def test_the_docs_generator_documents_the_plugin_when_asked(sixth, tmp_path):
    from phd_swarm.tools import gen_docs

    assert gen_docs.main(["--plugins", str(PARTS), "--out", str(tmp_path)]) == 0
    topics = (tmp_path / "topics.md").read_text()
    row = next(line for line in topics.splitlines()
               if line.startswith("| `/robot_<id>/detections` |"))
    assert "`geometry_msgs/msg/PoseArray`" in row and "`STEP`" in row
    assert "estimator `last_seen`" in row
    assert registry.lookup("estimator", "last_seen").outputs[0].description in row
    params = (tmp_path / "parameters.md").read_text()
    for name in ("memory_steps", "merge_radius", "beacon_range"):
        assert f"| `scenario.system.options.{name}` |" in params
    for name in NAMES.values():
        assert f"| `{name}` |" in params
    # Without --plugins the package's docs are unchanged, even with the plugin loaded.
    assert "detections" not in gen_docs.render_topics()
    assert gen_docs.check(ROOT) == []
    with pytest.raises(SystemExit):
        gen_docs.main(["--plugins", str(PARTS)])


# -------------------------------------------------------------------- outside the package
def test_the_example_lives_outside_the_package_and_the_package_does_not_name_it():
    assert sorted(p.name for p in EXAMPLE.iterdir() if p.name != "__pycache__") \
        == sorted(FILES)
    for name in FILES:
        assert not (EXAMPLE / name).resolve().is_relative_to(PACKAGE.resolve())
    words = ("last_seen", "beacon", "sixth_system", "sixth.yaml")
    for path in sorted(PACKAGE.rglob("*")):
        if not path.is_file() or path.suffix not in (".py", ".yaml", ".md", ".txt", ".cfg"):
            continue
        text = path.read_text()
        found = [w for w in words if w in text.lower()]
        assert not found, f"{path.relative_to(ROOT)} mentions {found}"
        if path.suffix == ".py":
            # "waypoint" is a word of the package's prose; as a part name it is a string.
            names = [n.value for n in ast.walk(ast.parse(text))
                     if isinstance(n, ast.Constant) and n.value in set(NAMES.values())]
            assert not names, f"{path.relative_to(ROOT)} names {names}"


# ------------------------------------------------------------------ run_swarm, evaluate
STEPS = 16


@pytest.mark.ros
@pytest.mark.slow
def test_run_swarm_runs_it_and_evaluate_scores_its_log(sixth, tmp_path, children):
    argv = [str(ROOT / "scripts" / "run_swarm.sh"), str(CONFIG), "--duration",
            str(STEPS * 0.5), "--out", str(tmp_path), "--name", "sixth", "--quiet"]
    proc = children.start(argv)
    try:
        out, err = proc.communicate(timeout=240)
    except subprocess.TimeoutExpired:
        children.stop(proc)
        raise
    assert proc.returncode == 0, f"run_swarm failed:\n{out}\n{err}"
    from phd_swarm.logs.mcap_log import read_messages, summarize
    from phd_swarm.nodes import topics as T
    from phd_swarm.nodes.convert import target_positions

    run = tmp_path / "sixth"
    summary = json.loads((run / "summary.json").read_text())
    assert summary["steps"] == STEPS and summary["dead_robots"] == []
    assert {r: summary["system"][r] for r in SIXTH} == SIXTH
    assert summary["system"]["plugins"] == [str(PARTS)]
    report = summary["log_completeness"]
    assert report["complete"] and report["missing"] == 0, report
    info = summarize(run / "run.mcap")
    robots = summary["robots"]
    for r in range(robots):
        topic = T.robot_topic(r, "detections")
        assert info.topics[topic].ros_type == "geometry_msgs/msg/PoseArray"
        assert info.topics[topic].message_count == STEPS
        assert report["topics"][topic] == {"expected": STEPS, "recorded": STEPS,
                                           "missing_steps": []}
        # The detections are the robot's estimates of the step, as poses.
        est = [target_positions(m.msg) for m in read_messages(
            run / "run.mcap", topics=[T.robot_topic(r, "estimates")])]
        poses = [np.array([(p.position.x, p.position.y) for p in m.msg.poses]).reshape(-1, 2)
                 for m in read_messages(run / "run.mcap", topics=[topic])]
        assert len(est) == len(poses) == STEPS
        for a, b in zip(est, poses, strict=True):
            np.testing.assert_array_equal(a, b)
    assert summary["messages_per_robot_per_step"] > 0, "beacons travelled"

    # evaluate.sh scores the log alone, as the monitor scored the run.
    res = subprocess.run([str(ROOT / "scripts" / "evaluate.sh"), str(run / "run.mcap"),
                          "--out", str(tmp_path / "eval"), "--no-plots"],
                         capture_output=True, text=True, timeout=180)
    assert res.returncode == 0, res.stderr
    ev = json.loads((tmp_path / "eval" / "evaluation.json").read_text())
    assert ev["ospa_series"] == summary["ospa_series"]
    assert ev["monitor_agreement"] == {"steps_compared": STEPS,
                                       "max_abs_ospa_difference": 0.0,
                                       "steps_only_in_evaluation": 0}
    assert ev["log_completeness"]["complete"]

    # The in-memory engine on the run's resolved config gives the same run, bit for bit.
    from phd_swarm.engines.distributed import DistributedEngine

    scenario = load_run_config(run / "config.yaml").scenario
    engine = DistributedEngine(scenario)
    series = []
    for k in range(STEPS):
        _, truth = engine.world.truth()
        engine.step()
        score = score_estimates(*engine.team_estimates(), truth, scenario.ospa_c,
                                scenario.ospa_p)
        series.append([k * scenario.dt, score.ospa])
    assert series == summary["ospa_series"]
    final = [m.msg for m in read_messages(run / "run.mcap", topics=[T.WORLD_ROBOTS])][-1]
    np.testing.assert_array_equal([(p.x, p.y) for p in final.positions],
                                  engine.world.robot_positions)
