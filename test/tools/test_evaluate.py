"""scripts/evaluate.sh: OSPA and cardinality from the log alone, pictures, bad logs."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rclpy.serialization import deserialize_message

from phd_swarm.core.estimators.grid_phd.central import CentralPhdFilter
from phd_swarm.core.scan import Scan
from phd_swarm.logs.mcap_log import LogWriter, open_log, read_messages
from phd_swarm.nodes import convert
from phd_swarm.nodes.completeness import step_of
from phd_swarm.tools.run_log import config_from_log, load_run
from phd_swarm_msgs.msg import DensityGrid, MeasurementSet

ROOT = Path(__file__).resolve().parents[2]
RECORDED_STEPS = 24
EVALUATE = str(ROOT / "scripts" / "evaluate.sh")

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def _evaluate(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([EVALUATE, *args], capture_output=True, text=True, timeout=180)


def _copy_log(src: Path, dst: Path, chunk_size: int = 1 << 20, metadata: bool = True) -> Path:
    """Rewrite ``src`` into ``dst`` (smaller chunks, or without the config metadata)."""
    with open_log(src) as log:
        meta = log.metadata()
        with LogWriter(dst, chunk_size=chunk_size) as out:
            if metadata:  # first, as the recorder writes it
                for name, data in meta.items():
                    out.add_metadata(name, data)
            for rec in log.messages(decode=False):
                out.add_channel(rec.topic, rec.ros_type)
                out.write(rec.topic, rec.data, rec.log_time_ns, rec.publish_time_ns)
    return dst


def _copy_rewriting(src: Path, dst: Path, rewrite, completeness: bool = True) -> Path:
    """Rewrite ``src`` into ``dst`` message by message.

    ``rewrite(topic, step, data)`` gives the bytes to write, or None to drop the message;
    without ``completeness`` the recorder's report is left out (as if it had been killed).
    """
    with open_log(src) as log:
        meta = log.metadata()
        dt = log_config(src).scenario.dt
        with LogWriter(dst) as out:
            for name, data in meta.items():
                if completeness or name != "phd_swarm.completeness":
                    out.add_metadata(name, data)
            for rec in log.messages(decode=False):
                out.add_channel(rec.topic, rec.ros_type)
                data = rewrite(rec.topic, step_of(rec.publish_time_ns, dt), rec.data)
                if data is not None:
                    out.write(rec.topic, data, rec.log_time_ns, rec.publish_time_ns)
    return dst


def _copy_without(src: Path, dst: Path, drop) -> Path:
    """Rewrite ``src`` into ``dst`` without the messages ``drop(topic, step)`` selects."""
    return _copy_rewriting(src, dst, lambda topic, step, data: None if drop(topic, step)
                           else data, completeness=False)


def log_config(path: Path):
    """The run config stored in the log at ``path``."""
    with open_log(path) as log:
        return config_from_log(path, log.metadata())


def _is_png(path: Path) -> bool:
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_evaluation_reproduces_the_monitor_and_draws_the_run(recorded_run, tmp_path):
    out = tmp_path / "eval"
    res = _evaluate(str(recorded_run / "run.mcap"), "--out", str(out), "--snapshot", "3",
                    "--snapshot", "11.5", "--animate", str(tmp_path / "run.gif"),
                    "--every", "8")
    assert res.returncode == 0, res.stderr
    assert "largest OSPA difference 0 m" in res.stdout
    assert "log: complete: " in res.stdout

    monitor = json.loads((recorded_run / "summary.json").read_text())
    ev = json.loads((out / "evaluation.json").read_text())
    assert ev["steps"] == monitor["steps"] == 24
    # Same windows, same arithmetic: the series are equal, not merely close.
    assert ev["ospa_series"] == monitor["ospa_series"]
    for key in ("ospa_final", "ospa_mean_last_half", "cardinality_true_final",
                "cardinality_est_final", "expected_cardinality_final"):
        assert ev[key] == monitor[key], key
    assert ev["monitor_agreement"] == {"steps_compared": 24, "max_abs_ospa_difference": 0.0,
                                       "steps_only_in_evaluation": 0}
    assert ev["truncated"] is False and ev["controller"] == "phd"
    assert ev["log_completeness"]["complete"] and ev["log_completeness"]["missing"] == 0
    assert "WARNING" not in res.stderr

    with open(out / "series.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["step"]) for r in rows] == list(range(24))
    assert all(int(r["windows"]) == 4 for r in rows)
    assert [float(r["ospa"]) for r in rows] == [o for _, o in monitor["ospa_series"]]

    for name in ("ospa.png", "snapshot_3s.png", "snapshot_11.5s.png"):
        assert _is_png(out / name), name
    assert (tmp_path / "run.gif").read_bytes()[:6] == b"GIF89a"


def test_a_log_with_gaps_is_flagged_naming_topics_and_steps(recorded_run, tmp_path):
    gappy = _copy_without(recorded_run / "run.mcap", tmp_path / "gappy.mcap",
                          lambda topic, k: (topic == "/robot_1/density" and k in (5, 6))
                          or (topic == "/robot_2/measurements" and k == 9))
    res = _evaluate(str(gappy), "--out", str(tmp_path / "eval"), "--no-plots")
    assert res.returncode == 0, res.stderr
    assert "WARNING: the log has gaps" in res.stderr
    assert "/robot_1/density steps 5-6" in res.stderr
    assert "/robot_2/measurements steps 9" in res.stderr
    ev = json.loads((tmp_path / "eval" / "evaluation.json").read_text())
    report = ev["log_completeness"]
    assert not report["complete"] and report["missing"] == 3
    assert report["topics"]["/robot_1/density"]["missing_steps"] == [5, 6]

    replay = subprocess.run([str(ROOT / "scripts" / "replay.sh"), str(gappy), "--dry-run"],
                            capture_output=True, text=True, timeout=120)
    assert replay.returncode == 0, replay.stderr
    assert "WARNING: the log has gaps" in replay.stderr
    assert "/robot_1/density steps 5-6" in replay.stderr
    check = subprocess.run([sys.executable, "-m", "phd_swarm.tools.log_check", str(gappy)],
                           capture_output=True, text=True, timeout=120)
    assert check.returncode == 1 and "INCOMPLETE: 3 of" in check.stdout
    clean = subprocess.run([str(ROOT / "scripts" / "replay.sh"),
                            str(recorded_run / "run.mcap"), "--dry-run"],
                           capture_output=True, text=True, timeout=120)
    assert clean.returncode == 0 and "WARNING" not in clean.stderr


def test_the_logged_measurement_sets_reproduce_the_logged_team_phd(recorded_run):
    """The log is a complete record of the run's filter.

    A centralised grid PHD fed the logged measurement sets (robot-id order, Dames Alg. 2)
    gives the logged team PHD at every step.
    """
    path = recorded_run / "run.mcap"
    s = log_config(path).scenario
    assert s.targets.kind == "static"
    scans: dict[int, list[Scan]] = {}
    team: dict[int, np.ndarray] = {}
    topics = ["/monitor/density"] + [f"/robot_{r}/measurements" for r in range(s.robots)]
    for rec in read_messages(path, topics=topics, decode=False):
        if rec.topic == "/monitor/density":
            m = deserialize_message(rec.data, DensityGrid)
            image = np.zeros(s.grid.shape)
            convert.add_density(image, m, s.grid)
            team[int(m.step)] = image
        else:
            scan = convert.scan_from_ros(deserialize_message(rec.data, MeasurementSet), 10_000)
            scans.setdefault(scan.step, []).append(scan)
    assert sorted(team) == sorted(scans) == list(range(RECORDED_STEPS))
    central = CentralPhdFilter(s.grid, s.models)
    for k in range(RECORDED_STEPS):
        assert len(scans[k]) == s.robots
        central.step(scans[k])
        mass = central.total_mass
        assert np.max(np.abs(central.weights - team[k])) <= 1e-9 * mass, k


def test_a_truncated_log_is_evaluated_up_to_its_last_complete_step(recorded_run, tmp_path):
    small = _copy_log(recorded_run / "run.mcap", tmp_path / "small.mcap", chunk_size=16_384)
    data = small.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.6)])

    res = _evaluate(str(cut), "--out", str(tmp_path / "eval"), "--no-plots")
    assert res.returncode == 0, res.stderr
    assert "truncated" in res.stderr
    ev = json.loads((tmp_path / "eval" / "evaluation.json").read_text())
    monitor = json.loads((recorded_run / "summary.json").read_text())
    assert ev["truncated"] is True
    assert 0 < ev["steps"] < 24
    assert ev["ospa_series"] == monitor["ospa_series"][: ev["steps"]]


def test_bad_files_give_clear_errors(recorded_run, tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("not a log\n")
    res = _evaluate(str(text))
    assert res.returncode == 1
    assert f"{text}: not an MCAP file" in res.stderr

    res = _evaluate(str(tmp_path / "missing.mcap"))
    assert res.returncode == 1 and "no such file" in res.stderr

    bare = _copy_log(recorded_run / "run.mcap", tmp_path / "bare.mcap", metadata=False)
    res = _evaluate(str(bare), "--no-plots")
    assert res.returncode == 1
    assert "holds no run configuration" in res.stderr and "--config" in res.stderr
    # ... and with the run's config file it works.
    res = _evaluate(str(bare), "--config", str(recorded_run / "config.yaml"), "--no-plots",
                    "--out", str(tmp_path / "eval"))
    assert res.returncode == 0, res.stderr

    res = _evaluate(str(recorded_run / "run.mcap"), "--out", str(tmp_path / "e2"),
                    "--animate", str(tmp_path / "run.avi"))
    assert res.returncode == 1 and ".gif or .mp4" in res.stderr
    res = _evaluate(str(recorded_run / "run.mcap"), "--snapshot", "99", "--no-plots",
                    "--out", str(tmp_path / "e3"))
    assert res.returncode == 0  # no plots asked for: --snapshot is not used
    res = _evaluate(str(recorded_run / "run.mcap"), "--snapshot", "99",
                    "--out", str(tmp_path / "e3"))
    assert res.returncode == 1 and "outside the log" in res.stderr


@pytest.fixture(scope="module")
def chen_run(system_run) -> Path:
    """A short recorded run of Chen's O method (4 robots, 1 m grid, 12 steps)."""
    return system_run("chen_o")


