"""Replay a recorded run: republish the messages of an MCAP log as if live (node ``replay``).

``scripts/replay.sh LOG [--rate R | --fast] [--topics T [T ...]] [--start S] [--end E]
[--wait-subscribers N] [--wait-timeout W] [--dry-run] [--quiet] [--ros-args ...]``

1. opens LOG with :mod:`phd_swarm.logs.mcap_log` (a log cut short by a crash replays its
   complete records, with a warning) and selects the messages of ``--topics`` whose log
   time lies in ``[first + S, first + E)``, ``first`` being the log time of the log's first
   message, whatever the selection;
2. creates node ``replay`` with one publisher per selected topic: the recorded type
   (``pkg/msg/Type``) and the QoS the recorder stored as the channel's
   ``offered_qos_profiles`` (:func:`offered_qos`), so latched (transient-local) topics stay
   latched;
3. waits, if asked, until every publisher has matched ``N`` subscriptions (bounded by
   ``W`` seconds);
4. publishes the recorded CDR bytes unchanged (``Publisher.publish(bytes)``), in log order,
   message i at wall time ``t0 + (log_time_i - log_time_0) / R``, where ``log_time_0`` is the
   log time of the first selected message; ``--fast`` sends them back to back. ``/clock`` is
   republished like any topic, so nodes with ``use_sim_time`` follow the replay.

Before anything is sent, the log's completeness is checked (the recorder's report stored in
the log, or :func:`phd_swarm.tools.log_check.check_log` for a log cut short): a log with
gaps is replayed, but with a warning on stderr that names the topics and steps missing.

Log time is the recorder's receive time (wall clock), so the replay reproduces the run's
wall-clock pacing, including its start-up. Progress lines go to stderr every
:data:`PROGRESS_PERIOD` seconds, then one final line. SIGINT / SIGTERM stop the replay
between two messages. Exit codes: 0 done (also when stopped by a signal), 1 the log cannot
be read, 2 bad usage. See ``docs/replay.md``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import os
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from phd_swarm.logs.mcap_log import LogError, LogReader, LogRecord, open_log
from phd_swarm.tools import view_run
from phd_swarm.tools.replay_log import (
    NS,
    LogIndex,
    Selection,
    UsageError,
    clock_ns,
    describe_qos,
    index_log,
    offered_qos,
    select,
    selected_messages,
)

PROG = "replay.sh"

#: Wall seconds between two progress lines.
PROGRESS_PERIOD = 5.0

#: Default bound on the wait for subscribers [s].
WAIT_TIMEOUT = 30.0

#: Bound on one wait for a reliable publisher's acknowledgements [s] (see :class:`Replayer`);
#: longer than Fast DDS's heartbeat period (3 s), after which a reader acknowledges at latest.
ACK_TIMEOUT = 5.0

#: Bound on the wait for the last messages' acknowledgements before exiting [s].
FINAL_ACK_TIMEOUT = 5.0

#: Wall seconds the publishers stay up after the last message [s]. When a writer goes away,
#: Fast DDS clears the samples of that writer that a reader has not yet taken from the
#: reader's history (eProsima/Fast-DDS#2053); a best-effort reader (rclpy's /clock
#: subscription) acknowledges nothing that :meth:`Replayer.flush` could wait for. Exiting at
#: once could so take the last clock sample from a node before its executor reads it, and
#: leave it short of the log's end (seen as a node stuck at 8 s of a 12 s log).
LINGER = 0.5

# ------------------------------------------------------------------------ timing
class Pacer:
    """When each message is due: ``t0 + (log_time - log_time_0) / rate`` [monotonic s].

    Parameters
    ----------
    rate : float or None
        Replay speed (2 = twice as fast as recorded); None sends every message at once.
    clock : callable
        Monotonic clock [s]; ``time.monotonic`` unless a test passes its own.

    Notes
    -----
    ``t0`` and ``log_time_0`` are fixed by the first call of :meth:`due`. A log time
    earlier than the previous one (a truncated log read in file order, a wall-clock step
    while recording) gives a time in the past: the message is sent at once, in log order.
    """

    def __init__(self, rate: float | None, clock: Any = time.monotonic) -> None:
        if rate is not None and not rate > 0:
            raise ValueError(f"rate must be positive, got {rate!r}")
        self.rate = rate
        self._clock = clock
        self._t0: float | None = None
        self._log0 = 0

    def due(self, log_time_ns: int) -> float:
        """Monotonic time [s] at which the message logged at ``log_time_ns`` is due."""
        if self._t0 is None:
            self._t0 = self._clock()
            self._log0 = log_time_ns
        if self.rate is None:
            return self._t0
        return self._t0 + (log_time_ns - self._log0) / NS / self.rate


# ------------------------------------------------------------------------ the node
class Replayer:
    """Node ``replay`` and its publishers: one per topic, recorded type and QoS.

    Parameters
    ----------
    index : LogIndex
        The log's topics (types and recorded QoS).
    topics : iterable of str
        Topics to publish.
    context : rclpy.Context, optional
        Context of the node (the default one unless given).

    Notes
    -----
    A reliable keep-last writer may drop its oldest sample when its history is full, even
    if a subscription has not yet acknowledged it (DDS keeps only ``depth`` samples). So
    after ``depth`` messages on a reliable topic, :meth:`publish` waits (at most
    :data:`ACK_TIMEOUT`) until they are acknowledged: with ``--fast`` the replay cannot
    outrun its own publishers' histories. A topic whose wait times out (a subscription that
    stopped acknowledging) is not throttled again.

    A topic whose message class is not installed gets no publisher, one whose recorded QoS
    cannot be read gets :data:`DEFAULT_QOS`; both are listed in ``warnings``.
    """

    def __init__(self, index: LogIndex, topics: Iterable[str], context: Any = None) -> None:
        import rclpy

        from phd_swarm.nodes.record_topics import message_class

        #: Problems met while creating the publishers, one line each.
        self.warnings: list[str] = []
        specs = []
        for topic in topics:
            entry = index.topics[topic]
            try:
                msg_class = message_class(entry.ros_type)
            except ValueError as exc:
                self.warnings.append(f"not replaying {topic}: {exc}")
                continue
            try:
                qos = offered_qos(entry.qos_yaml)
            except ValueError as exc:
                qos = offered_qos("")
                self.warnings.append(f"{topic}: {exc}; publishing with "
                                     f"{describe_qos(qos)}")
            specs.append((topic, msg_class, qos))
        self.node = rclpy.create_node("replay", context=context)
        self.publishers: dict[str, Any] = {}
        self.qos: dict[str, Any] = {}
        self._unacked: dict[str, int] = {}
        self._throttle: dict[str, int] = {}
        for topic, msg_class, qos in specs:
            self.publishers[topic] = self.node.create_publisher(msg_class, topic, qos)
            self.qos[topic] = qos
            self._unacked[topic] = 0
            if qos.reliability.name == "RELIABLE" and qos.history.name == "KEEP_LAST":
                self._throttle[topic] = max(int(qos.depth), 1)

    def unmatched(self, n: int) -> list[str]:
        """Topics whose publisher has fewer than ``n`` matched subscriptions."""
        return [t for t, pub in self.publishers.items() if pub.get_subscription_count() < n]

    def publish(self, record: LogRecord) -> None:
        """Publish the record's CDR bytes on its topic (see the class notes on throttling)."""
        topic = record.topic
        depth = self._throttle.get(topic)
        if depth is not None:
            if self._unacked[topic] >= depth:
                if not self._acked(topic, ACK_TIMEOUT):
                    del self._throttle[topic]
                    logging.getLogger(__name__).warning(
                        "%s: messages not acknowledged within %g s; later ones may be "
                        "dropped by the publisher's history", topic, ACK_TIMEOUT)
                self._unacked[topic] = 0
            self._unacked[topic] += 1
        self.publishers[topic].publish(record.data)

    def _acked(self, topic: str, timeout: float) -> bool:
        from rclpy.duration import Duration

        return self.publishers[topic].wait_for_all_acked(
            Duration(nanoseconds=int(timeout * NS)))

    def flush(self, timeout: float = FINAL_ACK_TIMEOUT) -> bool:
        """Wait until every reliable publisher's messages are acknowledged (bounded)."""
        deadline = time.monotonic() + timeout
        ok = True
        for topic in self.publishers:
            ok &= self._acked(topic, max(deadline - time.monotonic(), 0.0))
        return ok

    def destroy(self) -> None:
        """Destroy the publishers and the node."""
        for pub in self.publishers.values():
            self.node.destroy_publisher(pub)
        self.node.destroy_node()


