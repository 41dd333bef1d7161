"""A numpy codec for the CDR of ROS 2 messages, without building ROS message objects.

:func:`encode` writes, and :func:`decode` reads, the CDR that
``rclpy.serialization.serialize_message`` / ``deserialize_message`` use with rmw_fastrtps
(Fast CDR) on Jazzy: plain little-endian CDR (XCDR1). A 4-byte encapsulation header
``00 01 00 00``; then the fields in order, each primitive aligned to its own size (8 for
float64, int64 and uint64) counted from the first byte after the header; a sequence is its
uint32 length, then its elements (aligned only when there is at least one); a string its
uint32 length counting the terminating NUL, its UTF-8 bytes and the NUL; a bool one byte;
a fixed-size array its elements without a length; a nested message its fields inline.
:func:`encode` writes padding as zeros; Fast CDR leaves whatever its buffer held there, so
compare messages, not bytes.

The codec for a message type is built once from its rosidl introspection (``SLOT_TYPES``)
and cached. The work per message is per field, never per element: consecutive primitive
fields are one ``struct`` call, a sequence of points one ``tobytes`` / ``frombuffer``.

Values (what :func:`encode` takes and :func:`decode` returns):

- a message: a dict, field name -> value, in the type's field order;
- a primitive scalar: a Python ``int``, ``float`` or ``bool``; a string: ``str``;
- a sequence or array of primitives: a 1-D numpy array of the matching dtype
  (``uint32`` -> ``np.uint32``, ``float64`` -> ``np.float64``, ``bool`` -> ``np.bool_``...);
  :func:`encode` also takes a tuple or list. :func:`decode` returns read-only views into
  the bytes it was given (``np.frombuffer``; bool arrays are copies): copy before writing
  into one;
- a sequence or array of strings: ``list[str]``;
- a message whose fields are all float64 (``geometry_msgs/Point``, ``Vector3``,
  ``Quaternion``): a numpy float64 array of shape (k,), k its field count, in field order;
  a sequence or array of them: an (N, k) array (also a read-only view). For k = 3 (a point)
  :func:`encode` also takes (2,) and (N, 2), with z = 0;
- any other nested message (``std_msgs/Header``, ``builtin_interfaces/Time``): a dict; a
  sequence or array of them (``MarkerArray.markers``): a list of dicts, encoded and decoded
  one element at a time. ``char``, ``byte``, ``wstring`` and ``long double`` fields are not
  supported (:class:`NotImplementedError` when the codec is built).

A field missing from a dict given to :func:`encode` takes the type's default (that of
``Type()``: 0, "", empty, or the default the ``.msg`` file sets). Integers out of their
type's range, floats for integers, and strings holding a NUL are refused.

Decoding bytes from the network never crashes on them: a wrong encapsulation header,
truncated data, a sequence or string longer than what is left, a string without its NUL,
with a NUL inside, or not UTF-8 raise :class:`CdrError` naming the type and the field
(rclpy is more lenient with strings). Bytes after the last field are ignored, as by Fast
CDR (``serialize_message`` itself returns a few: its length is Fast CDR's size estimate).
Whether the numbers decoded are finite or sensible is the caller's business.
"""

from __future__ import annotations

import functools
import importlib
import struct
from collections.abc import Mapping
from typing import Any

import numpy as np
from rclpy.serialization import serialize_message
from rosidl_parser.definition import (
    AbstractSequence,
    AbstractString,
    Array,
    BasicType,
    BoundedSequence,
    BoundedString,
    NamespacedType,
)

#: Encapsulation header of plain little-endian CDR, and the bytes of it that are checked
#: (the last two are options).
ENCAPSULATION = b"\x00\x01\x00\x00"
_KIND = ENCAPSULATION[:2]

#: rosidl basic type -> struct code (standard sizes); the numpy dtype and the alignment
#: (the size) follow from it.
_CODES = {
    "boolean": "?", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H", "int32": "i",
    "uint32": "I", "int64": "q", "uint64": "Q", "float": "f", "double": "d", "short": "h",
    "unsigned short": "H", "long": "i", "unsigned long": "I", "long long": "q",
    "unsigned long long": "Q",
}

