"""Run configuration files: a ROS 2 parameter file holding the scenario and every node's block.

A config file (``config/*.yaml``) is a standard ROS 2 parameter file::

    /**:                      # every node
      ros__parameters:
        use_sim_time: true
        world_frame_id: map
        scenario:             # phd_swarm.sim.scenario_dict.scenario_from_dict: preset + overrides
          preset: dames_static
          robots: 20
          targets: {count: 30}
    world:     {ros__parameters: {mode: lockstep}}
    /**/robot: {ros__parameters: {controller: phd}}
    monitor:   {ros__parameters: {}}
    recorder:  {ros__parameters: {}}

:func:`load_run_config` validates it (scenario and node parameters against
:mod:`phd_swarm.config.node_params`) and :meth:`RunConfig.params_document` writes the
*resolved* file that the nodes are started with: every scenario field spelled out, so the
nodes, the MCAP metadata and ``ros2 param get`` all show the same numbers. In a parameter
file the scenario becomes dotted parameters (``scenario.targets.count``); lists of boxes
(``targets.clusters``) are flattened to 4k numbers because ROS parameters hold flat lists.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from phd_swarm.config.node_params import NODES, SHARED, ParamSpec
from phd_swarm.core.params import expect_mapping
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.presets import preset_of_kind
from phd_swarm.sim.scenario import Scenario
from phd_swarm.sim.scenario_dict import scenario_from_dict

#: Config-file keys of the node blocks, and the node kind each configures.
NODE_KEYS = {"world": "world", "/**/robot": "robot", "monitor": "monitor",
             "recorder": "recorder"}
SHARED_KEY = "/**"

#: World ``step_timeout`` >= this many robot ``tick_period`` s (:meth:`RunConfig.checked`).
LIVENESS_PERIODS = 3
_SHARED_EXTRA = ("use_sim_time", "scenario")


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """Every field of ``scenario`` as a nested mapping of plain values.

    ``scenario_from_dict(scenario_to_dict(s)) == s``: every field is spelled out over the
    preset of the same target kind (fields left unset, None or empty, are omitted and come
    from that preset).
    """
    def plain(value: Any) -> Any:
        if isinstance(value, SystemConfig):
            return value.to_dict()
        if dataclasses.is_dataclass(value):
            return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
        if isinstance(value, tuple):
            return [plain(v) for v in value]
        return value

    out: dict[str, Any] = {"preset": preset_of_kind()[scenario.targets.kind]}
    for f in dataclasses.fields(scenario):
        value = plain(getattr(scenario, f.name))
        if value is None:  # an optional field left unset (robot_start_grid)
            continue
        if isinstance(value, dict):
            value = {k: v for k, v in value.items() if v is not None and v != []}
        out[f.name] = value
    return out


def flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested mapping -> ``{"a.b.c": value}`` with ROS-compatible (flat list) values."""
    out: dict[str, Any] = {}
    for key, value in d.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            out.update(flatten(value, name + "."))
        elif isinstance(value, list) and value and isinstance(value[0], list):
            out[name] = [float(x) for row in value for x in row]
        else:
            out[name] = value
    return out


#: Flattened scenario keys whose value is a list of 4-number boxes.
BOX_LISTS = ("targets.clusters",)


def unflatten(flat: Mapping[str, Any], regroup: bool = True) -> dict[str, Any]:
    """Inverse of :func:`flatten` for scenario parameters (boxes regrouped by four).

    With ``regroup=False`` the lists stay flat (the nesting of a ROS parameter file).
    """
    out: dict[str, Any] = {}
    for name, value in flat.items():
        if regroup and name in BOX_LISTS and isinstance(value, (list, tuple)):
            if len(value) % 4:
                raise ValueError(f"{name}: expected groups of four numbers (xmin, ymin, xmax, "
                                 f"ymax), got {len(value)} numbers")
            value = [list(value[i:i + 4]) for i in range(0, len(value), 4)]
        elif isinstance(value, tuple):
            value = list(value)
        node = out
        *parents, leaf = name.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = value
    return out


