"""``--view`` for a run or a replay: the view server, the viewer node, and their end.

``scripts/run_swarm.sh CONFIG --view`` (so ``scripts/demo.sh --view``) and
``scripts/replay.sh LOG --view`` start a :class:`~phd_swarm.tools.view_server.ViewServer`
on 127.0.0.1, print its URL, and start the viewer node (:mod:`phd_swarm.nodes.viewer`) as
a process of the run, with the run's ROS environment, logging to the server and saving
the view to ``view.rrd`` beside the run. When the run ends the viewer is stopped (it draws
what it still holds and closes the file) and, when the command was started from a
terminal, the server stays up until Ctrl-C, so the finished run can still be looked at
and played back with the time slider; started from a script, it stops at once.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import time
from pathlib import Path

from phd_swarm.tools.processes import stop_process_group
from phd_swarm.tools.view_server import ViewServer

#: Seconds the viewer gets to draw what it holds and close its file.
VIEWER_STOP_GRACE = 15.0


def add_options(parser: argparse.ArgumentParser, what: str, note: str = "") -> None:
    """``--view`` and ``--view-hold`` for a command that runs ``what`` (a run, a replay)."""
    parser.add_argument("--view", action="store_true", help=f"watch the {what} in a browser: "
                        f"serve the live view on 127.0.0.1 and print its URL{note} "
                        "(docs/view.md; needs scripts/setup.sh --with-view)")
    parser.add_argument("--view-hold", action="store_true", help="with --view: keep serving "
                        f"the view after the {what} until Ctrl-C or SIGTERM (the default "
                        "only when started from a terminal)")


def viewer_ros_args(grpc_url: str, save_path: Path | None, name: str = "phd_swarm",
                    observe_world: bool = False) -> list[str]:
    """The viewer node's ``--ros-args`` for a server and an optional ``.rrd``."""
    args = ["-p", f"rerun_url:={grpc_url}", "-p", f"recording_name:={name}",
            "-p", f"observe_world:={str(observe_world).lower()}"]
    if save_path is not None:
        args += ["-p", f"save_path:={save_path}"]
    return args


def start_server(log_path: Path, prog: str) -> ViewServer:
    """Start the view server and print its URL (``prog: view at URL``)."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    server = ViewServer(log_path=str(log_path))
    print(f"{prog}: live view at {server.url}", flush=True)
    return server


def start_viewer(env: dict[str, str], grpc_url: str, save_path: Path | None, log_path: Path,
                 name: str = "phd_swarm", observe_world: bool = False) -> subprocess.Popen:
    """Start the viewer node as a process of its own (its own group, stopped by PID).

    ``observe_world``: the world counts the viewer among its observers (its
    ``observers`` parameter was raised by one, :class:`~phd_swarm.tools.launch_plan.
    SwarmOptions` ``view``), so the viewer must read its truth.
    """
    log_path.parent.mkdir(parents=True, exist_ok=True)
    with open(log_path, "w") as log:
        return subprocess.Popen(
            [sys.executable, "-m", "phd_swarm.nodes.viewer", "--ros-args",
             *viewer_ros_args(grpc_url, save_path, name, observe_world)],
            env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
            start_new_session=True)


def hold(server: ViewServer, prog: str, interactive: bool | None = None) -> None:
    """Keep ``server`` up until Ctrl-C or SIGTERM, if ``interactive``.

    ``interactive`` defaults to whether stdin is a terminal.
    """
    if not (sys.stdin.isatty() if interactive is None else interactive):
        return
    print(f"{prog}: the view stays at {server.url} until Ctrl-C", flush=True)
    previous = {sig: signal.signal(sig, _interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        while server.proc.poll() is None:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def stop(viewer: subprocess.Popen | None, server: ViewServer | None) -> None:
    """Stop the viewer (SIGINT, then SIGKILL after a grace) and the server, by PID."""
    if viewer is not None:
        stop_process_group(viewer, VIEWER_STOP_GRACE)
    if server is not None:
        server.close()
