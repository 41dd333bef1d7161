"""Robot processes forked from one that has imported them: a fork server for ``run_swarm``.

A robot process spends ~1 CPU-s importing NumPy, SciPy, rclpy and phd_swarm before it builds
its node; 100 robot processes on 2 cores spent ~50 s of their start-up on it, each holding
its own copy of the same modules. ``run_swarm`` instead starts this server once: it imports
the node modules (and every built-in part), freezes what it built for the garbage collector
(:func:`gc.freeze`, so that the children's copy-on-write pages stay shared) and forks each
robot process from itself on request.

A forked child runs ``MODULE.main()`` with ``sys.argv`` set, as ``python -m MODULE ARGS``
would (the module's ``if __name__ == "__main__": sys.exit(main())``): a session (and
process group) of its own, the environment and niceness it was given, its own rclpy context
and DDS participant (none exists before the fork), its output on its own pipe, its exit
code. It differs in its command line, which is the server's; its name (``ps -o comm``,
``/proc/PID/comm``) is the child's name (``robot_7``). The server has no threads, so the fork
is safe.

Protocol (a ``SOCK_SEQPACKET`` socket pair; one JSON object per packet):

- request: ``{"name", "module", "argv", "env", "nice"}``, with the write end of the child's
  output pipe attached (``SCM_RIGHTS``);
- reply, in order: ``{"name", "pid"}`` or ``{"name", "error"}``;
- when a child exits: ``{"pid", "exit"}`` (its status as :attr:`subprocess.Popen.returncode`
  gives it: negative for a signal).

The server ignores SIGINT and SIGTERM (its children are stopped by their own PIDs) and exits
when the socket closes.
"""

from __future__ import annotations

import argparse
import atexit
import ctypes
import gc
import importlib
import json
import os
import queue
import selectors
import signal
import socket
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import IO

#: The modules run_swarm forks its robot processes from.
ROBOT_MODULES = ("phd_swarm.nodes.robot", "phd_swarm.nodes.team")

#: How long a fork request waits for the server's reply [s] (its imports come first).
REPLY_TIMEOUT = 120.0

_PR_SET_NAME = 15  # prctl(2)


def _set_name(name: str) -> None:
    """Name this process (``/proc/self/comm``, at most 15 bytes)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_NAME, name.encode()[:15], 0, 0, 0)
    except (OSError, AttributeError):
        pass


def _run_child(request: dict, out_fd: int, sock: socket.socket) -> None:
    """In the forked child: become the requested process, run its module, exit."""
    code = 1
    try:
        os.setsid()
        sock.close()
        os.dup2(out_fd, 1)
        os.dup2(out_fd, 2)
        os.close(out_fd)
        os.environ.clear()
        os.environ.update(request["env"])
        if request["nice"]:
            os.nice(int(request["nice"]))
        _set_name(request["name"])
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        module = importlib.import_module(request["module"])
        sys.argv = [module.__file__ or request["module"], *request["argv"]]
        code = module.main()
    except SystemExit as exc:
        if exc.code is None or isinstance(exc.code, int):
            code = exc.code or 0
        else:
            print(exc.code, file=sys.stderr)
    except KeyboardInterrupt:
        code = 128 + signal.SIGINT
    except BaseException:  # noqa: BLE001 - reported like an uncaught exception, exit 1
        traceback.print_exc()
    finally:
        try:
            atexit._run_exitfuncs()
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def _send(sock: socket.socket, message: dict) -> None:
    try:
        sock.send(json.dumps(message).encode())
    except OSError:
        pass  # run_swarm is gone: nobody to tell


def serve(sock: socket.socket, modules: list[str]) -> int:
    """Import ``modules``, then fork a child per request until the socket closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    for module in modules:
        importlib.import_module(module)
    from phd_swarm.core import registry

    for role in registry.ROLES:
        registry.names(role)  # imports every built-in part once, for all children
    gc.collect()
    gc.freeze()
    selector = selectors.DefaultSelector()
    selector.register(sock, selectors.EVENT_READ)
    children: set[int] = set()
    while True:
        if selector.select(timeout=0.1):
            try:
                data, fds, _, _ = socket.recv_fds(sock, 1 << 20, 1)
            except OSError:
                data, fds = b"", []
            if not data:
                break
            request = json.loads(data)
            try:
                if len(fds) != 1:
                    raise OSError(f"expected the child's output pipe, got {len(fds)} fds")
                sys.stdout.flush()
                sys.stderr.flush()
                pid = os.fork()
                if pid == 0:
                    _run_child(request, fds[0], sock)
                children.add(pid)
                _send(sock, {"name": request["name"], "pid": pid})
            except OSError as exc:
                _send(sock, {"name": request["name"], "error": str(exc)})
            finally:
                for fd in fds:
                    os.close(fd)
        while children:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                break
            if pid == 0:
                break
            children.discard(pid)
            _send(sock, {"pid": pid, "exit": os.waitstatus_to_exitcode(status)})
    return 0


