"""scripts/sweep.sh: spec validation, end-to-end runs, resuming, determinism, Ctrl-C."""

from __future__ import annotations

import csv
import dataclasses
import io
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config.sweep_spec import SpecError, find_spec, load_spec
from phd_swarm.engines import make_engine
from phd_swarm.tools import sweep, sweep_results

ROOT = Path(__file__).resolve().parents[2]
SWEEP = str(ROOT / "scripts" / "sweep.sh")

#: A 30 x 30 m map, 2 seeds x 2 team sizes x 2 methods, 15 steps each: ~0.1 s a trial.
TINY = """\
preset: dames_static
figure: tiny test sweep
methods: {PHD: phd, uniform: uniform}
robots: [2, 3]
targets: [6]
trials: 2
base_seed: 5
duration: 7.5
metric: mean
window: [2.5, 7.5]
scenario:
  env: {xmin: 0, ymin: 0, xmax: 30, ymax: 30}
  robot_start_box: [10, 0, 20, 5]
  targets: {draw_box: [-3, -3, 33, 33]}
quick:
  robots: [2]
  trials: 1
"""
TINY_TRIALS = 8


def _run(children, *args: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    proc = children.start([SWEEP, *args])
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        children.stop(proc)
        raise
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def _rows(path: Path) -> dict[str, dict[str, str]]:
    with open(path, newline="") as f:
        return {r["trial"]: r for r in csv.DictReader(f)}


def _without_timing(rows: dict[str, dict[str, str]]) -> dict[str, dict[str, str]]:
    return {k: {c: v for c, v in r.items() if c not in sweep_results.TIMING_COLUMNS}
            for k, r in rows.items()}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> tuple[Path, Path]:
    """The tiny spec and the output of its first run with 2 workers."""
    from phd_swarm.testing import ChildProcesses

    d = tmp_path_factory.mktemp("sweep")
    spec = d / "tiny.yaml"
    spec.write_text(TINY)
    out = d / "two_workers"
    with ChildProcesses() as children:
        res = _run(children, str(spec), "--workers", "2", "--out", str(out))
    assert res.returncode == 0, res.stdout + res.stderr
    assert f"{TINY_TRIALS} to run" in res.stdout
    return spec, out


@pytest.mark.slow
def test_sweep_writes_rows_series_plots_and_summary(tiny):
    spec, out = tiny
    rows = _rows(out / "results.csv")
    assert len(rows) == TINY_TRIALS
    assert {r["method"] for r in rows.values()} == {"PHD", "uniform"}
    assert {r["robots"] for r in rows.values()} == {"2", "3"}
    assert {r["seed"] for r in rows.values()} == {"5", "6"}
    for name in ("boxplot.png", "ospa_vs_time.png", "cardinality_vs_time.png"):
        data = (out / name).read_bytes()
        assert data.startswith(b"\x89PNG") and len(data) > 5000, name
    summary = (out / "summary.md").read_text()
    assert "| 2 |" in summary and "sweep wall time" in summary
    with open(out / "summary.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == 4          # 2 methods x 2 team sizes
    # The row's figures are those of the saved series (window 2.5-7.5 s, t = k dt).
    truth = {}
    for key, r in rows.items():
        s = sweep_results.load_series(out / "series" / f"{key}.npz")
        assert len(s["t"]) == 15 and str(s["config_hash"]) == r["config_hash"]
        w = (s["t"] >= 2.5) & (s["t"] <= 7.5)
        # The series are float32 (save_series); the row holds the exact figures.
        assert s["ospa"].dtype == np.float32 and s["t"].dtype == np.float64
        assert float(r["value"]) == pytest.approx(np.mean(s["ospa"][w]), rel=1e-6)
        assert float(r["ospa_median_window"]) == pytest.approx(np.median(s["ospa"][w]),
                                                               rel=1e-6)
        assert float(r["ospa_final"]) == pytest.approx(s["ospa"][-1], rel=1e-6)
        assert int(r["cardinality_est_final"]) == s["cardinality_est"][-1]
        truth.setdefault(r["seed"], set()).add(tuple(s["cardinality_true"]))
    # Common random numbers: every method and team size of a seed sees the same targets.
    assert all(len(v) == 1 for v in truth.values())
    assert len({next(iter(v)) for v in truth.values()}) == 2


@pytest.mark.slow
def test_rerun_skips_finished_trials_and_runs_only_missing_ones(tiny, tmp_path, children):
    spec, first = tiny
    out = tmp_path / "copy"
    shutil.copytree(first, out)
    before = (out / "results.csv").read_text()
    res = _run(children, str(spec), "--workers", "2", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert f"{TINY_TRIALS} done, 0 to run" in res.stdout
    assert (out / "results.csv").read_text() == before

    lines = before.splitlines(keepends=True)
    kept = lines[:1] + lines[1:6]                       # header + 5 rows: 3 missing
    (out / "results.csv").write_text("".join(kept))
    res = _run(children, str(spec), "--workers", "2", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert "5 done, 3 to run" in res.stdout
    assert res.stderr.count("OSPA") == 3                # one line per trial (no TTY)
    again = _rows(out / "results.csv")
    assert len(again) == TINY_TRIALS
    assert _without_timing(again) == _without_timing(_rows(first / "results.csv"))


@pytest.mark.slow
def test_results_do_not_depend_on_the_number_of_workers(tiny, tmp_path, children):
    spec, two = tiny
    one = tmp_path / "one_worker"
    res = _run(children, str(spec), "--workers", "1", "--out", str(one))
    assert res.returncode == 0, res.stderr
    assert _without_timing(_rows(one / "results.csv")) == _without_timing(
        _rows(two / "results.csv"))
    for f in (two / "series").glob("*.npz"):
        a, b = sweep_results.load_series(f), sweep_results.load_series(one / "series" / f.name)
        assert a.keys() == b.keys()
        for k in a:
            np.testing.assert_array_equal(a[k], b[k])


@pytest.mark.slow
def test_distributed_engine_gives_the_central_engines_results(tiny, tmp_path, children):
    spec, central = tiny
    out = tmp_path / "distributed"
    res = _run(children, str(spec), "--workers", "2", "--engine", "distributed",
               "--out", str(out))
    assert res.returncode == 0, res.stderr
    a, b = _rows(central / "results.csv"), _rows(out / "results.csv")
    assert a.keys() == b.keys()
    for key in a:
        assert (a[key]["engine"], b[key]["engine"]) == ("central", "distributed")
        # The engine is part of what a row was computed with: no resuming across engines.
        assert a[key]["config_hash"] != b[key]["config_hash"]
        for c in ("value", "ospa_final", "ospa_mean_window", "expected_cardinality_final"):
            assert float(b[key][c]) == pytest.approx(float(a[key][c]), rel=1e-9, abs=1e-12)
        for c in ("cardinality_true_final", "cardinality_est_final",
                  *sweep_results.PROTOCOL_COLUMNS):
            assert a[key][c] == b[key][c], (key, c)
    assert sweep.main([str(spec), "--engine", "distributed", "--out", str(central),
                       "--dry-run"]) == 2


@pytest.mark.slow
def test_changed_spec_is_refused_and_plot_only_redraws(tiny, tmp_path, capsys):
    spec, first = tiny
    out = tmp_path / "copy"
    shutil.copytree(first, out)
    changed = tmp_path / "tiny.yaml"
    changed.write_text(TINY.replace("duration: 7.5", "duration: 8.0"))
    assert sweep.main([str(changed), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "other settings" in err and "results.csv" in err

    (out / "boxplot.png").unlink()
    assert sweep.main([str(spec), "--out", str(out), "--plot-only"]) == 0
    assert (out / "boxplot.png").exists()
    assert sweep.main([str(spec), "--quick", "--out", str(tmp_path / "none"),
                       "--plot-only"]) == 2


@pytest.mark.slow
def test_ctrl_c_stops_workers_and_keeps_finished_rows(tmp_path, children):
    spec = tmp_path / "longer.yaml"
    spec.write_text(TINY.replace("trials: 2\n", "trials: 12\n", 1)
                    .replace("duration: 7.5", "duration: 15.0")
                    .replace("window: [2.5, 7.5]", "window: [5.0, 15.0]"))
    out = tmp_path / "out"
    proc = children.start([SWEEP, str(spec), "--workers", "1", "--out", str(out)])
    csv_path = out / "results.csv"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if csv_path.exists() and len(csv_path.read_text().splitlines()) >= 3:
            break
        time.sleep(0.1)
    assert proc.poll() is None, "the sweep ended before it could be interrupted"
    children.stop(proc, grace=20.0)
    out_text, err = proc.communicate()
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    done = _rows(csv_path)
    assert 2 <= len(done) < 48
    res = _run(children, str(spec), "--workers", "2", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert f"{len(done)} done, {48 - len(done)} to run" in res.stdout
    assert len(_rows(csv_path)) == 48


def test_progress_bar_on_a_tty_and_lines_otherwise():
    spec = load_spec(find_spec("dames_static"), quick=True)
    trials = spec.trials_list()[:3]
    row = {"metric": "final", "value": 1.0, "ospa_final": 1.0, "wall_s": 2.0}
    tty = io.StringIO()
    p = sweep.Progress("x", trials, 1, tty, tty=True)
    p.finished(trials[0], row, None)
    p.close()
    assert "\r" in tty.getvalue() and "2/4" in tty.getvalue() and "ETA" in tty.getvalue()
    lines = io.StringIO()
    p = sweep.Progress("x", trials, 0, lines, tty=False)
    p.finished(trials[0], row, None)
    p.finished(trials[1], None, "RuntimeError: boom")
    assert "\r" not in lines.getvalue()
    assert lines.getvalue().count("\n") == 2 and "failed: RuntimeError: boom" in lines.getvalue()


def test_a_failing_trial_is_reported_not_raised():
    trial = load_spec(find_spec("dames_static"), quick=True).trials_list()[0]
    _, row, series, error, _ = sweep._work(dataclasses.replace(trial, engine="bogus"))
    assert row is None and series is None
    assert error.startswith("ValueError") and "bogus" in error



def test_plan_runs_seed_by_seed_so_a_partial_sweep_is_balanced(tmp_path):
    spec = load_spec(find_spec("dames_static"))
    done, todo, stray = sweep.plan(spec, sweep_results.ResultsFile(tmp_path / "results.csv"))
    assert (len(done), len(todo), stray) == (0, 600, 0)
    indices = [t.index for t in todo]
    assert indices == sorted(indices)
    # Cut anywhere: every cell (method x robots x targets) has n or n + 1 seeds.
    for cut in (1, 59, 60, 61, 233, 599):
        per_cell: dict[tuple, int] = {}
        for t in todo[:cut]:
            cell = (t.method, t.robots, t.targets)
            per_cell[cell] = per_cell.get(cell, 0) + 1
        counts = [per_cell.get((t.method, t.robots, t.targets), 0) for t in todo[:60]]
        assert max(counts) - min(counts) <= 1, cut
    # Within a seed, the longest trials first.
    first = [t.cost() for t in todo[:60]]
    assert first == sorted(first, reverse=True)


def test_full_forms_write_to_the_tracked_results_folder(monkeypatch, tmp_path):
    full = load_spec(find_spec("chen_clustered"))
    quick = load_spec(find_spec("chen_clustered"), quick=True)
    monkeypatch.setenv("PHD_SWARM_ROOT", str(tmp_path))
    assert sweep.default_out(full) == tmp_path / "results" / "sweeps" / "chen_clustered"
    assert sweep.default_out(quick) == tmp_path / "runs" / "sweeps" / "chen_clustered_quick"
    # results/ is in git (runs/ is not): committed rows are resumed by the next session.
    ignored = (ROOT / ".gitignore").read_text().split()
    assert "/runs/" in ignored and not any(p.startswith("/results") for p in ignored)


# ------------------------------------------------------------------------------- specs
@pytest.mark.parametrize("quick", [False, True])
@pytest.mark.parametrize("name", ["dames_static", "dames_moving", "chen_clustered",
                                  "chen_resolution"])
def test_repository_specs_parse(name, quick):
    spec = load_spec(find_spec(name), quick=quick)
    trials = spec.trials_list()
    assert len({t.key for t in trials}) == len(trials)
    # Paired seeds: every cell runs the same seeds base_seed .. base_seed + trials - 1.
    seeds = {t.seed for t in trials}
    assert seeds == set(range(spec.base_seed, spec.base_seed + spec.trials))
    assert spec.label == (f"{name}_quick" if quick else name)


def test_full_specs_are_the_papers_experiments():
    s = load_spec(find_spec("dames_static"))
    assert s.robots == tuple(range(10, 101, 10)) and s.targets == (10, 30, 50)
    assert s.methods == {"PHD": "phd", "uniform": "uniform"} and s.trials == 10
    assert s.duration == 250.0 and s.metric == "final" and s.resolutions == (1.0,)
    m = load_spec(find_spec("dames_moving"))
    assert m.robots == tuple(range(10, 101, 10)) and m.targets == (10, 20, 30)
    assert m.duration == 500.0 and m.metric == "mean" and m.window == (250.0, 500.0)
    c = load_spec(find_spec("chen_clustered"))
    assert c.robots == (60, 70, 80, 90) and c.trials == 10 and c.duration == 1000.0
    assert c.methods == {"D": "phd", "P": "chen_p", "O": "chen_o",
                         "O_laplace": "chen_o(cumulative_mode=laplace)"}
    assert c.metric == "median" and c.window == (300.0, 1000.0)
    r = load_spec(find_spec("chen_resolution"))
    assert len(r.resolutions) >= 2 and r.methods == {"D": "phd", "P": "chen_p", "O": "chen_o"}


BAD = [
    ("robotz: [1]\n", "robotz: unknown key"),
    ("engine: ros\n", "engine: expected one of ['central', 'distributed']"),
    ("robots: ten\n", "robots: expected a list"),
    ("robots: []\n", "robots: expected a non-empty list"),
    ("robots: [2, two]\n", "robots[1]: expected an integer >= 1"),
    ("trials: 1.5\n", "trials: expected an integer"),
    ("preset: dames_fancy\n", "preset: expected one of ['chen_clustered', 'dames_moving', "
                              "'dames_static', 'papaioannou', 'shirsat_berman', "
                              "'sung_tokekar'], got 'dames_fancy'"),
    ("methods: {PHD: lloyd}\n", "methods.PHD: unknown controller 'lloyd'"),
    ("methods: {}\n", "methods: expected at least one method"),
    ("methods: {O: {kind: chen_o, cumulative_mode: fancy}}\n",
     "methods.O.cumulative_mode: expected one of ['rate', 'literal', 'laplace'], got 'fancy'"),
    ("methods: {O: {cumulative_mode: rate}}\n", "methods.O.controller: missing"),
    ("methods: {O: {kind: chen_o, rho: 3}}\n", "methods.O.rho: unknown option"),
    ("methods: {O: {controller: chen_o, options: {rho_max: -1}}}\n",
     "methods.O.options.rho_max: expected a number in [0, 1000000], got -1"),
    ("methods: {O: {controller: chen_o, estimator: gm}}\n",
     "methods.O.estimator: unknown estimator 'gm'"),
    ("metric: max\n", "metric: expected one of"),
    ("window: [20, 30]\n", "window: [20, 30] s holds no step"),
    ("resolutions: [0.7]\n", "resolutions[0]:"),
    ("scenario: {robots: 4}\n", "scenario.robots: set by the sweep"),
    ("scenario: {robot_max_speed: fast}\n", "scenario: robot_max_speed: expected a number"),
    ("quick: {robots: [0]}\n", "quick.robots[0]: expected an integer >= 1"),
    ("quick: {preset: chen_clustered}\n", "quick.preset: unknown key"),
]


def _without_key(text: str, key: str) -> str:
    """``text`` without the top-level ``key`` and its indented block."""
    out, skipping = [], False
    for ln in text.splitlines(keepends=True):
        if not ln.startswith(" "):
            skipping = ln.startswith(f"{key}:")
        if not skipping:
            out.append(ln)
    return "".join(out)


@pytest.mark.parametrize(("line", "message"), BAD, ids=[b[1].split(":")[0] for b in BAD])
def test_bad_specs_name_the_file_and_the_key(tmp_path, line, message):
    key = line.split(":")[0]
    path = tmp_path / "bad.yaml"
    path.write_text(_without_key(TINY, key) + line)
    with pytest.raises(SpecError) as exc:
        load_spec(path, quick=key == "quick")
    assert str(exc.value).startswith(f"{path}: {message}")


def test_a_method_with_controller_options_runs_with_them(tmp_path):
    path = tmp_path / "options.yaml"
    path.write_text(TINY.replace("methods: {PHD: phd, uniform: uniform}",
                                 "methods: {O: chen_o, OL: {kind: chen_o, "
                                 "cumulative_mode: laplace}}"))
    spec = load_spec(path, quick=True)
    assert spec.methods == {"O": "chen_o", "OL": "chen_o(cumulative_mode=laplace)"}
    o, ol = spec.trials_list()
    assert o.config_hash != ol.config_hash
    assert ol.scenario.system.controller == "chen_o"
    assert ol.scenario.system.option("cumulative_mode") == "laplace"
    assert ol.scenario.system.option("rho_max") == 0.0  # the sensing radius
    assert o.scenario.system.option("cumulative_mode") == "rate"
    row, series = sweep.run_trial(ol)
    assert row["controller"] == "chen_o(cumulative_mode=laplace)" and len(series["t"]) == 15
    assert all(row[c] == 0 for c in sweep_results.PROTOCOL_COLUMNS)


def test_bad_spec_exits_2_before_any_trial(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(TINY.replace("robots: [2, 3]", "robots: []"))
    out = tmp_path / "out"
    assert sweep.main([str(path), "--out", str(out)]) == 2
    assert f"error: {path}: robots: expected a non-empty list" in capsys.readouterr().err
    assert not out.exists()
    assert sweep.main(["no_such_spec"]) == 2
    assert "unknown sweep spec" in capsys.readouterr().err
    path.write_text("preset: [unclosed\n")
    assert sweep.main([str(path)]) == 2
    assert "not valid YAML" in capsys.readouterr().err
    path.write_text(TINY)
    assert sweep.main([str(path), "--quick", "--dry-run", "--out", str(out)]) == 0
    assert "2 trials" in capsys.readouterr().out


def test_box_plot_title_says_how_many_trials_each_box_holds():
    from phd_swarm.tools.sweep_plots import trials_per_box

    assert trials_per_box({("PHD", 10): [1] * 10, ("PHD", 20): [1] * 10}, 10) == \
        "10 trials per box"
    assert trials_per_box({("PHD", 10): [1] * 4, ("PHD", 20): [1] * 3}, 10) == \
        "3-4 trials per box (of 10)"
    assert trials_per_box({}, 10) == "0 trials per box (of 10)"


def test_panel_titles_say_initial_targets_when_targets_are_born():
    from phd_swarm.config.sweep_spec import find_spec, load_spec
    from phd_swarm.tools.sweep_plots import _panel_title

    moving, static = (load_spec(find_spec(n)) for n in ("dames_moving", "dames_static"))
    assert _panel_title({"targets": 20}, moving) == "20 initial targets"
    assert _panel_title({"targets": 30}, static) == "30 targets"


@pytest.mark.parametrize(("labels", "width", "ncols"), [
    (["D (phd)", "P (chen_p)", "O (chen_o)"], 5.5, 3),
    (["D (phd)", "P (chen_p)", "O (chen_o)", "O_laplace (chen_o(cumulative_mode=laplace))"],
     5.5, 2),
    (["PHD (phd)", "uniform (uniform)"], 16.5, 2),
])
def test_box_plot_legend_fits_under_the_figure(labels, width, ncols):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    from phd_swarm.tools.sweep_plots import legend_columns

    assert legend_columns(labels, width) == ncols
    fig = Figure(figsize=(width, 3.6), layout="constrained")
    canvas = FigureCanvasAgg(fig)
    fig.subplots()
    legend = fig.legend(handles=[Patch(label=x) for x in labels], loc="outside lower center",
                        ncols=ncols)
    canvas.draw()
    box = legend.get_window_extent(canvas.get_renderer())
    assert box.x0 >= 0 and box.x1 <= fig.bbox.x1, (box, fig.bbox)


@pytest.mark.parametrize("folder", sorted(p.name for p in (ROOT / "results" / "sweeps").glob("*")
                                          if (p / "results.csv").exists()))
def test_committed_results_belong_to_their_specs(folder):
    # The full forms' rows are in git so that later sessions resume them: a change to a
    # spec or a preset that would orphan them (or mix them with new ones) fails here.
    out = ROOT / "results" / "sweeps" / folder
    spec = load_spec(find_spec(folder))
    results = sweep_results.ResultsFile(out / "results.csv")
    done, todo, stray = sweep.plan(spec, results)
    assert stray == 0 and len(done) == len(results.rows) > 0
    for trial in done[:5]:
        series = sweep_results.load_series(out / "series" / f"{trial.key}.npz")
        assert str(series["config_hash"]) == trial.config_hash
        assert len(series["ospa"]) == trial.scenario.steps


def test_a_controller_registered_by_a_plugin_runs_in_a_sweep(tmp_path):
    # The spec lists examples/stationary_controller.py (relative to the spec) as a plugin
    # and names its controller as a method; the sweep runner is not told about it.
    spec_path = ROOT / "examples" / "stationary_sweep.yaml"
    assert sweep.main([str(spec_path), "--quick", "--workers", "1", "--out",
                       str(tmp_path)]) == 0
    rows = {r["method"]: r for r in csv.DictReader(open(tmp_path / "results.csv"))}
    assert rows["stationary"]["controller"] == "stationary"
    trial = next(t for t in load_spec(spec_path, quick=True).trials_list()
                 if t.method == "stationary")
    engine = make_engine(trial.engine, trial.scenario)
    start = engine.world.robot_positions.copy()
    engine.run()
    assert np.array_equal(engine.world.robot_positions, start), "a stationary team stays put"
    row, _ = sweep.run_trial(trial)
    assert float(rows["stationary"]["ospa_final"]) == row["ospa_final"]


def test_a_sung_sweep_scores_its_own_estimates_and_saves_the_papers_figures(tmp_path):
    # Sung & Tokekar's system has no grid PHD: the sweep scores the estimator's own
    # targets and keeps the figures of its estimator part (sung_figures) in the series.
    assert sweep.main(["sung_planners", "--quick", "--workers", "1", "--out",
                       str(tmp_path)]) == 0
    rows = list(csv.DictReader(open(tmp_path / "results.csv")))
    assert sorted(r["method"] for r in rows) == ["largest_exact", "lawn_exact",
                                                 "nearest_exact"]
    for r in rows:
        s = sweep_results.load_series(tmp_path / "series" / f"{r['trial']}.npz")
        assert len(s["ospa"]) == 600 and np.all(s["cardinality_true"] == 10)
        assert {"components", "tracks", "mahal_closest", "largest_variance"} <= set(s)
        assert np.nanmax(s["tracks"]) > 0 and np.all(s["ospa"] <= 100.0)
        assert float(r["ospa_mean_window"]) == pytest.approx(float(np.mean(s["ospa"])))


def test_the_protocol_columns_are_the_exchanges_declared_counters():
    from phd_swarm.core import registry

    voronoi = registry.lookup("exchange", "voronoi_phd").counters
    assert sweep_results.PROTOCOL_COLUMNS == voronoi and "timeouts" in voronoi
    # The schema of the stored sweeps is unchanged by the declaration.
    stored = (ROOT / "results" / "sweeps" / "dames_static" / "results.csv").open().readline()
    assert tuple(stored.strip().split(",")) == sweep_results.COLUMNS
