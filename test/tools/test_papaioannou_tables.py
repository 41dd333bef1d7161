"""Papaioannou tables: searched area, OSPA and tracking ratio per cell from a sweep's series."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from phd_swarm.core.estimators.papaioannou_figures import step_figures
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