_U32 = struct.Struct("<I")

#: Padding: ``out += _ZEROS[(4 - len(out)) % align]`` zero-fills ``out`` up to a multiple of
#: ``align`` counted from the end of the encapsulation header.
_ZEROS = tuple(bytes(n) for n in range(8))


class CdrError(ValueError):
    """Bytes that are not the CDR of the type, or a value that cannot be encoded as it."""


class _Fail(Exception):
    """A problem inside a field; the enclosing messages add their field names."""

    def __init__(self, problem: str, name: str | None = None) -> None:
        super().__init__(problem)
        self.problem = problem
        self.path: list[str] = [] if name is None else [name]


def _aligned(pos: int, align: int) -> int:
    return pos + (4 - pos) % align


def _need(buf: bytes, pos: int, size: int, what: str) -> None:
    if pos + size > len(buf):
        raise _Fail(f"{what} needs {size} bytes at offset {pos - 4}, "
                    f"{max(len(buf) - pos, 0)} left")


def _length(buf: bytes, pos: int, itemsize: int, bound: int | None) -> tuple[int, int]:
    """A sequence's element count at ``pos`` (aligned to 4) and where its elements start.

    Refuses counts whose elements (at least ``itemsize`` bytes each) cannot fit in what is
    left, so that a corrupt count never allocates or loops beyond the buffer.
    """
    pos += (4 - pos) % 4
    if pos + 4 > len(buf):
        _need(buf, pos, 4, "sequence length")
    n = _U32.unpack_from(buf, pos)[0]
    pos += 4
    if bound is not None and n > bound:
        raise _Fail(f"{n} elements, more than the bound {bound}")
    if n * itemsize > len(buf) - pos:
        raise _Fail(f"{n} elements of {itemsize} bytes, {len(buf) - pos} bytes left")
    return n, pos


def _put_length(out: bytearray, n: int, size: int | None, bound: int | None) -> None:
    """A sequence's count (none for a fixed-size array, which must hold ``size``)."""
    if size is not None:
        if n != size:
            raise _Fail(f"{n} elements for an array of {size}")
        return
    if bound is not None and n > bound:
        raise _Fail(f"{n} elements, more than the bound {bound}")
    out += _ZEROS[(4 - len(out)) % 4]
    out += _U32.pack(n)


def _array(value: Any, dtype: np.dtype, bounds: tuple[int, int] | None) -> np.ndarray:
    """``value`` as an array of ``dtype``.

    Integers must lie within ``bounds`` (given for integer dtypes); floats, bools or others
    are refused for integer fields rather than truncated.
    """
    a = np.asarray(value)
    if a.dtype == dtype:
        return a
    if a.size == 0:
        return a.astype(dtype)
    if bounds is not None:
        if a.dtype.kind not in "iub":
            raise _Fail(f"{a.dtype} values for an integer field")
        if a.dtype.kind == "i" and bounds[0] == 0 and a.dtype.itemsize > dtype.itemsize:
            # One pass: negative values, read as unsigned, are beyond any narrower range.
            if a.view(f"u{a.dtype.itemsize}").max() > bounds[1]:
                raise _Fail(f"values outside {dtype.name}")
        elif a.dtype.kind != "b" and (a.min() < bounds[0] or a.max() > bounds[1]):
            raise _Fail(f"values outside {dtype.name}")
    elif dtype.kind == "f" and a.dtype.kind not in "iuf":
        raise _Fail(f"{a.dtype} values for a floating-point field")
    return a.astype(dtype)


# -------------------------------------------------------------------------- field codecs
# Each has encode(out, value), appending to ``out``, and decode(buf, pos) -> (value, pos).
def _encode_str(out: bytearray, value: str, bound: int | None) -> None:
    if not isinstance(value, str):
        raise _Fail(f"{type(value).__name__} for a string")
    if bound is not None and len(value) > bound:
        raise _Fail(f"{len(value)} characters, more than the bound {bound}")
    raw = value.encode("utf-8")
    if b"\x00" in raw:
        raise _Fail("a NUL character inside a string")
    out += _ZEROS[(4 - len(out)) % 4]
    out += _U32.pack(len(raw) + 1)
    out += raw
    out += b"\x00"


