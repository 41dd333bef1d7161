"""Every function that turns bytes or files into our data, as a fuzz target.

A :class:`Target` feeds raw bytes to one decoder or loader, the way its input arrives: the
CDR a raw subscription hands a callback, a file a tool is given. The contract each one
keeps (docs/ros.md, "Bad input"): it returns, or it raises its own clear error
(:attr:`Target.expected`) whose text names the source when the source is a file; nothing
else escapes, and nothing hangs. :func:`exercise` checks one input against it and raises
:class:`Finding` otherwise.

Two drivers use the same targets: the default test suite with ``hypothesis``
(``test/tools/test_fuzz_targets.py``, a bounded budget per target) and the fuzz benchmark,
coverage-guided with ``atheris`` (``scripts/bench.sh fuzz --minutes N``,
:mod:`phd_swarm.tools.fuzz`). Each target brings valid seeds (:attr:`Target.seeds`) for
the drivers to mutate, so they reach the checks behind the framing.

The targets (:func:`targets`):

- ``cdr/<Type>``: :func:`phd_swarm.nodes.cdr.decode` of every message type of ours;
- ``inbox``, ``bundle``: the envelopes robots and observers take raw
  (:func:`phd_swarm.nodes.inbox.unpack_cdr`, :func:`phd_swarm.nodes.bundle.unpack_cdr`);
- ``scan``: the measurement set a robot takes raw (:func:`phd_swarm.nodes.convert.decode_scan`);
- ``wire/<exchange>/<kind>``: each exchange's decoding of each inbox kind into a core
  message (:attr:`phd_swarm.nodes.wire.Wire.decode`), on the grid of ``dames_static``;
- ``config``, ``sweep_spec``: the run config and sweep spec loaders, on a file;
- ``log``: the MCAP log reader (:func:`phd_swarm.logs.mcap_log.open_log`: metadata, every
  message decoded), on a file;
- ``evaluate``: :func:`phd_swarm.tools.run_log.load_run` and
  :func:`phd_swarm.tools.evaluate.evaluate` of a log file.
"""

from __future__ import annotations

import functools
import io
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
from rclpy.serialization import serialize_message
from rosidl_parser.definition import (
    AbstractNestedType,
    AbstractString,
    BasicType,
    NamespacedType,
)

from phd_swarm.config import load_run_config
from phd_swarm.config.sweep_spec import SpecError, load_spec
from phd_swarm.core.registry import lookup, names
from phd_swarm.logs.mcap_log import LogError, open_log
from phd_swarm.nodes import bundle, cdr, convert, inbox
from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm.nodes.wire import wire_for

ROOT = Path(__file__).resolve().parents[2]

#: The message types of ours a node or tool decodes from bytes.
MESSAGE_TYPES = ("CellPolygon", "DensityGrid", "EtaPartial", "EtaTotal", "GaussianMixture",
                 "InboxMessage", "MeasurementSet", "MessageBundle", "ParticleTransfer",
                 "RewardSet", "RobotState", "RobotStatus", "SatState", "TargetSet",
                 "TeamMetrics", "TeamState", "TrackSet")

#: ``max_measurements`` of the wire and scan targets (the robot's default).
MAX_MEASUREMENTS = 200


class Finding(Exception):
    """An input a target does not survive.

    An exception other than the target's clear error, or an error that does not name its file.
    """


@dataclass(frozen=True)
class Target:
    """One decoder or loader, fed bytes.

    Attributes
    ----------
    name : str
        ``family/detail``, e.g. ``cdr/RobotState``.
    run : callable
        ``run(data)``: decodes or loads the bytes ``data``.
    expected : tuple of exception types
        The clear errors ``run`` may raise.
    seeds : callable
        ``seeds()`` -> valid inputs to mutate (computed once, cached).
    source : callable, optional
        ``source()`` -> the text an expected error must hold (a file's path), or None.
    """

    name: str
    run: Callable[[bytes], Any]
    expected: tuple[type[BaseException], ...]
    seeds: Callable[[], list[bytes]] = field(repr=False)
    source: Callable[[], str | None] = field(default=lambda: None, repr=False)


