"""Papaioannou tables: searched area, OSPA and tracking ratio per cell from a sweep's series."""

from __future__ import annotations

import csv
import json
from types import SimpleNamespace

import numpy as np
import pytest

from phd_swarm.core.controllers.sat_search_track.controller import OverlapStep
from phd_swarm.core.estimators.papaioannou.figures import step_figures
from phd_swarm.tools import papaioannou_tables as pt
from phd_swarm.tools.sweep import save_series


def _sweep(tmp_path):
    """Two methods x two seeds, series made by hand."""
    rows = []
    t = np.arange(4.0)
    for method, seen in (("a", 1.0), ("b", 0.5)):
        for seed in (0, 1):
            key = f"{method}_r002_t002_res1_s{seed}"
            save_series(tmp_path / "series" / f"{key}.npz", {
                "t": t, "ospa": np.full(4, 10.0 * (seed + 1)),
                "searched_area": np.linspace(0.0, seen, 4),
                "targets_alive": np.array([2.0, 2.0, 1.0, 0.0]),
                "targets_tracked": np.array([0.0, 1.0, 1.0, 0.0]) * (1 if method == "a" else 0),
                "agents_tracking": np.array([0.0, 1.0, 1.0, 0.0])}, "h")
            rows.append({"trial": key, "method": method, "robots": 2, "targets": 2,
                         "seed": seed})
    with open(tmp_path / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    (tmp_path / "spec.json").write_text(json.dumps({"name": "papaioannou_fig5a",
                                                    "methods": {"a": {}, "b": {}}}))
    return tmp_path


def test_cells_hold_the_means_over_runs(tmp_path):
    (tmp_path / "series").mkdir()
    table = pt.sweep_table(_sweep(tmp_path))
    a, b = table["cells"]
    assert (a["method"], a["agents"], a["targets"], a["runs"]) == ("a", 2, 2, 2)
    assert a["stats"]["searched_final_pct"]["mean"] == pytest.approx(100.0)
    assert b["stats"]["searched_final_pct"]["mean"] == pytest.approx(50.0)
    assert a["stats"]["ospa_mean"]["mean"] == pytest.approx(15.0)
    assert a["stats"]["tracking_ratio"]["mean"] == pytest.approx(2.0 / 5.0)
    assert b["stats"]["tracking_ratio"]["mean"] == 0.0
    assert "0.25 for 2 agents" in table["paper"]
    assert pt.main([str(tmp_path)]) == 0
    assert (tmp_path / "papaioannou_fig5a_curves.png").is_file()
    assert "| a | 2 | 2 | 2 | 100 ± 0 |" in (tmp_path / "papaioannou_tables.md").read_text()


def test_a_missing_directory_is_an_error(tmp_path, capsys):
    assert pt.main([str(tmp_path / "nope")]) == 2
    assert "no such directory" in capsys.readouterr().err


class _View:
    def __init__(self, search, estimates):
        self.search = np.asarray(search, dtype=float)
        self._est = np.asarray(estimates, dtype=float).reshape(-1, 2)

    def estimates(self):
        return self._est


def test_step_figures_take_the_teams_best_search_value_and_gate_the_estimates():
    truth = np.array([[0.0, 0.0], [10.0, 0.0], [50.0, 50.0]])
    views = [_View([1.0, 0.0, 0.2, 0.0], [[1.0, 1.0]]), _View([0.0, 0.5, 0.9, 0.0], []),
             _View([0.0, 0.0, 0.0, 0.0], [[12.9, 0.0], [30.0, 30.0]])]
    f = step_figures(views, truth, 50.0, 2.0)
    assert f["searched_area"] == pytest.approx((1.0 + 0.5 + 0.9 + 0.0) / 4)
    assert (f["agents_tracking"], f["targets_alive"], f["targets_tracked"]) == (2.0, 3.0, 2.0)
    empty = step_figures([], np.empty((0, 2)), 50.0, 2.0)
    assert np.isnan(empty["searched_area"]) and empty["targets_tracked"] == 0.0


def test_per_target_readings_lifetimes_looks_and_overlaps_by_hand(tmp_path):
    """Three targets over four steps, two agents (module docstring's readings)."""
    pad = -1
    series = {
        "t": np.arange(4.0), "ospa": np.zeros(4), "searched_area": np.zeros(4),
        "agents_tracking": np.zeros(4),
        "targets_alive": np.array([2.0, 2.0, 1.0, 1.0]),
        "targets_tracked": np.array([1.0, 0.0, 1.0, 0.0]),
        "target_ids": np.array([[0, 1], [0, 1], [1, pad], [2, pad]]),
        "target_trackers": np.array([[1, 0], [0, 0], [2, pad], [0, pad]]),
        "target_in_view": np.array([[1, 0], [1, 2], [2, pad], [0, pad]]),
        "agents_looking": np.array([1.0, 0.0, 0.0, 1.0]),
        "overlap_tests": np.array([0.0, 1.0, 2.0, 0.0]),
        "overlaps_fired": np.array([0.0, 0.0, 1.0, 0.0])}
    v = pt.run_values(series, agents=2)
    # Target 0: 1 of 2 steps tracked, 1: 1 of 3, 2: 0 of 1 and never in a square.
    assert v["tracking_ratio"] == pytest.approx(2 / 6)
    assert v["per_target_all"] == pytest.approx((1 / 2 + 1 / 3 + 0) / 3)
    assert v["per_target_detected"] == pytest.approx((1 / 2 + 1 / 3) / 2)
    assert v["per_target_tracked"] == pytest.approx((1 / 2 + 1 / 3) / 2)
    assert (v["lifetime_mean"], v["targets_seen"]) == (2.0, 3.0)
    assert v["bound_pooled"] == pytest.approx(
        pt.tracking_ratio_bound(2, np.array([2, 3, 1])))
    assert v["looks_pct"] == pytest.approx(100 * 2 / 8)
    assert (v["overlap_tests"], v["overlaps_fired"]) == (3.0, 1.0)
    # The series survive the npz round trip as integers, -1 padded.
    save_series(tmp_path / "x.npz", series, "h")
    back = pt.load_series(tmp_path / "x.npz")
    assert back["target_ids"].dtype == np.int64
    assert pt.run_values(back, agents=2) == pytest.approx(v)
    old = pt.run_values({k: series[k] for k in ("t", "ospa", "searched_area",
                                                "agents_tracking", "targets_alive",
                                                "targets_tracked")}, agents=2)
    assert np.isnan(old["per_target_all"]) and np.isnan(old["looks_pct"])


class _Agent(_View):
    """An estimator view with an id and a square of side 10 m at ``where``."""

    def __init__(self, rid, where, estimates):
        super().__init__([0.0], estimates)
        self.robot_id = rid
        self.sensor_position = np.asarray(where, dtype=float)
        self.setup = SimpleNamespace(sensor=SimpleNamespace(
            inside=lambda p, s: (np.abs(np.asarray(p) - s) <= 5.0).all(axis=1)))


def test_step_figures_name_each_targets_trackers_and_the_agents_looking():
    truth = np.array([[0.0, 0.0], [10.0, 0.0], [50.0, 50.0]])
    views = [_Agent(0, [2.0, 0.0], [[1.0, 1.0]]), _Agent(3, [9.0, 2.0], [[12.0, 0.0],
                                                                        [0.5, 0.0]])]
    ctls = [SimpleNamespace(mode="look", overlap_step=OverlapStep(2, 1, 0.8)),
            SimpleNamespace(mode="track", overlap_step=OverlapStep(1, 0, 0.5))]
    f = step_figures(views, truth, 50.0, 2.0, ids=np.array([4, 7, 9]), controllers=ctls)
    assert f["target_ids"].tolist() == [4, 7, 9]
    assert f["target_trackers"].tolist() == [1 | 8, 8, 0]          # bits of agents 0 and 3
    assert f["target_in_view"].tolist() == [1, 8, 0]
    assert f["targets_tracked"] == 2.0
    assert (f["agents_looking"], f["overlap_tests"], f["overlaps_fired"],
            f["overlap_best"]) == (1.0, 3.0, 1.0, 0.5)
    with pytest.raises(ValueError, match="ids"):
        step_figures(views, truth, 50.0, 2.0, ids=np.array([1]))
