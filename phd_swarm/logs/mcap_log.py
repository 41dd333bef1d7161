"""MCAP run logs written and read the way rosbag2's MCAP storage does (no rclpy needed).

A log is an MCAP file with profile ``ros2``; each topic is a channel with message encoding
``cdr`` (the bytes of a ``raw=True`` subscription: the 4-byte CDR encapsulation header and the
payload) and a ``ros2msg`` schema named ``pkg/msg/Type``. The schema text is the type's
``.msg`` file followed, once per nested type, by a line of 80 ``=``, a line ``MSG: pkg/Type``
and that type's ``.msg`` file, so decoders without the ROS type support
(``mcap_ros2.decoder.DecoderFactory``, Foxglove) can decode nested fields
(rosbag2 ``docs/message_definition_encoding.md``). Channel metadata holds
``offered_qos_profiles`` in the YAML that Jazzy's rosbag2 writes (policy names as strings)
and ``topic_type_hash`` (the RIHS01 hash rosidl installs next to the ``.msg`` file).
Log time is when a message was received, publish time when it was sent; see
:mod:`phd_swarm.nodes.recorder` for the clocks the recorder uses.

Crash safety: the writer hands every finished chunk to the operating system at once (no
buffering in the process), so a recorder killed with SIGKILL leaves a file whose complete
chunks can be read. Such a file has no summary and no footer; the reader then scans the
records in file order up to the last complete one, sets :attr:`LogReader.truncated` and
logs a warning on the ``phd_swarm.logs.mcap_log`` logger.
"""

from __future__ import annotations

import io
import logging
import os
import struct
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import breakup_chunk
from mcap_ros2.decoder import DecoderFactory

from phd_swarm.logs.log_format import (  # noqa: F401 (re-exported: the log's names)
    MAGIC,
    MESSAGE_ENCODING,
    PROFILE,
    SCHEMA_ENCODING,
    LogError,
)
from phd_swarm.logs.log_writer import LogWriter  # noqa: F401 (re-exported)

logger = logging.getLogger(__name__)


# ------------------------------------------------------------------------ reading
@dataclass(frozen=True)
class LogRecord:
    """One message of a log.

    Attributes
    ----------
    topic, ros_type : str
        Channel topic and message type (``pkg/msg/Type``).
    log_time_ns, publish_time_ns : int
        Receive and publish time [ns] (see the recorder for their clocks).
    data : bytes
        The CDR bytes, as ``rclpy.serialization.deserialize_message`` takes them.
    msg : object or None
        The message decoded by ``mcap_ros2`` (attribute access like the ROS message), or
        None when read with ``decode=False``.
    """

    topic: str
    ros_type: str
    log_time_ns: int
    publish_time_ns: int
    data: bytes
    msg: Any = None


@dataclass(frozen=True)
class TopicSummary:
    """Messages of one topic: count and first/last log time [ns] (None if no message)."""

    topic: str
    ros_type: str
    message_count: int
    start_ns: int | None
    end_ns: int | None


@dataclass(frozen=True)
class LogInfo:
    """What a log holds.

    Attributes
    ----------
    path : str
        The file.
    library : str
        Writer library recorded in the MCAP header.
    truncated : bool
        True if the file has no valid summary and footer (a writer that was killed or is
        still writing, or cut bytes); the counts are then those of the complete records.
    message_count : int
        Messages in the log.
    start_ns, end_ns : int or None
        First and last log time [ns] over all topics.
    topics : dict
        Topic -> :class:`TopicSummary`, for every channel (also those without messages).
    """

    path: str
    library: str
    truncated: bool
    message_count: int
    start_ns: int | None
    end_ns: int | None
    topics: dict[str, TopicSummary]


