"""The processes of a run: started, watched and stopped as whole process groups.

:class:`Swarm` holds the child processes of one ``run_swarm`` run (each in a session of its
own, its output pumped into ``logs/<name>.log``, its CPU time and peak memory read from
/proc, stopped by PID whatever happens); :func:`stop_process_group` and
:func:`clean_fastdds_shm` stop a group and clear what Fast DDS leaves behind, for
``run_swarm`` (Ctrl-C stops every process of a run) and the test helpers of
:mod:`phd_swarm.testing`.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import IO

from phd_swarm.tools.fork_server import ROBOT_MODULES, ForkedProcess, ForkServer


def stop_process_group(proc: subprocess.Popen, grace: float = 5.0) -> int | None:
    """SIGINT ``proc``'s process group, SIGKILL it after ``grace`` s; returns the exit code.

    The group is killed in the end even if its leader already exited, so no child of it
    (e.g. the Python under a shell script) survives.
    """
    if proc.poll() is None:
        for sig, wait in ((signal.SIGINT, grace), (signal.SIGKILL, 5.0)):
            try:
                os.killpg(proc.pid, sig)
            except ProcessLookupError:
                break
            try:
                proc.wait(timeout=wait)
                break
            except subprocess.TimeoutExpired:
                continue
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    return proc.poll()


def clean_fastdds_shm() -> None:
    """Remove Fast DDS shared-memory files of dead processes (``fastdds shm clean``)."""
    tool = shutil.which("fastdds")
    if tool is None:
        return
    subprocess.run([tool, "shm", "clean"], stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, timeout=30, check=False)


def _pump(stream: IO[str], log: IO[str], echo: bool, marks: list[tuple[str, threading.Event]]
          ) -> None:
    """Copy a child's output to its log; echo progress lines and errors to the terminal.

    ``marks``: (marker, event) pairs: an event is set at the first line holding its marker.
    """
    writing = True
    for line in stream:
        if writing:
            try:
                log.write(line)
                log.flush()
            except OSError as exc:  # a full disk: keep reading, or the child would block
                writing = False
                print(f"run_swarm: cannot write {getattr(log, 'name', 'a log')}: "
                      f"{exc.strerror or exc}; its lines are dropped", file=sys.stderr)
        for marker, event in marks:
            if not event.is_set() and marker in line:
                event.set()
        if echo and ("steps/s" in line or line.startswith(("[ERROR]", "error:"))
                     or "world: done" in line or "waiting for the team" in line):
            print(line.rstrip().split("]: ", 1)[-1], flush=True)


class Swarm:
    """The child processes of one run; always stopped by PID (process group)."""

    def __init__(self, run_dir: Path, env: dict[str, str], quiet: bool,
                 fork: bool = False) -> None:
        self.run_dir = run_dir
        self.env = env
        self.quiet = quiet
        #: Whether the robot processes are forked from a fork server (started on first use).
        self.fork = fork
        self.fork_server: ForkServer | None = None
        self.procs: dict[str, subprocess.Popen | ForkedProcess] = {}
        self.cpu: dict[str, float] = {}
        #: Peak resident memory of each child [MB] (VmHWM), as last read.
        self.memory: dict[str, float] = {}
        self._threads: list[threading.Thread] = []
        self._up: dict[str, threading.Event] = {}
        (run_dir / "logs").mkdir(exist_ok=True)

    def start(self, name: str, module: str, ros_args: list[str], extra: list[str] = (),
              echo: bool = False, up_marker: str | None = None, nice: int = 0,
              env: dict[str, str] | None = None, prefix: tuple[str, ...] = (),
              marks: Mapping[str, threading.Event] | None = None
              ) -> subprocess.Popen | ForkedProcess:
        """Start ``python -m module extra --ros-args ros_args`` as child ``name``.

        A robot module (:data:`~phd_swarm.tools.fork_server.ROBOT_MODULES`) is forked from
        the fork server when :attr:`fork` is set and it runs on this machine (no
        ``prefix``).

        ``up_marker``: text of the log line that says the child is up (:meth:`wait_up`).
        ``marks``: more such texts, each with the event set at the first line holding it.
        ``nice``: the child's niceness (:func:`lower_priority`). ``env``: variables added to
        the run's environment for this child. ``prefix``: words put before the command to
        run it on another host (``ip netns exec NS``, ``--hosts``).
        """
        args = [*extra, "--ros-args", *ros_args]
        proc: subprocess.Popen | ForkedProcess
        if self.fork and module in ROBOT_MODULES and not prefix:
            if self.fork_server is None:
                log = open(self.run_dir / "logs" / "fork_server.log", "w")  # noqa: SIM115
                self.fork_server = ForkServer.start(self.env, log, run=str(self.run_dir))
                log.close()  # the server has its own descriptor
            proc = self.fork_server.fork(name, module, args, {**self.env, **(env or {})},
                                         nice)
        else:
            argv = [sys.executable, "-m", module, *args]
            if nice:
                argv = ["nice", "-n", str(nice), *argv]
            proc = subprocess.Popen([*prefix, *argv], env={**self.env, **(env or {})},
                                    start_new_session=True, stdout=subprocess.PIPE,
                                    stderr=subprocess.STDOUT, text=True)
        if nice:
            lower_priority(proc.pid, nice)
        log = open(self.run_dir / "logs" / f"{name}.log", "w")  # noqa: SIM115 (closed by EOF)
        found = list((marks or {}).items())
        if up_marker is not None:
            found.append((up_marker, self._up.setdefault(name, threading.Event())))
        t = threading.Thread(target=_pump,
                             args=(proc.stdout, log, echo and not self.quiet, found),
                             daemon=True)
        t.start()
        self._threads.append(t)
        self.procs[name] = proc
        return proc

    def wait_up(self, names: list[str], timeout: float) -> list[str]:
        """Wait until children ``names`` logged their up marker, one exited, or ``timeout``.

        Returns the names that are not up.
        """
        deadline = time.monotonic() + timeout
        waiting = [n for n in names if n in self._up]
        while waiting and time.monotonic() < deadline:
            if any(self.procs[n].poll() is not None for n in waiting):
                break
            self._up[waiting[0]].wait(timeout=0.1)
            waiting = [n for n in waiting if not self._up[n].is_set()]
        return waiting

    def is_up(self, name: str) -> bool:
        """Whether child ``name`` logged its up marker."""
        return name in self._up and self._up[name].is_set()

    def cpu_seconds(self, name: str) -> float:
        """User + system CPU time child ``name`` has used so far [s] (0 once it is gone)."""
        return process_cpu_seconds(self.procs[name].pid)

    def sample_fork_server(self) -> None:
        """Note the fork server's CPU time (its imports: the robots' start-up, shared)."""
        if self.fork_server is not None:
            cpu = process_cpu_seconds(self.fork_server.proc.pid)
            self.cpu["fork_server"] = max(self.cpu.get("fork_server", 0.0), cpu)

    def sample(self, name: str) -> None:
        """Note child ``name``'s CPU time and peak memory so far (kept once it is gone)."""
        self.cpu[name] = max(self.cpu.get(name, 0.0), self.cpu_seconds(name))
        try:
            status = Path(f"/proc/{self.procs[name].pid}/status").read_text()
        except OSError:
            return
        for line in status.splitlines():
            if line.startswith("VmHWM:"):
                kb = float(line.split()[1])
                self.memory[name] = max(self.memory.get(name, 0.0), kb / 1024.0)
                return

    def stop(self, name: str, grace: float = 10.0) -> int | None:
        """SIGINT child ``name``'s group, SIGKILL after ``grace`` s; returns its exit code."""
        proc = self.procs[name]
        self.sample(name)
        return stop_process_group(proc, grace)

    def stop_many(self, names: list[str], grace: float) -> None:
        """SIGINT the groups of ``names`` at once; SIGKILL what still runs after ``grace`` s."""
        running = [n for n in names if n in self.procs and self.procs[n].poll() is None]
        for n in running:
            self.sample(n)
            _signal_group(self.procs[n], signal.SIGINT)
        deadline = time.monotonic() + grace
        for n in running:
            try:
                self.procs[n].wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
        for n in running:
            # The whole group, even if its leader exited: no grandchild survives.
            _signal_group(self.procs[n], signal.SIGKILL)
        for n in running:
            try:
                self.procs[n].wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                pass

    def stop_all(self, grace: float = 5.0) -> None:
        """Stop every child still running, all at once, then clean Fast DDS shm."""
        self.stop_many(list(self.procs), grace)
        if self.fork_server is not None:
            self.sample_fork_server()
            self.fork_server.close()
        for t in self._threads:
            t.join(timeout=1.0)
        clean_fastdds_shm()

    def exited(self, prefix: str) -> dict[str, int]:
        """Children named ``prefix...`` that have exited, with their exit codes."""
        return {n: p.returncode for n, p in self.procs.items()
                if n.startswith(prefix) and p.poll() is not None}