@dataclass
class RunConfig:
    """A validated run configuration.

    Attributes
    ----------
    scenario : Scenario
        The resolved scenario.
    shared : dict
        ``/**`` parameters other than the scenario (e.g. ``world_frame_id``).
    nodes : dict
        Node kind (``world``, ``robot``, ``monitor``, ``recorder``) -> its parameters.
    source : str
        Where the config came from (for messages and metadata).
    moved : tuple of str
        Robot parameters of an older config read as ``scenario.system`` keys
        (:data:`LEGACY_ROBOT_KEYS`).
    """

    scenario: Scenario
    shared: dict[str, Any] = field(default_factory=dict)
    nodes: dict[str, dict[str, Any]] = field(default_factory=dict)
    source: str = "<config>"
    moved: tuple[str, ...] = ()

    def with_overrides(self, scenario: Scenario | None = None,
                       **node_params: Mapping[str, Any]) -> RunConfig:
        """A copy with another scenario and/or some node parameters replaced (validated)."""
        nodes = {k: dict(v) for k, v in self.nodes.items()}
        for kind, params in node_params.items():
            nodes.setdefault(kind, {}).update(_check_params(params, kind, NODES[kind]))
        return RunConfig(self.scenario if scenario is None else scenario, dict(self.shared),
                         nodes, self.source).checked()

    def checked(self) -> RunConfig:
        """Return the config after the checks that involve several nodes (ValueError if not).

        The world's lockstep deadline and the robots' liveness signal come from the same
        numbers: a robot that works on a step reports that it is alive once per
        ``tick_period``, and the world declares a robot dead after ``step_timeout`` without
        any word from it, so the deadline must span several periods.
        """
        tick = float(self.param("robot", "tick_period"))
        timeout = float(self.param("world", "step_timeout"))
        if timeout < LIVENESS_PERIODS * tick:
            raise ValueError(f"{self.source}: world.step_timeout ({timeout:g} s) must be at "
                             f"least {LIVENESS_PERIODS} x robot.tick_period ({tick:g} s): a "
                             "robot working on a step reports that it is alive once per "
                             "tick_period")
        return self

    def params_document(self) -> dict[str, Any]:
        """The resolved ROS 2 parameter file as a mapping (write it with :func:`yaml.dump`)."""
        scenario = unflatten(flatten(scenario_to_dict(self.scenario)), regroup=False)
        shared = {"use_sim_time": True, **self.shared, "scenario": scenario}
        doc: dict[str, Any] = {SHARED_KEY: {"ros__parameters": shared}}
        for key, kind in NODE_KEYS.items():
            doc[key] = {"ros__parameters": dict(self.nodes.get(kind, {}))}
        return doc

    def write_params(self, path: str | Path) -> Path:
        """Write :meth:`params_document` to ``path``; returns the path."""
        path = Path(path)
        path.write_text(dump_params(self.params_document()))
        return path

    def param(self, kind: str, name: str) -> Any:
        """Value of node ``kind``'s parameter ``name`` (the spec default if not set)."""
        if name in self.nodes.get(kind, {}):
            return self.nodes[kind][name]
        for spec in NODES[kind] + SHARED:
            if spec.name == name:
                return self.shared.get(name, spec.default)
        raise KeyError(f"{kind} has no parameter {name!r}")


#: Plain scalars that ROS's parameter-file parser (rcl_yaml_param_parser, YAML 1.1 booleans)
#: reads as booleans although PyYAML writes them unquoted as strings.
_ROS_BOOLEAN_WORDS = frozenset({"y", "n", "yes", "no", "on", "off", "true", "false"})


class _ParamsDumper(yaml.SafeDumper):
    """A SafeDumper that quotes the strings ROS would read as booleans (e.g. the axis 'y')."""


def _represent_str(dumper: yaml.SafeDumper, value: str) -> yaml.ScalarNode:
    style = "'" if value.lower() in _ROS_BOOLEAN_WORDS else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


_ParamsDumper.add_representer(str, _represent_str)


def dump_params(document: Mapping[str, Any]) -> str:
    """A ROS parameter file's text: YAML whose strings ROS reads back as strings."""
    return yaml.dump(document, Dumper=_ParamsDumper, sort_keys=False)


