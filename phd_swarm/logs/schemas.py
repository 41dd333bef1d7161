"""Message definitions of installed ROS 2 types, as MCAP ``ros2msg`` schemas hold them.

:func:`message_definition` gives the text of a type's ``.msg`` file followed by those of
every type it uses, each after a :data:`SEPARATOR` line and ``MSG: pkg/Type`` (the layout
rosbag2 and Foxglove read); :func:`installed_type_hash` the RIHS01 type hash of the
installed type description, as rosbag2 stores it with a channel.
"""

from __future__ import annotations

import functools
import json
import re
from pathlib import Path

#: Line between the definitions of a ``ros2msg`` schema.
SEPARATOR = "=" * 80

_PRIMITIVES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
    "int32", "uint32", "int64", "uint64", "string", "wstring",
})

_TYPE_NAME = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)/(?:msg/)?([A-Za-z][A-Za-z0-9_]*)$")


class DefinitionNotFoundError(LookupError):
    """No ``.msg`` file for a message type among the installed packages."""


def _split_type(ros_type: str) -> tuple[str, str]:
    """``pkg/msg/Type`` or ``pkg/Type`` -> ``(pkg, Type)``."""
    match = _TYPE_NAME.match(ros_type)
    if match is None:
        raise DefinitionNotFoundError(
            f"{ros_type!r} is not a message type name (expected pkg/msg/Type or pkg/Type)")
    return match.group(1), match.group(2)


@functools.cache
def _share_dir(package: str) -> Path:
    from ament_index_python.packages import (
        PackageNotFoundError,
        get_package_share_directory,
    )

    try:
        return Path(get_package_share_directory(package))
    except PackageNotFoundError:
        raise DefinitionNotFoundError(
            f"package {package!r} is not installed (not in AMENT_PREFIX_PATH)") from None


@functools.cache
def _msg_text(package: str, name: str) -> str:
    path = _share_dir(package) / "msg" / f"{name}.msg"
    try:
        return path.read_text()
    except OSError:
        raise DefinitionNotFoundError(f"no definition of {package}/msg/{name}: {path} "
                                      "cannot be read") from None


def _has_msg(package: str, name: str) -> bool:
    try:
        return (_share_dir(package) / "msg" / f"{name}.msg").is_file()
    except DefinitionNotFoundError:
        return False


def _dependencies(text: str, package: str) -> list[str]:
    """Nested types (``pkg/Type``) of the fields in ``.msg`` text, sorted, each once.

    The type is the first word of a non-comment line, with any array suffix (``[]``,
    ``[<=N]``, ``[N]``) and string bound (``<=N``) removed; a name without a package is in
    ``package``. A bare ``Header`` is ``std_msgs/Header`` (the ROS 1 shorthand, which
    ROS 2's rosidl does not know) unless ``package`` has a ``Header`` of its own. Constants
    have primitive types and so add nothing.
    """
    deps = set()
    for line in text.splitlines():
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        base = words[0].split("[", 1)[0].split("<=", 1)[0]
        if base in _PRIMITIVES:
            continue
        if base == "Header" and not _has_msg(package, "Header"):
            deps.add("std_msgs/Header")
        elif "/" in base:
            pkg, name = _split_type(base)
            deps.add(f"{pkg}/{name}")
        else:
            deps.add(f"{package}/{base}")
    return sorted(deps)


@functools.cache
def message_definition(ros_type: str) -> str:
    """The ``ros2msg`` schema text of ``ros_type`` (``pkg/msg/Type``) as rosbag2 writes it.

    The type's ``.msg`` text, then for each nested type, depth first in sorted order and
    each once: a newline, a line of 80 ``=``, a line ``MSG: pkg/Type`` and that type's
    ``.msg`` text. Files are found with ``ament_index_python`` in
    ``<share>/<pkg>/msg/<Type>.msg``.

    Raises
    ------
    DefinitionNotFoundError
        If the package or one of the ``.msg`` files is not installed.
    """
    package, name = _split_type(ros_type)
    seen: set[str] = set()

    def append(pkg: str, typ: str, depth: int) -> str:
        if depth <= 0:
            raise DefinitionNotFoundError(f"{ros_type}: nesting deeper than 50 types")
        text = _msg_text(pkg, typ)
        parts = [text]
        for dep in _dependencies(text, pkg):
            if dep in seen:
                continue
            seen.add(dep)
            dep_pkg, dep_name = dep.split("/")
            parts.append(f"\n{SEPARATOR}\nMSG: {dep}\n" + append(dep_pkg, dep_name, depth - 1))
        return "".join(parts)

    return append(package, name, 50)


@functools.cache
def installed_type_hash(ros_type: str) -> str | None:
    """The RIHS01 type hash of ``ros_type`` from rosidl's ``<Type>.json``, or None."""
    package, name = _split_type(ros_type)
    try:
        path = _share_dir(package) / "msg" / f"{name}.json"
        doc = json.loads(path.read_text())
    except (DefinitionNotFoundError, OSError, ValueError):
        return None
    for entry in doc.get("type_hashes", ()):
        if entry.get("type_name") == f"{package}/msg/{name}":
            return entry.get("hash_string")
    return None


