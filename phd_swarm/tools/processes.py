"""Stopping the processes of a run: whole process groups, and what Fast DDS leaves behind.

Used by ``run_swarm`` (Ctrl-C stops every process of a run) and by the test helpers of
:mod:`phd_swarm.testing`.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess


def stop_process_group(proc: subprocess.Popen, grace: float = 5.0) -> int | None:
    """SIGINT ``proc``'s process group, SIGKILL it after ``grace`` s; returns the exit code.

    The group is killed in the end even if its leader already exited, so no child of it
    (e.g. the Python under a shell script) survives.
    """
    if proc.poll() is None:
        for sig, wait in ((signal.SIGINT, grace), (signal.SIGKILL, 5.0)):
            try:
                os.killpg(proc.pid, sig)
            except ProcessLookupError:
                break
            try:
                proc.wait(timeout=wait)
                break
            except subprocess.TimeoutExpired:
                continue
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    return proc.poll()


def clean_fastdds_shm() -> None:
    """Remove Fast DDS shared-memory files of dead processes (``fastdds shm clean``)."""
    tool = shutil.which("fastdds")
    if tool is None:
        return
    subprocess.run([tool, "shm", "clean"], stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, timeout=30, check=False)
