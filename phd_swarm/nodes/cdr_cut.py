"""Cutting our envelopes' little-endian CDR by hand: strings, and named pieces of a body.

An ``InboxMessage`` (``inbox.py``) and a ``MessageBundle`` (``bundle.py``) end the same way:
``string[] names``, ``uint32[] offsets``, ``uint8[] data``, the data being the pieces'
CDR one after the other. Every robot cuts ~50 envelopes a step and the observers a bundle
per robot and step, so they are read here with ``struct`` rather than through the general
codec (:mod:`phd_swarm.nodes.cdr`, 4-6x slower), for plain little-endian CDR only: the
callers send other bytes to the codec. Offsets are counted from the start of ``data``
(the encapsulation header included), alignment from the byte after the header.

Malformed bytes raise ``struct.error``, ``UnicodeDecodeError``, ``IndexError`` or
``ValueError``; the callers turn them into
:class:`~phd_swarm.nodes.convert.InvalidMessage`. Whether the offsets cut the body into one
piece per name is the callers' check.
"""

from __future__ import annotations

import struct

_U32 = struct.Struct("<I")


def aligned(at: int) -> int:
    """``at`` moved up to a multiple of 4 counted from the byte after the header."""
    return at + (-(at - 4) % 4)


def string_at(data: bytes, at: int) -> tuple[str, int]:
    """The CDR string at ``at`` (already aligned) and the offset after it.

    As the codec reads one: a zero length is the empty string; refused are a string
    running past the end, without its terminating NUL, with a NUL inside, or not UTF-8.
    """
    (n,) = _U32.unpack_from(data, at)
    end = at + 4 + n
    if n == 0:
        return "", end
    if end > len(data) or data[end - 1] != 0:
        raise ValueError(f"bad string of {n} bytes at byte {at}")
    raw = data[at + 4:end - 1]
    if b"\x00" in raw:
        raise ValueError(f"a NUL inside the string at byte {at}")
    return raw.decode(), end


def names_offsets_body(data: bytes, at: int) -> tuple[list[str], list[int], bytes, int]:
    """``string[]``, ``uint32[]`` and ``uint8[]`` from ``at``: names, offsets, body, end.

    Counts that cannot fit in what is left of ``data`` are refused before anything is read.
    """
    at = aligned(at)
    (n,) = _U32.unpack_from(data, at)
    at += 4
    if 5 * n > len(data) - at:
        raise ValueError(f"{n} names in {len(data)} bytes")
    names = []
    for _ in range(n):
        name, at = string_at(data, aligned(at))
        names.append(name)
    at = aligned(at)
    (m,) = _U32.unpack_from(data, at)
    if at + 4 + 4 * m > len(data):
        raise ValueError(f"{m} offsets past the end")
    offsets = list(struct.unpack_from(f"<{m}I", data, at + 4))
    at += 4 + 4 * m
    (size,) = _U32.unpack_from(data, at)
    if at + 4 + size > len(data):
        raise ValueError(f"{size} bytes of data past the end")
    return names, offsets, data[at + 4:at + 4 + size], at + 4 + size
