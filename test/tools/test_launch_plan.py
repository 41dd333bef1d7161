"""The plan of a run: one list of processes for ``run_swarm.sh`` and the launch files.

``run_swarm`` starts exactly the plan's processes (checked with a recording stand-in for its
process handling); the plan's executables are the package's console scripts; the robots'
command lines are ``scripts/run_robot.sh``'s; DDS and the nodes' parameters are chosen as
before the plan existed (``test_run_swarm_dds.py`` and the ROS tests run the rest).
"""

from __future__ import annotations

import importlib
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from phd_swarm.config import load_run_config
from phd_swarm.nodes.world import EXIT_NOT_READY
from phd_swarm.tools import launch_plan as LP
from phd_swarm.tools import run_swarm
from phd_swarm.tools.dds import DDS_PROFILE
from phd_swarm.tools.hosts import load_layout

ROOT = Path(__file__).resolve().parents[2]
CONFIG = str(ROOT / "config" / "dames_static.yaml")


def _plan(tmp_path: Path, robots: int = 4, env: dict | None = None, **options):
    rc = LP.resolve_config(CONFIG, robots=robots, seed=3)
    return LP.swarm_plan(rc, tmp_path, LP.SwarmOptions(**options),
                         {"PATH": "/usr/bin"} if env is None else env)


def test_a_small_team_is_observers_then_one_process_per_robot_then_the_world(tmp_path):
    plan = _plan(tmp_path)
    assert [p.name for p in plan.processes] == [
        "recorder", "monitor", "robot_0", "robot_1", "robot_2", "robot_3", "world"]
    params = str(tmp_path / "config.yaml")
    robot = plan.robots[3]
    assert (robot.executable, robot.module, robot.node_name, robot.namespace) == (
        "robot", "phd_swarm.nodes.robot", "robot", "/robot_3")
    # What scripts/run_robot.sh passes, and what run_swarm passed before the plan.
    assert robot.argv() == ["--ros-args", "--params-file", params, "-r", "__ns:=/robot_3",
                            "-p", "robot_id:=3"]
    assert robot.up_marker == "robot 3: system "
    assert plan.world.argv() == ["--ros-args", "--params-file", params] and plan.world.echo
    assert [p.up_marker for p in plan.observers] == [LP.RECORDER_UP, LP.MONITOR_UP]
    assert plan.observers[0].stop_grace == LP.RECORDER_STOP_GRACE > LP.STOP_GRACE
    # Every node reads the run's parameters from the resolved file.
    assert plan.params == tmp_path / "config.yaml"
    rc = plan.rc
    assert rc.param("world", "observers") == rc.param("robot", "observers") == 2
    assert rc.param("monitor", "summary_path") == str(tmp_path / "summary.json")
    assert rc.param("monitor", "exit_when_done") is True
    assert rc.param("recorder", "output") == str(tmp_path / "run.mcap")
    assert rc.param("recorder", "params_file") == params
    assert rc.param("recorder", "discover") is False


def test_without_a_recorder_the_monitor_is_the_one_observer(tmp_path):
    plan = _plan(tmp_path, record=False)
    assert [p.name for p in plan.observers] == ["monitor"]
    assert plan.rc.param("world", "observers") == 1


def test_robots_per_process_groups_them_in_team_processes(tmp_path):
    plan = _plan(tmp_path, robots=7, robots_per_process=3)
    assert [(p.name, p.executable, p.arguments, p.up_marker) for p in plan.robots] == [
        ("robots_0-2", "team", ("--ids", "0-2"), "robot 2: system "),
        ("robots_3-5", "team", ("--ids", "3-5"), "robot 5: system "),
        ("robots_6-6", "team", ("--ids", "6-6"), "robot 6: system ")]
    team = plan.robots[0]
    assert team.node_name is None and team.namespace is None
    assert team.argv()[:3] == ["--ids", "0-2", "--ros-args"]


def test_dds_stays_on_loopback_and_large_runs_get_the_profile_and_a_server(tmp_path):
    small = _plan(tmp_path / "a", env={"ROS_DISCOVERY_SERVER": "1.2.3.4:1", "X": "1"})
    assert small.env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert small.env["ROS_DOMAIN_ID"] == LP.DEFAULT_DOMAIN_ID and small.env["X"] == "1"
    assert "ROS_DISCOVERY_SERVER" not in small.env and not small.use_server
    changes, unset = small.env_changes({"ROS_DISCOVERY_SERVER": "1.2.3.4:1", "X": "1"})
    assert unset == ["ROS_DISCOVERY_SERVER"] and changes["PYTHONUNBUFFERED"] == "1"
    mine = _plan(tmp_path / "b", env={"ROS_DOMAIN_ID": "7"})
    assert mine.env["ROS_DOMAIN_ID"] == "7"
    large = _plan(tmp_path / "c", robots=LP.AUTO_PROFILE_PROCESSES)
    assert large.use_server
    assert large.env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT"
    assert large.env["FASTDDS_DEFAULT_PROFILES_FILE"] == str(DDS_PROFILE)
    assert _plan(tmp_path / "d", dds="profile").env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == \
        "SYSTEM_DEFAULT"
    assert not _plan(tmp_path / "e", robots=40, discovery_server="off").use_server


