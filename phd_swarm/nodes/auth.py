"""A run's key: who may speak as a robot or as the world (HMAC over the CDR, issue 40).

Anyone on the run's ROS domain can publish on ``/robot_3/inbox`` claiming to be robot 0, or
on ``/robot_3/measurements`` as the world. DDS Security (SROS2) would stop that at the
transport, but the Fast DDS of the Jazzy wheels is built without its security plugins, and
rclpy's message info carries no publisher GID to bind a peer to (docs/decisions.md, "No
impersonation"). So each run has a key, and the messages that steer a robot carry an
HMAC-SHA256 of their bytes under it, cut to :data:`MAC_SIZE` bytes: the inbox envelopes
robots send each other and the measurement sets the world sends each robot. A message
without the right MAC is rejected (:class:`phd_swarm.nodes.convert.Unauthenticated`) and
counted (``unauthenticated``).

The key: :data:`KEY_BYTES` random bytes (``secrets``; not a numpy Generator, as no result
depends on it), hex in a file only the run's user can read (``run.key`` in the run's folder,
mode 0600), named to every node by the shared parameter ``auth_key_file``. ``''``: no key,
nothing signed or checked (in-process tests, a node started by hand).

The MAC is the message's last field, ``uint8[] mac``. It signs the CDR before it: every
byte of the message up to the MAC's length word, padding included (:func:`seal`); a
receiver checks the same bytes (:func:`is_sealed`). Only the exact bytes a sender wrote
verify, so the senders write their CDR by hand (:func:`phd_swarm.nodes.inbox.pack_cdr`,
:func:`phd_swarm.nodes.convert.encode_scan`).
"""

from __future__ import annotations

import hmac
import os
import secrets
import stat
import struct
from pathlib import Path

#: Bytes of a run's key, and of a MAC.
KEY_BYTES = 32
MAC_SIZE = 16

_EMPTY = struct.pack("<I", 0)
_LENGTH = struct.pack("<I", MAC_SIZE)


def write_key(path: Path) -> Path:
    """Write a new random key to ``path`` (hex, mode 0600, replacing any); returns ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists():
        path.unlink()
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(secrets.token_hex(KEY_BYTES) + "\n")
    return path


def read_key(path: str | Path) -> bytes | None:
    """The key in the file ``path``, or None for ``''`` (no key).

    Raises
    ------
    ValueError
        Naming the file: unreadable, readable by others than its owner, or not
        :data:`KEY_BYTES` bytes in hex.
    """
    if not path:
        return None
    path = Path(path)
    try:
        mode = path.stat().st_mode
        text = path.read_text().strip()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the run's key: {exc.strerror}") from None
    if mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise ValueError(f"{path}: the run's key is readable by others (mode "
                         f"{stat.S_IMODE(mode):o}); it must be 600")
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) != KEY_BYTES:
        raise ValueError(f"{path}: not a key ({KEY_BYTES} bytes in hex)")
    return key


def node_key(node) -> bytes | None:
    """The key a node's ``auth_key_file`` parameter names (None for ``''``).

    Raises :class:`phd_swarm.nodes.ros_params.ParameterError` naming the node and the file.
    """
    from phd_swarm.nodes.ros_params import ParameterError

    try:
        return read_key(node.params["auth_key_file"])
    except ValueError as exc:
        raise ParameterError(f"node {node.get_fully_qualified_name()}: parameter "
                             f"auth_key_file: {exc}") from None


def _mac(key: bytes, signed: bytes) -> bytes:
    # The one-shot C path; SHA-256 beat keyed BLAKE2b above 10 kB here (SHA extensions).
    return hmac.digest(key, signed, "sha256")[:MAC_SIZE]


def seal(key: bytes | None, body: bytes) -> bytes:
    """``body`` (a message's CDR up to its last field, ``mac``) completed with its MAC.

    Pads ``body`` to the MAC's 4-byte alignment (counted after the 4-byte encapsulation
    header), then writes the ``mac`` sequence: its length and the MAC of everything before
    it, or an empty sequence when ``key`` is None.
    """
    signed = body + b"\0" * (-(len(body) - 4) % 4)
    if key is None:
        return signed + _EMPTY
    return signed + _LENGTH + _mac(key, signed)


def is_sealed(key: bytes, data: bytes) -> bool:
    """Whether the message CDR ``data`` ends with the MAC of its bytes under ``key``."""
    n = len(data) - 4 - MAC_SIZE
    return (n >= 4 and data[n:n + 4] == _LENGTH
            and hmac.compare_digest(_mac(key, data[:n]), data[n + 4:]))