def exercise(target: Target, data: bytes) -> None:
    """Feed ``data`` to ``target``; :class:`Finding` unless it keeps its contract."""
    try:
        target.run(data)
    except target.expected as exc:
        where = target.source()
        if where is not None and where not in str(exc):
            raise Finding(f"{target.name}: the error does not name {where}: "
                          f"{type(exc).__name__}: {exc}") from exc
    except Exception as exc:  # anything else is what the fuzzing is looking for
        raise Finding(f"{target.name}: {type(exc).__name__}: {exc}") from exc


# ------------------------------------------------------------------------- messages
def _msg_type(name: str) -> type:
    import phd_swarm_msgs.msg as msgs

    return getattr(msgs, name)


def _filled_value(t: Any) -> Any:
    """A small valid value of rosidl type ``t``: 3 elements per sequence, values in (0, 1]."""
    if isinstance(t, AbstractNestedType):
        inner = t.value_type
        n = getattr(t, "size", None) or 3
        if isinstance(inner, BasicType) and inner.typename in ("float", "double"):
            return [0.25 * (i + 1) for i in range(n)]
        if isinstance(inner, BasicType):
            return [inner.typename == "boolean" or i + 1 for i in range(n)]
        return [_filled_value(inner) for _ in range(n)]
    if isinstance(t, AbstractString):
        return "map"
    if isinstance(t, BasicType):
        if t.typename == "boolean":
            return True
        return 0.5 if t.typename in ("float", "double") else 1
    if isinstance(t, NamespacedType):
        return filled(cdr._message_class(t))
    raise NotImplementedError(f"no filled value for {t}")


def filled(typ: type) -> Any:
    """An instance of ROS message type ``typ`` with every field set (see :func:`_filled_value`)."""
    msg = typ()
    for name, t in zip(typ.get_fields_and_field_types(), typ.SLOT_TYPES, strict=True):
        setattr(msg, name, _filled_value(t))
    return msg


def _message_seeds(typ: type) -> list[bytes]:
    return [serialize_message(typ()), serialize_message(filled(typ))]


def _cdr_target(name: str) -> Target:
    typ = _msg_type(name)
    return Target(f"cdr/{name}", functools.partial(cdr.decode, typ), (cdr.CdrError,),
                  functools.cache(functools.partial(_message_seeds, typ)))


@functools.cache
def _wires() -> dict[str, Any]:
    return {n: wire_for(lookup("exchange", n)) for n in names("exchange")}


@functools.cache
def _grid() -> Any:
    return load_run_config(ROOT / "config" / "dames_static.yaml").scenario.grid


def _wire_decode(exchange: str, kind: str, data: bytes) -> Any:
    return _wires()[exchange].decode(kind, data, _grid(), MAX_MEASUREMENTS)


def _wire_target(exchange: str, kind: str) -> Target:
    typ = _wires()[exchange].types[kind]
    return Target(f"wire/{exchange}/{kind}", functools.partial(_wire_decode, exchange, kind),
                  (InvalidMessage,), functools.cache(functools.partial(_message_seeds, typ)))


def _all_kinds() -> set[str]:
    return {k for w in _wires().values() for k in w.types}


def _inbox_seeds() -> list[bytes]:
    wire = max(_wires().values(), key=lambda w: len(w.types))  # the most kinds
    pieces = [(k, serialize_message(filled(t))) for k, t in wire.types.items()]
    return [inbox.pack_cdr(2, pieces[:1]), inbox.pack_cdr(0, pieces), inbox.pack_cdr(1, [])]


def _bundle_seeds() -> list[bytes]:
    state = serialize_message(filled(_msg_type("RobotStatus")))
    est = serialize_message(filled(_msg_type("GaussianMixture")))
    return [bundle.pack_cdr(1, 5, "map", 3, 2, [("/robot_3/status", state),
                                                ("/robot_3/estimates", est)]),
            bundle.pack_cdr(0, 0, "map", bundle.WORLD, 0, [])]


