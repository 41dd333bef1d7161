"""A robot waiting to become ready says what it waits for, and names it if it gives up."""

from __future__ import annotations

import pytest

from phd_swarm.testing import small_static_scenario, start_swarm


@pytest.mark.ros
def test_a_robot_without_its_second_observer_names_what_is_missing(tmp_path, monkeypatch):
    from phd_swarm.nodes import robot as robot_module
    from phd_swarm.testing import InProcessRos

    monkeypatch.setattr(robot_module, "READY_LOG_PERIOD", 0.2)
    logged: list[str] = []
    scenario = small_static_scenario(robots=2, steps=4)
    with InProcessRos(executor="events") as ros:
        # Two observers expected, only the monitor runs: no recorder reads the
        # team's statuses and outputs.
        _, _, robots = start_swarm(ros, tmp_path, scenario, observers=2,
                                   robot={"ready_timeout": 3.0})
        for r in robots:
            logger = r.get_logger()
            monkeypatch.setattr(r, "get_logger", lambda lg=logger: _Tee(lg, logged))
        assert ros.spin_until(lambda: all(r.ready for r in robots), timeout=30.0)
    waiting = [m for m in logged if "waiting" in m]
    gave_up = [m for m in logged if "not matched within 3.0 s" in m]
    assert waiting and len(gave_up) == 2, logged
    for text in (waiting[0], *gave_up):
        assert "/team/status: 2 of 3 readers (world and observers)" in text, text
        assert "/team/outputs: fewer than 2 observers" in text, text
        assert "inboxes" not in text, text      # the two robots found each other's inbox


class _Tee:
    """A logger that also keeps what was logged."""

    def __init__(self, logger, sink: list[str]) -> None:
        self.logger, self.sink = logger, sink

    def info(self, msg: str) -> None:
        self.sink.append(msg)
        self.logger.info(msg)

    def error(self, msg: str) -> None:
        self.sink.append(msg)
        self.logger.error(msg)

    def warning(self, msg: str) -> None:
        self.sink.append(msg)
        self.logger.warning(msg)
