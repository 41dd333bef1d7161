"""Run nodes in a process: Jazzy's init / spin / shutdown pattern, with our executor choice.

:func:`spin_nodes` is every node module's ``main``: it starts rclpy with the command-line
arguments, builds the nodes, spins them until Ctrl-C / SIGTERM or until every node that has a
``finished`` attribute says it is finished, and always destroys the nodes and shuts rclpy
down. A bad parameter ends the process with exit code 2 and one clear line on stderr; a node
with an ``exit_code`` attribute sets the exit code of any other end (the largest wins).

The executor is rclpy's ``EventsExecutor`` (several times faster per callback than the
``SingleThreadedExecutor``, DESIGN.md) unless ``PHD_SWARM_EXECUTOR=single``.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future

from phd_swarm.nodes.ros_params import ParameterError

#: Seconds the executor spins between two checks for a stop signal or finished nodes.
SPIN_PERIOD = 0.1

#: Seconds a process waits at exit, in all, for its last messages to be acknowledged.
FLUSH_TIMEOUT = 2.0


def make_executor(context: Any = None, kind: str | None = None) -> Any:
    """An executor of ``kind`` (``events`` or ``single``; default from PHD_SWARM_EXECUTOR)."""
    kind = kind or os.environ.get("PHD_SWARM_EXECUTOR", "events")
    if kind == "events":
        from rclpy.experimental import EventsExecutor

        return EventsExecutor(context=context)
    if kind == "single":
        return SingleThreadedExecutor(context=context)
    raise ValueError(f"PHD_SWARM_EXECUTOR must be 'events' or 'single', got {kind!r}")


def spin_nodes(factory: Callable[[], Sequence[Any]], args: list[str] | None = None) -> int:
    """Init rclpy with ``args``, spin ``factory()``'s nodes, clean up; returns the exit code.

    SIGINT and SIGTERM set a flag that the spin loop checks every 0.1 s, instead of rclpy's
    handlers raising KeyboardInterrupt inside an executor callback (which aborts the
    process with the EventsExecutor); nodes then get ``close()``d, their publishers flushed
    (:func:`flush_publishers`) and destroyed normally.
    """
    stop = []
    rclpy.init(args=sys.argv if args is None else args,
               signal_handler_options=SignalHandlerOptions.NO)
    previous = {sig: signal.signal(sig, lambda *_: stop.append(True))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    nodes: Sequence[Any] = ()
    code = 0
    try:
        nodes = factory()
        executor = make_executor()
        for node in nodes:
            executor.add_node(node)
        watched = [n for n in nodes if hasattr(n, "finished")]
        # Spin 0.1 s at a time (a future that never completes), not one callback at a time:
        # the checks below then cost once per 0.1 s rather than once per message (a robot
        # takes ~50 envelopes a step).
        never = Future()
        while (not stop and rclpy.ok()
               and not (watched and all(n.finished for n in watched))):
            executor.spin_until_future_complete(never, timeout_sec=SPIN_PERIOD)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ParameterError as exc:
        print(f"error: {exc}", file=sys.stderr)
        code = 2
    finally:
        code = max([code, *(int(getattr(n, "exit_code", 0)) for n in nodes)])
        for node in nodes:
            close = getattr(node, "close", None)
            if close is not None:
                close()
        flush_publishers(nodes, FLUSH_TIMEOUT)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return code


def flush_publishers(nodes: Sequence[Any], timeout: float) -> bool:
    """Wait until matched readers acknowledged what ``nodes`` published; True if they all did.

    ``timeout`` [s] bounds the wait for all publishers together.

    A reliable writer that is destroyed forgets what its readers have not acknowledged yet:
    without this, the messages of a node's last step (sent just before Ctrl-C) could miss
    the recorder, which run_swarm stops after the other nodes for that reason.
    """
    deadline = time.monotonic() + timeout
    for node in nodes:
        for pub in list(node.publishers):
            left = deadline - time.monotonic()
            if left <= 0.0 or not pub.wait_for_all_acked(Duration(nanoseconds=int(left * 1e9))):
                return False
    return True
