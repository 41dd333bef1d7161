"""/diagnostics: the pure builders' levels at their thresholds, and the recorder's gap count."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus

from phd_swarm.nodes import diagnostics as D
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.completeness import TEAM_WITH_FINAL, check, step_topics


def _values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


# ------------------------------------------------------------------------------- robot
def _robot(**kw) -> D.RobotHealth:
    base = {"robot_id": 3, "state": "stepping", "step": 10, "finished": 9, "world_step": 10,
            "contacts": (1, 2, 4)}
    return D.RobotHealth(**{**base, **kw})


def test_the_levels_are_the_diagnostic_msgs_bytes():
    assert (D.OK, D.WARN, D.ERROR) == (0, 1, 2)
    status = D.robot_status(_robot())
    assert status.level == DiagnosticStatus.OK and D.level_of(status) == D.OK


def test_a_robot_reports_its_state_lag_contacts_and_counters():
    status = D.robot_status(_robot(timeouts=1, rejected=2, dropped=3, dead_peers=(5, 6, 7),
                                   rejoins=1, revived_peers=2))
    assert (status.name, status.hardware_id) == ("phd_swarm: robot_3", "robot_3")
    assert status.message == "working on step 10"
    values = _values(status)
    assert values["state"] == "stepping" and values["step_lag"] == "1"
    assert (values["contacts"], values["contact_ids"]) == ("3", "1-2, 4")
    assert (values["timeouts"], values["rejected_messages"], values["dropped_messages"]) == (
        "1", "2", "3")
    assert (values["dead_peers"], values["rejoins"], values["revived_peers"]) == (
        "5-7", "1", "2")
    assert _values(D.robot_status(_robot(contacts=None)))["contacts"] == "n/a"
    assert D.robot_status(_robot(state="ready", step=-1, finished=10)).message == \
        "ready for step 11"


@pytest.mark.parametrize("lag, level", [(0, D.OK), (1, D.OK), (D.LAG_WARN - 1, D.OK),
                                        (D.LAG_WARN, D.WARN), (D.LAG_ERROR - 1, D.WARN),
                                        (D.LAG_ERROR, D.ERROR), (50, D.ERROR)])
def test_a_robot_behind_the_world_warns_then_errs_at_the_thresholds(lag, level):
    health = _robot(finished=20 - lag, world_step=20)
    assert health.lag == lag
    status = D.robot_status(health)
    assert D.level_of(status) == level
    assert (f"{lag} steps behind the world" in status.message) == (level != D.OK)


def test_a_robot_without_a_team_state_yet_is_not_behind():
    assert _robot(state="starting", finished=-1, world_step=-1).lag == 0
    assert _robot(finished=-1, world_step=0).lag == 1


def test_a_robot_the_world_counts_dead_is_an_error():
    status = D.robot_status(_robot(state="counted dead", counted_dead=True))
    assert D.level_of(status) == D.ERROR and "counted dead by the world" in status.message


@pytest.mark.parametrize("before, after, words", [
    ({"timeouts": 1}, {"timeouts": 2}, "more timeouts"),
    ({"rejected": 0}, {"rejected": 1}, "more rejected messages"),
    ({"dead_peers": (1,)}, {"dead_peers": (1, 4)}, "dead peers (4 new)"),
])
def test_counters_that_grew_since_the_last_report_warn(before, after, words):
    assert D.level_of(D.robot_status(_robot(**after), _robot(**before))) == D.WARN
    assert words in D.robot_status(_robot(**after), _robot(**before)).message
    # unchanged since the last report, or the first report: OK
    assert D.level_of(D.robot_status(_robot(**after), _robot(**after))) == D.OK
    assert D.level_of(D.robot_status(_robot(**after))) == D.OK


def test_dropped_messages_and_a_peer_coming_back_are_not_a_warning():
    assert D.level_of(D.robot_status(_robot(dropped=9, dead_peers=()),
                                     _robot(dropped=1, dead_peers=(2,)))) == D.OK


# ------------------------------------------------------------------------------- world
def _world(**kw) -> D.WorldHealth:
    base = {"phase": "stepping", "mode": "lockstep", "steps_done": 7, "steps": 100, "step": 7,
            "robots": 4, "ready": 4, "step_timeout": 10.0}
    return D.WorldHealth(**{**base, **kw})


def test_the_world_reports_steps_the_step_it_waits_on_and_the_team():
    status = D.world_status(_world(dead=(2,), waiting_for=(0, 1), step_wait_s=1.5,
                                   rejected=3, rejoins=1))
    assert (status.name, status.hardware_id) == ("phd_swarm: world", "world")
    values = _values(status)
    assert (values["steps_done"], values["step"], values["waiting_for"]) == ("7", "7", "0-1")
    assert (values["robots_alive"], values["robots_dead"]) == ("3", "2")
    assert (values["rejected_messages"], values["rejoins"]) == ("3", "1")
    assert values["realtime_lag_steps"] == "n/a"
    assert status.message.startswith("step 7 of 100")


def test_a_healthy_world_is_ok_in_every_phase():
    for phase in ("waiting", "stepping", "lingering", "finished"):
        assert D.level_of(D.world_status(_world(phase=phase))) == D.OK, phase


@pytest.mark.parametrize("wait, level", [(4.99, D.OK), (5.0, D.WARN), (9.0, D.WARN)])
def test_a_lockstep_step_waiting_half_the_step_timeout_warns(wait, level):
    status = D.world_status(_world(step_wait_s=wait, waiting_for=(3,)))
    assert D.level_of(status) == level
    assert ("waited" in status.message and "robots 3" in status.message) == (level == D.WARN)


@pytest.mark.parametrize("lag, level", [(0.4, D.OK), (D.LAG_WARN - 0.01, D.OK),
                                        (D.LAG_WARN, D.WARN), (D.LAG_ERROR - 0.01, D.WARN),
                                        (D.LAG_ERROR, D.ERROR)])
def test_the_world_behind_real_time_warns_then_errs(lag, level):
    status = D.world_status(_world(mode="realtime", realtime_lag=lag, step_wait_s=100.0))
    assert D.level_of(status) == level
    assert _values(status)["realtime_lag_steps"] == f"{lag:.2f}"


def test_dead_robots_new_rejections_and_a_failed_start_up():
    assert D.level_of(D.world_status(_world(dead=(1,)))) == D.WARN
    assert D.level_of(D.world_status(_world(rejected=2), _world(rejected=1))) == D.WARN
    assert D.level_of(D.world_status(_world(rejected=2), _world(rejected=2))) == D.OK
    failed = D.world_status(_world(phase="failed", steps_done=0, step=-1, ready=2))
    assert D.level_of(failed) == D.ERROR and "no step was run" in failed.message


# ---------------------------------------------------------------------------- recorder
def test_the_recorder_reports_messages_steps_and_gaps_at_their_thresholds():
    ok = D.recorder_status(D.RecorderHealth(1200, 30, last_step=41, expected=1000))
    assert (ok.name, ok.hardware_id, D.level_of(ok)) == ("phd_swarm: recorder", "recorder",
                                                         D.OK)
    values = _values(ok)
    assert (values["messages_written"], values["steps_recorded"]) == ("1200", "42")
    below = int(D.GAPS_ERROR_FRACTION * 1000) - 1
    warn = D.recorder_status(D.RecorderHealth(1200, 30, 41, {"/robot_1/goal": below}, 1000))
    assert D.level_of(warn) == D.WARN
    assert _values(warn)["gap_topics"] == f"/robot_1/goal ({below})"
    err = D.recorder_status(D.RecorderHealth(1200, 30, 41, {"/a": below, "/b": 1}, 1000))
    assert D.level_of(err) == D.ERROR and "of 1000 step messages missing" in err.message
    gaps = {f"/t{i}": 1 for i in range(10)}
    shown = _values(D.recorder_status(D.RecorderHealth(1, 1, 1, gaps, 10**6), shown=3))
    assert shown["gap_topics"].endswith("and 7 more")


def test_a_report_is_a_stamped_array():
    array = D.diagnostic_array(Time(sec=4), [D.robot_status(_robot())])
    assert array.header.stamp.sec == 4 and len(array.status) == 1


# ------------------------------------------------------------------------ gap counting
def _team(steps: int, robots: int, dead: dict[int, int] | None = None) -> dict:
    """Team states 0..steps: robot r dead from step dead[r] on."""
    dead = dead or {}
    return {k: np.array([k < dead.get(r, steps + 1) for r in range(robots)])
            for k in range(steps + 1)}


def test_gaps_follow_the_completeness_rule_on_settled_steps_only():
    robots, steps = 2, 6
    topics = step_topics(robots, ("density", "cell", "status", "goal", "estimates"))
    team = _team(steps, robots, dead={1: 3})
    recorded = {t: set(range(steps + 1)) for t in topics}
    recorded[T.robot_topic(0, "goal")] -= {1, 4}
    recorded[T.WORLD_TRUTH] -= {5}
    for t in topics:                       # robot 1 is dead from step 3: nothing of it
        if t.startswith(T.robot_namespace(1)):
            recorded[t] -= {3, 4, 5, 6}
    gaps = D.GapCounter(topics, robots, settle_s=5.0)
    assert gaps.update(recorded, {k: team[k] for k in range(4)}, now=0.0) == {}
    assert gaps.expected == 0                       # nothing settled yet
    assert gaps.update(recorded, {k: team[k] for k in range(4)}, now=4.9) == {}
    got = gaps.update(recorded, team, now=5.0)      # team state 3 settled: steps 0..2
    assert got == {T.robot_topic(0, "goal"): 1}
    assert gaps.update(recorded, team, now=10.0) == {T.robot_topic(0, "goal"): 2,
                                                     T.WORLD_TRUTH: 1}
    # the same as the completeness check of the whole log, but for the clock and team state
    # of the last step K (the counter checks the steps before the latest team state)
    report = check(recorded, team, robots, topics)
    assert gaps.expected == report.expected - len(TEAM_WITH_FINAL)
    assert sum(gaps.update(recorded, team, now=11.0).values()) == report.missing
    # a message that arrives late takes its gap back
    recorded[T.WORLD_TRUTH].add(5)
    assert gaps.update(recorded, team, now=12.0) == {T.robot_topic(0, "goal"): 2}


def test_the_monitor_s_topics_count_only_when_a_monitor_ran():
    topics = step_topics(1)
    recorded = {t: set(range(4)) for t in topics if not t.startswith("/monitor/")}
    gaps = D.GapCounter(topics, 1, settle_s=0.0)
    assert gaps.update(recorded, _team(3, 1), now=0.0) == {}
    assert gaps.expected == check(recorded, _team(3, 1), 1, [
        t for t in topics if not t.startswith("/monitor/")]).expected - len(TEAM_WITH_FINAL)