def process_cpu_seconds(pid: int) -> float:
    """User + system CPU time process ``pid`` has used so far [s] (0 once it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1]
    except OSError:
        return 0.0
    utime, stime = fields.split()[11:13]
    return (int(utime) + int(stime)) / os.sysconf("SC_CLK_TCK")


def lower_priority(pid: int, nice: int) -> None:
    """Give process ``pid`` (started by ``nice -n nice``) the same niceness against others.

    Each child runs in a session of its own, and with autogroup scheduling (Linux's default
    on desktops and on this machine: /proc/sys/kernel/sched_autogroup_enabled) a session's
    processes share one scheduling group: the CPU is split between sessions first, and a
    process's own niceness only counts inside its session. The session's group has a
    niceness of its own, /proc/PID/autogroup, which an unprivileged user may raise. Without
    autogroup the file is missing and ``nice -n`` alone does it.
    """
    try:
        Path(f"/proc/{pid}/autogroup").write_text(f"{nice}\n")
    except OSError:
        pass


def _signal_group(proc: subprocess.Popen, sig: int) -> None:
    try:
        os.killpg(proc.pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


class Stepping:
    """When the world was stepping, and what each child's CPU was then.

    The world logs a line when its team is ready (step 0 begins) and one when it is done;
    :meth:`marks` gives the events :meth:`Swarm.start` sets at those lines, and :meth:`note`,
    called at every sample of the children's CPU (``Swarm.cpu``), takes the CPU at each.

    Parameters
    ----------
    started : float
        ``time.monotonic()`` when the run started (before its first child).
    ready_line, done_line : str
        Texts of the world's two lines.
    """

    def __init__(self, started: float, ready_line: str, done_line: str) -> None:
        self.started = started
        self._lines = {ready_line: threading.Event(), done_line: threading.Event()}
        self._ready, self._done = self._lines.values()
        #: ``time.monotonic()`` at which the team was seen ready, or None.
        self.ready_at: float | None = None
        self._at_ready: dict[str, float] = {}
        self._at_done: dict[str, float] | None = None

    def marks(self) -> dict[str, threading.Event]:
        """The world's lines to watch for (:meth:`Swarm.start`'s ``marks``)."""
        return dict(self._lines)

    def note(self, cpu: Mapping[str, float]) -> None:
        """Take the children's CPU ``cpu`` [s] if the world just became ready or done."""
        if self.ready_at is None and self._ready.is_set():
            self.ready_at = time.monotonic()
            self._at_ready = dict(cpu)
        if self.ready_at is not None and self._at_done is None and self._done.is_set():
            self._at_done = dict(cpu)

    def figures(self, cpu: Mapping[str, float]) -> dict[str, object]:
        """``startup_s`` (run start to the team ready) and ``cpu_s_stepping`` per child.

        The CPU each child used from the ready line to the done line (to ``cpu``, the last
        sample, if the world never said it was done). Empty if the team was never ready.
        """
        if self.ready_at is None:
            return {}
        end = self._at_done if self._at_done is not None else cpu
        return {"startup_s": round(self.ready_at - self.started, 2),
                "cpu_s_stepping": {k: round(v - self._at_ready.get(k, 0.0), 2)
                                   for k, v in sorted(end.items())}}
