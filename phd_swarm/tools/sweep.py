"""Parameter sweeps: the papers' box plots, trial by trial.

``scripts/sweep.sh SPEC [--quick] [--workers N] [--engine E] [--out DIR] [--plot-only]
[--dry-run] [--recheck N] [--scheduler ADDRESS] [--shard K/N | --merge DIR...]``

SPEC is a name under ``config/sweeps/`` or a path to a spec file
(:mod:`phd_swarm.config.sweep_spec`). The specs in the repository reproduce Dames (2020)
Fig. 2 (static targets, final OSPA) and Fig. 5 (moving targets, mean OSPA over the last
250 s), and Chen, Dames & Park (2021) Fig. 3a/b (clustered targets, median OSPA over
300-1000 s, and the mean OSPA over time).

Each trial runs on the spec's engine (``engine:``, or ``--engine``): by default
:class:`phd_swarm.engines.central.CentralEngine`, one filter and one partition for the
team, or :class:`phd_swarm.engines.distributed.DistributedEngine`, the robots' protocol message by
message, which computes exactly the ROS stack's team PHD and is several times slower. The
two agree up to rounding (test/engines/test_central.py). Every step is scored with
:func:`phd_swarm.core.scoring.score_step`, as the live monitor does: the truth X^k is taken
before step k and compared with the team PHD after the step's update (OSPA, Dames eq. 12,
c = 10 m, p = 1). A trial's result depends only on its scenario (seed included),
controller and engine, never on the worker or the order.

Outputs in ``<out>`` (default ``results/sweeps/<name>``, kept in git, or
``runs/sweeps/<name>_quick``; ``_<engine>`` appended when ``--engine`` is not the spec's
own):

- ``results.csv``: one row per finished trial (:data:`COLUMNS`), appended and flushed as
  each trial finishes. Running the same command again skips the trials already there; a
  row whose ``config_hash`` does not match the spec's trial (the spec or the scenario
  presets changed) stops the sweep with an error instead of mixing results.
- ``series/<trial>.npz``: the per-step series of a trial (t, OSPA and its parts, true,
  estimated and expected cardinality), written before its CSV row.
- ``logs/<trial>.log``: the log lines of a trial (protocol warnings) and the error of a
  failed one, when there are any.
- ``spec.json`` (the resolved spec), ``sweep.json`` (wall and CPU time and failed trials of
  every session),
  and the plots and ``summary.csv`` / ``summary.md`` of :mod:`phd_swarm.tools.sweep_plots`.

The trials run on a local pool of ``--workers`` processes, or on a Dask cluster
(``--scheduler``, :mod:`phd_swarm.tools.sweep_cluster`) with the same rows. ``--shard K/N``
runs one of N disjoint parts of the sweep into ``<out>/shard-K-of-N`` and ``--merge``
joins such folders into ``<out>`` (:mod:`phd_swarm.tools.sweep_shard`). Progress and the
ETA: :mod:`phd_swarm.tools.sweep_progress`.

Exit codes: 0 done, 1 some trials failed (rerun to retry them) or a recheck failed, 2 bad
spec, results that belong to another spec, shards that do not merge, or a cluster that
cannot run the sweep, 130 interrupted (finished rows are kept; rerun to resume).
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import io
import json
import logging
import multiprocessing as mp
import os
import resource
import signal
import sys
import threading
import time
import traceback
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from phd_swarm.config.sweep_spec import (
    ENGINES,
    SpecError,
    SweepSpec,
    Trial,
    find_spec,
    load_spec,
)
from phd_swarm.engines import make_engine
from phd_swarm.tools.series_arrays import pad_rows
from phd_swarm.tools.sweep_progress import Progress, _hms
from phd_swarm.tools.sweep_results import (
    COLUMNS,
    PROTOCOL_COLUMNS,
    SERIES,
    TIMING_COLUMNS,
    ResultsFile,
    parse_row,
    save_series,
)

if TYPE_CHECKING:
    from phd_swarm.tools.sweep_shard import Shard

#: Threading variables set to 1 in the workers: one process per core, no oversubscription.
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
               "NUMEXPR_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")

# --------------------------------------------------------------------------- one trial
def run_trial(trial: Trial) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Run one trial to the end and score it.

    Returns
    -------
    row : dict
        The trial's results.csv row (:data:`COLUMNS`; ``spec`` left empty).
    series : dict of str to np.ndarray
        Per-step arrays (:data:`SERIES`), shape (steps,); ``t = k dt`` [s]; and the
        system's own figures, (steps,), or (steps, W) for one given as an array per step
        (:mod:`phd_swarm.tools.series_arrays`).
    """
    from phd_swarm.core.scoring import score_estimates, score_step

    wall0, cpu0 = time.perf_counter(), time.process_time()
    sc = trial.scenario
    engine = make_engine(trial.engine, sc)
    # An estimator observed through an image (the grid PHD) is scored from the team's
    # image, as the monitor scores it; the others give their estimates.
    grid = bool(sc.system.parts()["estimator"].observation.image)
    n = sc.steps
    s = {name: np.zeros(n) for name in SERIES}
    wide: dict[str, list] = {}
    for k in range(n):
        ids, truth = engine.world.truth()
        engine.step()
        if grid:
            score = score_step(sc.grid, engine.team_weights(), truth, sc.extraction,
                               sc.ospa_c, sc.ospa_p)
        else:
            score = score_estimates(*engine.team_estimates(), truth, sc.ospa_c, sc.ospa_p)
        s["t"][k] = k * sc.dt
        for name, value in score.row().items():
            s[name][k] = value
        # The system's own figures (e.g. Sung & Tokekar's tracks), saved with the series;
        # an array per step (e.g. one entry per target) becomes a (steps, W) series.
        for name, value in engine.figures(truth, ids).items():
            if np.ndim(value):
                wide.setdefault(name, [None] * n)[k] = value
            else:
                s.setdefault(name, np.full(n, np.nan))[k] = value
    s.update({name: pad_rows(rows) for name, rows in wide.items()})
    ospa = s["ospa"]
    a, b = trial.window
    in_window = (s["t"] >= a - 1e-9) & (s["t"] <= b + 1e-9)
    stats = {"final": float(ospa[-1]), "mean": float(np.mean(ospa[in_window])),
             "median": float(np.median(ospa[in_window]))}
    row = {"spec": "", "trial": trial.key, "method": trial.method,
           "controller": trial.controller, "engine": trial.engine, "robots": trial.robots,
           "targets": trial.targets,
           "resolution": trial.resolution, "seed": trial.seed, "trial_index": trial.index,
           "steps": n, "duration_s": n * sc.dt, "metric": trial.metric,
           "value": stats[trial.metric], "ospa_final": stats["final"],
           "ospa_mean_window": stats["mean"], "ospa_median_window": stats["median"],
           "window_start_s": a, "window_end_s": b,
           "cardinality_true_final": int(s["cardinality_true"][-1]),
           "cardinality_est_final": int(s["cardinality_est"][-1]),
           "expected_cardinality_final": float(s["expected_cardinality"][-1]),
           "cardinality_true_mean_window": float(np.mean(s["cardinality_true"][in_window])),
           **protocol_counters(engine),
           "wall_s": time.perf_counter() - wall0, "cpu_s": time.process_time() - cpu0,
           "config_hash": trial.config_hash}
    return row, s


