"""``sweep.sh --scheduler``: a sweep on a Dask cluster writes the local pool's rows.

The cluster tests (marked ``full``) start a Dask scheduler and two workers as processes,
on 127.0.0.1 or in network-namespace hosts (:mod:`phd_swarm.tools.netns`), and stop them
by PID whatever happens (:class:`phd_swarm.tools.sweep_cluster.DaskProcesses`).
"""

from __future__ import annotations

import ipaddress
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.tools import sweep, sweep_cluster, sweep_results
from phd_swarm.tools.netns import HostNetwork
from phd_swarm.tools.sweep_cluster import (
    WORKER_THREAD_VARS,
    ClusterError,
    DaskProcesses,
    check_workers,
    worker_report,
)

from .test_sweep_shard import _rows, _without_timing

#: On the distributed engine: 12 trials of about a second in the quick form, so that a
#: sweep can be interrupted, or lose a worker, half-way.
SPEC = """\
preset: dames_static
figure: cluster test sweep
methods: {PHD: phd, uniform: uniform}
robots: [4, 6]
targets: [6]
trials: 4
base_seed: 5
duration: 100.0
metric: mean
window: [50.0, 100.0]
engine: distributed
scenario:
  env: {xmin: 0, ymin: 0, xmax: 30, ymax: 30}
  robot_start_box: [10, 0, 20, 5]
  targets: {draw_box: [-3, -3, 33, 33]}
quick:
  trials: 3
"""
TRIALS = 12


# --------------------------------------------------------------------------- helpers


def _assert_same_sweep(out: Path, reference: Path) -> None:
    """Rows (but for the timings) and series of ``out`` are those of ``reference``."""
    rows = _rows(out / "results.csv")
    assert len(rows) == TRIALS
    assert _without_timing(rows) == _without_timing(_rows(reference / "results.csv"))
    for r in rows:
        a = sweep_results.load_series(reference / "series" / f"{r['trial']}.npz")
        b = sweep_results.load_series(out / "series" / f"{r['trial']}.npz")
        assert a.keys() == b.keys()
        for name in a:
            np.testing.assert_array_equal(a[name], b[name])


def _sweep_argv(spec: Path, address: str, out: Path) -> list[str]:
    return [sys.executable, "-m", "phd_swarm.tools.sweep", str(spec), "--quick",
            "--scheduler", address, "--out", str(out)]


