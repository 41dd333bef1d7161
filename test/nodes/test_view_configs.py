"""The shipped viewer configs parse and name only topics a run has, with types and QoS that fit.

``config/rviz/swarm.rviz`` is RViz2's YAML, ``config/foxglove/swarm.json`` a Foxglove layout
(JSON). Neither viewer runs here, so the test reads them as files: every topic they name
must be in the topic table of a Dames run (:func:`phd_swarm.nodes.topics.run_topics` with
its declared outputs), each RViz2 display must take the topic's type, and a display's QoS
must match what the topic's writer offers.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

from phd_swarm.config import load_run_config
from phd_swarm.config.node_params import SHARED
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.qos import publisher_qos

ROOT = Path(__file__).resolve().parents[2]
RVIZ = ROOT / "config" / "rviz" / "swarm.rviz"
FOXGLOVE = ROOT / "config" / "foxglove" / "swarm.json"

#: The message type each RViz2 display class used takes.
RVIZ_TYPES = {
    "rviz_default_plugins/Map": "nav_msgs/msg/OccupancyGrid",
    "rviz_default_plugins/MarkerArray": "visualization_msgs/msg/MarkerArray",
    "rviz_default_plugins/Pose": "geometry_msgs/msg/PoseStamped",
}


@pytest.fixture(scope="module")
def table() -> dict[str, T.TopicSpec]:
    """The topics of a run of config/dames_static.yaml, by name."""
    s = load_run_config(ROOT / "config" / "dames_static.yaml").scenario
    return {t.name: t for t in T.run_topics(range(s.robots), T.declared_outputs(s.system))}


def _displays(displays: list[dict]) -> Iterator[dict]:
    for d in displays:
        yield d
        yield from _displays(d.get("Displays", []))      # rviz_common/Group


def _topic_fields(node: object) -> Iterator[dict]:
    """Every ``...Topic:`` mapping of an RViz2 config (displays, tools), wherever it is."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key.endswith("Topic") and isinstance(value, dict):
                yield value
            yield from _topic_fields(value)
    elif isinstance(node, list):
        for value in node:
            yield from _topic_fields(value)


def _named(node: object) -> Iterator[str]:
    """Every topic a Foxglove layout names: keys and strings starting with '/'.

    A message path (``/monitor/metrics.ospa``) names the topic before its first dot.
    """
    if isinstance(node, dict):
        for key, value in node.items():
            if key.startswith("/"):
                yield key
            yield from _named(value)
    elif isinstance(node, list):
        for value in node:
            yield from _named(value)
    elif isinstance(node, str) and node.startswith("/"):
        yield node.split(".", 1)[0]


def test_the_rviz_config_shows_the_team_from_the_run_s_topics(table):
    config = yaml.safe_load(RVIZ.read_text())
    manager = config["Visualization Manager"]
    frame = next(p.default for p in SHARED if p.name == "world_frame_id")
    assert manager["Global Options"]["Fixed Frame"] == frame
    assert manager["Views"]["Current"]["Class"] == "rviz_default_plugins/TopDownOrtho"
    shown = {}
    for d in _displays(manager["Displays"]):
        if "Topic" in d:
            shown[d["Topic"]["Value"]] = d
    assert {T.MONITOR_DENSITY_GRID, T.WORLD_MARKERS, T.MONITOR_MARKERS} <= set(shown)
    assert shown[T.MONITOR_DENSITY_GRID]["Enabled"] is True
    for topic, d in shown.items():
        assert topic in table, f"{RVIZ.name}: {d['Name']} shows {topic}, not a run's topic"
        spec = table[topic]
        assert RVIZ_TYPES[d["Class"]] == spec.type, (topic, d["Class"])
        offered = publisher_qos(spec.qos)
        qos = d["Topic"]
        if qos["Reliability Policy"] == "Reliable":
            assert offered.reliability == ReliabilityPolicy.RELIABLE, topic
        if qos["Durability Policy"] == "Transient Local":
            assert offered.durability == DurabilityPolicy.TRANSIENT_LOCAL, topic
    # every topic named anywhere (tools included) is a run's topic
    for field in _topic_fields(config):
        assert field["Value"] in table, field
    world = next(d for d in shown.values() if d["Topic"]["Value"] == T.WORLD_MARKERS)
    team = next(d for d in shown.values() if d["Topic"]["Value"] == T.MONITOR_MARKERS)
    assert {"robots", "robot_ids", "fov", "targets"} <= set(world["Namespaces"])
    assert {"cells", "goals", "estimates"} <= set(team["Namespaces"])


def test_the_foxglove_layout_shows_the_team_from_the_run_s_topics(table):
    layout = json.loads(FOXGLOVE.read_text())
    panels = layout["configById"]
    scene = next(c for key, c in panels.items() if key.startswith("3D!"))
    assert {T.MONITOR_DENSITY_GRID, T.WORLD_MARKERS, T.MONITOR_MARKERS} <= set(scene["topics"])
    assert scene["topics"][T.MONITOR_DENSITY_GRID]["visible"] is True
    diagnostics = next(c for key, c in panels.items() if key.startswith("DiagnosticSummary!"))
    assert diagnostics["topicToRender"] == T.DIAGNOSTICS
    named = set(_named(panels))
    assert T.DIAGNOSTICS in named and "/monitor/metrics" in named
    assert named <= set(table), f"not a run's topic: {sorted(named - set(table))}"

    def leaves(node: str | dict) -> Iterator[str]:
        if isinstance(node, str):
            yield node
        else:
            yield from leaves(node["first"])
            yield from leaves(node["second"])

    assert set(leaves(layout["layout"])) == set(panels), (
        "the layout places every configured panel, no other")
