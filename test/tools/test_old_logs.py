"""Logs recorded before the parts declared their outputs (issue 35) still evaluate.

``test/data/logs_before_issue35/`` holds two runs recorded at commit 074273e0, whose
recorders subscribed to every system's topics (channels nobody wrote). ``evaluate.sh``
scores each from its log alone, step by step equal to the monitor's OSPA recorded then, and
to the run's summary of that day.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LOGS = ROOT / "test" / "data" / "logs_before_issue35"


@pytest.mark.parametrize("name", ["dames", "sung"])
def test_a_log_from_before_the_declared_outputs_evaluates_as_it_did(name, tmp_path):
    then = json.loads((LOGS / f"{name}.summary.json").read_text())
    out = tmp_path / "eval"
    res = subprocess.run([str(ROOT / "scripts" / "evaluate.sh"), str(LOGS / f"{name}.mcap"),
                          "--out", str(out), "--no-plots", "--quiet"],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    now = json.loads((out / "evaluation.json").read_text())
    assert now["log_completeness"]["complete"] and now["steps"] == then["steps"]
    assert now["monitor_agreement"]["steps_compared"] == then["steps"]
    assert now["monitor_agreement"]["max_abs_ospa_difference"] == 0.0
    assert now["ospa_final"] == then["ospa_final"]
    assert now["controller"] == then["controller"]
