"""Sweeps on a Dask ``distributed`` cluster: ``scripts/sweep.sh SPEC --scheduler tcp://H:P``.

The client (the sweep's own process) submits one task per trial to the scheduler, in the
order of the plan; a worker runs the trial as a process of the local pool does
(:func:`phd_swarm.tools.sweep._work`) and returns its row, series and log lines. Only the
client writes: the series and then the row of each future as it finishes, one row per
finished future, so ``results.csv`` holds the rows of the local pool (a trial's result
depends on the trial alone) and resumes as it does. Progress and the ETA are those of the
pool (:class:`phd_swarm.tools.sweep_progress.Progress`).

A worker lost mid-trial: the scheduler runs the trials it held again on the others (up to
``distributed.scheduler.allowed-failures`` times, after which the trial fails with
``KilledWorker`` and a rerun retries it). Since no worker writes anything, a trial is
neither lost nor written twice. Ctrl-C cancels the trials not finished (a worker
finishes the one it is on, and the result is dropped); the rows written stay.

Workers need the client's checkout and environment. Before any trial, and again with
every result (so a worker that joins later is checked too), each worker reports
(:func:`worker_report`) a digest of the phd_swarm sources it runs, its Python, numpy and
scipy versions and its BLAS thread variables; one that differs from the client stops the
sweep with a :class:`ClusterError` naming it.

The client listens on nothing; it connects to the scheduler. :class:`DaskProcesses` starts
a scheduler and workers as child processes, every socket bound to a given address (the
tests, ``bench/sweep_cluster.py``, a cluster on one machine).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import platform
import signal
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import phd_swarm
from phd_swarm.config.sweep_spec import SweepSpec, Trial
from phd_swarm.tools.processes import stop_process_group
from phd_swarm.tools.sweep import _collect_logs, _raise_interrupt, _work, record_result
from phd_swarm.tools.sweep_progress import Progress
from phd_swarm.tools.sweep_results import ResultsFile

#: Variables that must be 1 on a worker, as in the local pool's processes, so that BLAS
#: sums in the same order; Dask's nanny sets them (``distributed.nanny.pre-spawn-environ``).
WORKER_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")

#: What a worker must share with the client (:func:`worker_report`).
SAME_AS_CLIENT = ("source", "python", "numpy", "scipy")

#: Seconds to wait for the scheduler to answer, and for a first worker to join it.
CONNECT_TIMEOUT = 30.0
WORKERS_TIMEOUT = 300.0


class ClusterError(RuntimeError):
    """The cluster cannot run the sweep: no scheduler, no worker, or a worker that differs."""


@functools.cache
def source_digest() -> str:
    """A digest of phd_swarm's Python sources: sha256 of each path and content, sorted."""
    root = Path(phd_swarm.__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode() + b"\0")
        h.update(hashlib.sha256(path.read_bytes()).digest())
    return h.hexdigest()[:16]


def worker_report() -> dict[str, Any]:
    """What decides a trial's result besides the trial: the code and its environment."""
    import numpy
    import scipy

    return {"source": source_digest(), "python": platform.python_version(),
            "numpy": numpy.__version__, "scipy": scipy.__version__,
            **{v: os.environ.get(v) for v in WORKER_THREAD_VARS}}


def report_problems(report: Mapping[str, Any], client: Mapping[str, Any]) -> list[str]:
    """How a worker's :func:`worker_report` differs from the client's (empty if it does not)."""
    out = [f"{k} {report.get(k)!r} (the client's: {client[k]!r})"
           for k in SAME_AS_CLIENT if report.get(k) != client[k]]
    out += [f"{v}={report.get(v)} (must be 1: start workers with Dask's nanny, the "
            f"default, or with {v}=1)" for v in WORKER_THREAD_VARS if report.get(v) != "1"]
    return out


def check_workers(reports: Mapping[str, Any], client: Mapping[str, Any]) -> None:
    """Raise :class:`ClusterError` naming each worker whose report differs or failed.

    ``reports`` maps worker address to its :func:`worker_report`, or to the exception it
    raised (e.g. it cannot import phd_swarm).
    """
    bad = []
    for address, report in sorted(reports.items()):
        if isinstance(report, BaseException):
            bad.append(f"worker {address} cannot run the sweep's code: "
                       f"{type(report).__name__}: {report}")
        elif problems := report_problems(report, client):
            bad.append(f"worker {address} differs from the client: {'; '.join(problems)}")
    if bad:
        raise ClusterError("\n  ".join(["workers need the client's checkout and "
                                        "environment (docs/sweeps.md, On a cluster):", *bad]))


