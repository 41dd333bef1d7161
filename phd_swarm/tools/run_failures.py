"""When a run cannot go on: a process it needs died, or its output cannot be written.

A robot process that dies does not stop a run (the team carries on without it). The world,
the monitor and the recorder are different: without the world nothing steps, without the
monitor there is no summary, and without the recorder the run would go on unrecorded, and a
run is what its log says. So ``run_swarm`` checks them at every sample
(:func:`vital_failure`), and when one has died it stops the run at once, says why on stderr
and in ``summary.json`` (``failure``, :func:`mark_failure`) and exits with
:data:`EXIT_PROCESS_DIED`. What was recorded stays readable: the log up to its last complete
chunk (docs/ros.md, "Failures").

Before the team starts, :func:`check_output_dir` refuses an output folder that cannot be
written or a disk with less than :data:`MIN_FREE_MB` free.
"""

from __future__ import annotations

import json
import shutil
import signal
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

#: Exit code of a run stopped because the world, the monitor or the recorder died.
EXIT_PROCESS_DIED = 4

#: Free space an output folder needs before a run starts [MB].
MIN_FREE_MB = 64


class ProcessDied(RuntimeError):
    """A process the run cannot go on without exited."""


def describe_exit(code: int) -> str:
    """``exited with code 1`` or ``was killed by SIGKILL`` (Popen's returncode ``code``)."""
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with code {code}"


def vital_failure(procs: Mapping[str, Any], record: bool) -> str | None:
    """Why the run cannot go on, or None: the monitor or the recorder has died.

    ``procs``: the run's children by name (``Popen``-like). Called while the world runs: the
    monitor may exit only when it is done (code 0), the recorder not at all.
    """
    monitor = procs.get("monitor")
    if monitor is not None and monitor.poll() not in (None, 0):
        return f"the monitor {describe_exit(monitor.returncode)}"
    recorder = procs.get("recorder")
    if record and recorder is not None and recorder.poll() is not None:
        return (f"the recorder {describe_exit(recorder.returncode)}; the run stops rather "
                "than go on unrecorded")
    return None


def mark_failure(path: Path, reason: str, known: Mapping[str, Any]) -> dict[str, Any]:
    """Add ``failure: reason`` to the summary at ``path``; returns the summary.

    If the monitor wrote none (it died, or no step was processed), a summary of what is
    known (``known``: wall time, CPU) and the failure is written instead, ``steps`` 0. On a
    full disk it says so on stderr and returns the summary all the same.
    """
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError):  # none, or cut short by a full disk
        summary = {"steps": 0, **known}
    summary["failure"] = reason
    try:
        path.write_text(json.dumps(summary, indent=2) + "\n")
    except OSError as exc:
        print(f"run_swarm: cannot write {path}: {exc.strerror or exc}", file=sys.stderr)
    return summary


def check_output_dir(out: Path) -> None:
    """Raise ValueError unless ``out`` (created if missing) can be written, with space left.

    Names the folder and what is wrong: a folder that cannot be made or written, or less
    than :data:`MIN_FREE_MB` MB free on its disk.
    """
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"output folder {out}: cannot create it: {exc.strerror}") from None
    try:  # a real write: os.access says yes to root on a read-only mount
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as exc:
        raise ValueError(f"output folder {out}: cannot write in it: {exc.strerror}") from None
    free_mb = shutil.disk_usage(out).free / 2**20
    if free_mb < MIN_FREE_MB:
        raise ValueError(f"output folder {out}: only {free_mb:.0f} MB free on its disk "
                         f"(a run needs at least {MIN_FREE_MB} MB; logs take ~1-100 MB)")