class _Proc:
    pid = 0

    def __init__(self, code: int | None) -> None:
        self.returncode = code

    def poll(self):
        return self.returncode

    def wait(self, timeout=None):
        return self.returncode


class RecordingSwarm:
    """Stands in for :class:`phd_swarm.tools.processes.Swarm`: records what is started.

    The world exits at once with "not ready", so run_swarm stops there.
    """

    last: RecordingSwarm | None = None

    def __init__(self, run_dir, env, quiet, fork=False) -> None:
        self.env, self.quiet = dict(env), quiet
        self.procs: dict[str, _Proc] = {}
        self.started: list[tuple] = []
        self.cpu: dict[str, float] = {}
        self.memory: dict[str, float] = {}
        RecordingSwarm.last = self

    def start(self, name, module, ros_args, extra=(), echo=False, up_marker=None, nice=0,
              env=None, prefix=(), marks=None):
        self.started.append((name, module, [*extra, "--ros-args", *ros_args], up_marker,
                             echo, nice, tuple(prefix), dict(env or {})))
        self.procs[name] = _Proc(EXIT_NOT_READY if name == "world" else None)
        return self.procs[name]

    def wait_up(self, names, timeout):
        return []

    def is_up(self, name):
        return True

    def exited(self, prefix):
        return {}

    def sample(self, name):
        pass

    def sample_fork_server(self):
        pass

    def stop_many(self, names, grace):
        pass

    def stop_all(self, grace=5.0):
        pass


#: A layout of two hosts for run_swarm --hosts (no prefix: the recording swarm starts
#: nothing).
LAYOUT = """discovery: peers
observers: base
hosts:
  base: {address: 127.0.0.2}
  field: {address: 127.0.0.3, run: [ip, netns, exec, field]}
"""


@pytest.mark.parametrize("extra", [[], ["--robots-per-process", "2", "--no-record"],
                                   ["--robots-per-process", "2", "--hosts", "LAYOUT"]])
def test_run_swarm_starts_the_plans_processes(tmp_path, monkeypatch, capsys, extra):
    monkeypatch.setattr(run_swarm, "Swarm", RecordingSwarm)
    monkeypatch.setenv("ROS_DOMAIN_ID", "150")
    if "LAYOUT" in extra:
        (tmp_path / "hosts.yaml").write_text(LAYOUT)
        extra = [str(tmp_path / "hosts.yaml") if a == "LAYOUT" else a for a in extra]
    opts = run_swarm.parse_args([CONFIG, "--robots", "5", "--seed", "3", "--out",
                                 str(tmp_path), "--name", "x", "--quiet", *extra])
    assert run_swarm.run(opts) == EXIT_NOT_READY
    swarm = RecordingSwarm.last
    run_dir = tmp_path / "x"
    plan = LP.swarm_plan(run_swarm.resolve(opts), run_dir, LP.SwarmOptions(
        robots_per_process=opts.robots_per_process, record=not opts.no_record,
        hosts=None if opts.hosts is None else load_layout(opts.hosts)))
    assert swarm.started == [(p.name, p.module, p.argv(), p.up_marker, p.echo, p.nice,
                              p.prefix, dict(p.env)) for p in plan.processes]
    for path, text in plan.files.items():
        assert path.read_text() == text
    assert swarm.env == plan.env and swarm.env["ROS_DOMAIN_ID"] == "150"
    assert load_run_config(run_dir / "config.yaml").nodes == plan.rc.nodes
    assert "start-up failed" in capsys.readouterr().err


def _console_scripts() -> dict[str, str]:
    text = (ROOT / "setup.py").read_text()
    return dict(re.findall(r'"(\w+) = ([\w.]+:\w+)"', text))


def test_every_executable_is_a_console_script_of_a_main():
    scripts = _console_scripts()
    plan = {**LP.NODE_EXECUTABLES, **LP.TOOL_EXECUTABLES}
    assert scripts == {name: f"{module}:main" for name, module in plan.items()}
    for target in scripts.values():
        module, func = target.split(":")
        assert callable(getattr(importlib.import_module(module), func)), target
    # Installed where `ros2 run` looks: lib/<package>/ (the ament_python convention).
    cfg = (ROOT / "setup.cfg").read_text()
    assert "script_dir=$base/lib/phd_swarm" in cfg and "install_scripts=$base/lib/phd_swarm" \
        in cfg


