"""A named parameter with its default, description and allowed values (rclpy-free).

One :class:`ParamSpec` describes a node parameter (:mod:`phd_swarm.config.node_params`) or an
option of a system part (:mod:`phd_swarm.core.registry`); its :meth:`ParamSpec.check` is the
one validator both use, so a bad value is refused with the same message wherever it comes
from (a config file, a sweep spec, a ROS parameter).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter; its type is the type of ``default``.

    ``low``/``high`` bound numbers (inclusive), ``choices`` lists allowed strings.
    """

    name: str
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    read_only: bool = True

    def check(self, value: Any, where: str) -> Any:
        """Return ``value`` converted to the spec's type, or raise ValueError naming ``where``."""
        kind = type(self.default)
        if kind is bool:
            ok = isinstance(value, bool)
        elif kind is int:
            ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
        elif kind is float:
            ok = (isinstance(value, numbers.Real) and not isinstance(value, bool)
                  and math.isfinite(float(value)))
        else:
            ok = isinstance(value, kind)
        if not ok:
            raise ValueError(f"{where}: {self.name}: expected {kind.__name__}, got {value!r}")
        value = kind(value)
        if self.low is not None and value < self.low:
            raise ValueError(f"{where}: {self.name}: must be >= {self.low}, got {value!r}")
        if self.high is not None and value > self.high:
            raise ValueError(f"{where}: {self.name}: must be <= {self.high}, got {value!r}")
        if self.choices and value not in self.choices:
            raise ValueError(f"{where}: {self.name}: must be one of {list(self.choices)}, "
                             f"got {value!r}")
        return value