def _wait_rows(path: Path, proc: subprocess.Popen, n: int, timeout: float = 120.0) -> int:
    """Wait until ``path`` holds ``n`` rows while ``proc`` runs; the rows then."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        if path.exists() and (rows := len(path.read_text().splitlines()) - 1) >= n:
            return rows
        time.sleep(0.05)
    ended = proc.poll() is not None and proc.stderr is not None
    raise AssertionError(f"the sweep did not write {n} rows while running (exit code "
                         f"{proc.poll()}){': ' + proc.stderr.read() if ended else ''}")


def _group_pids(groups: set[int]) -> list[int]:
    """The processes of the given process groups (each leader's children included)."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) in groups:
                out.append(int(d.name))
    return out


def _address(hex_address: str) -> tuple[str, int]:
    host, port = hex_address.split(":")
    raw = bytes.fromhex(host)
    # /proc/net/tcp{,6} print each 32-bit word of the address in host (little-endian) order.
    words = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
    ip = ipaddress.ip_address(words)
    return str(getattr(ip, "ipv4_mapped", None) or ip), int(port, 16)


def _listening(pids: list[int]) -> set[tuple[str, int]]:
    """(address, port) of every TCP socket that ``pids`` listen on, in their namespaces."""
    found = set()
    for pid in pids:
        inodes = set()
        try:
            fds = list(Path(f"/proc/{pid}/fd").iterdir())
        except OSError:
            continue
        for fd in fds:
            try:
                link = os.readlink(fd)
            except OSError:        # closed since the listing
                continue
            if link.startswith("socket:["):
                inodes.add(link[8:-1])
        for table in ("tcp", "tcp6"):
            try:
                lines = Path(f"/proc/{pid}/net/{table}").read_text().splitlines()[1:]
            except OSError:
                continue
            for line in lines:
                f = line.split()
                if f[3] == "0A" and f[9] in inodes:          # 0A: LISTEN
                    found.add(_address(f[1]))
    return found


def _cluster_sockets(dask: DaskProcesses, address: str, hosts: set[str]) -> None:
    """Every socket the cluster listens on is on ``hosts``; the check sees the scheduler's."""
    found = _listening(_group_pids({p.pid for p in dask.procs.values()}))
    host, port = address.removeprefix("tcp://").rsplit(":", 1)
    assert (host, int(port)) in found, found
    # The scheduler's and each worker's HTTP endpoint, each worker's and nanny's port.
    assert len(found) >= 2 + 3 * (len(dask.procs) - 1), found
    assert {h for h, _ in found} <= hosts, found


@pytest.fixture(scope="module")
def local(tmp_path_factory) -> tuple[Path, Path]:
    """The spec and its quick form's results on the local pool of 2 workers."""
    d = tmp_path_factory.mktemp("cluster")
    spec = d / "cluster.yaml"
    spec.write_text(SPEC)
    out = d / "local"
    assert sweep.main([str(spec), "--quick", "--workers", "2", "--out", str(out)]) == 0
    return spec, out


# --------------------------------------------------------------------- without a cluster
def _good(report: dict) -> dict:
    return {**report, **{v: "1" for v in WORKER_THREAD_VARS}}


def test_workers_that_differ_from_the_client_are_named():
    ours = worker_report()
    check_workers({"tcp://10.0.0.1:4000": _good(ours)}, ours)
    reports = {
        "tcp://10.0.0.1:4000": _good(ours),
        "tcp://10.0.0.2:4000": {**_good(ours), "source": "0" * 16},
        "tcp://10.0.0.3:4000": ModuleNotFoundError("No module named 'phd_swarm'"),
        "tcp://10.0.0.4:4000": {**_good(ours), "OPENBLAS_NUM_THREADS": None},
        "tcp://10.0.0.5:4000": {**_good(ours), "numpy": "1.0.0"}}
    with pytest.raises(ClusterError) as exc:
        check_workers(reports, ours)
    text = str(exc.value)
    assert "10.0.0.1" not in text
    assert (f"worker tcp://10.0.0.2:4000 differs from the client: source '{'0' * 16}' "
            f"(the client's: '{ours['source']}')") in text
    assert ("worker tcp://10.0.0.3:4000 cannot run the sweep's code: ModuleNotFoundError: "
            "No module named 'phd_swarm'") in text
    assert "tcp://10.0.0.4:4000 differs from the client: OPENBLAS_NUM_THREADS=None" in text
    assert "tcp://10.0.0.5:4000 differs from the client: numpy '1.0.0'" in text


def test_the_source_digest_is_the_same_in_another_process():
    other = subprocess.run([sys.executable, "-c", "from phd_swarm.tools.sweep_cluster import "
                            "source_digest; print(source_digest())"],
                           capture_output=True, text=True, timeout=60, check=True)
    assert other.stdout.strip() == sweep_cluster.source_digest()
    assert len(sweep_cluster.source_digest()) == 16


def test_no_scheduler_is_a_clear_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sweep_cluster, "CONNECT_TIMEOUT", 2.0)
    spec = tmp_path / "cluster.yaml"
    spec.write_text(SPEC)
    with socket.socket() as closed:       # a port of ours that nothing listens on
        closed.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{closed.getsockname()[1]}"
        assert sweep.main([str(spec), "--quick", "--scheduler", address, "--out",
                           str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"error: no Dask scheduler answers at {address}" in err and "Traceback" not in err


# ------------------------------------------------------------------------ on a cluster
@pytest.mark.full
def test_a_sweep_on_dask_has_the_pools_rows_and_resumes_after_ctrl_c(local, tmp_path,
                                                                       children):
    spec, reference = local
    out = tmp_path / "dask"
    with DaskProcesses(tmp_path / "cluster") as dask:
        address = dask.scheduler("127.0.0.1")
        for name in ("w1", "w2"):
            dask.worker(address, "127.0.0.1", name)
        _cluster_sockets(dask, address, {"127.0.0.1"})

        proc = children.start(_sweep_argv(spec, address, out))
        _wait_rows(out / "results.csv", proc, 2)
        assert _listening(_group_pids({proc.pid})) == set(), "the client listens"
        children.stop(proc, grace=20.0)
        _, err = proc.communicate()
        assert proc.returncode == 130, err
        assert "interrupted" in err and "Traceback" not in err
        kept = len(_rows(out / "results.csv"))
        assert 2 <= kept < TRIALS

        proc = children.start(_sweep_argv(spec, address, out))
        stdout, err = proc.communicate(timeout=240)
        assert proc.returncode == 0, err
        assert f"{kept} done, {TRIALS - kept} to run" in stdout
        assert "Dask scheduler tcp://127.0.0.1:" in err and "2 worker(s)" in err
    _assert_same_sweep(out, reference)


@pytest.mark.full
def test_a_worker_killed_mid_sweep_loses_no_trial_and_writes_none_twice(local, tmp_path,
                                                                          children):
    spec, reference = local
    out = tmp_path / "dask"
    with DaskProcesses(tmp_path / "cluster") as dask:
        address = dask.scheduler("127.0.0.1")
        dask.worker(address, "127.0.0.1", "w1")
        doomed = dask.worker(address, "127.0.0.1", "w2")
        proc = children.start(_sweep_argv(spec, address, out))
        done = _wait_rows(out / "results.csv", proc, 1)
        # Trials are left for both workers: the one killed is running one.
        assert done <= TRIALS - 4, "the sweep was too far on to lose a busy worker"
        os.killpg(doomed.pid, signal.SIGKILL)             # the worker and its nanny
        stdout, err = proc.communicate(timeout=240)
        assert proc.returncode == 0, err
    assert "left the cluster; the scheduler runs its trials again" in err
    assert f"{TRIALS} to run" in stdout and "failed" not in err
    _assert_same_sweep(out, reference)


@pytest.mark.full
def test_a_worker_on_another_host_runs_trials_of_the_sweep(local, tmp_path, children):
    # Network namespaces need root: without it HostNetwork raises, and the test fails.
    spec, reference = local
    out = tmp_path / "dask"
    with HostNetwork(["head", "node1"]) as net, DaskProcesses(tmp_path / "cluster") as dask:
        head, node = net["head"], net["node1"]
        address = dask.scheduler(head.address, port=8786, prefix=head.prefix)
        dask.worker(address, head.address, "head", prefix=head.prefix)
        dask.worker(address, node.address, "node1", prefix=node.prefix)
        _cluster_sockets(dask, address, {head.address, node.address})
        proc = children.start(head.command(_sweep_argv(spec, address, out)))
        stdout, err = proc.communicate(timeout=240)
        assert proc.returncode == 0, err
    per_worker = next(ln for ln in err.splitlines() if ln.startswith("trials per worker: "))
    ran = dict(w.rsplit(" ", 1) for w in per_worker.split(": ", 1)[1].split(", "))
    assert {w.removeprefix("tcp://").rsplit(":", 1)[0] for w in ran} == \
        {head.address, node.address}, per_worker
    assert sum(map(int, ran.values())) == TRIALS
    _assert_same_sweep(out, reference)
