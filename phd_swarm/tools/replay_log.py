"""What ``replay.sh`` reads from a log before it sends anything: QoS, topics, times.

- The publisher QoS of each channel (:func:`offered_qos`): the ``offered_qos_profiles`` the
  recorder stored with it, rosbag2's YAML, combined over the publishers as rosbag2 does
  (the strongest reliability and durability any publisher offered), or rosbag2's default
  profile (:data:`DEFAULT_QOS`) for a channel without any.
- The log's index (:func:`index_log`): per topic its type, QoS, message count and first
  and last log times, and the sim-time span of ``/clock``.
- What to send (:func:`select`, :func:`selected_messages`): the topics and the time window
  asked for, in log order.
"""

from __future__ import annotations

import contextlib
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from mcap.reader import make_reader
from mcap.records import Channel
from mcap.stream_reader import StreamReader

from phd_swarm.logs.mcap_log import LogReader, LogRecord


class UsageError(ValueError):
    """A bad command-line value (exit code 2)."""


#: Publisher QoS of a topic whose channel has no ``offered_qos_profiles`` (a publisher
#: unknown to the recorder, or a log from another tool): rosbag2's default profile.
DEFAULT_QOS = {"history": "keep_last", "depth": 10, "reliability": "reliable",
               "durability": "volatile"}

#: Nanoseconds per second.
NS = 1_000_000_000
_STAMP_LE = struct.Struct("<iI")
_STAMP_BE = struct.Struct(">iI")
#: Durations rosbag2 writes for "infinite": rmw's int64 maximum, and Humble's (sec, nsec).
_INFINITE_NS = (1 << 63) - 1
_HUMBLE_INFINITE = (2147483647, 4294967295)



# ------------------------------------------------------------------------ QoS
def _policy(enum: Any, value: Any, strongest: Any) -> Any:
    """The member of rclpy policy ``enum`` named (or numbered) ``value`` in a QoS YAML.

    ``best_available`` becomes ``strongest`` (a replay publisher must offer a concrete
    policy); ``unknown`` and names rclpy does not know become ``SYSTEM_DEFAULT``.
    """
    try:
        member = enum(int(value)) if isinstance(value, int) else enum[str(value).upper()]
    except (KeyError, ValueError):
        return enum.SYSTEM_DEFAULT
    if member.name == "BEST_AVAILABLE":
        return strongest
    if member.name == "UNKNOWN":
        return enum.SYSTEM_DEFAULT
    return member


def _qos_duration(value: Any) -> Any:
    """An rclpy Duration from a ``{sec, nsec}`` mapping; 0 is "default", huge is Infinite."""
    from rclpy.duration import Duration, Infinite

    if not isinstance(value, dict):
        return Duration()
    sec, nsec = int(value.get("sec", 0)), int(value.get("nsec", 0))
    ns = sec * NS + nsec
    if ns >= _INFINITE_NS or (sec, nsec) == _HUMBLE_INFINITE:
        return Infinite
    return Duration(nanoseconds=max(ns, 0))


