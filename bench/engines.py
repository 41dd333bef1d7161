"""Engine benchmark: steps per second of the distributed and the central engine.

Run with ``scripts/bench.sh engines``. For each case (a sweep spec's trial: scenario,
controller, team size, resolution), both engines run the same trial from its start: a
warm-up, then the measured steps. Prints the steps per second of each (CPU time of this
process, so that other load on the machine counts less), the ratio, and how far the two
runs are apart at the end (team PHD, relative to its mass, and robot positions), which the
tests bound at every step (test/engines/test_central.py).

Writes ``bench/results/engines-<date>.json``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from results_io import machine_meta, write_results

from phd_swarm.config.sweep_spec import find_spec, load_spec
from phd_swarm.engines import make_engine

#: (spec, method, robots, targets or None, resolution, warm-up steps, measured steps).
CASES = (
    ("dames_static", "PHD", 50, 30, 1.0, 20, 40),
    ("dames_moving", "PHD", 100, 20, 1.0, 20, 20),
    ("chen_clustered", "O", 70, None, 1.0, 20, 40),
    ("chen_resolution", "P", 70, None, 0.1, 4, 4),
)

QUICK = (("dames_static", "PHD", 10, 10, 1.0, 2, 3),
         ("chen_clustered", "O", 60, None, 1.0, 2, 3))


def _trial(spec: str, method: str, robots: int, targets: int | None, res: float):
    for t in load_spec(find_spec(spec)).trials_list():
        if (t.method, t.robots, t.resolution, t.index) == (method, robots, res, 0) and \
                (targets is None or t.targets == targets):
            return t
    raise ValueError(f"{spec}: no trial {method}, {robots} robots, {targets} targets, {res} m")


def _timed(engine, warmup: int, steps: int) -> float:
    engine.run(warmup)
    t0 = time.process_time()
    engine.run(steps)
    return steps / (time.process_time() - t0)


def measure(spec: str, method: str, robots: int, targets: int | None, res: float,
            warmup: int, steps: int) -> dict[str, object]:
    """Both engines on one trial; steps per second and their distance at the end."""
    trial = _trial(spec, method, robots, targets, res)
    sc = trial.scenario
    rates, engines = {}, {}
    for name in ("distributed", "central"):
        engines[name] = make_engine(name, sc)
        rates[name] = _timed(engines[name], warmup, steps)
    d, c = engines["distributed"], engines["central"]
    ref = c.team_weights()
    return {"spec": spec, "method": method, "controller": trial.controller,
            "robots": robots, "targets": trial.targets, "resolution": res,
            "warmup": warmup, "steps": steps,
            "distributed_steps_per_s": rates["distributed"],
            "central_steps_per_s": rates["central"],
            "speed_up": rates["central"] / rates["distributed"],
            "max_phd_difference_rel": float(np.abs(d.team_weights() - ref).max() / ref.sum()),
            "max_position_difference_m": float(np.abs(d.world.robot_positions
                                                      - c.world.robot_positions).max())}


def main(argv: list[str] | None = None) -> int:
    """Run the cases, print the table, write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two small cases, few steps")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)
    rows = []
    print(f"{'case':<44} {'distributed':>12} {'central':>9} {'x':>5} {'dPHD/mass':>10} "
          f"{'dq [m]':>9}")
    for case in QUICK if args.quick else CASES:
        r = measure(*case)
        rows.append(r)
        name = (f"{r['spec']} {r['method']} {r['robots']} robots {r['targets']} targets "
                f"{r['resolution']:g} m")
        print(f"{name:<44} {r['distributed_steps_per_s']:>10.2f}/s "
              f"{r['central_steps_per_s']:>7.2f}/s {r['speed_up']:>5.1f} "
              f"{r['max_phd_difference_rel']:>10.1e} {r['max_position_difference_m']:>9.1e}",
              flush=True)
    write_results(args.out, "engines", machine_meta(), rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
