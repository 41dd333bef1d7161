"""Every spec of config/sweeps resumes from its rows in git, with no option (issue 33)."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest

from phd_swarm.config.sweep_spec import find_spec, load_spec
from phd_swarm.tools import sweep

ROOT = Path(__file__).resolve().parents[2]
SPECS = sorted(p.stem for p in (ROOT / "config" / "sweeps").glob("*.yaml"))


@pytest.mark.parametrize("name", SPECS)
def test_dry_run_counts_every_committed_row_as_done(name, monkeypatch, capsys):
    monkeypatch.setenv("PHD_SWARM_ROOT", str(ROOT))
    folder = ROOT / "results" / "sweeps" / name
    code = sweep.main([name, "--dry-run"])
    out, err = capsys.readouterr()
    assert code == 0, err
    m = re.search(r"(\d+) trials .*, (\d+) done, (\d+) to run; results in (\S+)", out)
    assert m, out
    total, done, todo = (int(g) for g in m.groups()[:3])
    assert Path(m.group(4)) == folder and total == done + todo
    # The rows in git whose trial and config_hash are the spec's: every one of them is
    # counted done, and there are no others.
    hashes = {t.key: t.config_hash for t in load_spec(find_spec(name)).trials_list()}
    path = folder / "results.csv"
    rows = list(csv.DictReader(path.open())) if path.exists() else []
    matching = sum(1 for r in rows if hashes.get(r["trial"]) == r["config_hash"])
    assert done == matching == len(rows)