# ------------------------------------------------------------------------ running
@dataclass
class Progress:
    """Counters of a replay, for the progress lines and the final line."""

    sent: int = 0
    log_offset_ns: int = 0
    sim_ns: int | None = None
    stopped: bool = False


def _say(quiet: bool, text: str) -> None:
    if not quiet:
        print(f"{PROG}: {text}", file=sys.stderr, flush=True)


def _status(progress: Progress) -> str:
    sim = "" if progress.sim_ns is None else f", sim time {progress.sim_ns / NS:.2f} s"
    return f"sent {progress.sent}, log +{progress.log_offset_ns / NS:.2f} s{sim}"


def run_replay(log: LogReader, index: LogIndex, selection: Selection, replayer: Replayer,
               pacer: Pacer, stop: threading.Event, quiet: bool = False) -> Progress:
    """Publish the selected messages on time; returns the counters.

    Sleeps on ``stop`` until each message is due, so a signal handler that sets ``stop``
    ends the replay at once, between two messages.
    """
    progress = Progress()
    next_report = time.monotonic() + PROGRESS_PERIOD
    for record in selected_messages(log, selection):
        wait = pacer.due(record.log_time_ns) - time.monotonic()
        while wait > 0 and not stop.is_set():
            if time.monotonic() >= next_report:
                _say(quiet, _status(progress))
                next_report = time.monotonic() + PROGRESS_PERIOD
            stop.wait(min(wait, max(next_report - time.monotonic(), 0.0)))
            wait = pacer.due(record.log_time_ns) - time.monotonic()
        if stop.is_set():
            progress.stopped = True
            break
        replayer.publish(record)
        progress.sent += 1
        progress.log_offset_ns = record.log_time_ns - (index.start_ns or 0)
        sim = clock_ns(record)
        if sim is not None:
            progress.sim_ns = sim
        if time.monotonic() >= next_report:
            _say(quiet, _status(progress))
            next_report = time.monotonic() + PROGRESS_PERIOD
    return progress