def test_the_launch_files_are_installed_and_their_dependencies_declared():
    assert '(f"share/{PACKAGE}/launch", glob("launch/*.launch.py"))' in \
        (ROOT / "setup.py").read_text()
    files = sorted(p.name for p in (ROOT / "launch").glob("*.launch.py"))
    assert files == ["robot.launch.py", "swarm.launch.py", "world.launch.py"]
    depends = {e.text for e in ET.parse(ROOT / "package.xml").getroot().iter("exec_depend")}
    assert {"launch", "launch_ros"} <= depends


def test_a_config_is_found_by_path_or_among_the_installed_ones(tmp_path, monkeypatch):
    assert LP.find_config(CONFIG) == Path(CONFIG)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match="nowhere.yaml: no such file"):
        LP.find_config("nowhere.yaml")
    try:
        found = LP.find_config("dames_static.yaml")
    except ValueError:
        pytest.skip("phd_swarm is not installed (scripts/setup.sh) on AMENT_PREFIX_PATH")
    assert found.name == "dames_static.yaml" and found.parent.parts[-2:] == ("phd_swarm",
                                                                            "config")


def test_the_run_swarm_overrides_are_the_plans(tmp_path):
    rc = LP.resolve_config(CONFIG, robots=3, targets=7, duration=4.0, seed=9,
                           controller="uniform", realtime=True, robot={"fault_drop": 0.1})
    s = rc.scenario
    assert (s.robots, s.targets.count, s.steps, s.seed) == (3, 7, 8, 9)
    assert s.system.controller == "uniform" and rc.param("world", "mode") == "realtime"
    assert rc.param("robot", "fault_drop") == 0.1
    assert LP.run_name(rc) == f"dames_static-{s.system.label()}-r3-s9"
    with pytest.raises(ValueError, match="command-line override"):
        LP.resolve_config(CONFIG, robots=0)
    first = LP.fresh_run_dir(tmp_path, "r")
    assert LP.fresh_run_dir(tmp_path, "r") == tmp_path / "r-2" and first == tmp_path / "r"


def test_finish_summary_adds_the_runs_fields(tmp_path):
    rc = LP.resolve_config(CONFIG, robots=2, duration=1.0)
    summary = {"steps": 2, "ospa_final": 1.0}
    assert LP.finish_summary(summary, rc, tmp_path) is None        # no log
    assert summary["complete"] and summary["log_completeness"] is None
    assert summary["controller"] == rc.scenario.system.controller
    assert summary["mode"] == "lockstep" and summary["run_dir"] == str(tmp_path)
    json.dumps(summary)


def test_single_nodes_keep_dds_on_loopback_unless_the_caller_chose():
    assert LP.node_env({}) == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                               "ROS_DOMAIN_ID": "42", "PYTHONUNBUFFERED": "1"}
    mine = LP.node_env({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "ROS_DOMAIN_ID": "3"})
    assert mine["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET" and mine["ROS_DOMAIN_ID"] == "3"


def test_real_time_robots_hold_their_own_verdicts_for_the_worlds_step_timeout():
    from phd_swarm.tools.launch_plan import resolve_config

    config = ROOT / "config" / "dames_static.yaml"
    assert resolve_config(config).param("robot", "revive_every") == 1
    # 15 s of step timeout at 0.5 s steps: the team's epochs are 30 steps apart.
    assert resolve_config(config, realtime=True).param("robot", "revive_every") == 30
    kept = resolve_config(config, realtime=True, robot={"revive_every": 4})
    assert kept.param("robot", "revive_every") == 4


def test_a_real_time_monitor_awaits_reports_for_the_worlds_verdict_window(tmp_path):
    import yaml

    from phd_swarm.nodes.completeness import verdict_window
    from phd_swarm.tools.launch_plan import resolve_config

    config = ROOT / "config" / "dames_static.yaml"
    assert resolve_config(config).param("monitor", "verdict_window") == 1
    realtime = resolve_config(config, realtime=True)
    # 15 s of step timeout at 0.5 s steps, plus one (nodes/completeness.py).
    assert realtime.param("monitor", "verdict_window") == verdict_window(realtime) == 31
    # A window of the config's own is kept.
    doc = yaml.safe_load(config.read_text())
    doc.setdefault("monitor", {}).setdefault("ros__parameters", {})["verdict_window"] = 3
    mine = tmp_path / "mine.yaml"
    mine.write_text(yaml.safe_dump(doc))
    assert resolve_config(mine, realtime=True).param("monitor", "verdict_window") == 3