def test_cumulative_density_rebuilt_from_the_log_equals_the_robots(chen_run, tmp_path):
    from phd_swarm.core.controllers.power_lloyd.cumulative import cumulative_weight
    from phd_swarm.engines.distributed import DistributedEngine

    run = load_run(chen_run / "run.mcap")
    assert run.controller == "chen_o" and len(run.steps) == 12
    rebuilt = run.map_layer_images([5, 11])

    # The in-memory engine computes what the ROS robots computed (proven bit for bit in
    # test_systems_inprocess); its robots' own cumulative state is the reference.
    engine = DistributedEngine(run.scenario, "chen_o")
    grid = run.scenario.grid
    for k in range(12):
        engine.step()
        if k in rebuilt:
            alpha = np.zeros(grid.size)
            count = np.zeros(grid.size, dtype=np.int64)
            for robot in engine.robots.values():
                alpha[robot.bins] = robot.alpha
                count[robot.bins] = robot.count
            expected = cumulative_weight(alpha, count, "rate").reshape(grid.shape)
            np.testing.assert_array_equal(rebuilt[k], expected)
            assert expected.max() > 0

    res = _evaluate(str(chen_run / "run.mcap"), "--out", str(tmp_path / "eval"))
    assert res.returncode == 0, res.stderr
    assert _is_png(tmp_path / "eval" / "snapshot_5.5s.png")


def test_a_message_of_another_definition_is_a_clear_error(recorded_run, tmp_path):
    """A message that does not fit the installed definition is refused, naming the topic.

    Here robot 1's statuses are cut short, as an older, shorter RobotStatus would be; the
    log's completeness still reads.
    """
    dst = _copy_rewriting(recorded_run / "run.mcap", tmp_path / "old.mcap",
                          lambda topic, step, data: data[:40] if topic == "/robot_1/status"
                          else data)
    res = _evaluate(str(dst), "--no-plots", "--out", str(tmp_path / "eval"))
    assert res.returncode == 1 and "Traceback" not in res.stderr
    assert "RobotStatus message on /robot_1/status does not fit the installed" in res.stderr
    check = subprocess.run([sys.executable, "-m", "phd_swarm.tools.log_check", str(dst)],
                           capture_output=True, text=True, timeout=120)
    assert check.returncode == 0 and "complete: " in check.stdout
