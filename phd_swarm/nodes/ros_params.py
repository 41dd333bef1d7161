"""Declare a node's parameters from :mod:`phd_swarm.config.node_params` and the scenario.

Every parameter is declared with its description and range (``ros2 param describe`` shows
them) and is read-only unless its spec says otherwise; values are checked again by the spec
so that a bad value stops the node with a message naming the node and the parameter. The
scenario is declared as read-only ``scenario.*`` parameters (dynamic typing, so ``120`` and
``120.0`` are both accepted for a number) and validated by
:func:`phd_swarm.sim.scenario_dict.scenario_from_dict`.
"""

from __future__ import annotations

from functools import cache
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from phd_swarm.config import flatten, scenario_to_dict, unflatten
from phd_swarm.config.node_params import ParamSpec
from phd_swarm.core.registry import ROLES
from phd_swarm.core.system import DEFAULT_PARTS, SystemConfig
from phd_swarm.sim.presets import PRESETS
from phd_swarm.sim.scenario import Scenario
from phd_swarm.sim.scenario_dict import preset_name, scenario_from_dict


class ParameterError(ValueError):
    """A node parameter is missing, of the wrong type or out of range."""


def _descriptor(spec: ParamSpec) -> ParameterDescriptor:
    d = ParameterDescriptor(description=spec.description, read_only=spec.read_only)
    if spec.choices:
        d.additional_constraints = f"one of: {', '.join(spec.choices)}"
    if isinstance(spec.default, bool):
        return d
    if isinstance(spec.default, int) and spec.low is not None and spec.high is not None:
        d.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high),
                                        step=0)]
    elif isinstance(spec.default, float) and spec.low is not None and spec.high is not None:
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.low),
                                                     to_value=float(spec.high), step=0.0)]
    return d


def declare(node: Node, specs: tuple[ParamSpec, ...]) -> dict[str, Any]:
    """Declare ``specs`` on ``node`` and return their checked values by name.

    Raises
    ------
    ParameterError
        For a value of the wrong type, out of range or not among the choices; the message
        names the node and the parameter.
    """
    where = f"node {node.get_fully_qualified_name()}"
    out = {}
    for spec in specs:
        try:
            value = node.declare_parameter(spec.name, spec.default,
                                           _descriptor(spec)).value
        except Exception as exc:  # rclpy raises several types for type / range violations
            raise ParameterError(f"{where}: parameter {spec.name}: {exc}") from None
        try:
            out[spec.name] = spec.check(value, where)
        except ValueError as exc:
            raise ParameterError(str(exc)) from None
    return out


@cache
def _scenario_keys() -> dict[str, dict[str, Any]]:
    """Preset name -> its flattened scenario parameters."""
    return {name: flatten(scenario_to_dict(make())) for name, make in PRESETS.items()}


def declare_scenario(node: Node) -> Scenario:
    """Declare the read-only ``scenario.*`` parameters and build the scenario from them."""
    where = f"node {node.get_fully_qualified_name()} parameters scenario"
    desc = ParameterDescriptor(read_only=True, description=(
        f"Scenario preset ({', '.join(PRESETS)}); the other scenario.* parameters override "
        "it (docs/parameters.md)."))
    preset = node.declare_parameter("scenario.preset", "dames_static", desc).value
    try:
        preset = preset_name({"preset": preset})
    except ValueError as exc:
        raise ParameterError(f"{where}.{exc}") from None
    keys = _scenario_keys()
    names = sorted({k for flat in keys.values() for k in flat} - {"preset"})
    defaults = dict(keys[preset])
    values: dict[str, Any] = {"preset": preset}
    # The options depend on the parts chosen (and plugins may bring parts): read the
    # part names first, then declare the options of those parts.
    system = _declare_system(node, values)
    names = [n for n in names if not n.startswith("system.")]
    defaults.update({f"system.options.{k}": v for k, v in system.options})
    names += [f"system.options.{k}" for k, _ in system.options]
    for name in names:
        d = ParameterDescriptor(read_only=True, dynamic_typing=True,
                                description=f"Scenario field {name} (docs/parameters.md).")
        default = defaults.get(name)
        if default is None:
            p = node.declare_parameter(f"scenario.{name}", None, d)
        else:
            p = node.declare_parameter(f"scenario.{name}", default, d)
        if p.type_ != Parameter.Type.NOT_SET:
            values[name] = list(p.value) if isinstance(p.value, (list, tuple)) else p.value
    try:
        scenario = scenario_from_dict(unflatten(values), where)
    except ValueError as exc:
        raise ParameterError(str(exc)) from None
    refusal = ros_refusal(scenario.system)
    if refusal:
        raise ParameterError(f"{where}.system: {refusal}")
    return scenario


def ros_refusal(system: SystemConfig) -> str:
    """Why the ROS stack cannot run ``system``, or "" if it can.

    A sensor that identifies targets (``provides target_label``, e.g. ``disk_labelled``)
    gives each measurement a label, which ``phd_swarm_msgs/MeasurementSet`` cannot carry
    (nor ``RewardSet`` a reward member's): the labelled reading of Shirsat & Berman
    (``reward_union: label``) runs on the in-memory engines only, so the nodes refuse it
    rather than run the robots without the labels.
    """
    sensor = system.parts()["sensor"]
    if "target_label" not in sensor.provides:
        return ""
    return (f"sensor {sensor.name} labels its measurements, which the ROS messages do not "
            f"carry (MeasurementSet, RewardSet): the labelled reading (shirsat_gmphd "
            f"reward_union: label) runs on the in-memory engines only (scripts/sweep.sh)")


def _declare_system(node: Node, values: dict[str, Any]) -> SystemConfig:
    """Declare ``scenario.system.<role>`` and ``.plugins``; the system they name (no options).

    The values go into ``values`` (flattened scenario keys).
    """
    where = f"node {node.get_fully_qualified_name()} parameters scenario.system"
    for role in ROLES:
        d = ParameterDescriptor(read_only=True, description=(
            f"The system's {role} (registered name, docs/architecture.md); default "
            f"{DEFAULT_PARTS[role]}."))
        values[f"system.{role}"] = node.declare_parameter(f"scenario.system.{role}",
                                                          DEFAULT_PARTS[role], d).value
    d = ParameterDescriptor(read_only=True, dynamic_typing=True, description=(
        "Modules or .py files that register more system parts (docs/architecture.md)."))
    p = node.declare_parameter("scenario.system.plugins", None, d)
    if p.type_ != Parameter.Type.NOT_SET:
        values["system.plugins"] = list(p.value)
    try:
        return SystemConfig.from_dict({role: values[f"system.{role}"] for role in ROLES}
                                      | {"plugins": values.get("system.plugins", [])},
                                      "system")
    except ValueError as exc:
        raise ParameterError(f"{where}: {exc}") from None