def _cluster_work(trial: Trial) -> tuple[dict[str, Any], str, Any]:
    """The task of one trial on a worker: its report, its address and :func:`_work`'s result."""
    from distributed import get_worker

    _collect_logs()
    return worker_report(), get_worker().address, _work(trial)


def run_on_cluster(address: str, spec: SweepSpec, todo: Iterable[Trial],
                   results: ResultsFile, out: Path, progress: Progress
                   ) -> tuple[dict[str, str], bool]:
    """Run ``todo`` on the Dask cluster at ``address``, writing each result as it arrives.

    As :func:`phd_swarm.tools.sweep.run_trials`: returns the failed trials (key ->
    error) and whether Ctrl-C (or SIGTERM) stopped the sweep.

    Raises
    ------
    ClusterError
        The scheduler does not answer, no worker joins within :data:`WORKERS_TIMEOUT`, or
        a worker differs from the client (:func:`check_workers`); rows written so far stay.
    """
    try:
        from distributed import Client
    except ImportError as exc:
        raise ClusterError(f"--scheduler needs Dask's distributed package ({exc}); it is "
                           f"in requirements.lock (scripts/setup.sh)") from None
    todo = list(todo)
    failed: dict[str, str] = {}
    if not todo:
        return failed, False
    ours = worker_report()
    old = {sig: signal.signal(sig, _raise_interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}
    client = None
    left: dict[Any, Trial] = {}
    ran: Counter[str] = Counter()
    try:
        try:
            client = Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise ClusterError(f"no Dask scheduler answers at {address}: {exc}") from None
        workers = _wait_for_workers(client, address, progress)
        check_workers(client.run(worker_report, on_error="return"), ours)
        session = f"{os.getpid()}-{time.time_ns()}"
        left = {client.submit(_cluster_work, t, key=f"{t.key}-{session}", pure=False,
                              priority=len(todo) - i): t for i, t in enumerate(todo)}
        progress.tick()
        watched = time.monotonic()
        while left:
            if time.monotonic() - watched > 2.0:
                workers = _watch_workers(client, workers, progress)
                watched = time.monotonic()
            ready = [f for f in left if f.done()]
            if not ready:
                _wait_any(client, left)
                progress.tick()
                continue
            for fut in ready:
                trial = left.pop(fut)
                worker, row, series, error, lines = _outcome(fut, ours)
                ran[worker] += 1
                record_result(spec, results, out, trial, row, series, error, lines)
                if error is not None:
                    failed[trial.key] = error
                progress.finished(trial, row, error)
                fut.release()
        progress.message("trials per worker: " + ", ".join(
            f"{w} {n}" for w, n in sorted(ran.items())))
        return failed, False
    except KeyboardInterrupt:
        return failed, True
    finally:
        if client is not None:
            if left:
                client.cancel(list(left))
            client.close()
        for sig, handler in old.items():
            signal.signal(sig, handler)


def _wait_for_workers(client: Any, address: str, progress: Progress) -> set[str]:
    workers = set(client.nthreads())
    if not workers:
        progress.message(f"waiting for a worker to join the scheduler at {address}")
        try:
            client.wait_for_workers(1, timeout=WORKERS_TIMEOUT)
        except TimeoutError:
            raise ClusterError(f"no worker joined the scheduler at {address} within "
                               f"{WORKERS_TIMEOUT:g} s") from None
        workers = set(client.nthreads())
    nthreads = sum(client.nthreads().values())
    progress.message(f"Dask scheduler {address}: {len(workers)} worker(s), {nthreads} "
                     f"thread(s)")
    return workers


def _watch_workers(client: Any, before: set[str], progress: Progress) -> set[str]:
    """Say which workers left or joined since ``before``; the workers now."""
    now = set(client.nthreads())
    for w in sorted(before - now):
        progress.message(f"worker {w} left the cluster; the scheduler runs its trials "
                         f"again on the others ({len(now)} worker(s) left)")
    for w in sorted(now - before):
        progress.message(f"worker {w} joined the cluster ({len(now)} worker(s))")
    return now


def _wait_any(client: Any, futures: Iterable[Any], timeout: float = 1.0) -> None:
    """Block until one of ``futures`` (of ``client``) is done or ``timeout`` [s] passes."""
    from distributed import wait
    from distributed.client import FuturesCancelledError

    try:
        with client.as_current():
            wait(list(futures), timeout=timeout, return_when="FIRST_COMPLETED")
    except (TimeoutError, FuturesCancelledError):
        pass


def _outcome(fut: Any, ours: Mapping[str, Any]
             ) -> tuple[str, dict | None, dict | None, str | None, list[str]]:
    """A finished future's worker, row, series, error and log lines (as :func:`_work`'s).

    The worker is ``-`` for a task that did not finish on one (e.g. ``KilledWorker``).
    """
    if fut.status != "finished":
        exc = fut.exception() if fut.status == "error" else None
        error = (f"{type(exc).__name__}: {exc}" if exc is not None
                 else f"the task was {fut.status} by the cluster")
        return "-", None, None, error, []
    report, worker, (_, row, series, error, lines) = fut.result()
    if problems := report_problems(report, ours):
        raise ClusterError(f"worker {worker} differs from the client: {'; '.join(problems)}")
    return worker, row, series, error, lines


# ------------------------------------------------------------------- local processes
class DaskProcesses:
    """A Dask scheduler and workers as child processes, bound to given addresses.

    Each process runs in a session of its own, with its output in ``workdir/<name>.log``
    and Dask's scratch files in ``workdir`` (workers without Dask's profiler), and is
    stopped by PID (its process group) by :meth:`close`, which ``with`` calls even on
    failure. Every socket, the HTTP endpoints that Dask opens even without a dashboard
    included, is bound to the host address given; ``prefix`` runs a process inside
    another host (:meth:`phd_swarm.tools.netns.Host.prefix`).

    Parameters
    ----------
    workdir : Path
        Logs, the scheduler file and the workers' local directories.
    """

    def __init__(self, workdir: Path) -> None:
        self.workdir = Path(workdir)
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.procs: dict[str, subprocess.Popen] = {}

    def _start(self, name: str, argv: list[str]) -> subprocess.Popen:
        # Dask's scratch files (the scheduler's too) in workdir, not in the shared /tmp;
        # no statistical profiler (it samples each thread every 10 ms: ~10 % of a sweep's
        # throughput on 2 cores, docs/sweeps.md).
        env = {**os.environ, "DASK_TEMPORARY_DIRECTORY": str(self.workdir),
               "DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False"}
        with open(self.workdir / f"{name}.log", "w") as log:
            proc = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT,
                                    stdin=subprocess.DEVNULL, env=env,
                                    start_new_session=True)
        self.procs[name] = proc
        return proc

    def log(self, name: str) -> str:
        """The output of process ``name`` so far."""
        return (self.workdir / f"{name}.log").read_text()

    def _wait(self, name: str, ready: Any, timeout: float) -> Any:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if (found := ready()) is not None:
                return found
            if self.procs[name].poll() is not None:
                break
            time.sleep(0.1)
        raise RuntimeError(f"dask {name} did not start within {timeout:g} s:\n"
                           f"{self.log(name)[-3000:]}")

    def scheduler(self, host: str, port: int = 0, prefix: Sequence[str] = (),
                  timeout: float = 60.0) -> str:
        """Start the scheduler on ``host:port`` (0: a free port); returns its address."""
        file = self.workdir / "scheduler.json"
        file.unlink(missing_ok=True)
        self._start("scheduler", [*prefix, sys.executable, "-m",
                                  "distributed.cli.dask_scheduler", "--host", host,
                                  "--port", str(port), "--no-dashboard",
                                  "--dashboard-address", f"{host}:0", "--scheduler-file",
                                  str(file)])

        def ready() -> str | None:
            try:
                return json.loads(file.read_text())["address"]
            except (OSError, ValueError, KeyError):
                return None
        return self._wait("scheduler", ready, timeout)

    def worker(self, scheduler: str, host: str, name: str, nthreads: int = 1,
               prefix: Sequence[str] = (), timeout: float = 60.0) -> subprocess.Popen:
        """Start worker ``name`` (with its nanny) on ``host``; returns once it has joined."""
        self._start(name, [*prefix, sys.executable, "-m", "distributed.cli.dask_worker",
                           scheduler, "--host", host, "--nthreads", str(nthreads),
                           "--name", name, "--no-dashboard", "--dashboard-address",
                           f"{host}:0", "--local-directory", str(self.workdir / name)])
        self._wait(name, lambda: True if "Registered to:" in self.log(name) else None,
                   timeout)
        return self.procs[name]

    def close(self) -> None:
        """Stop every process by PID: SIGINT to each group, SIGKILL after 5 s."""
        procs = list(reversed(self.procs.values()))
        for proc in procs:
            # All at once: the workers close in parallel, before the scheduler goes.
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(proc.pid, signal.SIGINT)
        for proc in procs:
            stop_process_group(proc, grace=5.0)

    def __enter__(self) -> DaskProcesses:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