def _decode_str(buf: bytes, pos: int, bound: int | None) -> tuple[str, int]:
    pos = _aligned(pos, 4)
    _need(buf, pos, 4, "string length")
    n = _U32.unpack_from(buf, pos)[0]
    pos += 4
    if n == 0:  # Fast CDR reads a zero length as the empty string
        return "", pos
    _need(buf, pos, n, "string")
    raw = buf[pos:pos + n - 1]
    if buf[pos + n - 1] != 0:
        raise _Fail("string without its terminating NUL")
    if b"\x00" in raw:
        raise _Fail("a NUL inside a string")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _Fail(f"string is not UTF-8 ({exc.reason} at byte {exc.start})") from None
    if bound is not None and len(text) > bound:
        raise _Fail(f"{len(text)} characters, more than the bound {bound}")
    return text, pos + n


class _String:
    """One string, bounded or not."""

    def __init__(self, bound: int | None) -> None:
        self.bound = bound

    def encode(self, out: bytearray, value: Any) -> None:
        _encode_str(out, value, self.bound)

    def decode(self, buf: bytes, pos: int) -> tuple[str, int]:
        return _decode_str(buf, pos, self.bound)


class _Strings:
    """A sequence or fixed-size array of strings: list[str] (one loop over the strings)."""

    def __init__(self, size: int | None, bound: int | None, string_bound: int | None) -> None:
        self.size, self.bound, self.string_bound = size, bound, string_bound

    def encode(self, out: bytearray, value: Any) -> None:
        value = list(value)
        _put_length(out, len(value), self.size, self.bound)
        for s in value:
            _encode_str(out, s, self.string_bound)

    def decode(self, buf: bytes, pos: int) -> tuple[list[str], int]:
        if self.size is None:
            n, pos = _length(buf, pos, 4, self.bound)
        else:
            n = self.size
        out = []
        for _ in range(n):
            s, pos = _decode_str(buf, pos, self.string_bound)
            out.append(s)
        return out, pos


class _Numbers:
    """A sequence or fixed-size array of primitives: a 1-D array.

    A tuple or list is packed by ``struct`` (which checks each integer's range in C); an
    array by numpy, its range checked as a whole.
    """

    def __init__(self, code: str, size: int | None, bound: int | None) -> None:
        self.code = code
        self.dtype = np.dtype("<" + code)
        self.size, self.bound = size, bound
        self.bool = self.dtype.kind == "b"
        info = np.iinfo(self.dtype) if self.dtype.kind in "iu" else None
        self.bounds = None if info is None else (int(info.min), int(info.max))
        #: What an empty one decodes to (read-only, so one serves all).
        self.empty = np.frombuffer(b"", self.dtype)

    def encode(self, out: bytearray, value: Any) -> None:
        if isinstance(value, tuple | list):
            n = len(value)
            _put_length(out, n, self.size, self.bound)
            if n:
                out += _ZEROS[(4 - len(out)) % self.dtype.itemsize]
                out += struct.pack(f"<{n}{self.code}", *value)
            return
        a = _array(value, self.dtype, self.bounds)
        if a.ndim != 1:
            raise _Fail(f"shape {a.shape}, not a 1-D array")
        _put_length(out, len(a), self.size, self.bound)
        if len(a):
            out += _ZEROS[(4 - len(out)) % self.dtype.itemsize]
            out += a.tobytes()

    def decode(self, buf: bytes, pos: int) -> tuple[np.ndarray, int]:
        size = self.dtype.itemsize
        if self.size is None:
            n, pos = _length(buf, pos, size, self.bound)
            if not n:
                return self.empty, pos
        else:
            n = self.size
        pos = _aligned(pos, size)
        _need(buf, pos, n * size, f"{n} values")
        if self.bool:
            a = np.frombuffer(buf, np.uint8, n, pos) != 0
        else:
            a = np.frombuffer(buf, self.dtype, n, pos)
        return a, pos + n * size


