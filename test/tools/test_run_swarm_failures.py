"""scripts/run_swarm.sh when the world, the monitor or the recorder dies, or the disk fills.

Each test starts a long run (so it cannot end before the failure lands), kills or starves
one process mid-run, and checks what the issue asks (issue 40): the run stops at once with
exit code 4 and says why on stderr and in ``summary.json``; every process of the run is
gone; the log written so far is readable (ours, the ``mcap`` library's stream reader,
evaluate.sh). Timings are printed, not asserted.
"""

from __future__ import annotations

import json
import os
import signal
import struct
import subprocess
import time
from pathlib import Path

import pytest
from mcap.exceptions import McapError
from mcap.stream_reader import StreamReader

from phd_swarm.logs.mcap_log import open_log
from phd_swarm.testing import run_pids, wait_for_text
from phd_swarm.tools.run_failures import EXIT_PROCESS_DIED

ROOT = Path(__file__).resolve().parents[2]
RUN_SWARM = str(ROOT / "scripts" / "run_swarm.sh")
EVALUATE = str(ROOT / "scripts" / "evaluate.sh")
CONFIG = ROOT / "config" / "dames_static.yaml"
MODULES = ("phd_swarm.nodes.robot", "phd_swarm.nodes.world", "phd_swarm.nodes.monitor",
           "phd_swarm.nodes.recorder", "phd_swarm.tools.fork_server")

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.full]


def _start(children, out: Path, name: str):
    """A 3-robot run of 4000 steps with progress every 2 steps, into ``out/name``."""
    config = out / "progress.yaml"
    config.write_text(CONFIG.read_text().replace("progress_every: 20", "progress_every: 2"))
    return children.start([RUN_SWARM, str(config), "--robots", "3", "--targets", "10",
                           "--duration", "2000", "--seed", "3", "--out", str(out),
                           "--name", name])


def _kill_mid_run(children, tmp_path: Path, module: str) -> tuple[Path, str, float]:
    """Start a run, SIGKILL its ``module`` process after step 7; (run dir, stderr, s to end)."""
    proc = _start(children, tmp_path, "run")
    run = tmp_path / "run"
    wait_for_text(run / "logs" / "monitor.log", "step 7/", proc)
    (pid,) = run_pids(run, module)
    os.kill(pid, signal.SIGKILL)
    killed = time.monotonic()
    out, err = proc.communicate(timeout=120.0)
    took = time.monotonic() - killed
    print(f"{module} killed: run_swarm ended {took:.1f} s later")
    assert proc.returncode == EXIT_PROCESS_DIED, f"{out}\n{err}"
    for m in MODULES:
        assert run_pids(run, m) == [], m
    return run, err, took


def _readable(log: Path) -> int:
    """Messages in ``log`` by our reader, checked against the mcap library's stream reader."""
    with open_log(log) as reader:
        ours = sum(1 for _ in reader.messages(decode=False))
    theirs = 0
    with open(log, "rb") as f:
        try:
            for record in StreamReader(f, validate_crcs=True).records:
                theirs += type(record).__name__ == "Message"
        except (McapError, EOFError, ValueError, struct.error):
            pass  # the cut (in a record's header: struct.error): what came before was read
    assert ours == theirs and ours > 0
    return ours


def test_a_killed_recorder_stops_the_run_and_its_log_reads_to_the_last_chunk(children,
                                                                             tmp_path):
    run, err, _ = _kill_mid_run(children, tmp_path, "phd_swarm.nodes.recorder")
    assert "the recorder was killed by SIGKILL; the run stops rather than go on " \
           "unrecorded" in err
    summary = json.loads((run / "summary.json").read_text())
    assert summary["failure"].startswith("the recorder was killed by SIGKILL")
    assert summary["steps"] >= 6
    with open_log(run / "run.mcap") as log:
        assert log.truncated
    _readable(run / "run.mcap")
    evaluated = subprocess.run([EVALUATE, str(run / "run.mcap"), "--no-plots"],
                               capture_output=True, text=True, timeout=300)
    assert evaluated.returncode == 0, evaluated.stderr
    report = json.loads((run / "evaluation" / "evaluation.json").read_text())
    assert report["truncated"] is True and report["steps"] >= 1
    assert (run / "metadata.yaml").exists()


