"""``ros2 launch phd_swarm swarm.launch.py`` and the ``ros2`` CLI on a live run (issue 36).

With the real tools (the ``ros2_cli`` fixture says which: a native install's, or the wheels
of ../shared/ros2-cli): the package's executables are listed; a launched team runs in
lockstep exactly as ``run_swarm.sh`` runs it (the same summary and, step by step, the same
team PHD); Ctrl-C on ``ros2 launch`` stops every process of the run within 10 s; and
``ros2 node list``, ``ros2 topic hz`` and ``ros2 param get`` see a live launched run. Every
process stays on loopback on a ROS_DOMAIN_ID of its test's own (the ``children`` fixture).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from phd_swarm.logs.mcap_log import read_messages, summarize
from phd_swarm.tools.launch_plan import NODE_EXECUTABLES, TOOL_EXECUTABLES, resolve_config
from phd_swarm.tools.run_swarm import WALL_CLOCK_FIELDS

pytestmark = [pytest.mark.ros]

ROOT = Path(__file__).resolve().parents[2]
CONFIG = str(ROOT / "config" / "dames_static.yaml")
ROBOTS = 4


def _env(ros2_cli, tmp_path: Path) -> dict[str, str]:
    """The CLI's environment, with the ROS logs (launch's and the nodes') in ``tmp_path``."""
    return {**ros2_cli.env, "ROS_LOG_DIR": str(tmp_path / "ros_log")}


def _launch(children, ros2_cli, tmp_path: Path, name: str, *args: str):
    """``ros2 launch phd_swarm swarm.launch.py config:=dames_static ARGS`` into ``tmp_path/name``.

    Its output goes to ``tmp_path/<name>.out`` (a pipe nobody reads would fill up).
    """
    out = open(tmp_path / f"{name}.out", "w")  # noqa: SIM115 (the child holds it)
    try:
        return children.start(
            ros2_cli("launch", "phd_swarm", "swarm.launch.py", f"config:={CONFIG}",
                     f"robots:={ROBOTS}", f"out:={tmp_path}", f"name:={name}", *args),
            env=_env(ros2_cli, tmp_path), stdout=out, stderr=subprocess.STDOUT, cwd=str(ROOT))
    finally:
        out.close()


