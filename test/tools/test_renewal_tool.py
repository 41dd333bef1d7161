"""``python -m phd_swarm.tools.renewal``: the exact inter-arrival tables and the plot."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_quick_run_prints_the_tables_and_writes_the_plot(tmp_path):
    out = tmp_path / "renewal"
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "phd_swarm.tools.renewal", "--quick",
                           "--out", str(out)], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    elapsed = time.perf_counter() - t0
    assert proc.returncode == 0, proc.stderr
    assert elapsed < 30
    text = proc.stdout
    assert "Fig. 5a: 3 robots on 5 x 5 m" in text and "Table 1: 20 robots" in text
    assert "| robot-any: gap between meetings (Kac) | 219.1 (0.31 s) **" in text
    assert "9.50, 21.50, 2.26" in text  # the paper's ratios
    assert (out / "renewal.md").read_text() in text
    png = (out / "renewal.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    data = json.loads((out / "renewal.json").read_text())
    assert data["quick"] is True
    fig5 = data["fig5"]["0.5 m/4"]
    assert abs(fig5["pair_gap"] - 119.25) < 0.1
    assert data["fig5"]["0.25 m/4"]["robot_first"] is None  # too large for --quick
    sims = data["simulation"]
    assert {s["robots"] for s in sims} == {3, 10, 20}
    # Every simulated point within 1.5 of its 95 % half-widths (~3 sd) of the exact value.
    assert all(abs(s["mean"] - s["exact"]) < 1.5 * s["half_width"] for s in sims)