class _Scan:
    """Records of an MCAP file in file order, stopping quietly at the first incomplete one.

    Each record's length is checked against the file size before it is read, chunks are
    checked against their CRC, and anything that fails ends the scan with ``stopped`` set to
    the reason; the data section's end (DataEnd) ends it normally.
    """

    def __init__(self, stream: io.BufferedReader, size: int) -> None:
        self._stream = stream
        self._size = size
        self.stopped: str | None = None

    def records(self) -> Iterator[Any]:
        pos = len(MAGIC)
        stream = self._stream
        while True:
            if pos + 9 > self._size:
                self.stopped = f"file ends inside a record header at byte {pos}"
                return
            stream.seek(pos)
            opcode, length = struct.unpack("<BQ", stream.read(9))
            if opcode == 0 or pos + 9 + length > self._size:
                self.stopped = f"incomplete record at byte {pos}"
                return
            body = stream.read(length)
            try:
                if opcode == Opcode.CHUNK:
                    chunk = Chunk.read(ReadDataStream(io.BytesIO(body)))
                    records = breakup_chunk(chunk, validate_crc=True)
                else:
                    records = [self._parse(opcode, body)]
            except Exception as exc:  # mcap, struct, zstd and lz4 each raise their own types
                self.stopped = f"damaged record at byte {pos}: {exc}"
                return
            pos += 9 + length
            for record in records:
                if isinstance(record, (DataEnd, Footer)):
                    return
                if record is not None:
                    yield record

    @staticmethod
    def _parse(opcode: int, body: bytes) -> Any:
        stream = ReadDataStream(io.BytesIO(body))
        if opcode == Opcode.HEADER:
            return Header.read(stream)
        if opcode == Opcode.SCHEMA:
            return Schema.read(stream)
        if opcode == Opcode.CHANNEL:
            return Channel.read(stream)
        if opcode == Opcode.MESSAGE:
            return Message.read(stream, len(body))
        if opcode == Opcode.METADATA:
            return Metadata.read(stream)
        if opcode == Opcode.DATA_END:
            return DataEnd.read(stream)
        if opcode == Opcode.FOOTER:
            return Footer.read(stream)
        return None


