"""The core benchmark runs through its public entry point and writes its JSON."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _bench(*args: str, timeout: float) -> subprocess.CompletedProcess:
    """``scripts/bench.sh ARGS``, its output captured (the exit code is the test's to check)."""
    return subprocess.run([str(ROOT / "scripts" / "bench.sh"), *args], capture_output=True,
                          text=True, timeout=timeout, check=False)


def _quick_results(suite: str, out: Path, *args: str, timeout: float) -> tuple[str, dict]:
    """``scripts/bench.sh SUITE --quick ARGS --out OUT``: its stdout and its JSON file."""
    result = _bench(suite, "--quick", *args, "--out", str(out), timeout=timeout)
    assert result.returncode == 0, result.stderr
    return result.stdout, json.loads(next(out.glob(f"{suite}-*.json")).read_text())


def test_bench_core_quick_prints_and_writes_figures(tmp_path):
    result = _bench("core", "--quick", "--out", str(tmp_path), timeout=300)
    assert result.returncode == 0, result.stderr
    assert "team step dames_moving 1.0 m" in result.stdout
    files = list(tmp_path.glob("core-*.json"))
    assert len(files) == 1
    data = json.loads(files[0].read_text())
    cases = {r["case"]: r for r in data["results"]}
    assert len(cases) == 6
    assert all(r["median_ms"] > 0 for r in cases.values())
    assert data["meta"]["cpus"] >= 1


def test_bench_rejects_unknown_suite():
    result = _bench("nonsense", timeout=120)
    assert result.returncode == 2
    assert "usage" in result.stderr


def test_bench_comms_quick_reports_traffic_per_team_size(tmp_path):
    result = _bench("comms", "--quick", "--sizes", "4,8", "--out", str(tmp_path), timeout=300)
    assert result.returncode == 0, result.stderr
    data = json.loads(next(tmp_path.glob("comms-*.json")).read_text())
    rows = {r["robots"]: r for r in data["results"]}
    assert set(rows) == {4, 8}
    for r in rows.values():
        assert r["messages_per_robot_per_step"] > 0
        assert r["by_type_per_robot_per_step"]["RobotState"] > 0
        # A robot never hears from more robots than the team has, per message type.
        assert r["by_type_per_robot_per_step"]["RobotState"] <= r["robots"] - 1


def test_bench_engines_quick_compares_the_two_engines(tmp_path):
    result = _bench("engines", "--quick", "--out", str(tmp_path), timeout=300)
    assert result.returncode == 0, result.stderr
    assert "central" in result.stdout and "dames_static PHD 10 robots" in result.stdout
    data = json.loads(next(tmp_path.glob("engines-*.json")).read_text())
    assert len(data["results"]) == 2
    for r in data["results"]:
        assert r["distributed_steps_per_s"] > 0 and r["central_steps_per_s"] > 0
        # Same trial, same steps: the two engines agree (tests bound this at every step).
        assert r["max_phd_difference_rel"] <= 1e-9 and r["max_position_difference_m"] <= 1e-9


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.full
def test_bench_recorder_quick_reports_a_complete_log_and_the_stop_time(tmp_path):
    result = _bench("recorder", "--quick", "--interrupt-after", "2", "--out", str(tmp_path),
                    timeout=600)
    assert result.returncode == 0, result.stderr
    data = json.loads(next(tmp_path.glob("recorder-*.json")).read_text())
    runs = data["results"]["runs"]
    assert [r["inboxes_recorded"] for r in runs] == [False, True]
    for r in runs:
        assert r["steps"] == 20 and r["step_messages_missing"] == 0
        assert r["step_messages_recorded"] == r["step_messages_expected"] > 0
        assert r["recorder_ms_per_message"] > 0 and r["startup_s"] is not None
    # Recording the inboxes adds the protocol traffic to the log. (How much it adds depends
    # on how the robots spread, which is the benchmark's figure, not a bound to test: with 4
    # crowded robots over 20 steps it is about as much again as the step messages.)
    assert runs[1]["recorder_messages"] > runs[0]["recorder_messages"]
    (stop,) = data["results"]["interrupts"]
    assert stop["exit_code"] == 130 and stop["processes_left"] == 0
    assert "| ms / msg |" in result.stdout


def test_bench_estimators_quick_runs_our_side_without_stone_soup(tmp_path):
    # --no-stonesoup: the project's .venv only, no Stone Soup, no network.
    result = _bench("estimators", "--quick", "--no-stonesoup", "--out", str(tmp_path), timeout=300)
    assert result.returncode == 0, result.stderr
    assert "stonesoup 1.9.1" not in result.stdout
    lines = result.stdout.splitlines()
    assert any(ln.startswith("B ") and "phd_swarm" in ln and "GM-PHD" in ln for ln in lines)
    assert any(ln.startswith("A ") and "p_D at mean" in ln for ln in lines)
    assert any(ln.startswith("A ") and "integrated p_D" in ln for ln in lines)
    data = json.loads(next(tmp_path.glob("estimators-*.json")).read_text())
    rows = {(r["scenario"], r["variant"]): r for r in data["results"]}
    assert {r["implementation"] for r in rows.values()} == {"phd_swarm"}
    b, a = rows[("B", "GM-PHD")], rows[("A", "GM-PHD p_D at mean")]
    assert (b["steps"], a["steps"]) == (20, 60)
    for r in (a, b):
        assert 0 < r["median_ms"] <= r["p95_ms"] and r["mean_size"] > 0
        assert len(r["ospa_per_step"]) == r["steps"] == len(r["ms_per_step"])
        assert 0 <= r["ospa_last_half"] <= r["ospa_c"]
        assert r["speedup_vs_stonesoup"] is None
    # The oracle knows every target seen so far: nothing tracks better.
    assert 0 <= a["oracle_ospa_last_half"] <= a["ospa_last_half"]
    # Tracking ten targets in clutter: well under the cut-off once the filter has them,
    # with either filter and either sensor.
    assert b["ospa_last_half"] < 0.5 * b["ospa_c"]
    for key in (("smc", "SMC-PHD"), ("B-rb", "GM-PHD EKF"), ("B-rb", "GM-PHD UKF"),
                ("B-rb", "SMC-PHD")):
        assert rows[key]["ospa_last_half"] < 0.5 * rows[key]["ospa_c"], key
    # Scenario C (issue 33): both p_D forms under each merge rule, on the same data.
    c_rows = [r for r in data["results"] if r["scenario"] == "C"]
    assert {r["variant"].split(",")[0] for r in c_rows} == {"GM-PHD p_D at mean",
                                                            "GM-PHD integrated"}
    assert len(c_rows) in (2, 4)
    assert any(ln.startswith("C ") and "integrated" in ln for ln in lines)
    for r in c_rows:
        assert r["steps"] == 120 == len(r["ospa_per_step"])
        assert 0 <= r["oracle_ospa_last_half"] <= r["ospa_last_half"] <= r["ospa_c"] == 50.0
    assert data["meta"]["revisit_spec"]["radius"] == 12.5


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.full
def test_bench_sung_quick_times_a_trial_the_gp_and_the_ros_run(tmp_path, children):
    proc = children.start([str(ROOT / "scripts" / "bench.sh"), "sung", "--quick",
                           "--out", str(tmp_path)])
    _, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    data = json.loads(next(tmp_path.glob("sung-*.json")).read_text())
    trials, gp, ros = data["results"][:2], data["results"][2], data["results"][3]
    assert [t["steps"] for t in trials] == [600, 600]
    assert all(t["engine_cpu_s"] > 0 and t["scoring_cpu_s"] > 0 for t in trials)
    assert all(gp[f"{n} tracks"] > 0 for n in (1, 10, 50))
    assert ros["steps"] == 600 and ros["complete"] and ros["real_time_factor"] > 0
    assert set(ros["cpu_s"]) == {"world", "monitor", "recorder", "robot_0", "fork_server"}


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.full
def test_bench_shirsat_quick_times_the_robot_step_and_the_ros_run(tmp_path, children):
    proc = children.start([str(ROOT / "scripts" / "bench.sh"), "shirsat", "--quick",
                           "--out", str(tmp_path)])
    _, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    trial, ros = json.loads(next(tmp_path.glob("shirsat-*.json")).read_text())["results"]
    assert trial["robot_steps"] == 200 * 20 and trial["ms_per_robot_step"] > 0
    assert ros["steps"] == 300 and ros["complete"] and ros["real_time_factor"] > 0
    # One message per robot met, none otherwise: a robot at a meeting meets 1 or 2 others.
    meeting = ros["robots_meeting_per_step"] / 3
    assert meeting - 1e-12 <= ros["messages_per_robot_per_step"] <= 2 * meeting + 1e-12


@pytest.mark.slow
def test_bench_papaioannou_quick_times_a_trial_and_the_reward(tmp_path):
    """The ROS run of the benchmark is test_run_swarm_papaioannou's; --no-ros skips it here."""
    result = _bench("papaioannou", "--quick", "--no-ros", "--out", str(tmp_path), timeout=300)
    assert result.returncode == 0, result.stderr
    trial, *rewards = json.loads(next(tmp_path.glob("papaioannou-*.json")).read_text())[
        "results"]
    assert trial["steps"] == 100 and trial["trial_cpu_s_median"] > 0
    assert [(r["particles"], r["moves"]) for r in rewards] == [(300, 17), (1200, 17),
                                                                (6000, 17)]
    assert all(r["median_ms"] > 0 for r in rewards)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.full
def test_bench_swarm_quick_runs_every_layout_with_a_complete_log(tmp_path):
    stdout, data = _quick_results("swarm", tmp_path, timeout=600)
    rows = data["results"]
    assert [(r["layout"], r["processes"]) for r in rows] == [
        ("one process per robot", 4), ("2 robots per process", 2),
        ("all robots in one process", 1)]
    for r in rows:
        assert r["robots"] == 4 and r["steps"] == 60 and r["dead_robots"] == []
        assert r["log_complete"] is True and r["cpu_ms_per_robot_step"] > 0
        assert 20 < r["peak_memory_mb_robot_process"] <= r["peak_memory_mb_per_process"] < 2000
        # Start-up and the CPU while stepping, robots and observers apart.
        assert r["start"] == "spread" and 0 < r["startup_s"] < r["total_wall_s"]
        assert r["robot_cpu_ms_per_robot_step_stepping"] > 0
        obs = r["observers_cpu_ms_per_step_stepping"]
        # /proc counts CPU in 10 ms ticks: over 10 steps the recorder's share may round to 0.
        assert set(obs) == {"world", "monitor", "recorder"} and all(v >= 0 for v in obs.values())
        assert sum(obs.values()) > 0
    assert "complete" in stdout


def test_bench_swarm_rejects_an_unknown_layout():
    result = _bench("swarm", "--layouts", "processes,clusters", timeout=120)
    assert result.returncode == 2 and "clusters" in result.stderr
    result = _bench("swarm", "--starts", "spread,diagonal", timeout=120)
    assert result.returncode == 2 and "diagonal" in result.stderr


@pytest.mark.ros
@pytest.mark.slow
def test_bench_discovery_quick_matches_ten_processes_on_the_profile(tmp_path):
    result = _bench("discovery", "--quick", "--out", str(tmp_path), timeout=300)
    assert result.returncode == 0, result.stderr
    (row,) = json.loads(next(tmp_path.glob("discovery-*.json")).read_text())["results"]
    assert (row["mode"], row["processes"], row["exited"]) == ("profile", 10, 10), row["stuck"]
    assert row["all_matched"] == 10 and row["min_seen"] == 10
    assert row["cpu_s"] > 0 and row["max_rss_mb"] > 0


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.full
def test_bench_view_quick_measures_the_demo_with_and_without_the_view(tmp_path):
    stdout, data = _quick_results("view", tmp_path, timeout=900)
    rows = {r["way"]: r for r in data["results"]}
    assert set(rows) == {"off", "view", "browser"}
    assert rows["off"]["drop"] == 0.0
    for r in rows.values():
        assert r["steps_per_s"] > 0 and r["cpu_s"] > 0 and len(r["runs"]) == 1
    assert "browser" in stdout and "drop" in stdout


@pytest.mark.slow
def test_bench_fuzz_quick_runs_each_target_and_reports_executions(tmp_path):
    stdout, data = _quick_results("fuzz", tmp_path, "--targets", "cdr/RobotState,scan",
                                  timeout=300)
    rows = data["results"]
    assert [r["target"] for r in rows] == ["cdr/RobotState", "scan"]
    for r in rows:
        assert r["seconds"] == 5 and r["executions"] > 1000 and r["corpus"] > 0
        assert r["finding"] is None and r["exit_code"] == 0
    assert "0 findings" in stdout


def test_bench_fuzz_rejects_an_unknown_target():
    result = _bench("fuzz", "--quick", "--targets", "nothing_like_it", timeout=120)
    assert result.returncode != 0 and "no target starts with 'nothing_like_it'" in result.stderr


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.full
def test_bench_soak_quick_samples_every_process_and_gives_the_slopes(tmp_path):
    stdout, data = _quick_results("soak", tmp_path, "--sample-s", "0.5", timeout=600)
    (result,) = data["results"]
    figures, samples = result["figures"], result["samples"]
    assert data["meta"]["robots"] == 4 and data["meta"]["steps"] == 240
    assert data["meta"]["log_complete"] is True
    assert {"world", "monitor", "recorder", "robot_0", "robot_3", "/dev/shm"} <= set(figures)
    # Every process in every sample while the world steps (not while the team stops).
    stepping = [s for s in samples if s["stepping"]]
    assert len(stepping) >= 2, samples
    middle = stepping[len(stepping) // 3: 2 * len(stepping) // 3 + 1]
    for s in middle:
        assert len(s["processes"]) == 7, (s["step"], sorted(s["processes"]))
    for name in ("world", "robot_0"):
        f = figures[name]
        assert f["rss_mb_end"] > 20 and f["cpu_ms_per_step_q2"] > 0
        assert middle[-1]["processes"][name]["shm_mapped"] > 0  # Fast DDS shared memory
        assert f["rss_mb_per_sim_hour"] == f["rss_mb_per_sim_hour"]  # a number, not NaN
    assert (tmp_path / "soak-" f"{data['meta']['date']}-rss.png").exists()
    assert "/dev/shm entries" in stdout


@pytest.mark.ros
@pytest.mark.slow
def test_bench_floor_quick_steps_the_message_pattern_with_no_work(tmp_path):
    stdout, data = _quick_results("floor", tmp_path, timeout=300)
    rows = data["results"]
    assert [r["robots"] for r in rows] == [4]
    for r in rows:
        assert r["steps"] == 10 and r["robots_completed"] == r["robots"]
        assert r["exited"] == r["processes"] == r["robots"] + 2, r["stuck"]
        assert r["robot_cpu_ms_per_robot_step"] > 0 and r["steps_per_s"] > 0
        assert 0 < r["startup_s"] and 20 < r["robot_peak_rss_mb"] < 2000
        # Every status and bundle reached the observer (reliable, keep-all readers).
        expected = r["robots"] * r["steps"]
        assert r["observers_received"] == [{"statuses": expected, "bundles": expected}]
    assert data["meta"]["contacts"] == 2 and data["meta"]["phases"] == 3
    assert "robot CPU ms/robot-step" in stdout


@pytest.mark.ros
@pytest.mark.slow
def test_bench_floor_variants_outbox_over_shared_memory_lose_nothing(tmp_path):
    # The variants weighed in issue 39: one envelope per phase on the robot's own outbox,
    # and the UDP profile plus Fast DDS's shared memory (the profile written per run).
    _, data = _quick_results("floor", tmp_path, "--send", "outbox", "--dds", "shm",
                             "--discovery-server", "off", timeout=300)
    (row,) = data["results"]
    assert (row["dds"], row["send"], data["meta"]["send"]) == ("shm", "outbox", "outbox")
    assert row["robots_completed"] == row["robots"] == 4, row["stuck"]
    assert row["exited"] == row["processes"] == 6, row["stuck"]
    expected = row["robots"] * row["steps"]
    assert row["observers_received"] == [{"statuses": expected, "bundles": expected}]