def _wait_until(condition: Callable[[], bool], what: str, proc, timeout: float = 120.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert proc.poll() is None, f"the launch ended (code {proc.returncode}) before {what}"
        assert time.monotonic() < deadline, f"no {what} within {timeout:g} s"
        time.sleep(0.2)


def _output(tmp_path: Path, name: str) -> str:
    return (tmp_path / f"{name}.out").read_text(errors="replace")


def _session(leader: int) -> list[int]:
    """PIDs of the processes in the session of ``leader`` (the launch and its children)."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == leader and fields[0] != "Z":
            out.append(int(entry.name))
    return out


def test_ros2_pkg_executables_lists_the_nodes_and_tools(ros2_cli, tmp_path):
    res = subprocess.run(ros2_cli("pkg", "executables", "phd_swarm"), capture_output=True,
                         text=True, timeout=60, env={**os.environ, **_env(ros2_cli, tmp_path)})
    assert res.returncode == 0, f"{ros2_cli.origin}\n{res.stderr}"
    listed = {line.split()[1] for line in res.stdout.splitlines() if line.strip()}
    assert listed == set(NODE_EXECUTABLES) | set(TOOL_EXECUTABLES), ros2_cli.origin
    args = subprocess.run(ros2_cli("launch", "phd_swarm", "swarm.launch.py", "--show-args"),
                          capture_output=True, text=True, timeout=60,
                          env={**os.environ, **_env(ros2_cli, tmp_path)})
    assert args.returncode == 0, args.stderr
    for name in ("config", "robots", "targets", "seed", "realtime", "record",
                 "robots_per_process", "out"):
        assert f"'{name}':" in args.stdout, name


@pytest.mark.slow
def test_a_launched_team_runs_in_lockstep_as_run_swarm_does(tmp_path, children, ros2_cli):
    """4 robots, 16 steps, seed 3: the same summary and team PHD as ``run_swarm.sh``."""
    options = {"targets": "10", "duration": "8", "seed": "3"}
    script = children.start([str(ROOT / "scripts" / "run_swarm.sh"), CONFIG, "--robots",
                             str(ROBOTS), *(a for k, v in options.items() for a in (f"--{k}", v)),
                             "--out", str(tmp_path), "--name", "script", "--quiet"])
    out, err = script.communicate(timeout=240)
    assert script.returncode == 0, f"{out}\n{err}"

    started = time.monotonic()
    launch = _launch(children, ros2_cli, tmp_path, "launched",
                     *(f"{k}:={v}" for k, v in options.items()))
    launch.wait(timeout=240)
    print(f"ros2 launch ({ros2_cli.origin}): 16 steps in {time.monotonic() - started:.1f} s")
    text = _output(tmp_path, "launched")
    assert launch.returncode == 0, text

    run, ref = tmp_path / "launched", tmp_path / "script"
    summary = json.loads((run / "summary.json").read_text())
    assert summary["steps"] == 16 and summary["complete"] and summary["dead_robots"] == []
    report = summary["log_completeness"]
    assert report["complete"] and report["missing"] == 0 and report["steps"] == 16, report
    info = summarize(run / "run.mcap")
    assert not info.truncated and (run / "metadata.yaml").exists()
    counts = {t: s.message_count for t, s in info.topics.items()}
    assert counts["/world/truth"] == counts["/monitor/metrics"] == 16
    for i in range(ROBOTS):
        assert counts[f"/robot_{i}/measurements"] == counts[f"/robot_{i}/density"] == 16
        assert report["topics"][f"/robot_{i}/status"]["recorded"] == 16

    expected = json.loads((ref / "summary.json").read_text())
    for key in WALL_CLOCK_FIELDS:
        summary.pop(key, None)
        expected.pop(key, None)
    assert summary == expected
    # The team PHD, step by step, to the bit (the messages' bytes: grid, stamp, step).
    team = [r.data for r in read_messages(run / "run.mcap", ["/monitor/density"], decode=False)]
    same = [r.data for r in read_messages(ref / "run.mcap", ["/monitor/density"], decode=False)]
    assert len(team) == 16 and team == same
    # The robots ran as launch_ros nodes, each in its namespace, from the run's config.
    for i in range(ROBOTS):
        assert f"[robot_{i}.robot]: robot {i}: system " in text
    assert "ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST" in text


@pytest.mark.slow
def test_ctrl_c_on_ros2_launch_stops_every_process_within_10_s(tmp_path, children, ros2_cli):
    launch = _launch(children, ros2_cli, tmp_path, "interrupted", "duration:=600")
    _wait_until(lambda: "step 21/" in _output(tmp_path, "interrupted"), "step 21", launch)
    before = _session(launch.pid)
    # the launch itself, the recorder, the monitor, the robots and the world
    assert len(before) >= ROBOTS + 4, before
    started = time.monotonic()
    launch.send_signal(signal.SIGINT)
    try:
        launch.wait(timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail(f"ros2 launch still runs 60 s after SIGINT:\n"
                    f"{_output(tmp_path, 'interrupted')[-3000:]}")
    # Its children may outlive it by a moment: wait for them, as long as the 10 s allow.
    while _session(launch.pid) and time.monotonic() - started < 10.0:
        time.sleep(0.05)
    stopped = time.monotonic() - started
    left = _session(launch.pid)
    print(f"ros2 launch ({ros2_cli.origin}) and its {len(before) - 1} processes stopped "
          f"{stopped:.1f} s after SIGINT")
    assert left == [], f"still running {stopped:.1f} s after SIGINT: {left}"
    assert stopped < 10.0
    run = tmp_path / "interrupted"
    assert not summarize(run / "run.mcap").truncated, "the recorder closed the log"
    assert (run / "metadata.yaml").exists()
    summary = json.loads((run / "summary.json").read_text())
    assert 20 <= summary["steps"] < 1200 and not summary["complete"]


@pytest.mark.slow
def test_the_world_and_robot_launch_files_make_a_team(tmp_path, children, ros2_cli):
    """``world.launch.py`` and two ``robot.launch.py``, as run_world.sh and run_robot.sh."""
    config = resolve_config(CONFIG, robots=2, targets=5, duration=2.0, seed=3).write_params(
        tmp_path / "team.yaml")
    env = _env(ros2_cli, tmp_path)
    procs = {}
    for name, args in [*((f"robot_{i}", ("robot.launch.py", f"robot_id:={i}"))
                         for i in range(2)), ("world", ("world.launch.py",))]:
        with open(tmp_path / f"{name}.out", "w") as sink:
            procs[name] = children.start(
                ros2_cli("launch", "phd_swarm", *args, f"config:={config}"), env=env,
                stdout=sink, stderr=subprocess.STDOUT)
    try:
        procs["world"].wait(timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the world did not finish:\n{_output(tmp_path, 'world')[-3000:]}")
    world = _output(tmp_path, "world")
    assert "world: done, 4 steps" in world and "dead robots: none" in world, world
    for i in range(2):
        children.stop(procs[f"robot_{i}"])
        assert f"[robot_{i}.robot]: robot {i}: system " in _output(tmp_path, f"robot_{i}")


def cli_answer(children, argv: list[str], env: dict[str, str], out_file: Path,
               answered: Callable[[str], bool], timeout: float = 60.0) -> str:
    """The output of a short ``ros2`` command once it holds its answer.

    ``ros2 param get`` printed the right value and then hung in its own teardown
    (``DirectNode.__exit__``: destroying its node and shutting rclpy down) once in a CI run
    (2026-12-05), not reproduced in 70 further calls, under load or not. What these tests
    check is the answer the CLI got from our nodes, so this waits for ``answered(output)``
    (or the command's end), gives it 10 s to exit, and stops it by PID if it has not; a
    command that ends without the answer fails the test with its output.
    """
    with open(out_file, "w") as sink:
        proc = children.start(argv, env=env, stdout=sink, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + timeout
    while not answered(out_file.read_text(errors="replace")) and proc.poll() is None:
        assert time.monotonic() < deadline, \
            f"{' '.join(argv[1:])}: no answer within {timeout:g} s:\n{out_file.read_text()}"
        time.sleep(0.1)
    try:
        proc.wait(timeout=10.0)
    except subprocess.TimeoutExpired:
        print(f"{' '.join(argv[1:])}: answered, then did not exit within 10 s (stopped)")
        children.stop(proc)
    return out_file.read_text(errors="replace")


def check_diagnostics_echo(ros2_cli, env: dict[str, str], children, tmp_path: Path) -> None:
    """``ros2 topic echo --once /diagnostics`` prints one DiagnosticArray of the run."""
    out = cli_answer(children, ros2_cli("topic", "echo", "--once", "--no-daemon", "/diagnostics",
                                        "diagnostic_msgs/msg/DiagnosticArray"), env,
                     tmp_path / "echo.out", lambda text: "status:" in text and "---" in text)
    assert "status:" in out, out


@pytest.mark.slow
def test_the_ros2_cli_sees_a_live_launched_run(tmp_path, children, ros2_cli):
    launch = _launch(children, ros2_cli, tmp_path, "live", "duration:=600", "realtime:=true")
    _wait_until(lambda: f"all {ROBOTS} robots and 2 observers ready" in
                _output(tmp_path, "live"), "ready team", launch)
    env = _env(ros2_cli, tmp_path)

    expected = {"/world", "/monitor", "/recorder", *(f"/robot_{i}/robot" for i in range(ROBOTS))}
    nodes: set[str] = set()
    deadline = time.monotonic() + 90.0
    # Each try is a new participant: 5 s to discover the run's 7 (2 s missed robots once,
    # on a loaded machine).
    while nodes != expected and time.monotonic() < deadline:
        out = cli_answer(children, ros2_cli("node", "list", "--no-daemon", "--spin-time", "5"),
                         env, tmp_path / "nodes.out",
                         lambda text: {line.strip() for line in text.splitlines()} >= expected)
        nodes = {line.strip() for line in out.splitlines() if line.strip()}
    assert nodes == expected, f"ros2 node list ({ros2_cli.origin}): {sorted(nodes)}"

    # ``ros2 topic hz`` prints a rate once a second until stopped.
    hz_out = tmp_path / "hz.out"
    with open(hz_out, "w") as sink:
        hz = children.start(ros2_cli("topic", "hz", "/robot_1/status"), env=env, stdout=sink,
                            stderr=subprocess.STDOUT)
    _wait_until(lambda: "average rate:" in hz_out.read_text(), "rate from ros2 topic hz",
                launch, timeout=60.0)
    children.stop(hz)
    rate = float(re.search(r"average rate: ([0-9.]+)", hz_out.read_text()).group(1))
    assert rate > 0.0

    for name, value in (("robot_id", "2"), ("scenario.robots", str(ROBOTS))):
        answer = f"Integer value is: {value}"
        out = cli_answer(children, ros2_cli("param", "get", "--no-daemon", "--spin-time", "2",
                                            "--timeout", "30", "/robot_2/robot", name),
                         env, tmp_path / f"param_{name}.out",
                         lambda text, answer=answer: answer in text)
        assert out.strip() == answer, out

    check_diagnostics_echo(ros2_cli, env, children, tmp_path)
    assert launch.poll() is None, "the run went on while the CLI looked at it"
    launch.send_signal(signal.SIGINT)
    launch.wait(timeout=60)
    print(f"ros2 CLI ({ros2_cli.origin}): nodes {sorted(nodes)}, /robot_1/status at "
          f"{rate:.2f} Hz")