def _check_block(block: Any, where: str, specs: tuple[ParamSpec, ...],
                 extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """A node's ``{ros__parameters: {...}}`` block: its parameters, checked by their specs.

    The keys ``extra`` are allowed and left out of the result (the scenario of ``/**``).
    """
    if not isinstance(block, Mapping) or set(block) != {"ros__parameters"}:
        raise ValueError(f"{where}: expected a mapping with the single key ros__parameters")
    params = expect_mapping(block["ros__parameters"] or {}, f"{where}.ros__parameters")
    return _check_params(params, where, specs, extra)


def _check_params(params: Mapping[str, Any], where: str, specs: tuple[ParamSpec, ...],
                  extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """Name -> value checked by its spec; errors start with ``where: name``."""
    by_name = {s.name: s for s in specs}
    try:
        expect_mapping(params, "", [*by_name, *extra])
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    return {name: by_name[name].check(value, where) for name, value in params.items()
            if name not in extra}


def run_config_from_dict(doc: Any, where: str = "config",
                         base_dir: str | Path | None = None) -> RunConfig:
    """Validate a parsed config document (see the module docstring).

    ``base_dir`` is where relative plugin files are taken from (the config file's
    directory).
    """
    if not isinstance(doc, Mapping):
        raise ValueError(f"{where}: expected a mapping at the top level, got {doc!r}")
    unknown = sorted(set(doc) - {SHARED_KEY, *NODE_KEYS})
    if unknown:
        raise ValueError(f"{where}: unknown block {unknown[0]!r}; expected some of "
                         f"{[SHARED_KEY, *NODE_KEYS]}")
    if SHARED_KEY not in doc:
        raise ValueError(f"{where}: missing the {SHARED_KEY!r} block with the scenario")
    shared = _check_block(doc[SHARED_KEY], f"{where}: {SHARED_KEY}", SHARED, _SHARED_EXTRA)
    raw = doc[SHARED_KEY]["ros__parameters"].get("scenario")
    if raw is None:
        raise ValueError(f"{where}: {SHARED_KEY}: missing ros__parameters.scenario")
    moved: tuple[str, ...] = ()
    if isinstance(raw, Mapping):
        flat = flatten(raw)
        raw = unflatten({k: v for k, v in flat.items()})
        doc, raw, moved = _moved_to_system(doc, raw)
    scenario = scenario_from_dict(raw, f"{where}: scenario", base_dir)
    nodes = {kind: _check_block(doc[key], f"{where}: {key}", NODES[kind])
             for key, kind in NODE_KEYS.items() if key in doc}
    return RunConfig(scenario, shared, nodes, where, moved).checked()


#: Robot parameters of older configs (and the logs written with them) that are now
#: ``scenario.system`` keys: the controller and its options.
LEGACY_ROBOT_KEYS = {"controller": "controller", "rho_max": "options.rho_max",
                     "cumulative_mode": "options.cumulative_mode"}


def _moved_to_system(doc: Mapping[str, Any], scenario: dict[str, Any]
                     ) -> tuple[Mapping[str, Any], dict[str, Any], tuple[str, ...]]:
    """Read an older config whose robots set the controller and its options.

    Robot ``controller``, ``rho_max`` and ``cumulative_mode`` become
    ``scenario.system.controller`` and ``.options`` (docs/decisions.md). Options the
    controller does not take (``rho_max`` of ``phd``) are dropped, as the robot ignored
    them. A config that sets both places keeps ``scenario.system``.

    Returns
    -------
    doc, scenario : the document without those robot parameters, the scenario with them
    moved : tuple of str, the legacy keys found (empty for a current config)
    """
    block = doc.get("/**/robot")
    params = block.get("ros__parameters") if isinstance(block, Mapping) else None
    moved = tuple(sorted(set(LEGACY_ROBOT_KEYS) & set(params or {}))) \
        if isinstance(params, Mapping) else ()
    if not moved:
        return doc, scenario, ()
    system = dict(scenario.get("system") or {})
    options = dict(system.get("options") or {})
    controller = system.setdefault("controller", params.get("controller", "phd"))
    from phd_swarm.core.registry import RegistryError, lookup

    try:
        taken = {spec.name for spec in lookup("controller", str(controller)).options}
    except RegistryError:
        taken = set()
    for key in ("rho_max", "cumulative_mode"):
        if key in params and key in taken:
            options.setdefault(key, params[key])
    if options:
        system["options"] = options
    robot = {k: v for k, v in params.items() if k not in LEGACY_ROBOT_KEYS}
    return ({**doc, "/**/robot": {"ros__parameters": robot}},
            {**scenario, "system": system}, moved)


def read_yaml(path: str | Path, what: str = "file") -> Any:
    """Parse the YAML file ``path``; ValueError naming the file if unreadable or invalid."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the {what}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: the {what} is not UTF-8 text (byte {exc.start})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: not valid YAML: {exc}") from None


def load_run_config(path: str | Path) -> RunConfig:
    """Read and validate a config file; errors name the file and the key."""
    return run_config_from_dict(read_yaml(path, "config file"), str(path), Path(path).parent)
