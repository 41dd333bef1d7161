"""Shared fixtures: in-process ROS contexts and child processes, both loopback-only."""

from __future__ import annotations

import os

import pytest

# Every ROS process a test starts stays on loopback, whatever the caller's shell says.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


def pytest_addoption(parser):
    parser.addoption("--full", action="store_true",
                     help="also run the tests marked full (the 50-process run)")


def pytest_collection_modifyitems(config, items):
    """Tests marked ``full`` run only with ``--full`` (``scripts/test.sh --full``)."""
    if config.getoption("--full"):
        return
    skip = pytest.mark.skip(reason="marked full: run with --full (scripts/test.sh --full)")
    for item in items:
        if "full" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def ros():
    """A private rclpy context on a fresh domain id with a single-threaded executor."""
    from phd_swarm.testing import InProcessRos

    with InProcessRos() as harness:
        yield harness


@pytest.fixture
def children():
    """Child processes started on loopback and stopped by PID at teardown."""
    from phd_swarm.testing import ChildProcesses

    with ChildProcesses() as procs:
        yield procs


@pytest.fixture(scope="session")
def ros2_cli(request):
    """The real ``ros2`` command for tests: a native install's, else the wheels' (issue 36).

    A ``ros2`` on PATH outside this project's virtual environment is a native ROS install's
    and is used as it is. Otherwise ``scripts/ros2_tools.sh`` installs the wheels of
    ``../shared/ros2-cli`` into the venv and builds composition_interfaces (a no-op when
    done), and the command runs with that build's ``local_setup.bash`` sourced. Skips when
    neither exists. Says which one it is on the terminal and in ``.origin``.
    """
    import subprocess
    import sys
    from dataclasses import dataclass, field
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]

    @dataclass(frozen=True)
    class Ros2Cli:
        """``ros2`` as a command line: ``cli("node", "list")``; ``env`` for its children."""

        command: str
        origin: str
        env: dict[str, str] = field(default_factory=dict)

        def __call__(self, *args: str) -> list[str]:
            return [self.command, *args]

    venv_bin = Path(sys.prefix) / "bin"
    native = [p for p in (Path(d) / "ros2" for d in os.environ.get("PATH", "").split(":") if d)
              if p.is_file() and os.access(p, os.X_OK) and p.parent != venv_bin]
    if native:
        cli = Ros2Cli(str(native[0]), f"native: {native[0]} (ROS_DISTRO="
                      f"{os.environ.get('ROS_DISTRO', '?')})")
    else:
        tools = root / "scripts" / "ros2_tools.sh"
        res = subprocess.run([str(tools)], capture_output=True, text=True, timeout=900)
        assert res.returncode == 0, f"scripts/ros2_tools.sh failed:\n{res.stdout}\n{res.stderr}"
        setup = subprocess.run([str(tools), "--setup-file"], capture_output=True, text=True,
                               check=True).stdout.strip()
        if not setup or not Path(setup).is_file() or not (venv_bin / "ros2").is_file():
            pytest.skip(f"no ros2 CLI: no native ROS on PATH and none installed by "
                        f"scripts/ros2_tools.sh ({res.stdout.strip()})")
        dump = subprocess.run(["bash", "-c", 'source "$1" >/dev/null 2>&1; env -0', "_", setup],
                              capture_output=True, check=True).stdout.decode()
        sourced = dict(item.split("=", 1) for item in dump.split("\0") if "=" in item)
        env = {k: v for k, v in sourced.items() if os.environ.get(k) != v
               and k not in ("_", "SHLVL", "PWD", "OLDPWD")}
        cli = Ros2Cli(str(venv_bin / "ros2"),
                      f"wheels: ../shared/ros2-cli installed into {sys.prefix} by "
                      f"scripts/ros2_tools.sh, composition_interfaces from {setup}", env)
    reporter = request.config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None:
        reporter.write_line(f"ros2 CLI for these tests: {cli.origin}")
    return cli
