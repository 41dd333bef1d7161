"""The loss study's command line, on a tiny study."""

from __future__ import annotations

import csv

from phd_swarm.tools import loss_study


def test_a_tiny_study_writes_its_rows_and_the_loss_free_row_is_at_distance_zero(tmp_path,
                                                                               capsys):
    out = tmp_path / "study"
    code = loss_study.main(["--steps", "5", "--robots", "3", "--seeds", "1",
                            "--drops", "0", "0.1", "--delay", "0", "--out", str(out)])
    assert code == 0
    with open(out / "trials.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["condition"] for r in rows] == ["loss-free", "drop 10%"]
    assert tuple(rows[0]) == loss_study.TRIAL_COLUMNS
    free, lossy = rows
    assert float(free["l1_mean"]) == float(free["l1_max"]) == 0.0
    assert int(free["dropped"]) == 0 and int(free["resent"]) == 0
    assert int(lossy["dropped"]) > 0
    with open(out / "summary.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == 2
    assert (out / "loss.png").stat().st_size > 0
    assert "| dames_static | drop 10% |" in capsys.readouterr().out


def test_conditions_start_loss_free_and_end_with_the_delay_only_one():
    conds = loss_study.conditions([0.0, 0.05], delay=0.05, max_delay_rounds=2)
    assert [c.label for c in conds] == ["loss-free", "drop 5%", "delay 5% (<=2)"]
    assert conds[0].faults(3) is None
    assert conds[2].faults(3).max_delay_rounds == 2