def wait_for_subscribers(replayer: Replayer, n: int, timeout: float, stop: threading.Event,
                         quiet: bool) -> None:
    """Wait until every publisher has ``n`` matched subscriptions, ``stop`` or ``timeout``.

    Polls the publishers' match counts every 50 ms; after ``timeout`` seconds it warns,
    naming the topics still short of subscriptions, and lets the replay start.
    """
    if n <= 0:
        return
    deadline = time.monotonic() + timeout
    missing = replayer.unmatched(n)
    if missing:
        _say(quiet, f"waiting for {n} subscription(s) on {len(missing)} topic(s)")
    while missing and not stop.is_set():
        if time.monotonic() >= deadline:
            print(f"{PROG}: warning: after {timeout:g} s, fewer than {n} subscription(s) on "
                  f"{' '.join(missing)}; replaying anyway", file=sys.stderr, flush=True)
            return
        stop.wait(0.05)
        missing = replayer.unmatched(n)


def dry_run(log: LogReader, index: LogIndex, selection: Selection,
            rate: float | None) -> list[str]:
    """Lines describing what a replay would send (reads the selection, publishes nothing).

    One line per selected topic: ``TOPIC TYPE COUNT FIRST LAST QOS`` with the first and last
    log times in seconds after the log's first message (``-`` for a topic without messages
    in the window) and the publisher QoS; then a total.
    """
    counts = dict.fromkeys(selection.topics, 0)
    first: dict[str, int] = {}
    last: dict[str, int] = {}
    for record in selected_messages(log, selection):
        counts[record.topic] += 1
        first.setdefault(record.topic, record.log_time_ns)
        last[record.topic] = record.log_time_ns
    origin = index.start_ns or 0

    def offset(times: dict[str, int], topic: str) -> str:
        return f"{(times[topic] - origin) / NS:.6f}" if topic in times else "-"

    width = max((len(t) for t in selection.topics), default=0)
    lines = [f"# {index.path}: {index.message_count} messages on {len(index.topics)} topics"
             + (" (truncated)" if index.truncated else "")]
    lines.append("# topic type count first_s last_s qos")
    for topic in selection.topics:
        try:
            qos = describe_qos(offered_qos(index.topics[topic].qos_yaml))
        except ValueError as exc:
            qos = f"(unreadable QoS: {exc})"
        lines.append(f"{topic:<{width}} {index.topics[topic].ros_type} {counts[topic]} "
                     f"{offset(first, topic)} {offset(last, topic)} {qos}")
    total = sum(counts.values())
    if first:
        span = (max(last.values()) - min(first.values())) / NS
        pace = "as fast as possible" if rate is None else f"{span / rate:.3f} s at rate {rate:g}"
        lines.append(f"# would send {total} messages on {len(selection.topics)} topics, "
                     f"log span {span:.3f} s: {pace}")
    else:
        lines.append("# would send 0 messages")
    return lines


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Command-line options (see the module docstring); argparse exits 2 on bad usage."""
    p = argparse.ArgumentParser(
        prog=PROG, description="Republish the messages of a recorded MCAP log with their "
                               "recorded types, QoS and timing (node 'replay').",
        epilog="--start and --end are seconds after the log's first message (any topic). "
               "ROS arguments go after --ros-args, e.g. --ros-args -r /clock:=/old/clock.")
    p.add_argument("log", help="the .mcap file (e.g. runs/<name>/run.mcap)")
    pace = p.add_mutually_exclusive_group()
    pace.add_argument("--rate", type=float, default=1.0, metavar="R",
                      help="speed factor: 2 replays twice as fast as recorded (default 1)")
    pace.add_argument("--fast", action="store_true",
                      help="send as fast as possible, in log order")
    p.add_argument("--topics", nargs="+", metavar="T", help="replay only these topics")
    p.add_argument("--start", type=float, metavar="S",
                   help="first log time to replay [s after the log's first message]")
    p.add_argument("--end", type=float, metavar="E",
                   help="replay log times before this [s after the log's first message]")
    p.add_argument("--wait-subscribers", type=int, default=0, metavar="N",
                   help="before sending, wait until every replayed topic has N matched "
                        "subscriptions (default 0: start at once)")
    p.add_argument("--wait-timeout", type=float, default=WAIT_TIMEOUT, metavar="W",
                   help=f"give up waiting for subscribers after W s and replay anyway "
                        f"(default {WAIT_TIMEOUT:g})")
    p.add_argument("--dry-run", action="store_true",
                   help="print what would be sent (per topic: type, count, first and last "
                        "log time, QoS) and exit without starting ROS")
    p.add_argument("--quiet", action="store_true", help="no progress and final lines")
    view_run.add_options(p, "replay", "; replays the topics it draws, each once the view "
                         "reads it")
    p.add_argument("--view-save", type=Path, metavar="FILE", help="with --view: also save "
                   "the view to FILE (.rrd; rerun FILE opens it)")
    opts = p.parse_args(list(argv))
    if not opts.rate > 0:
        p.error(f"--rate must be positive, got {opts.rate:g}")
    if opts.wait_subscribers < 0:
        p.error("--wait-subscribers must be >= 0")
    if not opts.wait_timeout >= 0:
        p.error("--wait-timeout must be >= 0")
    return opts


@contextlib.contextmanager
def _log_warnings_to_stderr() -> Iterator[None]:
    """Show the log reader's warnings (a truncated log) as ``replay.sh: warning: ...``."""
    logger = logging.getLogger("phd_swarm.logs")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter(f"{PROG}: warning: %(message)s"))
    handler.setLevel(logging.WARNING)
    previous = logger.propagate
    logger.addHandler(handler)
    logger.propagate = False
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.propagate = previous


