"""A team over three hosts (network namespaces on a bridge), and a cut link.

Each host is a network namespace made by the test (:class:`phd_swarm.tools.netns.HostNetwork`),
with an address on a private subnet on a bridge in a namespace of its own; nothing is
added to the machine's own network namespace, and the namespaces (and every process left
in them) are removed in a ``finally`` even when a test fails. Needs root: without it the
tests fail, naming why.
"""

from __future__ import annotations

import json
import re
import subprocess
import time
from pathlib import Path

import pytest
import yaml

from phd_swarm.logs.mcap_log import read_messages, read_metadata, summarize
from phd_swarm.nodes.completeness import verdict_window
from phd_swarm.tools.hosts import load_layout
from phd_swarm.tools.launch_plan import resolve_config
from phd_swarm.tools.netns import HostNetwork
from phd_swarm.tools.run_swarm import WALL_CLOCK_FIELDS

from .test_scripts import _config as _two_robots

ROOT = Path(__file__).resolve().parents[2]
RUN_SWARM = str(ROOT / "scripts" / "run_swarm.sh")
CONFIG = ROOT / "config" / "dames_static.yaml"
ROBOTS = 4
HOSTS = ("base", "field1", "field2")

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.full]


def _layout(net: HostNetwork, path: Path, discovery: str = "peers") -> Path:
    """The layout of ``net``: observers on base, the robots spread over field1 and field2."""
    path.write_text(yaml.safe_dump({
        "discovery": discovery, "observers": "base",
        "hosts": {n: {"address": h.address, "run": list(h.prefix)}
                  for n, h in net.hosts.items()}}))
    return path


def _run(children, out: Path, name: str, *extra: str, config: Path = CONFIG):
    return children.start([RUN_SWARM, str(config), "--robots", str(ROBOTS), "--targets", "10",
                           "--seed", "3", "--out", str(out), "--name", name, *extra])


def _finish(children, proc, timeout: float = 300.0) -> str:
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        children.stop(proc)
        raise
    assert proc.returncode == 0, f"run_swarm failed:\n{out}\n{err}"
    return out


def _bound_addresses(net: HostNetwork) -> dict[str, set[str]]:
    """Host -> the local addresses of the UDP sockets open in its namespace now."""
    out = {}
    for name, host in net.hosts.items():
        text = subprocess.run(host.command(["ss", "-uanH"]), capture_output=True, text=True,
                              timeout=10).stdout
        out[name] = {line.split()[3].rsplit(":", 1)[0] for line in text.splitlines()}
    return out


def _comparable(run: Path) -> dict:
    summary = json.loads((run / "summary.json").read_text())
    for key in WALL_CLOCK_FIELDS:
        summary.pop(key, None)
    return summary


@pytest.mark.parametrize("discovery", ["peers", "server"])
def test_a_team_over_three_hosts_equals_the_one_host_run_bit_for_bit(tmp_path, children,
                                                                     discovery):
    with HostNetwork(HOSTS) as net:
        layout = _layout(net, tmp_path / "hosts.yaml", discovery)
        proc = _run(children, tmp_path, "hosts", "--duration", "8", "--hosts", str(layout))
        # Every DDS socket of every process is bound to its host's own address.
        seen: dict[str, set[str]] = {h: set() for h in HOSTS}
        while proc.poll() is None:
            for host, addresses in _bound_addresses(net).items():
                seen[host] |= addresses
            time.sleep(0.2)
        out = _finish(children, proc)
        for host in HOSTS:
            assert seen[host] == {net[host].address}, (host, seen)
    assert "hosts base (" in out and f"discovery {discovery}" in out
    assert "field1 (" in out and "2 robot processes" in out
    alone = _run(children, tmp_path, "alone", "--duration", "8")
    _finish(children, alone)

    run, ref = tmp_path / "hosts", tmp_path / "alone"
    summary = _comparable(run)
    assert summary["steps"] == 16 and summary["complete"] and summary["dead_robots"] == []
    assert summary["log_completeness"]["complete"], summary["log_completeness"]
    assert summary == _comparable(ref)
    # The team PHD, step by step, to the bit.
    team = [r.data for r in read_messages(run / "run.mcap", ["/monitor/density"], decode=False)]
    same = [r.data for r in read_messages(ref / "run.mcap", ["/monitor/density"], decode=False)]
    assert len(team) == 16 and team == same


def test_robots_started_by_hand_on_their_hosts_join_a_world_on_another(tmp_path, children):
    """docs/deployment.md's recipe: each host's profile, then run_robot.sh there."""
    config = _two_robots(tmp_path)
    with HostNetwork(HOSTS) as net:
        layout = load_layout(_layout(net, tmp_path / "hosts.yaml"))

        def on(host: str, argv: list[str]):
            profile = tmp_path / f"{host}.xml"
            profile.write_text(layout.profile(host))
            env = {"FASTRTPS_DEFAULT_PROFILES_FILE": str(profile),
                   "ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT"}
            return children.start(net[host].command(argv), env=env)

        log = tmp_path / "hand.mcap"
        recorder = on("base", [str(ROOT / "scripts" / "record.sh"), str(log), str(config)])
        robots = [on(host, [str(ROOT / "scripts" / "run_robot.sh"), str(i), str(config)])
                  for i, host in enumerate(("field1", "field2"))]
        world = on("base", [str(ROOT / "scripts" / "run_world.sh"), str(config)])
        try:
            out, err = world.communicate(timeout=180.0)
        except subprocess.TimeoutExpired:
            children.stop(world)
            raise
        time.sleep(0.5)
        for proc in (recorder, *robots):
            children.stop(proc)
    assert world.returncode == 0, out + err
    assert "done, 8 steps" in out + err and "dead robots: none" in out + err, out + err
    assert summarize(log).topics["/world/truth"].message_count == 8
    report = json.loads(read_metadata(log)["phd_swarm.completeness"]["report"])
    assert report["complete"] and report["steps"] == 8, report


