"""What a ROS 2 MCAP log is made of: its profile, encodings, magic, and its error.

Shared by the writer (:mod:`phd_swarm.logs.log_writer`) and the reader
(:mod:`phd_swarm.logs.mcap_log`, which re-exports every name here).
"""

from __future__ import annotations

#: MCAP profile, schema encoding and message encoding of a ROS 2 log.
PROFILE = "ros2"
SCHEMA_ENCODING = "ros2msg"
MESSAGE_ENCODING = "cdr"

#: The 8 bytes that open and close every MCAP file.
MAGIC = b"\x89MCAP0\r\n"


class LogError(Exception):
    """A log cannot be read or written; the message names the file and the problem."""