class _Vectors:
    """A message of k float64 fields (a point), or a sequence or array of them.

    ``size`` is 0 for one message (shape (k,)), None for a sequence, N for an array
    (shape (N, k)).
    """

    def __init__(self, k: int, size: int | None, bound: int | None) -> None:
        self.k, self.size, self.bound = k, size, bound
        self.empty = np.frombuffer(b"", np.float64).reshape(0, k)

    def _rows(self, value: Any) -> np.ndarray:
        a = np.asarray(value, dtype=np.float64)
        if self.size == 0:
            if a.shape == (self.k,):
                return a
            if self.k == 3 and a.shape == (2,):
                return np.array((a[0], a[1], 0.0))
            raise _Fail(f"shape {a.shape} for one message of {self.k} float64 fields")
        if a.ndim == 2 and a.shape[1] == self.k:
            return a
        if a.size == 0:
            return a.reshape(0, self.k)
        if self.k == 3 and a.ndim == 2 and a.shape[1] == 2:
            rows = np.zeros((len(a), 3))
            rows[:, :2] = a
            return rows
        raise _Fail(f"shape {a.shape} for messages of {self.k} float64 fields")

    def encode(self, out: bytearray, value: Any) -> None:
        a = self._rows(value)
        if self.size != 0:
            _put_length(out, len(a), self.size, self.bound)
        if a.size:
            out += _ZEROS[(4 - len(out)) % 8]
            out += a.tobytes()

    def decode(self, buf: bytes, pos: int) -> tuple[np.ndarray, int]:
        row = 8 * self.k
        if self.size is None:
            n, pos = _length(buf, pos, row, self.bound)
            if not n:
                return self.empty, pos
        else:
            n = max(self.size, 1)
        pos = _aligned(pos, 8)
        _need(buf, pos, n * row, f"{n} x {self.k} float64")
        a = np.frombuffer(buf, np.float64, n * self.k, pos)
        return (a if self.size == 0 else a.reshape(n, self.k)), pos + n * row


class _Messages:
    """A sequence or fixed-size array of other messages: a list of dicts (one loop over them)."""

    def __init__(self, codec: _Message, size: int | None, bound: int | None) -> None:
        self.codec, self.size, self.bound = codec, size, bound

    def encode(self, out: bytearray, value: Any) -> None:
        value = list(value)
        _put_length(out, len(value), self.size, self.bound)
        for i, item in enumerate(value):
            try:
                self.codec.encode(out, item)
            except _Fail as exc:
                exc.path.insert(0, str(i))
                raise

    def decode(self, buf: bytes, pos: int) -> tuple[list[dict[str, Any]], int]:
        if self.size is None:
            # Every ROS message has a field, so each element takes at least a byte.
            n, pos = _length(buf, pos, 1, self.bound)
        else:
            n = self.size
        out = []
        for i in range(n):
            try:
                item, pos = self.codec.decode(buf, pos)
            except _Fail as exc:
                exc.path.insert(0, str(i))
                raise
            out.append(item)
        return out, pos


# ------------------------------------------------------------------------------ messages
# A message's fields are read and written by ops: one field with its codec, or a run of
# consecutive primitive fields packed by one struct.
class _Field:
    """One field of a message, by its codec."""

    def __init__(self, name: str, codec: Any) -> None:
        self.name, self.codec = name, codec

    def encode(self, out: bytearray, value: Mapping[str, Any], defaults: dict) -> None:
        name = self.name
        try:
            self.codec.encode(out, value[name] if name in value else defaults[name])
        except _Fail as exc:
            exc.path.insert(0, name)
            raise
        except (struct.error, TypeError, ValueError, OverflowError) as exc:
            raise _Fail(str(exc), name) from None

    def decode(self, buf: bytes, pos: int, out: dict) -> int:
        try:
            out[self.name], pos = self.codec.decode(buf, pos)
        except _Fail as exc:
            exc.path.insert(0, self.name)
            raise
        except (struct.error, ValueError, IndexError, OverflowError, MemoryError) as exc:
            # Not expected (every read is checked first); never let one escape as such.
            raise _Fail(f"{type(exc).__name__}: {exc}", self.name) from None
        return pos


