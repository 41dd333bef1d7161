"""``sweep.sh --recheck N``: finished rows re-run on the current code come out the same."""

from __future__ import annotations

import csv
from pathlib import Path

from phd_swarm.tools import sweep, sweep_results

SPEC = str(Path(__file__).resolve().parents[2] / "examples" / "stationary_sweep.yaml")


def test_recheck_reruns_finished_rows_and_catches_a_changed_one(tmp_path, capsys):
    assert sweep.main([SPEC, "--quick", "--workers", "1", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    assert sweep.main([SPEC, "--quick", "--out", str(tmp_path), "--recheck", "2"]) == 0
    out = capsys.readouterr().out
    assert out.count(": same (") == 2 and "PHD_" in out and "stationary_" in out

    # A stored number that the code does not give any more is caught, and named.
    path = tmp_path / "results.csv"
    rows = list(csv.DictReader(path.open()))
    rows[0]["ospa_final"] = str(float(rows[0]["ospa_final"]) + 0.5)
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=sweep_results.COLUMNS)
        w.writeheader()
        w.writerows(rows)
    assert sweep.main([SPEC, "--quick", "--out", str(tmp_path), "--recheck", "2"]) == 1
    assert "DIFFERS in ospa_final" in capsys.readouterr().out


def test_recheck_fails_naming_the_folder_when_too_few_rows_are_there(tmp_path, capsys):
    # A recheck that finds nothing to compare (the wrong folder) must not pass.
    assert sweep.main([SPEC, "--quick", "--out", str(tmp_path), "--recheck", "1"]) == 1
    err = capsys.readouterr().err
    assert f"--recheck 1: {tmp_path} holds only 0 finished trial(s)" in err
