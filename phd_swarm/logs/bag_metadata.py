"""rosbag2's ``metadata.yaml`` for a run log, so ROS tools can open the run directory.

``ros2 bag info runs/demo`` and rosbags' ``AnyReader([Path("runs/demo")])`` open a bag
*directory* through the ``metadata.yaml`` that rosbag2 writes beside its storage files; our
recorder writes only the MCAP file. :func:`write_bag_metadata` adds that file::

    python -m phd_swarm.logs.bag_metadata runs/demo/run.mcap   # prints the path written

Format: rosbag2's ``rosbag2_bagfile_information`` of metadata version 9, the version ROS 2
Jazzy's rosbag2 (0.26.x) writes, checked against rosbag2's own sources (the YAML converters
``rosbag2_storage/include/rosbag2_storage/yaml.hpp`` and ``rosbag2_storage/src/rosbag2_storage/
qos.cpp``, and ``rosbag2_storage_mcap/src/mcap_storage.cpp``, which fills the same fields
from an MCAP file) and against rosbags 0.11 (``rosbags/rosbag2/metadata.py``, ``reader.py``
and ``writer.py``, whose version-9 writer produces the same layout). Keys, in rosbag2's
order::

    rosbag2_bagfile_information:
      version: 9
      storage_identifier: mcap
      duration: {nanoseconds: last log time - first log time}
      starting_time: {nanoseconds_since_epoch: first log time}
      message_count: N
      topics_with_message_count:
        - topic_metadata:
            name: /topic
            type: pkg/msg/Type
            serialization_format: cdr
            offered_qos_profiles:          # a YAML list of mappings since version 9
              - {history: keep_last, depth: 10, reliability: reliable, durability: volatile,
                 deadline: {sec: 0, nsec: 0}, lifespan: {sec: 0, nsec: 0},
                 liveliness: system_default, liveliness_lease_duration: {sec: 0, nsec: 0},
                 avoid_ros_namespace_conventions: false}
            type_description_hash: RIHS01_...   # '' if the channel has none
          message_count: n
      compression_format: ''              # MCAP chunk compression is storage-level: ''
      compression_mode: ''
      relative_file_paths: [run.mcap]
      files:
        - {path: run.mcap, starting_time: {...}, duration: {...}, message_count: N}
      custom_data: null
      ros_distro: jazzy

Times are the messages' log times (receive times), as rosbag2 takes them from the MCAP
statistics. The QoS list is the channel metadata ``offered_qos_profiles``
(:func:`phd_swarm.logs.qos_yaml.qos_yaml`) parsed and normalised: policies by name
(version 8's integer policies are converted), durations as ``{sec, nsec}``.

A truncated log (no summary, see :mod:`phd_swarm.logs.mcap_log`) still gets a
``metadata.yaml``, with the counts and times of its complete records (a warning is logged).
rosbag2's MCAP storage reads such a file by scanning it (``AllowFallbackScan``), but rosbags
refuses an MCAP file without a footer: its ``AnyReader`` then raises ``AnyReaderError``
("File end magic is invalid.").
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml
from mcap.reader import make_reader
from mcap.records import Channel
from mcap.stream_reader import StreamReader

from phd_swarm.logs.mcap_log import LogError, LogReader

logger = logging.getLogger(__name__)

#: rosbag2 metadata version written (ROS 2 Jazzy's rosbag2).
VERSION = 9
#: Name of the file rosbag2 reads in a bag directory.
METADATA_FILE = "metadata.yaml"
#: ROS distribution recorded in the metadata.
ROS_DISTRO = "jazzy"
STORAGE_IDENTIFIER = "mcap"
SERIALIZATION_FORMAT = "cdr"

# rmw enum values -> the names rosbag2 writes since version 9 (rmw_qos_*_policy_to_str).
_POLICY_NAMES: dict[str, dict[int, str]] = {
    "history": {0: "system_default", 1: "keep_last", 2: "keep_all", 3: "unknown"},
    "reliability": {0: "system_default", 1: "reliable", 2: "best_effort", 3: "unknown",
                    4: "best_available"},
    "durability": {0: "system_default", 1: "transient_local", 2: "volatile", 3: "unknown",
                   4: "best_available"},
    "liveliness": {0: "system_default", 1: "automatic", 2: "manual_by_node",
                   3: "manual_by_topic", 4: "unknown", 5: "best_available"},
}
_DURATIONS = ("deadline", "lifespan", "liveliness_lease_duration")


# ------------------------------------------------------------------------ QoS
def _policy(entry: Mapping[str, Any], key: str) -> str:
    value = entry.get(key, 0)
    names = _POLICY_NAMES[key]
    if isinstance(value, bool):
        raise ValueError(f"{key}: {value!r} is not a policy")
    if isinstance(value, int):
        return names.get(value, "unknown")
    name = str(value).strip().lower()
    return name if name in names.values() else "unknown"


def _time(value: Any, key: str) -> dict[str, int]:
    if value is None:
        return {"sec": 0, "nsec": 0}
    if not isinstance(value, Mapping):
        raise ValueError(f"{key}: expected a mapping with sec and nsec, got {value!r}")
    return {"sec": int(value.get("sec", 0)), "nsec": int(value.get("nsec", 0))}


def qos_profiles(text: str) -> list[dict[str, Any]]:
    """The ``offered_qos_profiles`` YAML text of an MCAP channel as rosbag2 v9 writes it.

    Parameters
    ----------
    text : str
        The channel metadata value: a YAML list of QoS mappings (:func:`phd_swarm.tools.
        qos_yaml.qos_yaml`, or rosbag2's, with policies by name or, before version 9, by
        rmw enum value); empty for none.

    Returns
    -------
    list of dict
        One mapping per profile with the keys ``history``, ``depth``, ``reliability``,
        ``durability``, ``deadline``, ``lifespan``, ``liveliness``,
        ``liveliness_lease_duration`` (``{sec, nsec}``) and
        ``avoid_ros_namespace_conventions``, in rosbag2's order; policies by name.

    Raises
    ------
    ValueError
        If the text is not YAML or not a list of mappings.
    """
    if not text.strip():
        return []
    try:
        entries = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"not YAML: {exc}") from None
    if entries is None:
        return []
    if not isinstance(entries, list) or not all(isinstance(e, Mapping) for e in entries):
        raise ValueError(f"expected a list of QoS mappings, got {type(entries).__name__}")
    out = []
    for entry in entries:
        out.append({
            "history": _policy(entry, "history"),
            "depth": int(entry.get("depth", 0)),
            "reliability": _policy(entry, "reliability"),
            "durability": _policy(entry, "durability"),
            "deadline": _time(entry.get("deadline"), "deadline"),
            "lifespan": _time(entry.get("lifespan"), "lifespan"),
            "liveliness": _policy(entry, "liveliness"),
            "liveliness_lease_duration": _time(entry.get("liveliness_lease_duration"),
                                               "liveliness_lease_duration"),
            "avoid_ros_namespace_conventions":
                bool(entry.get("avoid_ros_namespace_conventions", False)),
        })
    return out


# ------------------------------------------------------------------------ reading
def _summary_statistics(path: Path) -> tuple[dict[str, tuple[str, int]], int, int | None,
                                              int | None] | None:
    """Counts and times from a finished log's summary, without reading its chunks.

    Returns (topic -> (type, count), total, first and last log time [ns]) from the
    ``Statistics`` record, or None if the log has none.
    """
    with open(path, "rb") as stream, contextlib.suppress(Exception):
        summary = make_reader(stream).get_summary()
        if summary is None or summary.statistics is None:
            return None
        st = summary.statistics
        out: dict[str, tuple[str, int]] = {}
        for cid in sorted(summary.channels):
            channel = summary.channels[cid]
            ros_type = summary.schemas[channel.schema_id].name
            _, count = out.get(channel.topic, (ros_type, 0))
            out[channel.topic] = (ros_type, count + st.channel_message_counts.get(cid, 0))
        total = st.message_count
        return out, total, (st.message_start_time if total else None), \
            (st.message_end_time if total else None)
    return None


def _channel_metadata(path: Path, truncated: bool) -> dict[str, dict[str, str]]:
    """Topic -> metadata of its first channel, from the summary or, if none, a record scan."""
    with open(path, "rb") as stream:
        if not truncated:
            with contextlib.suppress(Exception):  # a damaged summary: scan the records
                summary = make_reader(stream).get_summary()
                if summary is not None:
                    out: dict[str, dict[str, str]] = {}
                    for cid in sorted(summary.channels):
                        channel = summary.channels[cid]
                        out.setdefault(channel.topic, dict(channel.metadata))
                    return out
            stream.seek(0)
        out = {}
        with contextlib.suppress(Exception):  # mcap's end-of-file, CRC or decompression errors
            for record in StreamReader(stream).records:
                if isinstance(record, Channel):
                    out.setdefault(record.topic, dict(record.metadata))
        return out


def bag_metadata(mcap_path: str | Path) -> dict[str, Any]:
    """rosbag2's ``rosbag2_bagfile_information`` (version 9) for one MCAP run log.

    Parameters
    ----------
    mcap_path : str or Path
        A ROS 2 MCAP log (:mod:`phd_swarm.logs.mcap_log`); a truncated one is scanned and
        described by its complete records.

    Returns
    -------
    dict
        The mapping under ``rosbag2_bagfile_information`` (see the module docstring), in
        rosbag2's key order; topics sorted by name, message counts and times from the
        messages' log times [ns].

    Raises
    ------
    LogError
        If the file is missing, is not a ROS 2 MCAP log, or a channel's
        ``offered_qos_profiles`` cannot be parsed.
    """
    path = Path(mcap_path)
    with LogReader(path) as log:
        truncated = log.truncated
        stats = None if truncated else _summary_statistics(path)
        if stats is None:  # no statistics in the summary: count the messages
            info = log.info()
            stats = ({n: (t.ros_type, t.message_count) for n, t in info.topics.items()},
                     info.message_count, info.start_ns, info.end_ns)
    by_topic, total, first, last = stats
    metadata = _channel_metadata(path, truncated)
    start = first if first is not None else 0
    duration = (last - first) if first is not None else 0
    topics = []
    for name, (ros_type, count) in sorted(by_topic.items()):
        channel = metadata.get(name, {})
        try:
            qos = qos_profiles(channel.get("offered_qos_profiles", ""))
        except ValueError as exc:
            raise LogError(f"{path}: topic {name}: bad offered_qos_profiles: {exc}") from None
        topics.append({
            "topic_metadata": {
                "name": name,
                "type": ros_type,
                "serialization_format": SERIALIZATION_FORMAT,
                "offered_qos_profiles": qos,
                "type_description_hash": channel.get("topic_type_hash", ""),
            },
            "message_count": count,
        })
    return {
        "version": VERSION,
        "storage_identifier": STORAGE_IDENTIFIER,
        "duration": {"nanoseconds": duration},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": total,
        "topics_with_message_count": topics,
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [path.name],
        "files": [{
            "path": path.name,
            "starting_time": {"nanoseconds_since_epoch": start},
            "duration": {"nanoseconds": duration},
            "message_count": total,
        }],
        "custom_data": None,
        "ros_distro": ROS_DISTRO,
    }


# ------------------------------------------------------------------------ writing
def dump_bag_metadata(information: Mapping[str, Any]) -> str:
    """The text of ``metadata.yaml`` for a :func:`bag_metadata` mapping (block style)."""
    return yaml.safe_dump({"rosbag2_bagfile_information": dict(information)},
                          sort_keys=False, default_flow_style=False, allow_unicode=True)


def write_bag_metadata(mcap_path: str | Path) -> Path:
    """Write ``metadata.yaml`` for ``mcap_path`` in its directory; returns the file's path.

    The file is written atomically (a temporary file in the same directory, then renamed
    over any existing ``metadata.yaml``), so a reader never sees half a file.

    Raises
    ------
    LogError
        As :func:`bag_metadata`.
    OSError
        If the directory is not writable.
    """
    path = Path(mcap_path)
    text = dump_bag_metadata(bag_metadata(path))
    target = path.parent / METADATA_FILE
    fd, tmp = tempfile.mkstemp(prefix=f".{METADATA_FILE}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write(text)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return target


# ------------------------------------------------------------------------ CLI
def main(argv: Sequence[str] | None = None) -> int:
    """``python -m phd_swarm.logs.bag_metadata RUN.mcap``: write and print metadata.yaml.

    Exit codes: 0 written, 1 the log cannot be read or the file cannot be written, 2 bad
    usage.
    """
    parser = argparse.ArgumentParser(
        prog="python -m phd_swarm.logs.bag_metadata",
        description="Write rosbag2's metadata.yaml (version 9, Jazzy) beside an MCAP run log "
                    "so that `ros2 bag info DIR` and rosbags' AnyReader open its directory.")
    parser.add_argument("mcap", type=Path, help="the run's MCAP log (e.g. runs/demo/run.mcap)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s: %(message)s")
    try:
        target = write_bag_metadata(args.mcap)
    except LogError as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"{parser.prog}: error: cannot write {METADATA_FILE} beside {args.mcap}: "
              f"{exc.strerror or exc}", file=sys.stderr)
        return 1
    print(target)
    return 0


if __name__ == "__main__":
    sys.exit(main())