def offered_qos(text: str) -> Any:
    """A publisher QoSProfile that offers what the recorded publishers offered.

    Parameters
    ----------
    text : str
        A channel's ``offered_qos_profiles``: the YAML list of rosbag2 (Jazzy writes policy
        names, older versions numbers) that :func:`phd_swarm.logs.qos_yaml.qos_yaml`
        writes, one entry per publisher the recorder saw. Empty for none.

    Returns
    -------
    rclpy.qos.QoSProfile
        With several entries: reliable if any publisher was (a reliable writer serves
        reliable and best-effort readers), transient-local if any was (latched data stays
        latched), keep-all if any was, the largest depth; deadline, lifespan and liveliness
        from the first entry. With none: :data:`DEFAULT_QOS`.

    Raises
    ------
    ValueError
        If ``text`` is not a YAML list of mappings.
    """
    from rclpy.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        LivelinessPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )

    try:
        entries = yaml.safe_load(text) if text and text.strip() else None
    except yaml.YAMLError as exc:
        raise ValueError(f"offered_qos_profiles is not YAML: {exc}") from None
    if entries is None:
        entries = [DEFAULT_QOS]
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise ValueError("offered_qos_profiles is not a list of QoS mappings")
    history = [_policy(HistoryPolicy, e.get("history", "keep_last"), HistoryPolicy.KEEP_LAST)
               for e in entries]
    reliability = [_policy(ReliabilityPolicy, e.get("reliability", "reliable"),
                           ReliabilityPolicy.RELIABLE) for e in entries]
    durability = [_policy(DurabilityPolicy, e.get("durability", "volatile"),
                          DurabilityPolicy.TRANSIENT_LOCAL) for e in entries]
    first = entries[0]
    depth = max(int(e.get("depth", 0) or 0) for e in entries)

    def pick(values: list[Any], preferred: Any) -> Any:
        return preferred if preferred in values else values[0]

    return QoSProfile(
        history=pick(history, HistoryPolicy.KEEP_ALL),
        depth=depth if depth > 0 else int(DEFAULT_QOS["depth"]),
        reliability=pick(reliability, ReliabilityPolicy.RELIABLE),
        durability=pick(durability, DurabilityPolicy.TRANSIENT_LOCAL),
        deadline=_qos_duration(first.get("deadline")),
        lifespan=_qos_duration(first.get("lifespan")),
        liveliness=_policy(LivelinessPolicy, first.get("liveliness", "system_default"),
                           LivelinessPolicy.AUTOMATIC),
        liveliness_lease_duration=_qos_duration(first.get("liveliness_lease_duration")),
        avoid_ros_namespace_conventions=bool(first.get("avoid_ros_namespace_conventions",
                                                       False)))


def describe_qos(profile: Any) -> str:
    """A short description of a QoSProfile, e.g. ``reliable transient_local keep_last 8``."""
    history = profile.history.name.lower()
    if profile.history.name == "KEEP_LAST":
        history += f" {profile.depth}"
    return f"{profile.reliability.name.lower()} {profile.durability.name.lower()} {history}"


# ------------------------------------------------------------------------ the log
@dataclass(frozen=True)
class LogTopic:
    """One topic of a log: type, the recorded publishers' QoS YAML, message count."""

    topic: str
    ros_type: str
    qos_yaml: str
    message_count: int


@dataclass(frozen=True)
class LogIndex:
    """What a replay needs to know about a log before reading its messages.

    Attributes
    ----------
    path : str
        The file.
    truncated : bool
        Whether the log has no valid footer (only its complete records are read).
    start_ns, end_ns : int or None
        Log time of the first and last message [ns]; None for a log without messages.
    topics : dict
        Topic -> :class:`LogTopic`, sorted by topic.
    """

    path: str
    truncated: bool
    start_ns: int | None
    end_ns: int | None
    topics: dict[str, LogTopic]

    @property
    def message_count(self) -> int:
        """Messages in the log."""
        return sum(t.message_count for t in self.topics.values())


def _channel_metadata(path: Path, complete: bool) -> tuple[dict[str, dict[str, str]], Any]:
    """(topic -> channel metadata, MCAP summary or None) of the log at ``path``.

    A complete log has its channels in the summary section; a truncated one is read record
    by record (chunks decompressed) until the first incomplete record.
    """
    with open(path, "rb") as stream:
        if complete:
            with contextlib.suppress(Exception):  # a damaged summary: scan the records
                summary = make_reader(stream).get_summary()
                if summary is not None:
                    return ({c.topic: dict(c.metadata) for c in summary.channels.values()},
                            summary)
            stream.seek(0)
        metadata: dict[str, dict[str, str]] = {}
        with contextlib.suppress(Exception):  # mcap's EndOfFile, CRC or decompression errors
            for record in StreamReader(stream).records:
                if isinstance(record, Channel):
                    metadata.setdefault(record.topic, dict(record.metadata))
        return metadata, None


