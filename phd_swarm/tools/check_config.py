"""Validate config files: ``python -m phd_swarm.tools.check_config CONFIG...``.

Prints one line per file (scenario, team, steps) or the error naming the file and the key,
and exits 1 if any file is bad. The run scripts call it before starting a node, so a typo
fails at once instead of inside a ROS process. A file of an older version whose robots set
``controller`` (now ``scenario.system.controller``) is refused here, because a node given
the file directly would not see it; ``run_swarm.sh`` reads such a file the new way.
"""

from __future__ import annotations

import sys

from phd_swarm.config import load_run_config


def main(argv: list[str] | None = None) -> int:
    """Check every file named on the command line."""
    paths = sys.argv[1:] if argv is None else argv
    if not paths:
        print("usage: python -m phd_swarm.tools.check_config CONFIG...", file=sys.stderr)
        return 2
    bad = 0
    for path in paths:
        try:
            rc = load_run_config(path)
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            bad += 1
            continue
        if rc.moved:
            print(f"error: {path}: robot parameter(s) {', '.join(rc.moved)} moved to "
                  f"scenario.system (controller, options; docs/decisions.md): a node started "
                  f"from this file would not see them", file=sys.stderr)
            bad += 1
            continue
        s = rc.scenario
        print(f"{path}: {s.name}, {s.robots} robots, {s.targets.count} targets, "
              f"{s.steps} steps of {s.dt} s, {s.resolution} m bins")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
