"""The MCAP writer's chunk indexes, packed while they wait for the summary.

An MCAP log's summary holds one chunk index per chunk, and each chunk index the offset of
every channel's message index in that chunk. The ``mcap`` library's writer keeps them as
Python objects (a dataclass with a dict of the offsets) until it writes the summary at
close: ~90 bytes a channel and chunk, ~20 MB per sim-hour for the recorder of a 20-robot
run (the soak, docs/benchmarks.md), the one thing in it that still grew with the run.
:func:`pack_new_chunk_indexes` replaces each finished chunk's index by
:class:`PackedChunkIndex`: the record exactly as the writer would serialise it,
zlib-compressed (~3 bytes a channel), which writes those bytes into the summary at close.
The log is byte for byte the same. The message indexes themselves stay in the log:
readers such as ``rosbags`` need them.

The writer's list of chunk indexes is private to ``mcap`` (pinned in requirements.lock);
if a version moves it, nothing is packed and the log is the same (the test that measures
the packing fails instead).
"""

from __future__ import annotations

import zlib

from mcap.data_stream import RecordBuilder
from mcap.records import ChunkIndex


class PackedChunkIndex:
    """A chunk index record, serialised and compressed; :meth:`write` puts it back."""

    __slots__ = ("_record",)

    def __init__(self, index: ChunkIndex) -> None:
        builder = RecordBuilder()
        index.write(builder)
        self._record = zlib.compress(builder.end(), 1)

    def write(self, stream: RecordBuilder) -> None:
        """Append the record to ``stream`` (as ``ChunkIndex.write`` would)."""
        stream.write(zlib.decompress(self._record))

    def nbytes(self) -> int:
        """Bytes held."""
        return len(self._record)


def pack_new_chunk_indexes(writer: object, packed: int) -> int:
    """Pack the chunk indexes of ``writer`` (an ``mcap.writer.Writer``) after the first ``packed``.

    Returns how many are packed now (pass it back next time); 0 if the writer keeps its
    chunk indexes elsewhere than this ``mcap`` version does.
    """
    indexes = getattr(writer, "_Writer__chunk_indices", None)
    if indexes is None:
        return 0
    for i in range(packed, len(indexes)):
        if isinstance(indexes[i], ChunkIndex):
            indexes[i] = PackedChunkIndex(indexes[i])
    return len(indexes)
