"""Helpers for tests that run ROS 2 nodes in-process or as child processes.

``InProcessRos`` gives a test its own rclpy ``Context`` on its own ``ROS_DOMAIN_ID``, an
executor on that context, and ``spin_until(predicate, timeout)``; it shuts everything down
even when the test fails (the pattern of rclpy's own ``test_executor.py``).

``ChildProcesses`` starts processes with DDS kept on loopback and stops them by PID (the
whole process group), even on failure, then removes the Fast DDS shared-memory files that
killed processes leave behind.

``run_pids(run_dir, arg)`` finds the processes of a ``run_swarm`` run, and
``wait_for_text(path, text, proc)`` waits for a line in one of its logs.

``fuzzed_bytes(seeds)`` is the hypothesis strategy of the fuzz tests: valid inputs mutated,
and random bytes.
"""

from __future__ import annotations

import itertools
import os
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from phd_swarm.tools.processes import clean_fastdds_shm, stop_process_group

_domain_counter = itertools.count()


def fresh_domain_id() -> int:
    """A ROS_DOMAIN_ID in [120, 219] that differs between calls and between test processes."""
    return 120 + (os.getpid() * 7 + next(_domain_counter)) % 100


def loopback_env(domain_id: int, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """Environment for a child ROS process: DDS on loopback, the given domain id."""
    env = dict(os.environ if base is None else base)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["PYTHONUNBUFFERED"] = "1"
    return env


class InProcessRos:
    """A private rclpy context, executor and node factory for one test.

    Use as a context manager::

        with InProcessRos() as ros:
            node = ros.node("talker")
            ros.spin_until(lambda: got, timeout=5.0)
    """

    def __init__(self, domain_id: int | None = None, executor: str = "single") -> None:
        self.domain_id = fresh_domain_id() if domain_id is None else domain_id
        self._executor_kind = executor
        self.context: Any = None
        self.executor: Any = None
        self._nodes: list[Any] = []

    def __enter__(self) -> InProcessRos:
        import rclpy
        from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor

        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        if os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] != "LOCALHOST":
            raise RuntimeError("refusing to start ROS with DDS discovery beyond loopback: "
                               "set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST")
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=self.domain_id)
        try:
            if self._executor_kind == "single":
                self.executor = SingleThreadedExecutor(context=self.context)
            elif self._executor_kind == "multi":
                self.executor = MultiThreadedExecutor(context=self.context)
            elif self._executor_kind == "events":
                from rclpy.experimental import EventsExecutor
                self.executor = EventsExecutor(context=self.context)
            else:
                raise ValueError(f"unknown executor kind {self._executor_kind!r}")
        except BaseException:
            rclpy.try_shutdown(context=self.context)
            raise
        return self

    def node(self, name: str, **kwargs: Any) -> Any:
        """Create a node on this context and add it to the executor."""
        import rclpy

        node = rclpy.create_node(name, context=self.context, **kwargs)
        self.add(node)
        return node

    def add(self, node: Any) -> Any:
        """Add an already created node (on this context) to the executor; returns it."""
        self._nodes.append(node)
        self.executor.add_node(node)
        return node

    def spin_until(self, predicate: Callable[[], bool], timeout: float,
                   step: float = 0.01) -> bool:
        """Spin the executor until ``predicate()`` is true or ``timeout`` [s] passes."""
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() >= deadline:
                return bool(predicate())
            self.executor.spin_once(timeout_sec=step)
        return True

    def __exit__(self, *exc: object) -> None:
        import rclpy

        try:
            for node in self._nodes:
                try:
                    self.executor.remove_node(node)
                finally:
                    node.destroy_node()
        finally:
            self._nodes.clear()
            try:
                self.executor.shutdown()
            finally:
                rclpy.try_shutdown(context=self.context)


class ChildProcesses:
    """Start ROS processes on loopback and always stop them by PID (process group)."""

    def __init__(self, domain_id: int | None = None) -> None:
        self.domain_id = fresh_domain_id() if domain_id is None else domain_id
        self.procs: list[subprocess.Popen] = []

    def start(self, argv: Sequence[str], env: Mapping[str, str] | None = None,
              **popen_kwargs: Any) -> subprocess.Popen:
        """Start ``argv`` in its own process group with the loopback environment."""
        full_env = loopback_env(self.domain_id)
        if env:
            full_env.update(env)
        popen_kwargs.setdefault("stdout", subprocess.PIPE)
        popen_kwargs.setdefault("stderr", subprocess.PIPE)
        popen_kwargs.setdefault("text", True)
        proc = subprocess.Popen(list(argv), env=full_env, start_new_session=True,
                                **popen_kwargs)
        self.procs.append(proc)
        return proc

    def stop(self, proc: subprocess.Popen, grace: float = 5.0) -> None:
        """SIGINT the process group, then SIGKILL it after ``grace`` seconds."""
        stop_process_group(proc, grace)

    def __enter__(self) -> ChildProcesses:
        return self

    def __exit__(self, *exc: object) -> None:
        for proc in self.procs:
            self.stop(proc)
        clean_fastdds_shm()


def small_static_scenario(robots: int = 5, steps: int = 64, seed: int = 7) -> Any:
    """A 40 x 40 m Dames static scenario (12 targets) where 5 robots find most in 32 s."""
    from phd_swarm.core.geometry.grid import Environment
    from phd_swarm.sim.presets import dames_static
    from phd_swarm.sim.scenario import TargetConfig

    s = dames_static(robots=robots, targets=12)
    return s.with_overrides(
        env=Environment(0.0, 0.0, 40.0, 40.0), robot_start_box=(15.0, 0.0, 25.0, 5.0),
        duration=steps * s.dt, seed=seed,
        targets=TargetConfig(kind="static", count=12, draw_box=(0.0, 0.0, 40.0, 40.0)))


