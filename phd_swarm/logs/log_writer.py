"""Writing a ROS 2 MCAP log (see :mod:`phd_swarm.logs.mcap_log` for the format).

Crash safety: every finished chunk goes to the operating system at once (no buffering in the
process), so a writer killed with SIGKILL, or one whose disk fills, leaves a file whose
complete chunks can be read.

Memory: the chunk indexes the summary needs are packed as each chunk is finished
(:mod:`phd_swarm.logs.packed_index`), so a long run's writer holds ~10 bytes per channel
and chunk until close.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from mcap.writer import LIBRARY_IDENTIFIER, CompressionType, Writer

from phd_swarm import __version__
from phd_swarm.logs.log_format import MESSAGE_ENCODING, PROFILE, SCHEMA_ENCODING, LogError
from phd_swarm.logs.packed_index import pack_new_chunk_indexes
from phd_swarm.logs.schemas import installed_type_hash, message_definition

_COMPRESSION = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}


class _DirectFile:
    """A write-only file without a user-space buffer.

    ``mcap.writer.Writer`` wraps raw files in a ``BufferedWriter``; this object is not a
    ``RawIOBase``, so every ``write`` (one per finished chunk, with its message indexes)
    reaches the operating system at once and survives a SIGKILL of the process.
    """

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self._pos = 0
        #: Writes so far (the writer writes when it finishes a chunk).
        self.writes = 0

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            n = os.write(self._fd, view)
            view = view[n:]
        self._pos += len(data)
        self.writes += 1
        return len(data)

    def tell(self) -> int:
        return self._pos

    def flush(self) -> None:
        """Nothing is buffered here."""

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class LogWriter:
    """Writes a ROS 2 MCAP log: chunked, compressed, indexed, readable after a crash.

    Parameters
    ----------
    path : str or Path
        File to create (replaced if it exists).
    compression : {"zstd", "lz4", "none"}
        Chunk compression.
    chunk_size : int
        Uncompressed bytes after which a chunk is finished and written [bytes]. A crash
        loses at most the chunk in progress.

    Notes
    -----
    Use as a context manager, or call :meth:`close`, which writes the summary (schemas,
    channels, statistics, chunk and metadata indexes) and the footer. Not thread-safe: call
    it from one thread (the recorder's executor).
    """

    def __init__(self, path: str | Path, compression: str = "zstd",
                 chunk_size: int = 1 << 20) -> None:
        if compression not in _COMPRESSION:
            raise ValueError(f"compression must be one of {sorted(_COMPRESSION)}, "
                             f"got {compression!r}")
        if int(chunk_size) < 1:
            raise ValueError(f"chunk_size must be positive, got {chunk_size!r}")
        self.path = Path(path)
        try:
            self._file = _DirectFile(self.path)
        except OSError as exc:
            raise LogError(f"{self.path}: cannot create the log: {exc.strerror}") from None
        self._writer = Writer(self._file, chunk_size=int(chunk_size),
                              compression=_COMPRESSION[compression])
        self._writer.start(PROFILE, f"phd_swarm/{__version__} {LIBRARY_IDENTIFIER}")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._closed = False
        #: Why the log stopped taking messages (a write the OS refused), or None.
        self.failure: str | None = None
        #: Messages written so far.
        self.message_count = 0
        #: Chunk indexes packed so far (:func:`pack_new_chunk_indexes`), and the file's
        #: writes when they were.
        self._packed = 0
        self._writes_packed = 0

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has been called."""
        return self._closed

    @property
    def topics(self) -> tuple[str, ...]:
        """Topics with a channel, in the order they were added."""
        return tuple(self._channels)

    def add_channel(self, topic: str, ros_type: str, offered_qos_yaml: str = "",
                    type_hash: str | None = None) -> int:
        """Add the channel of ``topic`` (type ``pkg/msg/Type``); returns its channel id.

        Idempotent per topic: a second call returns the first channel and ignores its
        arguments. ``offered_qos_yaml`` is the publishers' QoS (:func:`qos_yaml`);
        ``type_hash`` (``RIHS01_...``) defaults to the hash rosidl installed for the type
        (:func:`installed_type_hash`).

        Raises
        ------
        DefinitionNotFoundError
            If the type's ``.msg`` definition is not installed.
        """
        self._check_open()
        if topic in self._channels:
            return self._channels[topic]
        schema_id = self._schemas.get(ros_type)
        if schema_id is None:
            text = message_definition(ros_type)
            schema_id = self._writer.register_schema(ros_type, SCHEMA_ENCODING, text.encode())
            self._schemas[ros_type] = schema_id
        metadata = {"offered_qos_profiles": offered_qos_yaml}
        digest = type_hash if type_hash is not None else installed_type_hash(ros_type)
        if digest:
            metadata["topic_type_hash"] = digest
        channel_id = self._writer.register_channel(topic, MESSAGE_ENCODING, schema_id, metadata)
        self._channels[topic] = channel_id
        return channel_id

    def write(self, topic: str, cdr: bytes, log_time_ns: int, publish_time_ns: int) -> None:
        """Append one CDR-serialised message of ``topic`` (added with :meth:`add_channel`).

        Times are nanoseconds since the epoch of their clock, >= 0.
        """
        if self._closed:
            raise LogError(f"{self.path}: write after close")
        try:
            self._writer.add_message(self._channels[topic], log_time_ns, cdr, publish_time_ns)
        except OSError as exc:
            raise self._failed(exc) from None
        self.message_count += 1
        if self._file.writes != self._writes_packed:  # a chunk was finished: pack its index
            self._writes_packed = self._file.writes
            self._packed = pack_new_chunk_indexes(self._writer, self._packed)

    def _failed(self, exc: OSError) -> LogError:
        """The error for a write the OS refused (a full disk); the log takes no more.

        What was written before stays readable, up to its last complete chunk: the chunk
        in progress is lost, and the file has no summary (a reader scans it).
        """
        self.failure = f"{self.path}: cannot write the log: {exc.strerror or exc}"
        self._closed = True
        self._file.close()
        return LogError(self.failure)

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Store a metadata record ``name`` with string keys and values."""
        self._check_open()
        bad = [k for k, v in data.items() if not isinstance(k, str) or not isinstance(v, str)]
        if bad:
            raise TypeError(f"metadata {name!r}: keys and values must be str; bad key(s) "
                            f"{bad}")
        try:
            self._writer.add_metadata(name, dict(data))
        except OSError as exc:
            raise self._failed(exc) from None

    def close(self) -> None:
        """Finish the last chunk, write the summary and footer, close the file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()
        except OSError as exc:
            raise self._failed(exc) from None
        finally:
            self._file.close()

    def _check_open(self) -> None:
        if self._closed:
            raise LogError(f"{self.path}: the log is closed")

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