def index_log(log: LogReader) -> LogIndex:
    """Topics, types, recorded QoS, counts and time span of an open log.

    Uses the MCAP summary (schemas, channels, statistics) of a complete log, so nothing but
    the file's tail is read; a truncated log is scanned (:meth:`LogReader.info`).
    """
    metadata, summary = _channel_metadata(log.path, not log.truncated)
    stats = getattr(summary, "statistics", None)
    if summary is not None and stats is not None:
        counts = stats.channel_message_counts
        topics = {}
        for cid, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            ros_type = schema.name if schema is not None else ""
            old = topics.get(channel.topic)
            count = counts.get(cid, 0) + (old.message_count if old else 0)
            qos = metadata.get(channel.topic, {}).get("offered_qos_profiles", "")
            topics[channel.topic] = LogTopic(channel.topic, ros_type, qos, count)
        has = stats.message_count > 0
        return LogIndex(str(log.path), False,
                        stats.message_start_time if has else None,
                        stats.message_end_time if has else None,
                        dict(sorted(topics.items())))
    info = log.info()
    topics = {name: LogTopic(name, t.ros_type,
                             metadata.get(name, {}).get("offered_qos_profiles", ""),
                             t.message_count)
              for name, t in info.topics.items()}
    return LogIndex(str(log.path), log.truncated, info.start_ns, info.end_ns, topics)


@dataclass(frozen=True)
class Selection:
    """Which messages of a log a replay sends.

    Attributes
    ----------
    topics : tuple of str
        Selected topics, sorted.
    start_ns, end_ns : int or None
        Log-time window ``[start_ns, end_ns)`` [ns since the epoch]; None for open.
    """

    topics: tuple[str, ...]
    start_ns: int | None
    end_ns: int | None


def select(index: LogIndex, topics: Sequence[str] | None, start_s: float | None,
           end_s: float | None) -> Selection:
    """The selection for ``--topics``, ``--start`` and ``--end`` (seconds after the log's start).

    Raises
    ------
    UsageError
        For a topic that is not in the log (the message lists the log's topics) or a
        window that ends before it starts.
    """
    if topics:
        unknown = [t for t in topics if t not in index.topics]
        if unknown:
            raise UsageError(f"{index.path}: no topic {', '.join(unknown)} in the log; its "
                             f"topics are: {' '.join(index.topics) or '(none)'}")
        chosen = tuple(sorted(set(topics)))
    else:
        chosen = tuple(index.topics)
    if start_s is not None and end_s is not None and end_s <= start_s:
        raise UsageError(f"--end ({end_s:g} s) must be after --start ({start_s:g} s)")
    first = index.start_ns or 0
    start_ns = None if start_s is None else first + round(start_s * NS)
    end_ns = None if end_s is None else first + round(end_s * NS)
    return Selection(chosen, start_ns, end_ns)


def selected_messages(log: LogReader, selection: Selection) -> Iterator[LogRecord]:
    """The selected messages, undecoded, in log-time order (file order if truncated)."""
    return log.messages(list(selection.topics), selection.start_ns, selection.end_ns,
                        decode=False)


def clock_ns(record: LogRecord) -> int | None:
    """Sim time [ns] of a ``rosgraph_msgs/msg/Clock`` record, else None.

    The Clock's ``builtin_interfaces/Time`` is the first field: CDR bytes 4-12 after the
    encapsulation header (odd kinds are little-endian), as the recorder reads stamps.
    """
    if record.ros_type != "rosgraph_msgs/msg/Clock" or len(record.data) < 12:
        return None
    sec, nsec = (_STAMP_LE if record.data[1] & 1 else _STAMP_BE).unpack_from(record.data, 4)
    return sec * NS + nsec


