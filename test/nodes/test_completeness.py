"""Completeness of a log: expected, recorded and missing steps per step topic."""

from __future__ import annotations

import numpy as np

from phd_swarm.nodes import topics as T
from phd_swarm.nodes.completeness import Completeness, check, ranges, step_of, step_topics


def _full(robots: int, steps: int, alive: dict[int, np.ndarray]) -> dict[str, set[int]]:
    """What a lossless log holds when robots are alive as in ``alive`` (step -> flags)."""
    rec: dict[str, set[int]] = {}
    for name in step_topics(robots):
        rec[name] = set(range(steps + 1))
    for r in range(robots):
        for kind in ("measurements", "pose"):
            rec[T.robot_topic(r, kind)] = {k for k in range(steps) if alive[k][r]}
        for kind in ("status", "density", "cell", "goal", "estimates"):
            rec[T.robot_topic(r, kind)] = {k for k in range(steps)
                                           if alive[k][r] and alive[k + 1][r]}
    return rec


def test_a_lossless_log_is_complete_with_a_death_and_a_rejoin():
    robots, steps = 3, 10
    alive = {k: np.array([True, not 4 <= k < 7, True]) for k in range(steps + 1)}
    report = check(_full(robots, steps, alive), alive, robots, step_topics(robots))
    assert report.complete and report.steps == steps and report.absent == ()
    # Robot 1 died during step 3 and was back at step 7: scanned at 0-3 and 7-9, reported
    # steps 0-2 and 7-9.
    assert report.topics[T.robot_topic(1, "measurements")].expected == 7
    assert report.topics[T.robot_topic(1, "status")].expected == 6
    assert report.topics[T.CLOCK].expected == steps + 1
    assert report.topics[T.WORLD_TRUTH].expected == steps
    assert "complete: " in report.describe()


def test_missing_steps_are_named_and_round_trip():
    robots, steps = 2, 8
    alive = {k: np.ones(robots, dtype=bool) for k in range(steps + 1)}
    rec = _full(robots, steps, alive)
    rec[T.robot_topic(1, "density")] -= {2, 3, 4, 6}
    rec[T.MONITOR_METRICS].discard(0)
    report = check(rec, alive, robots, step_topics(robots))
    assert not report.complete and report.missing == 5
    assert report.gaps() == {T.MONITOR_METRICS: (0,), T.robot_topic(1, "density"): (2, 3, 4, 6)}
    text = report.describe()
    assert "INCOMPLETE: 5 of" in text and "/robot_1/density steps 2-4, 6" in text
    assert Completeness.from_dict(report.to_dict()) == report


def test_a_missing_team_state_is_missing_and_its_step_takes_the_previous_flags():
    robots, steps = 2, 5
    alive = {k: np.ones(robots, dtype=bool) for k in range(steps + 1)}
    rec = _full(robots, steps, alive)
    rec[T.WORLD_ROBOTS].discard(3)
    team = {k: v for k, v in alive.items() if k != 3}
    report = check(rec, team, robots, step_topics(robots))
    assert report.gaps() == {T.WORLD_ROBOTS: (3,)}


def test_a_run_without_a_monitor_lists_its_topics_as_absent():
    robots, steps = 1, 4
    alive = {k: np.ones(robots, dtype=bool) for k in range(steps + 1)}
    rec = {t: s for t, s in _full(robots, steps, alive).items()
           if not t.startswith("/monitor/")}
    report = check(rec, alive, robots, step_topics(robots))
    assert report.complete
    assert set(report.absent) == {T.MONITOR_METRICS, T.MONITOR_ESTIMATES, T.MONITOR_DENSITY}
    assert "no monitor ran" in report.describe()


def test_step_topics_follow_the_density_switches_and_steps_come_from_stamps():
    assert T.MONITOR_DENSITY not in step_topics(1, monitor_density=False)
    assert T.robot_topic(0, "density") not in step_topics(1, outputs=("status", "cell"))
    assert not any(t.endswith("/inbox") or "markers" in t for t in step_topics(3))
    assert step_of(int(7 * 0.5e9), 0.5) == 7 and step_of(int(3 * 0.1e9) - 1, 0.1) == 3
    assert ranges([5, 1, 2, 3, 9, 10]) == "1-3, 5, 9-10" and ranges([]) == ""


def test_reporters_is_one_rule_for_sets_and_arrays():
    from phd_swarm.nodes.completeness import reporters

    assert reporters(frozenset({0, 1, 2}), frozenset({0, 2, 3})) == {0, 2}
    assert reporters(frozenset({0, 1}), None) == {0, 1}  # the last step
    a = np.array([True, True, False])
    b = np.array([True, False, True])
    np.testing.assert_array_equal(reporters(a, b), [True, False, False])


def test_a_robot_writes_the_outputs_its_parts_provide():
    from phd_swarm.nodes.completeness import monitor_density, robot_outputs
    from phd_swarm.sim.presets import dames_static, sung_tokekar

    dames, sung = dames_static().system, sung_tokekar().system
    # The node's own, then the step outputs the parts declare in role order (estimator,
    # exchange, controller); markers are no step topic.
    assert robot_outputs(dames) == ("goal", "status", "estimates", "density", "cell")
    assert robot_outputs(dames, publish_density=False) == ("goal", "status", "estimates",
                                                           "cell")
    assert robot_outputs(sung) == ("goal", "status", "estimates", "components", "tracks")
    assert monitor_density(dames) and not monitor_density(sung)
    topics = step_topics(1, robot_outputs(sung), monitor_density=False)
    assert T.robot_topic(0, "tracks") in topics and T.robot_topic(0, "cell") not in topics


def test_in_real_time_the_steps_before_the_worlds_verdict_are_not_expected():
    from phd_swarm.nodes.completeness import reporters, reporting, verdict_window
    from phd_swarm.tools.launch_plan import resolve_config

    robots, steps = 2, 12
    # Robot 1's link went down after step 3; the world counted it dead at step 7 (its
    # step timeout 3 wall steps later) and let it back at step 9.
    alive = {k: np.array([True, not 7 <= k < 9]) for k in range(steps + 1)}
    rec = _full(robots, steps, alive)
    for kind in ("status", "density", "cell", "goal", "estimates"):
        rec[T.robot_topic(1, kind)] -= {4, 5}
    lockstep = check(rec, alive, robots, step_topics(robots))
    assert lockstep.gaps()[T.robot_topic(1, "density")] == (4, 5)
    realtime = check(rec, alive, robots, step_topics(robots), window=4)
    assert realtime.complete, realtime.describe()
    # But a step of robot 1 lost well before its verdict is still missing.
    rec[T.robot_topic(1, "density")].discard(1)
    assert check(rec, alive, robots, step_topics(robots), window=4).gaps() == {
        T.robot_topic(1, "density"): (1,)}
    flags = np.random.default_rng(0).random((20, 3)) > 0.2
    np.testing.assert_array_equal(reporting(flags, 1), reporters(flags[:-1], flags[1:]))
    assert verdict_window(resolve_config("config/dames_static.yaml")) == 1
    # 15 s of step timeout at 0.5 s steps: 30 steps, plus the step of the report.
    assert verdict_window(resolve_config("config/dames_static.yaml", realtime=True)) == 31
