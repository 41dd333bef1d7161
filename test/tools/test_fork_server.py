"""The fork server: children as ``python -m`` would start them, their exits reported."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from phd_swarm.testing import fresh_domain_id, loopback_env
from phd_swarm.tools.fork_server import ForkServer

PROBE = '''\
import os, sys, time
IMPORTED_BY = os.getpid()


def main():
    print("argv", sys.argv[1:], flush=True)
    print("env", os.environ.get("PROBE_VAR"), "nice", os.nice(0), flush=True)
    print("sid", os.getsid(0) == os.getpid(), "preloaded", IMPORTED_BY != os.getpid(),
          flush=True)
    with open("/proc/self/comm") as f:
        print("comm", f.read().strip(), flush=True)
    if sys.argv[1] == "sleep":
        time.sleep(60)
    if sys.argv[1] == "raise":
        raise RuntimeError("probe failed")
    if sys.argv[1] == "exit":
        sys.exit(5)
    return int(sys.argv[1])
'''


@pytest.fixture
def server(tmp_path):
    (tmp_path / "fork_probe.py").write_text(PROBE)
    # The children run a probe, not ROS; they get the loopback environment all the same.
    env = dict(loopback_env(fresh_domain_id()),
               PYTHONPATH=os.pathsep.join([str(tmp_path), *sys.path]))
    log = open(tmp_path / "server.log", "w")  # noqa: SIM115
    srv = ForkServer.start(env, log, modules=("fork_probe",))
    srv.env = env
    try:
        yield srv
    finally:
        for child in list(srv._children.values()):
            child.kill()
        srv.close()
        log.close()


def test_a_child_gets_its_argv_environment_niceness_name_and_session(server):
    env = dict(server.env, PROBE_VAR="seven")
    child = server.fork("robot_7", "fork_probe", ["3"], env, nice=4)
    out = child.stdout.read()
    assert child.wait(timeout=30) == 3
    assert "argv ['3']" in out
    assert "env seven nice 4" in out
    assert "sid True preloaded True" in out  # imported once, by the server
    assert "comm robot_7" in out
    assert child.pid != server.proc.pid


def test_a_module_that_raises_exits_1_with_its_traceback_and_sys_exit_gives_its_code(server):
    child = server.fork("robot_1", "fork_probe", ["raise"], server.env)
    out = child.stdout.read()
    assert child.wait(timeout=30) == 1
    assert "RuntimeError: probe failed" in out
    child = server.fork("robot_1", "fork_probe", ["exit"], server.env)
    child.stdout.read()
    assert child.wait(timeout=30) == 5


def test_a_child_stopped_by_a_signal_reports_it_and_wait_times_out_while_it_runs(server):
    child = server.fork("robot_2", "fork_probe", ["sleep"], server.env)
    assert child.stdout.readline().startswith("argv")
    assert child.poll() is None
    with pytest.raises(subprocess.TimeoutExpired):
        child.wait(timeout=0.3)
    child.send_signal(signal.SIGINT)
    assert child.wait(timeout=30) == 130  # KeyboardInterrupt, as the robot's spin loop
    other = server.fork("robot_3", "fork_probe", ["sleep"], server.env)
    assert other.stdout.readline().startswith("argv")
    os.killpg(other.pid, signal.SIGKILL)  # a session and process group of its own
    assert other.wait(timeout=30) == -signal.SIGKILL


def test_children_outlive_a_dead_server_and_are_then_polled_by_pid(server):
    child = server.fork("robot_4", "fork_probe", ["sleep"], server.env)
    assert child.stdout.readline().startswith("argv")
    server.proc.kill()
    server.proc.wait()
    time.sleep(0.2)
    assert child.poll() is None  # still running: the server's death does not stop it
    os.kill(child.pid, signal.SIGKILL)
    assert child.wait(timeout=30) == -1  # exited, its code lost with the server
    with pytest.raises(OSError, match="did not start robot_5"):
        server.fork("robot_5", "fork_probe", ["0"], server.env)