def _replay_live(argv: Sequence[str], opts: argparse.Namespace, log: LogReader,
                 index: LogIndex, selection: Selection) -> int:
    """Start rclpy, publish the selection, shut down; returns the exit code."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    stop = threading.Event()
    rclpy.init(args=list(argv), signal_handler_options=SignalHandlerOptions.NO)
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    replayer = None
    try:
        replayer = Replayer(index, selection.topics)
        for warning in replayer.warnings:
            print(f"{PROG}: warning: {warning}", file=sys.stderr)
        if not replayer.publishers:
            print(f"{PROG}: {index.path}: none of the selected topics can be published",
                  file=sys.stderr)
            return 1
        selection = replace(selection, topics=tuple(replayer.publishers))
        wait_for_subscribers(replayer, opts.wait_subscribers, opts.wait_timeout, stop,
                             opts.quiet)
        rate = None if opts.fast else opts.rate
        _say(opts.quiet, f"replaying {index.path}: {len(selection.topics)} topics, "
                         + ("as fast as possible" if rate is None else f"rate {rate:g}"))
        start = time.monotonic()
        progress = run_replay(log, index, selection, replayer, Pacer(rate), stop, opts.quiet)
        wall = time.monotonic() - start
        how = "stopped by signal" if progress.stopped else "done"
        _say(opts.quiet, f"{how}: sent {progress.sent} messages in {wall:.2f} s wall "
                         f"({_status(progress).split(', ', 1)[1]})")
        if progress.sent == 0 and not progress.stopped:
            print(f"{PROG}: warning: no message of the selected topics in the window",
                  file=sys.stderr)
        if not progress.stopped:
            if not replayer.flush():
                print(f"{PROG}: warning: some messages were not acknowledged by every "
                      f"subscription within {FINAL_ACK_TIMEOUT:g} s", file=sys.stderr)
            stop.wait(LINGER)
        return 0
    finally:
        if replayer is not None:
            replayer.destroy()
        rclpy.try_shutdown()
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def log_gaps(log: LogReader, index: LogIndex) -> str | None:
    """The log's completeness verdict, or None when it cannot be judged (no run config).

    The recorder's report stored in a finished log; recomputed from the messages for a log
    cut short (the recorder could not store one).
    """
    from phd_swarm.nodes.completeness import Completeness
    from phd_swarm.tools.log_check import check_log

    stored = log.metadata().get("phd_swarm.completeness")
    if stored is not None and not index.truncated:
        return Completeness.from_dict(json.loads(stored["report"])).describe()
    if "phd_swarm.config" not in log.metadata():
        return None
    return check_log(log.path).describe()


def _warn_gaps(log: LogReader, index: LogIndex) -> None:
    from phd_swarm.tools.log_check import WARNING

    verdict = log_gaps(log, index)
    if verdict is not None and not verdict.startswith("complete"):
        print(f"{PROG}: {WARNING}: {verdict}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``scripts/replay.sh`` (``python -m phd_swarm.tools.replay``)."""
    from rclpy.utilities import remove_ros_args

    full = list(sys.argv[1:] if argv is None else argv)
    try:
        opts = parse_args(remove_ros_args(["replay", *full])[1:])
    except SystemExit as exc:  # argparse: --help (0) or bad usage (2)
        return int(exc.code or 0)
    with _log_warnings_to_stderr():
        try:
            with open_log(opts.log) as log:
                index = index_log(log)
                try:
                    selection = select(index, opts.topics, opts.start, opts.end)
                except UsageError as exc:
                    print(f"{PROG}: error: {exc}", file=sys.stderr)
                    return 2
                _warn_gaps(log, index)
                if opts.dry_run:
                    for line in dry_run(log, index, selection, None if opts.fast
                                        else opts.rate):
                        print(line)
                    return 0
                if index.start_ns is None:
                    print(f"{PROG}: warning: {index.path}: the log holds no messages",
                          file=sys.stderr)
                    return 0
                if opts.view:
                    return _replay_viewed(["replay", *full], opts, log, index)
                return _replay_live(["replay", *full], opts, log, index, selection)
        except LogError as exc:
            print(f"{PROG}: {exc}", file=sys.stderr)
            return 1


