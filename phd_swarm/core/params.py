"""Config value validators and named parameters with their default, description and range.

The ``expect_*`` functions are the one family of checks for values read from a config: node
parameters and options of system parts (:class:`ParamSpec`), the scenario
(:func:`phd_swarm.sim.scenario_dict.scenario_from_dict`), the system block
(:mod:`phd_swarm.core.system`), run configs (:mod:`phd_swarm.config`) and sweep specs
(:mod:`phd_swarm.config.sweep_spec`). Each takes the value and its key path, returns the value
converted (``float``, ``int``, a tuple for a list) or raises ValueError whose text starts
with the path::

    targets.speed: expected a number >= 0, got 'fast'

Callers put the source in front (``runs/a.yaml: targets.speed: ...``). Booleans are not
numbers here (YAML's ``true`` is no count), NaN is refused and infinities are unless
``allow_inf``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

#: Converts an item of a list: ``item(value, path)`` (an ``expect_*`` function).
Item = Callable[[Any, str], Any]


def _fail(path: str, msg: str) -> ValueError:
    return ValueError(f"{path}: {msg}" if path else msg)


def _num(x: float) -> str:
    """A bound as text: ``1`` for 1 and 1.0, ``0.01``, ``inf``."""
    if isinstance(x, numbers.Integral):
        return str(int(x))
    x = float(x)
    return str(int(x)) if x.is_integer() and abs(x) < 1e15 else repr(x)


def _range(low: float | None, high: float | None, strict: bool) -> str:
    """`` >= 0``, `` > 0``, `` <= 1`` or `` in [0, 1]`` (empty without bounds)."""
    if low is not None and high is not None:
        return f" in {'(' if strict else '['}{_num(low)}, {_num(high)}]"
    if low is not None:
        return f" {'>' if strict else '>='} {_num(low)}"
    if high is not None:
        return f" <= {_num(high)}"
    return ""


def _in_range(v: float, low: float | None, high: float | None, strict: bool) -> bool:
    above = low is None or (v > low if strict else v >= low)
    return above and (high is None or v <= high)


def expect_number(value: Any, path: str, low: float | None = None, high: float | None = None,
                  strict: bool = False, allow_inf: bool = False) -> float:
    """``value`` as a float: a real number (not a bool), not NaN, in the bounds.

    ``low <= value <= high``, or ``low < value`` with ``strict``; infinities only with
    ``allow_inf`` (and then still bounded by ``low`` / ``high``).
    """
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    finite = ok and (math.isfinite(value) or (allow_inf and math.isinf(value)))
    if not (finite and _in_range(float(value), low, high, strict)):
        noun = "a finite number" if ok and not finite and not allow_inf else "a number"
        raise _fail(path, f"expected {noun}{_range(low, high, strict)}, got {value!r}")
    return float(value)


def expect_int(value: Any, path: str, low: int | None = None,
               high: int | None = None) -> int:
    """``value`` as an int: an integral number (not a bool, not ``2.0``) in ``[low, high]``."""
    ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if not (ok and _in_range(int(value), low, high, False)):
        raise _fail(path, f"expected an integer{_range(low, high, False)}, got {value!r}")
    return int(value)


def expect_str(value: Any, path: str, choices: Sequence[str] | None = None,
               nonempty: bool = False) -> str:
    """``value``, a string; one of ``choices`` if given, not ``""`` with ``nonempty``."""
    if choices is not None:
        if not isinstance(value, str) or value not in choices:
            raise _fail(path, f"expected one of {list(choices)}, got {value!r}")
    elif not isinstance(value, str) or (nonempty and not value):
        raise _fail(path, f"expected a {'non-empty ' if nonempty else ''}string, "
                          f"got {value!r}")
    return value


def expect_bool(value: Any, path: str) -> bool:
    """``value``, a bool (``0`` and ``1`` are not)."""
    if not isinstance(value, bool):
        raise _fail(path, f"expected true or false, got {value!r}")
    return value


def expect_list(value: Any, path: str, item: Item | None = None, nonempty: bool = False,
                distinct: bool = False) -> tuple:
    """``value`` as a tuple: a list (a sequence, not a string or a mapping).

    ``item(value, f"{path}[i]")`` converts each entry; ``nonempty`` refuses ``[]``,
    ``distinct`` a repeated (converted) entry.
    """
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Sequence):
        raise _fail(path, f"expected a list, got {value!r}")
    if nonempty and not value:
        raise _fail(path, f"expected a non-empty list, got {value!r}")
    out = tuple(value) if item is None else tuple(item(v, f"{path}[{i}]")
                                                  for i, v in enumerate(value))
    if distinct and any(v in out[:i] for i, v in enumerate(out)):
        raise _fail(path, f"expected distinct values, got {list(value)}")
    return out


def expect_box(value: Any, path: str) -> tuple[float, float, float, float]:
    """``value`` as ``(xmin, ymin, xmax, ymax)``: four finite numbers, xmax > xmin, ymax > ymin.

    A list, a tuple or a 1-D array (a box computed in Python).
    """
    shape = "four numbers (xmin, ymin, xmax, ymax)"
    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Sequence) \
            or len(value) != 4:
        raise _fail(path, f"expected {shape}, got {value!r}")
    b = expect_list(value, path, item=expect_number)
    if not (b[2] > b[0] and b[3] > b[1]):
        raise _fail(path, f"expected {shape} with xmax > xmin and ymax > ymin, got {value!r}")
    return b  # type: ignore[return-value]


def expect_mapping(value: Any, path: str,
                   allowed: Sequence[str] | None = None) -> Mapping[str, Any]:
    """``value``, a mapping whose keys are among ``allowed`` (any keys if None).

    An unknown key is named by its own path (``targets.sped: unknown key; ...``).
    """
    if not isinstance(value, Mapping):
        raise _fail(path, f"expected a mapping, got {value!r}")
    if allowed is not None:
        unknown = sorted(str(k) for k in value if k not in allowed)
        if unknown:
            key = f"{path}.{unknown[0]}" if path else unknown[0]
            raise _fail(key, f"unknown key; expected one of {sorted(allowed)}")
    return value


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter or part option; its type is the type of ``default``.

    ``default`` is a bool, int, float or str. ``low``/``high`` bound numbers (inclusive),
    ``choices`` lists allowed strings.
    """

    name: str
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    read_only: bool = True

    def __post_init__(self) -> None:
        if type(self.default) not in (bool, int, float, str):
            raise TypeError(f"ParamSpec {self.name}: default must be a bool, int, float or "
                            f"str, got {self.default!r}")
        if self.choices and type(self.default) is not str:
            raise TypeError(f"ParamSpec {self.name}: choices need a str default")

    def check(self, value: Any, where: str = "") -> Any:
        """``value`` converted to the spec's type, or ValueError ``"{where}: {name}: ..."``."""
        path = f"{where}: {self.name}" if where else self.name
        kind = type(self.default)
        if kind is bool:
            return expect_bool(value, path)
        if kind is int:
            return expect_int(value, path, self.low, self.high)  # type: ignore[arg-type]
        if kind is float:
            return expect_number(value, path, self.low, self.high)
        return expect_str(value, path, choices=self.choices or None)