class LogReader:
    """An open MCAP log (see :func:`open_log`).

    Attributes
    ----------
    path : Path
        The file.
    library : str
        Writer library from the MCAP header.
    truncated : bool
        True if the file does not end with a valid footer (a writer that was killed or is
        still writing, or cut bytes): only the complete records are read, in file order.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        try:
            self._stream = open(self.path, "rb")  # noqa: SIM115 - closed in close()
        except FileNotFoundError:
            raise LogError(f"{self.path}: no such file") from None
        except OSError as exc:
            raise LogError(f"{self.path}: cannot open: {exc.strerror}") from None
        try:
            self._size = os.fstat(self._stream.fileno()).st_size
            if self._stream.read(len(MAGIC)) != MAGIC:
                raise LogError(f"{self.path}: not an MCAP file (bad magic)")
            header = next(iter(self._scan().records()), None)
            if not isinstance(header, Header):
                raise LogError(f"{self.path}: MCAP file cut inside its header record; it "
                               "holds no messages")
            if header.profile != PROFILE:
                raise LogError(f"{self.path}: not a ROS 2 log (MCAP profile "
                               f"{header.profile!r}, expected {PROFILE!r})")
            self.library = header.library
            self.truncated, self._summary = self._read_tail()
            if self._summary is not None:
                for channel in self._summary.channels.values():
                    self._check_channel(channel, self._summary.schemas)
        except BaseException:
            self._stream.close()
            raise
        if self.truncated:
            logger.warning("%s: log is truncated (no valid footer: the writer was killed or "
                           "is still writing); reading its complete records only", self.path)
        self._decoders = DecoderFactory()

    def _read_tail(self) -> tuple[bool, Any]:
        """(truncated, summary): summary is None without a (valid) summary section."""
        if self._size < 2 * len(MAGIC) + 9:
            return True, None
        self._stream.seek(self._size - len(MAGIC))
        if self._stream.read(len(MAGIC)) != MAGIC:
            return True, None
        try:
            self._stream.seek(0)
            summary = make_reader(self._stream).get_summary()
        except Exception:  # mcap, struct and OS errors alike mean a damaged tail
            return True, None
        return False, summary

    def _check_channel(self, channel: Channel, schemas: Mapping[int, Schema]) -> None:
        schema = schemas.get(channel.schema_id)
        if channel.message_encoding != MESSAGE_ENCODING or schema is None \
                or schema.encoding != SCHEMA_ENCODING:
            enc = schema.encoding if schema is not None else "none"
            raise LogError(f"{self.path}: not a ROS 2 CDR log: topic {channel.topic} has "
                           f"message encoding {channel.message_encoding!r} and schema "
                           f"encoding {enc!r} (expected {MESSAGE_ENCODING!r} and "
                           f"{SCHEMA_ENCODING!r})")

    @property
    def _indexed_ok(self) -> bool:
        return self._summary is not None and bool(self._summary.chunk_indexes)

    # -------------------------------------------------------------- messages
    def _scan(self) -> _Scan:
        self._stream.seek(0)
        return _Scan(self._stream, self._size)

    def _indexed(self, topics: list[str] | None, start_ns: int | None,
                 end_ns: int | None) -> Iterator[tuple[Schema, Channel, Message]]:
        self._stream.seek(0)
        reader = make_reader(self._stream)
        yield from reader.iter_messages(topics, log_time_order=True, starting_at=start_ns,
                                        ending_before=end_ns)

    def _scanned(self, topics: list[str] | None, start_ns: int | None,
                 end_ns: int | None) -> Iterator[tuple[Schema, Channel, Message]]:
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        scan = self._scan()
        for record in scan.records():
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                self._check_channel(record, schemas)
                channels[record.id] = record
            elif isinstance(record, Message):
                channel = channels.get(record.channel_id)
                if channel is None:
                    raise LogError(f"{self.path}: message on channel {record.channel_id} "
                                   "before the channel's definition")
                if topics is not None and channel.topic not in topics:
                    continue
                if start_ns is not None and record.log_time < start_ns:
                    continue
                if end_ns is not None and record.log_time >= end_ns:
                    continue
                yield schemas[channel.schema_id], channel, record
        if scan.stopped:
            logger.debug("%s: scan stopped: %s", self.path, scan.stopped)

    def messages(self, topics: Iterable[str] | None = None, start_ns: int | None = None,
                 end_ns: int | None = None, decode: bool = True) -> Iterator[LogRecord]:
        """Yield the messages with ``start_ns <= log_time < end_ns`` on ``topics`` (all if None).

        A complete log is read through its chunk index in log-time order; a truncated one
        in file order (which is receive order for the recorder), up to the last complete
        chunk. ``decode=False`` skips decoding (``msg`` is None), which is much faster.

        Raises
        ------
        LogError
            If a channel is not ROS 2 CDR or a message cannot be decoded.
        """
        wanted = None if topics is None else [topics] if isinstance(topics, str) \
            else list(topics)
        source = self._indexed if self._indexed_ok else self._scanned
        try:
            for schema, channel, message in source(wanted, start_ns, end_ns):
                msg = self._decode(schema, channel, message) if decode else None
                yield LogRecord(channel.topic, schema.name, message.log_time,
                                message.publish_time, message.data, msg)
        except LogError:
            raise
        except Exception as exc:  # the mcap library on damaged bytes (fuzzed, issue 40)
            raise self._damaged(exc) from exc

    def _damaged(self, exc: Exception) -> LogError:
        """The error for what the mcap library (or struct, zstd, lz4, UTF-8) raised."""
        if isinstance(exc, McapError):
            return LogError(f"{self.path}: {exc}")
        return LogError(f"{self.path}: damaged log ({type(exc).__name__}: {exc})")

    def recorded_decoder(self, topic: str) -> Callable[[bytes], Any]:
        """A decoder of ``topic``'s CDR by the definition recorded in the log (mcap_ros2).

        For messages recorded with another version of their type than the installed one
        (a field added since). LogError if the log has no such topic.
        """
        if self._summary is not None:
            schemas, channels = self._summary.schemas, self._summary.channels.values()
        else:
            records = list(self._scan().records())
            schemas = {r.id: r for r in records if isinstance(r, Schema)}
            channels = [r for r in records if isinstance(r, Channel)]
        for channel in channels:
            if channel.topic == topic and channel.schema_id in schemas:
                return self._decoders.decoder_for(channel.message_encoding,
                                                  schemas[channel.schema_id])
        raise LogError(f"{self.path}: no topic {topic}")

    def _decode(self, schema: Schema, channel: Channel, message: Message) -> Any:
        try:
            decoder = self._decoders.decoder_for(channel.message_encoding, schema)
            return decoder(message.data)
        except Exception as exc:  # the generated decoders raise struct, index, value errors
            raise LogError(f"{self.path}: cannot decode the {schema.name} message on "
                           f"{channel.topic} logged at {message.log_time} ns: {exc}") from exc

    # -------------------------------------------------------------- metadata, summary
    def metadata(self) -> dict[str, dict[str, str]]:
        """Metadata records by name (a later record of the same name replaces an earlier)."""
        out: dict[str, dict[str, str]] = {}
        if self._summary is None:
            records: Iterable[Any] = (r for r in self._scan().records()
                                      if isinstance(r, Metadata))
        else:
            self._stream.seek(0)
            records = make_reader(self._stream).iter_metadata()
        try:
            for record in records:
                out[record.name] = dict(record.metadata)
        except Exception as exc:  # the mcap library on damaged bytes
            raise self._damaged(exc) from exc
        return out

    def info(self) -> LogInfo:
        """Per-topic counts and times (reads every chunk, without decoding)."""
        types: dict[str, str] = {}
        if self._summary is not None:
            for channel in self._summary.channels.values():
                types[channel.topic] = self._summary.schemas[channel.schema_id].name
        else:
            schemas: dict[int, Schema] = {}
            for record in self._scan().records():
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel) and record.schema_id in schemas:
                    types.setdefault(record.topic, schemas[record.schema_id].name)
        counts = dict.fromkeys(types, 0)
        first: dict[str, int] = {}
        last: dict[str, int] = {}
        for rec in self.messages(decode=False):
            counts[rec.topic] = counts.get(rec.topic, 0) + 1
            types.setdefault(rec.topic, rec.ros_type)
            t = rec.log_time_ns
            if t < first.get(rec.topic, t + 1):
                first[rec.topic] = t
            if t > last.get(rec.topic, t - 1):
                last[rec.topic] = t
        topics = {name: TopicSummary(name, types[name], counts[name], first.get(name),
                                     last.get(name)) for name in sorted(types)}
        return LogInfo(str(self.path), self.library, self.truncated, sum(counts.values()),
                       min(first.values(), default=None), max(last.values(), default=None),
                       topics)

    def close(self) -> None:
        """Close the file (idempotent)."""
        self._stream.close()

    def __enter__(self) -> LogReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_log(path: str | Path) -> LogReader:
    """Open a ROS 2 MCAP log for reading; use as a context manager.

    Raises
    ------
    LogError
        If the file is missing, is not an MCAP file, or is not a ROS 2 (``ros2`` profile,
        ``cdr``/``ros2msg``) log. A truncated log opens with ``truncated`` set.
    """
    return LogReader(path)


def read_messages(path: str | Path, topics: Iterable[str] | None = None,
                  start_ns: int | None = None, end_ns: int | None = None,
                  decode: bool = True) -> Iterator[LogRecord]:
    """Yield the messages of the log at ``path`` (see :meth:`LogReader.messages`)."""
    with open_log(path) as log:
        yield from log.messages(topics, start_ns, end_ns, decode)


def read_metadata(path: str | Path) -> dict[str, dict[str, str]]:
    """Metadata records of the log at ``path`` by name."""
    with open_log(path) as log:
        return log.metadata()


def summarize(path: str | Path) -> LogInfo:
    """Per-topic message counts, types and first/last log times of the log at ``path``."""
    with open_log(path) as log:
        return log.info()