def _replay_viewed(argv: list[str], opts: argparse.Namespace, log: LogReader,
                   index: LogIndex) -> int:
    """``--view``: start the view server and the viewer, then replay what it draws.

    The topics the view draws (unless ``--topics``), each once the viewer reads it
    (``--wait-subscribers 1`` at least).
    """
    from phd_swarm.nodes.viewer import drawn_topics
    from phd_swarm.tools.view_server import ViewServerError

    if not opts.topics:
        opts.topics = list(drawn_topics({t: [lt.ros_type] for t, lt in index.topics.items()}))
    if not opts.topics:
        print(f"{PROG}: error: {index.path}: no topic the view draws (markers, grids, "
              "team state, metrics)", file=sys.stderr)
        return 2
    selection = select(index, opts.topics, opts.start, opts.end)
    opts.wait_subscribers = max(1, opts.wait_subscribers)
    # The view's logs beside the run's, or in a temporary directory if that is read-only.
    logs = Path(index.path).resolve().parent / "logs"
    if not os.access(logs if logs.exists() else logs.parent, os.W_OK):
        logs = Path(tempfile.mkdtemp(prefix="phd_swarm_replay_view_"))
    try:
        server = view_run.start_server(logs / "view_server.log", PROG)
    except ViewServerError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 1
    viewer = None
    try:
        viewer = view_run.start_viewer(dict(os.environ), server.grpc_url, opts.view_save,
                                       logs / "replay_viewer.log",
                                       f"replay of {Path(index.path).parent.name}")
        code = _replay_live(argv, opts, log, index, selection)
        view_run.stop(viewer, None)
        viewer = None
        view_run.hold(server, PROG, True if opts.view_hold else None)
        return code
    finally:
        view_run.stop(viewer, server)


if __name__ == "__main__":
    sys.exit(main())
