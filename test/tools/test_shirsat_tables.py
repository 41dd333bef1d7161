"""Shirsat & Berman's tables from a (quick) sweep: renewal times beside the exact ones."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.tools.shirsat_tables import run_values

ROOT = Path(__file__).resolve().parents[2]


def test_run_values_count_renewals_per_robot_step_and_the_first_full_reward():
    t = np.arange(10.0)
    series = {"t": t, "robots_meeting": np.array([0, 2, 0, 0, 3, 0, 0, 0, 0, 1.0]),
              "all_found": np.array([0, 0, 0, 0, 0, 1, 0, 1, 1, 1.0]),
              "reward_mean": np.linspace(0, 3, 10), "reward_ospa_mean": np.full(10, 0.5)}
    v = run_values(series, robots=3, targets=3)
    assert v["interarrival_s"] == 3 * 10 / 6 and v["renewals"] == 6.0
    assert v["t_reward_s"] == 5.0 and v["reward_final"] == 3.0
    series["robots_meeting"][:] = 0
    series["all_found"][:] = 0
    v = run_values(series, robots=3, targets=3)
    assert np.isnan(v["interarrival_s"]) and np.isnan(v["t_reward_s"])


def test_tables_of_the_committed_small_sweep(tmp_path):
    src = ROOT / "results" / "sweeps" / "shirsat_small"
    res = subprocess.run([sys.executable, "-m", "phd_swarm.tools.shirsat_tables", str(src),
                          "--out", str(tmp_path)], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    (table,) = json.loads((tmp_path / "shirsat_tables.json").read_text())
    assert table["runs"] == 100 and table["robots"] == 3 and table["grid"] == "0.5 m / 4"
    # Kac's mean inter-arrival of a robot's renewals on the 0.5 m grid of 5 x 5 m, 1 s steps,
    # and the 100 runs' pooled estimate of it (within 10 %: uniform, not stationary, starts).
    assert table["exact_interarrival_s"] == pytest.approx(59.93, abs=0.01)
    assert table["pooled_interarrival_s"] == pytest.approx(59.93, rel=0.1)
    assert table["stats"]["t_reward_s"]["n"] == 100
    assert "| shirsat_small | 3 / 3 / 5 m | 100 |" in (tmp_path / "shirsat_tables.md").read_text()
    assert (tmp_path / "shirsat_reward_vs_time.png").read_bytes()[:4] == b"\x89PNG"
    bad = subprocess.run([sys.executable, "-m", "phd_swarm.tools.shirsat_tables",
                          str(tmp_path / "none")], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "no such directory" in bad.stderr
