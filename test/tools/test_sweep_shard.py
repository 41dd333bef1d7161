"""``sweep.sh --shard K/N`` and ``--merge``: disjoint shards that merge into the whole sweep."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config.sweep_spec import find_spec, load_spec
from phd_swarm.tools import sweep, sweep_results
from phd_swarm.tools.sweep_shard import Shard

from .test_sweep import TINY, TINY_TRIALS


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _without_timing(rows: list[dict[str, str]]) -> dict[str, dict[str, str]]:
    out = {r["trial"]: {c: v for c, v in r.items() if c not in sweep_results.TIMING_COLUMNS}
           for r in rows}
    assert len(out) == len(rows), "a trial has two rows"
    return out


@pytest.mark.parametrize("n", [1, 2, 3, 7, 600])
def test_shards_are_disjoint_cover_the_plan_and_are_balanced(n):
    spec = load_spec(find_spec("dames_static"))
    trials = spec.trials_list()
    shards = [Shard(k, n).select(trials) for k in range(1, n + 1)]
    keys = [t.key for s in shards for t in s]
    assert sorted(keys) == sorted(t.key for t in trials)       # a cover, and disjoint
    assert max(map(len, shards)) - min(map(len, shards)) <= 1
    # Deterministic: the same on another machine, i.e. from a freshly loaded spec.
    again = load_spec(find_spec("dames_static")).trials_list()
    assert [[t.key for t in Shard(k, n).select(again)] for k in range(1, n + 1)] == \
        [[t.key for t in s] for s in shards]


def test_a_shard_does_not_depend_on_what_is_done(tmp_path):
    spec = load_spec(find_spec("dames_static"))
    shard = Shard(2, 5)
    mine = {t.key for t in shard.select(spec.trials_list())}
    results = sweep_results.ResultsFile(tmp_path / "results.csv")
    _, todo, _ = sweep.plan(spec, results, shard)
    assert {t.key for t in todo} == mine
    # Rows of finished trials (this shard's or others') change what is to do, never which
    # trials the shard holds.
    for t in spec.trials_list()[:9]:
        results.rows[t.key] = {"config_hash": t.config_hash}
    done, todo, stray = sweep.plan(spec, results, shard)
    assert {t.key for t in done + todo} == mine
    assert {t.key for t in done} == mine & {t.key for t in spec.trials_list()[:9]}
    assert stray == 9 - len(done)


@pytest.mark.parametrize(("text", "message"), [
    ("0/3", "1 <= K <= N"), ("4/3", "1 <= K <= N"), ("3", "expected K/N"),
    ("a/b", "expected K/N"), ("1/0", "1 <= K <= N")])
def test_bad_shards_are_refused_with_the_reason(text, message, capsys):
    with pytest.raises(ValueError, match=message):
        Shard.parse(text)
    with pytest.raises(SystemExit) as exc:
        sweep.parse_args(["dames_static", "--shard", text])
    assert exc.value.code == 2 and message in capsys.readouterr().err


def test_merge_runs_alone(capsys):
    for other in (["--shard", "1/2"], ["--scheduler", "tcp://127.0.0.1:1"], ["--dry-run"]):
        with pytest.raises(SystemExit):
            sweep.parse_args(["dames_static", "--merge", "a", *other])
        assert "--merge runs alone" in capsys.readouterr().err


@pytest.fixture(scope="module")
def sharded(tmp_path_factory) -> tuple[Path, Path, list[Path]]:
    """The tiny spec run whole (2 workers) and as 3 shards (1 worker each)."""
    d = tmp_path_factory.mktemp("shards")
    spec = d / "tiny.yaml"
    spec.write_text(TINY)
    whole = d / "whole"
    assert sweep.main([str(spec), "--workers", "2", "--out", str(whole)]) == 0
    for k in (1, 2, 3):
        assert sweep.main([str(spec), "--workers", "1", "--shard", f"{k}/3", "--out",
                           str(d / "sharded")]) == 0
    return spec, whole, [d / "sharded" / f"shard-{k}-of-3" for k in (1, 2, 3)]


@pytest.mark.slow
def test_merged_shards_equal_the_unsharded_run(sharded, tmp_path, capsys):
    spec, whole, shards = sharded
    sizes = [len(_rows(s / "results.csv")) for s in shards]
    assert sizes == [3, 3, 2]
    out = tmp_path / "merged"
    # Any order of the folders on the command line.
    assert sweep.main([str(spec), "--merge", *map(str, shards[::-1]), "--out", str(out)]) == 0
    assert f"merged {TINY_TRIALS} new row(s) from 3 folder(s)" in capsys.readouterr().out
    merged = _rows(out / "results.csv")
    assert _without_timing(merged) == _without_timing(_rows(whole / "results.csv"))
    # In the order a one-worker run writes them: seed by seed, the longest first.
    order = [t.key for t in sweep.run_order(load_spec(spec).trials_list())]
    assert [r["trial"] for r in merged] == order
    for key in order:
        a = sweep_results.load_series(whole / "series" / f"{key}.npz")
        b = sweep_results.load_series(out / "series" / f"{key}.npz")
        assert a.keys() == b.keys()
        for name in a:
            np.testing.assert_array_equal(a[name], b[name])
    for name in ("boxplot.png", "summary.md", "spec.json"):
        assert (out / name).is_file(), name
    # The sessions of the shards are the merged sweep's.
    assert "3 session(s)" in (out / "summary.md").read_text()

    # Merging again adds nothing; the merged folder is a finished, resumable sweep.
    before = (out / "results.csv").read_text()
    assert sweep.main([str(spec), "--merge", *map(str, shards), "--out", str(out)]) == 0
    assert "merged 0 new row(s)" in capsys.readouterr().out
    assert (out / "results.csv").read_text() == before
    assert sweep.main([str(spec), "--out", str(out), "--dry-run"]) == 0
    assert f"{TINY_TRIALS} done, 0 to run" in capsys.readouterr().out


@pytest.mark.slow
def test_a_partial_merge_is_completed_by_merging_the_rest(sharded, tmp_path, capsys):
    spec, whole, shards = sharded
    out = tmp_path / "merged"
    assert sweep.main([str(spec), "--merge", str(shards[0]), "--out", str(out)]) == 0
    assert sweep.main([str(spec), "--out", str(out), "--dry-run"]) == 0
    assert "3 done, 5 to run" in capsys.readouterr().out
    assert sweep.main([str(spec), "--merge", *map(str, shards), "--out", str(out)]) == 0
    assert "merged 5 new row(s)" in capsys.readouterr().out
    assert _without_timing(_rows(out / "results.csv")) == \
        _without_timing(_rows(whole / "results.csv"))


@pytest.mark.slow
def test_merge_refuses_overlaps_other_specs_and_disagreeing_rows(sharded, tmp_path, capsys):
    spec, whole, shards = sharded
    out = tmp_path / "merged"

    def refused(*sources: Path, spec_path: Path = spec) -> str:
        before = (out / "results.csv").read_text() if (out / "results.csv").exists() else None
        assert sweep.main([str(spec_path), "--merge", *map(str, sources), "--out",
                           str(out)]) == 2
        after = (out / "results.csv").read_text() if (out / "results.csv").exists() else None
        assert after == before, "a refused merge wrote rows"
        return capsys.readouterr().err

    # The same shard twice, or shards of another N: overlap.
    assert "shards overlap" in refused(shards[0], shards[0])
    assert "shards overlap" in refused(shards[0], whole)
    # Not a shard's folder.
    assert "no results.csv" in refused(tmp_path)
    # Rows of another spec (here: another duration).
    changed = tmp_path / "tiny.yaml"
    changed.write_text(TINY.replace("duration: 7.5", "duration: 8.0"))
    assert "run with other settings" in refused(shards[0], spec_path=changed)
    # A row whose series is missing.
    broken = tmp_path / "broken"
    shutil.copytree(shards[1], broken)
    first = _rows(broken / "results.csv")[0]["trial"]
    (broken / "series" / f"{first}.npz").unlink()
    assert f"{first}.npz: missing" in refused(broken)
    # A row that disagrees with the one already merged.
    assert sweep.main([str(spec), "--merge", str(shards[2]), "--out", str(out)]) == 0
    capsys.readouterr()
    forged = tmp_path / "forged"
    shutil.copytree(shards[2], forged)
    rows = _rows(forged / "results.csv")
    rows[0]["ospa_final"] = str(float(rows[0]["ospa_final"]) + 0.5)
    rows[1]["wall_s"] = str(float(rows[1]["wall_s"]) + 9.0)   # timings may differ
    with open(forged / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=sweep_results.COLUMNS)
        w.writeheader()
        w.writerows(rows)
    err = refused(forged)
    assert f"row {rows[0]['trial']} disagrees with" in err and "in ospa_final" in err
    rows[0]["ospa_final"] = _rows(shards[2] / "results.csv")[0]["ospa_final"]
    with open(forged / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=sweep_results.COLUMNS)
        w.writeheader()
        w.writerows(rows)
    assert sweep.main([str(spec), "--merge", str(forged), "--out", str(out)]) == 0
    assert "merged 0 new row(s)" in capsys.readouterr().out
