"""run_swarm starts the robot processes a window at a time (``--start-window``)."""

from __future__ import annotations

import pytest

from phd_swarm.tools import run_swarm
from phd_swarm.tools.launch_plan import robot_processes
from phd_swarm.tools.run_swarm import _start_robots, parse_args


class _Proc:
    def __init__(self, exited: bool = False) -> None:
        self.code = 1 if exited else None

    def poll(self):
        return self.code


class FakeSwarm:
    """Records starts; a process is up after ``up_after`` polls of :meth:`is_up`."""

    def __init__(self, up_after: int = 2, never_up: tuple[str, ...] = (),
                 quiet: bool = False) -> None:
        self.quiet = quiet
        self.procs: dict[str, _Proc] = {}
        self.polls: dict[str, int] = {}
        self.markers: dict[str, str] = {}
        self.argv: dict[str, list[str]] = {}
        self.up_after = up_after
        self.never_up = never_up
        self.most_starting = 0

    def start(self, name, module, ros_args, extra=(), nice=0, up_marker=None, **_):
        self.procs[name] = _Proc(exited=name in self.never_up)
        self.polls[name] = 0
        self.markers[name] = up_marker
        self.argv[name] = [module, *extra, *ros_args]
        starting = sum(1 for n in self.procs if self.polls[n] < self.up_after
                       and n not in self.never_up)
        self.most_starting = max(self.most_starting, starting)

    def is_up(self, name: str) -> bool:
        if name in self.never_up:
            return False
        self.polls[name] += 1
        return self.polls[name] >= self.up_after


def test_at_most_a_window_of_robot_processes_start_at_once(capsys, monkeypatch):
    monkeypatch.setattr(run_swarm.time, "sleep", lambda _: None)
    swarm = FakeSwarm()
    _start_robots(swarm, robot_processes(20, 1, ["--params-file", "c.yaml"]), window=4)
    assert list(swarm.procs) == [f"robot_{i}" for i in range(20)]
    assert swarm.most_starting == 4
    assert swarm.markers["robot_7"] == "robot 7: system "
    out = capsys.readouterr().out
    assert "run_swarm: 4 of 20 robot processes up" in out
    assert "run_swarm: 20 of 20 robot processes up" in out


def test_grouped_processes_are_up_when_their_last_robot_is(monkeypatch):
    monkeypatch.setattr(run_swarm.time, "sleep", lambda _: None)
    swarm = FakeSwarm()
    _start_robots(swarm, robot_processes(25, 10, []), window=1)
    assert list(swarm.procs) == ["robots_0-9", "robots_10-19", "robots_20-24"]
    assert swarm.markers["robots_20-24"] == "robot 24: system "
    assert swarm.argv["robots_10-19"][:3] == ["phd_swarm.nodes.team", "--ids", "10-19"]


def test_a_window_of_zero_starts_all_at_once_without_waiting(capsys):
    swarm = FakeSwarm(never_up=("robot_1",))
    _start_robots(swarm, robot_processes(6, 1, []), window=0)
    assert len(swarm.procs) == 6
    assert capsys.readouterr().out == ""


def test_a_process_that_exits_leaves_the_window_and_is_named(capsys, monkeypatch):
    monkeypatch.setattr(run_swarm.time, "sleep", lambda _: None)
    swarm = FakeSwarm(never_up=("robot_2",))
    _start_robots(swarm, robot_processes(6, 1, []), window=2)
    assert len(swarm.procs) == 6
    captured = capsys.readouterr()
    assert "run_swarm: 5 of 6 robot processes up" in captured.out
    assert "robot_2" in captured.err


def test_the_window_defaults_to_four_per_core_and_refuses_a_negative_one():
    assert parse_args(["config/dames_static.yaml"]).start_window == run_swarm.START_WINDOW
    assert run_swarm.START_WINDOW >= 4
    with pytest.raises(SystemExit):
        parse_args(["config/dames_static.yaml", "--start-window", "-1"])


def test_quiet_runs_print_no_start_progress(capsys, monkeypatch):
    monkeypatch.setattr(run_swarm.time, "sleep", lambda _: None)
    _start_robots(FakeSwarm(quiet=True), robot_processes(9, 1, []), window=2)
    assert capsys.readouterr().out == ""
