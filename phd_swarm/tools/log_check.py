"""Check a recorded run for gaps: which step messages a log should hold and which it lacks.

:func:`check_log` reads the step numbers the messages carry (the sim-time stamp of every
step-topic message; for ``/robot_<i>/status`` only ``STEP_DONE``; the alive flags of every
``/world/robots`` team state) and applies :func:`phd_swarm.nodes.completeness.check`: per
topic, the steps expected, recorded and missing. It is what the recorder computes live,
recomputed from the file alone, so a log that was cut, edited or written by an older
recorder is judged by what it holds. ``scripts/evaluate.sh`` and ``scripts/replay.sh`` call
it and warn loudly (topics and steps) before they use a log with gaps.

Only the step topics that have a channel in the log are checked (a recorder subscribed to a
run's config has a channel for every one of them, with or without messages); a log recorded
without a config (``record.sh OUT``) is checked against the config passed in.

``python -m phd_swarm.tools.log_check RUN.mcap [--config CONFIG] [--json]`` prints the
verdict; exit code 0 if complete, 1 if not, 2 if the log cannot be read.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from phd_swarm.config import RunConfig, load_run_config
from phd_swarm.logs.mcap_log import LogError, open_log
from phd_swarm.nodes import completeness
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.team_routes import status_state
from phd_swarm.tools.run_log import config_from_log, deserialize
from phd_swarm_msgs.msg import RobotStatus, TeamState

#: Prefix of the warning evaluate and replay print for a log with gaps.
WARNING = "WARNING: the log has gaps, results from it are not the run's"


def check_log(path: str | Path, config: RunConfig | None = None
              ) -> completeness.Completeness:
    """Completeness of the log at ``path`` (see the module docstring).

    Raises
    ------
    LogError
        If the log cannot be read or holds no run configuration and none is given.
    """
    path = Path(path)
    with open_log(path) as log:
        rc = config if config is not None else config_from_log(path, log.metadata())
        s = rc.scenario
        present = set(log.info().topics)
        wanted = [t for t in completeness.run_step_topics(rc) if t in present]
        steps: dict[str, set[int]] = {t: set() for t in wanted}
        team: dict[int, np.ndarray] = {}
        for rec in log.messages(wanted, decode=False):
            if rec.topic == T.WORLD_ROBOTS:
                msg = deserialize(rec, TeamState, path)
                ids = np.asarray(msg.robot_ids, dtype=np.int64)
                ok = ids < s.robots
                flags = np.zeros(s.robots, dtype=bool)
                flags[ids[ok]] = np.asarray(msg.alive, dtype=bool)[ok]
                team[int(msg.step)] = flags
                steps[rec.topic].add(int(msg.step))
            elif rec.topic.endswith("/status"):
                # The state from the bytes (not the whole message: logs of older versions
                # of RobotStatus are checked all the same); a report's stamp is its step.
                if status_state(rec.data) == RobotStatus.STATE_STEP_DONE:
                    steps[rec.topic].add(completeness.step_of(rec.publish_time_ns, s.dt))
            else:
                steps[rec.topic].add(completeness.step_of(rec.publish_time_ns, s.dt))
    return completeness.check(steps, team, s.robots, wanted, completeness.verdict_window(rc))


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point (see the module docstring)."""
    p = argparse.ArgumentParser(prog="python -m phd_swarm.tools.log_check",
                                description="Are all of a run's step messages in its log?")
    p.add_argument("log", help="the run's MCAP log")
    p.add_argument("--config", help="the run's config, for a log recorded without one")
    p.add_argument("--json", action="store_true", help="print the full report as JSON")
    args = p.parse_args(argv)
    try:
        rc = load_run_config(args.config) if args.config else None
        report = check_log(args.log, rc)
    except (LogError, ValueError) as exc:
        print(f"log_check: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(report.to_dict(), indent=2))
    else:
        print(f"{args.log}: {report.describe()}")
    return 0 if report.complete else 1


if __name__ == "__main__":
    sys.exit(main())
