"""The live view's server: Rerun's web viewer and gRPC proxy, on 127.0.0.1 only.

``python -m phd_swarm.tools.view_server`` starts one and prints its URL (open it in a
browser), then serves until Ctrl-C; ``scripts/run_swarm.sh --view`` and ``scripts/replay.sh
LOG --view`` start one for their run (docs/view.md). The viewer node
(:mod:`phd_swarm.nodes.viewer`) sends the view to the proxy; the browser loads the viewer
(WebAssembly, served from the rerun-sdk package) from the web port and the data from the
proxy, which keeps what it received for a browser opened later (up to
``memory_limit``).

Why the ``rerun`` command rather than the SDK's ``serve_grpc`` / ``serve_web_viewer``:
those listen on 0.0.0.0 and take no address, while the command takes ``--bind``. Both
ports are chosen by the system (``--port 0``) and read from the server's log lines, so two
views on one machine never collide. The server runs with a configuration directory of its
own in which Rerun's usage analytics are turned off (``rerun analytics disable``), so it
sends nothing anywhere (the project's network rule).
"""

from __future__ import annotations

import argparse
import atexit
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse
from collections.abc import Sequence

#: Where the server listens, and nowhere else.
HOST = "127.0.0.1"

#: Seconds to wait for the server's two "listening" lines.
START_TIMEOUT = 30.0

_GRPC = re.compile(r"Listening for gRPC connections on [\d.]+:(\d+)")
_WEB = re.compile(r"Hosting a web-viewer at http://[\d.]+:(\d+)")


class ViewServerError(RuntimeError):
    """The view server could not start (no rerun-sdk, or it did not come up)."""


def rerun_command() -> str:
    """The ``rerun`` binary of rerun-sdk.

    Not its Python launcher, so that the PID stopped is the server's own.
    """
    try:
        import rerun_cli
    except ImportError:
        rerun_cli = None
    path = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun") if rerun_cli else ""
    if not os.access(path, os.X_OK):
        raise ViewServerError("the live view needs rerun-sdk: scripts/setup.sh --with-view "
                              "(or pip install -r requirements-view.txt)")
    return path


def view_url(web_port: int, grpc_port: int) -> str:
    """The URL that opens the web viewer on the proxy's data."""
    proxy = f"rerun+http://{HOST}:{grpc_port}/proxy"
    return f"http://{HOST}:{web_port}/?url={urllib.parse.quote(proxy, safe='')}"


class ViewServer:
    """A running ``rerun --serve-web`` on 127.0.0.1; a context manager.

    Attributes
    ----------
    url : str
        Open this in a browser.
    grpc_url : str
        The proxy the viewer node logs to (its ``rerun_url`` parameter).
    pid : int
        The server's process id (it is stopped by this PID).
    """

    def __init__(self, memory_limit: str = "1GiB", log_path: str | None = None) -> None:
        self._home = tempfile.mkdtemp(prefix="phd_swarm_view_")
        env = dict(os.environ, XDG_CONFIG_HOME=os.path.join(self._home, "config"),
                   XDG_DATA_HOME=os.path.join(self._home, "data"))
        exe = rerun_command()
        subprocess.run([exe, "analytics", "disable"], env=env, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self._log = open(log_path or os.path.join(self._home, "server.log"), "w")
        self.proc = subprocess.Popen(
            [exe, "--serve-web", "--bind", HOST, "--port", "0", "--web-viewer-port", "0",
             "--server-memory-limit", memory_limit, "--hide-welcome-screen"],
            env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True, start_new_session=True)
        self.pid = self.proc.pid
        atexit.register(self.close)     # stopped even if its owner fails on the way
        try:
            grpc, web = self._ports()
        except BaseException:
            self.close()
            raise
        self.grpc_url = f"rerun+http://{HOST}:{grpc}/proxy"
        self.url = view_url(web, grpc)
        # Keep draining the server's output into the log file, so it never blocks.
        self._drain = threading.Thread(target=self._copy_output, daemon=True)
        self._drain.start()

    def _ports(self) -> tuple[int, int]:
        grpc = web = None
        deadline = time.monotonic() + START_TIMEOUT
        assert self.proc.stdout is not None
        while grpc is None or web is None:
            line = self.proc.stdout.readline()
            if not line:
                raise ViewServerError(f"rerun exited ({self.proc.wait()}) before listening; "
                                      f"see {self._log.name}")
            self._log.write(line)
            grpc = grpc or (int(m.group(1)) if (m := _GRPC.search(line)) else None)
            web = web or (int(m.group(1)) if (m := _WEB.search(line)) else None)
            if time.monotonic() > deadline:
                raise ViewServerError(f"rerun did not listen within {START_TIMEOUT:.0f} s")
        self._log.flush()
        return grpc, web

    def _copy_output(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self._log.write(line)
            self._log.flush()

    def __enter__(self) -> ViewServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop the server (its process group, by PID) and remove its directory."""
        atexit.unregister(self.close)
        if self.proc.poll() is None:
            try:
                os.killpg(self.pid, signal.SIGTERM)
                self.proc.wait(timeout=10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(self.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                self.proc.wait()
        self._log.close()
        shutil.rmtree(self._home, ignore_errors=True)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m phd_swarm.tools.view_server``: serve a view until Ctrl-C."""
    parser = argparse.ArgumentParser(
        prog="view_server", description="Serve the live view on 127.0.0.1 until Ctrl-C; "
        "point a viewer node at the printed proxy (docs/view.md).")
    parser.add_argument("--memory-limit", default="1GiB",
                        help="what the proxy keeps for browsers opened later")
    args = parser.parse_args(argv)
    try:
        server = ViewServer(args.memory_limit)
    except ViewServerError as exc:
        print(f"view_server: {exc}", file=sys.stderr)
        return 1
    with server:
        print(f"view: {server.url}", flush=True)
        print(f"view: viewer nodes log to {server.grpc_url} (ros2 run phd_swarm viewer "
              f"--ros-args -p rerun_url:={server.grpc_url})", flush=True)
        try:
            server.proc.wait()
        except KeyboardInterrupt:
            pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