def test_a_killed_world_stops_the_run_and_the_summary_says_why(children, tmp_path):
    run, err, took = _kill_mid_run(children, tmp_path, "phd_swarm.nodes.world")
    assert "the world was killed by SIGKILL; stopping the run" in err
    summary = json.loads((run / "summary.json").read_text())
    assert summary["failure"] == "the world was killed by SIGKILL" and summary["steps"] >= 6
    with open_log(run / "run.mcap") as log:
        assert not log.truncated  # the recorder was stopped and closed the log
    assert took < 60.0, "a hang guard only; the figure is printed"


def test_a_killed_monitor_fails_the_run_clearly(children, tmp_path):
    run, err, _ = _kill_mid_run(children, tmp_path, "phd_swarm.nodes.monitor")
    assert "the monitor was killed by SIGKILL; stopping the run" in err
    assert "no step was summarised" in err
    summary = json.loads((run / "summary.json").read_text())
    assert summary["failure"] == "the monitor was killed by SIGKILL" and summary["steps"] == 0
    with open_log(run / "run.mcap") as log:
        assert not log.truncated
    assert _readable(run / "run.mcap") > 0


@pytest.fixture
def small_disk(tmp_path):
    """A 96 MB tmpfs mounted at ``tmp_path/disk`` (root only), unmounted at the end."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    disk = tmp_path / "disk"
    disk.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=96m", "tmpfs", str(disk)], check=True)
    try:
        yield disk
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


def test_a_read_only_or_full_disk_is_refused_before_the_team_starts(children, small_disk):
    ballast = small_disk / "ballast"
    ballast.write_bytes(b"\0" * (64 * 2**20))  # 32 MB left: under the 64 MB a run needs
    proc = _start(children, small_disk, "run")
    out, err = proc.communicate(timeout=60.0)
    assert proc.returncode == 2 and f"output folder {small_disk}: only " in err, err
    assert not (small_disk / "run").exists()
    ballast.unlink()
    subprocess.run(["mount", "-o", "remount,ro", str(small_disk)], check=True)
    proc = _start_readonly(children, small_disk)
    out, err = proc.communicate(timeout=60.0)
    assert proc.returncode == 2 and "cannot write in it: Read-only file system" in err, err


def _start_readonly(children, out: Path):
    return children.start([RUN_SWARM, str(CONFIG), "--robots", "3", "--duration", "5",
                           "--out", str(out), "--name", "run"])


def test_a_disk_that_fills_mid_run_stops_it_with_what_was_written_intact(children,
                                                                         small_disk):
    proc = _start(children, small_disk, "run")
    run = small_disk / "run"
    wait_for_text(run / "logs" / "monitor.log", "step 7/", proc)
    free = os.statvfs(small_disk)
    left = free.f_bavail * free.f_frsize
    with open(small_disk / "ballast", "wb") as f:  # all but 256 kB: a few chunks more
        f.write(b"\0" * max(left - 256 * 2**10, 0))
    out, err = proc.communicate(timeout=180.0)
    assert proc.returncode == EXIT_PROCESS_DIED, f"{out}\n{err}"
    assert "the recorder exited with code 1" in err
    # (Its "No space left on device" may not reach recorder.log: that disk is full too.)
    for m in MODULES:
        assert run_pids(run, m) == [], m
    (small_disk / "ballast").unlink()  # room to read and check what was written
    with open_log(run / "run.mcap") as log:
        assert log.truncated  # stopped inside a chunk's write
    assert _readable(run / "run.mcap") > 0
    assert (run / "config.yaml").exists()