class _Run:
    """Consecutive primitive fields, packed by one struct per alignment phase.

    Where the run starts modulo its largest alignment decides the padding between its
    fields, so there is one struct (padding included) for each starting phase.
    """

    def __init__(self, names: list[str], codes: list[str]) -> None:
        self.names, self.codes = tuple(names), codes
        self.align = max(struct.calcsize("<" + c) for c in codes)
        self.structs = []
        for phase in range(self.align):
            fmt, offset = "<", phase
            for c in codes:
                size = struct.calcsize("<" + c)
                pad = -offset % size
                fmt += "x" * pad + c
                offset += pad + size
            self.structs.append(struct.Struct(fmt))

    def encode(self, out: bytearray, value: Mapping[str, Any], defaults: dict) -> None:
        values = [value[n] if n in value else defaults[n] for n in self.names]
        try:
            out += self.structs[(len(out) - 4) % self.align].pack(*values)
        except (struct.error, TypeError, OverflowError) as exc:
            for name, code, v in zip(self.names, self.codes, values, strict=True):
                try:
                    struct.pack("<" + code, v)
                except (struct.error, TypeError, OverflowError) as one:
                    raise _Fail(str(one), name) from None
            raise _Fail(str(exc), self.names[0]) from None

    def decode(self, buf: bytes, pos: int, out: dict) -> int:
        st = self.structs[(pos - 4) % self.align]
        if pos + st.size > len(buf):
            raise _Fail(f"value needs {st.size} bytes at offset {pos - 4}, "
                        f"{max(len(buf) - pos, 0)} left", self.names[0])
        out.update(zip(self.names, st.unpack_from(buf, pos), strict=True))
        return pos + st.size


class _Message:
    """A message: its fields in order (ops), with the type's defaults."""

    def __init__(self, typ: type) -> None:
        self.type = typ
        self.name = type_name(typ)
        names = list(typ.get_fields_and_field_types())
        self.ops: list[_Field | _Run] = []
        run: list[tuple[str, str]] = []
        for name, t in zip(names, typ.SLOT_TYPES, strict=True):
            codec = _field_codec(self.name, name, t)
            if isinstance(codec, str):  # a primitive's struct code
                run.append((name, codec))
                continue
            self._close(run)
            self.ops.append(_Field(name, codec))
        self._close(run)
        self.names = frozenset(names)
        self.defaults: dict[str, Any] = {}
        self.defaults = self.decode(serialize_message(typ()), len(ENCAPSULATION))[0]

    def _close(self, run: list[tuple[str, str]]) -> None:
        if run:
            self.ops.append(_Run([n for n, _ in run], [c for _, c in run]))
            run.clear()

    def encode(self, out: bytearray, value: Mapping[str, Any]) -> None:
        if type(value) is not dict and not isinstance(value, Mapping):
            raise _Fail(f"{type(value).__name__} for a {self.name} (a dict)")
        if not self.names.issuperset(value):
            raise _Fail(f"no field {sorted(set(value) - self.names)[0]!r} in {self.name}")
        for op in self.ops:
            op.encode(out, value, self.defaults)

    def decode(self, buf: bytes, pos: int) -> tuple[dict[str, Any], int]:
        out: dict[str, Any] = {}
        for op in self.ops:
            pos = op.decode(buf, pos, out)
        return out, pos


def _message_class(t: NamespacedType) -> type:
    return getattr(importlib.import_module(".".join(t.namespaces)), t.name)


def _float64_fields(typ: type) -> int:
    """The field count of a message whose fields are all float64; else 0."""
    slots = typ.SLOT_TYPES
    if slots and all(isinstance(t, BasicType) and t.typename == "double" for t in slots):
        return len(slots)
    return 0