def protocol_counters(engine) -> dict[str, int]:
    """:data:`PROTOCOL_COLUMNS` summed over the robots (all 0 without a protocol)."""
    counts = engine.counters()
    return {c: counts.get(c, 0) for c in PROTOCOL_COLUMNS}


class _Collect(logging.Handler):
    """Keeps the log lines of the trial running in each thread of this worker."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        # A list per thread (``local.lines``): a Dask worker may run several trials at once.
        self.local = threading.local()
        self.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        lines = getattr(self.local, "lines", None)
        if lines is not None:
            lines.append(self.format(record))


_COLLECT = _Collect()


def _collect_logs() -> None:
    """Keep phd_swarm's log lines for the trial's log file (idempotent)."""
    # The protocol's warnings (e.g. a cell that misses a neighbour) would otherwise
    # interleave with the progress lines.
    log = logging.getLogger("phd_swarm")
    if _COLLECT not in log.handlers:
        log.addHandler(_COLLECT)
    log.setLevel(logging.INFO)
    log.propagate = False


def _init_worker() -> None:
    # Ctrl-C reaches the whole process group; only the parent handles it (and terminates
    # the workers), so a worker never dies half-way through writing anything.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _collect_logs()


def _work(trial: Trial) -> tuple[Trial, dict | None, dict | None, str | None, list[str]]:
    lines = _COLLECT.local.lines = []
    try:
        row, series = run_trial(trial)
        return trial, row, series, None, lines
    except Exception as exc:  # noqa: BLE001 (reported, the sweep goes on)
        tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return trial, None, None, tb, lines


# ------------------------------------------------------------------------------ sweep
def run_order(trials: Iterable[Trial]) -> list[Trial]:
    """``trials`` in the order a sweep runs them: seed by seed, the longest first in a seed."""
    return sorted(trials, key=lambda t: (t.index, -t.cost()))


def plan(spec: SweepSpec, results: ResultsFile, shard: Shard | None = None
         ) -> tuple[list[Trial], list[Trial], int]:
    """Split the spec's trials (or one ``shard`` of them) into done and to-do; count strays.

    Returns
    -------
    done, todo : list of Trial
        Trials with a matching row, and the rest: seed by seed (trial index first), the
        longest first within a seed (shorter makespan). A sweep stopped part-way thus
        leaves every cell of the figure with the same number of seeds, give or take one,
        and the figures of a partial sweep are those of a smaller full one.
    stray : int
        Rows of results.csv that are no trial of this spec (or shard): ignored.

    Raises
    ------
    SpecError
        If a row has a trial's key but another ``config_hash``.
    """
    trials = spec.trials_list() if shard is None else shard.select(spec.trials_list())
    done, todo, clash = [], [], []
    for t in trials:
        row = results.rows.get(t.key)
        if row is None:
            todo.append(t)
        elif row["config_hash"] == t.config_hash:
            done.append(t)
        else:
            clash.append(t.key)
    if clash:
        raise SpecError(
            f"{results.path}: {len(clash)} row(s) hold results of the same trials run with "
            f"other settings (e.g. {clash[0]}): the spec, the presets or the tool changed "
            f"since. Use another --out, or delete those rows (or the file) to run them "
            f"again.")
    keys = {t.key for t in trials}
    stray = sum(1 for k in results.rows if k not in keys)
    return done, run_order(todo), stray


def _pool(workers: int):
    """A pool of ``workers`` fresh (spawned) processes with one thread each."""
    saved = {v: os.environ.get(v) for v in THREAD_VARS}
    os.environ.update({v: "1" for v in THREAD_VARS})
    try:
        return mp.get_context("spawn").Pool(workers, initializer=_init_worker)
    finally:
        for v, old in saved.items():
            if old is None:
                os.environ.pop(v, None)
            else:
                os.environ[v] = old


def _raise_interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def record_result(spec: SweepSpec, results: ResultsFile, out: Path, trial: Trial,
                  row: dict | None, series: dict | None, error: str | None,
                  log_lines: list[str]) -> None:
    """Write one trial's outcome: its log file (or none), then its series and its row.

    The row is appended last, so a row in results.csv always has its series; a failed
    trial (``error``) writes only its log.
    """
    log_file = out / "logs" / f"{trial.key}.log"
    if log_lines or error:
        log_file.parent.mkdir(parents=True, exist_ok=True)
        log_file.write_text("\n".join([*log_lines, *([error] if error else [])]) + "\n")
    elif log_file.exists():
        log_file.unlink()
    if error is None:
        assert row is not None and series is not None
        row["spec"] = spec.name
        (out / "series").mkdir(parents=True, exist_ok=True)
        save_series(out / "series" / f"{trial.key}.npz", series, trial.config_hash)
        results.append(row)


def run_trials(spec: SweepSpec, todo: Iterable[Trial], results: ResultsFile, out: Path,
               workers: int, progress: Progress) -> tuple[dict[str, str], bool]:
    """Run ``todo`` on ``workers`` processes, writing each result as it arrives.

    A trial's series goes to ``out/series/<trial>.npz`` before its row is appended to
    ``results``; its log lines (protocol warnings), if any, to ``out/logs/<trial>.log``
    (:func:`record_result`).

    Returns
    -------
    failed : dict of str to str
        Trial key -> the exception of each trial that raised.
    interrupted : bool
        True if Ctrl-C (or SIGTERM) stopped the sweep; the workers are terminated and the
        rows already written are kept.
    """
    todo = list(todo)
    failed: dict[str, str] = {}
    if not todo:
        return failed, False
    # Both signals are set explicitly: a process started in the background by a
    # non-interactive shell inherits SIGINT ignored, and Python keeps it so.
    old = {sig: signal.signal(sig, _raise_interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}
    pool = None
    try:
        pool = _pool(min(workers, len(todo)))
        it = pool.imap_unordered(_work, todo, chunksize=1)
        progress.tick()
        while True:
            try:
                trial, row, series, error, log_lines = it.next(timeout=1.0)
            except mp.TimeoutError:
                progress.tick()
                continue
            except StopIteration:
                break
            record_result(spec, results, out, trial, row, series, error, log_lines)
            if error is not None:
                failed[trial.key] = error
            progress.finished(trial, row, error)
        pool.close()
        pool.join()
        return failed, False
    except KeyboardInterrupt:
        if pool is not None:
            pool.terminate()
            pool.join()
        return failed, True
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


def _cpu_seconds() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _log_session(out: Path, session: dict[str, Any]) -> dict[str, Any]:
    path = out / "sweep.json"
    doc: dict[str, Any] = {"sessions": []}
    if path.exists():
        try:
            doc = json.loads(path.read_text())
        except json.JSONDecodeError:
            pass
    doc.setdefault("sessions", []).append(session)
    doc["wall_s"] = sum(s["wall_s"] for s in doc["sessions"])
    doc["cpu_s"] = sum(s["cpu_s"] for s in doc["sessions"])
    path.write_text(json.dumps(doc, indent=2) + "\n")
    return doc


def pick_for_recheck(done: list[Trial], n: int) -> list[Trial]:
    """The ``n`` cheapest of ``done`` (:meth:`Trial.cost`), one method after the other."""
    by_method: dict[str, list[Trial]] = {}
    for t in sorted(done, key=lambda t: (t.cost(), t.key)):
        by_method.setdefault(t.method, []).append(t)
    picked: list[Trial] = []
    while len(picked) < n and any(by_method.values()):
        for queue in by_method.values():
            if queue and len(picked) < n:
                picked.append(queue.pop(0))
    return picked


def recheck(done: list[Trial], results: ResultsFile, n: int) -> bool:
    """Re-run ``n`` finished trials (:func:`pick_for_recheck`) and compare with their rows.

    Every column but :data:`TIMING_COLUMNS` and ``spec`` must come out the same, after the
    same trip through the CSV text (so floats compare as stored). The trials run in a
    worker process made as the sweep's are (:func:`_pool`: one BLAS thread), since a
    multithreaded BLAS may sum in another order and change the last digits. Prints one
    line per trial; returns whether all agree.
    """
    ok = True
    picked = pick_for_recheck(done, n)
    with _pool(1) as pool:
        for trial, (row, _) in zip(picked, pool.imap(run_trial, picked), strict=True):
            ok &= _compare_row(trial, row, results.rows[trial.key])
    return ok


def _compare_row(trial: Trial, row: dict[str, Any], stored: dict[str, Any]) -> bool:
    """Print whether a re-run row equals its stored row (:func:`recheck`); True if so."""
    row["spec"] = stored["spec"]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=COLUMNS)
    w.writeheader()
    w.writerow(row)
    fresh = parse_row(next(csv.DictReader(io.StringIO(buf.getvalue()))))
    diff = [c for c in COLUMNS if c not in TIMING_COLUMNS and fresh[c] != stored[c]]
    verdict = "same" if not diff else "DIFFERS in " + ", ".join(
        f"{c} ({stored[c]!r} -> {fresh[c]!r})" for c in diff)
    print(f"recheck {trial.key}: {trial.metric} OSPA {stored['value']:.6f} m stored, "
          f"{fresh['value']:.6f} m now: {verdict} ({row['wall_s']:.1f} s)", flush=True)
    return not diff


def default_out(spec: SweepSpec) -> Path:
    """Where a sweep writes by default, under the repository (``$PHD_SWARM_ROOT``) or here.

    A full form writes to ``results/sweeps/<name>``, which is kept in git: the full forms
    take longer than one working session, so their rows are committed as they come and a
    later session (or another machine) resumes them. A quick form writes to
    ``runs/sweeps/<name>_quick`` (not in git). Trials run on another engine than the
    spec's own (``--engine``) write to a folder of their own, ``<name>_<engine>`` (or
    ``<name>_quick_<engine>``).
    """
    root = os.environ.get("PHD_SWARM_ROOT")
    base = Path(root) if root else Path.cwd()
    if spec.quick:
        return base / "runs" / "sweeps" / spec.label
    return base / "results" / "sweeps" / spec.label


def parse_args(argv: list[str]) -> argparse.Namespace:
    """Command-line options (see the module docstring)."""
    p = argparse.ArgumentParser(prog="scripts/sweep.sh",
                                description="Run a parameter sweep (config/sweeps/*.yaml); "
                                            "results, plots and a summary in "
                                            "results/sweeps/<name>/.")
    p.add_argument("spec", help="spec name under config/sweeps/ or path to a spec file")
    p.add_argument("--quick", action="store_true", help="the spec's quick form")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1, metavar="N",
                   help="worker processes (default: the number of CPUs, %(default)s)")
    p.add_argument("--out", type=Path, help="output directory (default "
                                            "results/sweeps/<name>, in git, for a full "
                                            "form; runs/sweeps/<name>_quick for --quick)")
    p.add_argument("--engine", choices=ENGINES, default=None,
                   help="run the trials on this engine instead of the spec's (default "
                        "central: one filter for the team; distributed: the robots' "
                        "protocol, bit-equal to the ROS stack, several times slower)")
    p.add_argument("--plot-only", action="store_true",
                   help="only redraw the plots and summary from the existing results")
    p.add_argument("--dry-run", action="store_true",
                   help="print how many trials would run and exit")
    p.add_argument("--recheck", type=int, default=0, metavar="N",
                   help="re-run the N cheapest finished trials (of different methods where "
                        "there are several) and compare every column but the timings with "
                        "the stored rows; exit 1 if any differs or fewer than N are "
                        "finished")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the trials on the Dask cluster of this scheduler "
                        "(tcp://HOST:PORT) instead of --workers local processes; the "
                        "workers need this checkout and environment")
    p.add_argument("--shard", metavar="K/N",
                   help="run only shard K of N (every N-th trial of the spec's full list), "
                        "into <out>/shard-K-of-N; join the shards with --merge")
    p.add_argument("--merge", nargs="+", type=Path, metavar="DIR",
                   help="append the rows of these shard folders to <out>/results.csv "
                        "(refusing overlaps and rows that disagree), then plot")
    opts = p.parse_args(argv)
    if opts.merge and (opts.shard or opts.scheduler or opts.recheck or opts.dry_run
                       or opts.plot_only):
        p.error("--merge runs alone (with --quick, --engine and --out)")
    if opts.shard:
        from phd_swarm.tools.sweep_shard import Shard
        try:
            opts.shard = Shard.parse(opts.shard)
        except ValueError as exc:
            p.error(f"--shard: {exc}")
    if opts.workers < 1:
        p.error(f"--workers must be >= 1, got {opts.workers}")
    if opts.recheck < 0:
        p.error(f"--recheck must be >= 0, got {opts.recheck}")
    return opts


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``scripts/sweep.sh``; returns the exit code."""
    opts = parse_args(sys.argv[1:] if argv is None else argv)
    wall0, cpu0 = time.monotonic(), _cpu_seconds()
    started = _dt.datetime.now().isoformat(timespec="seconds")
    try:
        spec = load_spec(find_spec(opts.spec), quick=opts.quick, engine=opts.engine)
        out = opts.out or default_out(spec)
        if opts.shard:
            out = out / opts.shard.label
        results = ResultsFile(out / "results.csv")
        if opts.merge:
            from phd_swarm.tools.sweep_shard import merge

            added = merge(spec, opts.merge, results, out)
            print(f"merged {added} new row(s) from {len(opts.merge)} folder(s) into "
                  f"{results.path}", flush=True)
        done, todo, stray = plan(spec, results, opts.shard)
    except SpecError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    total = len(done) + len(todo)
    shard = (f"shard {opts.shard.k}/{opts.shard.n} of the {len(spec.trials_list())} trials "
             f"of " if opts.shard else "")
    print(f"sweep {spec.label}: {total} trials ({shard}{len(spec.methods)} methods x "
          f"{len(spec.robots)} team sizes x {len(spec.targets)} target counts x "
          f"{len(spec.resolutions)} resolutions x {spec.trials} seeds), {len(done)} done, "
          f"{len(todo)} to run; results in {out}", flush=True)
    if stray:
        print(f"note: {stray} row(s) of {results.path} are not trials of this spec; "
              f"ignored", flush=True)
    if opts.dry_run:
        return 0
    if opts.recheck:
        if len(done) < opts.recheck:
            print(f"error: --recheck {opts.recheck}: {out} holds only {len(done)} finished "
                  f"trial(s) of this spec, fewer than {opts.recheck} (is that the folder of "
                  f"its rows? see --out and --engine)", file=sys.stderr)
            return 1
        return 0 if recheck(done, results, opts.recheck) else 1
    from phd_swarm.tools.sweep_plots import write_report

    failed: dict[str, str] = {}
    interrupted = False
    cluster_error = None
    if not opts.plot_only and not opts.merge:
        out.mkdir(parents=True, exist_ok=True)
        (out / "spec.json").write_text(json.dumps(spec.to_dict(), indent=2) + "\n")
        progress = Progress(spec.label, todo, len(done), sys.stderr)
        if opts.scheduler:
            from phd_swarm.tools.sweep_cluster import ClusterError, run_on_cluster
            try:
                failed, interrupted = run_on_cluster(opts.scheduler, spec, todo, results,
                                                     out, progress)
            except ClusterError as exc:
                cluster_error = str(exc)
        else:
            failed, interrupted = run_trials(spec, todo, results, out, opts.workers, progress)
        progress.close()
        session = {"started": started, "workers": "dask" if opts.scheduler else opts.workers,
                   "trials_run": progress.done - len(done) - len(failed),
                   "trials_failed": len(failed), "failed": failed,
                   "interrupted": interrupted, "wall_s": time.monotonic() - wall0,
                   "cpu_s": _cpu_seconds() - cpu0, "scheduler": opts.scheduler,
                   "shard": opts.shard and opts.shard.label}
        timing = _log_session(out, session)
        if cluster_error:
            print(f"error: {cluster_error}\n{len(results.rows)} rows kept in "
                  f"{results.path}", file=sys.stderr)
            return 2
        if interrupted:
            print(f"interrupted: {len(results.rows)} rows kept in {results.path}; run the "
                  f"same command again to resume", file=sys.stderr)
            return 130
    else:
        path = out / "sweep.json"
        timing = json.loads(path.read_text()) if path.exists() else {}
    keys = {t.key: t for t in done + todo}
    rows = [r for k, r in results.rows.items()
            if k in keys and r["config_hash"] == keys[k].config_hash]
    if not rows:
        print(f"error: no results of this spec in {results.path}", file=sys.stderr)
        return 2 if opts.plot_only else 1
    written = write_report(spec, rows, out, timing)
    wall = time.monotonic() - wall0
    print(f"sweep {spec.label}: {len(rows)}/{total} trials in {results.path}; this session "
          f"{_hms(wall)} wall, {_hms(_cpu_seconds() - cpu0)} CPU; plots and summary: "
          + ", ".join(str(p.name) for p in written), flush=True)
    if failed:
        print(f"error: {len(failed)} trial(s) failed (errors in {out / 'logs'}); run the "
              f"same command again to retry them", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