def _wait_for(predicate, what: str, proc, timeout: float = 240.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert proc.poll() is None, f"run_swarm ended before {what}"
        assert time.monotonic() < deadline, f"no {what} within {timeout:g} s"
        time.sleep(0.05)


def _log(run: Path, name: str) -> str:
    path = run / "logs" / f"{name}.log"
    return path.read_text() if path.exists() else ""


def _short_timeouts(tmp_path: Path) -> Path:
    """dames_static with a 3 s step timeout and 0.5 s protocol rounds (faster verdicts)."""
    cfg = yaml.safe_load(CONFIG.read_text())
    cfg["world"]["ros__parameters"]["step_timeout"] = 3.0
    cfg["/**/robot"]["ros__parameters"]["tick_period"] = 0.5
    cfg["monitor"]["ros__parameters"]["progress_every"] = 10
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def _lines_between(text: str, start: float, end: float) -> list[str]:
    """The log lines stamped (ROS log wall time) within [start, end]."""
    out = []
    for line in text.splitlines():
        m = re.search(r"\] \[(\d+\.\d+)\]", line)
        if m and start <= float(m.group(1)) <= end:
            out.append(line.split("]: ", 1)[-1])
    return out


@pytest.mark.parametrize("mode", ["lockstep", "realtime"])
def test_a_cut_link_takes_a_hosts_robots_out_and_they_rejoin_when_it_is_back(
        tmp_path, children, mode):
    config = _short_timeouts(tmp_path)
    # Lockstep: long enough that the run outlasts the cut on any machine; realtime: 60 s.
    duration = "400" if mode == "lockstep" else "60"
    extra = ["--realtime"] if mode == "realtime" else []
    run = tmp_path / mode
    with HostNetwork(HOSTS) as net:
        layout = _layout(net, tmp_path / "hosts.yaml")
        proc = _run(children, tmp_path, mode, "--duration", duration, "--hosts", str(layout),
                    *extra, config=config)
        _wait_for(lambda: "step 21/" in _log(run, "monitor"), "step 21", proc)
        cut_at = time.time()
        net.cut("field2")  # robots 2 and 3
        _wait_for(lambda: "dead: 2-3" in _log(run, "world"), "robots 2-3 counted dead", proc,
                  timeout=60)
        time.sleep(3.0)
        net.restore("field2")
        restored_at = time.time()
        out = _finish(children, proc)
    world = _log(run, "world")
    # What each side saw during the cut (printed with the test's output).
    print(f"cut at {cut_at:.3f}, restored at {restored_at:.3f}")
    for name in ("world", "robot_0", "robot_2"):
        for line in _lines_between(_log(run, name), cut_at, restored_at + 5.0):
            print(f"{name}: {line}")
    assert re.search(r"robot 2 did not report step \d+ and was not heard from", world)
    assert re.search(r"robot 3 did not report step \d+ and was not heard from", world)
    assert "robot 2 rejoins the team at step" in world
    assert "robot 3 rejoins the team at step" in world
    assert re.search(r"robot 0: .*(\[2\]|\[2, 3\]|\[3\]).* dead", _log(run, "robot_0"))
    assert "rejoined the team at step" in _log(run, "robot_2")

    summary = json.loads((run / "summary.json").read_text())
    assert summary["complete"] and summary["dead_robots"] == []
    assert summary["rejoined_robots"] == [2, 3]
    report = summary["log_completeness"]
    assert report["complete"] and report["missing"] == 0, report
    steps = summary["steps"]

    # The log shows the cut as gaps of robots 2 and 3; nothing of robots 0 and 1 is lost.
    evaluated = subprocess.run(["bash", str(ROOT / "scripts" / "evaluate.sh"), str(run),
                                "--no-plots"], capture_output=True, text=True, timeout=300)
    assert evaluated.returncode == 0, evaluated.stderr
    assert re.search(r"out of the team: robot 2 steps \d+-\d+ \(rejoined at \d+\); "
                     r"robot 3 steps \d+-\d+ \(rejoined at \d+\)", evaluated.stdout) or \
        re.search(r"out of the team: robot 3 steps \d+-\d+ \(rejoined at \d+\); "
                  r"robot 2 steps \d+-\d+ \(rejoined at \d+\)", evaluated.stdout), \
        evaluated.stdout
    absences = json.loads((run / "evaluation" / "evaluation.json").read_text())["absences"]
    assert sorted(a["robot"] for a in absences) == [2, 3]
    counts = {t: s.message_count for t, s in summarize(run / "run.mcap").topics.items()}
    for rid in (0, 1):
        assert counts[f"/robot_{rid}/density"] == steps
    # The steps between the link going down and the world's verdict: 1 in lockstep (the
    # world waits), the step timeout's worth in real time (nodes/completeness.py).
    window = verdict_window(resolve_config(config, realtime=mode == "realtime"))
    for a in absences:
        assert 0 < a["first"] <= a["last"] < a["rejoined"] == a["last"] + 1 < steps
        # Its densities miss the steps it was out, and at most those between its link going
        # down and the world's verdict; none before, none after it rejoined.
        have = {r.msg.step for r in read_messages(run / "run.mcap",
                                                  [f"/robot_{a['robot']}/density"])}
        missing = set(range(steps)) - have
        assert set(range(a["first"], a["last"] + 1)) <= missing
        assert missing <= set(range(a["first"] - window, a["last"] + 1))
    assert "log complete" in out