def start_swarm(ros: InProcessRos, tmp_dir: Any, scenario: Any, controller: str | None = None,
                observers: int = 1, robot: dict[str, Any] | None = None,
                shared: dict[str, Any] | None = None,
                **world: Any) -> tuple[Any, Any, list[Any]]:
    """World, monitor (keeping its images) and one robot node per robot on ``ros``.

    ``controller`` replaces ``scenario.system.controller`` if given; ``robot`` and
    ``world`` override those nodes' parameters, ``shared`` every node's (e.g.
    ``auth_key_file``).

    Writes the resolved parameter file to ``tmp_dir/params.yaml`` and starts every node
    from it, as the scripts do. Spin ``ros`` until ``monitor.done``.

    Returns
    -------
    tuple
        ``(world_node, monitor_node, [robot_node, ...])``.
    """
    from pathlib import Path

    from rclpy.parameter import Parameter

    from phd_swarm.config import RunConfig
    from phd_swarm.nodes.monitor import MonitorNode
    from phd_swarm.nodes.robot import RobotNode
    from phd_swarm.nodes.topics import robot_namespace
    from phd_swarm.nodes.world import WorldNode

    if controller is not None:
        scenario = scenario.with_system(controller=controller)
    rc = RunConfig(scenario, dict(shared or {})).with_overrides(
        world={"observers": observers, **world},
        robot={"observers": observers, **(robot or {})},
        monitor={"progress_every": 0})
    params = rc.write_params(Path(tmp_dir) / "params.yaml")
    args = ["--ros-args", "--params-file", str(params)]
    robots = [ros.add(RobotNode(context=ros.context, namespace=robot_namespace(i),
                                cli_args=args,
                                parameter_overrides=[Parameter("robot_id", value=i)]))
              for i in range(scenario.robots)]
    monitor = ros.add(MonitorNode(keep_images=True, context=ros.context, cli_args=args))
    world_node = ros.add(WorldNode(context=ros.context, cli_args=args))
    return world_node, monitor, robots


#: Values a length, count, id or offset word is set to by :func:`fuzzed_bytes`.
EDGE_WORDS = (0, 1, 2, 3, 0x7F, 0xFF, 0x100, 0xFFFF, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF)


def fuzzed_bytes(seeds: Sequence[bytes], max_random: int = 512) -> Any:
    """A hypothesis strategy: one of ``seeds`` mutated, or up to ``max_random`` random bytes.

    A mutated seed has 1 to 4 mutations: a bit flipped, a 32-bit word set to one of
    :data:`EDGE_WORDS`, a cut, bytes inserted or deleted, or the tail of another seed
    spliced in. (hypothesis is a test dependency, imported here only when called.)
    """
    import struct

    from hypothesis import strategies as st

    @st.composite
    def mutated(draw: Any) -> bytes:
        data = bytearray(draw(st.sampled_from(list(seeds))))
        for _ in range(draw(st.integers(1, 4))):
            op = draw(st.sampled_from(("flip", "word", "cut", "insert", "delete", "splice")))
            at = draw(st.integers(0, max(len(data) - 1, 0)))
            if op == "flip" and data:
                data[at] ^= 1 << draw(st.integers(0, 7))
            elif op == "word":
                data[at:at + 4] = struct.pack("<I", draw(st.sampled_from(EDGE_WORDS)))
            elif op == "cut":
                del data[at:]
            elif op == "insert":
                data[at:at] = draw(st.binary(min_size=1, max_size=16))
            elif op == "delete":
                del data[at:at + draw(st.integers(1, 16))]
            else:
                other = draw(st.sampled_from(list(seeds)))
                data = data[:at] + other[draw(st.integers(0, len(other))):]
        return bytes(data)

    return st.one_of(mutated(), st.binary(max_size=max_random))


def run_pids(run_dir: Any, arg: str) -> list[int]:
    """PIDs of the processes of the run at ``run_dir`` with the argument ``arg``.

    ``arg`` is a module (``phd_swarm.nodes.recorder``) or ``robot_id:=2``. A robot process
    forked by the run's fork server has the server's command line and its own name
    (``robot_2``; /proc/PID/comm).
    """
    import re
    from pathlib import Path

    robot = re.fullmatch(r"robot_id:=(\d+)", arg)
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            args = [a.decode(errors="replace")
                    for a in (entry / "cmdline").read_bytes().split(b"\0")]
            comm = (entry / "comm").read_text().strip()
        except OSError:
            continue
        if not any(str(run_dir) in a for a in args):
            continue
        if "phd_swarm.tools.fork_server" in args and comm.startswith("robot"):
            found = (comm == f"robot_{robot.group(1)}" if robot
                     else arg == "phd_swarm.nodes.robot")
        else:
            found = arg in args
        if found:
            out.append(int(entry.name))
    return out


def wait_for_text(path: Any, text: str, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    """Wait until the file ``path`` holds ``text``; AssertionError if ``proc`` ends first."""
    from pathlib import Path

    path = Path(path)
    deadline = time.monotonic() + timeout
    while not (path.exists() and text in path.read_text()):
        assert proc.poll() is None, f"the run ended before {text!r} appeared in {path}"
        assert time.monotonic() < deadline, f"{text!r} did not appear in {path}"
        time.sleep(0.1)
