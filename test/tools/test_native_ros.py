"""The scripts on a native ROS 2 install: a sourced ROS environment and no ``.venv``.

A real ``/opt/ros/jazzy`` is not on this machine, so the test makes one from the project's
wheel install: a directory whose ``setup.bash`` does what ROS's does (``ROS_DISTRO``, the
ament and CMake prefix paths, ``PYTHONPATH``, ``LD_LIBRARY_PATH``, ``PATH``), with the
interpreter the wheels were installed for (not the virtual environment: no ``pyvenv.cfg``,
the packages only through ``PYTHONPATH``) and colcon run by that interpreter. A copy of the
repository's files without ``.venv`` then runs ``scripts/setup.sh`` and ``run_swarm.sh``
from a clean environment (``env -i``) in which only that ``setup.bash`` was sourced.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
VENV = ROOT / ".venv"

#: Not copied: data the build and a run never read (the sweeps' rows are ~230 MB).
SKIP_TOP = {"results"}


def _copy_worktree(dest: Path) -> Path:
    """Copy the repository's files (tracked and new, not ignored) as they are now."""
    listed = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
        capture_output=True, check=True).stdout.decode().split("\0")
    for rel in filter(None, listed):
        src = ROOT / rel
        if rel.split("/", 1)[0] in SKIP_TOP or not os.path.lexists(src):
            continue
        target = dest / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, target, follow_symlinks=False)
    return dest


def _fake_ros(where: Path) -> Path:
    """A stand-in for ``/opt/ros/jazzy`` made from the wheel install; returns its setup.bash."""
    site = next((VENV / "lib").glob("python3.*/site-packages"))
    interpreter = Path(os.path.realpath(VENV / "bin" / "python3"))
    assert VENV not in interpreter.parents, interpreter
    bin_dir = where / "bin"
    bin_dir.mkdir(parents=True)
    (bin_dir / "python3").symlink_to(interpreter)
    colcon = bin_dir / "colcon"
    colcon.write_text("#!/bin/sh\n"
                      "exec python3 -c 'import sys\n"
                      "from colcon_core.command import main\n"
                      "sys.exit(main())' \"$@\"\n")
    colcon.chmod(0o755)
    cmake = shutil.which("cmake")
    assert cmake, "cmake: on PATH or in the venv (scripts/setup.sh)"
    (bin_dir / "cmake").symlink_to(cmake)
    # What /opt/ros/jazzy/lib is to a native install: the wheels' libraries (in the venv a
    # .pth file adds them, but Python reads .pth files in site directories, not PYTHONPATH).
    libs = ":".join(str(p) for p in [VENV / "lib", *sorted(site.glob("ros_*.libs"))])
    setup = where / "setup.bash"
    setup.write_text(f"""\
# Stand-in for /opt/ros/jazzy/setup.bash, made from {VENV} by {Path(__file__).name}.
export ROS_DISTRO=jazzy ROS_VERSION=2 ROS_PYTHON_VERSION=3
export PATH="{bin_dir}${{PATH:+:$PATH}}"
export PYTHONPATH="{site}${{PYTHONPATH:+:$PYTHONPATH}}"
export AMENT_PREFIX_PATH="{VENV}${{AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}}"
export CMAKE_PREFIX_PATH="{VENV}${{CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}}"
export LD_LIBRARY_PATH="{libs}${{LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}}"
""")
    return setup


def _in_native_shell(children, home: Path, ros_setup: Path, script: str,
                     timeout: float) -> subprocess.CompletedProcess:
    """Run ``script`` in bash with nothing but ``ros_setup`` sourced (``env -i``).

    It runs in ``home``, so that Python finds phd_swarm through the install space only.
    """
    argv = ["env", "-i", f"HOME={home}", "PATH=/usr/local/bin:/usr/bin:/bin", "LANG=C.UTF-8",
            f"ROS_DOMAIN_ID={children.domain_id}", "ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST",
            "bash", "-c", f'source "$0" && {script}', str(ros_setup)]
    proc = children.start(argv, cwd=home)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        children.stop(proc)
        raise
    return subprocess.CompletedProcess(argv, proc.returncode, out, err)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(1200)
@pytest.mark.skipif(not (VENV / "bin" / "python3").exists(),
                    reason="needs the wheel install (.venv) to stand in for /opt/ros/jazzy")
@pytest.mark.skipif(sys.platform != "linux", reason="Linux only, like ROS 2 Jazzy's wheels")
def test_scripts_build_and_run_on_a_sourced_ros_without_a_venv(tmp_path, children):
    tree = _copy_worktree(tmp_path / "repo")
    assert not (tree / ".venv").exists() and not (tree / "install").exists()
    ros_setup = _fake_ros(tmp_path / "opt_ros_jazzy")
    home = tmp_path / "home"
    home.mkdir()

    setup = _in_native_shell(children, home, ros_setup, f'exec "{tree}/scripts/setup.sh"', 900)
    assert setup.returncode == 0, setup.stdout + setup.stderr
    assert setup.stderr.count("[setup] native ROS 2 jazzy") == 1, setup.stderr
    assert "PyPI wheels" not in setup.stderr and "installing" not in setup.stdout
    assert "building msg_defs and phd_swarm with colcon" in setup.stdout
    assert not (tree / ".venv").exists()
    assert (tree / "install" / "local_setup.bash").is_file()
    assert (tree / "install" / "phd_swarm_msgs" / "share" / "phd_swarm_msgs").is_dir()

    # A second call has nothing to build; env.sh agrees on the install and on whose modules.
    probe = ("import phd_swarm, phd_swarm_msgs, sys\n"
             "print(sys.prefix == sys.base_prefix, phd_swarm.__file__, phd_swarm_msgs.__file__)")
    again = _in_native_shell(
        children, home, ros_setup,
        f'"{tree}/scripts/setup.sh" && source "{tree}/scripts/env.sh" && '
        f'echo "install=$PHD_SWARM_INSTALL" && python3 -c "{probe}"', 120)
    assert again.returncode == 0, again.stdout + again.stderr
    assert "building" not in again.stdout and "install=native" in again.stdout
    in_venv, swarm_file, msgs_file = again.stdout.splitlines()[-1].split()
    assert in_venv == "True"
    assert Path(swarm_file).is_relative_to(tree), swarm_file
    assert Path(msgs_file).is_relative_to(tree / "install"), msgs_file

    run = _in_native_shell(
        children, home, ros_setup,
        f'exec "{tree}/scripts/run_swarm.sh" "{tree}/config/dames_static.yaml" --robots 3 '
        f'--duration 5 --seed 3 --out "{tmp_path / "runs"}" --name native --quiet', 300)
    assert run.returncode == 0, run.stdout + run.stderr
    summary = json.loads((tmp_path / "runs" / "native" / "summary.json").read_text())
    assert summary["robots"] == 3 and summary["steps"] == 10, summary
    assert summary["complete"] and summary["dead_robots"] == [], summary
    assert summary["log_completeness"]["complete"], summary["log_completeness"]