def _field_codec(owner: str, name: str, t: Any):
    """The codec of field ``name`` of type ``t`` (rosidl_parser.definition).

    A primitive's is its struct code (it joins a :class:`_Run`).
    """
    def unsupported(what: str) -> NotImplementedError:
        return NotImplementedError(f"{owner}.{name}: {what} is not supported by the codec")

    if isinstance(t, BasicType):
        if t.typename not in _CODES:
            raise unsupported(t.typename)
        return _CODES[t.typename]
    if isinstance(t, AbstractString):
        return _String(t.maximum_size if isinstance(t, BoundedString) else None)
    if isinstance(t, NamespacedType):
        typ = _message_class(t)
        k = _float64_fields(typ)
        return _Vectors(k, 0, None) if k else _codec(typ)
    if not isinstance(t, Array | AbstractSequence):
        raise unsupported(type(t).__name__)
    size = t.size if isinstance(t, Array) else None
    bound = t.maximum_size if isinstance(t, BoundedSequence) else None
    v = t.value_type
    if isinstance(v, BasicType) and v.typename in _CODES:
        return _Numbers(_CODES[v.typename], size, bound)
    if isinstance(v, AbstractString):
        return _Strings(size, bound, v.maximum_size if isinstance(v, BoundedString) else None)
    if isinstance(v, NamespacedType):
        typ = _message_class(v)
        k = _float64_fields(typ)
        return _Vectors(k, size, bound) if k else _Messages(_codec(typ), size, bound)
    what = getattr(v, "typename", type(v).__name__)
    raise unsupported(f"a sequence of {what}")


@functools.cache
def _codec(typ: type) -> _Message:
    return _Message(typ)


# -------------------------------------------------------------------------- public verbs
def type_name(typ: type) -> str:
    """``package/msg/Name`` of a ROS message class."""
    return f"{typ.__module__.split('.')[0]}/msg/{typ.__name__}"


@functools.cache
def string_cdr(text: str) -> bytes:
    """``text`` as a CDR string (length with the NUL, bytes, NUL), padded to 4 bytes."""
    raw = text.encode()
    out = struct.pack("<I", len(raw) + 1) + raw + b"\x00"
    return out + bytes(-len(out) % 4)


def encode(typ: type, fields: Mapping[str, Any]) -> bytes:
    """The CDR of a ``typ`` message with ``fields`` (see the module docstring for values).

    Raises
    ------
    CdrError
        A field the type does not have, or a value of the wrong kind, shape or range.
    NotImplementedError
        ``typ`` has a field the codec does not support.
    """
    codec = _codec(typ)
    out = bytearray(ENCAPSULATION)
    try:
        codec.encode(out, fields)
    except _Fail as exc:
        raise CdrError(f"{codec.name}: cannot encode "
                       f"{'field ' + '.'.join(exc.path) + ': ' if exc.path else ''}"
                       f"{exc.problem}") from None
    return bytes(out)


def decode(typ: type, data: bytes) -> dict[str, Any]:
    """The fields of the ``typ`` message whose CDR is ``data`` (see the module docstring).

    Arrays in the result are read-only views into ``data``.

    Raises
    ------
    CdrError
        ``data`` is not the CDR of a ``typ`` message; the text names the type and field.
    NotImplementedError
        ``typ`` has a field the codec does not support.
    """
    codec = _codec(typ)
    if not isinstance(data, bytes):
        data = bytes(data)
    if data[:2] != _KIND or len(data) < len(ENCAPSULATION):
        raise CdrError(f"{codec.name}: encapsulation header {data[:4].hex(' ') or 'missing'}"
                       f" is not little-endian plain CDR ({ENCAPSULATION.hex(' ')})")
    try:
        return codec.decode(data, len(ENCAPSULATION))[0]
    except _Fail as exc:
        raise CdrError(f"{codec.name}: field {'.'.join(exc.path)}: {exc.problem}") from None