# ---------------------------------------------------------------------------- files
class _FileInput:
    """Bytes written to one file in a private temporary directory, for the file targets.

    The directory is empty but for the file, so what a fuzzed config names beside itself
    (plugins, a base spec) does not exist.
    """

    def __init__(self, name: str) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix="phd_swarm_fuzz_")
        self.path = Path(self._dir.name) / name

    def write(self, data: bytes) -> Path:
        self.path.write_bytes(data)
        return self.path


@functools.cache
def _file(name: str) -> _FileInput:
    return _FileInput(name)


def _load_config(data: bytes) -> Any:
    return load_run_config(_file("fuzz_config.yaml").write(data))


def _load_sweep_spec(data: bytes) -> Any:
    return load_spec(_file("fuzz_spec.yaml").write(data), quick=True)


def _read_log(data: bytes) -> None:
    with open_log(_file("fuzz_log.mcap").write(data)) as log:
        log.metadata()
        log.info()
        for _ in log.messages():
            pass


def _evaluate_log(data: bytes) -> None:
    from phd_swarm.tools.evaluate import evaluate
    from phd_swarm.tools.run_log import load_run

    evaluate(load_run(_file("fuzz_run.mcap").write(data)))


def _config_seeds() -> list[bytes]:
    return [(ROOT / "config" / n).read_bytes() for n in
            ("dames_static.yaml", "sung_static.yaml", "shirsat_small.yaml")]


def _spec_seeds() -> list[bytes]:
    return [(ROOT / "config" / "sweeps" / n).read_bytes() for n in
            ("dames_static.yaml", "shirsat_small.yaml")]


#: The recorded log the log seeds are cut from (a dames_static run, 5 robots).
SEED_LOG = ROOT / "test" / "data" / "logs_before_issue35" / "dames.mcap"


@functools.cache
def _log_seeds() -> list[bytes]:
    """The first steps of :data:`SEED_LOG` (to its third clock), uncompressed.

    Small, so each run is quick, and a mutation lands in records rather than in compressed
    chunks. Copied record by record with the mcap library, each channel with the schema
    recorded (an old log's definitions, not the installed ones).
    """
    out = io.BytesIO()
    writer = Writer(out, chunk_size=16_384, compression=CompressionType.NONE)
    with open(SEED_LOG, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        writer.start(header.profile, header.library)
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, dict(record.metadata))
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        clocks = 0
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            clocks += channel.topic == "/clock"
            if clocks > 3:
                break
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                            schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id],
                    dict(channel.metadata))
            writer.add_message(channels[channel.id], message.log_time, message.data,
                               message.publish_time, message.sequence)
    writer.finish()
    return [out.getvalue()]


@functools.cache
def targets() -> dict[str, Target]:
    """Every target, by name."""
    found = [_cdr_target(n) for n in MESSAGE_TYPES]
    found += [
        Target("inbox", lambda d: inbox.unpack_cdr(d, _all_kinds()), (InvalidMessage,),
               functools.cache(_inbox_seeds)),
        Target("bundle", bundle.unpack_cdr, (InvalidMessage,), functools.cache(_bundle_seeds)),
        Target("scan", lambda d: convert.decode_scan(d, MAX_MEASUREMENTS), (InvalidMessage,),
               functools.cache(functools.partial(_message_seeds,
                                                 _msg_type("MeasurementSet")))),
    ]
    found += [_wire_target(e, k) for e, w in sorted(_wires().items()) for k in w.types]
    found += [
        Target("config", _load_config, (ValueError,), functools.cache(_config_seeds),
               lambda: str(_file("fuzz_config.yaml").path)),
        Target("sweep_spec", _load_sweep_spec, (SpecError,), functools.cache(_spec_seeds),
               lambda: str(_file("fuzz_spec.yaml").path)),
        Target("log", _read_log, (LogError,), _log_seeds,
               lambda: str(_file("fuzz_log.mcap").path)),
        Target("evaluate", _evaluate_log, (LogError,), _log_seeds,
               lambda: str(_file("fuzz_run.mcap").path)),
    ]
    return {t.name: t for t in found}