class ForkedProcess:
    """A child of the fork server, with the part of :class:`subprocess.Popen` run_swarm uses.

    ``stdout`` is the read end of its output pipe (text); :meth:`poll` and :meth:`wait` give
    its exit code once the server reported it.
    """

    def __init__(self, name: str, pid: int, stdout: IO[str], server: ForkServer) -> None:
        self.args = name
        self.pid = pid
        self.stdout = stdout
        self.returncode: int | None = None
        self._server = server
        self._exited = threading.Event()

    def _set_exit(self, code: int) -> None:
        self.returncode = code
        self._exited.set()

    def _gone_without_report(self) -> bool:
        """Whether the server died and this child has exited too (its code is lost: -1)."""
        if self._server.alive():
            return False
        try:
            state = Path(f"/proc/{self.pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            state = "X"
        if state in ("Z", "X"):
            self._set_exit(-1)
            return True
        return False

    def poll(self) -> int | None:
        """The exit code, or None while it runs."""
        if not self._exited.is_set():
            self._gone_without_report()
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        """Wait for the exit; raises :class:`subprocess.TimeoutExpired` after ``timeout``."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self._exited.wait(0.1):
            if self._gone_without_report():
                break
            if deadline is not None and time.monotonic() >= deadline:
                raise subprocess.TimeoutExpired(self.args, timeout)
        return self.returncode  # type: ignore[return-value]

    def send_signal(self, sig: int) -> None:
        """Signal the child (not its group) if it has not exited."""
        if self.returncode is None:
            try:
                os.kill(self.pid, sig)
            except ProcessLookupError:
                pass

    def kill(self) -> None:
        """SIGKILL the child."""
        self.send_signal(signal.SIGKILL)


class ForkServer:
    """Client of a fork server process started by :meth:`start` (run_swarm's side)."""

    def __init__(self, proc: subprocess.Popen, sock: socket.socket) -> None:
        self.proc = proc
        self._sock = sock
        self._lock = threading.Lock()
        self._fork_lock = threading.Lock()  # one request at a time: replies come in order
        self._replies: queue.Queue[dict] = queue.Queue()
        self._children: dict[int, ForkedProcess] = {}
        self._early: dict[int, int] = {}
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    @classmethod
    def start(cls, env: dict[str, str], log: IO[str],
              modules: tuple[str, ...] = ROBOT_MODULES, run: str = "") -> ForkServer:
        """Start the server process (its own session; output to ``log``).

        ``run``: the run it serves, shown on its command line (and its children's) only.
        """
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            proc = subprocess.Popen(
                [sys.executable, "-m", "phd_swarm.tools.fork_server", "--fd",
                 str(theirs.fileno()), "--preload", ",".join(modules),
                 *(["--run", run] if run else [])],
                env=env, pass_fds=[theirs.fileno()], start_new_session=True,
                stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT)
        finally:
            theirs.close()
        return cls(proc, ours)

    def alive(self) -> bool:
        """Whether the server process still runs."""
        return self.proc.poll() is None

    def _read(self) -> None:
        while True:
            try:
                data = self._sock.recv(1 << 16)
            except OSError:
                data = b""
            if not data:
                self._replies.put({"error": "the fork server exited"})
                return
            message = json.loads(data)
            if "exit" in message:
                with self._lock:
                    child = self._children.get(message["pid"])
                    if child is None:
                        self._early[message["pid"]] = message["exit"]
                if child is not None:
                    child._set_exit(message["exit"])
            else:
                self._replies.put(message)

    def fork(self, name: str, module: str, argv: list[str], env: dict[str, str],
             nice: int = 0) -> ForkedProcess:
        """Fork child ``name`` running ``python -m module argv`` with ``env`` and ``nice``.

        Raises
        ------
        OSError
            If the server is gone, does not answer within :data:`REPLY_TIMEOUT` s, or could
            not fork.
        """
        read_fd, write_fd = os.pipe()
        request = {"name": name, "module": module, "argv": list(argv), "env": dict(env),
                   "nice": int(nice)}
        try:
            with self._fork_lock:
                socket.send_fds(self._sock, [json.dumps(request).encode()], [write_fd])
                reply = self._replies.get(timeout=REPLY_TIMEOUT)
        except (OSError, queue.Empty) as exc:
            os.close(read_fd)
            why = str(exc) or f"no answer in {REPLY_TIMEOUT:g} s"
            raise OSError(f"the fork server did not start {name}: {why}") from None
        finally:
            os.close(write_fd)
        if "pid" not in reply:
            os.close(read_fd)
            raise OSError(f"the fork server did not start {name}: {reply.get('error')}")
        child = ForkedProcess(name, reply["pid"], os.fdopen(read_fd, "r"), self)
        with self._lock:
            self._children[child.pid] = child
            early = self._early.pop(child.pid, None)
        if early is not None:
            child._set_exit(early)
        return child

    def close(self, grace: float = 5.0) -> None:
        """Close the socket (the server exits) and wait for the server; SIGKILL it late."""
        try:
            self._sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._sock.close()
        try:
            self.proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def main(argv: list[str] | None = None) -> int:
    """``python -m phd_swarm.tools.fork_server --fd N --preload MODULES`` (run_swarm's)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fd", type=int, required=True, help="the socket's descriptor")
    parser.add_argument("--preload", default=",".join(ROBOT_MODULES),
                        help="modules to import before forking, comma separated")
    parser.add_argument("--run", default="", help="the run served (for ps only)")
    opts = parser.parse_args(argv)
    sock = socket.socket(fileno=opts.fd)
    return serve(sock, [m for m in opts.preload.split(",") if m])


if __name__ == "__main__":
    sys.exit(main())
