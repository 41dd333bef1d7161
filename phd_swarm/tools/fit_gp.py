"""Fit the GP motion model's hyperparameters offline (Sung & Tokekar Sec. V-B, eq. 7-8).

``python -m phd_swarm.tools.fit_gp [--config config/sung_moving.yaml] [--tracks 40]
[--steps 2000] [--window 20] [--seed 1000]``

"The hyperparameters (sigma_f and lambda) for the kernel are learned offline using a
training set consisting of noisy observations of the target's motion." The training set:
``--tracks`` targets of the scenario's own motion model (``targets`` of the config: the
turning walk of Sec. VI-A.4), simulated for ``--steps`` steps from seeds that no
experiment uses (``--seed`` and up), each position observed with the scenario's
measurement noise (``models.measurement.variance``). The hyperparameters maximise the GP's
log marginal likelihood over windows of ``--window`` points
(:func:`phd_swarm.core.estimators.sung.gp_motion.fit_hyperparameters`). Prints the
``system.options`` block to paste into a config, with the figures of the fit.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from phd_swarm.config import load_run_config
from phd_swarm.core.estimators.sung.gp_motion import fit_hyperparameters
from phd_swarm.sim.targets import make_targets

ROOT = Path(__file__).resolve().parents[2]


def training_tracks(scenario, tracks: int, steps: int, seed: int
                    ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Noisy observations of ``tracks`` targets of ``scenario`` over ``steps`` steps.

    Targets are drawn as the world draws them (``make_targets``), one population per seed
    ``seed, seed + 1, ...`` until ``tracks`` are collected; each position gets
    N(0, variance I) noise from a generator seeded with ``[seed, 1]``.
    """
    noise = np.random.default_rng([seed, 1])
    sd = np.sqrt(scenario.models.measurement.variance)
    out: list[tuple[np.ndarray, np.ndarray]] = []
    s = seed
    while len(out) < tracks:
        rng = np.random.default_rng(s)
        population = make_targets(rng, scenario)
        path = np.empty((steps, len(population.ids), 2))
        for k in range(steps):
            path[k] = population.positions
            population.step(rng, scenario.dt)
        for i in range(path.shape[1]):
            if len(out) < tracks:
                obs = path[:, i, :] + sd * noise.standard_normal((steps, 2))
                out.append((np.arange(steps, dtype=float), obs))
        s += 1
    return out


def main(argv: list[str] | None = None) -> int:
    """Fit on training tracks of the config's targets and print the options block."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--config", default=str(ROOT / "config" / "sung_moving.yaml"))
    p.add_argument("--tracks", type=int, default=40)
    p.add_argument("--steps", type=int, default=2000)
    p.add_argument("--window", type=int, default=20)
    p.add_argument("--seed", type=int, default=1000)
    args = p.parse_args(argv)
    scenario = load_run_config(args.config).scenario
    t0 = time.perf_counter()
    data = training_tracks(scenario, args.tracks, args.steps, args.seed)
    hp = fit_hyperparameters(data, args.window)
    print(f"# fitted on {args.tracks} tracks x {args.steps} steps of {scenario.targets.kind} "
          f"(seeds {args.seed}..), window {args.window}, in {time.perf_counter() - t0:.1f} s")
    print("options:")
    print(f"  gp_signal_sd: {hp.signal_sd:.4g}")
    print(f"  gp_length_scale: {hp.length_scale:.4g}")
    print(f"  gp_noise_sd: {hp.noise_sd:.4g}")
    print(f"  gp_window: {hp.window}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
