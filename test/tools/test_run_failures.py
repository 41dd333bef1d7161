"""When a run cannot go on: :mod:`phd_swarm.tools.run_failures`."""

from __future__ import annotations

import json
import signal

import pytest

from phd_swarm.tools import run_failures
from phd_swarm.tools.run_failures import (
    check_output_dir,
    describe_exit,
    mark_failure,
    vital_failure,
)


class _Proc:
    def __init__(self, returncode):
        self.returncode = returncode

    def poll(self):
        return self.returncode


def test_an_exit_is_described_by_its_code_or_its_signal():
    assert describe_exit(1) == "exited with code 1"
    assert describe_exit(-signal.SIGKILL) == "was killed by SIGKILL"
    assert describe_exit(-99) == "was killed by signal 99"


@pytest.mark.parametrize("procs, record, reason", [
    ({"monitor": _Proc(None), "recorder": _Proc(None)}, True, None),
    ({"monitor": _Proc(0), "recorder": _Proc(None)}, True, None),  # done: it may exit
    ({"monitor": _Proc(-9), "recorder": _Proc(None)}, True, "the monitor was killed by SIGKILL"),
    ({"monitor": _Proc(None), "recorder": _Proc(1)}, True,
     "the recorder exited with code 1; the run stops rather than go on unrecorded"),
    ({"monitor": _Proc(None), "recorder": _Proc(0)}, True, "the recorder exited with code 0"),
    ({"monitor": _Proc(None)}, False, None),  # --no-record
])
def test_the_monitor_and_the_recorder_are_vital(procs, record, reason):
    found = vital_failure(procs, record)
    assert found == reason if reason is None else found.startswith(reason)


def test_a_failure_is_added_to_the_monitors_summary_or_makes_one(tmp_path):
    path = tmp_path / "summary.json"
    assert mark_failure(path, "the world was killed by SIGKILL", {"wall_duration_s": 3.0}) == {
        "steps": 0, "wall_duration_s": 3.0, "failure": "the world was killed by SIGKILL"}
    path.write_text(json.dumps({"steps": 12, "ospa_final": 1.5}))
    mark_failure(path, "the recorder exited with code 1", {"wall_duration_s": 3.0})
    assert json.loads(path.read_text()) == {"steps": 12, "ospa_final": 1.5,
                                            "failure": "the recorder exited with code 1"}


def test_an_output_folder_that_cannot_be_written_or_a_full_disk_is_refused(tmp_path,
                                                                            monkeypatch):
    check_output_dir(tmp_path / "new" / "runs")  # made
    assert (tmp_path / "new" / "runs").is_dir()
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match=r"output folder .*file/runs: cannot create it"):
        check_output_dir(tmp_path / "file" / "runs")
    monkeypatch.setattr(run_failures, "MIN_FREE_MB", 10**12)
    with pytest.raises(ValueError, match=r"only \d+ MB free on its disk \(a run needs at "
                                         r"least 1000000000000 MB"):
        check_output_dir(tmp_path)
