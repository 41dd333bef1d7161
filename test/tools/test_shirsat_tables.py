"""Shirsat & Berman's tables from a (quick) sweep: renewal times beside the exact ones."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config.sweep_spec import find_spec, load_spec
from phd_swarm.tools.shirsat_tables import main, run_values
from phd_swarm.tools.sweep import save_series

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
    assert "| 3 / 3 / 5 m | 100 |" in (tmp_path / "shirsat_tables.md").read_text()
    assert (tmp_path / "shirsat_reward_vs_time.png").read_bytes()[:4] == b"\x89PNG"
    bad = subprocess.run([sys.executable, "-m", "phd_swarm.tools.shirsat_tables",
                          str(tmp_path / "none")], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "no such directory" in bad.stderr


def _sweep_dir(path: Path, renewals, true_share=None) -> Path:
    """A shirsat_small sweep of hand-made runs: 300 steps of 1 s, 3 robots, 3 targets.

    Run i has ``renewals[i]`` renewals; every run's mean reward cardinality is t / 100 and
    its members that match a target ``true_share`` of that (no such series if None).
    """
    trials = load_spec(find_spec("shirsat_small")).trials_list()
    (path / "series").mkdir(parents=True)
    (path / "spec.json").write_text(json.dumps({"name": "shirsat_small"}))
    lines = ["trial,method,seed,robots,targets,config_hash"]
    t = np.arange(300.0)
    for trial, n in zip(trials[:len(renewals)], renewals, strict=True):
        meeting = np.zeros(300)
        meeting[:n] = 1.0
        series = {"t": t, "robots_meeting": meeting, "all_found": np.zeros(300),
                  "reward_mean": t / 100.0, "reward_ospa_mean": np.full(300, 0.5)}
        if true_share is not None:
            series["reward_true_mean"] = true_share * t / 100.0
        save_series(path / "series" / f"{trial.key}.npz", series, trial.config_hash)
        lines.append(f"{trial.key},walk,{trial.seed},3,3,{trial.config_hash}")
    (path / "results.csv").write_text("\n".join(lines) + "\n")
    return path


def _table(tmp_path, *args, **kw) -> dict:
    src = _sweep_dir(tmp_path / "sweep", *args, **kw)
    assert main([str(src), "--out", str(tmp_path / "out")]) == 0
    (table,) = json.loads((tmp_path / "out" / "shirsat_tables.json").read_text())
    return table


def test_the_reward_at_the_pooled_interarrival_time_uses_the_ratio_of_totals(tmp_path):
    # 900 robot-seconds per run over 18 and 2 renewals: 50 s and 450 s per run (mean 250 s);
    # pooled 1800 / 20 = 90 s, where the mean cardinality is 0.9 of 3 targets: 30 %.
    table = _table(tmp_path, [18, 2], true_share=1.0)
    assert table["pooled_interarrival_s"] == pytest.approx(90.0)
    assert table["stats"]["interarrival_s"]["mean"] == pytest.approx(250.0)
    assert table["stats"]["reward_pct"]["mean"] == pytest.approx(30.0)
    assert table["stats"]["reward_all_pct"]["mean"] == pytest.approx(30.0)


def test_the_reward_counts_the_members_that_match_a_target_at_both_times(tmp_path):
    # Half the members match a target: at the pooled 90 s 0.45 of 3 (15 %), at the paper's
    # 68 s 0.34 of 3; every member counted, 30 % at 90 s.
    table = _table(tmp_path, [18, 2], true_share=0.5)
    s = table["stats"]
    assert s["reward_pct"]["mean"] == pytest.approx(15.0)
    assert s["reward_pct_paper_tau"]["mean"] == pytest.approx(100.0 * 0.34 / 3)
    assert s["reward_all_pct"]["mean"] == pytest.approx(30.0)
    assert s["reward_true_final"]["mean"] == pytest.approx(0.5 * 2.99)
    assert table["reading"].startswith("union by position")
    md = (tmp_path / "out" / "shirsat_tables.md").read_text()
    assert "| shirsat_small | union by position" in md and "| 15 ± 0 (median 15) |" in md


def test_series_saved_before_the_matching_give_no_matched_reward(tmp_path):
    table = _table(tmp_path, [18, 2])
    s = table["stats"]
    assert s["reward_pct"]["n_valid"] == s["reward_pct_paper_tau"]["n_valid"] == 0
    assert s["reward_all_pct"]["mean"] == pytest.approx(30.0)
