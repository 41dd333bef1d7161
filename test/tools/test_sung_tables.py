"""phd_swarm.tools.sung_tables: per-run values, statistics over seeds, outputs, errors."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.tools import sung_tables
from phd_swarm.tools.sung_tables import main, over_seeds, run_values, summary

NAN = math.nan
STEPS = 5
PNGS = ("sung_counts_vs_time.png", "sung_mahalanobis_vs_time.png", "sung_ospa_vs_time.png",
        "sung_largest_variance_vs_time.png", "sung_boxplots.png")


def _series(**over: list[float]) -> dict[str, np.ndarray]:
    """A 5-step series with every array of a Sung sweep; ``over`` replaces some."""
    base = {
        "t": np.arange(STEPS, dtype=float),
        "ospa": np.full(STEPS, 10.0), "ospa_localisation": np.full(STEPS, 5.0),
        "ospa_cardinality": np.full(STEPS, 5.0), "cardinality_true": np.full(STEPS, 10.0),
        "cardinality_est": np.full(STEPS, 9.0), "expected_cardinality": np.full(STEPS, 9.5),
        "components": np.full(STEPS, 12.0), "tracks": np.full(STEPS, 9.0),
        "weights_components": np.full(STEPS, 9.5), "weights_tracks": np.full(STEPS, 8.5),
        "mahal_closest": np.full(STEPS, 2.0), "mahal_closest_sq": np.full(STEPS, 4.0),
        "mahal_second": np.full(STEPS, 6.0), "largest_variance": np.full(STEPS, 50.0),
        "ospa_tracks": np.full(STEPS, 20.0),
    }
    base.update({k: np.asarray(v, dtype=float) for k, v in over.items()})
    return base


#: (method, seed) -> series. fp0 has the paper's Table I-II numbers, rule has none and no
#: confirmed track pair ever (Mahalanobis and largest variance NaN throughout).
SERIES = {
    ("fp0", 0): _series(components=[1, 2, 3, 4, 5], tracks=[0, 1, 1, 1, 2],
                        weights_components=[2, 2, 2, 2, 4], weights_tracks=[0, 1, 1, 1, 3],
                        mahal_closest=[NAN, 1, 2, 3, NAN],
                        mahal_closest_sq=[NAN, 2, 5, 10, NAN],
                        mahal_second=[NAN, 4, 5, 6, NAN], ospa=[10, 20, 30, 40, 50]),
    ("fp0", 1): _series(components=[2, 2, 2, 2, 2], tracks=[0, 2, 2, 2, 4],
                        mahal_closest=[NAN, 3, 3, 3, 3], mahal_closest_sq=[NAN, 9, 9, 9, 9],
                        mahal_second=[NAN, NAN, NAN, NAN, NAN], ospa=[20, 20, 20, 20, 20]),
    ("rule", 0): _series(mahal_closest=[NAN] * STEPS, mahal_closest_sq=[NAN] * STEPS,
                         mahal_second=[NAN] * STEPS, largest_variance=[NAN] * STEPS),
    ("rule", 1): _series(mahal_closest=[NAN] * STEPS, mahal_closest_sq=[NAN] * STEPS,
                         mahal_second=[NAN] * STEPS, largest_variance=[NAN] * STEPS,
                         tracks=[1, 1, 1, 1, 7]),
}


def _key(method: str, seed: int) -> str:
    return f"{method}_r001_t010_res1_s{seed}"


def make_sweep(root: Path, series: dict | None = None, partial_line: bool = False) -> Path:
    """A fake sweep directory: results.csv (the columns read) and series/<trial>.npz."""
    series = SERIES if series is None else series
    (root / "series").mkdir(parents=True)
    with open(root / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=("spec", "trial", "method", "seed", "steps",
                                          "ospa_final", "ospa_mean_window"))
        w.writeheader()
        for (method, seed), s in series.items():
            w.writerow({"spec": "fake", "trial": _key(method, seed), "method": method,
                        "seed": seed, "steps": STEPS, "ospa_final": s["ospa"][-1],
                        "ospa_mean_window": s["ospa"].mean()})
            np.savez_compressed(root / "series" / f"{_key(method, seed)}.npz",
                                config_hash=np.array("0123456789abcdef"), **s)
    if partial_line:
        with open(root / "results.csv", "a") as f:
            f.write("fake,fp0_r001_t010_res1_s7,fp0,7,5")  # a row being written
    return root


def test_run_values_known_series():
    v = run_values(SERIES[("fp0", 0)])
    assert v["components_mean"] == pytest.approx(3.0)
    assert v["components_sd"] == pytest.approx(math.sqrt(2.0))  # population sd over steps
    assert v["tracks_mean"] == pytest.approx(1.0)
    assert v["weights_components_mean"] == pytest.approx(2.4)
    assert v["mahal_closest_mean"] == pytest.approx(2.0)
    # pooled: mean(d^2) = 17/3, mean(d)^2 = 4
    assert v["mahal_closest_sd"] == pytest.approx(math.sqrt(17 / 3 - 4))
    assert v["mahal_second_mean"] == pytest.approx(5.0)
    assert v["tracks_final"] == 2.0
    assert v["weights_components_final"] == 4.0
    assert v["weights_tracks_final"] == 3.0
    assert v["ospa_mean"] == pytest.approx(30.0)
    assert v["ospa_tracks_mean"] == pytest.approx(20.0)


def test_pooled_sd_is_sd_over_targets_and_steps():
    rng = np.random.default_rng(3)
    d = rng.gamma(2.0, 1.5, size=(40, 10))  # steps x targets
    s = _series(mahal_closest=d.mean(axis=1), mahal_closest_sq=(d**2).mean(axis=1))
    d[[0, 7]] = np.nan  # steps without enough confirmed tracks
    s["mahal_closest"][[0, 7]] = np.nan
    s["mahal_closest_sq"][[0, 7]] = np.nan
    s["t"] = np.arange(40.0)
    v = run_values(s)
    ok = d[np.isfinite(d)]
    assert v["mahal_closest_mean"] == pytest.approx(ok.mean())
    assert v["mahal_closest_sd"] == pytest.approx(ok.std())


def test_over_seeds_leaves_nan_out():
    s = over_seeds([1.0, NAN, 3.0])
    assert s == {"mean": 2.0, "sd": pytest.approx(math.sqrt(2.0)), "n_valid": 2, "n": 3}
    assert math.isnan(over_seeds([NAN, NAN])["mean"])
    one = over_seeds([4.0])
    assert one["mean"] == 4.0 and math.isnan(one["sd"])


def test_main_writes_tables_and_plots(tmp_path, capsys):
    d = make_sweep(tmp_path / "sweep", partial_line=True)
    before = (d / "results.csv").read_bytes()
    assert main([str(d)]) == 0
    assert (d / "results.csv").read_bytes() == before  # read only
    for name in ("sung_tables.md", *PNGS):
        assert (d / name).is_file(), name
        assert (d / name).stat().st_size < 200_000
    printed = capsys.readouterr().out.split()
    assert str(d / "sung_tables.md") in printed

    summ = summary(d)
    assert list(summ["methods"]) == ["fp0", "rule"]  # order of results.csv, no spec.json
    fp0, rule = summ["methods"]["fp0"], summ["methods"]["rule"]
    assert fp0["seeds"] == [0, 1] and fp0["n"] == 2 and fp0["steps"] == [5, 5]
    assert fp0["runs"]["components_mean"] == pytest.approx([3.0, 2.0])
    assert fp0["mean"]["components_mean"] == pytest.approx(2.5)
    assert fp0["sd"]["components_mean"] == pytest.approx(math.sqrt(0.5))  # ddof=1
    assert fp0["runs"]["mahal_closest_sd"] == pytest.approx([math.sqrt(17 / 3 - 4), 0.0])
    assert fp0["mean"]["mahal_closest_mean"] == pytest.approx(2.5)
    assert fp0["runs"]["tracks_final"] == [2.0, 4.0]
    assert fp0["mean"]["tracks_final"] == pytest.approx(3.0)
    assert fp0["sd"]["tracks_final"] == pytest.approx(math.sqrt(2.0))
    assert fp0["mean"]["ospa_mean"] == pytest.approx(25.0)
    # seed 1 never has a second-closest track: left out, counted
    assert fp0["n_valid"]["mahal_second_mean"] == 1
    assert fp0["mean"]["mahal_second_mean"] == pytest.approx(5.0)
    assert fp0["paper"]["tracks_mean"] == 6.68 and fp0["group"] == "fp"
    assert rule["paper"] == {} and rule["group"] is None
    assert rule["n_valid"]["mahal_closest_mean"] == 0
    assert math.isnan(rule["mean"]["mahal_closest_mean"])
    assert rule["mean"]["tracks_final"] == pytest.approx(8.0)

    md = (d / "sung_tables.md").read_text()
    assert "paper Table I" in md and "paper Table II" in md
    assert "| Mean from components | 2.50 ± 0.71 (9.2995) | 12.00 ± 0.00 |" in md
    assert "5.00 [1 of 2 runs] (8.245)" in md
    assert "| Mean to closest | 2.50 ± 0.71 (3.0311) | n/a |" in md


def test_out_and_several_dirs(tmp_path):
    a = make_sweep(tmp_path / "a")
    b = make_sweep(tmp_path / "b", {k: v for k, v in SERIES.items() if k[0] == "fp0"})
    out = tmp_path / "out"
    assert main([str(a), str(b), "--out", str(out)]) == 0
    for sub in ("a", "b"):
        for name in ("sung_tables.md", *PNGS):
            assert (out / sub / name).is_file()
    assert not (a / "sung_tables.md").exists()


def test_spec_order_and_paper_lookup():
    assert sung_tables.paper_group("exact") == "belief"
    assert sung_tables.paper_group("largest_over") == "planner"
    assert sung_tables.paper_group("nearest_over") is None
    assert sung_tables.PAPER["exact"]["mahal_closest_mean"] == 2.3603
    assert sung_tables.PAPER["lawn_under"]["tracks_final"] == 10


def test_missing_directory_and_results(tmp_path, capsys):
    assert main([str(tmp_path / "nowhere")]) == 2
    assert "no such directory" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main([str(tmp_path / "empty")]) == 2
    assert "no results.csv" in capsys.readouterr().err


def test_missing_series_file_is_named(tmp_path, capsys):
    d = make_sweep(tmp_path / "sweep")
    gone = d / "series" / f"{_key('rule', 1)}.npz"
    gone.unlink()
    assert main([str(d)]) == 2
    assert str(gone) in capsys.readouterr().err
    with pytest.raises(sung_tables.SungTablesError, match="rule_r001_t010_res1_s1"):
        summary(d)
