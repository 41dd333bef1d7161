"""The launch files' glue (``phd_swarm.tools.launch_actions``; the ROS tests run it for real).

Launch arguments -> the run's plan, and the robots started once the observers are up.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from phd_swarm.config import load_run_config


@pytest.fixture
def LA(ros2_cli, monkeypatch):
    """:mod:`phd_swarm.tools.launch_actions`, importable with the ``ros2_cli`` environment.

    (``launch_ros`` imports composition_interfaces, which the wheels' install builds apart.)
    """
    import importlib

    for var, value in ros2_cli.env.items():
        monkeypatch.setenv(var, value)
    for path in reversed(ros2_cli.env.get("PYTHONPATH", "").split(":")):
        if path:
            monkeypatch.syspath_prepend(path)
    return importlib.import_module("phd_swarm.tools.launch_actions")


ROOT = Path(__file__).resolve().parents[2]


def _arguments(LA, tmp_path: Path, **values: str) -> dict[str, str]:
    out = {name: default or "" for name, (default, _) in LA.SWARM_ARGUMENTS.items()}
    out.update(config=str(ROOT / "config" / "dames_static.yaml"), out=str(tmp_path))
    out.update(values)
    return out


def test_the_arguments_make_run_swarms_plan_and_write_its_config(LA, tmp_path):
    plan = LA.plan_from_arguments(_arguments(LA, tmp_path, robots="3", seed="4", duration="2",
                                             robots_per_process="2", record="false"),
                                  {"ROS_DOMAIN_ID": "9"})
    assert plan.run_dir == tmp_path / "dames_static-phd-r3-s4"
    assert [p.name for p in plan.processes] == ["monitor", "robots_0-1", "robots_2-2",
                                               "world"]
    assert plan.env["ROS_DOMAIN_ID"] == "9"
    rc = load_run_config(plan.params)
    assert (rc.scenario.robots, rc.scenario.seed, rc.scenario.steps) == (3, 4, 4)
    assert rc.param("world", "observers") == 1


def test_with_a_hosts_layout_each_node_runs_on_its_host_with_its_hosts_profile(LA, tmp_path):
    layout = tmp_path / "hosts.yaml"
    layout.write_text("observers: base\nhosts:\n  base: {address: 10.1.0.1}\n"
                      "  field: {address: 10.1.0.2, run: [ip, netns, exec, field ns]}\n")
    plan = LA.plan_from_arguments(_arguments(LA, tmp_path, robots="2", hosts=str(layout)), {})
    assert {p.name: p.host for p in plan.processes} == {
        "recorder": "base", "monitor": "base", "robot_0": "field", "robot_1": "field",
        "world": "base"}
    for path, text in plan.files.items():
        assert path.read_text() == text
    from launch.launch_context import LaunchContext

    context = LaunchContext()

    def prefix(p) -> str:   # launch keeps it private: Executable.__prefix
        parts = LA.node_action(p).process_description._Executable__prefix
        return "".join(part.perform(context) for part in parts)

    assert prefix(plan.robots[0]) == "ip netns exec 'field ns'"   # one word, quoted
    assert prefix(plan.world) == ""
    env = dict((k[0].perform(context), v[0].perform(context))
               for k, v in LA.node_action(plan.robots[0]).additional_env)
    assert env["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(plan.run_dir / "dds" / "field.xml")


@pytest.mark.parametrize(("values", "message"), [
    ({"robots": "four"}, "robots: expected a number"),
    ({"record": "maybe"}, "record: expected true or false"),
    ({"dds": "udp"}, "dds: auto, localhost or profile"),
    ({"config": "nowhere.yaml"}, "nowhere.yaml: no such file"),
    ({"hosts": "nowhere.yaml"}, "hosts layout nowhere.yaml"),
])
def test_bad_arguments_are_named(LA, tmp_path, values, message):
    with pytest.raises(ValueError, match=message):
        LA.plan_from_arguments(_arguments(LA, tmp_path, **values), {})


def test_the_robots_start_once_every_observer_printed_its_up_marker(LA):
    from launch.actions import ExecuteProcess

    recorder, monitor = ExecuteProcess(cmd=["true"]), ExecuteProcess(cmd=["true"])
    gate = LA.WhenUp({recorder: "recording ", monitor: "monitor: watching "}, ["robots"],
                     60.0, "the robots")
    assert gate.output_seen(recorder, b"[recorder]: record") is None
    assert gate.output_seen(recorder, b"ing 41 topics\n") is None     # split across reads
    started = gate.output_seen(monitor, b"[monitor]: monitor: watching 4 robots\n")
    assert [type(a).__name__ for a in started] == ["OpaqueFunction"]
    assert gate.output_seen(monitor, b"again\n") is None                 # once only
    assert gate.start(SimpleNamespace(is_shutdown=False)) == ["robots"]
    assert gate.start(SimpleNamespace(is_shutdown=True)) is None          # Ctrl-C came first
    assert len(gate.actions()) == 5            # output and exit handlers per process, a timer
