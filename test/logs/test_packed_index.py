"""The writer's chunk indexes are packed as chunks finish, and the log is the same bytes."""

import numpy as np

import phd_swarm.logs.log_writer as log_writer
from phd_swarm.logs.mcap_log import LogReader
from phd_swarm.logs.packed_index import PackedChunkIndex

TOPICS = [f"/robot_{r}/{kind}" for r in range(10) for kind in ("status", "density", "pose")]


def _write(path, chunk_size=4096):
    rng = np.random.default_rng(3)
    writer = log_writer.LogWriter(path, chunk_size=chunk_size)
    for topic in TOPICS:
        writer.add_channel(topic, "std_msgs/msg/String")
    for k in range(200):
        for topic in TOPICS:
            writer.write(topic, rng.bytes(int(rng.integers(8, 200))), k, k)
    indexes = list(writer._writer._Writer__chunk_indices)
    writer.close()
    return indexes


def test_chunk_indexes_are_packed_and_the_log_is_byte_for_byte_the_same(tmp_path, monkeypatch):
    indexes = _write(tmp_path / "packed.mcap")
    # Every chunk's index but the one still open when the loop ended is packed, small.
    assert len(indexes) > 100
    packed = [i for i in indexes if isinstance(i, PackedChunkIndex)]
    assert len(packed) >= len(indexes) - 1
    assert max(i.nbytes() for i in packed) < 6 * len(TOPICS) + 80

    monkeypatch.setattr(log_writer, "pack_new_chunk_indexes", lambda writer, packed: 0)
    plain = _write(tmp_path / "plain.mcap")
    assert not any(isinstance(i, PackedChunkIndex) for i in plain)
    assert (tmp_path / "packed.mcap").read_bytes() == (tmp_path / "plain.mcap").read_bytes()

    with LogReader(tmp_path / "packed.mcap") as reader:
        assert sum(1 for _ in reader.messages(decode=False)) == 200 * len(TOPICS)
