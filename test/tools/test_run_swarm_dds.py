"""run_swarm's DDS choice: LOCALHOST for small teams, the repository's profile for large ones."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from phd_swarm.tools.dds import DDS_PROFILE, dds_env
from phd_swarm.tools.run_swarm import (
    AUTO_PROFILE_PROCESSES,
    STARTUP_S_PER_PROCESS,
    parse_args,
    ready_timeouts,
)

ROOT = Path(__file__).resolve().parents[2]


def test_the_profile_replaces_localhost_and_back():
    assert DDS_PROFILE.is_file() and AUTO_PROFILE_PROCESSES < 32
    env = dds_env({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "X": "1"}, profile=True)
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT" and env["X"] == "1"
    assert env["FASTRTPS_DEFAULT_PROFILES_FILE"] == env["FASTDDS_DEFAULT_PROFILES_FILE"] \
        == str(DDS_PROFILE)
    back = dds_env(env, profile=False)
    assert back["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert "FASTRTPS_DEFAULT_PROFILES_FILE" not in back
    # A profile file of the user's own is left alone.
    mine = dds_env({"FASTRTPS_DEFAULT_PROFILES_FILE": "/elsewhere.xml"}, profile=False)
    assert mine["FASTRTPS_DEFAULT_PROFILES_FILE"] == "/elsewhere.xml"


def test_the_option_defaults_to_auto():
    from phd_swarm.tools.run_swarm import AUTO_SERVER_PROCESSES

    assert parse_args(["config/dames_static.yaml"]).dds == "auto"
    # The server from the same size on as the profile; the 50-robot acceptance test uses it.
    assert parse_args(["config/dames_static.yaml"]).discovery_server == "auto"
    assert AUTO_SERVER_PROCESSES == AUTO_PROFILE_PROCESSES < 53
    assert parse_args(["config/dames_static.yaml", "--dds", "profile"]).dds == "profile"


def test_env_sh_selects_the_profile_on_request():
    def sourced(prefix: str) -> list[str]:
        out = subprocess.run(["bash", "-c", f"{prefix} source scripts/env.sh >/dev/null; "
                              "echo $ROS_AUTOMATIC_DISCOVERY_RANGE "
                              "${FASTRTPS_DEFAULT_PROFILES_FILE:-none}"],
                             cwd=ROOT, capture_output=True, text=True, check=True,
                             env={"PATH": "/usr/bin:/bin", "HOME": "/tmp"})
        return out.stdout.split()

    assert sourced("PHD_SWARM_DDS=profile") == ["SYSTEM_DEFAULT", str(DDS_PROFILE)]
    assert sourced("") == ["LOCALHOST", "none"]
    bad = subprocess.run(["bash", "-c", "PHD_SWARM_DDS=udp source scripts/env.sh"], cwd=ROOT,
                         capture_output=True, text=True, check=False,
                         env={"PATH": "/usr/bin:/bin", "HOME": "/tmp"})
    assert bad.returncode == 2 and "PHD_SWARM_DDS must be localhost or profile, got 'udp'" \
        in bad.stderr


def test_a_missing_profile_is_refused(monkeypatch, tmp_path):
    from phd_swarm.tools import dds

    monkeypatch.setattr(dds, "DDS_PROFILE", tmp_path / "gone.xml")
    with pytest.raises(FileNotFoundError, match="gone.xml is missing"):
        dds.dds_env({}, profile=True)


def test_ready_timeouts_grow_with_the_processes_unless_the_config_sets_them():
    from phd_swarm.config import load_run_config

    rc = load_run_config(ROOT / "config" / "dames_static.yaml")
    assert ready_timeouts(rc, 7) == {"world": 60.0, "robot": 60.0}    # the defaults
    big = STARTUP_S_PER_PROCESS * 53
    assert big > 60.0 and ready_timeouts(rc, 53) == {"world": big, "robot": big}
    mine = rc.with_overrides(world={"ready_timeout": 4.0})
    assert ready_timeouts(mine, 53) == {"world": 4.0, "robot": big}


def test_robots_can_be_started_nicer_also_against_other_sessions(tmp_path, monkeypatch):
    """``--robot-nice``: ``nice -n`` for the process, and its session's autogroup niceness.

    Each child runs in a session of its own; with autogroup scheduling the CPU is shared
    between sessions first, so ``nice -n`` alone would change nothing against the world.
    """
    from phd_swarm.tools import processes, run_swarm

    assert parse_args(["config/dames_static.yaml"]).robot_nice == run_swarm.ROBOT_NICE == 0
    assert parse_args(["config/dames_static.yaml", "--robot-nice", "7"]).robot_nice == 7
    proc = subprocess.Popen(["sleep", "30"], start_new_session=True)
    try:
        processes.lower_priority(proc.pid, 7)
        autogroup = Path(f"/proc/{proc.pid}/autogroup")
        if autogroup.exists():
            assert autogroup.read_text().split()[-1] == "7"
    finally:
        proc.kill()
        proc.wait()
    started = []

    class FakePopen:
        def __init__(self, argv, **kwargs):
            started.append((argv, kwargs["env"]))
            self.pid, self.stdout = 0, iter(())

    monkeypatch.setattr(processes.subprocess, "Popen", FakePopen)
    monkeypatch.setattr(processes, "lower_priority", lambda pid, nice: started.append(nice))
    swarm = processes.Swarm(tmp_path, {"A": "1"}, quiet=True)
    swarm.start("robot_0", "phd_swarm.nodes.robot", ["-p", "robot_id:=0"], nice=7,
                env={"B": "2"})
    swarm.start("world", "phd_swarm.nodes.world", [])
    (argv, env), nice, (world_argv, _) = started
    assert argv[:3] == ["nice", "-n", "7"] and argv[4:6] == ["-m", "phd_swarm.nodes.robot"]
    assert env == {"A": "1", "B": "2"} and nice == 7
    assert world_argv[1:3] == ["-m", "phd_swarm.nodes.world"]


def test_the_discovery_server_refuses_an_environment_that_is_not_its_own(tmp_path, capsys,
                                                                          monkeypatch):
    from phd_swarm.tools import discovery_server
    from phd_swarm.tools.dds import server_env, server_profile

    with pytest.raises(ValueError, match="port 70000 is not a UDP port"):
        server_profile(70000)
    profile = tmp_path / "server.xml"
    profile.write_text(server_profile(40000))
    assert "<port>40000</port>" in profile.read_text()
    assert "<address>127.0.0.1</address>" in profile.read_text()
    env = server_env({"ROS_DISCOVERY_SERVER": "127.0.0.1:1", "ROS_SUPER_CLIENT": "TRUE",
                      "X": "1"}, profile)
    assert "ROS_DISCOVERY_SERVER" not in env and "ROS_SUPER_CLIENT" not in env
    assert env["X"] == "1" and env["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(profile)
    argv = ["--profile", str(profile), "--port", "40000"]
    # Fast DDS reads the profile from the environment: without it the server would not be one.
    monkeypatch.delenv("FASTRTPS_DEFAULT_PROFILES_FILE", raising=False)
    assert discovery_server.main(argv) == 2
    assert "FASTRTPS_DEFAULT_PROFILES_FILE must be" in capsys.readouterr().err
    for var in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
        monkeypatch.setenv(var, str(profile))
    monkeypatch.setenv("ROS_DISCOVERY_SERVER", "127.0.0.1:1")
    assert discovery_server.main(argv) == 2
    assert "must not be a client" in capsys.readouterr().err
